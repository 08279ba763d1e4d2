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
from .passes import _block_max, _displacement_pass, _drift_pass, _forces
from .piston import piston_half_kick, piston_kick_drift
from .team_steps import _team_steps
from .time_step import check_outcome, needs_rebuild, next_skin
from .workspace import _lists, prepare_blocks, refresh_wall_list
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


#: Below this many grains the engine runs on one thread (the same results): two parallel
#: regions per step cost more than they save on a small system (applied by the callers,
#: :func:`granwave.threads.at_most`: numba.set_num_threads inside a kernel stops caching).
MIN_PARALLEL_GRAINS = 1000


@numba.njit(cache=True)
def run_chunk(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws):
    """Advance ``ipar.nsteps`` velocity-Verlet steps (or stop early).

    State on entry and exit: positions, velocities and accelerations at the same
    time (``acc``/``alpha`` valid). Returns 0 when all steps ran, 1 when the
    convergence candidate test passed at a check (every ``ipar.check``
    steps: piston touching grains, every |a|, |alpha| and |a_piston| below
    ``fpar.tol_a``, every |v|, |w| R and |v_piston| below ``fpar.tol_v``), 2 when the pair list
    needs more room (``ipar.needed`` pairs, ``ipar.width`` neighbours per grain,
    ``ws.need[2]`` incoming pairs; the state is one that a new call goes on from with
    the same bits), 3 when the
    state blew up (an overlap larger than the largest radius or non-finite motion at a
    check, or non-finite positions before a rebuild): the time step is unstable.
    With ``ipar.adaptive`` the time step is reset at every check from
    :func:`stable_dt`.

    Two parallel passes per step over the grain blocks (:func:`_incoming_pass`,
    :func:`_row_pass`); the first half kick and drift of the next step ride on the second
    unless that step rebuilds the pair list or follows a check (then :func:`_drift_pass`).
    With ``ipar.team`` > 0 the runs of plain steps between go in a team of threads instead
    (:func:`_team_steps`: one parallel region for the run, the same bits).
    """
    blk_g = ws.blk
    nblk = blk_g.shape[0]
    # largest squared displacement since the last build (then kept by the drift)
    disp2 = chunk_start(pos, rad, mass, inertia, lateral, pos0, wall_ov, piston, fpar, ipar, ws)
    if disp2 < 0.0:  # lists built elsewhere, more than room
        return 2
    check = ipar.check
    n_steps = ipar.nsteps
    drifted = False
    # plain steps in a team of threads (_team_steps) when asked for and on more than one thread
    use_team = ipar.team > 0 and ws.claims[0] > 1
    sync = np.zeros(team.SYNC_LENGTH, np.int64)
    step = np.int64(0)  # typed int64 at once: a literal 0 compiles _team_steps a second time
    while step < n_steps:
        if drifted and use_team:
            done, disp2 = _team_steps(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i,
                                      pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, ws, nblk,
                                      step, n_steps, disp2, sync)
            step += done
            use_team = ipar.team > 0
        dt = fpar.dt
        if not drifted:
            status, disp2 = _rebuild_and_drift(pos, vel, acc, omega, alpha, rad, mass, lateral, pos0, pair_i, pair_j,
                                               pair_ft, pair_ov, wall_ov, piston, fpar, ipar, ws, disp2)
            if status != 0:
                return status
        is_check = check > 0 and (ipar.steps + 1) % check == 0
        # the next step's rebuild test is known now unless dt may change (a check)
        reach = math.sqrt(disp2) + 2.0 * fpar.v_max * dt
        drifted = (not is_check and step + 1 < n_steps and math.isfinite(reach)
                   and not needs_rebuild(fpar, ipar, reach, np.int64(1)))
        _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
                pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, np.bool_(True), is_check, drifted)
        piston_half_kick(piston, dt)
        ipar.steps += 1
        if drifted:
            fpar.v_max = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            piston_kick_drift(piston, dt)
        if is_check:
            outcome = check_outcome(out, fpar, ipar, piston)
            if outcome != 0:
                return outcome
        step += 1
    return 0


@numba.njit(cache=True)
def _rebuild_list(pos, rad, mass, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ov, piston, fpar, ipar,
                  ws, reach):
    """The pair list, its constants, wall list and block lists made again from the current
    positions (a rebuild of :func:`run_chunk` and :func:`one_step`). Returns 0, or 2 when the
    pair list or the block lists need more room (``ipar.needed``, ``ipar.width``; the state is
    one that a new call goes on from with the same bits)."""
    n, d = pos.shape
    skin = next_skin(fpar, ipar, reach)  # kept only once the list is made with it
    np_new = neighbours.rebuild(pos, rad, lateral, piston.h, skin, pair_i, pair_j,
                                pair_ft, pair_ov, ipar.npairs, ws.nbr, ws.ncount, ws.nlo,
                                ws.row, ws.gather, ws.need)
    if np_new < 0:
        ipar.needed = ws.need[0]
        ipar.width = ws.need[1]
        return 2
    fpar.skin = skin
    ipar.npairs = np_new
    ipar.rebuilds += 1
    ipar.built = ipar.steps
    pair_constants(pair_i, pair_j, np_new, rad, mass, ws.pair_c)
    for i in range(n):  # explicit loops: slice assignment compiles shape-check machinery
        for a in range(d):
            pos0[i, a] = pos[i, a]
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws.walls, np.bool_(True))  # new positions
    if _lists(ws, ws.blk.shape[0]) > ws.slot_pair.shape[0]:  # grow (Engine.grow), then go on: the same bits
        ipar.needed = np_new
        ipar.width = 0
        return 2
    return 0


@numba.njit(cache=True)
def _rebuild_and_drift(pos, vel, acc, omega, alpha, rad, mass, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov,
                       wall_ov, piston, fpar, ipar, ws, disp2):
    """A step's start when the last step's force pass did not drift it (:func:`run_chunk`,
    :func:`one_step`): the pair list rebuilt when a grain may come within reach of a pair not
    in it before the next rebuild check (factor 2: the speed may grow in a step), then the half
    kick and drift. ``disp2``: the largest squared displacement since the last build. Returns
    (status, disp2): 0, 2 when a list needs room (:func:`_rebuild_list`), 3 when the state blew
    up (non-finite reach: stopped before the rebuild)."""
    blk_g = ws.blk
    dt = fpar.dt
    reach = math.sqrt(disp2) + 2.0 * fpar.v_max * dt
    if not math.isfinite(reach):
        return 3, disp2
    if needs_rebuild(fpar, ipar, reach, np.int64(0)):
        if _rebuild_list(pos, rad, mass, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ov, piston,
                         fpar, ipar, ws, reach) != 0:
            return 2, disp2
    _drift_pass(pos, vel, acc, omega, alpha, lateral, pos0, dt, blk_g)
    fpar.v_max = math.sqrt(_block_max(blk_g, G_DVMAX))
    disp2 = _block_max(blk_g, G_DISP)
    piston_kick_drift(piston, dt)
    return 0, disp2


@numba.njit(cache=True)
def chunk_start(pos, rad, mass, inertia, lateral, pos0, wall_ov, piston, fpar, ipar, ws):
    """What a run of :func:`one_step` calls starts from, as :func:`run_chunk` starts: 1/m, 1/I
    and the block lists, the wall list from the last rebuild's positions. Returns the largest
    squared displacement since the last build, which :func:`one_step` then keeps, or -1 when
    the block lists need more room (``ipar.needed``: the caller grows the engine)."""
    blk_g = ws.blk
    nblk = blk_g.shape[0]
    if prepare_blocks(rad, mass, inertia, ws, nblk) > ws.slot_pair.shape[0]:
        ipar.needed = ipar.npairs
        ipar.width = 0
        return -1.0
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws.walls, np.bool_(True))  # from the last rebuild's positions
    _displacement_pass(pos, lateral, pos0, blk_g)
    return _block_max(blk_g, G_DISP)


@numba.njit(cache=True)
def one_step(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
             pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, disp2):
    """One step of :func:`run_chunk` on the parallel passes, after :func:`chunk_start`, its drift
    a pass of its own (the state between calls is a whole step's: the DEM pulse reads it; the
    same bits as run_chunk). ``disp2``: the largest squared displacement since the last build.
    Returns (status, disp2) with run_chunk's statuses (0 after the step; 2 before it when a
    list needs room; 3; a check's outcome)."""
    status, disp2 = _rebuild_and_drift(pos, vel, acc, omega, alpha, rad, mass, lateral, pos0, pair_i, pair_j,
                                       pair_ft, pair_ov, wall_ov, piston, fpar, ipar, ws, disp2)
    if status != 0:
        return status, disp2
    dt = fpar.dt
    nblk = ws.blk.shape[0]
    check = ipar.check
    is_check = check > 0 and (ipar.steps + 1) % check == 0
    _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, np.bool_(True), is_check, np.bool_(False))
    piston_half_kick(piston, dt)
    ipar.steps += 1
    if is_check:
        return check_outcome(out, fpar, ipar, piston), disp2
    return 0, disp2
