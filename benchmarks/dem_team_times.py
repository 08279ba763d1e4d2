"""Where a DEM step's time goes on each thread of the team (a script, not a test).

    python benchmarks/dem_team_times.py [--threads 1,16] [--tiles 17] [--steps 1000]
        [--repeat 2] [--packing FILE] [--blocks-per-thread 2,4 | --blocks 8,24] [--blocks-on-one 16]

On the lent 16-vCPU machines (docs/decisions/0004-parallel-passes.md) the engine ran the
10^4-grain state 6-8x faster on 16 threads than on one, with 2.2-2.8 times the CPU time per
step: either each thread's work slows down when all run (shared units, a host's limits), or
threads wait for each other (imbalance, late vCPUs). The team's per-thread timers tell which:
each thread of a team adds the cycles (RDTSC) it spends in its blocks of each pass and at the
barrier after it (granwave.dem.kernels, ws.team_times). Per thread count, the best of
``--repeat`` runs of the benchmark state of scale.py (the 600-grain packing at p = 1e-4 tiled
``--tiles`` times, shaken, the same engine settings) is printed as:

- wall time per step, and its ratio to one thread's (one thread runs the single pair loop, as
  the engine does);
- per thread, microseconds per team step in pass 1 (with the step's own tests), at barrier 1,
  in pass 2, at barrier 2 and in the step's end (piston, blocks' maxima): mean over the threads,
  and the busiest thread's;
- work inflation: the threads' busy time summed, per step, over one thread's step time (1 if
  the work did not slow down when run in parallel; the block engine's own extra work, about
  10 % on one thread, is in it);
- imbalance: the busiest thread's busy time over the mean.

The cycle counter's rate is measured against the wall clock in the same run. With
``--blocks-per-thread`` a list, the runs of each value (granwave.dem.kernels.BLOCKS_PER_THREAD,
read when an engine starts: which thread computes which grains, not the bits) alternate in each
repetition and each gets its table; with ``--blocks`` a list, the same for block counts given
outright (at every thread count above 1; on the 2-core machine 8, 16 and 24 blocks at two
threads differed by less than the host's scatter). (Commit 212ca46 also alternated a rule that let a thread done
early take any block of a late one's share but its first: no gain at 16 threads, removed.)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import granwave.threads  # noqa: E402,F401  (threading layer first)
import numba  # noqa: E402

from granwave import team  # noqa: E402
from granwave.dem import blocks  # noqa: E402
from granwave.dem import kernels as K  # noqa: E402


@numba.njit(cache=True)
def _cycles():
    return team.cycle_counter()


def cycle_rate(seconds: float = 0.2) -> float:
    """Cycle counter ticks per second, against the wall clock."""
    c0, w0 = _cycles(), time.perf_counter()
    time.sleep(seconds)
    return (_cycles() - c0) / (time.perf_counter() - w0)


class _Counting:
    """numba for granwave.dem.integrator, but with ``get_num_threads()`` saying ``threads``."""

    def __init__(self, threads: int):
        self.threads = threads

    def get_num_threads(self) -> int:
        return self.threads

    def __getattr__(self, name):
        return getattr(numba, name)


def run(packing, tiles: int, steps: int, threads: int, blocks_for: int = 0):
    """The benchmark state of scale.py on ``threads`` threads: (wall s per step, team steps,
    cycles per thread and column). With ``blocks_for`` > 1 (and one thread): the block engine on
    one thread, its blocks and passes those of ``blocks_for`` threads, a region per pass."""
    from dem import engine_rate

    from granwave.dem import integrator

    engines = []
    keep = integrator.Engine.run
    keep_team = integrator.PLAIN_STEPS_IN_TEAM

    def run_and_keep(self, n):
        engines.append(self)
        return keep(self, n)

    numba.set_num_threads(threads)
    integrator.Engine.run = run_and_keep
    if blocks_for > 1:  # Engine.run asks numba for the thread count: the block engine's partition
        integrator.numba = _Counting(blocks_for)
        integrator.PLAIN_STEPS_IN_TEAM = False
    try:
        _, wall_rate, n, _ = engine_rate(packing, tiles, steps)
    finally:
        integrator.Engine.run = keep
        integrator.numba = numba
        integrator.PLAIN_STEPS_IN_TEAM = keep_team
    e = engines[-1]
    return n / wall_rate, int(e.ipar.team_steps), e.ws.team_times[:threads].copy()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts, 1 first")
    ap.add_argument("--tiles", type=int, default=17, help="the 600-grain packing tiled this many times")
    ap.add_argument("--steps", type=int, default=1000, help="timed steps per run (after 20 untimed)")
    ap.add_argument("--repeat", type=int, default=2, help="runs per thread count (the fastest counts)")
    ap.add_argument("--packing", default=None, help="the 600-grain packing at p = 1e-4 from a file")
    ap.add_argument("--blocks-per-thread", default=str(K.BLOCKS_PER_THREAD),
                    help="comma-separated values of kernels.BLOCKS_PER_THREAD to alternate")
    ap.add_argument("--blocks", default=None,
                    help="comma-separated block counts to alternate instead (every thread count above 1: "
                         "kernels.block_count replaced; e.g. 8,24 at 2 threads)")
    ap.add_argument("--blocks-on-one", type=int, default=0,
                    help="also run the block engine on one thread with the blocks of this many threads "
                         "(after the threaded runs, whose compilation it needs)")
    args = ap.parse_args()
    threads = [int(x) for x in args.threads.split(",")]
    per_thread = [int(x) for x in args.blocks_per_thread.split(",")]
    if min(per_thread) < 1:
        sys.exit("--blocks-per-thread: at least 1")
    counts = [int(x) for x in args.blocks.split(",")] if args.blocks else []
    if counts and min(counts) < 1:
        sys.exit("--blocks: at least 1")
    # the settings alternated at each thread count above 1: blocks per thread, or block counts
    settings = [("blocks", c) for c in counts] if counts else [("per thread", b) for b in per_thread]
    keep_count = K.block_count

    def apply(setting) -> None:
        kind, value = setting
        K.block_count = (lambda n, threads=1: value) if kind == "blocks" else keep_count
        blocks.BLOCKS_PER_THREAD = value if kind == "per thread" else per_thread[0]  # read by block_count
    if threads[0] != 1:
        sys.exit("--threads must start with 1")
    if args.blocks_on_one > max(1, numba.config.NUMBA_NUM_THREADS):
        # the engine keeps one tile scratch per thread numba can start, and a pass takes at most
        # that many partitions: fewer would time another partition than the one asked for
        sys.exit(f"--blocks-on-one {args.blocks_on_one} needs NUMBA_NUM_THREADS >= {args.blocks_on_one} "
                 f"(now {numba.config.NUMBA_NUM_THREADS}); e.g. NUMBA_NUM_THREADS={args.blocks_on_one}")
    if args.packing:
        from granwave.io.files import read_packing

        packing = read_packing(args.packing)
    else:
        from dem import prepare

        packing = prepare(1e-4)[0]
    best: dict[tuple, tuple] = {}
    for _ in range(args.repeat):
        for t in threads:
            for setting in settings[:1] if t == 1 else settings:  # one thread: the pair loop, no blocks
                apply(setting)
                r = run(packing, args.tiles, args.steps, t)
                if (setting, t) not in best or r[0] < best[setting, t][0]:
                    best[setting, t] = r
            apply(settings[0])
        if args.blocks_on_one > 1:
            apply(("per thread", per_thread[0]))
            r = run(packing, args.tiles, args.steps, 1, args.blocks_on_one)
            best["blocks on one"] = min(best.get("blocks on one", r), r, key=lambda x: x[0])
            r = run(packing, args.tiles, args.steps, 1)  # the pair loop beside it
            best["loop beside"] = min(best.get("loop beside", r), r, key=lambda x: x[0])
    rate = cycle_rate()
    one = best[settings[0], 1][0]
    print(f"{args.tiles * packing.n_grains} grains, {args.steps} steps per run; cycle counter "
          f"{rate / 1e9:.3f} GHz; one thread {1e6 * one:.1f} us per step")
    for setting in settings if len(threads) > 1 else ():
        kind, value = setting
        print(f"\nblocks per thread (above {K.BLOCK_MULTIPLE} threads): {value}" if kind == "per thread"
              else f"\n{value} blocks")
        table(threads, {t: best[setting, t] for t in threads[1:]}, one, rate)
    if args.blocks_on_one > 1:
        blk, loop = best["blocks on one"][0], best["loop beside"][0]
        print(f"\nthe block engine on one thread with the blocks of {args.blocks_on_one} threads "
              f"({K.block_count(args.tiles * packing.n_grains, args.blocks_on_one)} blocks, a region per pass): "
              f"{1e6 * blk:.1f} us per step against the pair loop's {1e6 * loop:.1f} run after it: "
              f"x{blk / loop:.3f}")
    numba.set_num_threads(max(threads))


def table(threads, best, one, rate) -> None:
    """The table of the docstring for the best runs ``best[t]`` at each thread count t > 1."""
    print("| threads | wall us/step (ratio) | team steps | pass 1 | barrier 1 | pass 2 | barrier 2 | end "
          "| busiest: pass 1 + 2 + end | work inflation | imbalance |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for t in threads[1:]:
        wall, n_team, cycles = best[t]
        if n_team == 0:
            print(f"| {t} | {1e6 * wall:.1f} ({one / wall:.2f}) | 0 | no team ran | | | | | | |")
            continue
        us = cycles / rate / n_team * 1e6  # per thread and column, microseconds per team step
        mean = us.mean(axis=0)
        busy = us[:, K.T_PASS1] + us[:, K.T_PASS2] + us[:, K.T_END]
        print(f"| {t} | {1e6 * wall:.1f} ({one / wall:.2f}) | {n_team} | {mean[K.T_PASS1]:.1f} | "
              f"{mean[K.T_WAIT1]:.1f} | {mean[K.T_PASS2]:.1f} | {mean[K.T_WAIT2]:.1f} | {mean[K.T_END]:.1f} | "
              f"{busy.max():.1f} | "
              f"{busy.sum() / (1e6 * one):.2f} | {busy.max() / busy.mean():.2f} |")
    print("(pass and barrier columns: microseconds per team step, mean over the threads)")
    print("per thread, us per team step (pass 1, barrier 1, pass 2, barrier 2, end) at the largest count:")
    t = threads[-1]
    wall, n_team, cycles = best[t]
    if n_team:
        for k, row in enumerate(cycles / rate / n_team * 1e6):
            print(f"  thread {k:2d}: " + " ".join(f"{x:7.1f}" for x in row))


if __name__ == "__main__":
    main()
