"""Which vCPUs share a physical core? (a script, not a test)

    python benchmarks/investigations/vcpu_siblings.py [--passes 120000] [--places FILE]

A virtual machine presents each vCPU as a core of its own ("one thread per core" in lscpu), but
on the host two vCPUs may be the two hardware threads of one core, sharing its vector units and
caches. core_throughput.py showed the sum: on the 16-vCPU machines of docs/dem.md, work bound by
the vector units or the L2 cache ran about 8x one thread at 16 threads, a dependent chain 15x.
This script finds the pairs. One process per vCPU, each pinned to it (os.sched_setaffinity),
runs the same vector work (independent multiply-adds over 16 KB, in L1): first each alone, then
every pair of vCPUs at once. A pair's throughput in units of one vCPU alone,
t_alone(i) / t_pair(i) + t_alone(j) / t_pair(j), is 2 for two cores and near 1 for two hardware
threads of one core.

Printed: the throughput of each pair (a matrix), the pairs below 1.5, and the groups of vCPUs
that share a core. ``--places FILE`` writes OpenMP place lists to bind threads with
(``OMP_PLACES``): ``FILE.spread`` one vCPU per group (as many as there are groups), and
``FILE.packed`` the groups' vCPUs side by side (every vCPU, siblings together).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import sys
import time

import numpy as np

SIZE = 2048  # float64 elements: 16 KB, in L1


def _worker(cpu: int, passes: int, conn) -> None:
    os.sched_setaffinity(0, {cpu})
    import numba

    @numba.njit(cache=True)
    def work(row, passes):
        for _ in range(passes):
            for i in range(row.shape[0]):
                row[i] = row[i] * 0.999 + 0.001
        return row[0]

    row = np.ones(SIZE)
    work(row, 10)
    conn.send("ready")
    while True:
        msg = conn.recv()
        if msg is None:
            return
        start_at = msg
        while time.time() < start_at:  # start together with the other vCPU of the pair
            pass
        t0 = time.perf_counter()
        work(row, passes)
        conn.send(time.perf_counter() - t0)


def _run(conns, cpus, delay=0.02) -> list[float]:
    at = time.time() + delay
    for c in cpus:
        conns[c].send(at)
    return [conns[c].recv() for c in cpus]


def groups_of(pairs: dict, n: int, threshold: float = 1.5) -> list[list[int]]:
    """vCPUs joined by a pair whose throughput is below ``threshold`` (connected groups)."""
    parent = list(range(n))

    def root(a):
        while parent[a] != a:
            a = parent[a]
        return a

    for (i, j), r in pairs.items():
        if r < threshold:
            parent[root(j)] = root(i)
    out: dict[int, list[int]] = {}
    for c in range(n):
        out.setdefault(root(c), []).append(c)
    return sorted(out.values())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--passes", type=int, default=120_000, help="passes over the 16 KB per run")
    ap.add_argument("--places", default=None, help="write OMP_PLACES lists to FILE.spread and FILE.packed")
    args = ap.parse_args()
    cpus = sorted(os.sched_getaffinity(0))
    ctx = mp.get_context("spawn")
    conns, procs = {}, []
    for c in cpus:
        a, b = ctx.Pipe()
        p = ctx.Process(target=_worker, args=(c, args.passes, b), daemon=True)
        p.start()
        conns[c], procs = a, procs + [p]
    for c in cpus:
        conns[c].recv()
    alone = {c: min(_run(conns, [c])[0] for _ in range(3)) for c in cpus}
    pairs = {}
    for x, i in enumerate(cpus):
        for j in cpus[x + 1:]:
            best = 0.0
            for _ in range(2):
                ti, tj = _run(conns, [i, j])
                best = max(best, alone[i] / ti + alone[j] / tj)
            pairs[i, j] = best
    for c in cpus:
        conns[c].send(None)
    for p in procs:
        p.join()
    print(f"{len(cpus)} vCPUs; one alone: {1e3 * min(alone.values()):.1f}-{1e3 * max(alone.values()):.1f} ms per run")
    print("throughput of each pair of vCPUs at once (2: two cores, ~1: one core's two hardware threads)")
    print("     " + " ".join(f"{j:5d}" for j in cpus))
    for i in cpus:
        cells = []
        for j in cpus:
            r = pairs.get((i, j), pairs.get((j, i)))
            cells.append("    -" if r is None else f"{r:5.2f}")
        print(f"{i:4d} " + " ".join(cells))
    low = sorted(((r, ij) for ij, r in pairs.items() if r < 1.5))
    print("pairs below 1.5: " + (", ".join(f"{i}+{j} {r:.2f}" for r, (i, j) in low) or "none"))
    groups = groups_of(pairs, max(cpus) + 1)
    groups = [[c for c in g if c in cpus] for g in groups if any(c in cpus for c in g)]
    print(f"{len(groups)} groups sharing a core: " + " ".join("{" + ",".join(map(str, g)) + "}" for g in groups))
    if args.places:
        spread = ",".join("{%d}" % g[0] for g in groups)
        packed = ",".join("{%d}" % c for g in groups for c in g)
        with open(args.places + ".spread", "w") as f:
            f.write(spread + "\n")
        with open(args.places + ".packed", "w") as f:
            f.write(packed + "\n")
        print(f"OMP_PLACES one per core: {spread}")
        print(f"OMP_PLACES siblings together: {packed}")


if __name__ == "__main__":
    sys.exit(main())
