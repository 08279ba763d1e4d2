"""The device rebuild of a batch's large packings as one launch sequence (ensembles per launch).

:mod:`granwave.gpu.neighbours`'s multi-kernel rebuild (twelve launches) is made segmented:
each kernel runs over the concatenated grains (or cells, or packings) of every packing of the
batch (:class:`granwave.gpu.batch.Ensemble`'s arrays, grain i of packing k at ``goff[k] + i``,
its cells from ``coff[k]``), so a batch of B large packings costs the twelve launches of one.
Each kernel calls the single rebuild's device functions on the packing's slices (the trigger,
the cell of a grain, the neighbours of a grain, the merge with the old list's history, the
commit), so each packing's new list, histories, offsets and counters are those of its rebuild
alone, bit for bit.

What differs is only the bookkeeping of the two prefix sums: one scan over the whole batch
(:func:`granwave.gpu.neighbours.scan`, the single rebuild's, on batch-long arrays) instead of
one per packing.

- Cells: the global exclusive sums of the cell counts are used as they are, as each cell's
  start in one batch-long ``members`` array (a packing's cells are contiguous in it, wherever
  it starts); the cell list only decides which grains are compared, never the result.
- Grains: packing k's own offsets are the global ones minus the global one at its first grain
  (exact integers); :func:`rb_fill_batch` writes them into the packing's ``gptr`` rows (where
  the single rebuild's scan writes them) before :func:`rb_merge_batch` and the commit read them.
- The scans sum the rows of packings not rebuilding too (their last counts, bounded by their
  grains; the batch allocates ``gcnt`` zeroed): the differences within a packing do not see
  them, and the cells' starts stay within the batch's grains.

Which packings rebuild in a step is a per-packing mask (``due``: the large packings whose k-th
step this is, ``GpuEngine.rebuild_every``): the trigger clears the rebuild flag (``C_DUE``) of
every other packing, so the kernels after it skip them and their lists stay as they are. A
batch-wide flag (``anyctl[C_DUE]``, set by the trigger where any packing is due, cleared by the
commit) gates the scans, as the single rebuild's flag gates its own.
"""

from __future__ import annotations

import numpy as np

from . import load_cuda, simulated
from . import neighbours as NB
from .neighbours import C_DUE, C_NEED, C_STATUS

cuda = load_cuda()

#: Kernel launches of one segmented rebuild, whatever the number of packings: the trigger, the
#: cell count, a scan (three), the cell fill, the neighbour count, a scan (three), fill, merge, commit.
LAUNCHES = 12


@cuda.jit
def rb_trigger_batch(red, fpars, pistons, lateral, ctl, coff, due, anyctl):
    """One block: packing k's trigger (:func:`granwave.gpu.neighbours._trigger`) where ``due[k]``,
    its rebuild flag cleared where not; ``anyctl[C_DUE]`` = 1 where any is due."""
    t = cuda.threadIdx.x
    for k in range(t, ctl.shape[0], cuda.blockDim.x):
        if due[k] != 0:
            NB._trigger(red[k], fpars[k], pistons[k], lateral[k], ctl[k], coff[k + 1] - coff[k])
        else:
            ctl[k, C_DUE] = 0
    cuda.syncthreads()
    if t == 0:
        for k in range(ctl.shape[0]):
            if ctl[k, C_DUE] != 0:
                anyctl[C_DUE] = 1
                break


@cuda.jit
def rb_cell_count_batch(pos, lateral, pistons, ctl, cell, ccount, coff, gk):
    """Each grain's cell (its packing's own index), counted in its packing's cells."""
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_DUE] == 0:
            continue
        c = NB._cell_of(pos, i, lateral[k], pistons[k], ctl[k])
        cell[i] = c
        cuda.atomic.add(ccount, (coff[k] + c, 0), 1)


@cuda.jit
def rb_cell_fill_batch(ctl, cell, ccount, cstart, members, goff, coff, gk):
    """Each grain (its packing's index) into a slot of its cell's block of the batch-long
    ``members`` (``cstart``: the global exclusive sums of the cells' counts)."""
    for i in range(cuda.grid(1), cell.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_DUE] == 0:
            continue
        c = coff[k] + cell[i]
        s = cuda.atomic.add(ccount, (c, 1), 1)
        members[cstart[c, 0] + s] = i - goff[k]


@cuda.jit
def rb_count_batch(pos, rad, lateral, fpars, ctl, cell, cstart, members, nbr, gcnt, goff, coff, gk):
    """gcnt[i] = (neighbours above grain i of its packing, all its neighbours)."""
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_DUE] == 0:
            continue
        o, e = goff[k], goff[k + 1]
        cnt, lo = NB._neighbours(i - o, pos[o:e], rad[o:e], lateral[k], fpars[k].skin, ctl[k], cell[o:e],
                                 cstart[coff[k]:coff[k + 1] + 1], members, nbr, 0, False)
        gcnt[i, 0] = cnt - lo
        gcnt[i, 1] = cnt


@cuda.jit
def rb_fill_batch(pos, rad, lateral, fpars, ctl, cell, cstart, members, gscan, gptr, nbr, goff, poff, coff, gk):
    """Packing k's capacity test (more pairs than its slots: ``C_NEED``, status 2, its list
    untouched), its own offsets (``gscan``: the global sums) into its rows of ``gptr``, and each
    grain's sorted neighbours into its block of the packing's ``nbr``."""
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_DUE] == 0 or ctl[k, C_STATUS] != 0:
            continue
        o, e, a, b = goff[k], goff[k + 1], poff[k], poff[k + 1]
        m = gscan[e, 0] - gscan[o, 0]
        if m > b - a:
            if i == o:
                ctl[k, C_NEED] = m
                ctl[k, C_STATUS] = 2
            continue
        r = i + k  # grain i's row of its packing's n + 1 offsets (they start at goff[k] + k)
        gptr[r, 0] = gscan[i, 0] - gscan[o, 0]
        gptr[r, 1] = gscan[i, 1] - gscan[o, 1]
        if i == e - 1:
            gptr[r + 1, 0] = m
            gptr[r + 1, 1] = gscan[e, 1] - gscan[o, 1]
        NB._neighbours(i - o, pos[o:e], rad[o:e], lateral[k], fpars[k].skin, ctl[k], cell[o:e],
                       cstart[coff[k]:coff[k + 1] + 1], members, nbr[2 * a:2 * b], gptr[r, 1], True)


@cuda.jit
def rb_merge_batch(ctl, gptr, nbr, row, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code, goff, poff,
                   gk):
    """:func:`granwave.gpu.neighbours._merge` of every grain of every rebuilding packing."""
    for i in range(cuda.grid(1), gk.shape[0], cuda.gridsize(1)):
        k = gk[i]
        if ctl[k, C_DUE] == 0 or ctl[k, C_STATUS] != 0:
            continue
        o, e, a, b = goff[k], goff[k + 1], poff[k], poff[k + 1]
        NB._merge(i - o, gptr[o + k:e + k + 1], nbr[2 * a:2 * b], row[o + k:e + k + 1], pair_j[a:b], pair_ft[a:b],
                  pair_ov[a:b], new_i[a:b], new_j[a:b], new_ft[a:b], new_ov[a:b], new_code[2 * a:2 * b])


@cuda.jit
def rb_commit_batch(ctl, gptr, pos, pos0, new_i, new_j, new_ft, new_ov, new_code, pair_i, pair_j, pair_ft, pair_ov,
                    row, inc_ptr, inc_code, ccount, goff, poff, coff, anyctl):
    """:func:`granwave.gpu.neighbours._commit` on a grid of NPART x packings (blocks (b, k):
    packing k's commit); block (0, 0) clears the batch-wide flag for the next rebuild."""
    k = cuda.blockIdx.y
    g = cuda.blockIdx.x * cuda.blockDim.x + cuda.threadIdx.x
    if k == 0 and g == 0:
        anyctl[C_DUE] = 0  # read by no kernel after this one in this rebuild
    if ctl[k, C_DUE] == 0 or ctl[k, C_STATUS] != 0:
        return
    o, e, a, b, c, f = goff[k], goff[k + 1], poff[k], poff[k + 1], coff[k], coff[k + 1]
    NB._commit(g, cuda.gridDim.x * cuda.blockDim.x, ctl[k], gptr[o + k:e + k + 1], pos[o:e], pos0[o:e], new_i[a:b],
               new_j[a:b], new_ft[a:b], new_ov[a:b], new_code[2 * a:2 * b], pair_i[a:b], pair_j[a:b], pair_ft[a:b],
               pair_ov[a:b], row[o + k:e + k + 1], inc_ptr[o + k:e + k + 1], inc_code[2 * a:2 * b], ccount[c:f])


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (rb_trigger_batch, rb_cell_count_batch, rb_cell_fill_batch, rb_count_batch, rb_fill_batch, rb_merge_batch,
           rb_commit_batch)


def work(ngrains: int, ncells: int) -> dict:
    """The segmented rebuild's own work arrays (beyond the batch's): the global sums of the
    cells' and the grains' counts, the scans' partial sums, the batch-wide control words."""
    z = cuda.device_array
    return dict(cscan=z((ncells + 1, 2), np.int64), gscan=z((ngrains + 1, 2), np.int64),
                spart=z((NB.NPART, 2), np.int64), anyctl=cuda.to_device(np.zeros(NB.N_CTL, np.int64)))


def launch(d: dict, due, npack: int) -> int:
    """Queue the segmented rebuild of the batch ``d`` (:class:`granwave.gpu.batch.Ensemble`'s
    device arrays, with :func:`work`'s) for the packings where the device array ``due`` is 1;
    returns the launches queued (:data:`LAUNCHES`; in the simulator only, one when none is due)."""
    n = d["position"].shape[0]
    nb = NB._blocks(n)
    ctl, anyctl = d["ctl"], d["anyctl"]
    rb_trigger_batch[1, NB.RBLOCK](d["red"], d["fpars"], d["pistons"], d["lateral"], ctl, d["coff"], due, anyctl)
    if simulated() and anyctl.copy_to_host()[C_DUE] == 0:
        return 1  # the simulator only: every launch costs there, and each kernel below would return at once
    rb_cell_count_batch[nb, NB.BLOCK](d["position"], d["lateral"], d["pistons"], ctl, d["cell"], d["ccount"],
                                      d["coff"], d["gk"])
    NB.scan(anyctl, d["ccount"], d["spart"], d["cscan"])
    rb_cell_fill_batch[nb, NB.BLOCK](ctl, d["cell"], d["ccount"], d["cscan"], d["members"], d["goff"], d["coff"],
                                     d["gk"])
    rb_count_batch[nb, NB.BLOCK](d["position"], d["radius"], d["lateral"], d["fpars"], ctl, d["cell"], d["cscan"],
                                 d["members"], d["nbr"], d["gcnt"], d["goff"], d["coff"], d["gk"])
    NB.scan(anyctl, d["gcnt"], d["spart"], d["gscan"])
    rb_fill_batch[nb, NB.BLOCK](d["position"], d["radius"], d["lateral"], d["fpars"], ctl, d["cell"], d["cscan"],
                                d["members"], d["gscan"], d["gptr"], d["nbr"], d["goff"], d["poff"], d["coff"],
                                d["gk"])
    rb_merge_batch[nb, NB.BLOCK](ctl, d["gptr"], d["nbr"], d["row"], d["j"], d["ft"], d["ov"], d["ni"], d["nj"],
                                 d["nft"], d["nov"], d["ncode"], d["goff"], d["poff"], d["gk"])
    rb_commit_batch[(NB.NPART, npack), NB.RBLOCK](ctl, d["gptr"], d["position"], d["pos0"], d["ni"], d["nj"],
                                                  d["nft"], d["nov"], d["ncode"], d["i"], d["j"], d["ft"], d["ov"],
                                                  d["row"], d["ptr"], d["code"], d["ccount"], d["goff"],
                                                  d["poff"], d["coff"], anyctl)
    return LAUNCHES
