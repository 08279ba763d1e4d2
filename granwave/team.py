"""A team of threads kept in one parallel region across many steps (spin barriers).

numba opens a parallel region (an OpenMP fork and join) per ``prange`` loop. A time step made of
two such loops pays two of them: about 1 us each on 2 cores, but 7-8 us each at 16 threads on
the 16-core machine of docs/linear.md, where a step of 10^4 grains takes 40 us of work per
thread. A kernel that loops over the steps *inside* one ``prange(threads)`` (one iteration per
thread) and separates the phases of a step by :func:`barrier` pays one fork and join per call
instead, and a barrier (an atomic add and a spin on a shared counter) per phase.

Use, inside an ``@njit(parallel=True)`` kernel (the caller first runs
``reset_team(sync, numba.get_num_threads())``)::

    threads = team_size(sync)
    for t in numba.prange(threads):          # one iteration per thread
        if enter(sync, threads):             # every thread of the team is running
            gen = 0
            for step in range(n):
                ...phase 1 on thread t's share...
                gen = barrier(sync, threads, gen)
                ...phase 2...
                gen = barrier(sync, threads, gen)

and afterwards ``entered(sync)`` says whether the team ran. :func:`enter` is where a team that is
not all running at once is caught: numba's static split gives each thread one iteration of
``prange(threads)`` when ``threads`` is the current thread count, but should two iterations ever
share a thread (a thread limit of the OpenMP runtime, a nested region), the first would wait at a
barrier for the second forever. A thread that waits at the entry longer than its patience
(ENTRY_SPINS loads of the counter, :func:`reset_team`) marks the team given up instead
(compare-and-swap, so that the last arrival and the giving up cannot both succeed); every thread
then leaves without work, and the caller runs its per-phase parallel loops instead (the same
bits), from then on in that process (:func:`usable`, :func:`give_up`). Barriers after the entry
only wait for threads known to be running.

The atomics are LLVM instructions (numba has no atomics on the CPU): ``atomicrmw add`` and
``xchg``, ``cmpxchg``, ``load atomic`` and ``store atomic`` on an int64 vector ``sync`` (:func:`new_sync`)
whose counters lie on separate 64-byte cache lines. The add is acquire-release and the spinning
load acquire: what a thread wrote before a barrier is seen by every thread after it. No
floating-point value is ever combined atomically: which thread computes a row never changes a
bit.
"""

from __future__ import annotations

import platform
import sys
import warnings

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from . import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

#: int64 slots of the sync vector: team size and entry patience (read only in the region), then
#: the three counters, each on its own 64-byte cache line
S_SIZE, S_SPINS, S_ENTRY, S_COUNT, S_GEN = 0, 1, 8, 16, 24
SYNC_LENGTH = 32
#: Loads of the entry counter after which a waiting thread gives the team up (each after a
#: PAUSE, past YIELD_AFTER after a sched_yield: seconds), against microseconds for a team that
#: starts
ENTRY_SPINS = 1 << 22
#: Threading layers that run the iterations of ``prange(threads)`` each on its own thread, all at
#: once (TBB may run two on one thread: the entry would wait its whole patience at every call)
TEAM_LAYERS = ("omp", "workqueue")
_given_up = False


def new_sync() -> np.ndarray:
    """The shared counters of one team (reset by :func:`reset_team` before each region)."""
    return np.zeros(SYNC_LENGTH, np.int64)


@numba.njit(cache=True)
def reset_team(sync, threads, spins=ENTRY_SPINS):
    """Counters to zero, the team size to ``threads`` and the entry patience to ``spins`` loads
    (serial code, before the region)."""
    for k in range(SYNC_LENGTH):
        sync[k] = 0
    sync[S_SIZE] = max(1, threads)
    sync[S_SPINS] = spins


def _slot_args(sync, k) -> bool:
    return (isinstance(sync, types.Array) and sync.dtype == types.int64 and sync.ndim == 1
            and isinstance(k, types.Integer))


def _slot(context, builder, sig, args):
    """LLVM pointer to ``sync[k]``."""
    aryty = sig.args[0]
    ary = context.make_array(aryty)(context, builder, args[0])
    k = context.cast(builder, args[1], sig.args[1], types.intp)
    return cgutils.get_item_pointer(context, builder, aryty, ary, [k])


def _read_modify_write(op: str, doc: str):
    """An intrinsic ``f(sync, k, value)``: LLVM ``atomicrmw <op>`` on ``sync[k]`` with ``value``
    (acquire-release), returning the value before."""

    @intrinsic
    def rmw(typingctx, sync, k, value):
        if not (_slot_args(sync, k) and isinstance(value, types.Integer)):
            return None

        def codegen(context, builder, sig, args):
            val = context.cast(builder, args[2], sig.args[2], types.int64)
            return builder.atomic_rmw(op, _slot(context, builder, sig, args), val, "acq_rel")

        return types.int64(sync, k, value), codegen

    rmw.__doc__ = doc
    return rmw


atomic_add = _read_modify_write("add", "``sync[k] += value`` atomically; returns the value before.")
atomic_swap = _read_modify_write("xchg", "``sync[k] = value`` atomically; returns the value before.")


@intrinsic
def atomic_cas(typingctx, sync, k, expected, new):
    """``sync[k] = new`` if it holds ``expected``, atomically (acquire-release); returns the
    value before (equal to ``expected`` when the swap happened)."""
    if not (_slot_args(sync, k) and isinstance(expected, types.Integer) and isinstance(new, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        old = context.cast(builder, args[2], sig.args[2], types.int64)
        val = context.cast(builder, args[3], sig.args[3], types.int64)
        pair = builder.cmpxchg(_slot(context, builder, sig, args), old, val, "acq_rel", "acquire")
        return builder.extract_value(pair, 0)

    return types.int64(sync, k, expected, new), codegen


@intrinsic
def atomic_load(typingctx, sync, k):
    """``sync[k]`` read atomically (acquire)."""
    if not _slot_args(sync, k):
        return None

    def codegen(context, builder, sig, args):
        return builder.load_atomic(_slot(context, builder, sig, args), "acquire", 8)

    return types.int64(sync, k), codegen


@intrinsic
def atomic_store(typingctx, sync, k, value):
    """``sync[k] = value`` atomically (release)."""
    if not (_slot_args(sync, k) and isinstance(value, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        val = context.cast(builder, args[2], sig.args[2], types.int64)
        builder.store_atomic(val, _slot(context, builder, sig, args), "release", 8)
        return context.get_dummy_value()

    return types.none(sync, k, value), codegen


#: x86's PAUSE in spin loops: a spinning thread then leaves its core's other hardware thread
#: the issue slots (and exits the loop without a memory-order flush); no-op elsewhere
_PAUSE = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686")


@intrinsic
def spin_pause(typingctx):
    """One PAUSE instruction (x86), inside a spin loop."""

    def codegen(context, builder, sig, args):
        if _PAUSE:
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), []),
                                                "llvm.x86.sse2.pause")
            builder.call(fn, [])
        return context.get_dummy_value()

    return types.none(), codegen


#: POSIX sched_yield in long waits: where threads outnumber free cores (more threads than cores,
#: other work on the machine) a thread that spins while the one it waits for has no core keeps
#: it off the core, and a step can take tens of times longer than numba's own loops
#: (docs/decisions/0012-thread-wait-policy.md)
_YIELD = sys.platform != "win32"
#: PAUSEd loads of a wait before it starts yielding the core (tens of microseconds)
YIELD_AFTER = 2000


@intrinsic
def os_yield(typingctx):
    """Give the core to another runnable thread (``sched_yield``; a PAUSE where there is none)."""

    def codegen(context, builder, sig, args):
        if _YIELD:
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.IntType(32), []),
                                                "sched_yield")
            builder.call(fn, [])
        elif _PAUSE:
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), []),
                                                "llvm.x86.sse2.pause")
            builder.call(fn, [])
        return context.get_dummy_value()

    return types.none(), codegen


@intrinsic
def cycle_counter(typingctx):
    """The processor's cycle counter (LLVM ``readcyclecounter``: RDTSC on x86, a constant rate
    there; 0 where the target has none), for the per-thread timers of the teams."""

    def codegen(context, builder, sig, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.IntType(64), []),
                                            "llvm.readcyclecounter")
        return builder.call(fn, [])

    return types.int64(), codegen


@numba.njit(cache=True, inline="always")
def relax(spins):
    """One turn of a wait that has lasted ``spins`` turns: a PAUSE, and past YIELD_AFTER turns the
    core given up for a moment (:func:`os_yield`)."""
    if spins < YIELD_AFTER:
        spin_pause()
    else:
        os_yield()


@numba.njit(cache=True, inline="always")
def team_size(sync):
    return sync[S_SIZE]


@numba.njit(cache=True, inline="always")
def enter(sync, threads):
    """Arrive at the team's entry and wait for all ``threads``: True when all arrived, False
    when the team was given up (a thread waited ``sync[S_SPINS]`` loads, or arrived after that)."""
    while True:  # arrive, unless the team was given up
        c = atomic_load(sync, S_ENTRY)
        if c < 0:
            return False
        if atomic_cas(sync, S_ENTRY, c, c + 1) == c:
            break
    patience = sync[S_SPINS]
    spins = 0
    while True:
        c = atomic_load(sync, S_ENTRY)
        if c < 0:
            return False
        if c >= threads:
            return True
        relax(spins)
        spins += 1
        if spins > patience and atomic_cas(sync, S_ENTRY, c, -1) == c:
            return False


@numba.njit(cache=True, inline="always")
def barrier(sync, threads, gen):
    """Wait until all ``threads`` have called this with generation ``gen``; returns gen + 1.
    The last to arrive resets the count and then advances the generation (release), on which
    the others spin (acquire)."""
    if atomic_add(sync, S_COUNT, 1) == threads - 1:
        atomic_store(sync, S_COUNT, 0)
        atomic_store(sync, S_GEN, gen + 1)
    else:
        spins = 0
        while atomic_load(sync, S_GEN) == gen:
            relax(spins)
            spins += 1
    return gen + 1


@numba.njit(cache=True, inline="always")
def chunk_visit(t, threads, k, j):
    """The j-th chunk (of ``k`` per thread, ``k * threads`` in all, thread u owning chunks
    u*k .. u*k + k - 1) that thread t offers to take in a phase: its own ascending, then each
    other thread's from the far end."""
    if j < k:
        return t * k + j
    j -= k
    u = (t + 1 + j // k) % threads
    return u * k + k - 1 - j % k


@numba.njit(cache=True, inline="always")
def next_chunk(claims, t, threads, k, j, phase):
    """The next chunk that thread t takes in ``phase`` from visit j of its order
    (:func:`chunk_visit`), and the visit to go on from: ``(c, j)``, or ``(-1, k * threads)``
    when none is left. A phase runs, per thread t, ``j = 0`` then ``c, j = next_chunk(...)``
    until c < 0: each chunk exactly once. ``claims[c] == phase`` once chunk c is taken (an
    atomic exchange; ``claims`` starts below every phase and phases increase). A thread takes
    all of its own chunks that nobody took, and another's only while the owner has not reached
    the chunk before it, so that threads keeping pace each compute their own rows from their
    own cache and a thread done early (a late or slow vCPU elsewhere) takes over the far end of
    another's share. It leaves a share at the first chunk whose predecessor is taken (by the
    owner, or by another thread that came down from the far end): one or two reads of another
    thread's claims instead of one per chunk; at 8 and 16 threads, where those reads miss the
    cache, the time domain ran 6-8 % faster so (docs/linear.md). Integer atomics decide only who
    computes a chunk: never a value."""
    nchunk = k * threads
    while j < nchunk:
        c = chunk_visit(t, threads, k, j)
        if c // k != t and (c % k == 0 or atomic_load(claims, c - 1) == phase):
            j = (j // k + 1) * k  # nothing more to take in this share
            continue
        j += 1
        if atomic_swap(claims, c, phase) != phase:
            return c, j
    return -1, nchunk


def entered(sync) -> bool:
    """Whether the last region's team ran (every thread arrived at :func:`enter`)."""
    return bool(sync[S_ENTRY] >= sync[S_SIZE])


def usable() -> bool:
    """Whether a kernel should try a team: on a threading layer of TEAM_LAYERS, and not after a
    team was given up in this process (then its per-phase parallel loops, the same bits)."""
    if _given_up:
        return False
    try:
        return numba.threading_layer() in TEAM_LAYERS
    except ValueError:  # no parallel region has run yet: the team's entry decides
        return True


def give_up(what: str) -> None:
    """Note that a team of ``what`` did not start (:func:`entered` False): warn once, and make
    :func:`usable` False for the rest of the process."""
    global _given_up
    if not _given_up:
        warnings.warn(f"{what}: the threads of a team did not all start together; per-phase parallel "
                      "loops run from now on in this process (the same results)", RuntimeWarning, stacklevel=3)
    _given_up = True
