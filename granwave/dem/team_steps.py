"""Plain steps of the DEM engine in a team of threads (one parallel region for a run of steps)."""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import team
from .. import threads as _threads  # noqa: F401  (selects the threading layer first)
from .blocks import G_DISP, G_DVMAX, claim_block, visit_order
from .mean_flow import M_GAMMA_M
from .passes import _block_max, _incoming_block, _row_block, _slab_job
from .layout import PARAMS, PISTON
from .piston import copy_piston, piston_acceleration, piston_contact_force, piston_half_kick, piston_kick_drift
from .time_step import rebuild_due
from .workspace import N_TEAM_TIMES, T_END, T_PASS1, T_PASS2, T_WAIT1, T_WAIT2
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


# --------------------------------------------------------------------------- team of threads
# Plain steps (no rebuild, no check, no wall list to remake) in one parallel
# region, the two passes of each separated by granwave.team's spin barrier. numba opens a region
# (an OpenMP fork and join) per pass, and each region ends in a wait for its slowest thread; a
# team saves the forks and joins of the plain steps (on many threads a region costs several
# microseconds: docs/decisions/0004-parallel-passes.md). Every block runs the same code as in
# the regions' passes and every thread takes the same decisions from the same numbers, so the
# bits are those of the regions' path (tests/test_parallel.py).


@numba.njit(cache=True)
def _team_thread(t, threads, sync, claims, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m,
                 inv_i, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar,
                 row, nblk, out_start, out_slot, slot_start, slot_pair, bnd_f, blk_g, top_f, mflow, slabs, scr,
                 scr_p, gamma_p, check, built, steps, step, n_steps, disp2, vmax, state, times, order):
    """Thread t's part of :func:`_team_steps`: from step ``step`` of ``n_steps`` (``steps`` done in
    all, the list made at ``built``), with its own copy ``piston`` of the piston, as long as the
    next step is one that :func:`run_chunk` would run as a plain drifted step. Its count of steps,
    ``disp2`` and the largest |v| into ``state`` (every thread the same); its cycles in the passes
    and at the barriers added to row t of ``times`` (T_* columns; a few counter reads per step).
    ``scr``, ``scr_p``: its tile scratch; ``order``: its row for :func:`visit_order`."""
    n = pos.shape[0]
    dt = fpar.dt
    half_skin = 0.5 * fpar.skin
    slab_job = mflow.shape[0] > 0 and fpar.gamma > 0.0
    gen = 0
    done = np.int64(0)  # typed int64 at once: a literal 0 compiles _row_block a second time
    visit_order(t, threads, nblk, order)
    c0 = team.cycle_counter()
    while True:
        # run_chunk's tests for this step, from the same numbers on every thread
        is_check = check > 0 and (steps + 1) % check == 0
        reach = math.sqrt(disp2) + 2.0 * vmax * dt
        if (is_check or step + 1 >= n_steps or not math.isfinite(reach)
                or rebuild_due(fpar, steps + 1 - built, reach)
                or abs(piston.h - fpar.wall_h) > half_skin):
            break
        phase = 2 * done + 1
        for j in range(nblk):
            b = claim_block(claims, order, nblk, j, phase)
            if b >= 0:
                _incoming_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j,
                                pair_ft, pair_ov, fpar, nblk, slot_start, slot_pair, bnd_f, blk_g, scr, scr_p)
        c1 = team.cycle_counter()
        gen = team.barrier(sync, threads, gen)
        c2 = team.cycle_counter()
        if t == 0 and slab_job:  # as in _row_pass: thread 0 first, the others take its blocks
            _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, done)
        for j in range(nblk):
            b = claim_block(claims, order, nblk, j, phase + 1)
            if b >= 0:
                _row_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral,
                           pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, row,
                           nblk, out_start, out_slot, slot_pair, bnd_f, blk_g, top_f, np.bool_(True), np.bool_(False),
                           np.bool_(True), mflow,
                           slabs, scr, scr_p, claims, done)
        c3 = team.cycle_counter()
        gen = team.barrier(sync, threads, gen)
        c4 = team.cycle_counter()
        times[t, T_PASS1] += c1 - c0
        times[t, T_WAIT1] += c2 - c1
        times[t, T_PASS2] += c3 - c2
        times[t, T_WAIT2] += c4 - c3
        # what _forces and run_chunk do after the passes, read before this thread arrives at the
        # next barrier: the next phase 1 writes no column read here, the next phase 2 all of them
        piston.f_con = piston_contact_force(blk_g, top_f, n, nblk)
        piston.a = piston_acceleration(piston, gamma_p)
        piston_half_kick(piston, dt)
        steps += 1
        step += 1
        done += 1
        vmax = math.sqrt(_block_max(blk_g, G_DVMAX))
        disp2 = _block_max(blk_g, G_DISP)
        piston_kick_drift(piston, dt)
        c0 = team.cycle_counter()
        times[t, T_END] += c0 - c4
    state[t, 0] = done
    state[t, 1] = disp2
    state[t, 2] = vmax


@numba.njit(cache=True, parallel=True)
def _team_region(pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral, pos0, pair_i,
                 pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, pistons, fpar1, row, nblk, out_start, out_slot,
                 slot_start, slot_pair, bnd_f, blk_g, top_f, mflow, slabs, tile, tile_p, gamma_p, check,
                 built, steps, step, n_steps, disp2, vmax, sync, claims, state, times, visit):
    threads = team.team_size(sync)
    for t in numba.prange(threads):  # one iteration per thread (granwave.team)
        if team.enter(sync, threads):
            _team_thread(np.int64(t), threads, sync, claims, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia,
                         inv_m, inv_i, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls,
                         pistons[t], fpar1[0], row, nblk, out_start, out_slot, slot_start, slot_pair, bnd_f, blk_g,
                         top_f, mflow, slabs, tile[t], tile_p[t], gamma_p, check, built, steps, step,
                         n_steps, disp2, vmax, state, times, visit[t])


@numba.njit(cache=True)
def _team_steps(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov,
                wall_ft, wall_ov, piston, fpar, ipar, ws, nblk, step, n_steps, disp2, sync):
    """Run the plain steps from step ``step`` of :func:`run_chunk` (whose drift is done) in a team
    of threads: each step the passes of :func:`_forces` with the drift of the next, and the
    piston and the rebuild test as run_chunk, until a step is a check, needs a new pair list or
    wall list, or is the last. Returns (steps run, disp2); updates the piston, ``fpar.v_max``
    and the step counts. Returns (0, disp2) with ``ipar.team`` = -1 when the team did not
    start (:func:`granwave.team.enter`; then nothing was done), or when it has more threads than
    the workspace has tile scratches (more than numba can start: it would not start either)."""
    threads = max(1, ws.claims[0])
    team.reset_team(sync, threads)
    if threads > ws.tile.shape[0]:
        ipar.team = -1
        return 0, disp2
    pistons = np.empty(threads, PISTON)
    for t in range(threads):
        pistons[t] = piston
    # the parameters as a one-element array (numba's parallel loops take no record, passes._frozen);
    # the team's threads only read them
    fpar1 = np.empty(1, PARAMS)
    fpar1[0] = fpar
    claims = np.zeros(nblk + 2, np.int64)
    state = np.zeros((threads, 3))
    times = ws.team_times
    if times.shape[0] < threads:  # a team larger than numba's threads (it will not start): no row to miss
        times = np.zeros((threads, N_TEAM_TIMES), np.int64)
    mflow = ws.mflow
    gamma_p = mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar.gamma
    _team_region(pos, vel, acc, omega, alpha, rad, ws.pair_c, mass, inertia, ws.inv_m, ws.inv_i, lateral,
                 pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, ws.walls, pistons, fpar1, ws.row,
                 nblk, ws.out_start, ws.out_slot, ws.slot_start, ws.slot_pair, ws.bnd_f, ws.blk, ws.top, mflow,
                 ws.slabs, ws.tile, ws.tile_p, gamma_p, ipar.check, ipar.built,
                 ipar.steps, step, n_steps, disp2, fpar.v_max, sync, claims, state, times, ws.visit)
    if sync[team.S_ENTRY] < threads:
        ipar.team = -1
        return 0, disp2
    done = int(state[0, 0])
    if done > 0:
        copy_piston(piston, pistons[0])
        fpar.v_max = state[0, 2]
        ipar.steps += done
        ipar.team_steps += done
    return done, state[0, 1]
