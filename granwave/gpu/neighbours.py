"""The Verlet pair list rebuilt on the device: the rebuild test and the rebuild itself, with no
host round trip (:class:`granwave.gpu.dem.GpuEngine` launches these kernels before every step).

The result is the CPU rebuild's (:func:`granwave.dem.neighbours.rebuild`) pair for pair, in the
same order: the pair list is a canonical object, every pair (i < j) whose surfaces are closer
than the skin (the same distance test, :func:`granwave.geometry.periodic_distance2` on (min,
max) compiled from its source), sorted by i then j, and the history of each pair carried from
the old list by that key. The cell list only decides which grains are compared, never the
result, so its layout need not be the CPU's.

Steps (one kernel each, all gated by ``ctl[C_DUE]``; with no rebuild due they return at once):

1. :func:`rb_trigger` (one thread): the CPU engine's test, reach = sqrt(disp2) + 2 vmax dt
   against half the skin, from the last step's reduction (with the test made only every
   k = ``ctl[C_AHEAD]`` steps, reach = sqrt(disp2) + 2 k vmax dt); a non-finite reach stops the run
   (``ctl[C_STATUS] = 3``); the cells per axis (at least 2 R_max + skin wide; one cell for
   all when a lateral axis has fewer than 3, as the CPU);
2. :func:`rb_cell_count` and a prefix sum: grains per cell (integer atomics: counts, whose
   result does not depend on their order), cells' offsets;
3. :func:`rb_cell_fill`: the grains of each cell (slot by an integer atomic: the order within a
   cell varies from run to run, the result below does not, because every row is sorted);
4. :func:`rb_count` and a prefix sum: each grain's neighbours (all, and those above it) and
   their offsets: the pair list's (``row``) and the incidence list's (``ptr``);
5. :func:`rb_fill`: each grain's neighbours, sorted, into its block of ``nbr``; the capacity
   test first: more pairs than room sets ``ctl[C_STATUS] = 2`` and ``ctl[C_NEED]``, and
   leaves the old list and the state untouched (every later kernel of the run then returns at
   once; the host reads the flag at its next check, makes room, and goes on from there);
6. :func:`rb_merge`: each grain's pairs (its neighbours above it) with the history of its old
   block (a merge on j, both sorted), and its incidence list (pairs in increasing pair index:
   first those where it is j, then those where it is i), into new buffers;
7. :func:`rb_commit`: the new buffers copied over the current ones, pos0 = positions, the cell
   counts cleared for the next rebuild, the pair count and rebuild count in ``ctl``.

No floating-point atomics; the integer prefix sums are exact whatever their order.
"""

from __future__ import annotations

import math

import numpy as np

from .. import geometry
from ..dem import kernels as K
from ..dem.neighbours import _wrap_cell
from . import load_cuda, simulated
from .compile import _rebound, device_functions

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

_DF = device_functions()
periodic_distance2 = cuda.jit(device=True)(_rebound(geometry.periodic_distance2.py_func,
                                                    {"nearest_image": _DF.nearest_image}))

BLOCK = 8 if simulated() else 128
RBLOCK = 4 if simulated() else 256
NPART = 2 if simulated() else 264

# the control words (int64) the device keeps and the host reads at checks
C_STATUS, C_DUE, C_STEPS, C_REBUILDS, C_NPAIRS, C_NEED, C_NC0, C_NC1, C_NC2, C_AHEAD = range(10)
N_CTL = 10

# the per-step reduction the trigger reads (granwave.gpu.dem's ``red``)
R_DISP2 = 5
R_VMAX = 6


@cuda.jit
def rb_trigger(red, fpar1, piston1, lateral, ctl, ncell_cap):
    """One thread: is a rebuild due before this step (and the cells per axis)?"""
    fpar = fpar1[0]  # the records (granwave.dem.layout), uploaded as one-element arrays
    piston = piston1[0]
    if cuda.grid(1) == 0:
        _trigger(red, fpar, piston, lateral, ctl, ncell_cap)


@cuda.jit(device=True)
def _trigger(red, fpar, piston, lateral, ctl, ncell_cap):
    ctl[C_DUE] = 0
    if ctl[C_STATUS] != 0:
        return
    # the CPU engine's reach, for the C_AHEAD steps until the test runs again (1: the CPU's own)
    ahead = ctl[C_AHEAD]
    if ahead == 1:
        reach = math.sqrt(red[R_DISP2]) + 2.0 * red[R_VMAX] * fpar.dt
    else:
        reach = math.sqrt(red[R_DISP2]) + 2.0 * ahead * red[R_VMAX] * fpar.dt
    if not reach < math.inf:  # the state blew up (unstable step): stop before the rebuild
        ctl[C_STATUS] = 3
        return
    skin = fpar.skin
    if not reach > 0.5 * skin:
        return
    d = lateral.shape[0] + 1
    cs = 2.0 * fpar.r_max + skin
    brute = False
    nlat = 1
    for a in range(d - 1):
        c = int(math.floor(lateral[a] / cs))
        if c < 3:
            brute = True
        ctl[C_NC0 + a] = c
        nlat *= c
    nv = int(math.floor(piston.h / cs))
    if nv < 1:
        nv = 1
    if brute:
        for a in range(d - 1):
            ctl[C_NC0 + a] = 1
        nlat = 1
        nv = 1
    if nlat * nv > ncell_cap:  # larger cells: the same pairs, more distances to test
        nv = ncell_cap // nlat
    ctl[C_NC0 + d - 1] = nv
    ctl[C_DUE] = 1


@cuda.jit(device=True)
def _cell_of(pos, i, lateral, piston, ctl):
    d = pos.shape[1]
    idx = 0
    for a in range(d):
        nc = ctl[C_NC0 + a]
        length = lateral[a] if a < d - 1 else piston.h
        c = int(math.floor(pos[i, a] / length * nc))
        if c < 0:
            c = 0
        if c > nc - 1:
            c = nc - 1
        idx = idx * nc + c
    return idx


@cuda.jit
def rb_cell_count(pos, lateral, piston1, ctl, cell, ccount):
    """Each grain's cell, and the grains per cell (ccount[:, 0], zero on entry)."""
    piston = piston1[0]  # the record (granwave.dem.layout), uploaded as a one-element array
    if ctl[C_DUE] == 0:
        return
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        c = _cell_of(pos, i, lateral, piston, ctl)
        cell[i] = c
        cuda.atomic.add(ccount, (c, 0), 1)


@cuda.jit
def rb_cell_fill(ctl, cell, ccount, cstart, members):
    """Each grain into a slot of its cell's block of ``members`` (ccount[:, 1] counts them)."""
    if ctl[C_DUE] == 0:
        return
    for i in range(cuda.grid(1), cell.shape[0], cuda.gridsize(1)):
        c = cell[i]
        k = cuda.atomic.add(ccount, (c, 1), 1)
        members[cstart[c, 0] + k] = i


#: The CPU cell list's periodic fold (granwave.dem.neighbours._wrap_cell), compiled for the device.
_wrap = cuda.jit(device=True)(_wrap_cell.py_func)


@cuda.jit(device=True)
def _visit_cell(i, idx, pos, rad, lateral, skin, cstart, members, out, base, write, cnt, lo):
    """Grain i's neighbours among the members of cell ``idx``: counted, and with ``write``
    inserted into the sorted row out[base:base + cnt]."""
    for q in range(cstart[idx, 0], cstart[idx + 1, 0]):
        j = members[q]
        if j == i:
            continue
        a = i if i < j else j
        b = j if i < j else i
        lim = rad[a] + rad[b] + skin
        if periodic_distance2(pos, b, pos, a, lateral) < lim * lim:
            if write:
                s = cnt
                while s > 0 and out[base + s - 1] > j:
                    out[base + s] = out[base + s - 1]
                    s -= 1
                out[base + s] = j
            cnt += 1
            if j < i:
                lo += 1
    return cnt, lo


@cuda.jit(device=True)
def _neighbours(i, pos, rad, lateral, skin, ctl, cell, cstart, members, out, base, write):
    """(neighbours, those below i) of grain i, from the cells around its own (lateral axes
    wrap, the vertical one is clamped; one cell: that one only)."""
    d = pos.shape[1]
    nc0 = ctl[C_NC0]
    nc1 = ctl[C_NC1]
    nc2 = ctl[C_NC2] if d == 3 else 1
    c = cell[i]
    cz = c % nc2  # 2D: nc2 = 1, cz = 0
    rest = c // nc2
    cy = rest % nc1
    cx = rest // nc1
    cnt = 0
    lo = 0
    for o0 in range(-1, 2):
        if nc0 == 1 and o0 != 0:
            continue
        x = _wrap(cx + o0, nc0)
        for o1 in range(-1, 2):
            if d == 2:
                y = cy + o1
                if y < 0 or y >= nc1:
                    continue
                cnt, lo = _visit_cell(i, x * nc1 + y, pos, rad, lateral, skin, cstart, members, out, base, write,
                                      cnt, lo)
            else:
                if nc1 == 1 and o1 != 0:
                    continue
                y = _wrap(cy + o1, nc1)
                for o2 in range(-1, 2):
                    z = cz + o2
                    if z < 0 or z >= nc2:
                        continue
                    cnt, lo = _visit_cell(i, (x * nc1 + y) * nc2 + z, pos, rad, lateral, skin, cstart, members,
                                          out, base, write, cnt, lo)
    return cnt, lo


@cuda.jit
def rb_count(pos, rad, lateral, fpar1, ctl, cell, cstart, members, nbr, gcnt):
    """gcnt[i] = (neighbours above i, all neighbours) (``nbr`` is not written)."""
    fpar = fpar1[0]  # the record (granwave.dem.layout), uploaded as a one-element array
    if ctl[C_DUE] == 0:
        return
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        cnt, lo = _neighbours(i, pos, rad, lateral, fpar.skin, ctl, cell, cstart, members, nbr, 0, False)
        gcnt[i, 0] = cnt - lo
        gcnt[i, 1] = cnt


@cuda.jit
def rb_fill(pos, rad, lateral, fpar1, ctl, cell, cstart, members, gptr, nbr, cap):
    """Capacity test, then each grain's sorted neighbours into nbr[gptr[i, 1]:gptr[i + 1, 1]]."""
    fpar = fpar1[0]  # the record (granwave.dem.layout), uploaded as a one-element array
    n = pos.shape[0]
    if ctl[C_DUE] == 0 or ctl[C_STATUS] != 0:
        return
    m = gptr[n, 0]
    if m > cap:
        if cuda.grid(1) == 0:
            ctl[C_NEED] = m
            ctl[C_STATUS] = 2
        return
    for i in range(cuda.grid(1), n, cuda.gridsize(1)):
        _neighbours(i, pos, rad, lateral, fpar.skin, ctl, cell, cstart, members, nbr, gptr[i, 1], True)


@cuda.jit
def rb_merge(ctl, gptr, nbr, row, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code):
    """Grain i's new pairs with the history of its old block (``row``: the old offsets), and
    its incidence list (p + 1 where it is the pair's i, -(p + 1) where it is its j)."""
    if ctl[C_DUE] == 0 or ctl[C_STATUS] != 0:
        return
    for i in range(cuda.grid(1), gptr.shape[0] - 1, cuda.gridsize(1)):
        _merge(i, gptr, nbr, row, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code)


@cuda.jit(device=True)
def _merge(i, gptr, nbr, row, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code):
    d = pair_ft.shape[1]  # every history column: the tangential one, then a rolling one
    base = gptr[i, 1]
    cnt = gptr[i + 1, 1] - base
    up = gptr[i + 1, 0] - gptr[i, 0]
    lo = cnt - up
    q = row[i]
    q_end = row[i + 1]
    for t in range(up):
        p = gptr[i, 0] + t
        j = nbr[base + lo + t]
        new_i[p] = i
        new_j[p] = j
        new_ov[p] = 0.0
        for a in range(d):
            new_ft[p, a] = 0.0
        while q < q_end and pair_j[q] < j:
            q += 1
        if q < q_end and pair_j[q] == j:
            new_ov[p] = pair_ov[q]
            for a in range(d):
                new_ft[p, a] = pair_ft[q, a]
    for t in range(lo):  # pairs (j, i), j < i: at j's offset plus the place of i among j's partners above j
        j = nbr[base + t]
        bj = gptr[j, 1]
        upj = gptr[j + 1, 0] - gptr[j, 0]
        s = bj + (gptr[j + 1, 1] - bj) - upj
        k = 0
        while nbr[s + k] != i:
            k += 1
        new_code[base + t] = -(gptr[j, 0] + k + 1)
    for t in range(lo, cnt):
        new_code[base + t] = gptr[i, 0] + t - lo + 1


@cuda.jit
def rb_commit(ctl, gptr, pos, pos0, new_i, new_j, new_ft, new_ov, new_code, pair_i, pair_j, pair_ft, pair_ov,
              row, inc_ptr, inc_code, ccount):
    """The new list over the current one (a grid-stride loop), pos0 = positions, cell counts
    cleared; thread 0 stores the pair count and counts the rebuild."""
    if ctl[C_DUE] == 0 or ctl[C_STATUS] != 0:
        return
    _commit(cuda.grid(1), cuda.gridsize(1), ctl, gptr, pos, pos0, new_i, new_j, new_ft, new_ov, new_code, pair_i,
            pair_j, pair_ft, pair_ov, row, inc_ptr, inc_code, ccount)


@cuda.jit(device=True)
def _commit(g, stride, ctl, gptr, pos, pos0, new_i, new_j, new_ft, new_ov, new_code, pair_i, pair_j, pair_ft,
            pair_ov, row, inc_ptr, inc_code, ccount):
    n, d = pos.shape
    m = gptr[n, 0]
    w = pair_ft.shape[1]
    for p in range(g, m, stride):
        pair_i[p] = new_i[p]
        pair_j[p] = new_j[p]
        pair_ov[p] = new_ov[p]
        for a in range(w):
            pair_ft[p, a] = new_ft[p, a]
    for k in range(g, 2 * m, stride):
        inc_code[k] = new_code[k]
    for k in range(g, n + 1, stride):
        row[k] = gptr[k, 0]
        inc_ptr[k] = gptr[k, 1]
    for i in range(g, n, stride):
        for a in range(d):
            pos0[i, a] = pos[i, a]
    for c in range(g, ccount.shape[0], stride):
        ccount[c, 0] = 0
        ccount[c, 1] = 0
    if g == 0:
        ctl[C_NPAIRS] = m
        ctl[C_REBUILDS] += 1


@cuda.jit(device=True)
def _serial_scan(x, out):
    """out[k + 1] = sum of x[:k + 1] by column (two columns), out[0] = 0: one thread."""
    a0 = 0
    a1 = 0
    out[0, 0] = 0
    out[0, 1] = 0
    for k in range(x.shape[0]):
        a0 += x[k, 0]
        a1 += x[k, 1]
        out[k + 1, 0] = a0
        out[k + 1, 1] = a1


@cuda.jit
def rb_small(red, fpar1, piston1, lateral, pos, rad, pos0, ctl, cell, ccount, cstart, members, gcnt, gptr, nbr, row,
             pair_i, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code, inc_ptr, inc_code):
    """The whole rebuild, trigger included, in one block (small systems: one launch per step
    instead of twelve): the steps of the multi-kernel rebuild, the same device functions,
    separated by barriers, the prefix sums by one thread."""
    # the records (granwave.dem.layout), uploaded as one-element arrays
    _small(cuda.threadIdx.x, cuda.blockDim.x, red, fpar1[0], piston1[0], lateral, pos, rad, pos0, ctl, cell, ccount,
           cstart, members, gcnt, gptr, nbr, row, pair_i, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov,
           new_code, inc_ptr, inc_code)


@cuda.jit(device=True)
def _small(t, s, red, fpar, piston, lateral, pos, rad, pos0, ctl, cell, ccount, cstart, members, gcnt, gptr, nbr,
           row, pair_i, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code, inc_ptr, inc_code):
    """The block's work in :func:`rb_small` (thread t of s; the batched engine's
    :func:`granwave.gpu.batch.rb_small_batch` calls it per packing)."""
    if t == 0:
        _trigger(red, fpar, piston, lateral, ctl, ccount.shape[0])
    cuda.syncthreads()
    if ctl[C_DUE] == 0:
        return
    n = pos.shape[0]
    skin = fpar.skin
    for i in range(t, n, s):
        c = _cell_of(pos, i, lateral, piston, ctl)
        cell[i] = c
        cuda.atomic.add(ccount, (c, 0), 1)
    cuda.syncthreads()
    if t == 0:
        _serial_scan(ccount, cstart)
    cuda.syncthreads()
    for i in range(t, n, s):
        c = cell[i]
        k = cuda.atomic.add(ccount, (c, 1), 1)
        members[cstart[c, 0] + k] = i
    cuda.syncthreads()
    for i in range(t, n, s):
        cnt, lo = _neighbours(i, pos, rad, lateral, skin, ctl, cell, cstart, members, nbr, 0, False)
        gcnt[i, 0] = cnt - lo
        gcnt[i, 1] = cnt
    cuda.syncthreads()
    if t == 0:
        _serial_scan(gcnt, gptr)
    cuda.syncthreads()
    m = gptr[n, 0]
    if m > pair_i.shape[0]:  # no room: the old list stays, the run stops on the device
        if t == 0:
            ctl[C_NEED] = m
            ctl[C_STATUS] = 2
        return
    for i in range(t, n, s):
        _neighbours(i, pos, rad, lateral, skin, ctl, cell, cstart, members, nbr, gptr[i, 1], True)
    cuda.syncthreads()
    for i in range(t, n, s):
        _merge(i, gptr, nbr, row, pair_j, pair_ft, pair_ov, new_i, new_j, new_ft, new_ov, new_code)
    cuda.syncthreads()
    _commit(t, s, ctl, gptr, pos, pos0, new_i, new_j, new_ft, new_ov, new_code, pair_i, pair_j, pair_ft, pair_ov,
            row, inc_ptr, inc_code, ccount)


# ---------------------------------------------------------------- exclusive prefix sums (int64)
@cuda.jit(device=True)
def _segment(b, length):
    """Rows [lo, hi) of block b when ``length`` rows are cut into NPART contiguous segments."""
    seg = (length + NPART - 1) // NPART
    lo = b * seg
    hi = lo + seg
    if hi > length:
        hi = length
    return lo, hi


@cuda.jit
def scan_partials(ctl, x, part):
    """NPART blocks: block b sums its contiguous segment of each of x's two columns."""
    if ctl[C_DUE] == 0 or ctl[C_STATUS] != 0:
        return
    t = cuda.threadIdx.x
    b = cuda.blockIdx.x
    lo, hi = _segment(b, x.shape[0])
    s0 = cuda.shared.array(RBLOCK, np.int64)
    s1 = cuda.shared.array(RBLOCK, np.int64)
    a0 = 0
    a1 = 0
    for k in range(lo + t, hi, RBLOCK):
        a0 += x[k, 0]
        a1 += x[k, 1]
    s0[t] = a0
    s1[t] = a1
    cuda.syncthreads()
    half = RBLOCK // 2
    while half > 0:
        if t < half:
            s0[t] += s0[t + half]
            s1[t] += s1[t + half]
        cuda.syncthreads()
        half //= 2
    if t == 0:
        part[b, 0] = s0[0]
        part[b, 1] = s1[0]


@cuda.jit
def scan_offsets(ctl, part):
    """One thread: the NPART partial sums turned into exclusive offsets, in place."""
    if cuda.grid(1) != 0 or ctl[C_DUE] == 0 or ctl[C_STATUS] != 0:
        return
    a0 = 0
    a1 = 0
    for b in range(part.shape[0]):
        v0 = part[b, 0]
        v1 = part[b, 1]
        part[b, 0] = a0
        part[b, 1] = a1
        a0 += v0
        a1 += v1


@cuda.jit
def scan_apply(ctl, x, part, out):
    """NPART blocks: out[k + 1] = sum of x[:k + 1] (both columns), out[0] = 0; each block scans
    its segment tile by tile (a shared-memory scan per tile) from its offset."""
    if ctl[C_DUE] == 0 or ctl[C_STATUS] != 0:
        return
    t = cuda.threadIdx.x
    b = cuda.blockIdx.x
    lo, hi = _segment(b, x.shape[0])
    s0 = cuda.shared.array(RBLOCK, np.int64)
    s1 = cuda.shared.array(RBLOCK, np.int64)
    c0 = part[b, 0]
    c1 = part[b, 1]
    if b == 0 and t == 0:
        out[0, 0] = 0
        out[0, 1] = 0
    base = lo
    while base < hi:
        k = base + t
        v0 = 0
        v1 = 0
        if k < hi:
            v0 = x[k, 0]
            v1 = x[k, 1]
        s0[t] = v0
        s1[t] = v1
        cuda.syncthreads()
        off = 1
        while off < RBLOCK:
            u0 = 0
            u1 = 0
            if t >= off:
                u0 = s0[t - off]
                u1 = s1[t - off]
            cuda.syncthreads()
            s0[t] += u0
            s1[t] += u1
            cuda.syncthreads()
            off *= 2
        if k < hi:
            out[k + 1, 0] = c0 + s0[t]
            out[k + 1, 1] = c1 + s1[t]
        c0 += s0[RBLOCK - 1]
        c1 += s1[RBLOCK - 1]
        cuda.syncthreads()
        base += RBLOCK


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (rb_trigger, rb_cell_count, rb_cell_fill, rb_count, rb_fill, rb_merge, rb_commit, scan_partials,
           scan_offsets, scan_apply, rb_small)

#: Grains up to which the one-block rebuild (:func:`rb_small`) is used.
SMALL = 4096


def _blocks(n: int) -> int:
    """Blocks for n items (the kernels are grid-stride loops): one thread per item on a GPU, at
    most two blocks in the simulator (each simulated thread costs)."""
    b = max(1, (n + BLOCK - 1) // BLOCK)
    return min(b, 2) if simulated() else b


def cell_capacity(lateral, height: float, rmax: float, skin: float) -> int:
    """Cells the device arrays have room for: twice the cells of a box of this height (a
    higher piston later gets taller cells, :func:`rb_trigger`)."""
    cs = 2.0 * rmax + skin
    nlat = 1
    for length in np.atleast_1d(lateral):
        nlat *= max(1, int(length // cs))
    return max(1, 2 * nlat * max(1, int(height // cs)))


def scan(ctl, x, part, out) -> None:
    """out (L + 1, 2) = exclusive prefix sums of x (L, 2) by column, on the device (gated)."""
    scan_partials[NPART, RBLOCK](ctl, x, part)
    scan_offsets[1, 1](ctl, part)
    scan_apply[NPART, RBLOCK](ctl, x, part, out)


def launch_rebuild(g: dict, gp: dict, small: int = SMALL) -> None:
    """Queue the rebuild kernels (each returns at once unless a rebuild is due): ``g`` the
    engine's device state, ``gp`` its pair arrays (granwave.gpu.dem.GpuEngine.upload); up to
    ``small`` grains the one-block kernel :func:`rb_small`."""
    n = g["position"].shape[0]
    nb = _blocks(n)
    ctl = g["ctl"]
    if n <= small:
        rb_small[1, RBLOCK](g["red"], g["fpar"], g["piston"], g["lateral"], g["position"], g["radius"], g["pos0"],
                            ctl, gp["cell"], gp["ccount"], gp["cstart"], gp["members"], gp["gcnt"], gp["gptr"],
                            gp["nbr"], gp["row"], gp["i"], gp["j"], gp["ft"], gp["ov"], gp["ni"], gp["nj"],
                            gp["nft"], gp["nov"], gp["ncode"], gp["ptr"], gp["code"])
        return
    rb_trigger[1, 1](g["red"], g["fpar"], g["piston"], g["lateral"], ctl, gp["ccount"].shape[0])
    if simulated() and ctl.copy_to_host()[C_DUE] == 0:
        return  # the simulator only: every launch costs there, and each kernel below would return at once
    rb_cell_count[nb, BLOCK](g["position"], g["lateral"], g["piston"], ctl, gp["cell"], gp["ccount"])
    scan(ctl, gp["ccount"], gp["part"], gp["cstart"])
    rb_cell_fill[nb, BLOCK](ctl, gp["cell"], gp["ccount"], gp["cstart"], gp["members"])
    rb_count[nb, BLOCK](g["position"], g["radius"], g["lateral"], g["fpar"], ctl, gp["cell"], gp["cstart"],
                        gp["members"], gp["nbr"], gp["gcnt"])
    scan(ctl, gp["gcnt"], gp["part"], gp["gptr"])
    rb_fill[nb, BLOCK](g["position"], g["radius"], g["lateral"], g["fpar"], ctl, gp["cell"], gp["cstart"],
                       gp["members"], gp["gptr"], gp["nbr"], gp["i"].shape[0])
    rb_merge[nb, BLOCK](ctl, gp["gptr"], gp["nbr"], gp["row"], gp["j"], gp["ft"], gp["ov"], gp["ni"], gp["nj"],
                        gp["nft"], gp["nov"], gp["ncode"])
    rb_commit[NPART, RBLOCK](ctl, gp["gptr"], g["position"], g["pos0"], gp["ni"],
                             gp["nj"], gp["nft"], gp["nov"], gp["ncode"], gp["i"], gp["j"], gp["ft"], gp["ov"],
                             gp["row"], gp["ptr"], gp["code"], gp["ccount"])
