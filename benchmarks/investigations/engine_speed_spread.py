"""What makes the same one-thread DEM run faster one time in five? (a script, not a test)

    python benchmarks/investigations/engine_speed_spread.py [--runs 24] [--steps 4000] [--record]

benchmarks/dem.py --vs-lammps gave granwave's one-thread engine a rate 30-50 % above its usual
one run in five, on the same state. The candidates named for it, each tested here on the
600-grain 2D frictional state of benchmarks/dem.py (fresh engine per run, the same 20 untimed
steps, so every run does the same arithmetic and the same neighbour rebuilds):

- the host: before and after every run, a fixed serial loop (benchmarks/dem.py's
  ``host_speed_seconds``) samples how fast the host runs this process; the correlation of the
  run times with those samples;
- memory placement: each run's arrays sit at new addresses; their offsets modulo 64 bytes (the
  cache line) against the run's rate;
- the threading layer's wait policy: CPU time of the process against its wall and thread time
  (spinning pool threads would add CPU time that no step uses);
- core affinity: runs pinned alternately to each vCPU;
- the neighbour rebuild's timing: the rebuild count of every run (the same state, so the same
  count unless the rule is not deterministic).

Printed: one line per run, then each candidate's verdict in numbers. ``--record`` appends the
summary to benchmarks/results/dem.jsonl.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent))

ARRAYS = ("position", "velocity", "acceleration", "radius", "pair_i", "pair_j", "pair_ft", "pair_ov")


def one_run(packing, steps: int, cpu: int | None) -> dict:
    """One fresh engine's ``steps`` steps (benchmarks/dem.py's state), pinned to ``cpu`` if given,
    with a host sample before and after."""
    import dem as B

    if cpu is not None:
        os.sched_setaffinity(0, {cpu})
    eng = B.benchmark_engine(packing, 1)
    before = B.host_speed_seconds()
    rebuilds = eng.rebuilds
    c0, w0, t0 = time.process_time(), time.perf_counter(), time.thread_time()
    eng.run(steps)
    cpu_s, wall, thread = time.process_time() - c0, time.perf_counter() - w0, time.thread_time() - t0
    after = B.host_speed_seconds()
    n = len(eng.radius)
    return dict(rate=n * steps / cpu_s, cpu=cpu_s, wall=wall, thread=thread, host=(before + after) / 2,
                rebuilds=eng.rebuilds - rebuilds, pinned=cpu,
                offsets={a: getattr(eng, a).ctypes.data % 64 for a in ARRAYS})


def verdicts(runs: list[dict]) -> dict:
    """Each candidate's number: spread of the rates, correlation with the host samples, the rate
    spread once divided by the host sample, the host-divided rate by the history's offset, CPU over wall time, rates
    per pinned vCPU, distinct rebuild counts."""
    rate = np.array([r["rate"] for r in runs])
    time_ = np.array([r["cpu"] for r in runs])
    host = np.array([r["host"] for r in runs])
    norm = time_ / host
    by_offset = {}  # host-divided rate by the offset of the pair history (the largest array a pair touches)
    for r in runs:
        by_offset.setdefault(r["offsets"]["pair_ft"], []).append(r["host"] / r["cpu"])
    per_cpu = {}
    for r in runs:
        if r["pinned"] is not None:
            per_cpu.setdefault(r["pinned"], []).append(r["rate"])
    return dict(
        rate_spread=float(rate.max() / rate.min()),
        rate_median=float(np.median(rate)),
        host_spread=float(host.max() / host.min()),
        correlation_time_host=float(np.corrcoef(time_, host)[0, 1]),
        spread_after_host_division=float(norm.max() / norm.min()),
        host_divided_rate_by_history_offset={str(k): round(float(statistics.median(v)), 4)
                                             for k, v in sorted(by_offset.items())},
        cpu_over_wall_max=float(max(r["cpu"] / r["wall"] for r in runs)),
        cpu_over_thread_max=float(max(r["cpu"] / r["thread"] for r in runs)),
        rate_median_per_vcpu={str(k): float(statistics.median(v)) for k, v in sorted(per_cpu.items())},
        rebuild_counts=sorted({r["rebuilds"] for r in runs}),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=24, help="fresh-engine runs (half free, half pinned)")
    ap.add_argument("--steps", type=int, default=4000, help="steps of each run")
    ap.add_argument("--record", action="store_true", help="append the summary to benchmarks/results/dem.jsonl")
    args = ap.parse_args()
    import numba

    import dem as B

    numba.set_num_threads(1)
    packing, _, _ = B.prepare(1e-4)
    every = sorted(os.sched_getaffinity(0))
    runs = []
    for k in range(args.runs):
        cpu = None if k < args.runs // 2 else every[k % len(every)]
        r = one_run(packing, args.steps, cpu)
        runs.append(r)
        print(f"run {k + 1}: {r['rate']:.3g} grain-steps/s CPU (wall {r['wall']:.3f} s, cpu {r['cpu']:.3f} s), "
              f"host sample {r['host'] * 1e3:.0f} ms, rebuilds {r['rebuilds']}, pinned {r['pinned']}, "
              f"offsets {r['offsets']}", flush=True)
    os.sched_setaffinity(0, set(every))
    v = verdicts(runs)
    print(json.dumps(v, indent=1))
    if args.record:
        from granwave.provenance import git_revision, machine, software

        key = "one-thread 600-grain engine, spread of the same run's rate (fresh engines)"
        value = (f"{v['rate_spread']:.2f}x; correlation of run time with a fixed loop's time "
                 f"{v['correlation_time_host']:.2f}; {v['spread_after_host_division']:.2f}x once divided by it")
        rec = dict(date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                   benchmark="dem", command=f"python benchmarks/investigations/engine_speed_spread.py "
                   f"--runs {args.runs} --steps {args.steps}", git_revision=git_revision(),
                   machine={"cpu": machine(), "short": f"{machine().split(', ')[1]}, {os.cpu_count()} vCPUs",
                            "software": software(),
                            "load average": " ".join(f"{x:.2f}" for x in os.getloadavg())},
                   summary={key: {"values": value}}, result=dict(verdicts=v, runs=runs))
        with open(HERE.parent / "results" / "dem.jsonl", "a") as f:
            f.write(json.dumps(rec) + "\n")


if __name__ == "__main__":
    main()
