"""The time domain's team of threads against numba's two parallel regions per step (a script, not a test).

    python benchmarks/investigations/time_domain_team.py [--threads 1,2,4,8,16] [--grains 10000,100000] [--repeat 3]
        [--chunks 2,4,16]

In one process, on 2D frictional triangular lattices (benchmarks/linear.py's), best of
``--repeat`` runs per variant and thread count, interleaved: wall ms per velocity-Verlet step of

- "two regions/step": the kernel before granwave.team (a ``prange`` loop for the kick-drift and
  one for the matvec and second half kick: two OpenMP fork-joins per step), which granwave keeps
  for where no team can run (``propagate._verlet_regions``);
- "team, fixed shares": one parallel region per call, the phases separated by spin barriers
  (granwave.team), each thread drifting and kicking a fixed share of the rows (granwave's
  kernel until its shared chunks);
- "team (granwave)": :func:`granwave.linear.propagate.verlet_steps` as shipped: the rows in
  16 chunks per thread, a thread done early taking over a late one's last chunks
  (granwave.team.next_chunk); two phases a step up to 4 threads, one above
  (``propagate.FUSED_ABOVE``);
- "shared, k chunks/thread": granwave's two-phase team kernel (``propagate._verlet_team``) with
  ``--chunks`` k per thread;
- "team, neighbour waits" (a prototype, not in granwave): fixed shares, and no barrier of the whole
  team: each thread waits only for the threads whose rows its rows of D read (before its kick) and
  for those that read its rows (before its next drift), found from D's pattern
  (:func:`dependency_ranges`; on the lattices its two neighbours). Whether that beats the
  barrier where vCPUs run late (16 threads, docs/linear.md) is what it is here to measure; on two
  threads each thread's neighbour is the other, so it is the barrier under another name;
- with per-thread cycle timers (:func:`team_proto`: how long each thread works and waits in each
  phase, the work inflation and the imbalance), granwave's chunks and claims: "timed, two
  phases" and "timed, one phase a step" (granwave's two kernels), and "two phases, own drift"
  (each thread drifts its own share without claims: the drift is a few percent of the step);

each as a ratio to the first at one thread, and whether every variant at every thread count
left the same bytes. Measured on the 16-core machine of docs/linear.md ("Sixteen cores").
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # benchmarks/linear.py
sys.path.insert(0, str(HERE.parents[1]))

import granwave.threads  # noqa: E402,F401  (threading layer first)
import numba  # noqa: E402
from linear import lattice  # noqa: E402

from granwave import team as T  # noqa: E402
from granwave.linear.assemble import linearize  # noqa: E402
from granwave.linear.propagate import (CHUNKS_PER_THREAD, _drift_rows, _fused_rows,  # noqa: E402
                                      _kick_rows, _verlet_regions, _verlet_team, stable_time_step,
                                      verlet_steps)


@numba.njit(parallel=True)
def team_fixed_shares(indptr, indices, data, minv, u, v, a, dt, n_steps, flush, sync):
    """The team as granwave ran it before its shared chunks: thread t drifts and kicks a fixed
    share of the rows, t * n // threads .. (t + 1) * n // threads - 1."""
    n = u.shape[0]
    threads = T.team_size(sync)
    for t in numba.prange(threads):
        if T.enter(sync, threads):
            lo = t * n // threads
            hi = (t + 1) * n // threads
            gen = 0
            for _ in range(n_steps):
                _drift_rows(lo, hi, u, v, a, dt, flush)
                gen = T.barrier(sync, threads, gen)
                _kick_rows(lo, hi, indptr, indices, data, minv, u, v, a, dt, flush)
                gen = T.barrier(sync, threads, gen)


#: int64 slots between two threads' progress counters (64-byte cache lines)
STRIDE = 8


@numba.njit(inline="always")
def await_progress(progress, first, last, need):
    """Wait until threads first .. last have each published progress >= ``need``."""
    for s in range(first, last + 1):
        spins = 0
        while T.atomic_load(progress, STRIDE * s) < need:
            T.relax(spins)
            spins += 1


@numba.njit(parallel=True)
def team_neighbour_waits(indptr, indices, data, minv, u, v, a, dt, n_steps, flush, sync, progress,
                         reads_lo, reads_hi, read_by_lo, read_by_hi):
    """Fixed shares as :func:`team_fixed_shares`, but no barrier of the whole team: thread t
    publishes its progress (``progress[STRIDE * t]``: 2n + 1 once it has drifted step n, 2n + 2
    once it has kicked it) and waits only for the threads it depends on: before its kick of
    step n for threads reads_lo[t] .. reads_hi[t] (those whose rows of u its rows of D read) to
    have drifted step n, before its drift of step n + 1 for threads read_by_lo[t] ..
    read_by_hi[t] (those that read its rows) to have kicked step n. A late thread then holds
    only the threads beside it in the matrix, for a step, not every thread at every phase."""
    n = u.shape[0]
    threads = T.team_size(sync)
    for t in numba.prange(threads):
        if T.enter(sync, threads):
            lo = t * n // threads
            hi = (t + 1) * n // threads
            for step in range(n_steps):
                await_progress(progress, read_by_lo[t], read_by_hi[t], 2 * step)  # my readers kicked
                _drift_rows(lo, hi, u, v, a, dt, flush)
                T.atomic_store(progress, STRIDE * t, 2 * step + 1)
                await_progress(progress, reads_lo[t], reads_hi[t], 2 * step + 1)  # what I read drifted
                _kick_rows(lo, hi, indptr, indices, data, minv, u, v, a, dt, flush)
                T.atomic_store(progress, STRIDE * t, 2 * step + 2)


DRIFT, KICK, FUSED = 0, 1, 2


@numba.njit(inline="always")
def do_chunk(what, c, nchunk, n, s, n_steps, indptr, indices, data, minv, u, u_other, v, a, dt, flush):
    """Rows of chunk c (of ``nchunk``): DRIFT or KICK as granwave's two phases, or FUSED step s
    as granwave's one phase a step (propagate._fused_rows)."""
    lo, hi = c * n // nchunk, (c + 1) * n // nchunk
    if what == DRIFT:
        _drift_rows(lo, hi, u, v, a, dt, flush)
    elif what == KICK:
        _kick_rows(lo, hi, indptr, indices, data, minv, u, v, a, dt, flush)
    else:
        _fused_rows(lo, hi, s, n_steps, indptr, indices, data, minv, u, u_other, v, a, dt, flush)


@numba.njit(inline="always")
def run_phase(what, own_only, claims, t, threads, k, phase, n, s, n_steps, indptr, indices, data, minv, u,
              u_other, v, a, dt, flush):
    """Thread t's chunks of a phase: those granwave.team.next_chunk gives it (as granwave's team),
    or with ``own_only`` its own k chunks without any claim."""
    nchunk = k * threads
    if own_only:
        for c in range(t * k, t * k + k):
            do_chunk(what, c, nchunk, n, s, n_steps, indptr, indices, data, minv, u, u_other, v, a, dt, flush)
        return
    c, j = T.next_chunk(claims, t, threads, k, 0, phase)
    while c >= 0:
        do_chunk(what, c, nchunk, n, s, n_steps, indptr, indices, data, minv, u, u_other, v, a, dt, flush)
        c, j = T.next_chunk(claims, t, threads, k, j, phase)


@numba.njit(parallel=True)
def team_proto(indptr, indices, data, minv, u, u_other, v, a, dt, n_steps, flush, sync, claims, k, fused,
               drift_own, times):
    """Prototypes of the time domain's team, ``k`` chunks per thread claimed as :func:`run_phase`:
    two phases per step as granwave (the drift of a thread's own share only where
    ``drift_own``), or (``fused``) one barrier per step, the kick reading one buffer of u and the
    next drift writing the other, so that no row another thread may still read is written before
    the barrier (the first drift before the steps; u ends in buffer (n_steps - 1) % 2, which the
    caller copies back). Per-thread cycles (granwave.team.cycle_counter) in ``times[t]``: phase
    A, barrier A, phase B, barrier B (fused: the step in A, its barrier in B)."""
    n = u.shape[0]
    threads = T.team_size(sync)
    for t in numba.prange(threads):
        if T.enter(sync, threads):
            gen = 0
            if fused:
                run_phase(DRIFT, drift_own, claims, t, threads, k, gen + 1, n, 0, n_steps, indptr, indices, data,
                          minv, u, u_other, v, a, dt, flush)
                gen = T.barrier(sync, threads, gen)
            for s in range(n_steps):
                c0 = T.cycle_counter()
                if fused:
                    run_phase(FUSED, False, claims, t, threads, k, gen + 1, n, s, n_steps, indptr, indices, data,
                              minv, u, u_other, v, a, dt, flush)
                    c1 = T.cycle_counter()
                    gen = T.barrier(sync, threads, gen)
                    c2 = c3 = c4 = T.cycle_counter()
                else:
                    run_phase(DRIFT, drift_own, claims, t, threads, k, gen + 1, n, 0, n_steps, indptr, indices,
                              data, minv, u, u_other, v, a, dt, flush)
                    c1 = T.cycle_counter()
                    gen = T.barrier(sync, threads, gen)
                    c2 = T.cycle_counter()
                    run_phase(KICK, False, claims, t, threads, k, gen + 1, n, 0, n_steps, indptr, indices, data,
                              minv, u, u_other, v, a, dt, flush)
                    c3 = T.cycle_counter()
                    gen = T.barrier(sync, threads, gen)
                    c4 = T.cycle_counter()
                times[t, 0] += c1 - c0
                times[t, 1] += c2 - c1
                times[t, 2] += c3 - c2
                times[t, 3] += c4 - c3


@numba.njit
def _cycles():
    return T.cycle_counter()


def cycle_rate(seconds: float = 0.2) -> float:
    """Cycle counter ticks per second, against the wall clock."""
    c0, w0 = _cycles(), time.perf_counter()
    time.sleep(seconds)
    return (_cycles() - c0) / (time.perf_counter() - w0)


def dependency_ranges(indptr: np.ndarray, indices: np.ndarray, threads: int):
    """For fixed shares of the rows among ``threads``: per thread t the range of threads whose
    rows t's rows of D read (reads_lo, reads_hi), and the range of threads that read t's rows
    (read_by_lo, read_by_hi; a superset where the readers are not contiguous: waiting for more
    is safe)."""
    n = indptr.shape[0] - 1
    starts = [t * n // threads for t in range(threads + 1)]
    reads_lo, reads_hi = np.zeros(threads, np.int64), np.zeros(threads, np.int64)
    for t in range(threads):
        cols = indices[indptr[starts[t]]:indptr[starts[t + 1]]]
        owners = np.searchsorted(np.asarray(starts[1:]), cols, side="right") if cols.size else np.array([t])
        reads_lo[t], reads_hi[t] = min(t, int(owners.min())), max(t, int(owners.max()))
    read_by_lo, read_by_hi = np.arange(threads, dtype=np.int64), np.arange(threads, dtype=np.int64)
    for t in range(threads):
        for s in range(int(reads_lo[t]), int(reads_hi[t]) + 1):
            read_by_lo[s], read_by_hi[s] = min(read_by_lo[s], t), max(read_by_hi[s], t)
    return reads_lo, reads_hi, read_by_lo, read_by_hi


VARIANTS = ("two regions/step", "team, fixed shares", "team (granwave)",
            "team, neighbour waits")
#: variants of :func:`team_proto`: name -> (chunks per thread, one phase a step, drift of the own
#: share only). (Commit 212ca46 also ran the early break of the claim scan and the one phase a
#: step as prototypes, before granwave had them.)
PROTOS = {"timed, two phases": (CHUNKS_PER_THREAD, False, False),
          "timed, one phase a step": (CHUNKS_PER_THREAD, True, False),
          "two phases, own drift": (CHUNKS_PER_THREAD, False, True)}


def measure(n_grains: int, threads: list[int], repeat: int, chunks: list[int]) -> None:
    system = linearize(lattice(n_grains), check=False)
    dt, _ = stable_time_step(system)
    D = system.stiffness.tocsr()
    D.sort_indices()
    minv = 1.0 / system.mass
    ip, ix = D.indptr.astype(np.int64), D.indices.astype(np.int64)
    steps = max(300, int(2e8 / D.nnz))
    sync = T.new_sync()
    ranges = {t: dependency_ranges(ip, ix, t) for t in threads}
    variants = VARIANTS + tuple(f"shared, {k} chunks/thread" for k in chunks) + tuple(PROTOS)
    best, finals, timed = {}, set(), {}
    times = np.zeros((max(threads), 4), np.int64)
    for _ in range(repeat):
        for t in threads:
            numba.set_num_threads(t)
            for name in variants:
                u, v, a = np.zeros(system.n_dof), system.source_velocity.copy(), np.zeros(system.n_dof)

                def run(k):
                    if name == VARIANTS[0]:
                        _verlet_regions(ip, ix, D.data, minv, u, v, a, dt, k, 1e-200)
                    elif name == VARIANTS[1]:
                        T.reset_team(sync, t)
                        team_fixed_shares(ip, ix, D.data, minv, u, v, a, dt, k, 1e-200, sync)
                    elif name == VARIANTS[2]:
                        verlet_steps(ip, ix, D.data, minv, u, v, a, dt, k, 1e-200, sync)
                    elif name == VARIANTS[3]:
                        T.reset_team(sync, t)
                        progress = np.zeros(STRIDE * t, np.int64)
                        team_neighbour_waits(ip, ix, D.data, minv, u, v, a, dt, k, 1e-200, sync, progress,
                                             *ranges[t])
                    elif name in PROTOS:
                        per, fused, drift_own = PROTOS[name]
                        T.reset_team(sync, t)
                        claims = np.zeros(per * t, np.int64)
                        u_other = np.empty_like(u)
                        times[:] = 0
                        team_proto(ip, ix, D.data, minv, u, u_other, v, a, dt, k, 1e-200, sync, claims, per,
                                   fused, drift_own, times)
                        if fused and (k - 1) % 2:
                            u[:] = u_other
                    else:
                        per = int(name.split(", ")[1].split()[0])
                        T.reset_team(sync, t)
                        claims = np.zeros(per * t, np.int64)
                        _verlet_team(ip, ix, D.data, minv, u, v, a, dt, k, 1e-200, sync, claims, per)
                    if name != VARIANTS[0] and not T.entered(sync):
                        raise RuntimeError("the team did not run")

                run(3)  # compile, warm up
                u[:] = 0.0
                v[:] = system.source_velocity
                a[:] = 0.0
                w0 = time.perf_counter()
                run(steps)
                wall = (time.perf_counter() - w0) / steps
                if wall < best.get((name, t), np.inf) and name in PROTOS:
                    timed[name, t] = times[:t] / steps  # cycles per step, per thread and column
                best[name, t] = min(best.get((name, t), np.inf), wall)
                finals.add(u.tobytes() + v.tobytes() + a.tobytes())
    print(f"\n{system.n_dof} dofs ({n_grains} grains), {D.nnz} stiffness entries, {steps} steps; "
          f"best of {repeat}; same bits for every variant and thread count: {len(finals) == 1}")
    one = best[VARIANTS[0], threads[0]]
    for name in variants:
        print(f"  {name:28s} " + "  ".join(f"{t}: {1e3 * best[name, t]:.4f} ms ({one / best[name, t]:.2f}x)"
                                          for t in threads), flush=True)
    rate = cycle_rate()
    print(f"prototypes' timers, microseconds per step (cycle counter {rate / 1e9:.3f} GHz), mean over the "
          "threads: phase A | barrier A | phase B | barrier B (fused: the step, its barrier, 0, 0); work "
          "inflation: busy time summed over the variant's one-thread step; imbalance: busiest over mean busy")
    for name in PROTOS:
        one_p = best[name, threads[0]]
        for t in threads:
            us = timed[name, t] / rate * 1e6
            busy = us[:, 0] + us[:, 2]
            print(f"  {name:28s} {t:3d}: " + " | ".join(f"{x:6.2f}" for x in us.mean(axis=0)) +
                  f"; inflation {busy.sum() / (1e6 * one_p):.2f}; imbalance {busy.max() / busy.mean():.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", default="1,2", help="comma-separated thread counts, 1 first")
    ap.add_argument("--grains", default="10000", help="comma-separated lattice sizes (grains)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per variant and thread count (the best counts)")
    ap.add_argument("--chunks", default="", help="chunks per thread of extra shared-chunks variants, e.g. 1,4,16")
    args = ap.parse_args()
    threads = [int(x) for x in args.threads.split(",")]
    for n in (int(x) for x in args.grains.split(",")):
        measure(n, threads, args.repeat, [int(x) for x in args.chunks.split(",") if x])


if __name__ == "__main__":
    main()
