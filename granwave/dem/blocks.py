"""Grain blocks of the parallel engine and the claims by which threads take them.

The grains are split into contiguous index blocks (:func:`block_count`); a force pass runs,
per thread, the blocks it claims (:func:`visit_order`, :func:`claim_block`). Which thread
computes a block never changes a bit (docs/dem.md, "Parallel engine").
"""

from __future__ import annotations

import numba
import numpy as np

from .. import team
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


#: The parallel engine splits the grains into contiguous index blocks (docs/dem.md, "Parallel
#: engine"): ``block_count(N, threads)`` blocks of about BLOCK_GRAINS grains, their number a
#: multiple of BLOCK_MULTIPLE so that 2 or 4 threads get equal shares of the blocks; with more
#: threads, at least BLOCKS_PER_THREAD blocks per thread (a multiple of the thread count, none
#: smaller than MIN_BLOCK_GRAINS grains), so that 16 threads on 10^4 grains have work (8 blocks
#: would cap them at 8x; more blocks per thread add incoming pairs faster than they balance
#: the work, docs/decisions/0004-parallel-passes.md). The partition decides only which thread
#: computes which grains: every grain adds its terms in the one-thread loop's order whatever
#: the blocks, so the bits do not
#: depend on it (tests/test_parallel.py runs several partitions); the blocks (not the threads)
#: hold the partial maxima.
BLOCK_GRAINS = 1024
BLOCK_MULTIPLE = 4
BLOCKS_PER_THREAD = 2
MIN_BLOCK_GRAINS = 64
# columns of the per-block statistics (``blk_g``)
G_DMAX, G_NC, G_NTOP, G_AMAX, G_ALMAX, G_VMAX, G_WMAX, G_KIN, G_DVMAX, G_DISP = range(10)
N_GCOL = 10


def block_count(n: int, threads: int = 1) -> int:
    """Number of grain blocks for ``n`` grains on ``threads`` threads: the multiple of
    BLOCK_MULTIPLE nearest n / BLOCK_GRAINS, at least BLOCK_MULTIPLE; above BLOCK_MULTIPLE
    threads, raised to BLOCKS_PER_THREAD per thread and rounded up to a multiple of the
    threads, but no block under MIN_BLOCK_GRAINS grains (at most n blocks, at least 1)."""
    k = int(n / (BLOCK_MULTIPLE * BLOCK_GRAINS) + 0.5)
    nb = BLOCK_MULTIPLE * max(1, k)
    if threads > BLOCK_MULTIPLE:
        nb = max(nb, threads * BLOCKS_PER_THREAD)
        nb = -(-nb // threads) * threads
        nb = min(nb, max(BLOCK_MULTIPLE, n // MIN_BLOCK_GRAINS))
    return max(1, min(n, nb))


@numba.njit(cache=True, inline="always")
def block_bounds(b, n, nblk):
    """Grains [b0, b1) of block b of ``nblk`` over ``n`` grains."""
    return b * n // nblk, (b + 1) * n // nblk


@numba.njit(cache=True, inline="always")
def grains(lo, hi):
    """range(lo, hi) counted unsigned, for the per-grain loops of a block. With a signed index
    whose start is not a constant, numba checks every access for a negative (wraparound)
    index, and that branch keeps the loop scalar: zeroing a block's forces took 14 us instead
    of 3 for 10^4 grains, and the block engine's grain loops were slower than the
    one-thread loop's over range(n)."""
    return range(np.uint64(lo), np.uint64(hi))


@numba.njit(cache=True, inline="always")
def take_block(claims, b, phase):
    """Mark block b taken in pass ``phase``: ``claims[1 + b]`` exchanged with ``phase`` atomically
    (an LLVM ``atomicrmw xchg``, :func:`granwave.team.atomic_swap`). True when this caller took
    the block, False when someone had. The flags start below every phase (:func:`open_claims`
    zeroes them for the regions' passes, which are all phase 1; the team's passes count up,
    :func:`_team_steps`)."""
    return team.atomic_swap(claims, b + 1, phase) != phase


@numba.njit(cache=True, inline="always")
def block_taken(claims, b, phase):
    """Whether block b is taken in pass ``phase`` (``claims[1 + b]`` read atomically)."""
    return team.atomic_load(claims, b + 1) == phase


@numba.njit(cache=True)
def visit_order(t, threads, nblk, order):
    """The blocks that thread t of ``threads`` offers to take in a force pass, in its order, into
    ``order[:nblk]``: first its own share (numba's static split, ascending), then the other
    threads' shares (t + 1, t + 2, ... cyclically), each from its far end. Where the threads keep
    pace each takes its own share, as the static split did (same memory, same cache); a thread
    done early takes the others' last blocks (:func:`take_block`). Into ``order[nblk + j]`` the
    first block of the share of block ``order[j]``, -1 for t's own. Made once per pass (a team:
    once per run) so that :func:`claim_block` looks blocks up: computing each from the thread
    count takes several integer divisions per block, on the path of the last thread to the
    barrier (benchmarks/investigations/claim_scan.py times both)."""
    j = 0
    for b in range(t * nblk // threads, (t + 1) * nblk // threads):
        order[j] = b
        order[nblk + j] = -1
        j += 1
    u = t
    for _ in range(1, threads):
        u = u + 1 if u + 1 < threads else 0
        c0 = u * nblk // threads
        for b in range((u + 1) * nblk // threads - 1, c0 - 1, -1):
            order[j] = b
            order[nblk + j] = c0
            j += 1


@numba.njit(cache=True, inline="always")
def claim_block(claims, order, nblk, j, phase):
    """The j-th block of a thread's ``order`` (:func:`visit_order`) if the thread should try it
    and took it (:func:`take_block`) in pass ``phase``; else -1. It tries every block of its own
    share, one of another's only while its owner has not reached the block before it. The owner
    then keeps the block it would start next, which it computes from its own cache: taking it
    over a little earlier made the balanced 10 200-grain square slower (threads 1 -> 2 down to
    1.60 in one of three runs, CPU time per step x1.25). A force pass runs, per thread, the blocks
    that ``claim_block(claims, order, nblk, j, phase)`` gives for j < nblk."""
    b = order[j]
    first = order[nblk + j]
    if (first < 0 or (b > first and not block_taken(claims, b - 1, phase))) and take_block(claims, b, phase):
        return b
    return -1


@numba.njit(cache=True, inline="always")
def open_claims(claims, nblk, rows):
    """Clear the taken flags before a pass; the thread count (``claims[0]``, set by the engines),
    at most ``rows``, the tile scratches (one per thread: a pass's iteration t uses row t)."""
    for b in range(nblk):
        claims[1 + b] = 0
    return max(1, min(claims[0], rows))
