"""What would 16 threads give if they never waited for each other? (a script, not a test)

    python benchmarks/engine_copies.py --packing FILE [--copies 1,8,16] [--tiles 1]
        [--baseline-tiles 17] [--steps 40000] [--repeat 2] [--pin no|yes|both]

The DEM engine's threads 1 -> 16 on the 10^4-grain benchmark state of scale.py ran 5.2-7.9x on
the lent 16-vCPU machines (docs/dem.md "Sixteen cores"), and the team's timers said that the
threads' summed busy time per step was 1.5-1.9 times one thread's step: the work slows down
when all vCPUs run, besides the waiting. This script measures that slow-down for the engine's
own work with no threads, no blocks, no pairs across blocks and no waiting at all: ``C``
separate processes at once (``C`` from ``--copies``), each running the one-thread engine (the
single pair loop, exactly the code of scale.py's one-thread run) on its own copy of the
benchmark state made of ``--tiles`` tiles of the 600-grain packing. With ``--tiles 1`` each copy
has 600 grains, about a thread's share of the 10 200-grain state at 16 threads (637 grains), so
each core's working set is the one it has in the threaded run.

Printed per copy count (the best of ``--repeat`` runs by aggregate rate, copy counts and
pinnings alternated in each repetition):

- the copies' own rates (grain-steps per wall second: slowest, median, fastest);
- the aggregate (their sum) and its ratio to one copy alone ("throughput ratio": C where
  nothing is shared);
- the overlap: the time all copies ran at once over the mean copy's run (near 1: the sum is a
  rate of simultaneous work);
- the ceiling for scale.py's ratio: the aggregate over the rate of one thread alone on the
  ``--baseline-tiles`` state (scale.py's one-thread denominator, measured in the same run). No
  synchronization design of the threaded engine can beat this on that machine at that moment
  unless its threads' work is cheaper than a copy's; the threaded engine shares one state
  (less memory in all than C copies), which this does not capture.

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
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))


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
    c0, t0 = time.process_time(), time.time()
    eng.run(args.steps)
    t1, c1 = time.time(), time.process_time()
    print(json.dumps({"start": t0, "end": t1, "cpu": c1 - c0, "grains": len(eng.radius),
                      "steps": args.steps}), flush=True)


def run_copies(packing_file: str, copies: int, tiles: int, steps: int, pin: bool = False) -> list[dict]:
    """``copies`` processes at once, each the one-thread engine on a ``tiles``-tile state of the
    packing in ``packing_file``, ``steps`` timed steps; per copy its start and end (wall clock),
    CPU seconds, grains and steps."""
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    cpus = sorted(os.sched_getaffinity(0))
    procs = []
    for k in range(copies):
        cpu = cpus[k % len(cpus)] if pin else -1
        cmd = [sys.executable, __file__, "--child", "--packing", packing_file, "--tiles", str(tiles),
               "--steps", str(steps), "--cpu", str(cpu)]
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


def summary(results: list[dict]) -> dict:
    """The copies' rates (grain-steps per wall second, ascending), their sum, the overlap of
    their runs, their mean CPU over wall time and a copy's grains."""
    rates = sorted(r["grains"] * r["steps"] / (r["end"] - r["start"]) for r in results)
    walls = [r["end"] - r["start"] for r in results]
    together = min(r["end"] for r in results) - max(r["start"] for r in results)
    return {"rates": rates, "aggregate": sum(rates), "overlap": max(0.0, together) / statistics.mean(walls),
            "cpu_over_wall": statistics.mean(r["cpu"] / (r["end"] - r["start"]) for r in results),
            "grains": results[0]["grains"]}


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
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--cpu", type=int, default=-1, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return
    counts = [int(x) for x in args.copies.split(",")]
    if counts[0] != 1:
        sys.exit("--copies must start with 1")
    pins = {"no": [False], "yes": [True], "both": [False, True]}[args.pin]
    run_copies(args.packing, 1, 1, 10)  # compiles the one-thread kernels into the cache
    print(f"{os.cpu_count()} CPUs, {len(os.sched_getaffinity(0))} allowed; load {os.getloadavg()[0]:.2f}",
          flush=True)
    best: dict[tuple, dict] = {}
    base = 0.0
    for _ in range(args.repeat):
        if args.baseline_tiles:
            r = summary(run_copies(args.packing, 1, args.baseline_tiles, args.baseline_steps))
            base = max(base, r["aggregate"])
        for pin in pins:
            for c in counts:
                r = summary(run_copies(args.packing, c, args.tiles, args.steps, pin))
                key = (pin, c)
                if key not in best or r["aggregate"] > best[key]["aggregate"]:
                    best[key] = r
                print(f"  run: pin {pin}, {c} copies: aggregate {r['aggregate']:.3e}, overlap {r['overlap']:.2f}",
                      flush=True)
    grains = best[pins[0], 1]["grains"]
    print(f"\ncopies of {args.tiles} tile(s) ({grains} grains), {args.steps} steps each; best of {args.repeat}")
    if base:
        print(f"one thread alone on {args.baseline_tiles} tiles (scale.py's one-thread state): {base:.3e} "
              f"grain-steps/s")
    print("| pinned | copies | per copy: slowest / median / fastest (grain-steps/s) | aggregate | "
          "throughput ratio | overlap | CPU / wall per copy | ceiling for scale.py's ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for pin in pins:
        one = best[pin, 1]["aggregate"]
        for c in counts:
            r = best[pin, c]
            ceiling = f"{r['aggregate'] / base:.2f}" if base else "-"
            print(f"| {'yes' if pin else 'no'} | {c} | {r['rates'][0]:.3e} / {statistics.median(r['rates']):.3e} / "
                  f"{r['rates'][-1]:.3e} | {r['aggregate']:.3e} | {r['aggregate'] / one:.2f} | "
                  f"{r['overlap']:.2f} | {r['cpu_over_wall']:.2f} | {ceiling} |")


if __name__ == "__main__":
    main()
