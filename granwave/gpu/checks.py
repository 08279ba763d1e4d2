"""GPU-against-CPU checks on tiny systems, small enough for numba's CUDA simulator.

Run by tests/test_gpu_sim.py (in a subprocess with ``NUMBA_ENABLE_CUDASIM=1``) and by
``benchmarks/gpu.py --tiny``; on a real GPU they run unchanged. Each check returns a dict of
plain numbers: the largest relative or absolute difference to the CPU kernels and whether two
GPU runs gave identical bytes. ``python -m granwave.gpu.checks`` prints them as JSON.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = float(np.max(np.abs(a), initial=0.0))
    return float(np.max(np.abs(a - b), initial=0.0) / scale) if scale > 0 else float(np.max(np.abs(b)))


def time_domain(rows: int = 4, width: int = 3) -> dict:
    """Frictional triangular lattice, both initial conditions, with snapshots: signal and
    snapshots of the GPU time domain against the CPU one; two GPU runs (IC A) compared bytewise."""
    from ..linear.assemble import linearize
    from ..linear.check import reference_lattice
    from ..linear.propagate import time_domain_signal
    from .linear import time_domain_signal_gpu

    system = linearize(reference_lattice(rows, width, pressure=1e-4, friction=0.5))
    out = {"n_dof": system.n_dof, "nnz": int(system.stiffness.nnz)}
    kw = dict(t_max=6.0, samples=7, snapshots=[0.0, 2.5])
    for ic in "AB":
        cpu = time_domain_signal(system, ic=ic, **kw)
        gpu = time_domain_signal_gpu(system, ic=ic, **kw)
        again = time_domain_signal_gpu(system, ic=ic, **kw) if ic == "A" else gpu
        out[f"signal_rel_{ic}"] = _rel(cpu.force, gpu.force)
        out[f"snapshot_rel_{ic}"] = _rel(cpu.snapshot_displacement, gpu.snapshot_displacement)
        out[f"steps_{ic}"] = int(gpu.attrs["n_steps"])
        if ic == "A":
            out["identical"] = bool(gpu.force.tobytes() == again.force.tobytes())
        out[f"energy_dev_cpu_{ic}"] = float(cpu.attrs["modified_energy_max_rel_deviation"])
        out[f"energy_dev_gpu_{ic}"] = float(gpu.attrs["modified_energy_max_rel_deviation"])
    return out


def _two_body(cls, steps: int, friction: float = 0.5, dim: int = 2):
    if dim == 2:
        pos, lateral = [[5.0, 3.0], [5.9, 3.3]], [12.0]
        vel, spin = [[0.3, 0.05], [-0.2, 0.0]], [[0.4], [-1.0]]
    else:
        pos, lateral = [[5.0, 5.0, 3.0], [5.9, 5.1, 3.3]], [12.0, 12.0]
        vel, spin = [[0.3, 0.0, 0.05], [-0.2, 0.1, 0.0]], [[0.4, 0.0, 0.1], [-1.0, 0.2, 0.0]]
    e = cls(np.array(pos), np.array([0.5, 0.45]), lateral, 8.0, friction=friction, damping=0.3, dt=2e-3,
            velocity=vel, angular_velocity=spin if friction > 0 else None)
    e.run(steps)
    return e


STATE = ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration")
#: The wall contacts' histories (every column: the tangential one, then a sub-model's).
WALLS = ("wall_ft", "wall_ov")


def two_body(steps: int = 24) -> dict:
    """Head-on-and-sliding collision of two grains (Hertz-Mindlin with friction 0.5, damping 0.3,
    spins): largest absolute difference of the state and tangential history after ``steps``;
    also (``steps // 2``) frictionless in 2D and frictional in 3D. (24 steps: the overlap 0.025
    and the tangential force 6e-4, both past the test's floors; each simulated step costs.)"""
    from ..dem.integrator import Engine
    from .dem import GpuEngine

    cpu, gpu, again = _two_body(Engine, steps), _two_body(GpuEngine, steps), _two_body(GpuEngine, steps)
    m = cpu.n_pairs
    diff = max(float(np.max(np.abs(getattr(cpu, k) - getattr(gpu, k)))) for k in STATE)
    diff = max(diff, float(np.max(np.abs(cpu.pair_ft[:m] - gpu.pair_ft[:m]), initial=0.0)))
    same = all(getattr(gpu, k).tobytes() == getattr(again, k).tobytes() for k in STATE)
    for friction, dim in ((0.0, 2), (0.5, 3)):  # the frictionless (no rotation) and 3D paths
        a, b = _two_body(Engine, steps // 2, friction, dim), _two_body(GpuEngine, steps // 2, friction, dim)
        diff = max(diff, *(float(np.max(np.abs(getattr(a, k) - getattr(b, k)), initial=0.0))
                           for k in (*STATE, "pair_ft")))
    return {"state_abs": diff, "tangential_force": float(np.abs(cpu.pair_ft[:m]).max(initial=0.0)),
            "overlap": float(cpu.pair_ov[:m].max(initial=0.0)), "identical": bool(same),
            "steps": steps}


def prepare(grains: int = 10, seed: int = 3, safety: float = 0.06) -> dict:
    """A whole preparation (piston compression to equilibrium, host neighbour rebuilds included)
    of a tiny 2D frictional packing at a loose tolerance, on both devices. (Seed 3 and the
    largest time-step safety: 240 steps and 33 rebuilds, against 360 steps for seed 1 at the
    default safety; the simulator's cost is its steps.)"""
    from .. import api

    kw = dict(grains=grains, seed=seed, tol=1e-2, pressure=1e-2, safety=safety)
    t0 = time.perf_counter()
    cpu = api.prepare_packing(**kw)
    t1 = time.perf_counter()
    gpu = api.prepare_packing(**kw, device="gpu")
    t2 = time.perf_counter()
    return {"grains": grains, "steps_cpu": int(cpu.attrs["steps"]), "steps_gpu": int(gpu.attrs["steps"]),
            "rebuilds": int(gpu.attrs["rebuilds"]),
            "position_abs": float(np.max(np.abs(cpu.position - gpu.position))),
            "height_abs": abs(cpu.height - gpu.height), "contacts_cpu": len(cpu.contacts),
            "contacts_gpu": len(gpu.contacts), "device_attr": gpu.attrs.get("device"),
            "seconds_cpu": t1 - t0, "seconds_gpu": t2 - t1}


def pulse() -> dict:
    """A strong nonlinear DEM pulse (contacts open, form and slide; a rebuild every step) through
    a 20-grain frictional packing prepared on the CPU: GPU signal and counts against the CPU."""
    from .. import api
    from ..dem.pulse import propagate_dem

    packing = api.prepare_packing(grains=20, seed=1, tol=1e-6, pressure=1e-3)
    kw = dict(ic="A", t_max=2.0, samples=3, dt=0.1, damping=0.2, skin=1e-3, amplitude=3.0, baseline=False)
    cpu = propagate_dem(packing, **kw)
    gpu = propagate_dem(packing, device="gpu", **kw)
    keys = ("n_opened", "n_formed", "n_sliding", "neighbour_rebuilds", "n_contacts_initial")
    return {"signal_rel": _rel(cpu.force, gpu.force),
            "max_displacement_rel": _rel(cpu.attrs["max_displacement"], gpu.attrs["max_displacement"]),
            **{f"{k}_cpu": int(cpu.attrs[k]) for k in keys}, **{f"{k}_gpu": int(gpu.attrs[k]) for k in keys}}


def pulse_piston() -> dict:
    """The piston drive (docs/shocks.md) on the GPU against the CPU: a strong push (strain 10
    delta0) into a 3 x 3 Hertz lattice column, damped, with the pulse field on (read at every
    sample from the state brought to the host): signal, field, largest forces, displacement and
    counts, at the end and at every sample. The column is short enough for the CUDA simulator (42
    steps)."""
    from ..dem import pulse_kernels as PK
    from ..dem.pulse import propagate_dem
    from ..systems import triangular_lattice

    packing = triangular_lattice(rows=3, width=3, pressure=1e-3)
    delta0 = float(np.mean(packing.contacts.overlap[packing.contacts.j >= 0]))
    kw = dict(drive="piston", strain=10.0 * delta0, t_max=1.2, samples=4, dt=0.03, damping=0.1, skin=0.02,
              baseline=False)
    cpu = propagate_dem(packing, **kw)
    gpu = propagate_dem(packing, device="gpu", **kw)
    both = (("cpu", cpu), ("gpu", gpu))
    keys = ("n_opened", "n_formed", "n_sliding", "neighbour_rebuilds", "n_contacts_initial", "n_steps")
    return {"signal_rel": _rel(cpu.force, gpu.force), "signal_max": float(np.max(np.abs(cpu.force))),
            "field_rel": _rel(cpu.pulse["velocity"], gpu.pulse["velocity"]),
            "field_max": float(np.max(np.abs(cpu.pulse["velocity"]))),
            "force_max_rel": _rel(cpu.pulse["force_max"], gpu.pulse["force_max"]),
            "force_grew": float(np.max(cpu.pulse["force_max"] / np.maximum(cpu.pulse["force_initial"], 1e-300))),
            "max_displacement_rel": _rel(cpu.attrs["max_displacement"], gpu.attrs["max_displacement"]),
            "piston_velocity": float(cpu.attrs["piston_velocity"]),
            **{f"{k}_cpu": int(cpu.attrs[k]) for k in keys}, **{f"{k}_gpu": int(gpu.attrs[k]) for k in keys},
            **{f"{k}_{dev}": float(sig.attrs[k]) for k in INCOMING for dev, sig in both},
            **{f"{k}_{dev}": sig.pulse[k].tolist() for k in PK.CONTACT_COUNTS for dev, sig in both}}


#: The incoming front's counts of a pulse with the field (granwave.dem.pulse.incoming_counts).
INCOMING = ("front_far_wall_time", "n_opened_incoming", "n_formed_incoming", "n_sliding_new_incoming")


def _gas(cls, dim: int, steps: int, **kw):
    """:func:`_gas_engine` run for ``steps`` steps."""
    e = _gas_engine(cls, dim, **kw)
    e.run(steps)
    return e


def _gas_engine(cls, dim: int, seed: int = 0, room: int | None = None, small: int | None = None,
                every: int = 1, friction: float = 0.5, top: float | None = None, grains: int | None = None,
                radii: tuple = (0.3, 0.4), **rule):
    """A dense frictional gas in a 6 x 6 (x 6) box (radii 0.3-0.4 on a jittered grid, random
    velocities and a vertical squeeze, so that pairs form and the list is rebuilt every ~10
    steps); ``room``: the pair arrays cut to that many slots before the run (the GPU engine
    must make room on the device's request); ``small``: the GPU engine's ``small_rebuild`` (0:
    the multi-kernel rebuild of large systems); ``top``: the top wall's height (default: the box
    side); ``radii``: the radii's range; ``rule``: more engine arguments (the mean-flow rule's
    ``mean_flow`` and ``background_damping``, a piston's mass and force)."""
    rng = np.random.default_rng(seed)
    side = 6 if dim == 2 else 5
    axes = np.meshgrid(*[np.arange(side) + 0.5] * dim, indexing="ij")
    pos = np.stack([a.ravel() for a in axes], axis=1)
    pos = pos[rng.permutation(len(pos))[: grains or len(pos) * 2 // 3]]  # room to move
    pos += rng.uniform(-0.1, 0.1, pos.shape)
    n = len(pos)
    rad = rng.uniform(*radii, n)
    vel = rng.normal(0.0, 1.0, pos.shape)
    vel[:, -1] -= 0.5 * (pos[:, -1] - side / 2)
    rot = 1 if dim == 2 else 3
    e = cls(pos, rad, [float(side)] * (dim - 1), float(side if top is None else top), friction=friction,
            damping=0.3, dt=4e-3, skin=0.2, velocity=vel, angular_velocity=rng.normal(0.0, 1.0, (n, rot)),
            check_every=rule.pop("check_every", 0), **rule)
    if small is not None:
        e.small_rebuild = small
    if every != 1:
        e.rebuild_every = every
    if room is not None:
        m = e.n_pairs
        for name in ("pair_i", "pair_j", "pair_ft", "pair_ov"):
            setattr(e, name, getattr(e, name)[: max(m, room)].copy())
    return e


def rebuild(steps: int = 24, steps_3d: int = 12) -> dict:
    """The device rebuild against the CPU's: a dense gas (:func:`_gas`) run on both devices
    with rebuilds mid-run, in 2D and 3D, by the one-block rebuild and by the multi-kernel one
    (``_multi``), and in 2D again with the pair arrays cut to the pairs of the first list
    (``_room``: a later rebuild needs more, the run stops on the device, the host makes room,
    the run goes on). Pair lists (keys in order, histories) and states compared bitwise. In 2D
    also with the rebuild test every 3 steps (``every3``: other rebuild steps, the same state).
    (24 and 12 steps: 3 and 2 rebuilds after the first list, 7 in ``every3``, the cut arrays
    enlarged once; the simulated multi-kernel rebuild costs seconds each.)"""
    from ..dem.integrator import Engine
    from .dem import GpuEngine

    out = {}
    for dim, k in ((2, steps), (3, steps_3d)):
        cpu, gpu = _gas(Engine, dim, k), _gas(GpuEngine, dim, k)
        runs = {"": gpu, "_multi": _gas(GpuEngine, dim, k, small=0)}
        if dim == 2:
            runs["_room"] = _gas(GpuEngine, dim, k, room=0)
            runs["_room_multi"] = _gas(GpuEngine, dim, k, room=0, small=0)
        m = cpu.n_pairs
        for tag, g in runs.items():
            key = f"{dim}d{tag}"
            out[f"pairs_{key}"] = g.n_pairs
            out[f"same_pairs_{key}"] = bool(g.n_pairs == m and np.array_equal(cpu.pair_i[:m], g.pair_i[:m])
                                            and np.array_equal(cpu.pair_j[:m], g.pair_j[:m]))
            out[f"same_history_{key}"] = bool(g.n_pairs == m and cpu.pair_ft[:m].tobytes() == g.pair_ft[:m].tobytes()
                                              and cpu.pair_ov[:m].tobytes() == g.pair_ov[:m].tobytes())
            out[f"same_state_{key}"] = all(getattr(cpu, s).tobytes() == getattr(g, s).tobytes() for s in STATE)
            out[f"state_abs_{key}"] = max(float(np.max(np.abs(getattr(cpu, s) - getattr(g, s)), initial=0.0))
                                          for s in STATE)
            out[f"rebuilds_{key}"] = g.rebuilds
            out[f"room_made_{key}"] = g.room_made
            out[f"steps_{key}"] = g.steps
        if dim == 2:  # the test every 3 steps, looking 3 steps ahead: other rebuild steps, the same bits
            g = _gas(GpuEngine, dim, k, every=3)
            out["same_state_2d_every3"] = all(getattr(cpu, s).tobytes() == getattr(g, s).tobytes() for s in STATE)
            out["rebuilds_2d_every3"] = g.rebuilds
        out[f"rebuilds_cpu_{dim}d"] = cpu.rebuilds
        out[f"pairs_cpu_{dim}d"] = m
        out[f"grains_{dim}d"] = len(cpu.radius)
    return out


def mean_flow(steps: int = 30, steps_3d: int = 12) -> dict:
    """The compaction rule 'mean-flow' in the engine: the dense gas of :func:`_gas` with
    background damping and the slabs' mean flows damped at rates of their own, on both devices,
    compared bitwise (state and the slabs' means of the last step): in 2D frictionless with the
    lateral mean flow at the background rate (the compaction's case, no lateral sums), in 3D
    frictional with it at its own rate too (the settling rule's case: both lateral means).
    ``moved_2d``, ``moved_3d``: how far the rule moves the state (against the same run without
    it): the comparison sees it. (:func:`rules` runs the rule in 2D with friction.)"""
    from ..dem.integrator import Engine
    from .dem import GpuEngine

    out = {}
    for dim, k, friction, rule in ((2, steps, 0.0, (0.2, 1.0)), (3, steps_3d, 0.5, (0.1, 1.5, 0.4))):
        kw = dict(friction=friction, background_damping=2.0)
        cpu = _gas(Engine, dim, k, mean_flow=rule, **kw)
        gpu = _gas(GpuEngine, dim, k, mean_flow=rule, **kw)
        plain = _gas(Engine, dim, k, **kw)
        out[f"same_state_{dim}d"] = all(getattr(cpu, s).tobytes() == getattr(gpu, s).tobytes() for s in STATE)
        out[f"same_slabs_{dim}d"] = bool(cpu.slabs.tobytes() == gpu.slabs.tobytes())
        out[f"state_abs_{dim}d"] = max(float(np.max(np.abs(getattr(cpu, s) - getattr(gpu, s)), initial=0.0))
                                       for s in STATE)
        out[f"moved_{dim}d"] = float(np.max(np.abs(cpu.velocity - plain.velocity)))
        out[f"lateral_sums_{dim}d"] = float(np.max(np.abs(cpu.slabs[2:]), initial=0.0))
        out[f"slabs_{dim}d"] = int(cpu.slabs.shape[1])
        out[f"occupied_slabs_{dim}d"] = int(np.count_nonzero(cpu.slabs[1]))
        out[f"rebuilds_{dim}d"] = gpu.rebuilds
    return out


def batch(steps: int = 10) -> dict:
    """Ensembles per launch (:mod:`granwave.gpu.batch`): three small 2D frictional gases of
    different seeds and sizes (24, 20 and 22 grains) under a loaded piston with the mean-flow
    rule and convergence checks every 8 steps, advanced together through runs of different
    lengths with a settling switch in between, one of them with its pair arrays cut so that a
    device rebuild runs out of room mid-batch, another rebuilt by the multi-kernel rebuild of
    large packings; each against the same runs of a
    :class:`GpuEngine` alone (bitwise: state, pair list and histories, piston, slabs, steps,
    rebuilds) and of the CPU engine (``cpu_abs``: the piston force is reduced in another order)."""
    setups = ((0, 24, None, None), (1, 20, 0, None), (2, 22, None, 0))  # (seed, grains, room, small)
    return _batched(setups, steps, {})


def _batched(setups, steps: int, extra: dict) -> dict:
    """:func:`batch`'s runs for ``setups`` ((seed, grains, room, small) per packing), the gases
    made with the engine arguments ``extra`` too (a contact sub-model's: tests/gpu_rolling_checks.py)."""
    from ..dem.integrator import Engine
    from ..dem.mean_flow import M_GAMMA_L, M_GAMMA_M
    from .batch import Ensemble
    from .dem import GpuEngine

    kw = dict(friction=0.5, background_damping=2.0, piston_mass=1.0, piston_force=20.0, top=5.8,
              mean_flow=(0.2, 1.0), check_every=8, **extra)

    def job(cls, seed, grains, room, small):
        def run():
            e = _gas_engine(cls, 2, seed=seed, grains=grains, room=room, small=small, **kw)
            e.run(steps + 5 * seed)  # runs of other lengths: the packings stop at other steps
            e.mflow[M_GAMMA_M] = e.mflow[M_GAMMA_L] = 0.7  # the settling switch between runs
            e.run(steps // 2)
            return e
        return run

    ensemble = Ensemble()
    t0 = time.perf_counter()
    together = ensemble.run([job(ensemble.member_class(), *s) for s in setups])
    t1 = time.perf_counter()
    out = {"rounds": ensemble.rounds, "batched_steps": ensemble.steps_queued, "seconds_batch": t1 - t0,
           "small_rebuild_launches": ensemble.small_rebuild_launches}
    for (seed, grains, room, small), (ok, b) in zip(setups, together):
        if not ok:
            raise b
        alone = job(GpuEngine, seed, grains, room, small)()
        cpu = job(Engine, seed, grains, None, None)()  # (the CPU engine makes its own room)
        m = alone.n_pairs
        key = f"seed{seed}"
        out[f"grains_{key}"] = len(b.radius)
        out[f"steps_{key}"] = b.steps
        out[f"rebuilds_{key}"] = b.rebuilds
        out[f"room_made_{key}"] = b.room_made
        out[f"same_{key}"] = bool(
            b.steps == alone.steps and b.rebuilds == alone.rebuilds and b.n_pairs == m
            and all(getattr(b, s).tobytes() == getattr(alone, s).tobytes() for s in (*STATE, *WALLS))
            and all(getattr(b, s)[:m].tobytes() == getattr(alone, s)[:m].tobytes()
                    for s in ("pair_i", "pair_j", "pair_ft", "pair_ov"))
            and b.piston.tobytes() == alone.piston.tobytes() and b.slabs.tobytes() == alone.slabs.tobytes()
            and b.fpar.tobytes() == alone.fpar.tobytes())
        out[f"cpu_abs_{key}"] = max(float(np.max(np.abs(getattr(cpu, s) - getattr(b, s)), initial=0.0))
                                    for s in STATE)
        out[f"cpu_steps_{key}"] = cpu.steps
        out[f"history_width_{key}"] = int(b.pair_ft.shape[1])
        # the history columns of a sub-model after the tangential ones (none without one)
        out[f"extra_history_max_{key}"] = float(np.max(np.abs(b.pair_ft[:m, b.dim:]), initial=0.0))
    out["seconds_alone_and_cpu"] = time.perf_counter() - t1
    return out


def batch_prepare(grains: int = 10, seeds=(0, 1)) -> dict:
    """Whole preparations through :func:`granwave.api.prepare_packings` on the GPU (the seeds
    advanced together; the tiny packing of :func:`prepare`) against each seed prepared alone on
    the GPU: positions, contacts and attributes compared bitwise (``same``), and the steps."""
    from .. import api

    kw = dict(grains=grains, tol=1e-2, pressure=1e-2)
    t0 = time.perf_counter()
    together = api.prepare_packings(seeds=list(seeds), device="gpu", **kw)
    t1 = time.perf_counter()
    out = {"seconds_batch": t1 - t0}
    for seed, b in zip(seeds, together):
        alone = api.prepare_packing(seed=seed, device="gpu", **kw)
        same = (b.position.tobytes() == alone.position.tobytes() and b.box.tobytes() == alone.box.tobytes()
                and all(getattr(b.contacts, f).tobytes() == getattr(alone.contacts, f).tobytes()
                        for f in ("i", "j", "force_normal", "force_tangential", "overlap"))
                and {k: str(v) for k, v in b.attrs.items()} == {k: str(v) for k, v in alone.attrs.items()})
        out[f"same_seed{seed}"] = bool(same)
        out[f"steps_seed{seed}"] = int(b.attrs["steps"])
        out[f"rebuilds_seed{seed}"] = int(b.attrs["rebuilds"])
    out["seconds_alone"] = time.perf_counter() - t1
    return out


def rules(steps: int = 6) -> dict:
    """What the preparation's host-side rules do to a GPU engine between two runs, against the
    CPU engine: a gas under a moving piston (the piston damped at the mean-flow rate) run for
    ``steps`` steps, then the settling rule's switch (the mean flows' rates lowered, the lateral
    one now apart from the background rate), ``steps`` more, then the end game's cap on every
    background damping rate, ``steps`` more; in 2D frictional with the mean-flow rule, in 3D
    frictionless without it (the rates 'fixed' and 'height-scaled' are one background rate).
    The piston force is reduced in another order on the device, so the state agrees to rounding
    (``state_abs``), not bit for bit; ``piston_moved``: the piston's travel (it takes part)."""
    from ..dem import kernels as K
    from ..dem.integrator import Engine
    from ..dem.mean_flow import M_GAMMA_L, M_GAMMA_M
    from .dem import GpuEngine

    TOP = {2: 5.8, 3: 4.9}  # the piston starts on the top grains (box sides 6 and 5)

    def run(cls, dim, friction, rule):
        kw = dict(friction=friction, background_damping=2.0, piston_mass=1.0, piston_force=20.0,
                  top=TOP[dim])
        if rule is not None:
            kw["mean_flow"] = rule
        e = _gas(cls, dim, steps, **kw)
        if rule is not None:  # the settling switch (granwave.dem.settling.CriticalSettling._switch)
            e.mflow[M_GAMMA_M] = e.mflow[M_GAMMA_L] = 0.7
        e.run(steps)
        e.cap_background_damping(0.3, e.damping_rates())  # the end game (granwave.dem.end_game)
        e.run(steps)
        return e

    out = {}
    for dim, friction, rule in ((2, 0.5, (0.2, 1.0)), (3, 0.0, None)):
        cpu, gpu = run(Engine, dim, friction, rule), run(GpuEngine, dim, friction, rule)
        piston = np.abs(np.array(cpu.piston.tolist()) - np.array(gpu.piston.tolist()))  # a record's fields
        out[f"state_abs_{dim}d"] = max(float(np.max(piston)), *(
            float(np.max(np.abs(getattr(cpu, s) - getattr(gpu, s)), initial=0.0)) for s in STATE))
        out[f"piston_moved_{dim}d"] = abs(cpu.height - TOP[dim])
        out[f"piston_force_{dim}d"] = float(cpu.piston.f_con)
        out[f"steps_{dim}d"] = gpu.steps
    return out


#: Tiny preparations, one per protocol the CPU accepts (compaction rules, settling rules, end
#: game; 2D and 3D; with and without friction). Loose tolerance, 2-step checks (the rules sample
#: every 10 checks) and a reference height of 1 d so that the mean-flow rule is on in columns a
#: few grains tall; background damping 0.1: the plug swings up, the settling rule switches.
PROTOCOLS = {
    "mean_flow_critical_3d": dict(dim=3, grains=40, friction=0.0, aspect=0.6, compaction="mean-flow",
                                  mean_flow_settling="critical", end_game="adaptive"),
    "height_scaled_2d": dict(dim=2, grains=20, friction=0.0, aspect=2.0, compaction="height-scaled",
                             end_game="adaptive"),
    "mean_flow_late_2d": dict(dim=2, grains=20, friction=0.0, aspect=2.0, compaction="mean-flow",
                              mean_flow_settling="late", end_game="adaptive"),
    "mean_flow_critical_2d_friction": dict(dim=2, grains=20, friction=0.5, aspect=2.0, compaction="mean-flow",
                                           mean_flow_settling="critical", end_game="adaptive"),
    "mean_flow_compaction_2d_friction": dict(dim=2, grains=20, friction=0.5, aspect=2.0,
                                             compaction="mean-flow", mean_flow_settling="compaction"),
    "height_scaled_3d_friction": dict(dim=3, grains=40, friction=0.5, aspect=0.6, compaction="height-scaled",
                                      end_game="adaptive"),
}
PROTOCOL_COMMON = dict(seed=1, tol=1e-3, pressure=1e-2, background_damping=0.1, reference_height=1.0,
                       mean_flow_slab=1.0, check_every=2)


def protocols(names=None) -> dict:
    """Whole preparations (:data:`PROTOCOLS`) on both devices: steps, the rules' decisions (the
    settling switch, the end game's start and rate changes) and the packing compared. The
    trajectories agree to rounding only (the piston force is reduced in another order on the
    device), so positions are compared with a tolerance; every decision must be the same."""
    from .. import api

    out = {}
    for name in names or PROTOCOLS:
        kw = {**PROTOCOL_COMMON, **PROTOCOLS[name]}
        t0 = time.perf_counter()
        cpu = api.prepare_packing(**kw)
        t1 = time.perf_counter()
        gpu = api.prepare_packing(**kw, device="gpu")
        t2 = time.perf_counter()
        r = {"position_abs": float(np.max(np.abs(cpu.position - gpu.position))),
             "height_abs": abs(cpu.height - gpu.height), "seconds_cpu": t1 - t0, "seconds_gpu": t2 - t1,
             "contacts_cpu": len(cpu.contacts), "contacts_gpu": len(gpu.contacts),
             "device_attr": gpu.attrs.get("device")}
        for key in ("steps", "rebuilds", "settling_step", "end_game_step", "end_game_changes",
                    "background_damping_scale", "mean_flow_damping_scale"):
            for tag, p in (("cpu", cpu), ("gpu", gpu)):
                value = p.attrs.get(key)
                r[f"{key}_{tag}"] = None if value is None else float(value)
        out[name] = r
    return out


CHECKS = {"time_domain": time_domain, "two_body": two_body, "prepare": prepare, "pulse": pulse,
          "pulse_piston": pulse_piston,
          "rebuild": rebuild, "mean_flow": mean_flow, "rules": rules, "protocols": protocols, "batch": batch,
          "batch_prepare": batch_prepare}


#: Checks run only when named: whole preparations take minutes in the CUDA simulator (about
#: 0.3-0.6 s a step on a 2-core machine), seconds on a GPU (benchmarks/gpu.py --tiny runs them).
HEAVY = ("protocols", "batch_prepare")
#: Checks left out of the default set because a test file of their own runs them
#: (tests/test_gpu_batch.py, tests/test_gpu_pulse_piston.py), so that tests/test_gpu_sim.py's subprocess does
#: not run them twice.
OWN_TEST = ("batch", "pulse_piston")


def main(argv=None) -> None:
    """Print the named checks' results (all but :data:`HEAVY` by default) as one JSON object."""
    names = list(argv if argv is not None else sys.argv[1:]) or [c for c in CHECKS if c not in HEAVY + OWN_TEST]
    print(json.dumps({name: CHECKS[name]() for name in names}))


if __name__ == "__main__":
    main()
