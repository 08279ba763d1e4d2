"""How much throughput do the machine's cores give together? (a script, not a test)

    python benchmarks/investigations/core_throughput.py [--threads 1,2,4,8,16] [--repeat 3]

The engines' ratios at 16 threads (docs/dem.md "Sixteen cores") are bounded by what the
machine's 16 vCPUs give to code like theirs. scale.py's "ideal compute loop" is a dependent
chain of multiply-adds and square roots: it is bound by the latency of one instruction after
the other, and two hardware threads of one physical core run two such chains almost as fast
as two cores would. Code bound by throughput (the vector units, the L2 cache, memory) is not:
where a virtual machine's vCPUs are hardware threads that share physical cores with each other
(or with other machines' vCPUs), they share those units too. Four kinds of work, each thread
doing as much as one thread does alone (weak scaling: with no sharing, T threads take the time
of one), one parallel region per run (long regions: no barrier cost):

- ``chain``: a dependent chain of multiply-adds and square roots (latency-bound, no memory);
- ``fma``: independent multiply-adds over a 16 KB array per thread (vector units, L1);
- ``l2``: the same over 768 KB per thread (the L2 cache's bandwidth; the engines' share of a
  10^4-grain state is of this size at 16 threads);
- ``mem``: the same over 32 MB per thread (memory bandwidth).

Printed per kind and thread count: the throughput of T threads over one thread's
(T x t_1 / t_T; T where nothing is shared), the best of ``--repeat`` runs, thread counts
interleaved.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import granwave.threads  # noqa: E402,F401  (threading layer first)
import numba  # noqa: E402

#: name -> (float64 elements per thread, passes over them per run)
KINDS = {"chain": (1, 4_000_000), "fma": (2048, 200_000), "l2": (98_304, 3200), "mem": (4_194_304, 40)}


@numba.njit(parallel=True, cache=True)
def _run(kind, buf, passes, out):
    """One region: thread t runs ``passes`` of its kind of work on row t of ``buf``."""
    threads = buf.shape[0]
    for t in numba.prange(threads):
        row = buf[t]
        n = row.shape[0]
        if kind == 0:  # one dependent chain: each step waits for the last
            x = row[0]
            for _ in range(passes):
                x = np.sqrt(x * x * 0.5 + 1.0)
            out[t] = x
        else:  # independent updates: the vector units, or the cache / memory behind them
            for _ in range(passes):
                for i in range(n):
                    row[i] = row[i] * 0.999 + 0.001
            out[t] = row[n - 1]


def measure(kind: str, threads: int) -> float:
    size, passes = KINDS[kind]
    numba.set_num_threads(threads)
    buf = np.ones((threads, size))
    out = np.zeros(threads)
    code = list(KINDS).index(kind)
    _run(code, buf, 1, out)  # touch the pages from their threads, warm the caches
    t0 = time.perf_counter()
    _run(code, buf, passes, out)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts, 1 first")
    ap.add_argument("--repeat", type=int, default=3, help="runs per kind and thread count (the best counts)")
    ap.add_argument("--kinds", default=",".join(KINDS), help="comma-separated kinds of work")
    args = ap.parse_args()
    threads = [int(x) for x in args.threads.split(",")]
    kinds = args.kinds.split(",")
    if threads[0] != 1:
        sys.exit("--threads must start with 1")
    if max(threads) > numba.config.NUMBA_NUM_THREADS:
        sys.exit(f"--threads: at most {numba.config.NUMBA_NUM_THREADS} here")
    best: dict[tuple[str, int], float] = {}
    for _ in range(args.repeat):
        for kind in kinds:
            for t in threads:
                s = measure(kind, t)
                best[kind, t] = min(best.get((kind, t), s), s)
    print(f"{numba.config.NUMBA_NUM_THREADS} threads available; throughput of T threads over one "
          f"thread's (T x t_1 / t_T), best of {args.repeat}")
    print("| kind | one thread (ms) | " + " | ".join(f"T = {t}" for t in threads[1:]) + " |")
    print("|---|---|" + "---|" * (len(threads) - 1))
    for kind in kinds:
        one = best[kind, 1]
        print(f"| {kind} | {1e3 * one:.1f} | " + " | ".join(f"{t * one / best[kind, t]:.2f}" for t in threads[1:])
              + " |")


if __name__ == "__main__":
    main()
