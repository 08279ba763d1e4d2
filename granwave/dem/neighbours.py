"""Verlet pair list built with a cell list; contact history carried across rebuilds.

The list holds every pair (i < j) whose surfaces are closer than ``skin``
(nearest periodic image along the lateral axes). It stays valid while no grain
has moved more than skin/2 since the build (the engine checks that before each
step). Pairs are kept sorted by the key i*N + j, so the tangential force and
last overlap of each pair are carried from the old list to the new one by a
merge on that key: contact history survives rebuilds.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..geometry import periodic_distance2


@numba.njit(cache=True)
def _push(keys, m, key):
    if m == keys.shape[0]:
        bigger = np.empty(2 * keys.shape[0], np.int64)
        for k in range(m):  # an explicit loop: slice assignment compiles shape-check machinery
            bigger[k] = keys[k]
        keys = bigger
    keys[m] = key
    return keys


@numba.njit(cache=True)
def candidate_keys(pos, rad, lateral, h, skin):
    """Sorted keys i*N + j (i < j) of the pairs with surface gap below ``skin``.

    Cell list with cells at least 2 R_max + skin wide (periodic lateral axes,
    the vertical axis clamped to [0, h]); all pairs when a lateral axis has
    fewer than 3 cells (tiny boxes). Positions must be wrapped into [0, L).
    """
    n, d = pos.shape
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, rad[i])
    cs = 2.0 * rmax + skin
    keys = np.empty(max(16, 8 * n), np.int64)
    m = 0
    nc = np.empty(d, np.int64)
    brute = False
    for a in range(d - 1):
        nc[a] = int(lateral[a] // cs)
        if nc[a] < 3:
            brute = True
    nc[d - 1] = max(1, int(h // cs))
    if brute:
        for i in range(n):
            for j in range(i + 1, n):
                r2 = periodic_distance2(pos, j, pos, i, lateral)
                lim = rad[i] + rad[j] + skin
                if r2 < lim * lim:
                    keys = _push(keys, m, i * n + j)
                    m += 1
        return keys[:m]
    ncell = 1
    for a in range(d):
        ncell *= nc[a]
    head = np.full(ncell, -1, np.int64)
    nxt = np.empty(n, np.int64)
    coord = np.empty((n, d), np.int64)
    for i in range(n):
        idx = 0
        for a in range(d):
            length = lateral[a] if a < d - 1 else h
            c = int(math.floor(pos[i, a] / length * nc[a]))
            c = min(max(c, 0), nc[a] - 1)
            coord[i, a] = c
            idx = idx * nc[a] + c
        nxt[i] = head[idx]
        head[idx] = i
    n_off = 3**d
    cc = np.empty(d, np.int64)
    # the partners j > i of one grain i, sorted by insertion (a handful): the keys then come
    # out sorted without a global sort (np.sort costs seconds of compilation)
    mine = np.empty(n, np.int64)
    for i in range(n):
        cnt = 0
        for o in range(n_off):
            rest = o
            idx = 0
            ok = True
            for a in range(d):
                shift = rest % 3 - 1
                rest //= 3
                c = coord[i, a] + shift
                if a < d - 1:
                    c = c % nc[a]
                elif c < 0 or c >= nc[a]:
                    ok = False
                cc[a] = c
                idx = idx * nc[a] + c
            if not ok:
                continue
            j = head[idx]
            while j >= 0:
                if j > i:
                    r2 = periodic_distance2(pos, j, pos, i, lateral)
                    lim = rad[i] + rad[j] + skin
                    if r2 < lim * lim:
                        q = cnt
                        while q > 0 and mine[q - 1] > j:
                            mine[q] = mine[q - 1]
                            q -= 1
                        mine[q] = j
                        cnt += 1
                j = nxt[j]
        for q in range(cnt):
            keys = _push(keys, m, i * n + mine[q])
            m += 1
    return keys[:m]


@numba.njit(cache=True)
def rebuild(pos, rad, lateral, h, skin, pair_i, pair_j, pair_ft, pair_ov, n_old):
    """Wrap positions, rebuild the pair list in place, carry history by (i, j).

    Returns the new number of pairs, or minus the number needed when the
    arrays are too small (then the list and its history are left untouched).
    """
    n, d = pos.shape
    for i in range(n):
        for a in range(d - 1):
            x = pos[i, a] % lateral[a]
            pos[i, a] = x if x < lateral[a] else 0.0
    keys = candidate_keys(pos, rad, lateral, h, skin)
    m = keys.shape[0]
    if m > pair_i.shape[0]:
        return -m
    new_ft = np.zeros((m, d))
    new_ov = np.zeros(m)
    q = 0
    for p in range(m):
        key = keys[p]
        while q < n_old and pair_i[q] * n + pair_j[q] < key:
            q += 1
        if q < n_old and pair_i[q] * n + pair_j[q] == key:
            new_ov[p] = pair_ov[q]
            for a in range(d):
                new_ft[p, a] = pair_ft[q, a]
    for p in range(m):
        pair_i[p] = keys[p] // n
        pair_j[p] = keys[p] % n
        pair_ov[p] = new_ov[p]
        for a in range(d):
            pair_ft[p, a] = new_ft[p, a]
    return m
