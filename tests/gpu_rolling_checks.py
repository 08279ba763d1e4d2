"""Rolling resistance (``rolling sds``) on the GPU engines against the CPU engine, small enough for
numba's CUDA simulator: run by tests/test_gpu_rolling.py as ``python tests/gpu_rolling_checks.py``
with ``NUMBA_ENABLE_CUDASIM=1`` (on a real GPU it runs unchanged); prints one JSON object.

Built on granwave.gpu.checks' dense gas and batch runs; kept beside the tests because it names the
sub-model, which no module of granwave outside granwave/contact_models may
(tests/test_contact_registry.py).
"""

from __future__ import annotations

import json
import math

import numpy as np

from granwave import contact as C
from granwave.contact_models import _dispatch as CD
from granwave.dem import kernels as K
from granwave.dem.integrator import Engine
from granwave.gpu import checks as GC

#: The sub-model (engine units): a spring stiff enough and a cap low enough that contacts load
#: the spring and reach the slider within a few tens of steps of the dense gas.
ROLLING = dict(rolling="sds", rolling_stiffness=0.05, rolling_damping=0.01, rolling_friction=0.1)
#: Larger grains than the other checks' gases (radii 0.42-0.5), so that contacts last.
RADII = (0.42, 0.5)
#: (seed, grains) per dimension: in 2D ~6 touching pairs a step, wall contacts, and a later list
#: longer than the first (cut pair arrays must grow); in 3D ~4 and wall contacts.
GASES = {2: (3, 20), 3: (1, 24)}


def _host_rebuilt() -> type:
    """A GpuEngine with the first version's host rebuild (``device_rebuild`` off, as the pulse
    runs it)."""
    from granwave.gpu.dem import GpuEngine

    return type("HostRebuiltGpuEngine", (GpuEngine,), {"device_rebuild": False})


def _at_cap(engine, values: dict) -> int:
    """Touching pairs of ``engine`` whose rolling spring k_r |xi| stands at the slider's cap
    mu_r F_n (to 1e-9 of it; meaningful without the rolling dashpot, whose force shares the cap)."""
    law, e_pair, d = K.law_of(engine.fpar), C.effective_young(False), engine.dim
    count = 0
    for p in range(engine.n_pairs):
        delta = engine.pair_ov[p]
        if delta > 0.0:
            ri, rj = engine.radius[engine.pair_i[p]], engine.radius[engine.pair_j[p]]
            r12 = C.effective_radius(1.0 / ri, 1.0 / rj)
            fcrit = values["rolling_friction"] * CD.law_force(law, delta, math.sqrt(r12), e_pair)
            spring = values["rolling_stiffness"] * float(np.linalg.norm(engine.pair_ft[p, d:]))
            count += abs(spring - fcrit) <= 1e-9 * fcrit
    return count


def _same(cpu, g, key: str) -> dict:
    """Bitwise comparisons of GPU engine ``g`` with ``cpu`` after the same run."""
    m = cpu.n_pairs
    return {
        f"same_pairs_{key}": bool(g.n_pairs == m and np.array_equal(cpu.pair_i[:m], g.pair_i[:m])
                                  and np.array_equal(cpu.pair_j[:m], g.pair_j[:m])),
        f"same_history_{key}": bool(g.n_pairs == m and g.pair_ft.shape[1] == cpu.pair_ft.shape[1]
                                    and cpu.pair_ft[:m].tobytes() == g.pair_ft[:m].tobytes()
                                    and cpu.pair_ov[:m].tobytes() == g.pair_ov[:m].tobytes()),
        f"same_walls_{key}": all(getattr(cpu, s).tobytes() == getattr(g, s).tobytes() for s in GC.WALLS),
        f"same_state_{key}": all(getattr(cpu, s).tobytes() == getattr(g, s).tobytes() for s in GC.STATE),
        f"same_counters_{key}": bool((g.steps, g.rebuilds, g.n_pairs) == (cpu.steps, cpu.rebuilds, m)),
        f"state_abs_{key}": max(float(np.max(np.abs(getattr(cpu, s) - getattr(g, s)), initial=0.0))
                                for s in GC.STATE),
        f"room_made_{key}": g.room_made,
    }


def rolling(steps: int = 24, steps_3d: int = 12) -> dict:
    """The dense gas of granwave.gpu.checks with the rolling sub-model (:data:`GASES`), fixed
    walls, on the GPU engine and the CPU engine, in 2D (rolling dashpot on) and 3D (off): state,
    pair list with every history column (tangential, then rolling), wall histories, steps,
    rebuilds and pairs compared bitwise (the one-block device rebuild; :func:`rolling_batch` runs
    the multi-kernel one). In 2D also with the pair arrays cut so that the device asks for room
    (``_room``) and with the host rebuild (``_host``). How much the couple takes part, over the
    CPU's steps: touching pairs and wall contacts summed over steps, the largest |xi| seen on each,
    pair contact steps at the slider's cap (3D, :func:`_at_cap`), and how far the spins end from
    the same run without rolling (``moved``)."""
    from granwave.gpu.dem import GpuEngine

    out = {}
    for dim, k in ((2, steps), (3, steps_3d)):
        values = dict(ROLLING, rolling_damping=ROLLING["rolling_damping"] if dim == 2 else 0.0)
        seed, grains = GASES[dim]
        gas = dict(seed=seed, grains=grains, radii=RADII)
        cpu = GC._gas_engine(Engine, dim, **gas, **values)
        seen = dict(pair_contact_steps=0, wall_contact_steps=0, rolling_pair_max=0.0, rolling_wall_max=0.0,
                    at_cap=0)
        for _ in range(k):  # step by step, to see the couples at work (the same bits as run(k))
            cpu.run(1)
            m = cpu.n_pairs
            seen["pair_contact_steps"] += int(np.count_nonzero(cpu.pair_ov[:m] > 0.0))
            seen["wall_contact_steps"] += int(np.count_nonzero(cpu.wall_ov > 0.0))
            seen["rolling_pair_max"] = max(seen["rolling_pair_max"],
                                           float(np.max(np.abs(cpu.pair_ft[:m, dim:]), initial=0.0)))
            seen["rolling_wall_max"] = max(seen["rolling_wall_max"], float(np.max(np.abs(cpu.wall_ft[:, dim:]))))
            if values["rolling_damping"] == 0.0:
                seen["at_cap"] += _at_cap(cpu, values)
        out.update(_same(cpu, GC._gas(GpuEngine, dim, k, **gas, **values), f"{dim}d"))
        if dim == 2:
            out.update(_same(cpu, GC._gas(GpuEngine, dim, k, room=0, **gas, **values), "2d_room"))
            out.update(_same(cpu, GC._gas(_host_rebuilt(), dim, k, **gas, **values), "2d_host"))
        plain = GC._gas(Engine, dim, k, **gas)
        out.update({f"{name}_{dim}d": value for name, value in seen.items()})
        out[f"history_width_{dim}d"] = int(cpu.pair_ft.shape[1])
        out[f"rebuilds_{dim}d"] = cpu.rebuilds
        out[f"moved_{dim}d"] = float(np.max(np.abs(cpu.angular_velocity - plain.angular_velocity)))
    return out


def rolling_batch(steps: int = 8) -> dict:
    """granwave.gpu.checks.batch's runs with rolling resistance: two 2D rolling gases (16 and 20
    grains) advanced together, one rebuilt by the batched one-block rebuild, the other by the
    multi-kernel rebuild with its pair arrays cut (its list grows: room made mid-batch); each
    against its runs alone (every history column) and on the CPU."""
    return GC._batched(((0, 16, None, None), (2, 20, 0, 0)), steps, {**ROLLING, "radii": RADII})


if __name__ == "__main__":
    print(json.dumps({"rolling": rolling(), "rolling_batch": rolling_batch()}))
