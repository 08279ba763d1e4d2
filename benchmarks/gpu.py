"""GPU backend speed: ratios to one CPU core and fractions of the memory-bandwidth roofline.

    python benchmarks/gpu.py [--tiny] [--dry-run] [--skip-crossing] [--skip-packing] [--full-crossing]

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
    kw = dict(friction=base.friction, damping=0.5, piston_mass=float(base.attrs["piston_mass"]) * tiles,
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
    out["bytes_per_step"] = G.bytes_per_step(len(rad), out["pairs"], 2, 1)
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tiny", action="store_true", help="toy sizes in the CUDA simulator")
    ap.add_argument("--dry-run", action="store_true", help="print the plan only")
    ap.add_argument("--skip-crossing", action="store_true")
    ap.add_argument("--skip-packing", action="store_true")
    ap.add_argument("--full-crossing", action="store_true", help="run the whole crossing")
    args = ap.parse_args(argv)
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
