"""Verlet pair list built with a cell list, in parallel; contact history carried across rebuilds.

The list holds every pair (i < j) whose surfaces are closer than ``skin``
(nearest periodic image along the lateral axes). It stays valid while no grain
has moved more than skin/2 since the build (the engine checks that before each
step). Pairs are kept sorted by the key i*N + j, so the tangential force and
last overlap of each pair are carried from the old list to the new one by a
merge on that key: contact history survives rebuilds.

Parallel and deterministic (the result does not depend on the thread count):
every grain finds all its neighbours (both directions) independently and keeps
them sorted (``nbr[i, :ncnt[i]]``, the ``nlo[i]`` ones below i first); a
prefix sum over the counts of partners above i gives each grain's block of
pairs (``row[i]:row[i+1]``, the pair list's CSR offsets), which that grain
fills and merges with its old block. The same rebuild writes each grain's
*gather list* ``gl[i, :ncnt[i]]``: the indices of its pairs in increasing
pair order (first those where it is j, then those where it is i), through
which the force kernel adds each grain's pair forces in the order of the
former serial loop (docs/dem.md, "Parallel engine").
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..geometry import periodic_distance2
from .. import threads as _threads  # noqa: F401  (selects the threading layer first)
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True, inline="always")
def _pair_distance2(pos, rad, lateral, skin, i, j):
    """(r^2, reach^2) of grains i and j, evaluated as (min, max) so that both grains agree."""
    a = np.int64(i)  # a prange index may be unsigned: mixed with int64 it would give a float
    b = np.int64(j)
    lo = min(a, b)
    hi = max(a, b)
    lim = rad[lo] + rad[hi] + skin
    return periodic_distance2(pos, hi, pos, lo, lateral), lim * lim


@numba.njit(cache=True, inline="always")
def _insert(nbr, i, cnt, j):
    """Insert j into the sorted row nbr[i, :cnt] (only the slots that exist)."""
    width = nbr.shape[1]
    q = cnt
    while q > 0 and nbr[i, q - 1] > j:
        if q < width:
            nbr[i, q] = nbr[i, q - 1]
        q -= 1
    if q < width:
        nbr[i, q] = j


@numba.njit(cache=True, parallel=True)
def find_neighbours(pos, rad, lateral, h, skin, nbr, ncnt, nlo):
    """Every grain's neighbours within ``skin`` (gap), sorted, into ``nbr``; counts into
    ``ncnt`` (may exceed the width of ``nbr``: then the caller must grow it) and ``nlo``
    (those below i). Positions must be wrapped into [0, L).

    Cell list with cells at least 2 R_max + skin wide (periodic lateral axes, the
    vertical axis clamped to [0, h]); all grains when a lateral axis has fewer than 3
    cells (tiny boxes).
    """
    n, d = pos.shape
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, rad[i])
    cs = 2.0 * rmax + skin
    nc = np.empty(d, np.int64)
    brute = np.bool_(False)  # not a literal: one compiled _search (dem/serial.py's note)
    for a in range(d - 1):
        nc[a] = int(lateral[a] // cs)
        if nc[a] < 3:
            brute = True
    nc[d - 1] = max(1, int(h // cs))
    if brute:
        for a in range(d):
            nc[a] = 1
    ncell = 1
    for a in range(d):
        ncell *= nc[a]
    coord = np.empty((n, d), np.int64)
    cell = np.empty(n, np.int64)
    for i in range(n):  # O(n): serial (a parallel loop costs more compilation than it saves)
        idx = 0
        for a in range(d):
            length = lateral[a] if a < d - 1 else h
            c = int(math.floor(pos[i, a] / length * nc[a]))
            c = min(max(c, 0), nc[a] - 1)
            coord[i, a] = c
            idx = idx * nc[a] + c
        cell[i] = idx
    # grains of each cell, contiguous (counting sort; serial, O(n))
    start = np.zeros(ncell + 1, np.int64)
    for i in range(n):
        start[cell[i] + 1] += 1
    for c in range(ncell):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(n, np.int64)
    for i in range(n):
        members[fill[cell[i]]] = i
        fill[cell[i]] += 1
    for i in numba.prange(n):
        _search(np.int64(i), pos, rad, lateral, skin, coord, nc, start, members, brute, nbr, ncnt, nlo)


@numba.njit(cache=True)
def _search(i, pos, rad, lateral, skin, coord, nc, start, members, brute, nbr, ncnt, nlo):
    """Grain i's neighbours in the cells around its own (all grains when ``brute``), sorted."""
    d = pos.shape[1]
    cnt = 0
    lo = 0
    if brute:
        cnt, lo = _search_run(i, start[0], start[1], pos, rad, lateral, skin, members, nbr, cnt, lo)
    else:
        # the 3^d cells around, by offsets -1, 0, 1 per lateral axis (they wrap: nc >= 3 there,
        # else brute); along the vertical axis (clamped, not periodic) the three cells are
        # consecutive in the cell order, so their members are one run: one loop instead of three,
        # whose short trip counts cost most of a rebuild. Written without / and %: an integer
        # division per axis and cell was most of a rebuild's time (insertion keeps the row sorted,
        # so the visiting order does not matter)
        nv = nc[d - 1]
        cv = coord[i, d - 1]
        v_lo = max(cv - 1, 0)
        v_hi = min(cv + 1, nv - 1)
        for o0 in range(-1, 2):
            x = _wrap_cell(coord[i, 0] + o0, nc[0])
            if d == 2:
                base = x * nv
                cnt, lo = _search_run(i, start[base + v_lo], start[base + v_hi + 1], pos, rad, lateral, skin,
                                      members, nbr, cnt, lo)
            else:
                for o1 in range(-1, 2):
                    base = (x * nc[1] + _wrap_cell(coord[i, 1] + o1, nc[1])) * nv
                    cnt, lo = _search_run(i, start[base + v_lo], start[base + v_hi + 1], pos, rad, lateral, skin,
                                          members, nbr, cnt, lo)
    ncnt[i] = cnt
    nlo[i] = lo


@numba.njit(cache=True, inline="always")
def _wrap_cell(c, n):
    """Cell index c in [-1, n] folded into [0, n) (periodic axis)."""
    if c < 0:
        return c + n
    if c >= n:
        return c - n
    return c


@numba.njit(cache=True, inline="always")
def _search_run(i, q_start, q_stop, pos, rad, lateral, skin, members, nbr, cnt, lo):
    """Add grain i's neighbours among ``members[q_start:q_stop]`` (cells next to each other in
    the cell order) to its sorted row."""
    for q in range(q_start, q_stop):
        j = members[q]
        if j == i:
            continue
        r2, lim2 = _pair_distance2(pos, rad, lateral, skin, i, j)
        if r2 < lim2:
            _insert(nbr, i, cnt, j)
            cnt += 1
            if j < i:
                lo += 1
    return cnt, lo


@numba.njit(cache=True, parallel=True)
def rebuild(pos, rad, lateral, h, skin, pair_i, pair_j, pair_ft, pair_ov, n_old, nbr, ncnt, nlo, row, gl,
            need):
    """Wrap positions, rebuild the pair list and the gather lists in place, carry history by (i, j).

    The wrap matters only for a new engine's first build: the engine's drift keeps every
    lateral coordinate in [0, L) (``kernels.drift_grain``), so later it changes no bit.

    Returns the new number of pairs, or -1 when the arrays are too small
    (``need[0]``: pairs needed, ``need[1]``: neighbours per grain; the pair list and
    its history are then left untouched). ``row`` (N + 1) holds the pair list's
    offsets per grain i (old ones on entry, new ones on exit).
    """
    n, d = pos.shape
    for i in range(n):  # O(n) loops stay serial: each parallel loop lengthens compilation
        for a in range(d - 1):
            x = pos[i, a] % lateral[a]
            pos[i, a] = x if x < lateral[a] else 0.0
    find_neighbours(pos, rad, lateral, h, skin, nbr, ncnt, nlo)
    width = 0
    new_row = np.empty(n + 1, np.int64)
    new_row[0] = 0
    for i in range(n):
        width = max(width, ncnt[i])
        new_row[i + 1] = new_row[i] + ncnt[i] - nlo[i]
    m = new_row[n]
    need[0] = m
    need[1] = width
    if m > pair_i.shape[0] or width > nbr.shape[1]:
        return -1
    new_j = np.empty(m, np.int64)
    new_ft = np.zeros((m, pair_ft.shape[1]))  # the whole history: F_t and a sub-model's columns after it
    new_ov = np.zeros(m)
    for i in numba.prange(n):
        _merge(np.int64(i), n_old, row, new_row, nbr, ncnt, nlo, pair_j, pair_ft, pair_ov, new_j, new_ft, new_ov)
    for i in range(n + 1):
        row[i] = new_row[i]
    for i in numba.prange(n):
        _store(np.int64(i), new_row, nbr, ncnt, nlo, new_j, new_ft, new_ov, pair_i, pair_j, pair_ft, pair_ov, gl)
    return m


@numba.njit(cache=True)
def _merge(i, n_old, row, new_row, nbr, ncnt, nlo, pair_j, pair_ft, pair_ov, new_j, new_ft, new_ov):
    """Grain i's new block of pairs (its partners above i) with the history of its old block."""
    d = pair_ft.shape[1]
    q = row[i]
    q_end = row[i + 1] if n_old > 0 else 0
    lo = nlo[i]
    for t in range(ncnt[i] - lo):
        p = new_row[i] + t
        j = nbr[i, lo + t]
        new_j[p] = j
        while q < q_end and pair_j[q] < j:
            q += 1
        if q < q_end and pair_j[q] == j:
            new_ov[p] = pair_ov[q]
            for a in range(d):
                new_ft[p, a] = pair_ft[q, a]


@numba.njit(cache=True)
def _store(i, new_row, nbr, ncnt, nlo, new_j, new_ft, new_ov, pair_i, pair_j, pair_ft, pair_ov, gl):
    """Grain i's block into the pair list, and its gather list."""
    d = pair_ft.shape[1]
    for p in range(new_row[i], new_row[i + 1]):
        pair_i[p] = i
        pair_j[p] = new_j[p]
        pair_ov[p] = new_ov[p]
        for a in range(d):
            pair_ft[p, a] = new_ft[p, a]
    # gather list: pairs (j, i), j < i, at row[j] + (place of i among j's partners above j)
    lo = nlo[i]
    for t in range(lo):
        j = nbr[i, t]
        q = nlo[j]
        while nbr[j, q] != i:
            q += 1
        gl[i, t] = new_row[j] + q - nlo[j]
    for t in range(lo, ncnt[i]):
        gl[i, t] = new_row[i] + t - lo


def candidate_keys(pos, rad, lateral, h, skin) -> np.ndarray:
    """Sorted keys i*N + j (i < j) of the pairs with surface gap below ``skin`` (the pair
    list :func:`rebuild` makes; positions wrapped into [0, L))."""
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    n = pos.shape[0]
    width = 16
    while True:
        nbr = np.zeros((n, width), np.int64)
        ncnt = np.zeros(n, np.int64)
        nlo = np.zeros(n, np.int64)
        find_neighbours(pos, np.ascontiguousarray(rad, dtype=np.float64),
                        np.ascontiguousarray(lateral, dtype=np.float64), float(h), float(skin), nbr, ncnt, nlo)
        if n == 0 or ncnt.max() <= width:
            break
        width = int(ncnt.max())
    return np.concatenate([i * n + nbr[i, nlo[i]:ncnt[i]] for i in range(n)] + [np.zeros(0, np.int64)])
