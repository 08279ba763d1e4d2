"""The segmented rebuild of a batch's large packings (granwave.gpu.batch_rebuild) in numba's CUDA
simulator: run by tests/test_gpu_batch_rebuild.py as ``python tests/gpu_batch_rebuild_checks.py``
with ``NUMBA_ENABLE_CUDASIM=1`` (on a real GPU it runs unchanged); prints one JSON object.

The packings are small dense gases made "large" by a threshold of 0 grains (``small_rebuild``):
every one is rebuilt by the segmented rebuild, whatever its size.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from granwave.gpu import checks as GC

#: (seed, grains, room, rebuild_every, steps) per packing: three sizes, runs of three lengths; one
#: with its pair arrays cut to its first list (its second rebuild in the batch finds more pairs:
#: status 2, room made, redone); one whose rebuild test runs every 3rd step (masked on the steps
#: between, while another packing rebuilds).
SETUPS = ((0, 8, None, 1, 1), (7, 10, 0, 1, 2), (2, 12, None, 3, 3))


def gas(cls, seed: int, grains: int, room=None, every: int = 1, width: int = 4, height: int = 3, check: int = 0):
    """A dense frictional 2D gas in a ``width`` x ``height`` box (granwave.gpu.checks' gas in a
    smaller box, larger grains: fewer cells, cheaper scans in the simulator), every packing a "large" one
    (``small_rebuild`` 0: the multi-kernel rebuild alone, the segmented one in a batch), its
    list due at the first step (reference positions moved by the skin) and one grain fast enough
    (|v| dt > skin / 4) that a list is due at every step of the rebuild test; ``check``: steps
    between convergence checks (0: none)."""
    rng = np.random.default_rng(seed)
    axes = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5, indexing="ij")
    pos = np.stack([a.ravel() for a in axes], axis=1)
    pos = pos[rng.permutation(len(pos))[:grains]] + rng.uniform(-0.1, 0.1, (grains, 2))
    vel = rng.normal(0.0, 1.0, pos.shape)
    dt, skin = 4e-3, 0.2
    vel[0] = [0.3 * skin / dt, 0.0]
    e = cls(pos, rng.uniform(0.4, 0.48, grains), [float(width)], float(height), friction=0.5, damping=0.3, dt=dt,
            skin=skin, velocity=vel, angular_velocity=rng.normal(0.0, 1.0, (grains, 1)), check_every=check)
    e.fpar.v_max = float(np.max(np.linalg.norm(vel, axis=1)))
    e.pos0 = e.pos0 - skin
    e.small_rebuild = 0
    e.rebuild_every = every
    if room is not None:
        m = e.n_pairs
        for name in ("pair_i", "pair_j", "pair_ft", "pair_ov"):
            setattr(e, name, getattr(e, name)[:max(m, room)].copy())
    return e


def same_as_alone() -> dict:
    """The packings of :data:`SETUPS` advanced together (convergence checks every 2 steps, the
    batch's in one launch) against each run alone by the GPU engine's multi-kernel rebuild:
    state, reference positions, pair list, histories, time step, steps, rebuilds and rooms made
    compared bytewise."""
    from granwave.gpu.batch import Ensemble
    from granwave.gpu.dem import GpuEngine

    def job(cls, setup):
        def run():
            e = gas(cls, *setup[:4], check=2)  # checks every 2 steps: the batch's measures in one launch
            e.run(setup[4])
            return e
        return run

    ensemble = Ensemble()
    together = ensemble.run([job(ensemble.member_class(), s) for s in SETUPS])
    out = {"launches_per_rebuild": {str(k): v for k, v in ensemble.launches_per_rebuild.items()},
           "small_rebuild_launches": ensemble.small_rebuild_launches, "measures": ensemble.measures}
    for setup, (ok, b) in zip(SETUPS, together):
        if not ok:
            raise b
        a = job(GpuEngine, setup)()
        m = a.n_pairs
        key = f"seed{setup[0]}"
        out[f"grains_{key}"] = len(b.radius)
        out[f"steps_{key}"] = b.steps
        out[f"rebuilds_{key}"] = b.rebuilds
        out[f"room_made_{key}"] = b.room_made
        out[f"room_made_alone_{key}"] = a.room_made
        out[f"same_{key}"] = bool(
            b.steps == a.steps and b.rebuilds == a.rebuilds and b.n_pairs == m and b.room_made == a.room_made
            and b.fpar.tobytes() == a.fpar.tobytes() and b.out.tobytes() == a.out.tobytes()
            and all(getattr(b, s).tobytes() == getattr(a, s).tobytes() for s in (*GC.STATE, *GC.WALLS, "pos0"))
            and all(getattr(b, s)[:m].tobytes() == getattr(a, s)[:m].tobytes()
                    for s in ("pair_i", "pair_j", "pair_ft", "pair_ov")))
    return out


def launches(sizes=(1, 3), steps: int = 1) -> dict:
    """Batches of B gases (B in ``sizes``, the packings of :func:`gas`, 8 grains), each list due
    at the first step: the launches of each step's rebuild."""
    from granwave.gpu.batch import Ensemble
    from granwave.gpu.batch_rebuild import LAUNCHES

    out = {"per_rebuild": LAUNCHES}
    for b in sizes:
        def job(cls, seed):
            def run():
                e = gas(cls, seed, 8)
                e.run(steps)
                return e
            return run

        ensemble = Ensemble()
        done = ensemble.run([job(ensemble.member_class(), s) for s in range(b)])
        for ok, e in done:
            if not ok:
                raise e
        out[f"B{b}"] = {"launches_per_rebuild": {str(k): v for k, v in ensemble.launches_per_rebuild.items()},
                        "rebuilds": [e.rebuilds for _, e in done], "launches": ensemble.rebuild_launches}
    return out


CHECKS = {"same_as_alone": same_as_alone, "launches": launches}

if __name__ == "__main__":
    names = sys.argv[1:] or list(CHECKS)
    print(json.dumps({name: CHECKS[name]() for name in names}, default=lambda x: x.item()))
