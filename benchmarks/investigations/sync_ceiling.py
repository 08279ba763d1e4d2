"""Is the 16-thread ceiling of short parallel steps the barrier's? (a script, not a test)

    python benchmarks/investigations/sync_ceiling.py [--threads 1,2,4,8,16] [--step-us 150] [--phases 2]
        [--first-share 0.15] [--repeat 3]

The DEM engine at 10^4 grains reaches about what a perfectly parallel loop of its region size
reaches on the 16-vCPU machines of docs/dem.md ("Sixteen cores"): 5-6x at 16 threads, against
14-15x for the same loop with 20 ms regions. A short step that ends in a wait for every thread
lasts as long as its slowest thread, and some vCPU is late in most steps. A DEM step, though,
needs only its neighbours' previous step (a grain's force reads the positions within a contact
of it), so a thread could start step n + 1 as soon as the two threads beside it have finished
step n: a late vCPU then delays its neighbours by a step, and its lateness can be absorbed by the
slack of the threads further away, instead of stopping all of them at every step.

This script measures that ceiling before any engine is rebuilt for it. A ring of chunks (16 per
thread), each phase computing every chunk from itself and its two neighbours of the phase before
(a dependent chain of multiply-adds and square roots: no memory traffic, like scale.py's ideal
loop), ``--step-us`` microseconds of one thread's work per step, cut into ``--phases`` phases
(default 2, as the engine's two passes: the first ``--first-share`` of the work, then the rest),
each phase reading the neighbours' previous phase, in three ways:

- "regions": one numba ``prange`` region per phase (an OpenMP fork and join; the engine opens
  one per pass, two per step);
- "barrier": one region for all steps, the phases separated by granwave.team's spin barrier (the
  time domain's team);
- "neighbours": one region for all steps; thread t publishes the phases it has finished (an
  atomic store on its own cache line) and starts phase k + 1 once threads t - 1 and t + 1 (on
  the ring) have finished phase k. Two buffers, so a thread writes phase k + 1 where its
  neighbours have finished reading phase k - 1.

Every way and thread count must leave the same bytes (checked; the run fails otherwise): the
waits must order the reads and writes, and a missing one would change the bytes in most runs.
Printed: steps per second, best of ``--repeat`` interleaved runs, and each as a ratio to
"regions" on one thread. On a
2-core machine "neighbours" on two threads is "barrier" (each thread's two neighbours are the
other thread); the question is for 16 threads.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import granwave.threads  # noqa: E402,F401  (threading layer first)
import numba  # noqa: E402

from granwave import team as T  # noqa: E402

CHUNKS_PER_THREAD = 16
#: int64 slots between two threads' step counters (64-byte cache lines)
STRIDE = 8


@numba.njit(inline="always")
def _chunk(src, c, n, work):
    """Chunk c of the next step from chunks c - 1, c, c + 1 of ``src`` (a ring)."""
    x = (src[(c + n - 1) % n] + 2.0 * src[c] + src[(c + 1) % n]) * 0.25
    for _ in range(work):
        x = math.sqrt(x * 1.0000001 + 1e-7)
    return x


@numba.njit(parallel=True)
def run_regions(a, b, works, phases):
    """One prange region per phase (``phases`` of them, phase s of ``works[s % len(works)]`` turns
    per chunk); the result in ``a`` when ``phases`` is even, else ``b``."""
    n = a.shape[0]
    for s in range(phases):
        work = works[s % works.shape[0]]
        # two loops, not a swapped pair of names: with the pair chosen at run time the parallel
        # loop gave other bytes than the serial ways, at an impossible rate (numba 0.6x)
        if s % 2 == 0:
            for c in numba.prange(n):
                b[c] = _chunk(a, c, n, work)
        else:
            for c in numba.prange(n):
                a[c] = _chunk(b, c, n, work)


@numba.njit(parallel=True)
def run_barrier(a, b, works, phases, sync):
    """One region; a spin barrier of the whole team after each phase."""
    n = a.shape[0]
    threads = T.team_size(sync)
    for t in numba.prange(threads):
        if T.enter(sync, threads):
            lo, hi = t * n // threads, (t + 1) * n // threads
            gen = 0
            for s in range(phases):
                work = works[s % works.shape[0]]
                src, dst = (a, b) if s % 2 == 0 else (b, a)
                for c in range(lo, hi):
                    dst[c] = _chunk(src, c, n, work)
                gen = T.barrier(sync, threads, gen)


@numba.njit(parallel=True)
def run_neighbours(a, b, works, phases, sync, done):
    """One region; thread t starts phase s once its two ring neighbours have finished phase s - 1
    (``done[STRIDE * u]``: phases thread u has finished)."""
    n = a.shape[0]
    threads = T.team_size(sync)
    for t in numba.prange(threads):
        if T.enter(sync, threads):
            lo, hi = t * n // threads, (t + 1) * n // threads
            left, right = STRIDE * ((t + threads - 1) % threads), STRIDE * ((t + 1) % threads)
            for s in range(phases):
                spins = 0
                while T.atomic_load(done, left) < s or T.atomic_load(done, right) < s:
                    T.relax(spins)
                    spins += 1
                work = works[s % works.shape[0]]
                src, dst = (a, b) if s % 2 == 0 else (b, a)
                for c in range(lo, hi):
                    dst[c] = _chunk(src, c, n, work)
                T.atomic_store(done, STRIDE * t, s + 1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts, 1 first")
    ap.add_argument("--step-us", type=float, default=150.0,
                    help="one thread's work per step (us); the engine's step at 10^4 grains is of this order")
    ap.add_argument("--phases", type=int, default=2, help="phases per step, each reading the neighbours' last")
    ap.add_argument("--first-share", type=float, default=0.15,
                    help="with 2 phases: the first phase's share of the step's work (the engine's first pass "
                         "is short)")
    ap.add_argument("--seconds", type=float, default=0.3, help="wall time of one-thread work per run")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    threads = [int(t) for t in a.threads.split(",")]
    if threads[0] != 1:
        raise SystemExit("--threads: a list starting with 1")
    n = CHUNKS_PER_THREAD * max(threads)
    seed = 1.0 + np.arange(n) * 1e-3
    sync, done = T.new_sync(), np.zeros(STRIDE * max(threads), np.int64)

    def run(way, works, phases):
        x, y = seed.copy(), np.zeros(n)
        if way == "regions":
            run_regions(x, y, works, phases)
        else:
            T.reset_team(sync, numba.get_num_threads())
            if way == "barrier":
                run_barrier(x, y, works, phases, sync)
            else:
                done[:] = 0
                run_neighbours(x, y, works, phases, sync, done)
            if not T.entered(sync):
                raise SystemExit(f"{way}: the team did not start (threading layer {numba.threading_layer()})")
        return x if phases % 2 == 0 else y

    if a.phases < 1 or not 0.0 < a.first_share < 1.0:
        raise SystemExit("--phases: at least 1; --first-share: between 0 and 1")
    numba.set_num_threads(1)
    ways = ("regions", "barrier", "neighbours")
    for way in ways:  # compile
        run(way, np.ones(1, np.int64), 2)
    w0 = time.perf_counter()
    run("regions", np.full(1, 20_000, np.int64), 2)
    per_unit = (time.perf_counter() - w0) / (2 * 20_000 * n)
    work = max(a.phases, int(a.step_us * 1e-6 / (per_unit * n)))  # turns per chunk and step
    if a.phases == 2:
        first = max(1, int(round(a.first_share * work)))
        works = np.array([first, work - first], np.int64)
    else:
        works = np.full(a.phases, work // a.phases, np.int64)
    steps = 2 * max(1, int(a.seconds / (a.step_us * 1e-6) / 2))
    print(f"{n} chunks, {int(works.sum())} turns each per step in {a.phases} phase(s) of {', '.join(map(str, works))} "
          f"({a.step_us:g} us of one thread's work per step), {steps} steps per run; threading layer "
          f"{numba.threading_layer()}; {numba.config.NUMBA_NUM_THREADS} threads available")
    best, results = {}, set()
    for _ in range(a.repeat):
        for t in threads:
            numba.set_num_threads(t)
            for way in ways:
                w0 = time.perf_counter()
                out = run(way, works, steps * a.phases)
                rate = steps / (time.perf_counter() - w0)
                best[way, t] = max(best.get((way, t), 0.0), rate)
                results.add(out.tobytes())
    base = best["regions", 1]
    print("| threads | " + " | ".join(f"{w} (steps/s, ratio)" for w in ways) + " |")
    print("|---|" + "---|" * len(ways))
    for t in threads:
        print(f"| {t} | " + " | ".join(f"{best[w, t]:.0f}, {best[w, t] / base:.2f}" for w in ways) + " |")
    if len(results) != 1:
        print(f"DIFFERENT BYTES: {len(results)} distinct results")
        return 1
    print("the same bytes for every way and thread count")
    return 0


if __name__ == "__main__":
    sys.exit(main())
