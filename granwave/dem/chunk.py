"""A chunk of velocity-Verlet steps of the parallel DEM engine (:func:`run_chunk`)."""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import team
from .. import threads as _threads  # noqa: F401  (selects the threading layer first)
from . import neighbours
from .blocks import G_DISP, G_DVMAX
from .contact_law import pair_constants
from .layout import (F_DT, F_RMAX, F_TOLA, F_TOLV, F_VMAX, F_SKIN, I_ADAPTIVE, I_BUILT, I_CHECK, I_NEEDED,
                     I_NPAIRS, I_NSTEPS, I_REBUILDS, I_STEPS, I_TEAM, I_WIDTH, O_ALPHAMAX, O_AMAX, O_APISTON,
                     O_DMAX, O_KIN, O_NTOP, O_VMAX, O_WMAX, P_H, P_V)
from .passes import _block_max, _displacement_pass, _drift_pass, _forces
from .piston import piston_half_kick, piston_kick_drift
from .team_steps import _team_steps
from .time_step import needs_rebuild, next_skin, stable_dt_at
from .workspace import W_BLK, W_CLAIM, W_PAIRC, W_SPAIR, W_WALLS, _lists, prepare_blocks, refresh_wall_list
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


#: Below this many grains the engine runs on one thread (the same results): two parallel
#: regions per step cost more than they save on a small system (applied by the callers,
#: :func:`granwave.threads.at_most`: numba.set_num_threads inside a kernel stops caching).
MIN_PARALLEL_GRAINS = 1000


@numba.njit(cache=True)
def run_chunk(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws):
    """Advance ``ipar[I_NSTEPS]`` velocity-Verlet steps (or stop early).

    State on entry and exit: positions, velocities and accelerations at the same
    time (``acc``/``alpha`` valid). Returns 0 when all steps ran, 1 when the
    convergence candidate test passed at a check (every ``ipar[I_CHECK]``
    steps: piston touching grains, every |a|, |alpha| and |a_piston| below
    F_TOLA, every |v|, |w| R and |v_piston| below F_TOLV), 2 when the pair list
    needs more room (``ipar[I_NEEDED]`` pairs, ``ipar[I_WIDTH]`` neighbours per grain,
    ``ws[W_NEED][2]`` incoming pairs; the state is one that a new call goes on from with
    the same bits), 3 when the
    state blew up (an overlap larger than the largest radius or non-finite motion at a
    check, or non-finite positions before a rebuild): the time step is unstable.
    With ``ipar[I_ADAPTIVE]`` the time step is reset at every check from
    :func:`stable_dt`.

    Two parallel passes per step over the grain blocks (:func:`_incoming_pass`,
    :func:`_row_pass`); the first half kick and drift of the next step ride on the second
    unless that step rebuilds the pair list or follows a check (then :func:`_drift_pass`).
    With ``ipar[I_TEAM]`` > 0 the runs of plain steps between go in a team of threads instead
    (:func:`_team_steps`: one parallel region for the run, the same bits).
    """
    n, d = pos.shape
    blk_g = ws[W_BLK]
    nblk = blk_g.shape[0]
    room = ws[W_SPAIR].shape[0]
    if prepare_blocks(rad, mass, inertia, ws, nblk) > room:  # lists built elsewhere, more than room
        ipar[I_NEEDED] = ipar[I_NPAIRS]
        ipar[I_WIDTH] = 0
        return 2
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws[W_WALLS], True)  # from the last rebuild's positions
    check = ipar[I_CHECK]
    n_steps = ipar[I_NSTEPS]
    # largest squared displacement since the last build (then kept by the drift)
    _displacement_pass(pos, lateral, pos0, blk_g)
    disp2 = _block_max(blk_g, G_DISP)
    drifted = False
    # plain steps in a team of threads (_team_steps) when asked for and on more than one thread
    use_team = ipar[I_TEAM] > 0 and ws[W_CLAIM][0] > 1
    sync = np.zeros(team.SYNC_LENGTH, np.int64)
    step = 0
    while step < n_steps:
        if drifted and use_team:
            done, disp2 = _team_steps(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i,
                                      pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, ws, nblk,
                                      step, n_steps, disp2, sync)
            step += done
            use_team = ipar[I_TEAM] > 0
        dt = fpar[F_DT]
        if not drifted:
            # rebuild when a grain may come within reach of a pair not in the list
            # before the next rebuild check (factor 2: the speed may grow in a step)
            reach = math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt
            if not math.isfinite(reach):  # the state blew up (unstable step): stop before the rebuild
                return 3
            if needs_rebuild(fpar, ipar, reach, 0):
                skin = next_skin(fpar, ipar, reach)  # kept only once the list is made with it
                np_new = neighbours.rebuild(pos, rad, lateral, piston[P_H], skin, pair_i, pair_j,
                                            pair_ft, pair_ov, ipar[I_NPAIRS], ws[0], ws[2], ws[3],
                                            ws[4], ws[1], ws[5])
                if np_new < 0:
                    ipar[I_NEEDED] = ws[5][0]
                    ipar[I_WIDTH] = ws[5][1]
                    return 2
                fpar[F_SKIN] = skin
                ipar[I_NPAIRS] = np_new
                ipar[I_REBUILDS] += 1
                ipar[I_BUILT] = ipar[I_STEPS]
                pair_constants(pair_i, pair_j, np_new, rad, mass, ws[W_PAIRC])
                for i in range(n):  # explicit loops: slice assignment compiles shape-check machinery
                    for a in range(d):
                        pos0[i, a] = pos[i, a]
                refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws[W_WALLS], True)  # new positions
                disp2 = 0.0
                if _lists(ws, nblk) > room:  # grow (Engine.grow), then go on from here: the same bits
                    ipar[I_NEEDED] = np_new
                    ipar[I_WIDTH] = 0
                    return 2
            _drift_pass(pos, vel, acc, omega, alpha, lateral, pos0, dt, blk_g)
            fpar[F_VMAX] = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            piston_kick_drift(piston, dt)
        is_check = check > 0 and (ipar[I_STEPS] + 1) % check == 0
        # the next step's rebuild test is known now unless dt may change (a check)
        reach = math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt
        drifted = (not is_check and step + 1 < n_steps and math.isfinite(reach)
                   and not needs_rebuild(fpar, ipar, reach, 1))
        _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
                pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, True, is_check, drifted)
        piston_half_kick(piston, dt)
        ipar[I_STEPS] += 1
        if drifted:
            fpar[F_VMAX] = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            piston_kick_drift(piston, dt)
        if is_check:
            if not (out[O_DMAX] < fpar[F_RMAX] and math.isfinite(out[O_KIN])):
                return 3  # an overlap beyond a radius, or non-finite motion: the step is unstable
            if ipar[I_ADAPTIVE]:
                fpar[F_DT] = stable_dt_at(fpar, out[O_DMAX])
            tol_a = fpar[F_TOLA]
            tol_v = fpar[F_TOLV]
            if (out[O_NTOP] > 0 and out[O_AMAX] < tol_a and out[O_ALPHAMAX] < tol_a
                    and out[O_APISTON] < tol_a and out[O_VMAX] < tol_v and out[O_WMAX] < tol_v
                    and abs(piston[P_V]) < tol_v):
                return 1
        step += 1
    return 0
