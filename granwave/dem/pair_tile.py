"""The pair law over a tile of listed pairs, staged so that its square roots and divisions
run as vector loops.

A frictional contact takes about seven square roots and four divisions (the distance, the
normal, sqrt(n) of Hertz, k_t, the history's projection and unloading rescale, the two
damping coefficients). One at a time they occupy the CPU's one divider for most of the
contact's time; in a loop over a packed array the compiler issues them as vector
instructions, 4 to 8 at once. So :func:`law_tile` packs up to ``TILE`` touching pairs
into columns of a scratch array and alternates scalar stages (gathers, the rest of the
arithmetic) with loops that only take roots and quotients. Every contact gets exactly the
operations of :func:`granwave.dem.contact_law.contact_force3`, in the same order (square
roots and divisions are correctly rounded, in a vector lane as in a scalar register), so
the bits are those of the pair-at-a-time law (tests/test_dem.py compares them).
Why, and what it gained: docs/decisions/0005-pair-law-in-tiles.md.

Compiled with ``error_model="numpy"``: numba's default (Python's) checks every float
division for a zero divisor, and that branch keeps the division loops scalar. A zero
distance (two coincident centres) then gives NaN instead of an exception, which the
engines' blow-up checks catch as a non-finite state.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from ..contact_models import _dispatch as CD
from .contact_law import (PC_MEFF, PC_R12, PC_ROOT, _add_torque3, _contact_velocity, _pair_geometry,
                          add_torque_with_couple, pair_couple, torque_with_couple)
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

#: touching pairs per tile: the scratch (N_TROW x ROW doubles, 53 kB) stays in L2
TILE = 256
#: length of a scratch row: one cache line more than a tile, so that the entries of one
#: contact (a column; rows 2 kB apart without it) fall into different sets of the L1 cache
#: instead of two (the staged loop took 47 us instead of 40 for 600 grains unpadded)
ROW = TILE + 8

# scratch rows, each ROW long, one entry per packed contact; the scratch is one flat row
# per tile, indexed ``T_X * ROW + c``, so that the compiler sees constant distances between
# rows and vectorizes the fused loops without run-time overlap checks
(T_DX, T_DY, T_DZ, T_R2, T_RS, T_NX, T_NY, T_NZ, T_DELTA, T_AI, T_AJ, T_VN, T_TX, T_TY, T_TZ, T_GX,
 T_GY, T_GZ, T_OLD2, T_NEW2, T_R12, T_ROOT, T_MEFF, T_OVOLD, T_FEL, T_CN, T_KT, T_CT, T_SPROJ,
 T_SRES) = range(30)
N_TROW = 30


def scratch(tiles: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Work arrays for ``tiles`` tiles in flight (one per parallel block): the float rows,
    (tiles, N_TROW * ROW), and the packed pair indices, followed by their slots in
    :func:`law_tile_incoming`, (tiles, 2 TILE)."""
    return np.zeros((tiles, N_TROW * ROW)), np.zeros((tiles, 2 * TILE), np.int64)


@numba.njit(cache=True, inline="always", _nrt=False)
def _packed(pos, lateral, rad, pair_ft, pair_ov, q, i, j, t, nc, d):
    """Stage 1 for pair q = (i, j): whether the grains touch; if so its geometry goes to column
    ``nc`` of the scratch ``t`` (the caller packs q), if not a history it had is destroyed (the
    contact opened)."""
    dx, dy, dz = _pair_geometry(pos, lateral, i, j)
    r2 = dx * dx + dy * dy + dz * dz
    rs = rad[i] + rad[j]
    if r2 >= rs * rs:
        if pair_ov[q] != 0.0:
            pair_ov[q] = 0.0
            for a in range(pair_ft.shape[1]):  # the tangential history and a rolling one after it
                pair_ft[q, a] = 0.0
        return False
    t[T_DX * ROW + nc] = dx
    t[T_DY * ROW + nc] = dy
    t[T_DZ * ROW + nc] = dz
    t[T_R2 * ROW + nc] = r2
    t[T_RS * ROW + nc] = rs
    return True


@numba.njit(cache=True, error_model="numpy", _nrt=False)
def law_tile(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, p0, p1, jmax, dt,
             damping, tangential, rescale, e12, g12, law, couple, t, tp, force, torque, dmax, ncontact):
    """The pair law (:func:`granwave.dem.contact_law.contact_force3`, the same bits) for the listed
    pairs p0, p0 + 1, ... below p1 whose j is below ``jmax`` (the others are skipped, their
    history untouched), until TILE of them touch; each contact's force and torque are added
    to both grains in list order, as the pair-at-a-time loop does.

    Pairs that no longer touch lose their history (``pair_ov``, ``pair_ft`` zeroed); touching
    ones get the new one. ``couple``: the couple sub-model (its model tuple, granwave.contact_models, kind rolling;
    none: the torques as before it). ``t``, ``tp``: one tile's scratch (:func:`scratch`). Returns (the
    first pair not looked at, the largest overlap and the contact count, ``dmax`` and
    ``ncontact`` updated)."""
    d = pos.shape[1]
    r = omega.shape[1]
    # stage 1: geometry; pairs apart release their history, touching ones are packed. Pair and
    # grain indices are taken unsigned in all stages: numba tests every signed index for a
    # negative (wraparound) value, two instructions per access on the gathers and scatters
    # (9-13 % of the force loop's time on 10^4 grains, blocks.grains)
    nc = 0
    p = p0
    while p < p1 and nc < TILE:
        pu = np.uint64(p)
        j = pair_j[pu]
        if j < jmax and _packed(pos, lateral, rad, pair_ft, pair_ov, pu, np.uint64(pair_i[pu]),
                                np.uint64(j), t, nc, d):
            tp[nc] = p
            nc += 1
        p += 1
    _staged_law(vel, omega, rad, pair_i, pair_j, pair_c, pair_ft, pair_ov, damping, tangential, e12, g12, law, t, tp,
                nc, d)
    # forces and torques added in list order
    for c in range(nc):
        q = np.uint64(tp[c])
        i = np.uint64(pair_i[q])
        j = np.uint64(pair_j[q])
        fx, fy, fz, delta, nx, ny, nz = _contact(pair_ft, pair_ov, t, c, q, d, dt, damping, tangential, rescale)
        force[i, 0] += fx
        force[i, 1] += fy
        force[j, 0] -= fx
        force[j, 1] -= fy
        if d == 3:
            force[i, 2] += fz
            force[j, 2] -= fz
        if r > 0:
            if couple.code != 0:  # a rolling couple c on i, -c on j, added with the force's torque
                cx, cy, cz = pair_couple(omega, pair_ft, q, i, j, nx, ny, nz, pair_c[q, PC_R12],
                                          t[T_FEL * ROW + c], dt, couple)
                add_torque_with_couple(torque, i, t[T_AI * ROW + c], nx, ny, nz, fx, fy, fz, cx, cy, cz)
                add_torque_with_couple(torque, j, t[T_AJ * ROW + c], nx, ny, nz, fx, fy, fz, -cx, -cy, -cz)
            else:
                _add_torque3(torque, i, t[T_AI * ROW + c], nx, ny, nz, fx, fy, fz)
                _add_torque3(torque, j, t[T_AJ * ROW + c], nx, ny, nz, fx, fy, fz)
        if delta > dmax:
            dmax = delta
        ncontact += 1
    return p, dmax, ncontact


@numba.njit(cache=True, error_model="numpy", _nrt=False)
def law_tile_incoming(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, slot_pair, s0, s1,
                      dt, damping, tangential, rescale, e12, g12, law, couple, t, tp, force, torque, bnd_f, dmax,
                      ncontact):
    """The pair law of :func:`law_tile` (the same bits) for a block's incoming pairs: the pairs
    ``slot_pair[s]`` (k, g) of slots s0, s0 + 1, ... below s1, until TILE of them touch. Each
    contact's force is subtracted from g and its torque a_g (n x f) added to g's, in slot
    order; its force on k and k's torque a_k (n x f) go to the slot's row of ``bnd_f`` (zeros
    for pairs apart), for k's row to add later (passes._incoming_block). Returns (the first
    slot not looked at, ``dmax`` and ``ncontact`` updated)."""
    d = pos.shape[1]
    r = omega.shape[1]
    nc = 0
    s = s0
    while s < s1 and nc < TILE:
        q = np.uint64(slot_pair[s])
        if _packed(pos, lateral, rad, pair_ft, pair_ov, q, np.uint64(pair_i[q]), np.uint64(pair_j[q]), t, nc, d):
            tp[nc] = q
            tp[TILE + nc] = s
            nc += 1
        else:
            for a in range(d + r):
                bnd_f[s, a] = 0.0
        s += 1
    _staged_law(vel, omega, rad, pair_i, pair_j, pair_c, pair_ft, pair_ov, damping, tangential, e12, g12, law, t, tp,
                nc, d)
    for c in range(nc):
        q = np.uint64(tp[c])
        slot = np.uint64(tp[TILE + c])
        g = np.uint64(pair_j[q])
        fx, fy, fz, delta, nx, ny, nz = _contact(pair_ft, pair_ov, t, c, q, d, dt, damping, tangential, rescale)
        force[g, 0] -= fx
        force[g, 1] -= fy
        bnd_f[slot, 0] = fx
        bnd_f[slot, 1] = fy
        if d == 3:
            force[g, 2] -= fz
            bnd_f[slot, 2] = fz
        if r > 0 and couple.code != 0:  # law_tile's torques with the rolling couple, k's into the slot
            cx, cy, cz = pair_couple(omega, pair_ft, q, np.uint64(pair_i[q]), g, nx, ny, nz, pair_c[q, PC_R12],
                                      t[T_FEL * ROW + c], dt, couple)
            add_torque_with_couple(torque, g, t[T_AJ * ROW + c], nx, ny, nz, fx, fy, fz, -cx, -cy, -cz)
            tx, ty, tz = torque_with_couple(t[T_AI * ROW + c], nx, ny, nz, fx, fy, fz, cx, cy, cz)
            if r == 1:
                bnd_f[slot, d] = tz
            else:
                bnd_f[slot, d] = tx
                bnd_f[slot, d + 1] = ty
                bnd_f[slot, d + 2] = tz
            if delta > dmax:
                dmax = delta
            ncontact += 1
            continue
        if r > 0:
            _add_torque3(torque, g, t[T_AJ * ROW + c], nx, ny, nz, fx, fy, fz)
        # the torque on k as _add_torque3 computes it (the same bits when k's row adds it)
        ai = t[T_AI * ROW + c]
        if r == 1:
            bnd_f[slot, d] = ai * (nx * fy - ny * fx)
        elif r == 3:
            bnd_f[slot, d] = ai * (ny * fz - nz * fy)
            bnd_f[slot, d + 1] = ai * (nz * fx - nx * fz)
            bnd_f[slot, d + 2] = ai * (nx * fy - ny * fx)
        if delta > dmax:
            dmax = delta
        ncontact += 1
    return s, dmax, ncontact


@numba.njit(cache=True, error_model="numpy", _nrt=False)
def _staged_law(vel, omega, rad, pair_i, pair_j, pair_c, pair_ft, pair_ov, damping, tangential, e12, g12, law, t, tp,
                nc, d):
    """The law's stages between the packing of ``nc`` touching pairs (their indices in
    ``tp``, geometry in the rows T_DX ... T_RS of ``t``) and the per-contact forces
    (:func:`_contact`): normals and overlaps, contact velocities, the carried history and
    the pair's constants, then the roots and quotients of the law in vector loops. The laws
    (``law``, ``damping``, ``tangential``: granwave.contact_models) are chosen once per tile,
    outside the vector loops, so that the loops of the defaults (code 0 of every kind:
    contact.py's formulas) stay branch-free (Hertz's is the loop before the seam); any other
    selection takes the dispatchers."""
    friction = CD.friction_acts(tangential)
    # an undamped contact has no dashpot coefficients to compute (their roots), and an undamped
    # frictionless one's force is its elastic normal force alone: its velocity (two grains'
    # gathers) is not computed either (the pulses' default)
    damped = CD.dashpot_acts(damping)
    # vector: distance, unit normal i -> j, overlap
    if d == 3:
        for c in range(nc):
            dist = math.sqrt(t[T_R2 * ROW + c])
            t[T_NX * ROW + c] = t[T_DX * ROW + c] / dist
            t[T_NY * ROW + c] = t[T_DY * ROW + c] / dist
            t[T_NZ * ROW + c] = t[T_DZ * ROW + c] / dist
            t[T_DELTA * ROW + c] = t[T_RS * ROW + c] - dist
    else:
        for c in range(nc):
            dist = math.sqrt(t[T_R2 * ROW + c])
            t[T_NX * ROW + c] = t[T_DX * ROW + c] / dist
            t[T_NY * ROW + c] = t[T_DY * ROW + c] / dist
            t[T_DELTA * ROW + c] = t[T_RS * ROW + c] - dist
    # stage 2: relative velocity at the contact point, the pair's constants, the history
    # carried into the new tangent plane up to its rescale (contact.tangential_part3, the first
    # half of project_tangential3)
    for c in range(nc):
        q = np.uint64(tp[c])
        i = np.uint64(pair_i[q])
        j = np.uint64(pair_j[q])
        delta = t[T_DELTA * ROW + c]
        nx = t[T_NX * ROW + c]
        ny = t[T_NY * ROW + c]
        nz = t[T_NZ * ROW + c] if d == 3 else 0.0
        ai = rad[i] - 0.5 * delta
        aj = rad[j] - 0.5 * delta
        t[T_AI * ROW + c] = ai
        t[T_AJ * ROW + c] = aj
        t[T_ROOT * ROW + c] = pair_c[q, PC_ROOT]
        if not (friction or damped):
            continue
        vx, vy, vz = _contact_velocity(vel, omega, i, j, ai, aj, nx, ny, nz)
        vn = vx * nx + vy * ny + vz * nz
        t[T_VN * ROW + c] = vn
        t[T_MEFF * ROW + c] = pair_c[q, PC_MEFF]
        if friction:
            t[T_TX * ROW + c] = vx - vn * nx
            t[T_TY * ROW + c] = vy - vn * ny
            t[T_TZ * ROW + c] = vz - vn * nz
            hx = pair_ft[q, 0]
            hy = pair_ft[q, 1]
            hz = pair_ft[q, 2] if d == 3 else 0.0
            hx, hy, hz, old2, new2 = C.tangential_part3(hx, hy, hz, nx, ny, nz)
            t[T_OLD2 * ROW + c] = old2
            t[T_NEW2 * ROW + c] = new2
            t[T_GX * ROW + c] = hx
            t[T_GY * ROW + c] = hy
            t[T_GZ * ROW + c] = hz
            t[T_R12 * ROW + c] = pair_c[q, PC_R12]
            t[T_OVOLD * ROW + c] = pair_ov[q]
    # vector: Hertz, k_n and the normal damping coefficient through contact.py's own functions
    # (inlined, their roots vectorize here), and with friction k_t, its damping coefficient, the
    # projection's rescale (its quotient may be inf or NaN where stage 3 does not use it) and
    # the unloading's (contact.unloading_scale)
    if law.code == 0 and damping.code == 0 and tangential.code == 0:
        # the defaults (code 0): contact.py's formulas (contact_models.hertz, damping_critical and
        # mindlin bind them)
        zeta = damping.c0
        if damped:
            for c in range(nc):
                delta = t[T_DELTA * ROW + c]
                root = t[T_ROOT * ROW + c]
                t[T_FEL * ROW + c] = C.normal_force_root(delta, root, e12)
                t[T_CN * ROW + c] = C.damping_coefficient(zeta, t[T_MEFF * ROW + c],
                                                          C.normal_stiffness_root(delta, root, e12))
        else:
            for c in range(nc):
                t[T_FEL * ROW + c] = C.normal_force_root(t[T_DELTA * ROW + c], t[T_ROOT * ROW + c], e12)
        if friction:
            for c in range(nc):
                delta = t[T_DELTA * ROW + c]
                kt = C.tangential_stiffness(delta, t[T_R12 * ROW + c], g12)
                t[T_KT * ROW + c] = kt
                if damped:  # loop-invariant: the compiler makes two loops of it
                    t[T_CT * ROW + c] = C.damping_coefficient(zeta, t[T_MEFF * ROW + c], kt)
                t[T_SPROJ * ROW + c] = math.sqrt(t[T_OLD2 * ROW + c] / t[T_NEW2 * ROW + c])
                t[T_SRES * ROW + c] = C.unloading_scale(t[T_OVOLD * ROW + c], delta)
    else:  # any other selection through the dispatchers (granwave.contact_models)
        if damped:
            for c in range(nc):
                delta = t[T_DELTA * ROW + c]
                root = t[T_ROOT * ROW + c]
                t[T_FEL * ROW + c] = CD.law_force(law, delta, root, e12)
                t[T_CN * ROW + c] = CD.dashpot_coefficient(damping, t[T_MEFF * ROW + c],
                                                           CD.law_stiffness(law, delta, root, e12), delta)
        else:
            for c in range(nc):
                t[T_FEL * ROW + c] = CD.law_force(law, t[T_DELTA * ROW + c], t[T_ROOT * ROW + c], e12)
        if friction:
            for c in range(nc):
                delta = t[T_DELTA * ROW + c]
                kt = CD.tangential_spring(tangential, CD.law_tangential_stiffness(law, delta, t[T_R12 * ROW + c], g12),
                                          delta, e12)
                t[T_KT * ROW + c] = kt
                if damped:
                    t[T_CT * ROW + c] = CD.dashpot_coefficient(damping, t[T_MEFF * ROW + c], kt, delta)
                t[T_SPROJ * ROW + c] = math.sqrt(t[T_OLD2 * ROW + c] / t[T_NEW2 * ROW + c])
                t[T_SRES * ROW + c] = CD.law_unloading_scale(law, t[T_OVOLD * ROW + c], delta)


@numba.njit(cache=True, error_model="numpy", inline="always", _nrt=False)
def _contact(pair_ft, pair_ov, t, c, q, d, dt, damping, tangential, rescale):
    """Contact c of a staged tile (pair q): its force on i (fx, fy, fz), overlap and normal
    (delta, nx, ny, nz); writes the pair's new history."""
    # stage 3, per contact: the projection's rescale, then the tangential law's steps (unloads,
    # the factor from the vector loop, its increment: a sliding contact's root and quotient stay
    # scalar), the damped normal force (never attractive), the force on i, the new history
    delta = t[T_DELTA * ROW + c]
    fel = t[T_FEL * ROW + c]
    vn = t[T_VN * ROW + c]
    nx = t[T_NX * ROW + c]
    ny = t[T_NY * ROW + c]
    nz = t[T_NZ * ROW + c] if d == 3 else 0.0
    fn = fel
    if CD.dashpot_acts(damping):
        # approaching (vn < 0) gives a repulsive viscous force
        fn = C.total_normal_force(fel, -t[T_CN * ROW + c] * vn)
    if CD.friction_acts(tangential):
        tx = t[T_TX * ROW + c]
        ty = t[T_TY * ROW + c]
        tz = t[T_TZ * ROW + c]
        gx = t[T_GX * ROW + c]
        gy = t[T_GY * ROW + c]
        gz = t[T_GZ * ROW + c]
        if t[T_NEW2 * ROW + c] > 0.0:
            scale = t[T_SPROJ * ROW + c]
            gx *= scale
            gy *= scale
            gz *= scale
        if CD.tangential_unloads(tangential, t[T_OVOLD * ROW + c], delta, rescale):
            scale = t[T_SRES * ROW + c]
            gx *= scale
            gy *= scale
            gz *= scale
        gx, gy, gz, slid = CD.tangential_increment(tangential, gx, gy, gz, tx * dt, ty * dt, tz * dt,
                                                   t[T_KT * ROW + c], fel)
        ct = 0.0
        if CD.dashpot_acts(damping) and not slid:
            ct = t[T_CT * ROW + c]
        fx = -fn * nx + gx + ct * tx
        fy = -fn * ny + gy + ct * ty
        fz = -fn * nz + gz + ct * tz
        pair_ft[q, 0] = gx
        pair_ft[q, 1] = gy
        if d == 3:
            pair_ft[q, 2] = gz
    else:
        fx = -fn * nx
        fy = -fn * ny
        fz = -fn * nz
    pair_ov[q] = delta
    return fx, fy, fz, delta, nx, ny, nz
