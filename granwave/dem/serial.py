"""The DEM step on one thread: one pass over the pairs adds each force to both grains.

The parallel engine (:mod:`granwave.dem.kernels`) runs this same pass per block of grain
indices, after a first pass over the pairs that cross into each block; on one thread that
is extra work (the incoming pairs, the blocks' bookkeeping; docs/dem.md "Parallel engine"), so
:class:`granwave.dem.integrator.Engine` runs this loop when it has one thread. Both add a
grain's contributions in the same order (pairs in list order, then its walls), so they
give the same bits; tests/test_parallel.py checks it. The pair list and its rebuild are
the parallel engine's (:func:`granwave.dem.neighbours.rebuild`). A grain's walls, damping and
measures are :mod:`granwave.dem.grain_step`'s, shared with the parallel passes and the GPU.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from ..geometry import periodic_distance2
from . import neighbours
from .grain_step import grain_damping, grain_walls
from .mean_flow import M_GAMMA_M, add_slab_damping, slab_means
from .pair_tile import law_tile
from .contact_law import couple_of, dashpot_of, friction_of, law_of, pair_constants
from .passes import drift_grain, measure
from .piston import piston_acceleration, piston_half_kick, piston_kick_drift
from .time_step import check_outcome, needs_rebuild, next_skin
from .workspace import refresh_wall_list
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True, _nrt=False)
def _force_loop(pos, vel, omega, rad, pair_c, mass, inertia, lateral, pair_i, pair_j, npairs, pair_ft,
                pair_ov, wall_ft, wall_ov, walls, piston, fpar, force, torque, out, mflow, slabs, tile, tile_p):
    """Total force and torque on every grain and the contact force on the piston.

    Contacts update their tangential history with slip = v_rel * fpar.dt
    (velocities at the half step of velocity Verlet, i.e. exactly the
    displacement of the step). Also adds the background damping -gamma m v,
    -gamma I w, and with a non-empty ``mflow`` (compaction 'mean-flow') gives the mean
    vertical flow of horizontal slabs and their mean lateral flow rates of their own
    (:mod:`granwave.dem.mean_flow`; ``slabs`` its work array). Statistics into ``out``: largest overlap, number of
    top-wall contacts and of contacts.

    The pairs go through :func:`granwave.dem.pair_tile.law_tile` a tile at a time (the law's
    square roots and divisions in vector loops; the same bits as the pair-at-a-time
    ``kernels._pair_law``), then every grain's walls, damping and slab term through
    :mod:`granwave.dem.grain_step`.
    ``tile``, ``tile_p``: the workspace's tile scratch (its first tile is used).
    """
    n_grains, d = pos.shape
    r = omega.shape[1]
    dt = fpar.dt
    damping = dashpot_of(fpar)
    tangential = friction_of(fpar)
    poisson = fpar.poisson
    gamma = fpar.gamma
    rescale = fpar.rescale != 0.0
    e_pair = C.effective_young(False)
    e_wall = C.effective_young(True)
    g_pair = C.effective_shear(poisson, False)
    g_wall = C.effective_shear(poisson, True)
    law = law_of(fpar)
    couple = couple_of(fpar)
    h = piston.h
    vp = piston.v
    force[:, :] = 0.0
    torque[:, :] = 0.0
    dmax = 0.0
    # np.int64 / np.bool_ constants below: a bare 0 or False is typed as a literal and numba would
    # compile the callee a second time for it (measured: 4 s of cold compile for law_tile alone)
    ncontact = np.int64(0)
    # the pairs, a tile at a time (pair_tile: the same bits as one at a time, with the square
    # roots and divisions in vector loops), each tile's forces added in list order
    t = tile[0]
    tp = tile_p[0]
    p = np.int64(0)
    while p < npairs:
        p, dmax, ncontact = law_tile(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, p,
                                     npairs, n_grains, dt, damping, tangential, rescale, e_pair, g_pair, law, couple,
                                     t, tp, force, torque, dmax, ncontact)
    # then the walls of the grains of the wall list (kernels.wall_list: no other can touch one),
    # then every grain's damping and slab term: the per-grain routines every engine runs
    # (grain_step, mean_flow; two loops, not one over every grain: that cost 5 % of the rate)
    fpiston = 0.0
    ntop = 0
    for q in range(1, walls[0] + 1):
        i = walls[q]
        top, nt, dmax, ncontact = grain_walls(i, pos, vel, omega, rad, mass, wall_ft, wall_ov, h, vp, e_wall,
                                              g_wall, dt, damping, tangential, rescale, law, couple, force, torque,
                                              dmax, ncontact)
        if nt:
            fpiston -= top
            ntop += 1
    if gamma > 0.0:
        for i in range(n_grains):
            grain_damping(i, vel, omega, mass, inertia, gamma, force, torque)
        if mflow.shape[0] > 0:
            slab_means(pos, vel, mass, gamma, mflow, slabs)
            add_slab_damping(0, n_grains, pos, mass, gamma, mflow, slabs, force)
    piston.f_con = fpiston
    out.d_max = dmax
    out.ntop = ntop
    out.ncontact = ncontact


@numba.njit(cache=True)
def compute_forces(pos, vel, omega, rad, mass, inertia, lateral, pair_i, pair_j, pair_ft, pair_ov, wall_ft,
                   wall_ov, piston, fpar, ipar, force, torque, out, ws):
    """:func:`granwave.dem.kernels.compute_forces` in one loop over pairs (same arguments and
    bits), for one thread: it compiles in a fraction of the parallel passes' time, which a
    one-thread process (a workflow job) would otherwise spend on a cold cache."""
    walls = ws.walls
    mflow = ws.mflow
    refresh_wall_list(pos, rad, piston, fpar, wall_ov, walls, np.bool_(True))  # for these positions
    _force_loop(pos, vel, omega, rad, ws.pair_c, mass, inertia, lateral, pair_i, pair_j, ipar.npairs,
                pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, force, torque, out, mflow,
                ws.slabs, ws.tile, ws.tile_p)
    piston.a = piston_acceleration(piston, mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar.gamma)


@numba.njit(cache=True)
def run_chunk(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws):
    """:func:`granwave.dem.kernels.run_chunk` in one loop over pairs (same arguments, statuses
    and bits): :func:`run_chunk_mean_flow` with the workspace's compaction rule 'mean-flow'
    (off when its parameters are empty)."""
    return run_chunk_mean_flow(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i,
                               pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws,
                               ws.mflow, ws.slabs)


@numba.njit(cache=True)
def run_chunk_mean_flow(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j,
                        pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, mflow, slabs):
    """:func:`granwave.dem.kernels.run_chunk` in one loop over pairs, plus the compaction rule
    'mean-flow' (``mflow`` [gamma_m, slab, gamma_l] and its work array ``slabs``,
    :mod:`granwave.dem.mean_flow`; an empty ``mflow``: off, the same bits as the parallel
    kernels): the mean vertical flow and the piston damped at gamma_m, the mean lateral flow
    at gamma_l.

    State on entry and exit: positions, velocities and accelerations at the same
    time (``acc``/``alpha`` valid). Returns 0 when all steps ran, 1 when the
    convergence candidate test passed at a check (every ``ipar.check``
    steps: piston touching grains, every |a|, |alpha| and |a_piston| below
    ``fpar.tol_a``, every |v|, |w| R and |v_piston| below ``fpar.tol_v``), 2 when the pair list
    needs more room (``ipar.needed`` pairs; the state is between steps), 3 when the
    state blew up (an overlap larger than the largest radius or non-finite motion at a
    check, or non-finite positions before a rebuild): the time step is unstable.
    With ``ipar.adaptive`` the time step is reset at every check from
    :func:`stable_dt`.
    """
    disp2 = chunk_start(pos, rad, mass, inertia, lateral, pos0, wall_ov, piston, fpar, ws)
    gamma_piston = mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar.gamma
    for _ in range(ipar.nsteps):
        outcome, disp2 = one_step(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j,
                                  pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, mflow, slabs,
                                  gamma_piston, disp2)
        if outcome != 0:
            return outcome
    return 0


@numba.njit(cache=True)
def chunk_start(pos, rad, mass, inertia, lateral, pos0, wall_ov, piston, fpar, ws):
    """What a chunk of :func:`one_step` calls starts from: the wall list from the last rebuild's
    positions, 1/m and 1/I into the workspace (once per chunk, not per step: the same
    quotients, the same bits). Returns the largest squared displacement since the last
    build, which :func:`one_step` then keeps."""
    n = pos.shape[0]
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws.walls, np.bool_(True))  # from the last rebuild's positions
    inv_m = ws.inv_m
    inv_i = ws.inv_i
    for i in range(n):
        inv_m[i] = 1.0 / mass[i]
        inv_i[i] = 1.0 / inertia[i]
    disp2 = 0.0
    for i in range(n):
        disp2 = max(disp2, periodic_distance2(pos, i, pos0, i, lateral))
    return disp2


@numba.njit(cache=True)
def one_step(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov,
             wall_ft, wall_ov, piston, fpar, ipar, out, ws, mflow, slabs, gamma_piston, disp2):
    """One velocity-Verlet step of :func:`run_chunk_mean_flow` (after :func:`chunk_start`;
    ``disp2``: the largest squared displacement since the last build, ``gamma_piston``: the
    piston's damping rate). Returns (status, disp2): status 0 after the step, 2 when the pair
    list needs more room (before the step), 3 when the state blew up, or the check's outcome
    (:func:`run_chunk_mean_flow`'s statuses). The DEM pulse steps with it too
    (granwave.dem.pulse_kernels), its bookkeeping between steps."""
    n, d = pos.shape
    r = omega.shape[1]
    pair_c = ws.pair_c
    walls = ws.walls
    inv_m = ws.inv_m
    inv_i = ws.inv_i
    gamma = fpar.gamma
    check = ipar.check
    dt = fpar.dt
    # rebuild when a grain may come within reach of a pair not in the list
    # before the next rebuild check (factor 2: the speed may grow in a step)
    reach = math.sqrt(disp2) + 2.0 * fpar.v_max * dt
    if not math.isfinite(reach):  # the state blew up (unstable step): stop before the rebuild
        return 3, disp2
    if needs_rebuild(fpar, ipar, reach, np.int64(0)):
        skin = next_skin(fpar, ipar, reach)  # kept only once the list is made with it
        np_new = neighbours.rebuild(pos, rad, lateral, piston.h, skin, pair_i, pair_j,
                                    pair_ft, pair_ov, ipar.npairs, ws.nbr, ws.ncount, ws.nlo, ws.row,
                                    ws.gather, ws.need)
        if np_new < 0:
            ipar.needed = ws.need[0]
            ipar.width = ws.need[1]
            return 2, disp2
        fpar.skin = skin
        ipar.npairs = np_new
        ipar.rebuilds += 1
        ipar.built = ipar.steps
        pair_constants(pair_i, pair_j, np_new, rad, mass, pair_c)
        for i in range(n):
            for a in range(d):
                pos0[i, a] = pos[i, a]
        refresh_wall_list(pos0, rad, piston, fpar, wall_ov, walls, np.bool_(True))  # from the new positions
    # half kick, drift
    vmax2 = 0.0
    disp2 = 0.0
    half = 0.5 * dt
    for i in range(n):
        v2, s = drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt)
        vmax2 = max(vmax2, v2)
        disp2 = max(disp2, s)
    fpar.v_max = math.sqrt(vmax2)
    piston_kick_drift(piston, dt)
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, walls, np.bool_(False))
    _force_loop(pos, vel, omega, rad, pair_c, mass, inertia, lateral, pair_i, pair_j, ipar.npairs,
                pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, acc, alpha, out, mflow, slabs,
                ws.tile, ws.tile_p)
    piston.a = piston_acceleration(piston, gamma_piston)
    # accelerations (as to_accelerations) and the second half kick, in one pass
    for i in range(n):
        inv = inv_m[i]
        for a in range(d):
            acc[i, a] *= inv
            vel[i, a] += 0.5 * dt * acc[i, a]
        inv = inv_i[i]
        for a in range(r):
            alpha[i, a] *= inv
            omega[i, a] += 0.5 * dt * alpha[i, a]
    piston_half_kick(piston, dt)
    ipar.steps += 1
    if check > 0 and ipar.steps % check == 0:
        measure(vel, acc, omega, alpha, mass, inertia, rad, piston, gamma, out)
        return check_outcome(out, fpar, ipar, piston), disp2
    return 0, disp2


