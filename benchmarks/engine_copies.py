"""What would 16 threads give if they never waited for each other? (a script, not a test)

    python benchmarks/engine_copies.py --packing FILE [--copies 1,8,16] [--tiles 1]
        [--baseline-tiles 17] [--steps 40000] [--repeat 2] [--pin no|yes|both]
        [--kind processes,threads,threads-main] [--chunk 1000]

The DEM engine's threads 1 -> 16 on the 10^4-grain benchmark state of scale.py ran 5.2-7.9x on
the lent 16-vCPU machines (docs/decisions/0004-parallel-passes.md), and the team's timers said that the
threads' summed busy time per step was 1.5-1.9 times one thread's step: the work slows down
when all vCPUs run, besides the waiting. This script measures that slow-down for the engine's
own work with no threads, no blocks, no pairs across blocks and no waiting at all: ``C``
separate processes at once (``C`` from ``--copies``), each running the one-thread engine (the
single pair loop, exactly the code of scale.py's one-thread run) on its own copy of the
benchmark state made of ``--tiles`` tiles of the 600-grain packing. With ``--tiles 1`` each copy
has 600 grains, about a thread's share of the 10 200-grain state at 16 threads (637 grains), so
each core's working set is the one it has in the threaded run.

Printed per kind and copy count (the best of ``--repeat`` runs by the window's rate; kinds,
pinnings and copy counts alternated in each repetition):

- the copies' own rates (grain-steps per wall second over each copy's run: slowest, median,
  fastest) and their sum;
- the window: the copies' summed rate over the time all ran at once (from the last start to
  the first end; each copy's steps in it interpolated between its progress marks, one every
  ``--chunk`` steps). The sum over the copies' own runs also counts a copy's time after others
  had finished, on freer cores; the window does not;
- in step: the slowest copy's rate in the window times C, what a step that waits for every
  thread would get if each thread did a copy's work on an equal share;
- the window's rate over one copy alone ("throughput ratio": C where nothing is shared), and
  the overlap (the window over the mean copy's run);
- the ceiling for scale.py's ratio: the window's rate, and the in-step rate, over the rate of
  one thread alone on the ``--baseline-tiles`` state (scale.py's one-thread denominator,
  measured in the same run). No synchronization design of the threaded engine can beat the
  first on that machine at that moment unless its threads' work is cheaper than a copy's, nor
  the second without moving work from slow threads to fast ones within a step; the threaded
  engine shares one state (less memory in all than C copies), which this does not capture.

``--kind`` says what a copy is: ``processes`` (below), ``threads`` (threads of this process,
each making its own state and stepping it with the GIL released: the one-thread kernel behind a
``nogil`` wrapper) or ``threads-main`` (the same, the states made by the main thread, so that
their memory was first written there). Processes against threads tells whether being threads of
one process (one address space, one allocator, pages first written by another thread) slows the
work; docs/decisions/0004-parallel-passes.md.

Each copy runs in a fresh interpreter with one numba thread (NUMBA_NUM_THREADS=1); the kernels
are compiled once by this process before the copies start, so they load them from the cache.
The copies build their engines, then all start their timed steps on one signal. With ``--pin
yes`` copy k is bound to CPU k of the allowed set (``os.sched_setaffinity``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import granwave.threads  # noqa: E402,F401  (threading layer first)
import numba  # noqa: E402
import numpy as np  # noqa: E402

from granwave.dem import kernels as K  # noqa: E402
from granwave.dem import serial  # noqa: E402


def timed_run(eng, steps: int, chunk: int, run) -> dict:
    """``steps`` steps of ``eng`` by ``run(eng, n)``, ``chunk`` at a time, with a mark (wall
    clock, steps done) before the first and after each chunk."""
    marks = [(time.time(), 0)]
    c0 = time.thread_time()  # this thread's: the copies may be threads of one process
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        run(eng, n)
        done += n
        marks.append((time.time(), done))
    return {"start": marks[0][0], "end": marks[-1][0], "cpu": time.thread_time() - c0,
            "grains": len(eng.radius), "steps": steps, "marks": marks}


def child(args) -> None:
    """One copy: build the engine, say ready, wait for the go line, run, report as JSON."""
    if args.cpu >= 0:
        os.sched_setaffinity(0, {args.cpu})
    import granwave.threads  # noqa: F401  (threading layer first)
    from dem import benchmark_engine

    from granwave.io.files import read_packing

    eng = benchmark_engine(read_packing(args.packing), args.tiles)
    print("ready", flush=True)
    sys.stdin.readline()
    r = timed_run(eng, args.steps, args.chunk, lambda e, n: e.run(n))
    print(json.dumps(r), flush=True)


def run_copies(packing_file: str, copies: int, tiles: int, steps: int, pin: bool = False,
               chunk: int = 1000, cpus: list[int] | None = None) -> list[dict]:
    """``copies`` processes at once, each the one-thread engine on a ``tiles``-tile state of the
    packing in ``packing_file``, ``steps`` timed steps; per copy its start and end (wall clock),
    CPU seconds, grains, steps and marks (wall clock, steps done) every ``chunk`` steps. With
    ``pin`` copy k is bound to CPU k of ``cpus`` (cyclically; default: the allowed set)."""
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    cpus = sorted(os.sched_getaffinity(0)) if cpus is None else list(cpus)
    procs = []
    for k in range(copies):
        cpu = cpus[k % len(cpus)] if pin else -1
        cmd = [sys.executable, __file__, "--child", "--packing", packing_file, "--tiles", str(tiles),
               "--steps", str(steps), "--chunk", str(chunk), "--cpu", str(cpu)]
        procs.append(subprocess.Popen(cmd, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True))
    for p in procs:
        line = p.stdout.readline()
        if line.strip() != "ready":
            for q in procs:
                q.kill()
            sys.exit(f"a copy did not start: {line!r}")
    for p in procs:  # the go signal, to all as close together as a loop can
        p.stdin.write("go\n")
        p.stdin.flush()
    results = []
    for p in procs:
        out, _ = p.communicate()
        if p.returncode != 0:
            sys.exit(f"a copy failed (exit {p.returncode})")
        results.append(json.loads(out.strip().splitlines()[-1]))
    return results


@numba.njit(cache=True, nogil=True)
def _serial_chunk_released(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j,
                           pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws):
    """The one-thread engine's chunk (granwave.dem.serial.run_chunk) with the GIL released, so
    that Python threads run copies at once."""
    return serial.run_chunk(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j,
                            pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws)


def run_released(eng, n_steps: int) -> int:
    """``eng.run(n_steps)`` for a one-thread engine (the single pair loop), the GIL released
    while it steps: the same kernel and the same statuses."""
    target = eng.steps + int(n_steps)
    while eng.steps < target:
        eng.ipar.nsteps = target - eng.steps
        status = _serial_chunk_released(eng.position, eng.velocity, eng.acceleration, eng.angular_velocity,
                                        eng.angular_acceleration, eng.radius, eng.mass, eng.inertia,
                                        eng.lateral, eng.pos0, eng.pair_i, eng.pair_j, eng.pair_ft,
                                        eng.pair_ov, eng.wall_ft, eng.wall_ov, eng.piston, eng.fpar,
                                        eng.ipar, eng.out, eng.ws)
        if status == 2:
            eng.grow(int(eng.ipar.needed), int(eng.ipar.width))
            continue
        if status in (1, 3):
            return status
    return 0


def run_thread_copies(packing_file: str, copies: int, tiles: int, steps: int, pin: bool = False,
                      chunk: int = 1000, build_in_thread: bool = True) -> list[dict]:
    """As :func:`run_copies`, but the copies are ``copies`` threads of this process, each
    running the one-thread engine on its own state (:func:`run_released`). With
    ``build_in_thread`` each thread makes its own state (its arrays first written by that
    thread, from its own allocator arena); otherwise this thread makes them all, one after the
    other, and hands them out."""
    from dem import benchmark_engine

    from granwave.io.files import read_packing

    packing = read_packing(packing_file)
    cpus = sorted(os.sched_getaffinity(0))
    engines = [None] * copies if build_in_thread else [benchmark_engine(packing, tiles) for _ in range(copies)]
    results: list = [None] * copies
    errors: list = []
    go = threading.Barrier(copies + 1)

    def work(k: int) -> None:
        try:
            numba.set_num_threads(1)  # per thread: the rebuild's parallel loops run on this one
            if pin:
                os.sched_setaffinity(0, {cpus[k % len(cpus)]})  # 0: the calling thread
            if build_in_thread:
                engines[k] = benchmark_engine(packing, tiles)
            go.wait()
            results[k] = timed_run(engines[k], steps, chunk, run_released)
        except BaseException as e:  # noqa: BLE001  (reported below)
            errors.append(e)
            go.abort()

    workers = [threading.Thread(target=work, args=(k,)) for k in range(copies)]
    for w in workers:
        w.start()
    try:
        go.wait()
    except threading.BrokenBarrierError:
        pass
    for w in workers:
        w.join()
    if errors:
        raise errors[0]
    return results


def alone_on_each_cpu(packing_file: str, tiles: int, steps: int) -> dict[int, float]:
    """One copy alone, bound to each allowed CPU in turn (one after the other, nothing else of
    this script running): {cpu: its grain-steps per wall second}. On the lent 16-vCPU machines
    one thread's rate depended on the vCPU it ran on 
    (docs/decisions/0004-parallel-passes.md), so a ratio over one unpinned one-thread run depends on where that run landed."""
    rates = {}
    for cpu in sorted(os.sched_getaffinity(0)):
        rates[cpu] = summary(run_copies(packing_file, 1, tiles, steps, pin=True, cpus=[cpu]))["aggregate"]
    return rates


def summary(results: list[dict]) -> dict:
    """The copies' rates (grain-steps per wall second over each copy's own run, ascending),
    their sum, the overlap of their runs, their mean CPU over wall time and a copy's grains;
    and over the window in which all ran at once (from the last start to the first end, each
    copy's steps in it interpolated between its marks): their summed rate ("window") and the
    slowest copy's times the copies ("in step": what a step that waits for every copy would
    get, each doing an equal share). The sum over the copies' own runs counts the time a copy
    ran after others had finished, on freer cores; the window does not."""
    rates = sorted(r["grains"] * r["steps"] / (r["end"] - r["start"]) for r in results)
    walls = [r["end"] - r["start"] for r in results]
    w0 = max(r["start"] for r in results)
    w1 = min(r["end"] for r in results)
    together = w1 - w0
    in_window = []
    if together > 0:
        for r in results:
            t, k = np.array(r["marks"]).T
            in_window.append(r["grains"] * (np.interp(w1, t, k) - np.interp(w0, t, k)) / together)
    return {"rates": rates, "aggregate": sum(rates), "overlap": max(0.0, together) / statistics.mean(walls),
            "cpu_over_wall": statistics.mean(r["cpu"] / (r["end"] - r["start"]) for r in results),
            "grains": results[0]["grains"],
            "window": sum(in_window) if in_window else float("nan"),
            "in_step": len(results) * min(in_window) if in_window else float("nan")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--packing", required=True, help="the 600-grain packing (granwave prepare-packing)")
    ap.add_argument("--copies", default="1,8,16", help="comma-separated copy counts, 1 first")
    ap.add_argument("--tiles", type=int, default=1, help="tiles of the packing per copy")
    ap.add_argument("--baseline-tiles", type=int, default=17,
                    help="tiles of the one-thread baseline (scale.py's state: 17); 0: none")
    ap.add_argument("--steps", type=int, default=40_000, help="timed steps per copy")
    ap.add_argument("--baseline-steps", type=int, default=3000, help="timed steps of the baseline")
    ap.add_argument("--repeat", type=int, default=2, help="runs per copy count (the best counts)")
    ap.add_argument("--pin", choices=("no", "yes", "both"), default="no", help="bind copy k to CPU k")
    ap.add_argument("--kind", default="processes",
                    help="comma-separated kinds of copies, alternated: processes, threads (threads of one "
                         "process, each making its own state), threads-main (states made by the main thread)")
    ap.add_argument("--chunk", type=int, default=1000, help="steps between a copy's progress marks")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--cpu", type=int, default=-1, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return
    counts = [int(x) for x in args.copies.split(",")]
    if counts[0] != 1:
        sys.exit("--copies must start with 1")
    kinds = args.kind.split(",")
    runners = {"processes": run_copies, "threads": run_thread_copies,
               "threads-main": lambda *a, **k: run_thread_copies(*a, **k, build_in_thread=False)}
    if any(k not in runners for k in kinds):
        sys.exit(f"--kind: one of {', '.join(runners)}")
    pins = {"no": [False], "yes": [True], "both": [False, True]}[args.pin]
    run_copies(args.packing, 1, 1, 10)  # compiles the one-thread kernels into the cache
    if set(kinds) - {"processes"}:
        run_thread_copies(args.packing, 1, 1, 10)  # and the chunk that releases the GIL
    print(f"{os.cpu_count()} CPUs, {len(os.sched_getaffinity(0))} allowed; load {os.getloadavg()[0]:.2f}",
          flush=True)
    best: dict[tuple, dict] = {}
    base = 0.0
    for _ in range(args.repeat):
        if args.baseline_tiles:
            r = summary(run_copies(args.packing, 1, args.baseline_tiles, args.baseline_steps))
            base = max(base, r["aggregate"])
        for kind in kinds:
            for pin in pins:
                for c in counts:
                    r = summary(runners[kind](args.packing, c, args.tiles, args.steps, pin, args.chunk))
                    key = (kind, pin, c)
                    if key not in best or r["window"] > best[key]["window"]:
                        best[key] = r
                    print(f"  run: {kind}, pin {pin}, {c} copies: aggregate {r['aggregate']:.3e}, window "
                          f"{r['window']:.3e}, in step {r['in_step']:.3e}, overlap {r['overlap']:.2f}", flush=True)
    grains = best[kinds[0], pins[0], 1]["grains"]
    print(f"\ncopies of {args.tiles} tile(s) ({grains} grains), {args.steps} steps each; best of {args.repeat} "
          f"by the window's rate")
    if base:
        print(f"one thread alone on {args.baseline_tiles} tiles (scale.py's one-thread state): {base:.3e} "
              f"grain-steps/s")
    print("| kind | pinned | copies | per copy: slowest / median / fastest (grain-steps/s) | sum of own runs | "
          "window (all at once) | in step (slowest x copies) | window over one copy alone | overlap | "
          "CPU / wall | ceiling for scale.py's ratio: window / in step |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for kind in kinds:
        for pin in pins:
            one = best[kind, pin, 1]["window"]
            for c in counts:
                r = best[kind, pin, c]
                ceiling = f"{r['window'] / base:.2f} / {r['in_step'] / base:.2f}" if base else "-"
                print(f"| {kind} | {'yes' if pin else 'no'} | {c} | {r['rates'][0]:.3e} / "
                      f"{statistics.median(r['rates']):.3e} / {r['rates'][-1]:.3e} | {r['aggregate']:.3e} | "
                      f"{r['window']:.3e} | {r['in_step']:.3e} | {r['window'] / one:.2f} | {r['overlap']:.2f} | "
                      f"{r['cpu_over_wall']:.2f} | {ceiling} |")


if __name__ == "__main__":
    main()
