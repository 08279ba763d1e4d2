"""What a thread's walk over the block claims costs in one force pass (a script, not a test).

    python benchmarks/investigations/claim_scan.py [--threads 2,16] [--blocks-per-thread 2,4] [--passes 200000]

In each force pass of the DEM block engine a thread offers to take every block: its own share
first, then the other threads' shares from their far ends (granwave.dem.kernels.visit_order,
claim_block). A thread that is done looks at every block another has taken; the last thread to
finish does so on its way to the barrier. Until 2026-11-27 each block of that walk was computed
from the thread count (several integer divisions per block: ``_former_claim`` below keeps that
code for comparison); since then each thread makes its order once per pass and looks it up.

Per thread count and blocks per thread, one thread's walk over all blocks with every flag set
(every block taken by its owner, the walk of a thread done early), best of three timings of
``--passes`` passes, both ways in the same run, and the ratio. Both ways must give the same
blocks in the same order (checked first, on flags that leave some blocks untaken).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import numba  # noqa: E402
import numpy as np  # noqa: E402

from granwave.dem import kernels as K  # noqa: E402


@numba.njit(cache=True, inline="always")
def _former_visit(t, threads, nblk, j):
    """The former kernels.visit_block: the j-th block of thread t's order, from the thread count."""
    b0 = t * nblk // threads
    own = (t + 1) * nblk // threads - b0
    if j < own:
        return b0 + j
    j -= own
    for s in range(1, threads):
        u = (t + s) % threads
        c0 = u * nblk // threads
        c1 = (u + 1) * nblk // threads
        if j < c1 - c0:
            return c1 - 1 - j
        j -= c1 - c0
    return -1


@numba.njit(cache=True, inline="always")
def _former_claim(claims, t, threads, nblk, j, phase):
    """The former kernels.claim_block with worth_taking: the share of block b found by division."""
    b = _former_visit(t, threads, nblk, j)
    u = b * threads // nblk
    while u * nblk // threads > b:
        u -= 1
    while (u + 1) * nblk // threads <= b:
        u += 1
    worth = u == t or (b > u * nblk // threads and not K.block_taken(claims, b - 1, phase))
    if worth and K.take_block(claims, b, phase):
        return b
    return -1


@numba.njit(cache=True)
def _walk_former(claims, t, threads, nblk, passes):
    got = 0
    for phase in range(1, passes + 1):
        for b in range(nblk):  # every block taken by its owner in this pass
            claims[1 + b] = phase
        for j in range(nblk):
            got += _former_claim(claims, t, threads, nblk, j, phase)
    return got


@numba.njit(cache=True)
def _walk_now(claims, order, t, threads, nblk, passes):
    got = 0
    for phase in range(1, passes + 1):
        for b in range(nblk):
            claims[1 + b] = phase
        K.visit_order(t, threads, nblk, order)  # once per pass, as the engine does
        for j in range(nblk):
            got += K.claim_block(claims, order, nblk, j, phase)
    return got


@numba.njit(cache=True)
def _claims_former(claims, t, threads, nblk, phase, out):
    for j in range(nblk):
        out[j] = _former_claim(claims, t, threads, nblk, j, phase)


@numba.njit(cache=True)
def _claims_now(claims, order, t, threads, nblk, phase, out):
    K.visit_order(t, threads, nblk, order)
    for j in range(nblk):
        out[j] = K.claim_block(claims, order, nblk, j, phase)


def same_claims(threads: int, nblk: int, seed: int = 0) -> bool:
    """Both ways take the same blocks in the same order, for every thread, with random blocks
    already taken in the pass."""
    rng = np.random.default_rng(seed)
    order = np.zeros(2 * nblk, np.int64)
    for t in range(threads):
        flags = np.where(rng.random(nblk) < 0.4, 1, 0).astype(np.int64)
        a, b = np.zeros(nblk, np.int64), np.zeros(nblk, np.int64)
        claims_a = np.concatenate([[threads], flags, [0]]).astype(np.int64)
        claims_b = claims_a.copy()
        _claims_former(claims_a, t, threads, nblk, 1, a)
        _claims_now(claims_b, order, t, threads, nblk, 1, b)
        if not (np.array_equal(a, b) and np.array_equal(claims_a, claims_b)):
            return False
    return True


def best_of(fn, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", default="2,16", help="comma-separated thread counts")
    ap.add_argument("--blocks-per-thread", default="2,4", help="comma-separated blocks per thread")
    ap.add_argument("--passes", type=int, default=200_000, help="passes per timing")
    args = ap.parse_args()
    print("| threads | blocks | former walk (us per pass) | now, order made included | ratio |")
    print("|---|---|---|---|---|")
    for threads in (int(x) for x in args.threads.split(",")):
        for per in (int(x) for x in args.blocks_per_thread.split(",")):
            nblk = threads * per
            if not same_claims(threads, nblk):
                raise SystemExit(f"the two ways differ at {threads} threads, {nblk} blocks")
            claims = np.zeros(nblk + 2, np.int64)
            order = np.zeros(2 * nblk, np.int64)
            t = threads // 2  # a thread in the middle: its walk wraps around
            _walk_former(claims, t, threads, nblk, 10)
            _walk_now(claims, order, t, threads, nblk, 10)
            former = best_of(lambda: _walk_former(claims, t, threads, nblk, args.passes)) / args.passes
            now = best_of(lambda: _walk_now(claims, order, t, threads, nblk, args.passes)) / args.passes
            print(f"| {threads} | {nblk} | {1e6 * former:.3f} | {1e6 * now:.3f} | {former / now:.1f} |")


if __name__ == "__main__":
    main()
