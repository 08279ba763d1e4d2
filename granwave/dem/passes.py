"""The parallel force passes of the DEM engine, and the per-grain kicks, drift and measures.

Parallel and deterministic (docs/dem.md, "Parallel engine"): the grains are split into
contiguous index blocks (:func:`granwave.dem.blocks.block_count`, of N and the thread count)
and a step is two parallel passes over the blocks. :func:`_incoming_pass` computes, for each
block, its incoming pairs (k, g): g in the block, k below it, whose row belongs to an earlier
block; :func:`_row_pass` then runs the one-thread pair loop (dem/serial.py) over each block's
own rows, taking the forces of its rows' boundary pairs from the first pass, followed by walls,
damping and kicks. The pair list is lexicographic, so a grain's terms in the one-thread loop
are its incoming pairs (increasing k), then its pairs inside the block, then its row's pairs
beyond the block, then its walls: both passes add them in that order and every grain's force
is bit for bit the one-thread loop's, for any thread count. Maxima and sums over grains are
taken per block. No two threads write the same memory, apart from the blocks' taken flags
(:func:`granwave.dem.blocks.take_block`, integer atomics that only decide which thread
computes a block); no floating-point atomics.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from .. import team
from .. import threads as _threads  # noqa: F401  (selects the threading layer first)
from ..geometry import fold_into_box, nearest_image, periodic_distance2
from . import pair_tile as PT
from .blocks import (G_ALMAX, G_AMAX, G_DISP, G_DMAX, G_DVMAX, G_KIN, G_NC, G_NTOP, G_VMAX, G_WMAX,
                     block_bounds, claim_block, grains, open_claims, visit_order)
from .contact_law import couple_of, dashpot_of, friction_of, law_of
from .grain_step import grain_damping, grain_measures, grain_walls
from .layout import PARAMS, PISTON
from .mean_flow import M_GAMMA_M, add_slab_damping, slab_means
from .piston import piston_acceleration, piston_contact_force
from .workspace import _lists, first_wall_entry, prepare_blocks, refresh_wall_list
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True, parallel=True)
def _incoming_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j, pair_ft, pair_ov, fpar1,
                   nblk, slot_start, slot_pair, bnd_f, blk_g, tile, tile_p, claims, visit):
    """Phase 1 of a step, in parallel over blocks: each block sets its grains' force and torque
    (``acc``, ``alpha``) to zero, then computes each of its incoming pairs (k, g) once (with
    the tangential history update: no one else touches that pair in this step), subtracts the
    force from g and adds a_g (n x f) to its torque, in g's order of the one-thread loop
    (increasing k), and leaves the force on k and a_k (n x f) in the pair's slot of
    ``bnd_f`` (zeros when the grains do not touch: adding them later changes no bit of a sum
    that starts from +0) for the owner row k in phase 2. Largest overlap and contacts of
    these pairs into ``blk_g``. ``fpar1``: a copy of the parameters as a one-element array
    (:func:`_frozen`)."""
    threads = open_claims(claims, nblk, tile.shape[0])
    for t in numba.prange(threads):  # one iteration per thread; blocks taken as in _row_pass
        visit_order(np.int64(t), threads, nblk, visit[t])
        for j in range(nblk):
            b = claim_block(claims, visit[t], nblk, j, 1)
            if b >= 0:
                _incoming_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j,
                                pair_ft, pair_ov, fpar1[0], nblk, slot_start, slot_pair, bnd_f, blk_g, tile[t],
                                tile_p[t])


@numba.njit(cache=True, _nrt=False)  # no reference counting of the arrays of the inlined helpers
def _incoming_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j, pair_ft, pair_ov,
                    fpar, nblk, slot_start, slot_pair, bnd_f, blk_g, t, tp):
    """Block b of :func:`_incoming_pass` (a plain function: the parallel one stays small, which
    keeps its compilation short); its incoming pairs go through the staged law a tile at a time
    (:func:`granwave.dem.pair_tile.law_tile_incoming`, the bits of :func:`_pair_law`), in the
    calling thread's tile scratch ``t``, ``tp`` (one row of the workspace's ``tile``, ``tile_p``)."""
    n, d = pos.shape
    r = omega.shape[1]
    b0, b1 = block_bounds(b, n, nblk)
    flat = acc.reshape(n * d)  # contiguous rows: one flat loop (a memset; unsigned: see grains)
    for q in grains(b0 * d, b1 * d):
        flat[q] = 0.0
    flat = alpha.reshape(n * r)
    for q in grains(b0 * r, b1 * r):
        flat[q] = 0.0
    dt = fpar.dt
    damping = dashpot_of(fpar)
    tangential = friction_of(fpar)
    rescale = fpar.rescale != 0.0
    e_pair = C.effective_young(False)
    g_pair = C.effective_shear(fpar.poisson, False)
    law = law_of(fpar)
    couple = couple_of(fpar)
    dmax = 0.0
    ncontact = np.int64(0)  # not a literal 0: one compiled law_tile_incoming (serial.py)
    # the block's slots are in the order of its grains g and then of k (incoming_lists): one
    # sequential walk, not the neighbour rows (two cache lines per grain, read for a pair or two).
    # Staged, not pair at a time (_pair_law): the tile's roots and divisions run as vector loops
    # (docs/decisions/0005-pair-law-in-tiles.md)
    s = slot_start[b]
    while s < slot_start[b + 1]:
        s, dmax, ncontact = PT.law_tile_incoming(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft,
                                                 pair_ov, slot_pair, s, slot_start[b + 1], dt, damping, tangential,
                                                 rescale, e_pair, g_pair, law, couple, t, tp, acc, alpha, bnd_f, dmax,
                                                 ncontact)
    blk_g[b, G_DMAX] = dmax
    blk_g[b, G_NC] = ncontact


@numba.njit(cache=True, inline="always")
def drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt):
    """First half kick (``half`` = dt / 2) and drift of grain i, its lateral coordinates
    folded back into the box at once (geometry.fold_into_box: the bits of a run do not
    depend on when the pair list is rebuilt). Returns |v|^2 and the squared displacement
    since ``pos0``: geometry.periodic_distance2's sum, taken in the same loop from the new
    coordinates (the same operations in the same order), so that they are not read twice."""
    d = pos.shape[1]
    v2 = 0.0
    s = 0.0
    for a in range(d):
        vel[i, a] += half * acc[i, a]
        v = vel[i, a]
        x = pos[i, a] + dt * v
        if a < d - 1:
            x = fold_into_box(x, lateral[a])
            dx = nearest_image(x - pos0[i, a], lateral[a])
        else:
            dx = x - pos0[i, a]
        pos[i, a] = x
        v2 += v * v
        s += dx * dx
    for a in range(omega.shape[1]):
        omega[i, a] += half * alpha[i, a]
    return v2, s


@numba.njit(cache=True)
def _finish(lo, hi, pos, vel, acc, omega, alpha, rad, mass, inertia, inv_m, inv_i, lateral, pos0, dt, stats,
            drift):
    """Grains lo..hi-1 after their forces and torques: accelerations and the second half kick;
    with ``stats`` the largest |a|^2, |alpha|^2, |v|^2, |w|^2 R^2 and the summed kinetic
    energy, after the kick; with ``drift`` the next step's first half kick and drift, the
    largest |v|^2 and squared displacement since ``pos0``. Returned in that order. Separate
    short loops (they vectorize); the same operations per grain as one loop."""
    d = pos.shape[1]
    r = omega.shape[1]
    half = 0.5 * dt
    for i in grains(lo, hi):
        inv = inv_m[i]
        for a in range(d):
            acc[i, a] *= inv
            vel[i, a] += half * acc[i, a]
        inv = inv_i[i]
        for a in range(r):
            alpha[i, a] *= inv
            omega[i, a] += half * alpha[i, a]
    amax = almax = vmax = wmax = kin = dvmax = disp = 0.0
    if stats:
        for i in grains(lo, hi):
            a2, al2, v2, w2r2, k = grain_measures(i, vel, acc, omega, alpha, rad, mass, inertia)
            amax = max(amax, a2)
            almax = max(almax, al2)
            vmax = max(vmax, v2)
            wmax = max(wmax, w2r2)
            kin += k
    if drift:
        for i in grains(lo, hi):
            v2, s = drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt)
            dvmax = max(dvmax, v2)
            disp = max(disp, s)
    return amax, almax, vmax, wmax, kin, dvmax, disp


@numba.njit(cache=True, parallel=True)
def _row_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral, pos0, pair_i,
              pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston1, fpar1, row, nblk, out_start, out_slot,
              slot_pair, bnd_f, blk_g, top_f, kick, stats, drift, mflow, slabs, tile, tile_p, claims, visit):
    """Phase 2 of a step, in parallel over blocks, after phase 1: each block runs the
    one-thread pair loop over its own rows (pairs (i, j), i in the block), updating their
    tangential histories and adding each force to i and j; a pair whose j lies beyond the
    block was computed by j's block in phase 1, and its force and torque on i are taken from
    its slot once the block's rows are done (a row's such pairs are its last). Then, per grain
    of the block, its bottom and top wall contacts and the background damping -gamma m v,
    -gamma I w (with the compaction rule 'mean-flow', ``mflow`` non-empty, the slabs' mean
    vertical and lateral flows at their own rates from the slab means in ``slabs``, which
    thread 0 takes first, :func:`_slab_job`): for every grain the terms
    of the one-thread loop in its order (phase 1 gave the first ones), so its force is bit for
    bit that loop's. Only the block's own grains are read or written, apart from the slots.

    ``kick`` 0: forces and torques stay in ``acc``, ``alpha``; 1: accelerations, the second
    half kick and (``stats``, ``drift``) what :func:`_finish` does. ``piston1``, ``fpar1``: copies of
    the piston and the parameters as one-element arrays (:func:`_frozen`). Per block into ``blk_g``:
    largest overlap and contacts (with phase 1's), top-wall contacts (their forces on the
    piston, grain order, into ``top_f`` from the block's first grain), the block's measures.
    """
    # Each thread takes its own share of the blocks (numba's static split) and then, when done
    # early, the other's last blocks still untaken (an atomic flag per block) while their owner
    # has not come near them (:func:`worth_taking`): with the gas numbered from the bottom up,
    # the static split alone gave one thread a compacting column's dilute bottom and the other
    # its dense top, and the first thread waited at the barrier for half of the compaction
    # (docs/decisions/0004-parallel-passes.md). Which thread computes a block never changes a bit.
    threads = open_claims(claims, nblk, tile.shape[0])
    slab_job = mflow.shape[0] > 0 and fpar1[0].gamma > 0.0
    claims[nblk + 1] = SLABS_TODO if slab_job else SLABS_READY
    for t in numba.prange(threads):
        if t == 0 and slab_job:
            _slab_job(pos, vel, mass, fpar1[0], mflow, slabs, claims, nblk, np.int64(0))
        visit_order(np.int64(t), threads, nblk, visit[t])
        for j in range(nblk):
            b = claim_block(claims, visit[t], nblk, j, 1)
            if b >= 0:
                _row_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral,
                           pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston1[0], fpar1[0], row,
                           nblk, out_start, out_slot, slot_pair, bnd_f, blk_g, top_f, kick, stats, drift, mflow, slabs,
                           tile[t], tile_p[t], claims, np.int64(0))


#: states of the slab means in ``claims[nblk + 1]`` during phase 2 of round 0 (:func:`_slab_job`);
#: round r adds 2 r, so that one round's SLABS_READY is the next one's SLABS_TODO
SLABS_TODO, SLABS_RUNNING, SLABS_READY = 0, 1, 2


@numba.njit(cache=True, _nrt=False)
def _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd):
    """The slabs' means (:func:`granwave.dem.mean_flow.slab_means`: serial, in grain order, the
    bits of the one-thread loop) into ``slabs``, by the first thread to ask for them: thread 0
    at the start of phase 2, while the others compute their blocks' pairs (which take longer)
    and take over its blocks, or the first block to need them if thread 0 has not started.
    (In phase 1, whose blocks are short, the other threads had waited for thread 0 at the end
    of the pass: on a 10 500-grain column the rule cost 10 % of the rate at two threads against
    4 % at one.) ``claims[nblk + 1]``: SLABS_TODO -> SLABS_RUNNING (compare-and-swap: one
    thread computes them) -> SLABS_READY (release), each plus 2 ``rnd`` (the regions' pass is
    round 0, its flag set to SLABS_TODO before; a team's step s is round s, its flag left at
    the last round's SLABS_READY, which is this round's SLABS_TODO). The job waits for nothing,
    so no schedule of the pass's iterations onto threads can deadlock on it."""
    todo = SLABS_TODO + 2 * rnd
    if team.atomic_cas(claims, nblk + 1, todo, todo + 1) == todo:
        slab_means(pos, vel, mass, fpar.gamma, mflow, slabs)
        team.atomic_store(claims, nblk + 1, todo + 2)


@numba.njit(cache=True, inline="always")
def _await_slab_means(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd):
    """The slab means of round ``rnd`` ready (acquire): taken here if nobody has
    (:func:`_slab_job`), else waited for while the thread that took them runs (yielding the
    core after a while, :func:`granwave.team.relax`). They read every grain's velocity and
    position, so no block may add its slab term, kick or drift before."""
    _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd)
    ready = SLABS_READY + 2 * rnd
    spins = 0
    while team.atomic_load(claims, nblk + 1) != ready:
        team.relax(spins)
        spins += 1


@numba.njit(cache=True, _nrt=False)  # no reference counting of the arrays passed to wall_contact
def _row_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral, pos0, pair_i,
               pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, row, nblk, out_start, out_slot,
               slot_pair, bnd_f, blk_g, top_f, kick, stats, drift, mflow, slabs, t, tp, claims, rnd):
    """Block b of :func:`_row_pass` (``t``, ``tp``: the calling thread's tile scratch, as in
    :func:`_incoming_block`; ``claims``, ``rnd``: where the slab means' state is and which round
    this pass is, :func:`_slab_job`)."""
    n, d = pos.shape
    r = omega.shape[1]
    b0, b1 = block_bounds(b, n, nblk)
    dt = fpar.dt
    damping = dashpot_of(fpar)
    tangential = friction_of(fpar)
    gamma = fpar.gamma
    rescale = fpar.rescale != 0.0
    e_pair = C.effective_young(False)
    g_pair = C.effective_shear(fpar.poisson, False)
    e_wall = C.effective_young(True)
    g_wall = C.effective_shear(fpar.poisson, True)
    law = law_of(fpar)
    couple = couple_of(fpar)
    dmax = blk_g[b, G_DMAX]
    ncontact = int(blk_g[b, G_NC])
    # the block's rows a tile at a time (pair_tile: the pair law with its roots and quotients in
    # vector loops, the bits of _pair_law), skipping the pairs beyond the block (computed by
    # their j's block in phase 1)
    p = row[b0]
    while p < row[b1]:
        p, dmax, ncontact = PT.law_tile(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov,
                                        p, row[b1], b1, dt, damping, tangential, rescale, e_pair, g_pair, law, couple,
                                        t, tp, acc, alpha, dmax, ncontact)
    # then those pairs' forces on their rows' grains, from the slots, in increasing pair index
    # (a row's are its last pairs, sorted by j). Nothing but row k adds to grain k once row k
    # is done (pairs have k < j) until the walls below, so each grain's order is the one-thread
    # loop's (adding them row by row as the tiles finished rows cost a test per row, 4 % of
    # the pass for 10^4 grains)
    for c in range(out_start[b], out_start[b + 1]):
        s = out_slot[c]
        k = pair_i[slot_pair[s]]
        acc[k, 0] += bnd_f[s, 0]
        acc[k, 1] += bnd_f[s, 1]
        if d == 3:
            acc[k, 2] += bnd_f[s, 2]
        for a in range(r):
            alpha[k, a] += bnd_f[s, d + a]
    # then the walls of the block's grains in the wall list (no other can touch one), then every
    # grain's damping and slab term: the per-grain routines every engine runs (grain_step, mean_flow)
    h = piston.h
    vp = piston.v
    ntop = 0
    q = first_wall_entry(walls, b0)
    while q <= walls[0] and walls[q] < b1:
        i = walls[q]
        q += 1
        top, nt, dmax, ncontact = grain_walls(i, pos, vel, omega, rad, mass, wall_ft, wall_ov, h, vp, e_wall,
                                              g_wall, dt, damping, tangential, rescale, law, couple, acc, alpha, dmax,
                                              ncontact)
        if nt:
            top_f[b0 + ntop] = top
            ntop += 1
    if gamma > 0.0:
        for i in grains(b0, b1):
            grain_damping(i, vel, omega, mass, inertia, gamma, acc, alpha)
        if mflow.shape[0] > 0:  # after every grain's damping, as the one-thread loop
            _await_slab_means(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd)
            add_slab_damping(b0, b1, pos, mass, gamma, mflow, slabs, acc)
    m = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if kick:
        m = _finish(b0, b1, pos, vel, acc, omega, alpha, rad, mass, inertia, inv_m, inv_i, lateral, pos0, dt,
                    stats, drift)
    blk_g[b, G_DMAX] = dmax
    blk_g[b, G_NC] = ncontact
    blk_g[b, G_NTOP] = ntop
    blk_g[b, G_AMAX] = m[0]
    blk_g[b, G_ALMAX] = m[1]
    blk_g[b, G_VMAX] = m[2]
    blk_g[b, G_WMAX] = m[3]
    blk_g[b, G_KIN] = m[4]
    blk_g[b, G_DVMAX] = m[5]
    blk_g[b, G_DISP] = m[6]


@numba.njit(cache=True, parallel=True)
def _drift_pass(pos, vel, acc, omega, alpha, lateral, pos0, dt, blk_g):
    """First half kick and drift of velocity Verlet; block maxima of |v|^2 and of the squared
    displacement since ``pos0`` into ``blk_g`` (columns G_DVMAX, G_DISP)."""
    n = pos.shape[0]
    nblk = blk_g.shape[0]
    half = 0.5 * dt
    for b in numba.prange(nblk):
        dvmax = 0.0
        disp = 0.0
        b0, b1 = block_bounds(np.int64(b), n, nblk)
        for i in grains(b0, b1):
            v2, s = drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt)
            dvmax = max(dvmax, v2)
            disp = max(disp, s)
        blk_g[b, G_DVMAX] = dvmax
        blk_g[b, G_DISP] = disp


@numba.njit(cache=True, parallel=True)
def _displacement_pass(pos, lateral, pos0, blk_g):
    """Block maxima of the squared displacement since ``pos0`` (nearest image) into
    ``blk_g[:, G_DISP]``."""
    n = pos.shape[0]
    nblk = blk_g.shape[0]
    for b in numba.prange(nblk):
        disp = 0.0
        b0, b1 = block_bounds(np.int64(b), n, nblk)
        for i in grains(b0, b1):
            disp = max(disp, periodic_distance2(pos, i, pos0, i, lateral))
        blk_g[b, G_DISP] = disp


@numba.njit(cache=True, inline="always")
def _frozen(piston, fpar):
    """Copies of the records ``piston`` and ``fpar`` as one-element arrays, for the parallel
    passes, which only read them: numba's parallel loops take no record argument (numba 0.68
    lowers a record parameter of their outlined body by value where a pointer is expected)."""
    p = np.empty(1, PISTON)
    p[0] = piston
    f = np.empty(1, PARAMS)
    f[0] = fpar
    return p, f


@numba.njit(cache=True)
def _block_max(blk, col):
    m = 0.0
    for b in range(blk.shape[0]):
        m = max(m, blk[b, col])
    return m


@numba.njit(cache=True)
def _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, kick, stats, drift):
    """Phases 1 and 2 of a step over ``nblk`` blocks (see each); reduce the blocks into ``out``
    and the piston's contact force (its grains' forces summed in grain order) and
    acceleration; with ``stats`` the convergence measures as :func:`measure` (the kinetic
    energy summed by blocks: only its finiteness is used). The incoming lists
    (:func:`prepare_blocks`) must be those of the current pair list and ``nblk``."""
    blk_g = ws.blk
    top_f = ws.top
    pair_c = ws.pair_c
    mflow = ws.mflow
    # the passes read the parameters and the piston (none of what refresh_wall_list writes)
    piston1, fpar1 = _frozen(piston, fpar)
    _incoming_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j, pair_ft, pair_ov,
                   fpar1, nblk, ws.slot_start, ws.slot_pair, ws.bnd_f, blk_g, ws.tile, ws.tile_p, ws.claims,
                   ws.visit)
    # the wall list must cover this piston height (made again if the piston moved)
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws.walls, np.bool_(False))
    # (with the rule 'mean-flow' also the slabs' mean flow, from this step's velocities)
    _row_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, ws.inv_m, ws.inv_i, lateral, pos0,
              pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, ws.walls, piston1, fpar1, ws.row, nblk,
              ws.out_start, ws.out_slot, ws.slot_pair, ws.bnd_f, blk_g, top_f, kick, stats, drift, mflow, ws.slabs,
              ws.tile, ws.tile_p, ws.claims, ws.visit)
    n = pos.shape[0]
    dmax = 0.0
    ncontact = 0
    ntop = 0
    kin = 0.0
    amax = almax = vmax = wmax = 0.0
    for b in range(nblk):
        dmax = max(dmax, blk_g[b, G_DMAX])
        ncontact += int(blk_g[b, G_NC])
        ntop += int(blk_g[b, G_NTOP])
        kin += blk_g[b, G_KIN]
        amax = max(amax, blk_g[b, G_AMAX])
        almax = max(almax, blk_g[b, G_ALMAX])
        vmax = max(vmax, blk_g[b, G_VMAX])
        wmax = max(wmax, blk_g[b, G_WMAX])
    piston.f_con = piston_contact_force(blk_g, top_f, n, nblk)
    piston.a = piston_acceleration(piston, mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar.gamma)
    out.d_max = dmax
    out.ntop = ntop
    out.ncontact = ncontact
    if stats:
        store_measures(out, piston, amax, almax, vmax, wmax, kin)


@numba.njit(cache=True)
def compute_forces(pos, vel, omega, rad, mass, inertia, lateral, pair_i, pair_j, pair_ft, pair_ov, wall_ft,
                   wall_ov, piston, fpar, ipar, force, torque, out, ws):
    """Total force and torque on every grain (into ``force``, ``torque``), the contact force on
    the piston (``piston.f_con``), largest overlap, top-wall and total contact counts (``out``).

    Also adds the background damping -gamma m v, -gamma I w. Contacts update their
    tangential history with slip = v_rel * fpar.dt (0: evaluated, not advanced). When the
    workspace has no room for the incoming pairs, one block (the same bits).
    """
    nblk = ws.blk.shape[0]
    if prepare_blocks(rad, mass, inertia, ws, nblk) > ws.slot_pair.shape[0]:
        nblk = np.int64(1)
        _lists(ws, nblk)
    refresh_wall_list(pos, rad, piston, fpar, wall_ov, ws.walls, np.bool_(True))  # for these positions
    _forces(pos, vel, force, omega, torque, rad, mass, inertia, lateral, pos, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, np.bool_(False), np.bool_(False),
            np.bool_(False))


@numba.njit(cache=True)
def to_accelerations(force, torque, mass, inertia):
    """Divide forces by masses and torques by moments of inertia, in place."""
    n, d = force.shape
    r = torque.shape[1]
    for i in range(n):
        inv = 1.0 / mass[i]
        for a in range(d):
            force[i, a] *= inv
        inv = 1.0 / inertia[i]
        for a in range(r):
            torque[i, a] *= inv


@numba.njit(cache=True)
def measure(vel, acc, omega, alpha, mass, inertia, rad, piston, gamma, out):
    """Largest accelerations and speeds, kinetic energy (grains + piston) into ``out``."""
    n = vel.shape[0]
    amax = 0.0
    almax = 0.0
    vmax = 0.0
    wmax = 0.0
    kin = 0.0
    for i in range(n):
        a2, al2, v2, w2r2, k = grain_measures(i, vel, acc, omega, alpha, rad, mass, inertia)
        amax = max(amax, a2)
        almax = max(almax, al2)
        vmax = max(vmax, v2)
        wmax = max(wmax, w2r2)
        kin += k
    store_measures(out, piston, amax, almax, vmax, wmax, kin)


@numba.njit(cache=True, inline="always")
def store_measures(out, piston, amax, almax, vmax, wmax, kin):
    """The convergence measures into ``out`` from the grains' largest squared |a|, |alpha|, |v|,
    |w| R and their kinetic energy ``kin``; the piston's |a| and kinetic energy added (a fixed
    wall, infinite mass, has none). :func:`measure` and the parallel finish share it."""
    out.a_max = math.sqrt(amax)
    out.alpha_max = math.sqrt(almax)
    out.v_max = math.sqrt(vmax)
    out.w_max = math.sqrt(wmax)
    if piston.mass < np.inf:
        out.a_piston = abs(piston.a)
        kin += 0.5 * piston.mass * piston.v * piston.v
    else:
        out.a_piston = 0.0
    out.kin = kin
