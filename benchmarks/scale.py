"""How the DEM engine and the time domain scale with threads and size (a script, not a test).

    python benchmarks/scale.py [--quick] [--write-docs]
    python benchmarks/scale.py --large column|grid2d|grid3d|time [--dry-run | --tiny]
        [--compaction fixed|height-scaled|mean-flow] [--settling compaction|critical|late]
        [--end-game none|adaptive] [--stop-at STEPS]

Default run, every number a ratio measured in this one run (so that the load of a shared
machine affects numerator and denominator alike; the load average is printed with them):

1. DEM, threads 1 -> 2: wall-clock grain-steps/s of the frictional damped 2D engine on a
   dense packing of 10200 grains (the 600-grain packing tiled 17 times along the periodic
   axis, as benchmarks/dem.py), a fixed number of steps per thread count (one thread: the
   single pair loop, dem/serial.py; two: the block engine), with the number of grain blocks
   and the fraction of the pairs that cross a block boundary (computed in the first phase,
   docs/dem.md "Parallel engine");
2. time domain, threads 1 -> 2: wall-clock seconds per velocity-Verlet step on a 2D
   frictional triangular lattice of 10^4 grains (3 * 10^4 dofs, as benchmarks/linear.py);
3. per-core rate on the 600-grain state against LAMMPS GRANULAR (benchmarks/dem.py's
   comparison, one thread, CPU time, the best of --repeat alternated runs of each), when
   the ``lammps`` module loads;
4. the same bits: the 10200-grain DEM state after the steps, and the time-domain state,
   compared byte for byte between the thread counts;
5. the CPU time per step (all threads) at 2 threads over 1 thread: the work the threads add
   (near 1: little overhead; a wall ratio far below 2 with this near 1 is threads waiting for
   a core on a loaded machine, not work);
6. with ``--ceiling``, the DEM's ceiling on this machine at the largest thread count T: T
   separate one-thread processes at once, each on its own copy of a thread's share of the
   state (benchmarks/engine_copies.py), their summed rate while all ran at once over the
   one-thread rate of the first row, and the engine's rate at T threads as a fraction of that
   sum (docs/decisions/0004-parallel-passes.md);
7. with ``--each-cpu``, the one-thread DEM rate of the first row's state alone on each allowed
   CPU in turn (a one-thread process bound to it), and the largest thread count's rate over
   the fastest, the median and the slowest of them: on the lent 16-vCPU machines one thread's
   rate depended on the vCPU it landed on, so the first row's ratio does too
   (docs/decisions/0004-parallel-passes.md).

``--write-docs`` writes the table into benchmarks/results/TABLES.md and docs/linear.md (marked blocks).

``--large NAME`` runs one of the large cases (or, with ``--dry-run``, prints its memory and
time estimate only; with ``--tiny``, runs the same code path at a tiny size to show that it
starts): ``column`` width 25 x height 800 at p = 1e-4 (~2 * 10^4 grains); ``grid2d`` 10^5
grains 2D at p = 1e-4; ``grid3d`` 10^5 frictional (mu = 0.5) spheres at p = 1e-4; ``time``
one crossing of a 10^6-grain 2D frictional triangular lattice (a lattice, not a disordered
packing: preparing and linearizing a 10^6-grain packing is its own multi-hour job). Each
prints wall time and peak memory (ru_maxrss). The time estimates use the engine's rate and
the steps model of the relaxation (steps ~ L^1.43 at fixed width, 275,740 steps for a
10^4-grain square packing: measured with the current protocol in 2D; the 3D figure is that
model applied to the height in diameters, not a 3D measurement). ``--stop-at STEPS`` stops a
preparation after that many steps (the same trajectory up to there: the budget only shortens
the last chunk), to check its progress lines against another run's log at a fraction of the
cost (benchmarks/investigations/same_progress.py).
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))

import granwave.threads  # noqa: E402,F401  (threading layer first)

BEGIN = "<!-- scale:begin -->"
END = "<!-- scale:end -->"
GOALS = {"dem_2": 1.8, "time_2": 1.7, "dem_16": 12.0, "time_16": 8.0, "lammps": 3.0}

#: Steps model of the relaxation (2D, current protocol): steps(10^4-grain square) and the
#: exponent of the height at fixed width.
STEPS_1E4 = 275_740
HEIGHT_EXPONENT = 1.43


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"load {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} cores"


def peak_memory() -> float:
    """Peak resident memory of this process so far (bytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0


def steal_jiffies() -> tuple[int, int]:
    """(steal, total) CPU jiffies of the machine so far (/proc/stat; zeros elsewhere): the time a
    virtual machine's cores waited for the host, which stalls every thread of a parallel region."""
    try:
        with open("/proc/stat") as f:
            vals = [int(x) for x in f.readline().split()[1:]]
        return (vals[7] if len(vals) > 7 else 0), sum(vals)
    except OSError:
        return 0, 0


def dem_threads(packing, steps: int, threads=(1, 2), tiles: int = 17, repeat: int = 3,
                regions_too: bool = False) -> list[dict]:
    """Wall-clock rate of the tiled state (``tiles`` x 600 grains; 17: 10200) at each thread
    count, the best of ``repeat`` runs (thread counts interleaved, so that a busy spell of a shared
    machine hits them alike). One result per variant: the engine as it is, and with
    ``regions_too`` also with its plain steps in a parallel region per pass as before the team
    (integrator.PLAIN_STEPS_IN_TEAM False; one thread runs the same single loop for both), the
    variants alternated inside each repetition. Each result's ``states``: the final states' bytes."""
    import numba
    from dem import engine_rate

    from granwave.dem import integrator
    from granwave.dem import kernels as K

    teams = (True, False) if regions_too else (True,)
    results = [dict(rates={}, cpu={}, states={}, count={}, fraction={}, team_steps={}, team=team)
               for team in teams]
    keep = integrator.Engine.run

    engines = {}

    def run_and_keep(self, n):  # keep the engine: its final state and blocks are read after timing
        engines[numba.get_num_threads()] = self
        return keep(self, n)

    for rep in range(repeat):
        for t in threads:
            for res in results:
                numba.set_num_threads(t)
                integrator.Engine.run = run_and_keep
                integrator.PLAIN_STEPS_IN_TEAM = res["team"]
                try:
                    cpu, wall, n, _ = engine_rate(packing, tiles, steps)
                finally:
                    integrator.Engine.run = keep
                    integrator.PLAIN_STEPS_IN_TEAM = True
                if wall > res["rates"].get(t, 0.0):
                    res["rates"][t], res["cpu"][t] = wall, cpu
                e = engines[t]
                res["states"].setdefault(t, set()).add(e.position.tobytes() + e.pair_ft.tobytes())
                nblk = e.ws.blk.shape[0]
                K.prepare_blocks(e.radius, e.mass, e.inertia, e.ws, nblk)
                res["count"][t], res["fraction"][t] = nblk, K.boundary_fraction(e.ws, e.n_pairs)
                res["grains"] = n
                res["team_steps"][t] = int(e.ipar.team_steps)
                print(f"  DEM {t} thread(s){'' if res['team'] else ', a region per pass'}, run {rep + 1}: "
                      f"{wall:.3g} grain-steps/s wall ({res['team_steps'][t]} steps in teams); {load()}", flush=True)
    numba.set_num_threads(max(threads))
    return results


def time_threads(n_grains: int, steps: int, threads=(1, 2), repeat: int = 3) -> dict:
    """Wall seconds per Verlet step on a frictional lattice of ``n_grains``, the best of
    ``repeat`` runs per thread count (interleaved); same bits?"""
    import numba
    from linear import lattice

    from granwave.linear.assemble import linearize
    from granwave.linear.propagate import stable_time_step, verlet_steps

    system = linearize(lattice(n_grains), check=False)
    dt, _ = stable_time_step(system)
    D = system.stiffness.tocsr()
    D.sort_indices()
    args = (D.indptr.astype(np.int64), D.indices.astype(np.int64), D.data.astype(np.float64),
            1.0 / system.mass)
    per_step, cpu, finals = {}, {}, set()
    for rep in range(repeat):
        for t in threads:
            numba.set_num_threads(t)
            u = np.zeros(system.n_dof)
            v = system.source_velocity.copy()
            a = np.zeros(system.n_dof)
            verlet_steps(*args, u, v, a, dt, 2, 1e-200)  # compile / warm up
            u[:] = 0.0
            v[:] = system.source_velocity
            a[:] = 0.0
            w0, c0 = time.perf_counter(), time.process_time()
            verlet_steps(*args, u, v, a, dt, steps, 1e-200)
            wall = (time.perf_counter() - w0) / steps
            if wall < per_step.get(t, math.inf):
                per_step[t], cpu[t] = wall, (time.process_time() - c0) / steps
            finals.add(u.tobytes() + v.tobytes())
            print(f"  time domain {t} thread(s), run {rep + 1}: {1e3 * wall:.3g} ms/step wall; {load()}",
                  flush=True)
    numba.set_num_threads(max(threads))
    return dict(per_step=per_step, cpu=cpu, dof=system.n_dof, same=len(finals) == 1)


def _ideal_kernel():
    import numba

    @numba.njit(parallel=True, cache=False)
    def region(out, work):
        # no memory traffic: each chunk iterates a dependent chain of multiply-adds and a sqrt
        for b in numba.prange(out.shape[0]):
            x = 1.0 + b * 1e-9
            for _ in range(work):
                x = math.sqrt(x * 1.0000001 + 1e-7)
            out[b] = x

    return region


def ideal_threads(threads, region_us: float = 150.0, total_s: float = 0.3, repeat: int = 3) -> dict:
    """Speed-up of a perfectly parallel compute-bound loop (no memory traffic, no shared data):
    the machine's own ceiling for threads 1 -> t (clock and core sharing included), with
    parallel regions of about ``region_us`` microseconds of one-thread work, as the engine's;
    the best of ``repeat`` runs per thread count, interleaved."""
    import numba

    region = _ideal_kernel()
    chunks = 16 * max(threads)
    out = np.zeros(chunks)
    region(out, 10)
    numba.set_num_threads(1)
    w0 = time.perf_counter()
    region(out, 100_000)
    per_iter = (time.perf_counter() - w0) / (100_000 * chunks)
    work = max(1, int(region_us * 1e-6 / (per_iter * chunks)))
    reps = max(3, int(total_s / (region_us * 1e-6)))
    rates = {}
    for _ in range(repeat):
        for t in threads:
            numba.set_num_threads(t)
            region(out, work)
            w0 = time.perf_counter()
            for _ in range(reps):
                region(out, work)
            rates[t] = max(rates.get(t, 0.0), reps / (time.perf_counter() - w0))
    numba.set_num_threads(max(threads))
    return rates


LAYER_CHILD = r"""
import json, time, numba, numpy as np
@numba.njit(parallel=True)
def region(x):
    for b in numba.prange(x.shape[0]):
        x[b] += 1.0
@numba.njit
def many(x, k):
    for _ in range(k):
        region(x)
x = np.zeros(64)
many(x, 10)
out = {"layer": numba.threading_layer()}
for t in (1, TOP_THREADS):
    numba.set_num_threads(min(t, numba.config.NUMBA_NUM_THREADS))
    w = time.perf_counter(); many(x, 20000)
    out[t] = (time.perf_counter() - w) / 20000 * 1e6
print(json.dumps(out))
"""


def layer_costs(threads: int = 2) -> list[tuple[str, str]]:
    """Microseconds per (empty) parallel region at 1 and ``threads`` threads for each threading
    layer, each in a child process (a process keeps the layer it started)."""
    import json
    import subprocess

    from granwave.threads import SPIN_COUNT

    rows = []
    variants = ((f"omp (spin {SPIN_COUNT}, granwave's default)", "omp", {"GOMP_SPINCOUNT": str(SPIN_COUNT)}),
                ("omp (spin 100000, granwave's default before 2026-11-26)", "omp", {"GOMP_SPINCOUNT": "100000"}),
                ("omp (passive)", "omp", {"OMP_WAIT_POLICY": "PASSIVE"}),
                ("omp (active)", "omp", {"OMP_WAIT_POLICY": "ACTIVE"}),
                ("workqueue", "workqueue", {}), ("tbb", "tbb", {}))
    for name, layer, extra in variants:
        env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
        env["NUMBA_THREADING_LAYER"] = layer
        env.update(extra)
        r = subprocess.run([sys.executable, "-c", LAYER_CHILD.replace("TOP_THREADS", str(threads))], env=env,
                           capture_output=True, text=True)
        if r.returncode != 0:
            rows.append((name, "not available"))
            continue
        out = json.loads(r.stdout.strip().splitlines()[-1])
        rows.append((name, f"{out['1']:.1f} us (1 thread), {out[str(threads)]:.1f} us ({threads} threads)"))
    return rows


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip() + f", {os.cpu_count()} logical cores"
    except OSError:
        pass
    return f"{os.cpu_count()} cores"


def per_core_vs_lammps(packing, steps: int, repeat: int = 3) -> tuple[float, float | None, str]:
    """Best of ``repeat`` runs of each code, alternated (one run each was at the mercy of
    whichever of the two met a busy moment of the shared host)."""
    import numba
    from dem import engine_rate, lammps_rate

    numba.set_num_threads(1)
    cpu, lmp, note = 0.0, None, ""
    for _ in range(max(1, repeat)):
        rate, _, _, dt = engine_rate(packing, 1, steps)
        cpu = max(cpu, rate)
        other, note = lammps_rate(packing, dt, steps)
        if other is None:
            break
        lmp = max(lmp or 0.0, other)
    return cpu, lmp, note


def dem_ceiling(packing, tiles: int, copies: int, steps: int, repeat: int, packing_file: str | None) -> dict:
    """The copies of :mod:`engine_copies`: ``copies`` one-thread processes at once, each on
    ``tiles / copies`` tiles (at least one; a thread's share of the state), the best of
    ``repeat`` runs by their summed rate while all ran at once (the window of
    engine_copies.summary): that summary and the tiles per copy."""
    import tempfile

    from engine_copies import run_copies, summary

    from granwave.io.files import write_packing

    per_copy = max(1, round(tiles / copies))
    copy_steps = max(100, 2 * steps * tiles // per_copy)  # twice a DEM run's grain-steps: runs that overlap
    with tempfile.TemporaryDirectory() as tmp:
        if packing_file is None:
            packing_file = str(Path(tmp) / "packing.h5")
            write_packing(packing_file, packing)
        best = None
        for rep in range(repeat):
            r = summary(run_copies(packing_file, copies, per_copy, copy_steps))
            print(f"  DEM ceiling, {copies} one-thread copies of {per_copy} tile(s), run {rep + 1}: "
                  f"{r['window']:.3g} grain-steps/s summed while all ran ({r['aggregate']:.3g} over their own "
                  f"runs, overlap {r['overlap']:.2f}); {load()}", flush=True)
            if best is None or r["window"] > best["window"]:
                best = r
    return dict(best, tiles=per_copy)


def dem_each_cpu(packing, tiles: int, steps: int, packing_file: str | None) -> dict[int, float]:
    """engine_copies.alone_on_each_cpu on the ``tiles``-tile state: {cpu: one-thread wall
    grain-steps/s}, ``steps`` timed steps each."""
    import tempfile

    from engine_copies import alone_on_each_cpu

    from granwave.io.files import write_packing

    with tempfile.TemporaryDirectory() as tmp:
        if packing_file is None:
            packing_file = str(Path(tmp) / "packing.h5")
            write_packing(packing_file, packing)
        rates = alone_on_each_cpu(packing_file, tiles, steps)
    for cpu, r in rates.items():
        print(f"  DEM one thread alone on CPU {cpu}: {r:.3g} grain-steps/s wall", flush=True)
    return rates


def main_table(quick: bool, write_docs: bool, threads=(1, 2), lammps: bool = True, tiles: int = 17,
               lattice_grains: int = 10_000, repeat: int = 3, regions_too: bool = False,
               engines_only: bool = False, packing_file: str | None = None, ceiling: bool = False,
               each_cpu: bool = False) -> None:
    from dem import prepare

    print(f"start: {load()}", flush=True)
    steal0 = steal_jiffies()
    if packing_file:  # the same packing, made elsewhere: no preparation (and its compilation) here
        from granwave.io.files import read_packing

        packing = read_packing(packing_file)
    else:
        packing, _, _ = prepare(1e-4)
    rows = []
    top = max(threads)
    steps = 200 if quick else 1000  # 400 steps (0.2 s) left the 2-thread run's fixed costs visible
    variants = dem_threads(packing, steps, threads, tiles, repeat, regions_too)
    same = len(set().union(*(s for d in variants for s in d["states"].values()))) == 1
    for d, how in zip(variants, ("", ", a region per pass")):
        r = d["rates"]
        for t in threads[1:]:
            rows.append((f"DEM threads 1 -> {t}, {d['grains']} grains{how} (wall grain-steps/s)",
                         f"{r[1]:.3g} -> {r[t]:.3g}", r[t] / r[1], GOALS.get(f"dem_{t}", float("nan")),
                         ("same bits" if same else "BITS DIFFER")
                         + f"; CPU time per step x{d['cpu'][1] / d['cpu'][t]:.2f} at {t} threads"
                         + f"; {d['count'][t]} grain blocks, boundary pairs {100 * d['fraction'][t]:.1f} %"
                         + (f"; {d['team_steps'][t]} of {steps + 20} steps in teams" if not how else "")))
    if ceiling:
        r = variants[0]["rates"]
        c = dem_ceiling(packing, tiles, top, steps, repeat, packing_file)
        rows.append((f"DEM ceiling at {top}: {top} one-thread copies of {c['tiles'] * packing.n_grains} grains "
                     "at once (summed wall grain-steps/s while all ran)", f"{r[1]:.3g} -> {c['window']:.3g}",
                     c["window"] / r[1], float("nan"),
                     f"over the first row's one thread; the engine at {top} threads: "
                     f"{100 * r[top] / c['window']:.0f} % of the copies' sum; the slowest copy times {top}: "
                     f"x{c['in_step'] / r[1]:.2f}; summed over their own runs x{c['aggregate'] / r[1]:.2f}"))
    if each_cpu:
        r = variants[0]["rates"]
        alone = sorted(dem_each_cpu(packing, tiles, steps, packing_file).values())
        mid = float(np.median(alone))
        rows.append((f"DEM one thread alone on each of {len(alone)} CPUs (pinned; wall grain-steps/s: "
                     "slowest / median / fastest)", f"{alone[0]:.3g} / {mid:.3g} / {alone[-1]:.3g}",
                     r[top] / mid, GOALS.get(f"dem_{top}", float("nan")),
                     f"the ratio: {top} threads' {r[top]:.3g} over the median CPU; over the fastest "
                     f"x{r[top] / alone[-1]:.2f}, over the slowest x{r[top] / alone[0]:.2f}; the first row's one "
                     f"thread ({r[1]:.3g}) was faster than {sum(a < r[1] for a in alone)} of them"))
    t_ = time_threads(lattice_grains, 100 if quick else 400, threads, repeat)
    s_ = t_["per_step"]
    for t in threads[1:]:
        rows.append((f"time domain threads 1 -> {t}, {t_['dof']} dofs (wall ms/step)",
                     f"{1e3 * s_[1]:.3g} -> {1e3 * s_[t]:.3g}", s_[1] / s_[t], GOALS.get(f"time_{t}", float("nan")),
                     ("same bits" if t_["same"] else "BITS DIFFER")
                     + f"; CPU time per step x{t_['cpu'][t] / t_['cpu'][1]:.2f} at {t} threads"))
    for region_us in () if engines_only else (150.0, 20_000.0):
        ideal = ideal_threads(threads, region_us, repeat=repeat)
        for t in threads[1:]:
            rows.append((f"ideal compute loop threads 1 -> {t}, regions of {region_us:g} us (ceiling)",
                         f"{ideal[1]:.3g} -> {ideal[t]:.3g} /s", ideal[t] / ideal[1], float("nan"),
                         "no memory traffic: the machine's clock and cores"))
    if lammps:
        cpu, lmp, note = per_core_vs_lammps(packing, 1000 if quick else 4000, repeat)
        if lmp is not None:
            rows.append(("per core, 600 grains, vs " + note + " (CPU grain-steps/s)",
                         f"{cpu:.3g} vs {lmp:.3g}", cpu / lmp, GOALS["lammps"], ""))
        else:
            rows.append(("per core, 600 grains (CPU grain-steps/s)", f"{cpu:.3g}", float("nan"),
                         GOALS["lammps"], note))
    layers = [] if engines_only else layer_costs(top)
    end = load()
    steal1 = steal_jiffies()
    steal = (steal1[0] - steal0[0]) / max(1, steal1[1] - steal0[1])
    end += f"; steal time {100 * steal:.1f} % of the CPU time over the run"
    print(f"end: {end}")
    width = max(len(x[0]) for x in rows)
    lines = [f"| {'measure':<{width}} | {'values':<22} | ratio | goal | note |",
             f"|{'-' * (width + 2)}|{'-' * 24}|-------|------|------|"]
    for name, vals, ratio, goal, note_ in rows:
        goal_ = f"{goal:4.1f}" if goal == goal else "  — "
        lines.append(f"| {name:<{width}} | {vals:<22} | {ratio:5.2f} | {goal_} | {note_} |")
    if layers:
        lines += ["", "Cost of one empty parallel region per threading layer (the engine runs two per step, "
                  "the time domain one per call, its phases separated by spin barriers):", ""]
    lines.insert(0, f"CPU: {_cpu_model()}; threads {', '.join(map(str, threads))}; each rate the best of "
                    f"{repeat} runs, thread counts interleaved\n")
    lines += [f"- {name}: {cost}" for name, cost in layers]
    table = "\n".join(lines)
    print(table)
    if write_docs:
        from granwave.io.files import replace_marked_block

        text = (f"Measured by `python benchmarks/scale.py` on {time.strftime('%Y-%m-%d', time.gmtime())}, "
                f"{os.cpu_count()} cores; {end} at the end of the run (a ratio measured on a loaded "
                "machine understates what a quiet one gives).\n\n" + table)
        for doc in (ROOT / "benchmarks" / "results" / "TABLES.md", ROOT / "docs" / "linear.md"):
            replace_marked_block(doc, BEGIN, END, text)
        print("wrote benchmarks/results/TABLES.md and docs/linear.md")


# ---------------------------------------------------------------- large runs
def _square_steps(height: float) -> float:
    """Relaxation steps at height ``height`` (d) by the steps model (2D, current protocol)."""
    return STEPS_1E4 * (height / 100.0) ** HEIGHT_EXPONENT


#: compaction of the large preparations when --compaction is not given: the rule every large run of
#: docs/dem.md was measured with (PrepareParams' default, 'fixed', takes steps ~ L^1.65: 5.4e6 for the
#: column by the steps model of --dry-run)
DEFAULT_LARGE_COMPACTION = "mean-flow"


def large_spec(name: str, tiny: bool, compaction: str | None = None, settling: str = "late",
               stop_at: int | None = None, end_game: str = "none"):
    from granwave.dem.params import PrepareParams

    compaction = compaction or DEFAULT_LARGE_COMPACTION
    max_steps = 20_000_000 if stop_at is None else stop_at  # a budget no large run reaches, unless asked

    if name == "column":
        n, aspect = (300, 4.0) if tiny else (21_000, 32.0)  # 25 x 800 d at solid fraction ~0.84
        return dict(params=PrepareParams(dim=2, grains=n, pressure=1e-4, aspect=aspect, compaction=compaction,
                                         mean_flow_settling=settling, max_steps=max_steps, end_game=end_game),
                    steps=_square_steps(800.0), note="2D column 25 x 800 d, p = 1e-4")
    if name == "grid2d":
        n = 300 if tiny else 100_000
        return dict(params=PrepareParams(dim=2, grains=n, pressure=1e-4, compaction=compaction,
                                         mean_flow_settling=settling, max_steps=max_steps, end_game=end_game),
                    steps=_square_steps(math.sqrt(n)), note="2D square, p = 1e-4")
    if name == "grid3d":
        n = 300 if tiny else 100_000
        return dict(params=PrepareParams(dim=3, grains=n, pressure=1e-4, friction=0.5, compaction=compaction,
                                         mean_flow_settling=settling, max_steps=max_steps, end_game=end_game),
                    steps=_square_steps(n ** (1 / 3)),
                    note="3D cube, mu = 0.5, p = 1e-4 (steps: the 2D model at the height, a guess)")
    if name == "time":
        side = 30 if tiny else 1000
        return dict(rows=side, width=side, note="2D frictional triangular lattice, one crossing")
    raise SystemExit(f"unknown large run {name!r}")


def large(name: str, dry_run: bool, tiny: bool, rate: float | None, compaction: str | None = None,
          settling: str = "late", stop_at: int | None = None, end_game: str = "none") -> None:
    from granwave import resources

    if stop_at is not None and name == "time":
        raise SystemExit("--stop-at: for a preparation (column, grid2d, grid3d), not the time domain")
    spec = large_spec(name, tiny, compaction, settling, stop_at, end_game)
    print(f"{name}: {spec['note']}; {load()}")
    if name == "time":
        rows, width = spec["rows"], spec["width"]
        n = rows * width
        n_dof, entries = 3 * n, 3 * n * 3 * 7  # 3 dofs, 6 neighbours + itself, 3 x 3 blocks
        need = 600.0 * n + 10 * 8 * n_dof + 40.0 * entries
        steps = 6800 * rows / 316  # one crossing: 6800 steps at 316 rows (docs/linear.md)
        minutes = steps * n_dof * 3e-8 / 60  # 9 ms per step at 3e5 dofs on one core (docs/linear.md)
        print(f"  {n} grains, {n_dof} dofs: estimated memory {resources.format_bytes(need)} "
              f"(available {resources.format_bytes(resources.available_memory())}); ~{steps:.3g} steps, "
              f"~{minutes:.0f} min on one core at the measured 30 ns per dof-step")
        if dry_run:
            return
        from linear import crossing_time

        from granwave.linear.assemble import linearize
        from granwave.linear.propagate import time_domain_signal
        from granwave.systems import triangular_lattice

        w0 = time.perf_counter()
        system = linearize(triangular_lattice(rows=rows, width=width, pressure=1e-4, friction=0.5), check=False)
        t_build = time.perf_counter() - w0
        w0 = time.perf_counter()
        sig = time_domain_signal(system, ic="A", t_max=crossing_time(system), samples=401,
                                 progress=print, progress_interval=10.0)
        print(f"  lattice + linearize {t_build:.1f} s; crossing {time.perf_counter() - w0:.1f} s wall, "
              f"{sig.attrs['n_steps']} steps; peak memory {resources.format_bytes(peak_memory())}")
        return
    p = spec["params"]
    print(f"  {p.grains} grains: estimated memory {resources.format_bytes(resources.prepare_bytes(p.grains, p.dim))} "
          f"(available {resources.format_bytes(resources.available_memory())}); steps model "
          f"~{spec['steps']:.3g}" + (f", at {rate:.3g} grain-steps/s ~{spec['steps'] * p.grains / rate / 60:.0f} min"
                                    if rate else ""))
    if dry_run:
        return
    from granwave.dem.protocol import prepare_packing
    from granwave.errors import StepBudgetExceeded

    w0, c0 = time.perf_counter(), time.process_time()
    try:
        pk = prepare_packing(p, progress=print)
    except StepBudgetExceeded:  # any other failure (a blow-up) is raised as it is
        if stop_at is None:
            raise
        print(f"  stopped after {stop_at} steps as asked (--stop-at), {time.perf_counter() - w0:.1f} s wall "
              f"({time.process_time() - c0:.1f} s CPU; {load()}); peak memory {resources.format_bytes(peak_memory())}")
        return
    print(f"  compaction {p.compaction} (settling {p.mean_flow_settling}, end game {p.end_game}): prepared in {time.perf_counter() - w0:.1f} s wall "
          f"({time.process_time() - c0:.1f} s CPU; {load()}), {pk.attrs['steps']} steps; "
          f"peak memory {resources.format_bytes(peak_memory())}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps (a smoke run)")
    ap.add_argument("--write-docs", action="store_true", help="write the table into benchmarks/results/TABLES.md, docs/linear.md")
    ap.add_argument("--threads", default="1,2",
                    help="comma-separated thread counts, 1 first (e.g. 1,2,4,8,16 on a 16-core machine)")
    ap.add_argument("--no-lammps", action="store_true", help="skip the per-core comparison with LAMMPS")
    ap.add_argument("--tiles", type=int, default=17,
                    help="DEM state: the 600-grain packing tiled this many times (17: 10200 grains)")
    ap.add_argument("--lattice-grains", type=int, default=10_000, help="time-domain lattice size (grains)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per thread count (the best counts)")
    ap.add_argument("--blocks-per-thread", type=int, default=None,
                    help="DEM blocks per thread above 4 threads (the engine's BLOCKS_PER_THREAD, default "
                         "2; 4 and 8 were slower at 16 threads, docs/decisions/0004-parallel-passes.md)")
    ap.add_argument("--regions-too", action="store_true",
                    help="also time the DEM with a parallel region per pass instead of the team of "
                         "threads (alternated in each repetition)")
    ap.add_argument("--engines-only", action="store_true",
                    help="only the DEM and time-domain rows (no ideal loops, no region costs; with --no-lammps "
                         "a short run on a lent machine)")
    ap.add_argument("--packing", default=None,
                    help="the 600-grain packing at p = 1e-4 from a file (granwave prepare-packing --pressure 1e-4) "
                         "instead of preparing it here")
    ap.add_argument("--ceiling", action="store_true",
                    help="also the DEM's ceiling at the largest thread count: as many one-thread processes at "
                         "once, each on a thread's share (benchmarks/engine_copies.py)")
    ap.add_argument("--each-cpu", action="store_true",
                    help="also the one-thread DEM rate alone on each allowed CPU in turn (pinned), and the largest "
                         "thread count's rate over the fastest, median and slowest of them")
    ap.add_argument("--large", choices=("column", "grid2d", "grid3d", "time"), help="one large run")
    ap.add_argument("--dry-run", action="store_true", help="with --large: estimates only")
    ap.add_argument("--tiny", action="store_true", help="with --large: the same path at a tiny size")
    ap.add_argument("--rate", type=float, default=None,
                    help="with --large --dry-run: grain-steps/s for the time estimate (e.g. from the table)")
    ap.add_argument("--compaction", choices=("fixed", "height-scaled", "mean-flow"), default=None,
                    help="with --large column|grid2d|grid3d: the compaction rule (docs/dem.md; default "
                         f"{DEFAULT_LARGE_COMPACTION}, the rule of the documented runs)")
    ap.add_argument("--settling", choices=("late", "compaction", "critical"), default="late",
                    help="with --large column|grid2d|grid3d and the mean-flow compaction: the mean flow's settling rule "
                         "(default: PrepareParams' default, 'late'; docs/dem.md 'Late settling')")
    ap.add_argument("--end-game", choices=("none", "adaptive"), default="none",
                    help="with --large column|grid2d|grid3d: the end-game rule (default: PrepareParams' default, "
                         "'none'; docs/dem.md 'End game')")
    ap.add_argument("--stop-at", type=int, default=None, metavar="STEPS",
                    help="with --large column|grid2d|grid3d: stop the preparation after STEPS steps (to compare "
                         "its progress lines with another run's: benchmarks/investigations/same_progress.py)")
    args = ap.parse_args()
    if args.stop_at is not None and (not args.large or args.stop_at < 1):
        raise SystemExit("--stop-at: a positive number of steps, with --large")
    if args.blocks_per_thread is not None:
        from granwave.dem import blocks

        if args.blocks_per_thread < 1:
            raise SystemExit("--blocks-per-thread: at least 1")
        blocks.BLOCKS_PER_THREAD = args.blocks_per_thread  # read by block_count when an engine starts
    if args.engines_only and args.write_docs:
        raise SystemExit("--engines-only: a partial table; not with --write-docs")
    if args.large:
        large(args.large, args.dry_run, args.tiny, args.rate, args.compaction, args.settling, args.stop_at,
              args.end_game)
    else:
        threads = tuple(int(t) for t in args.threads.split(","))
        if threads[0] != 1 or len(threads) < 2:
            raise SystemExit("--threads: a list starting with 1, e.g. 1,2 or 1,2,4,8,16")
        main_table(args.quick, args.write_docs, threads, lammps=not args.no_lammps, tiles=args.tiles,
                   lattice_grains=args.lattice_grains, repeat=args.repeat, regions_too=args.regions_too,
                   engines_only=args.engines_only, packing_file=args.packing, ceiling=args.ceiling,
                   each_cpu=args.each_cpu)


if __name__ == "__main__":
    main()
