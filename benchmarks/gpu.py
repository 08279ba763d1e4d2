"""GPU backend speed: ratios to one CPU core and fractions of the memory-bandwidth roofline.

    python benchmarks/gpu.py [--tiny] [--dry-run] [--skip-crossing] [--skip-packing] [--full-crossing]
    python benchmarks/gpu.py --all [--tiny] [--out FILE] [--budget SECONDS]

``--all`` is the one prepared measurement (it replaces the list below): device, date and
versions; the agreement checks of granwave.gpu.checks (time-domain signal, two-body collision,
the mean-flow rule, the preparation rules' changes between runs, ensembles per launch against
each packing alone, tiny preparations under every protocol, DEM pulse, device neighbour rebuild)
as pass/fail with their largest differences; the memory bandwidth; the time-domain step at 10^6
grains against one core and the roofline; DEM grain-steps/s at 10^6 grains against one core,
over 2000 steps in which the pair list is rebuilt on the device (the tiled packing drifts along
the periodic axis: a rebuild about every 25 steps; the rebuild count is reported) and over 200
steps without rebuilds; 1000 600-grain 2D packings (p = 1e-4, seeds 0..999) prepared in one
batch on the GPU against the same preparations on 2 CPU cores (seconds per packing; the two
ensembles' statics within errors); the continuum study's 2048 d
mean-flow column (51 200 grains) prepared on the GPU, ten of them (seeds 0-9) in one batch
(ensembles per launch) for 2000 steps: seconds per batched step and the whole batch predicted
from one column's CPU step count. Parts run in the order bandwidth, checks, DEM, batch,
columns, time domain (``--parts`` picks some); each has its own time budget and is skipped, with
a note, when the whole budget (``--budget``, default 450 s wall, compilation included) is spent;
the JSON is written (to ``--out``, else stdout) after every part, so a run stopped from outside
still leaves the parts done. Its ``goal_table`` gives every goal of one GPU with the measured
value, the goal and pass/fail (:func:`goal_table`); under ``--tiny`` no row passes or fails (the
simulator measures nothing).

Exit status: 0 when the run is done (goals met or not: read ``goal_table``); 2 with one line on
stderr when no GPU is usable and neither ``--tiny`` nor ``--dry-run`` is given, or on a bad
``--parts``; nothing is written then.

On one NVIDIA GPU (``pip install -e '.[gpu]'``) it measures, in one run:

0. the device's memory bandwidth: a device-to-device copy of 1 GiB (bytes read + written / time);
1. time domain, 10^6-grain frictional 2D system (a triangular lattice of 1000 x 1000 grains,
   friction 0.5, p = 1e-4): seconds per Verlet step on the GPU and on one CPU core
   (granwave.linear.propagate.verlet_steps, one thread), their ratio, and the step's bytes
   (granwave.gpu.linear.bytes_per_step) / time / bandwidth;
2. a 10^7-grain crossing (lattice 3162 rows x 3162): GPU seconds per step times the steps of
   one crossing (height / c, c the lattice's longitudinal speed, granwave.theory.lattice_speed,
   at the default time step), or the whole crossing measured with ``--full-crossing``;
3. DEM grain-steps/s at 10^6 grains, 2D frictional (a CPU-prepared 600-grain packing at
   p = 1e-4 tiled along the periodic axis, kicked with small random velocities), GPU against
   one CPU core, and the step's modelled bytes (granwave.gpu.dem.bytes_per_step) / time /
   bandwidth; the GPU time counts the steps with their host neighbour rebuilds and per-step
   reads, not the copies of the state before and after;
4. the wall time to prepare a 10^6-grain 2D packing at p = 1e-4 on the GPU (no CPU reference:
   hours on one core).

The goals it prints ratios against: step >= 300x one core and >= 70 % of the roofline, the
crossing < 5 min, DEM >= 2e9 grain-steps/s and >= 100x one core, the packing < 15 min.
``--tiny`` runs every part at toy sizes in numba's CUDA simulator (set here before numba.cuda is
imported): it shows the script works, its numbers mean nothing. ``--dry-run`` prints the plan
(sizes, memory) without computing. Without a GPU (and without --tiny/--dry-run): one line,
exit status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

GOALS = {"td_speedup": 300.0, "td_roofline": 0.70, "crossing_s": 300.0, "dem_rate": 2e9,
         "dem_speedup": 100.0, "packing_s": 900.0}

FULL = dict(td=(1000, 1000), crossing=(3162, 3162), dem_grains=1_000_000, packing_grains=1_000_000,
            copy_bytes=1 << 30, td_steps=200, cpu_td_steps=5, dem_steps=100, cpu_dem_steps=5)
TINY = dict(td=(6, 4), crossing=(8, 4), dem_grains=40, packing_grains=10, copy_bytes=1 << 12,
            td_steps=3, cpu_td_steps=3, dem_steps=3, cpu_dem_steps=3)


def _sync():
    from numba import cuda

    cuda.synchronize()


def bandwidth(nbytes: int) -> float:
    """Bytes/s of a device-to-device copy (read + write counted), best of 5."""
    from numba import cuda

    n = nbytes // 8
    a = cuda.to_device(np.ones(n))
    b = cuda.device_array(n)
    best = math.inf
    for _ in range(5):
        _sync()
        t0 = time.perf_counter()
        b.copy_to_device(a)
        _sync()
        best = min(best, time.perf_counter() - t0)
    return 2 * 8 * n / best


def lattice_system(rows: int, width: int):
    from granwave.linear.assemble import linearize
    from granwave.linear.check import reference_lattice

    # No stiffness check: this measures steps, and at 10^6 grains the default check (a
    # shift-invert factorization) takes ~20 min (the lattice's D is known to be sound).
    return linearize(reference_lattice(rows, width, pressure=1e-4, friction=0.5), check=False)


def td_step_times(system, gpu_steps: int, cpu_steps: int) -> dict:
    """Seconds per step of the GPU fused step and of the CPU kernel on one thread."""
    from numba import cuda

    from granwave.gpu import linear as L
    from granwave.linear.propagate import stable_time_step, verlet_steps
    from granwave.threads import set_threads

    D = system.stiffness.tocsr()
    D.sort_indices()
    n = system.n_dof
    dt, _ = stable_time_step(system)
    minv = 1.0 / system.mass
    u0 = np.asarray(system.source_velocity, float) * dt
    # CPU, one core
    set_threads(1)
    u, v, a = u0.copy(), np.zeros(n), np.zeros(n)
    ip, ix = D.indptr.astype(np.int64), D.indices.astype(np.int64)
    verlet_steps(ip, ix, D.data, minv, u, v, a, dt, 1, 0.0)  # compiled before timing
    t0 = time.perf_counter()
    verlet_steps(ip, ix, D.data, minv, u, v, a, dt, cpu_steps, 0.0)
    cpu = (time.perf_counter() - t0) / cpu_steps
    # GPU
    g = [cuda.to_device(D.indptr.astype(np.int64)), cuda.to_device(D.indices.astype(np.int32)),
         cuda.to_device(D.data), cuda.to_device(minv)]
    bufs = [cuda.to_device(u0), cuda.device_array(n)]
    gv, ga, gve = cuda.to_device(np.zeros(n)), cuda.device_array(n), cuda.device_array(n)
    blocks = max(1, (n + L.BLOCK - 1) // L.BLOCK)

    def steps(k):
        for s in range(k):
            L.verlet_step[blocks, L.BLOCK](*g, bufs[s % 2], bufs[(s + 1) % 2], gv, ga, gve, dt, 0.0, False)

    steps(2)
    _sync()
    t0 = time.perf_counter()
    steps(gpu_steps)
    _sync()
    gpu = (time.perf_counter() - t0) / gpu_steps
    return dict(n_dof=n, nnz=int(D.nnz), dt=dt, cpu_s_per_step=cpu, gpu_s_per_step=gpu,
                bytes_per_step=L.bytes_per_step(n, int(D.nnz)))


def tiled_packing(grains: int, tiny: bool):
    """A CPU-prepared 2D packing at p = 1e-4 (600 grains; tiny: 10 at a loose tolerance) tiled
    along the periodic axis to about ``grains`` grains: an exact equilibrium state."""
    from granwave import api

    base = (api.prepare_packing(grains=10, seed=1, tol=1e-3, pressure=1e-2) if tiny
            else api.prepare_packing(grains=600, seed=1, pressure=1e-4))
    tiles = max(1, round(grains / base.n_grains))
    L = base.box[0]
    pos = np.concatenate([base.position + [k * L, 0.0] for k in range(tiles)])
    return base, pos, np.tile(base.radius, tiles), L * tiles, tiles


def dem_rates(grains: int, gpu_steps: int, cpu_steps: int, tiny: bool) -> dict:
    from granwave.dem.integrator import Engine
    from granwave.dem.protocol import pressure_scales
    from granwave.gpu import dem as G
    from granwave.threads import set_threads

    base, pos, rad, width, tiles = tiled_packing(grains, tiny)
    rng = np.random.default_rng(0)
    kw = dict(friction=base.friction, damping=0.5, skin=0.2, piston_mass=float(base.attrs["piston_mass"]) * tiles,
              piston_force=base.pressure * width, velocity=rng.normal(0, 1e-4, pos.shape),
              overlap_floor=pressure_scales(base.pressure, float(base.mass.mean()))[0])
    set_threads(1)
    out = {"grains": len(rad)}
    for name, cls, steps in (("cpu", Engine, cpu_steps), ("gpu", G.GpuEngine, gpu_steps)):
        eng = cls(pos, rad, [width], base.box[1], **kw)
        if name == "cpu":
            eng.run(2)  # compilation
            t0 = time.perf_counter()
            eng.run(steps)
            elapsed = time.perf_counter() - t0
        else:  # the steps alone: state copied to the device before, back after the timing
            eng.upload()
            eng.step()
            eng.step()  # compilation
            _sync()
            t0 = time.perf_counter()
            for _ in range(steps):
                eng.step()
            _sync()
            elapsed = time.perf_counter() - t0
            eng.download()
        out[f"{name}_grain_steps_per_s"] = len(rad) * steps / elapsed
        out["pairs"] = eng.n_pairs
        out["rebuilds_" + name] = eng.rebuilds
    out["bytes_per_step"] = G.bytes_per_step(len(rad), out["pairs"], 2, 1, eng.pair_ft.shape[1])
    return out


def crossing(rows: int, width: int, steps: int, full: bool) -> dict:
    """GPU steps/s on a rows x width lattice and the projected (or, with ``full``, measured)
    time of one crossing of its height at the longitudinal speed of the lattice's modes."""
    from granwave import api
    from granwave.theory import lattice_speed

    system = lattice_system(rows, width)
    times = td_step_times(system, steps, 1)
    # crossing time: height over the lattice's longitudinal speed (granwave.theory), default dt
    c = lattice_speed(1e-4, friction=True)
    t_cross = system.height / c
    n_steps = int(math.ceil(t_cross / times["dt"]))
    out = dict(n_dof=system.n_dof, t_cross=t_cross, steps=n_steps,
               projected_s=n_steps * times["gpu_s_per_step"])
    if full:
        t0 = time.perf_counter()
        api.propagate(system, t_max=t_cross, samples=201, method="time", device="gpu")
        out["measured_s"] = time.perf_counter() - t0
    return out


def packing_time(grains: int, tiny: bool) -> dict:
    from granwave import api

    kw = dict(grains=grains, seed=1, pressure=1e-2 if tiny else 1e-4)
    if tiny:
        kw["tol"] = 1e-3
    t0 = time.perf_counter()
    p = api.prepare_packing(**kw, device="gpu")
    return dict(grains=grains, seconds=time.perf_counter() - t0, steps=int(p.attrs["steps"]),
                rebuilds=int(p.attrs["rebuilds"]))


def plan(size: dict) -> dict:
    r, w = size["td"]
    R, W = size["crossing"]
    return dict(time_domain_dofs=3 * r * w, crossing_dofs=3 * R * W, dem_grains=size["dem_grains"],
                packing_grains=size["packing_grains"], copy_bytes=size["copy_bytes"],
                crossing_csr_bytes_estimate=int(3 * R * W * 21 * 12))


# ------------------------------------------------------------------------------------ --all
def versions() -> dict:
    """Python, numpy, scipy, numba, numba-cuda, CUDA runtime and driver, granwave's revision."""
    import platform
    import subprocess
    from importlib import metadata

    out = {"python": platform.python_version()}
    for name in ("numpy", "scipy", "numba", "numba-cuda", "h5py"):
        try:
            out[name] = metadata.version(name)
        except Exception:  # noqa: BLE001 - not installed
            out[name] = None
    try:
        from numba import cuda

        out["cuda_runtime"] = ".".join(map(str, cuda.runtime.get_version()))
    except Exception as exc:  # noqa: BLE001 - simulator, or an older API
        out["cuda_runtime"] = f"unknown ({type(exc).__name__})"
    try:
        from numba.cuda.cudadrv.driver import driver

        out["cuda_driver"] = str(driver.get_version())
    except Exception as exc:  # noqa: BLE001
        out["cuda_driver"] = f"unknown ({type(exc).__name__})"
    try:
        out["git"] = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10,
                                    cwd=os.path.dirname(os.path.abspath(__file__))).stdout.strip() or None
    except Exception:  # noqa: BLE001 - no git
        out["git"] = None
    return out


#: Pass criteria of the agreement checks (those of tests/test_gpu_sim.py; on a GPU the results
#: agree up to rounding, fused multiply-adds included, so bitwise equality is reported, not asked).
def _verdicts(name: str, r: dict) -> tuple[bool, dict]:
    if name == "time_domain":
        worst = max(r[f"{k}_{ic}"] for k in ("signal_rel", "snapshot_rel") for ic in "AB")
        return worst < 1e-10, {"max_rel": worst}
    if name == "two_body":
        return r["state_abs"] < 1e-12 and r["tangential_force"] > 1e-4, {"max_abs": r["state_abs"]}
    if name == "pulse":
        same = all(r[f"{k}_gpu"] == r[f"{k}_cpu"] for k in ("n_opened", "n_formed", "n_sliding",
                                                            "neighbour_rebuilds", "n_contacts_initial"))
        worst = max(r["signal_rel"], r["max_displacement_rel"])
        return same and worst < 1e-10, {"max_rel": worst, "same_counts": same}
    if name == "batch":  # ensembles per launch: each packing the bytes of its run alone on the device
        same = all(v for k, v in r.items() if k.startswith("same_seed"))
        worst = max(v for k, v in r.items() if k.startswith("cpu_abs_"))
        return same, {"same_bytes_as_alone": same, "max_abs_vs_cpu": worst}
    if name == "rebuild":
        keys = [k[len("same_pairs_"):] for k in r if k.startswith("same_pairs_")]
        same = all(r[f"same_pairs_{k}"] for k in keys)
        worst = max(r[f"state_abs_{k}"] for k in keys)
        rebuilds = all(r[f"rebuilds_{k}"] == r[f"rebuilds_cpu_{k[:2]}"] for k in keys)
        return (same and worst < 1e-9 and rebuilds and r.get("room_made_2d_room", 0) > 0
                and r.get("room_made_2d_room_multi", 0) > 0,
                {"max_abs": worst, "same_pairs": same, "same_rebuilds": rebuilds,
                 "bitwise": all(r[f"same_state_{k}"] and r[f"same_history_{k}"] for k in keys)})
    if name == "mean_flow":
        same = all(r[f"same_state_{d}"] and r[f"same_slabs_{d}"] for d in ("2d", "3d"))
        worst = max(r["state_abs_2d"], r["state_abs_3d"])
        return worst < 1e-9 and r["moved_2d"] > 1e-2, {"max_abs": worst, "bitwise": same}
    if name == "rules":
        worst = max(r["state_abs_2d"], r["state_abs_3d"])
        return worst < 1e-9 and r["piston_force_2d"] > 0.0, {"max_abs": worst}
    if name == "protocols":
        keys = ("steps", "settling_step", "end_game_step", "end_game_changes")
        same = all(v[f"{k}_gpu"] == v[f"{k}_cpu"] for v in r.values() for k in keys)
        worst = max(v["position_abs"] for v in r.values())
        return same and worst < 1e-6, {"max_abs": worst, "same_decisions": same}
    raise KeyError(name)


def agreement(deadline: float) -> dict:
    """The checks of granwave.gpu.checks, each while time is left before ``deadline``."""
    from granwave.gpu import checks

    out = {}
    # the batch first: it compiles the single engine's and the batched kernels, and it is the
    # only device test of the segmented rebuild (each packing against its run alone, bitwise)
    for name in ("batch", "two_body", "mean_flow", "rules", "protocols", "time_domain", "pulse", "rebuild"):
        if time.perf_counter() > deadline:
            out[name] = {"skipped": "time budget of the checks spent"}
            continue
        t0 = time.perf_counter()
        try:
            r = checks.CHECKS[name]()
            ok, summary = _verdicts(name, r)
            out[name] = {"pass": bool(ok), **summary, "seconds": time.perf_counter() - t0, "detail": r}
        except Exception as exc:  # noqa: BLE001 - reported, the other parts go on
            out[name] = {"pass": False, "error": f"{type(exc).__name__}: {exc}"[:500],
                         "seconds": time.perf_counter() - t0}
    return out


def dem_with_rebuilds(grains: int, gpu_steps: int, plain_steps: int, cpu_steps: int, tiny: bool,
                      deadline: float) -> dict:
    """DEM grain-steps/s at ``grains`` grains (the tiled packing of :func:`tiled_packing`), GPU
    against one core. The whole packing drifts along the periodic axis at a speed U that
    uses half the skin in about 25 steps, so that the pair list is rebuilt on the device about
    every 25 steps (a uniform drift changes no contact force; the walls' friction slows the
    layers next to them). Also the GPU rate without drift (no rebuilds) over ``plain_steps``."""
    from granwave.dem.integrator import Engine
    from granwave.dem import kernels as K
    from granwave.dem.protocol import pressure_scales
    from granwave.gpu import dem as G
    from granwave.threads import set_threads

    base, pos, rad, width, tiles = tiled_packing(grains, tiny)
    rng = np.random.default_rng(0)
    kw = dict(friction=base.friction, damping=0.5, skin=0.2, piston_mass=float(base.attrs["piston_mass"]) * tiles,
              piston_force=base.pressure * width, velocity=rng.normal(0, 1e-4, pos.shape),
              overlap_floor=pressure_scales(base.pressure, float(base.mass.mean()))[0], check_every=0)
    set_threads(1)
    out = {"grains": len(rad)}

    def engine(cls, drift: bool):
        eng = cls(pos, rad, [width], base.box[1], **kw)
        if drift:
            u = 0.5 * eng.skin / (25 * eng.dt)
            eng.velocity[:, 0] += u
            out["drift_speed"] = u
        return eng

    # GPU, no rebuilds (no drift): the step alone
    eng = engine(G.GpuEngine, False)
    t0 = time.perf_counter()
    eng.run(2)  # compilation of every kernel, device rebuild included
    out["gpu_compile_s"] = time.perf_counter() - t0
    for every in (1, 8):
        eng.rebuild_every = every
        r0 = eng.rebuilds
        eng.upload()
        _sync()
        t0 = time.perf_counter()
        for _ in range(plain_steps):
            eng.step()
        queued = time.perf_counter() - t0  # host time to queue the launches (~ el: the host is the limit)
        _sync()
        el = time.perf_counter() - t0
        eng.download()
        out["gpu_plain" if every == 1 else f"gpu_plain_rebuild_every_{every}"] = dict(
            steps=plain_steps, seconds=el, host_queue_s=queued, grain_steps_per_s=len(rad) * plain_steps / el,
            rebuilds=eng.rebuilds - r0, pairs=eng.n_pairs)
    if time.perf_counter() > deadline:
        out["note"] = "time budget spent after the plain steps"
        return out
    # GPU with drift: the device rebuilds; the host reads the device every G.GpuEngine.SYNC_EVERY steps
    # (rebuild_every 1: the CPU's test before every step; 8: the rebuild's kernels with every 8th step)
    for every in (1, 8):
        if every > 1 and time.perf_counter() > deadline:
            break
        eng = engine(G.GpuEngine, True)
        eng.rebuild_every = every
        eng.run(2)
        eng.upload()
        r0, s0 = eng.rebuilds, eng.steps
        _sync()
        t0 = time.perf_counter()
        status = eng.advance(s0 + gpu_steps)  # GpuEngine.run's loop: a read of the device every SYNC_EVERY steps
        _sync()
        el = time.perf_counter() - t0
        eng.download()
        out["gpu" if every == 1 else f"gpu_rebuild_every_{every}"] = dict(
            steps=eng.steps - s0, seconds=el, grain_steps_per_s=len(rad) * (eng.steps - s0) / el,
            rebuilds=eng.rebuilds - r0, pairs=eng.n_pairs, status=status, room_made=eng.room_made,
            sync_every=G.GpuEngine.SYNC_EVERY, rebuild_every=every)
    if time.perf_counter() > deadline:
        out["note"] = "time budget spent before the CPU reference"
        return out
    # one core, the same drifting system
    eng = engine(Engine, True)
    eng.run(2)
    r0 = eng.rebuilds
    t0 = time.perf_counter()
    eng.run(cpu_steps)
    el = time.perf_counter() - t0
    out["cpu"] = dict(steps=cpu_steps, seconds=el, grain_steps_per_s=len(rad) * cpu_steps / el,
                      rebuilds=eng.rebuilds - r0)
    out["speedup_vs_one_core"] = out["gpu"]["grain_steps_per_s"] / out["cpu"]["grain_steps_per_s"]
    out["bytes_per_step"] = G.bytes_per_step(len(rad), out["gpu"]["pairs"], 2, 1, eng.pair_ft.shape[1])
    return out


STATIC_KEYS = ("phi2", "z_star", "rattler_fraction", "mean_force_over_p", "Z2", "F2", "stress_ratio",
               "max_force_residual", "piston_balance")


def _cpu_prepare(job):
    """One preparation on the CPU in a worker process (one thread): (seed, seconds, packing or
    the error's text). ``job``: (params, seed)."""
    import dataclasses

    from granwave.dem.protocol import prepare_packing
    from granwave.errors import ConvergenceError
    from granwave.threads import set_threads

    params, seed = job
    set_threads(1)
    t0 = time.perf_counter()
    try:
        p = prepare_packing(dataclasses.replace(params, seed=seed))
    except ConvergenceError as exc:
        return seed, time.perf_counter() - t0, f"{type(exc).__name__}: {exc}"[:200]
    return seed, time.perf_counter() - t0, p


class _OutOfTime(Exception):
    """The batch's driver passed its deadline (benchmarks only)."""


def _timed_ensemble(deadline: float):
    """A granwave.gpu.batch.Ensemble whose driver stops every packing once ``deadline`` is passed
    (each protocol then raises _OutOfTime; the members keep the steps they made)."""
    from granwave.gpu import batch as B

    class Timed(B.Ensemble):
        def advance(self, requests):
            if time.perf_counter() > deadline:
                raise _OutOfTime(f"time budget spent after {self.rounds} rounds")
            return super().advance(requests)

    return Timed()


def _ensemble_statics(packings) -> list:
    from granwave.analysis.statics import statics

    rows = []
    for p in packings:
        s = statics(p) if p.n_grains >= 100 else statics(p, layer=0.5)  # tiny: the whole 10-grain box
        rows.append([float(s[k]) for k in STATIC_KEYS])
    return rows


def _mean_err(rows, c):
    x = np.array([r[c] for r in rows])
    x = x[np.isfinite(x)]
    return (float(x.mean()), float(x.std(ddof=1) / math.sqrt(len(x)))) if len(x) >= 2 else (math.nan, math.nan)


def batch_vs_cpu(grains: int, packings: int, cpu_cores: int, tiny: bool, deadline: float, cpu_s: float,
                 max_steps: int | None = None) -> dict:
    """``packings`` 2D frictional packings of ``grains`` grains at p = 1e-4 (tiny: p = 1e-2,
    tol 1e-2, ``max_steps``), seeds 0, 1, ..., prepared in one batch on the GPU (ensembles per
    launch, granwave.gpu.batch; after a warm-up batch of two with a short step budget: the
    kernels' compilation), then the same preparations on ``cpu_cores`` CPU cores (one process
    per core, one thread each, seeds 0, 1, ... while ``cpu_s`` seconds last): seconds per
    packing on each (the GPU's: the batch's wall time over its packings), their ratio; the statics
    of the two ensembles (means, standard errors, agreement within 3 combined standard errors) and
    how many of the seeds both made are the same bytes. The GPU batch stops at ``deadline``
    (reported with the steps made)."""
    import concurrent.futures as cf
    import dataclasses
    import multiprocessing as mp

    from granwave.dem.protocol import prepare_packing
    from granwave.errors import StepBudgetExceeded
    from granwave.gpu import batch as B
    from granwave.params import PrepareParams

    kw = dict(grains=grains, pressure=1e-2 if tiny else 1e-4, dim=2, friction=0.5)
    if tiny:
        kw["tol"] = 1e-2
    if max_steps is not None:
        kw["max_steps"] = int(max_steps)
    params = PrepareParams(**kw)
    out = {"grains": grains, "pressure": kw["pressure"], "packings": packings, "cpu_cores": cpu_cores,
           "max_steps": max_steps}
    t0 = time.perf_counter()
    try:  # the kernels' compilation (the small packings' one-block rebuild, the batched step)
        if not tiny:  # (the simulator compiles nothing)
            B.prepare_packings(PrepareParams(**{**kw, "max_steps": 40}), [0, 1])
    except StepBudgetExceeded:
        pass
    out["gpu_warm_up_s"] = time.perf_counter() - t0
    ensemble = _timed_ensemble(deadline)
    engine = ensemble.member_class()

    def job(seed):  # as granwave.gpu.batch.prepare_packings, each seed's outcome kept
        return lambda: prepare_packing(dataclasses.replace(params, seed=seed), engine=engine)

    t0 = time.perf_counter()
    outcome = ensemble.run([job(s) for s in range(packings)])
    out["gpu_s"] = time.perf_counter() - t0
    gpu = [v for ok, v in outcome if ok]
    failed = [(s, v) for s, (ok, v) in enumerate(outcome) if not ok]
    gpu_note = None
    if any(isinstance(v, _OutOfTime) for _, v in failed):
        gpu_note = f"not finished: time budget spent after {ensemble.rounds} rounds"
    elif failed:
        gpu_note = f"{len(failed)} seeds failed, first: seed {failed[0][0]}: {type(failed[0][1]).__name__}: " \
                   f"{str(failed[0][1])[:200]}"
    if len(gpu) < packings:
        gpu = []  # the seeds in order are compared: a batch with failures is reported, not compared
    members = ensemble.key[0] if ensemble.key else ()
    out["gpu"] = {"done": len(outcome) - len(failed), "failed": len(failed), "seconds": out["gpu_s"],
                  "per_packing_s": out["gpu_s"] / packings, "measures": ensemble.measures,
                  "steps": sorted(int(p.attrs["steps"]) for p in gpu) if gpu else sorted(m.steps for m in members),
                  "rounds": ensemble.rounds, "batched_steps": ensemble.steps_queued,
                  "driver_s": ensemble.seconds, "rebuild_launches": ensemble.rebuild_launches,
                  "launches_per_rebuild": {str(k): v for k, v in sorted(ensemble.launches_per_rebuild.items())}}
    if gpu_note:
        out["gpu"]["note"] = gpu_note
    # the same work on cpu_cores cores: one process per core, seeds in order while the time lasts
    cpu, errors = {}, []
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(cpu_cores, mp_context=mp.get_context("spawn")) as pool:
        list(pool.map(_cpu_prepare, [(PrepareParams(**{**kw, "grains": 10, "tol": 1e-2, "pressure": 1e-2}), s)
                                     for s in range(cpu_cores)]))  # workers started, kernels loaded
        warm = time.perf_counter() - t0
        t0 = time.perf_counter()
        waiting, running = list(range(packings)), set()
        while True:
            while waiting and len(running) < cpu_cores and time.perf_counter() - t0 < cpu_s:
                running.add(pool.submit(_cpu_prepare, (params, waiting.pop(0))))
            if not running:
                break
            done, running = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            for f in done:
                sd, secs, p = f.result()
                if isinstance(p, str):
                    errors.append(f"seed {sd}: {p}")
                else:
                    cpu[sd] = p
        cpu_wall = time.perf_counter() - t0
    n_cpu = len(cpu) + len(errors)
    out["cpu"] = {"done": n_cpu, "converged": len(cpu), "seconds": cpu_wall, "worker_start_s": warm,
                  "per_packing_s": cpu_wall / max(n_cpu, 1),
                  "steps": sorted(int(p.attrs["steps"]) for p in cpu.values())}
    if errors:
        out["cpu"]["errors"] = errors[:10]
    out["gpu_faster_per_packing"] = bool(gpu and n_cpu and out["gpu"]["per_packing_s"] < out["cpu"]["per_packing_s"])
    out["cpu_over_gpu_per_packing"] = out["cpu"]["per_packing_s"] / out["gpu"]["per_packing_s"] if n_cpu else None
    common = [s for s in cpu if s < len(gpu)]
    out["byte_identical"] = sum(bool(gpu[s].position.tobytes() == cpu[s].position.tobytes()) for s in common)
    out["compared_seeds"] = len(common)
    if len(gpu) >= 2 and len(cpu) >= 2:
        rows = {"gpu": _ensemble_statics(gpu), "cpu": _ensemble_statics(cpu.values())}
        agree = {}
        for c, key in enumerate(STATIC_KEYS):
            (m1, e1), (m2, e2) = _mean_err(rows["cpu"], c), _mean_err(rows["gpu"], c)
            err = math.hypot(e1, e2)
            agree[key] = {"cpu_mean": m1, "cpu_stderr": e1, "gpu_mean": m2, "gpu_stderr": e2,
                          "agree_3_sigma": bool(abs(m1 - m2) <= 3 * err) if err > 0 else bool(m1 == m2)}
        out["statics"] = agree
        out["all_agree"] = all(v["agree_3_sigma"] for v in agree.values())
    else:
        out["statics"] = {"skipped": "fewer than two finished packings on a device"}
    return out


#: The continuum study's tallest column (config/continuum.yaml, continuum2d_p4): 2D frictional,
#: width 25 d, 2048 d, W x H grains, p = 1e-4, tol 1e-8, compaction 'mean-flow' (settling
#: 'late'), and the steps its preparation took on the CPU (docs/continuum.md, seed 0).
COLUMN = dict(dim=2, width=25, height=2048.0, pressure=1e-4, friction=0.5, polydispersity=0.2, tol=1e-8,
              compaction="mean-flow")
COLUMN_CPU_STEPS = 2_232_260
COLUMN_TINY = dict(dim=2, width=4, height=16.0, pressure=1e-2, friction=0.5, polydispersity=0.2, tol=1e-3,
                   compaction="mean-flow", reference_height=4.0)


def column_rate(spec: dict, steps: int, columns: int = 10, rebuild_every: int = 8) -> dict:
    """``columns`` mean-flow columns (``spec``: :data:`COLUMN`; seeds 0, 1, ...) prepared in one
    batch on the GPU (ensembles per launch, granwave.gpu.batch: every column advanced by the same
    kernel launches) for ``steps`` steps each by the preparation protocol itself (gas, compaction
    with the mean-flow rule and its settling rule, checks; stopped by its step budget), with the
    device rebuild's kernels queued every ``rebuild_every`` steps (the same bits), after a warm-up
    batch of two tiny columns (the kernels' compilation): seconds per batched step (``seconds``:
    everything, the gases and engines' set-up on the host included; ``stepping_seconds``: the
    driver's rounds: uploads, steps, checks, downloads) and the whole batch predicted from the
    CPU's step count of one column."""

    from granwave.errors import StepBudgetExceeded
    from granwave.gpu import batch as B
    from granwave.gpu import dem as G
    from granwave.params import PrepareParams

    def params(spec, steps):
        kw = {k: v for k, v in spec.items() if k not in ("width", "height")}
        kw.update(grains=int(round(spec["width"] * spec["height"])), aspect=spec["height"] / spec["width"],
                  max_steps=int(steps))
        return PrepareParams(**kw)

    saved = G.GpuEngine.rebuild_every, G.GpuEngine.small_rebuild
    G.GpuEngine.rebuild_every = int(rebuild_every)  # the batch's engines are GpuEngines
    # every column rebuilt as a large one (granwave.gpu.batch_rebuild's segmented rebuild), the
    # tiny warm-up columns too (so they compile its kernels) and the toy columns of --tiny
    G.GpuEngine.small_rebuild = 0
    try:
        t0 = time.perf_counter()
        try:
            B.prepare_packings(params(COLUMN_TINY, 20), [0, 1])
        except StepBudgetExceeded:
            pass
        warm = time.perf_counter() - t0
        p = params(spec, steps)
        ensemble = B.Ensemble()
        note = None
        t0 = time.perf_counter()
        try:
            B.prepare_packings(p, list(range(columns)), ensemble=ensemble)
            note = "converged within the steps asked"
        except StepBudgetExceeded:
            pass
        secs = time.perf_counter() - t0
    finally:
        G.GpuEngine.rebuild_every, G.GpuEngine.small_rebuild = saved
    per_step = ensemble.seconds / steps
    return {"grains_per_column": p.grains, "columns": columns, "steps": steps, "seconds": secs,
            "stepping_seconds": ensemble.seconds, "warm_up_seconds": warm, "batched_steps": ensemble.steps_queued,
            "rounds": ensemble.rounds, "s_per_batched_step": per_step,
            "launches_per_rebuild": {str(k): v for k, v in sorted(ensemble.launches_per_rebuild.items())},
            "grain_steps_per_s": columns * p.grains / per_step, "rebuild_every": int(rebuild_every),
            "cpu_steps_of_one_column": COLUMN_CPU_STEPS, "predicted_batch_s": per_step * COLUMN_CPU_STEPS,
            "how": "ensembles per launch (granwave.gpu.batch): the columns in one batch",
            **({"note": note} if note else {})}


ALL_FULL = dict(total_s=450.0, checks_s=60.0, td_s=60.0, dem_s=60.0, batch_s=200.0, td=(1000, 1000),
                dem_grains=1_000_000, dem_steps=2000, dem_plain_steps=200, cpu_dem_steps=30, td_steps=200,
                cpu_td_steps=5, copy_bytes=1 << 30, packing_grains=600, packings=1000, cpu_cores=2, cpu_s=40.0,
                batch_max_steps=None, columns_s=60.0, column=COLUMN, column_steps=2000, columns=10)
ALL_TINY = dict(total_s=3000.0, checks_s=1500.0, td_s=300.0, dem_s=600.0, batch_s=600.0, td=(6, 4),
                dem_grains=40, dem_steps=30, dem_plain_steps=3, cpu_dem_steps=3, td_steps=3, cpu_td_steps=3,
                copy_bytes=1 << 12, packing_grains=10, packings=2, cpu_cores=2, cpu_s=60.0, batch_max_steps=3,
                columns_s=600.0, column=COLUMN_TINY, column_steps=20, columns=3)
#: The parts of --all, in the order they run (``--parts`` picks some).
PARTS = ("bandwidth", "checks", "dem", "batch", "columns", "time_domain")
#: Wall-time goal of the whole --all run (s, compilation included).
ALL_WALL_GOAL_S = 480.0
#: The goal on ten 2048 d columns in one batch (s).
COLUMNS_GOAL_S = 600.0
#: When this module started (the --all wall time counts the imports and compilation too).
T_START = time.perf_counter()


def goal_table(res: dict) -> dict:
    """The issue's goals on one GPU, each with the measured value, the goal and pass/fail (None:
    not measured, said why). Under the simulator (``--tiny``) nothing is a measurement: every
    ``pass`` is None and ``measurement`` false."""
    sim = bool(res.get("simulator"))

    def get(*path):
        x = res
        for k in path:
            if not isinstance(x, dict) or k not in x:
                return None
            x = x[k]
        return x

    rows = {}

    def row(name, what, measured, goal, better, source):
        ok = None
        if measured is not None and not sim and isinstance(measured, (int, float)) and math.isfinite(measured):
            ok = bool(measured >= goal) if better == ">=" else bool(measured < goal)
        rows[name] = {"what": what, "measured": measured, "goal": f"{better} {goal:g}", "pass": ok,
                      "from": source}
        if measured is None:
            rows[name]["note"] = "not measured in this run (part skipped, failed or not asked)"

    rates = [get("dem", k, "grain_steps_per_s") for k in ("gpu", "gpu_rebuild_every_8")]
    rates = [r for r in rates if r is not None]
    row("dem_rate", "DEM grain-steps/s at 1e6 grains, device rebuilds (best of the rebuild tests every step "
        "and every 8 steps)", max(rates) if rates else None, GOALS["dem_rate"], ">=", "dem")
    row("td_speedup", "time-domain step, GPU over one core", get("time_domain", "speedup_vs_one_core"),
        GOALS["td_speedup"], ">=", "time_domain")
    row("td_roofline", "time-domain step, fraction of the copy roofline", get("time_domain", "roofline_fraction"),
        GOALS["td_roofline"], ">=", "time_domain")
    row("columns_s", "ten 2048 d mean-flow columns in one batch, predicted whole batch (s)",
        get("columns", "predicted_batch_s"), COLUMNS_GOAL_S, "<", "columns")
    ratio = get("batch", "cpu_over_gpu_per_packing") if get("batch", "gpu", "note") is None else None
    row("batch_per_packing", f"{get('batch', 'packings')} packings of {get('batch', 'grains')} grains in one "
        f"batch: CPU ({get('batch', 'cpu_cores')} cores) seconds per packing over GPU seconds per packing",
        ratio, 1.0, ">=", "batch")
    agree = get("batch", "all_agree")
    row("ensemble_statics", "GPU ensemble's statics within 3 combined standard errors of the CPU ensemble's "
        "(1: every one)", None if agree is None else float(agree), 1.0, ">=", "batch")
    row("all_wall_s", "benchmarks/gpu.py --all wall time, imports and compilation included (s)", res.get("wall_s"),
        ALL_WALL_GOAL_S, "<", "wall_s")
    if sim:
        for r in rows.values():
            r["measurement"] = False
            r["note"] = "CUDA simulator at toy sizes: not a measurement"
    return rows


def run_all(args) -> int:
    size = dict(ALL_TINY if args.tiny else ALL_FULL)
    if args.budget:
        size["total_s"] = float(args.budget)
    start = time.perf_counter()
    end = start + size["total_s"]
    res = {"benchmark": "benchmarks/gpu.py --all", "simulator": bool(args.tiny),
           "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "goals": GOALS}

    def write() -> None:
        res["wall_s"] = time.perf_counter() - T_START
        res["goal_table"] = goal_table(res)
        text = json.dumps(res, indent=1, default=float)
        if args.out:
            tmp = args.out + ".tmp"
            with open(tmp, "w") as f:
                f.write(text + "\n")
            os.replace(tmp, args.out)

    def stage(what: str) -> None:
        print(f"[gpu.py {time.strftime('%H:%M:%S')} +{time.perf_counter() - start:.0f}s] {what}", file=sys.stderr,
              flush=True)

    parts = PARTS if not args.parts else tuple(x.strip() for x in args.parts.split(","))

    def part(name: str, budget: float, fn) -> None:
        left = end - time.perf_counter()
        if name not in parts:
            return
        if left < 0.25 * budget:
            res[name] = {"skipped": f"whole time budget spent ({left:.0f} s left, part budget {budget:.0f} s)"}
            stage(f"{name}: skipped")
        else:
            stage(f"{name} (budget {min(budget, left):.0f} s)")
            t0 = time.perf_counter()
            try:
                res[name] = fn(t0 + min(budget, left))
            except Exception as exc:  # noqa: BLE001 - reported; the other parts go on
                import traceback

                res[name] = {"error": f"{type(exc).__name__}: {exc}"[:800],
                             "traceback": traceback.format_exc()[-2000:]}
            res[name + "_seconds"] = time.perf_counter() - t0
        write()

    from numba import cuda

    try:
        dev = cuda.get_current_device()
        res["device"] = dev.name.decode() if hasattr(dev.name, "decode") else str(dev.name)
    except Exception as exc:  # noqa: BLE001
        res["device"] = f"unknown ({type(exc).__name__})"
    res["versions"] = versions()
    write()
    bw = {}

    def do_bandwidth(deadline):
        bw["value"] = bandwidth(size["copy_bytes"])
        return {"copy_GBps": bw["value"] / 1e9, "bytes": size["copy_bytes"]}

    def do_td(deadline):
        t0 = time.perf_counter()
        system = lattice_system(*size["td"])
        td = {"lattice": list(size["td"]), "build_s": time.perf_counter() - t0}
        td.update(td_step_times(system, size["td_steps"], size["cpu_td_steps"]))
        td["speedup_vs_one_core"] = td["cpu_s_per_step"] / td["gpu_s_per_step"]
        td["roofline_fraction"] = td["bytes_per_step"] / td["gpu_s_per_step"] / bw.get("value", math.nan)
        return td

    def do_dem(deadline):
        d = dem_with_rebuilds(size["dem_grains"], size["dem_steps"], size["dem_plain_steps"],
                              size["cpu_dem_steps"], args.tiny, deadline)
        if "gpu" in d and "value" in bw and "bytes_per_step" in d:
            d["roofline_fraction"] = d["bytes_per_step"] * d["gpu"]["grain_steps_per_s"] / d["grains"] / bw["value"]
        if "gpu" in d:
            d["goal_ratio_rate"] = d["gpu"]["grain_steps_per_s"] / GOALS["dem_rate"]
        return d

    part("bandwidth", 30.0, do_bandwidth)
    part("checks", size["checks_s"], agreement)
    # the new parts first; the time domain (its code unchanged, measured before) last
    part("dem", size["dem_s"], do_dem)
    part("batch", size["batch_s"],
         lambda deadline: batch_vs_cpu(size["packing_grains"], size["packings"], size["cpu_cores"], args.tiny,
                                       deadline - size["cpu_s"], size["cpu_s"], size["batch_max_steps"]))
    part("columns", size["columns_s"],
         lambda deadline: column_rate(size["column"], size["column_steps"], size["columns"]))
    part("time_domain", size["td_s"], do_td)
    if args.tiny:
        res["note"] = "CUDA simulator at toy sizes: these numbers say nothing about a GPU"
    write()
    stage("done")
    if not args.out:
        print(json.dumps(res, indent=1, default=float))
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tiny", action="store_true", help="toy sizes in the CUDA simulator")
    ap.add_argument("--dry-run", action="store_true", help="print the plan only")
    ap.add_argument("--skip-crossing", action="store_true")
    ap.add_argument("--skip-packing", action="store_true")
    ap.add_argument("--full-crossing", action="store_true", help="run the whole crossing")
    ap.add_argument("--all", action="store_true", help="the one prepared measurement (module docstring)")
    ap.add_argument("--out", help="with --all: write the JSON here (else stdout)")
    ap.add_argument("--budget", type=float, help="with --all: whole wall-time budget in seconds (default 450)")
    ap.add_argument("--parts", help=f"with --all: the parts to run, comma-separated (default all: {','.join(PARTS)})")
    args = ap.parse_args(argv)
    if args.parts and not set(x.strip() for x in args.parts.split(",")) <= set(PARTS):
        print(f"benchmarks/gpu.py: --parts: expected some of {','.join(PARTS)} (got {args.parts!r})", file=sys.stderr)
        return 2
    size = TINY if args.tiny else FULL
    if args.dry_run:
        print(json.dumps({"plan": plan(size), "goals": GOALS}, indent=1))
        return 0
    if args.tiny:
        os.environ["NUMBA_ENABLE_CUDASIM"] = "1"  # before numba.cuda is first imported
    from granwave.errors import InputError
    from granwave.gpu import require_gpu

    try:
        require_gpu()
    except InputError as exc:
        print(f"benchmarks/gpu.py: {exc}", file=sys.stderr)
        return 2
    if args.all:
        return run_all(args)
    res = {"simulator": bool(args.tiny)}
    if not args.tiny:
        from numba import cuda

        res["device"] = cuda.get_current_device().name.decode() if hasattr(
            cuda.get_current_device().name, "decode") else str(cuda.get_current_device().name)
    def stage(what: str) -> None:  # progress on stderr; the JSON result alone on stdout
        print(f"[gpu.py {time.strftime('%H:%M:%S')}] {what}", file=sys.stderr, flush=True)

    stage("memory bandwidth")
    bw = bandwidth(size["copy_bytes"])
    res["bandwidth_GBps"] = bw / 1e9
    stage(f"time domain: lattice {size['td']}, linearize, GPU and one-core steps")
    td = td_step_times(lattice_system(*size["td"]), size["td_steps"], size["cpu_td_steps"])
    td["speedup_vs_one_core"] = td["cpu_s_per_step"] / td["gpu_s_per_step"]
    td["roofline_fraction"] = td["bytes_per_step"] / td["gpu_s_per_step"] / bw
    res["time_domain"] = td
    if not args.skip_crossing:
        stage(f"crossing: lattice {size['crossing']}")
        res["crossing"] = crossing(*size["crossing"], size["td_steps"], args.full_crossing)
    stage(f"DEM: {size['dem_grains']} grains, GPU and one core")
    dem = dem_rates(size["dem_grains"], size["dem_steps"], size["cpu_dem_steps"], args.tiny)
    dem["speedup_vs_one_core"] = dem["gpu_grain_steps_per_s"] / dem["cpu_grain_steps_per_s"]
    dem["roofline_fraction"] = (dem["bytes_per_step"] * dem["gpu_grain_steps_per_s"] / dem["grains"]) / bw
    res["dem"] = dem
    if not args.skip_packing:
        stage(f"packing: {size['packing_grains']} grains on the GPU")
        res["packing"] = packing_time(size["packing_grains"], args.tiny)
    ratios = {"td_speedup": td["speedup_vs_one_core"] / GOALS["td_speedup"],
              "td_roofline": td["roofline_fraction"] / GOALS["td_roofline"],
              "dem_rate": dem["gpu_grain_steps_per_s"] / GOALS["dem_rate"],
              "dem_speedup": dem["speedup_vs_one_core"] / GOALS["dem_speedup"]}
    if "crossing" in res:
        t = res["crossing"].get("measured_s", res["crossing"]["projected_s"])
        ratios["crossing_s"] = GOALS["crossing_s"] / t
    if "packing" in res:
        ratios["packing_s"] = GOALS["packing_s"] / res["packing"]["seconds"]
    res["goal_ratios (>= 1 meets the goal)"] = ratios
    if args.tiny:
        res["note"] = "CUDA simulator at toy sizes: these numbers say nothing about a GPU"
    print(json.dumps(res, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
