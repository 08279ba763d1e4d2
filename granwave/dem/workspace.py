"""The parallel engine's workspace: its arrays (:func:`workspace`, a :class:`Workspace` named
tuple), the incoming lists of the grain blocks and the wall list, remade at rebuilds.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from . import pair_tile as PT
from .blocks import N_GCOL, block_bounds, block_count
from .contact_law import N_PCOL
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True)
def wall_list(pos, rad, h, skin, wall_ov, walls):
    """The grains that may touch a wall until the list is made again, increasing, into
    ``walls[1:walls[0] + 1]``: those whose position in ``pos`` (the engines pass the positions
    of the last rebuild) is within ``skin`` of the bottom or of the piston at height ``h``, and
    any with a wall history still to clear. It stays complete while every grain is less than
    skin / 2 from that position (the pair list's own rule; it is made again at every rebuild)
    and the piston less than skin / 2 from h (:func:`refresh_wall_list`). The wall loops run
    over it instead of over every grain, in the same grain order: the same bits."""
    n, d = pos.shape
    c = 0
    for i in range(n):
        y = pos[i, d - 1]
        R = rad[i]
        if y - R < skin or (h - y) - R < skin or wall_ov[2 * i] != 0.0 or wall_ov[2 * i + 1] != 0.0:
            c += 1
            walls[c] = i
    walls[0] = c


@numba.njit(cache=True)
def refresh_wall_list(pos_ref, rad, piston, fpar, wall_ov, walls, force):
    """Make the wall list (:func:`wall_list`, from the positions ``pos_ref``) again when
    ``force`` or when the piston has moved more than skin / 2 since it was made (its height
    then is kept in ``fpar.wall_h``)."""
    h = piston.h
    if force or abs(h - fpar.wall_h) > 0.5 * fpar.skin:
        wall_list(pos_ref, rad, h, fpar.skin, wall_ov, walls)
        fpar.wall_h = h


@numba.njit(cache=True, inline="always")
def first_wall_entry(walls, b0):
    """Position in the wall list of its first grain >= b0 (binary search)."""
    lo = 1
    hi = walls[0] + 1
    while lo < hi:
        mid = (lo + hi) // 2
        if walls[mid] < b0:
            lo = mid + 1
        else:
            hi = mid
    return lo


class Workspace(NamedTuple):
    """The parallel kernels' arrays (:func:`workspace` says what each holds); numba takes the
    named tuple as it is and reads its fields by name."""
    nbr: np.ndarray
    gather: np.ndarray
    ncount: np.ndarray
    nlo: np.ndarray
    row: np.ndarray
    need: np.ndarray
    blk: np.ndarray
    top: np.ndarray
    pair_c: np.ndarray
    walls: np.ndarray
    slot_start: np.ndarray
    out_start: np.ndarray
    slot_pair: np.ndarray
    out_slot: np.ndarray
    bnd_f: np.ndarray
    inv_m: np.ndarray
    inv_i: np.ndarray
    mflow: np.ndarray
    slabs: np.ndarray
    tile: np.ndarray
    tile_p: np.ndarray
    claims: np.ndarray
    team_times: np.ndarray
    visit: np.ndarray


def boundary_room(n_grains: int) -> int:
    """Incoming pairs a new workspace has room for (it grows when a rebuild needs more)."""
    return max(64, n_grains // 2)


def workspace(n_grains: int, dim: int, n_rot: int, cap: int, width: int, boundary: int = 0, mflow=None,
              slabs=None, blocks: int | None = None) -> tuple:
    """Arrays of the parallel kernels for ``n_grains`` grains, ``width`` neighbours per grain and
    room for ``boundary`` incoming pairs (at least :func:`boundary_room`), the fields of
    :class:`Workspace` in order: the neighbour and gather lists, counts and pair-list offsets of
    :func:`granwave.dem.neighbours.rebuild` and its size request (pairs, width, incoming pairs),
    each block's incoming pairs (their slots) and the place of each in its owner's row order
    (:func:`incoming_lists`), the per-block statistics, the top-wall forces,
    the constants of each of ``cap`` listed pairs (:func:`pair_constants`), the wall list
    (:func:`wall_list`), per incoming pair
    the force and torque its block hands to the owner row (d + r columns), 1/m and 1/I per
    grain, the compaction rule 'mean-flow''s parameters (:mod:`granwave.dem.mean_flow`;
    empty: off) and slab work array, and one pair tile's scratch per thread that numba can
    start (:func:`granwave.dem.pair_tile.scratch`), the thread count, the blocks' taken flags
    (:func:`take_block`) and the state of the slab means (:func:`_slab_job`), the cycles of
    each thread of a team in its passes and at its barriers (T_* columns), and each thread's
    order of the blocks (:func:`visit_order`). ``blocks``: the
    number of grain blocks (None: :func:`block_count` for one thread; :func:`with_blocks`
    changes it)."""
    n = n_grains
    nblk = block_count(n) if blocks is None else int(blocks)
    cap_b = max(boundary_room(n), int(boundary))
    rows = max(1, numba.config.NUMBA_NUM_THREADS)  # one per thread numba can start
    return Workspace(np.zeros((n, width), np.int64), np.zeros((n, width), np.int64),
            np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n + 1, np.int64),
            np.zeros(3, np.int64), np.zeros((nblk, N_GCOL)), np.zeros(max(1, n)), np.zeros((cap, N_PCOL)),
            np.zeros(n + 1, np.int64),
            np.zeros(nblk + 1, np.int64), np.zeros(nblk + 1, np.int64), np.zeros(cap_b, np.int64),
            np.zeros(cap_b, np.int64), np.zeros((cap_b, dim + n_rot)), np.zeros(n), np.zeros(n),
            np.zeros(0) if mflow is None else mflow, np.zeros((2, 1)) if slabs is None else slabs,
            *PT.scratch(rows), np.zeros(nblk + 2, np.int64), np.zeros((rows, N_TEAM_TIMES), np.int64),
            np.zeros((rows, 2 * nblk), np.int64))


#: per thread of a team, cycles (team.cycle_counter) spent in its blocks of the first pass (with
#: the step's own tests), waiting at the barrier after it, in its blocks of the second pass,
#: waiting at the barrier after that, and after it in the step's end (the piston, the blocks'
#: maxima); summed over the engine's team steps (``ws.team_times``; read by
#: benchmarks/dem_team_times.py)
T_PASS1, T_WAIT1, T_PASS2, T_WAIT2, T_END = range(5)
N_TEAM_TIMES = 5


def with_blocks(ws: Workspace, nblk: int) -> Workspace:
    """The workspace ``ws`` with its per-block arrays sized for ``nblk`` blocks (the rest
    shared); the incoming lists are rebuilt at the next :func:`run_chunk`."""
    if ws.blk.shape[0] == nblk:
        return ws
    claims = np.zeros(nblk + 2, np.int64)
    claims[0] = ws.claims[0]
    return ws._replace(slot_start=np.zeros(nblk + 1, np.int64), out_start=np.zeros(nblk + 1, np.int64),
                       blk=np.zeros((nblk, N_GCOL)), claims=claims,
                       visit=np.zeros((ws.visit.shape[0], 2 * nblk), np.int64))


def grown_workspace(ws: Workspace, cap: int, width: int, boundary: int, keep_lists: bool) -> Workspace:
    """The workspace ``ws`` with room for ``cap`` pairs, ``width`` neighbours per grain and
    ``boundary`` incoming pairs: only the arrays whose size changes are new (the pair constants
    carried over); the others are the same arrays. The neighbour and gather lists, counts and
    offsets keep their contents with ``keep_lists`` and are cleared otherwise (the next rebuild
    makes them); every other entry is recomputed from the lists by the next
    :func:`run_chunk`. Making the whole workspace again at every growth (its arrays take about
    1 KB per grain in 3D) would leave the freed arrays in the allocator's heap: a step in the
    resident memory of a large preparation."""
    new = {}
    n = ws.ncount.shape[0]
    if width != ws.nbr.shape[1]:
        new.update(nbr=np.zeros((n, width), np.int64), gather=np.zeros((n, width), np.int64))
    if cap != ws.pair_c.shape[0]:
        new["pair_c"] = np.zeros((cap, N_PCOL))
        new["pair_c"][: ws.pair_c.shape[0]] = ws.pair_c
    if boundary != ws.slot_pair.shape[0]:
        new.update(slot_pair=np.zeros(boundary, np.int64), out_slot=np.zeros(boundary, np.int64),
                   bnd_f=np.zeros((boundary, ws.bnd_f.shape[1])))
    ws = ws._replace(**new)
    if not keep_lists:
        for a in (ws.nbr, ws.gather, ws.ncount, ws.nlo):
            a[:] = 0
    return ws


@numba.njit(cache=True)
def incoming_lists(nbr, nlo, gl, row, nblk, slot_start, out_start, slot_pair, out_slot):
    """The incoming pairs of each of ``nblk`` blocks: pairs (k, g) with g in the block and k below
    it (row k belongs to an earlier block). Block b's incoming pairs, in the order of its grains
    g and then of k (each grain's order of the one-thread loop), get the slots
    ``slot_start[b]:slot_start[b + 1]`` (``slot_pair``: their pair indices). ``out_slot`` lists
    the slots in increasing pair index, i.e. in the order the owner rows meet them, block b's
    rows from ``out_start[b]``. From the sorted neighbour rows of the last rebuild; serial
    (O(N) plus a sort of the incoming pairs). Returns the number of incoming pairs; when it
    exceeds the room of ``slot_pair`` only that count is valid."""
    n = nlo.shape[0]
    cap = slot_pair.shape[0]
    s = 0
    for b in range(nblk):
        slot_start[b] = s
        b0, b1 = block_bounds(b, n, nblk)
        for g in range(b0, b1):
            for t in range(nlo[g]):
                if nbr[g, t] >= b0:
                    break
                if s < cap:
                    slot_pair[s] = gl[g, t]
                s += 1
    slot_start[nblk] = s
    if s > cap:
        return s
    order = np.argsort(slot_pair[:s])
    for k in range(s):
        out_slot[k] = order[k]
    k = 0
    for b in range(nblk):
        first = row[block_bounds(b, n, nblk)[0]]
        while k < s and slot_pair[order[k]] < first:
            k += 1
        out_start[b] = k
    out_start[nblk] = s
    return s


@numba.njit(cache=True)
def prepare_blocks(rad, mass, inertia, ws, nblk):
    """1/m and 1/I per grain (the one-thread loop's divisions, once per chunk) and the
    incoming lists (:func:`incoming_lists`) of ``nblk`` blocks into the workspace; returns
    the number of incoming pairs (also into ``ws.need[2]``): above the room of the
    workspace, the lists are not usable."""
    inv_m = ws.inv_m
    inv_i = ws.inv_i
    for i in range(rad.shape[0]):
        inv_m[i] = 1.0 / mass[i]
        inv_i[i] = 1.0 / inertia[i]
    return _lists(ws, nblk)


@numba.njit(cache=True)
def _lists(ws, nblk):
    s = incoming_lists(ws.nbr, ws.nlo, ws.gather, ws.row, nblk, ws.slot_start, ws.out_start, ws.slot_pair,
                       ws.out_slot)
    ws.need[2] = s
    return s


def boundary_fraction(ws, n_pairs: int) -> float:
    """Incoming pairs (those computed in phase 1, by the block of their grain j) over all pairs
    of the list, for the lists last built in ``ws``."""
    return float(ws.slot_start[-1]) / max(1, n_pairs)
