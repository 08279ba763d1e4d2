"""Numba kernels of the DEM engine: per-contact law application and force loops.

Pure functions over float64 arrays (int64 indices); one code path for 2D and
3D (the dimension is read from array shapes) and for frictionless runs (the
rotation arrays then have zero columns), so each kernel compiles once.

Every piece of the contact law is called from :mod:`granwave.contact`; the
geometry follows docs/conventions.md. :func:`contact_force3` is the single
per-contact routine (scalars in and out): the engine's pair pass calls it with
velocities and the real Coulomb law; :func:`granwave.dem.forces.frozen_history_forces`
calls its array form :func:`contact_force` with displacements (``dt = 1``), no
unloading rescale and no Coulomb cap.

Parallel and deterministic (docs/dem.md, "Parallel engine"): a step is two
parallel passes, :func:`_pair_pass` (each pair's force and torques once, into
its own slots) and :func:`_grain_pass` (each grain adds its pairs' contributions
in increasing pair order from the gather list built with the pair list, then its
walls and damping, then kicks and drifts). Sums run in the order of the former
serial loop, and maxima and sums over grains are taken per fixed block, so the
results are bit for bit the same for any number of threads. No floating-point
atomics.

Layout of the small parameter arrays (indices below):
``fpar``: dt, zeta, mu, poisson, background damping rate, skin, dt safety,
overlap floor for the time step, acceleration tol, velocity tol, largest
radius, smallest mass, last max speed, unloading rule (1: rescale F_t on
unloading, 0: plain incremental; contact.update_tangential); ``piston``: height, velocity,
acceleration, mass (inf = fixed wall), downward force p*A, contact force.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from .. import threads as _threads  # noqa: F401  (selects the threading layer first)
from ..geometry import nearest_image
from . import neighbours


# fpar indices
F_DT, F_ZETA, F_MU, F_POISSON, F_GAMMA, F_SKIN, F_SAFETY, F_DFLOOR, F_TOLA, F_TOLV, F_RMAX, F_MMIN, \
    F_VMAX, F_RESCALE = range(14)
N_FPAR = 14
# piston indices
P_H, P_V, P_A, P_MASS, P_FEXT, P_FCON = range(6)
N_PISTON = 6
# ipar indices
I_NPAIRS, I_NSTEPS, I_STEPS, I_CHECK, I_ADAPTIVE, I_REBUILDS, I_NEEDED, I_WIDTH = range(8)
N_IPAR = 8
# out (statistics) indices
O_AMAX, O_ALPHAMAX, O_APISTON, O_VMAX, O_WMAX, O_KIN, O_NTOP, O_DMAX, O_NCONTACT = range(9)
N_OUT = 9


@numba.njit(cache=True, inline="always")
def rotation_velocity(vrel, n, omega, i, j, ai, aj):
    """Subtract (a_i w_i + a_j w_j) x n from ``vrel`` (j < 0: a wall, no rotation).

    The contact-point velocity of j relative to i (conventions) is
    v_j - v_i + w_j x (-a_j n) - w_i x (a_i n) = v_j - v_i - (a_i w_i + a_j w_j) x n.
    ``omega`` rows hold w (2D: one column, the z component; 3D: three).
    """
    r = omega.shape[1]
    if r == 1:
        w = ai * omega[i, 0]
        if j >= 0:
            w += aj * omega[j, 0]
        # w e_z x n = w (-n_y, n_x)
        vrel[0] += w * n[1]
        vrel[1] -= w * n[0]
    elif r == 3:
        w0 = ai * omega[i, 0]
        w1 = ai * omega[i, 1]
        w2 = ai * omega[i, 2]
        if j >= 0:
            w0 += aj * omega[j, 0]
            w1 += aj * omega[j, 1]
            w2 += aj * omega[j, 2]
        vrel[0] -= w1 * n[2] - w2 * n[1]
        vrel[1] -= w2 * n[0] - w0 * n[2]
        vrel[2] -= w0 * n[1] - w1 * n[0]


@numba.njit(cache=True, inline="always")
def add_torque(torque, k, arm, n, f):
    """torque[k] += (arm n) x f (only the tangential part of f contributes)."""
    r = torque.shape[1]
    if r == 1:
        torque[k, 0] += arm * (n[0] * f[1] - n[1] * f[0])
    elif r == 3:
        torque[k, 0] += arm * (n[1] * f[2] - n[2] * f[1])
        torque[k, 1] += arm * (n[2] * f[0] - n[0] * f[2])
        torque[k, 2] += arm * (n[0] * f[1] - n[1] * f[0])


@numba.njit(cache=True, inline="always")
def contact_force3(nx, ny, nz, delta, r12, e12, g12, meff, vx, vy, vz, hx, hy, hz, overlap_old, dt, zeta,
                   mu, rescale):
    """Force (fx, fy, fz) on i from one contact (Hertz-Mindlin, docs/method.md §2); returns it and
    the elastic normal force. The single per-contact routine (scalar form).

    Three components always (2D: the third is 0, and adding zeros leaves the 2D
    arithmetic unchanged). (nx, ny, nz) unit normal i -> j, ``delta`` > 0 the overlap,
    (vx, vy, vz) the contact-point velocity of j relative to i, (hx, hy, hz) the
    tangential history F_t, ``overlap_old`` the overlap when it was last updated.
    Returns (fx, fy, fz, elastic normal force, new history hx, hy, hz). Normal: Hertz plus viscous c_n = 2 zeta sqrt(m_eff k_n) on
    the normal velocity, total never attractive. Tangential (mu > 0): ``ft`` carried into
    the new tangent plane (contact.project_tangential), then contact.update_tangential
    with slip = tangential velocity * dt and its unloading rescale when ``rescale``
    (contact.py docstring: preparation True, pulses False); a viscous part c_t v_t is added to the force
    (not to the history) while the contact sticks.
    """
    fel = C.normal_force(delta, r12, e12)
    vn = vx * nx + vy * ny + vz * nz
    fn = fel
    if zeta > 0.0:
        kn = C.normal_stiffness(delta, r12, e12)
        # approaching (vn < 0) gives a repulsive viscous force
        fn = C.total_normal_force(fel, -C.damping_coefficient(zeta, meff, kn) * vn)
    if mu > 0.0:
        tx = vx - vn * nx
        ty = vy - vn * ny
        tz = vz - vn * nz
        # Scalar forms of the law (contact.py): the history stays in registers.
        gx, gy, gz = C.project_tangential3(hx, hy, hz, nx, ny, nz)
        kt = C.tangential_stiffness(delta, r12, g12)
        gx, gy, gz, slid = C.update_tangential3(gx, gy, gz, tx * dt, ty * dt, tz * dt,
                                                overlap_old, delta, kt, fel, mu, rescale)
        ct = 0.0
        if zeta > 0.0 and not slid:
            ct = C.damping_coefficient(zeta, meff, kt)
        return (-fn * nx + gx + ct * tx, -fn * ny + gy + ct * ty, -fn * nz + gz + ct * tz, fel,
                gx, gy, gz)
    return -fn * nx, -fn * ny, -fn * nz, fel, hx, hy, hz


@numba.njit(cache=True)
def contact_force(n, delta, r12, e12, g12, meff, vrel, ft, overlap_old, dt, zeta, mu, fvec,
                  rescale=True):
    """Array form of :func:`contact_force3` (tests, frozen-history forces).

    ``n``, ``vrel``, ``ft``, ``fvec`` have length d = 2 or 3; ``ft`` is updated
    in place, the force on i is written into ``fvec``, the elastic normal force returned.
    """
    d = n.shape[0]
    three = d == 3
    fx, fy, fz, fel, hx, hy, hz = contact_force3(
        n[0], n[1], n[2] if three else 0.0, delta, r12, e12, g12, meff,
        vrel[0], vrel[1], vrel[2] if three else 0.0, ft[0], ft[1], ft[2] if three else 0.0,
        overlap_old, dt, zeta, mu, rescale)
    ft[0] = hx
    ft[1] = hy
    if three:
        ft[2] = hz
    fvec[0] = fx
    fvec[1] = fy
    if d == 3:
        fvec[2] = fz
    return fel


#: The parallel engine splits the grains into contiguous index blocks (docs/dem.md, "Parallel
#: engine"): ``block_count(N)`` blocks of about BLOCK_GRAINS grains, their number a multiple of
#: BLOCK_MULTIPLE so that 2 or 4 threads get equal shares of the blocks. The partition depends
#: on N alone, never on the thread count; the blocks (not the threads) hold the partial maxima
#: and sums.
BLOCK_GRAINS = 1024
BLOCK_MULTIPLE = 4
# columns of the per-block statistics (``blk_g``)
G_DMAX, G_NC, G_NTOP, G_AMAX, G_ALMAX, G_VMAX, G_WMAX, G_KIN, G_DVMAX, G_DISP = range(10)
N_GCOL = 10


@numba.njit(cache=True)
def block_count(n):
    """Number of grain blocks for ``n`` grains: the multiple of BLOCK_MULTIPLE nearest
    n / BLOCK_GRAINS, at least BLOCK_MULTIPLE (and at most n, at least 1)."""
    k = int(n / (BLOCK_MULTIPLE * BLOCK_GRAINS) + 0.5)
    return max(1, min(n, BLOCK_MULTIPLE * max(1, k)))


@numba.njit(cache=True, inline="always")
def block_bounds(b, n, nblk):
    """Grains [b0, b1) of block b of ``nblk`` over ``n`` grains."""
    return b * n // nblk, (b + 1) * n // nblk


# Geometry pieces of one contact, shared with the GPU kernels (granwave.gpu.compile compiles
# these same functions for the device).
@numba.njit(cache=True, inline="always")
def _pair_geometry(pos, lateral, i, j):
    """(dx, dy, dz): nearest-image separation r_j - r_i (dz = 0 in 2D)."""
    d = pos.shape[1]
    dx = nearest_image(pos[j, 0] - pos[i, 0], lateral[0])
    if d == 2:
        return dx, pos[j, 1] - pos[i, 1], 0.0
    return dx, nearest_image(pos[j, 1] - pos[i, 1], lateral[1]), pos[j, 2] - pos[i, 2]


@numba.njit(cache=True, inline="always")
def _spin(omega, k, arm):
    """arm * w_k as (wx, wy, wz) (2D: only wz; frictionless: zeros)."""
    r = omega.shape[1]
    if r == 1:
        return 0.0, 0.0, arm * omega[k, 0]
    if r == 3:
        return arm * omega[k, 0], arm * omega[k, 1], arm * omega[k, 2]
    return 0.0, 0.0, 0.0


@numba.njit(cache=True, inline="always")
def _add_torque3(torque, k, arm, nx, ny, nz, fx, fy, fz):
    """torque[k] += (arm n) x f (only the tangential part of f contributes)."""
    r = torque.shape[1]
    if r == 1:
        torque[k, 0] += arm * (nx * fy - ny * fx)
    elif r == 3:
        torque[k, 0] += arm * (ny * fz - nz * fy)
        torque[k, 1] += arm * (nz * fx - nx * fz)
        torque[k, 2] += arm * (nx * fy - ny * fx)

@numba.njit(cache=True, inline="always")
def wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov, i, k, h, vp, e_wall, g_wall, dt, zeta,
                 mu, rescale):
    """Grain i against wall k (0 bottom: normal -e_z at 0; 1 top: +e_z at h, moving at vp):
    the pair law (:func:`contact_force3`) on the wall's own history slots (``wall_ft``,
    ``wall_ov``, updated here) with R12 = R_i, the wall moduli and the grain's mass.

    Returns (delta, arm, nx, ny, nz, fx, fy, fz): the force on the grain; delta <= 0 when
    they do not touch (the history is then cleared and the force is zero). One copy for
    the one-thread loop, the parallel grain pass and the GPU kernel.
    """
    d = pos.shape[1]
    r = omega.shape[1]
    y = pos[i, d - 1]
    R = rad[i]
    delta = R - y if k == 0 else R - (h - y)
    w = 2 * i + k
    if delta <= 0.0:
        if wall_ov[w] != 0.0:
            wall_ov[w] = 0.0
            for a in range(d):
                wall_ft[w, a] = 0.0
        return delta, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    sgn = -1.0 if k == 0 else 1.0
    vx = -vel[i, 0]
    if d == 2:
        nx, ny, nz = 0.0, sgn, 0.0
        vy = -vel[i, 1] + (vp if k == 1 else 0.0)
        vz = 0.0
    else:
        nx, ny, nz = 0.0, 0.0, sgn
        vy = -vel[i, 1]
        vz = -vel[i, 2] + (vp if k == 1 else 0.0)
    ai = R - delta
    if r > 0:
        wx, wy, wz = _spin(omega, i, ai)
        vx -= wy * nz - wz * ny
        vy -= wz * nx - wx * nz
        vz -= wx * ny - wy * nx
    hx = hy = hz = 0.0
    if mu > 0.0:
        hx = wall_ft[w, 0]
        hy = wall_ft[w, 1]
        if d == 3:
            hz = wall_ft[w, 2]
    fx, fy, fz, fel, hx, hy, hz = contact_force3(nx, ny, nz, delta, R, e_wall, g_wall, mass[i], vx, vy,
                                                 vz, hx, hy, hz, wall_ov[w], dt, zeta, mu, rescale)
    if mu > 0.0:
        wall_ft[w, 0] = hx
        wall_ft[w, 1] = hy
        if d == 3:
            wall_ft[w, 2] = hz
    wall_ov[w] = delta
    return delta, ai, nx, ny, nz, fx, fy, fz





def workspace(n_grains: int, dim: int, n_rot: int, cap: int, width: int) -> tuple:
    """Arrays of the parallel kernels for ``n_grains`` grains, ``width`` neighbours per grain:
    (nbr, gl, ncnt, nlo, row, need, inc_start, inc_g, blk_g, top_f, inv_rad): the neighbour and
    gather lists, counts and pair-list offsets of :func:`granwave.dem.neighbours.rebuild`, its
    size request, the incoming grains of each block (:func:`incoming_lists`), the per-block
    statistics, the top-wall forces and 1/R per grain (:func:`prepare_blocks`). (``dim``, ``n_rot``, ``cap``: kept for the callers;
    nothing here is per pair.)"""
    n = n_grains
    nblk = block_count(n)
    return (np.zeros((n, width), np.int64), np.zeros((n, width), np.int64),
            np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n + 1, np.int64),
            np.zeros(2, np.int64), np.zeros(nblk + 1, np.int64), np.zeros(max(1, n), np.int64),
            np.zeros((nblk, N_GCOL)), np.zeros(max(1, n)), np.zeros(n))


@numba.njit(cache=True)
def prepare_blocks(rad, ws):
    """Fill the workspace's incoming lists (:func:`incoming_lists`) and 1/R per grain (one
    division per grain, not two per pair and step)."""
    incoming_lists(ws[0], ws[3], ws[6], ws[7])
    inv_rad = ws[10]
    for i in range(rad.shape[0]):
        inv_rad[i] = 1.0 / rad[i]


@numba.njit(cache=True)
def incoming_lists(nbr, nlo, inc_start, inc_g):
    """For each block b, its grains with a partner below the block, increasing, into
    ``inc_g[inc_start[b]:inc_start[b + 1]]``: they receive the forces of pairs owned by
    earlier blocks (the *incoming* pairs; the block's other grains have all their pairs in its
    own rows). From the sorted neighbour rows of the last rebuild; O(N), serial."""
    n = nlo.shape[0]
    nblk = inc_start.shape[0] - 1
    q = 0
    for b in range(nblk):
        inc_start[b] = q
        b0, b1 = block_bounds(b, n, nblk)
        for g in range(b0, b1):
            if nlo[g] > 0 and nbr[g, 0] < b0:
                inc_g[q] = g
                q += 1
    inc_start[nblk] = q


@numba.njit(cache=True)
def boundary_fraction(nbr, nlo, inc_start, inc_g, npairs):
    """Incoming pairs (computed twice per step: once read-only by the block of j) over all
    pairs of the list."""
    n = nlo.shape[0]
    nblk = inc_start.shape[0] - 1
    m = 0
    for b in range(nblk):
        b0 = block_bounds(b, n, nblk)[0]
        for q in range(inc_start[b], inc_start[b + 1]):
            g = inc_g[q]
            for t in range(nlo[g]):
                if nbr[g, t] >= b0:
                    break
                m += 1
    return m / max(1, npairs)


@numba.njit(cache=True, inline="always")
def _pair_law(pos, vel, omega, rad, inv_rad, mass, lateral, pair_ft, pair_ov, p, i, j, dt, zeta, mu,
              rescale, e_pair, g_pair):
    """Pair p = (i, j): (touching, delta, a_i, a_j, n, force on i, new tangential history),
    with the arithmetic of the one-thread loop (dem/serial.py) so that the bits are its own.
    Reads the history, writes nothing."""
    d = pos.shape[1]
    r = omega.shape[1]
    dx, dy, dz = _pair_geometry(pos, lateral, i, j)
    r2 = dx * dx + dy * dy + dz * dz
    ri = rad[i]
    rj = rad[j]
    rs = ri + rj
    if r2 >= rs * rs:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    dist = math.sqrt(r2)
    delta = rs - dist
    nx = dx / dist
    ny = dy / dist
    nz = dz / dist if d == 3 else 0.0
    vx = vel[j, 0] - vel[i, 0]
    vy = vel[j, 1] - vel[i, 1]
    vz = vel[j, 2] - vel[i, 2] if d == 3 else 0.0
    ai = ri - 0.5 * delta
    aj = rj - 0.5 * delta
    if r > 0:
        # v_rel -= (a_i w_i + a_j w_j) x n (docs/conventions.md)
        wx, wy, wz = _spin(omega, i, ai)
        ux, uy, uz = _spin(omega, j, aj)
        wx += ux
        wy += uy
        wz += uz
        vx -= wy * nz - wz * ny
        vy -= wz * nx - wx * nz
        vz -= wx * ny - wy * nx
    r12 = C.effective_radius(inv_rad[i], inv_rad[j])
    meff = C.reduced_mass(mass[i], mass[j], False)
    hx = hy = hz = 0.0
    if mu > 0.0:
        hx = pair_ft[p, 0]
        hy = pair_ft[p, 1]
        if d == 3:
            hz = pair_ft[p, 2]
    fx, fy, fz, fel, hx, hy, hz = contact_force3(nx, ny, nz, delta, r12, e_pair, g_pair, meff,
                                                 vx, vy, vz, hx, hy, hz, pair_ov[p], dt, zeta,
                                                 mu, rescale)
    return True, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz


@numba.njit(cache=True, parallel=True)
def _incoming_pass(pos, vel, acc, omega, alpha, rad, inv_rad, mass, lateral, pair_ft, pair_ov, fpar, nbr, gl,
                   nlo, inc_start, inc_g):
    """Phase 1 of a step, in parallel over blocks: each block sets its grains' force and torque
    (``acc``, ``alpha``) to zero and adds to each of its grains g the forces of its incoming
    pairs (k, g), k below the block, in increasing k (g's gather list), read-only: the owner
    row computes the same force again in phase 2 and updates the history. For every grain
    these are the first terms of the one-thread loop's sum, in its order."""
    nblk = inc_start.shape[0] - 1
    for b in numba.prange(nblk):
        _incoming_block(np.int64(b), pos, vel, acc, omega, alpha, rad, inv_rad, mass, lateral, pair_ft, pair_ov,
                        fpar, nbr, gl, nlo, inc_start, inc_g)


@numba.njit(cache=True, _nrt=False)  # no reference counting of the arrays of the inlined helpers
def _incoming_block(b, pos, vel, acc, omega, alpha, rad, inv_rad, mass, lateral, pair_ft, pair_ov, fpar, nbr, gl,
                    nlo, inc_start, inc_g):
    """Block b of :func:`_incoming_pass` (a plain function: the parallel one stays small, which
    keeps its compilation short)."""
    n, d = pos.shape
    r = omega.shape[1]
    nblk = inc_start.shape[0] - 1
    b0, b1 = block_bounds(b, n, nblk)
    for g in range(b0, b1):
        for a in range(d):
            acc[g, a] = 0.0
        for a in range(r):
            alpha[g, a] = 0.0
    dt = fpar[F_DT]
    zeta = fpar[F_ZETA]
    mu = fpar[F_MU]
    rescale = fpar[F_RESCALE] != 0.0
    e_pair = C.effective_young(False)
    g_pair = C.effective_shear(fpar[F_POISSON], False)
    for q in range(inc_start[b], inc_start[b + 1]):
        g = inc_g[q]
        for t in range(nlo[g]):
            k = nbr[g, t]
            if k >= b0:
                break
            touch, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz = _pair_law(
                pos, vel, omega, rad, inv_rad, mass, lateral, pair_ft, pair_ov, gl[g, t], k, g, dt, zeta, mu,
                rescale, e_pair, g_pair)
            if not touch:
                continue
            acc[g, 0] -= fx
            acc[g, 1] -= fy
            if d == 3:
                acc[g, 2] -= fz
            if r > 0:
                _add_torque3(alpha, g, aj, nx, ny, nz, fx, fy, fz)


@numba.njit(cache=True, inline="always")
def _finish(lo, hi, pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, dt, stats, drift):
    """Grains lo..hi-1 after their forces and torques: accelerations and the second half kick;
    with ``stats`` the largest |a|^2, |alpha|^2, |v|^2, |w|^2 R^2 and the summed kinetic
    energy, after the kick; with ``drift`` the next step's first half kick and drift, the
    largest |v|^2 and squared displacement since ``pos0``. Returned in that order. Separate
    short loops (they vectorize); the same operations per grain as one loop."""
    d = pos.shape[1]
    r = omega.shape[1]
    half = 0.5 * dt
    for i in range(lo, hi):
        inv = 1.0 / mass[i]
        for a in range(d):
            acc[i, a] *= inv
            vel[i, a] += half * acc[i, a]
        inv = 1.0 / inertia[i]
        for a in range(r):
            alpha[i, a] *= inv
            omega[i, a] += half * alpha[i, a]
    amax = almax = vmax = wmax = kin = dvmax = disp = 0.0
    if stats:
        for i in range(lo, hi):
            a2 = 0.0
            v2 = 0.0
            for a in range(d):
                a2 += acc[i, a] * acc[i, a]
                v2 += vel[i, a] * vel[i, a]
            al2 = 0.0
            w2 = 0.0
            for a in range(r):
                al2 += alpha[i, a] * alpha[i, a]
                w2 += omega[i, a] * omega[i, a]
            amax = max(amax, a2)
            almax = max(almax, al2)
            vmax = max(vmax, v2)
            wmax = max(wmax, w2 * rad[i] * rad[i])
            kin += 0.5 * (mass[i] * v2 + inertia[i] * w2)
    if drift:
        for i in range(lo, hi):
            v2 = 0.0
            s = 0.0
            for a in range(d):
                vel[i, a] += half * acc[i, a]
                pos[i, a] += dt * vel[i, a]
                v2 += vel[i, a] * vel[i, a]
                x = pos[i, a] - pos0[i, a]
                s += x * x
            dvmax = max(dvmax, v2)
            disp = max(disp, s)
            for a in range(r):
                omega[i, a] += half * alpha[i, a]
    return amax, almax, vmax, wmax, kin, dvmax, disp


@numba.njit(cache=True, parallel=True)
def _row_pass(pos, vel, acc, omega, alpha, rad, inv_rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, row, inc_start, inc_g, blk_g, top_f, kick, stats,
              drift):
    """Phase 2 of a step, in parallel over blocks, after phase 1: each block runs the
    one-thread pair loop over its own rows (pairs (i, j), i in the block), updating their
    tangential histories and adding each force to i, and to j when j is in the block (a j
    beyond it got the same force in its own block's phase 1, :func:`_incoming_pass`); then, per grain of the block, its bottom and top wall contacts
    and the background damping -gamma m v, -gamma I w: for every grain the terms of the
    one-thread loop in its order, so its force is bit for bit that loop's.

    ``kick`` 0: forces and torques stay in ``acc``, ``alpha``; 1: accelerations, the second
    half kick and (``stats``, ``drift``: see :func:`_finish`) for the block's grains that no
    earlier block reads in this phase (those without incoming pairs); the others wait for
    :func:`_deferred_pass`. Per block into ``blk_g``: largest overlap, contacts (its rows
    and walls), top-wall contacts (their forces on the piston, grain order, into ``top_f``
    from the block's first grain), the measures of the grains finished here.
    """
    nblk = inc_start.shape[0] - 1
    for b in numba.prange(nblk):
        _row_block(np.int64(b), pos, vel, acc, omega, alpha, rad, inv_rad, mass, inertia, lateral, pos0, pair_i,
                   pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, row, inc_start, inc_g, blk_g,
                   top_f, kick, stats, drift)


@numba.njit(cache=True, _nrt=False)  # no reference counting of the arrays passed to wall_contact
def _row_block(b, pos, vel, acc, omega, alpha, rad, inv_rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
               pair_ov, wall_ft, wall_ov, piston, fpar, row, inc_start, inc_g, blk_g, top_f, kick, stats,
               drift):
    """Block b of :func:`_row_pass`."""
    n, d = pos.shape
    r = omega.shape[1]
    nblk = inc_start.shape[0] - 1
    b0, b1 = block_bounds(b, n, nblk)
    dt = fpar[F_DT]
    zeta = fpar[F_ZETA]
    mu = fpar[F_MU]
    gamma = fpar[F_GAMMA]
    rescale = fpar[F_RESCALE] != 0.0
    e_pair = C.effective_young(False)
    g_pair = C.effective_shear(fpar[F_POISSON], False)
    e_wall = C.effective_young(True)
    g_wall = C.effective_shear(fpar[F_POISSON], True)
    dmax = 0.0
    ncontact = 0
    for p in range(row[b0], row[b1]):
        i = pair_i[p]
        j = pair_j[p]
        touch, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz = _pair_law(
            pos, vel, omega, rad, inv_rad, mass, lateral, pair_ft, pair_ov, p, i, j, dt, zeta, mu, rescale,
            e_pair, g_pair)
        if not touch:
            if pair_ov[p] != 0.0:  # the contact opened: its history is destroyed
                pair_ov[p] = 0.0
                for a in range(d):
                    pair_ft[p, a] = 0.0
            continue
        if mu > 0.0:
            pair_ft[p, 0] = hx
            pair_ft[p, 1] = hy
            if d == 3:
                pair_ft[p, 2] = hz
        pair_ov[p] = delta
        inside = j < b1
        acc[i, 0] += fx
        acc[i, 1] += fy
        if d == 3:
            acc[i, 2] += fz
        if inside:
            acc[j, 0] -= fx
            acc[j, 1] -= fy
            if d == 3:
                acc[j, 2] -= fz
        if r > 0:
            _add_torque3(alpha, i, ai, nx, ny, nz, fx, fy, fz)
            if inside:
                _add_torque3(alpha, j, aj, nx, ny, nz, fx, fy, fz)
        if delta > dmax:
            dmax = delta
        ncontact += 1
    # walls: k = 0 bottom (normal -e_z, at 0), k = 1 top (normal +e_z, at h, velocity vp)
    h = piston[P_H]
    vp = piston[P_V]
    ntop = 0
    for i in range(b0, b1):
        for k in range(2):
            delta, ai, nx, ny, nz, fx, fy, fz = wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov,
                                                             i, k, h, vp, e_wall, g_wall, dt, zeta, mu,
                                                             rescale)
            if delta <= 0.0:
                continue
            acc[i, 0] += fx
            acc[i, 1] += fy
            if d == 3:
                acc[i, 2] += fz
            if r > 0:
                _add_torque3(alpha, i, ai, nx, ny, nz, fx, fy, fz)
            if k == 1:
                top_f[b0 + ntop] = fz if d == 3 else fy
                ntop += 1
            if delta > dmax:
                dmax = delta
            ncontact += 1
    if gamma > 0.0:
        for i in range(b0, b1):
            for a in range(d):
                acc[i, a] -= gamma * mass[i] * vel[i, a]
            for a in range(r):
                alpha[i, a] -= gamma * inertia[i] * omega[i, a]
    amax = almax = vmax = wmax = kin = dvmax = disp = 0.0
    if kick:
        # the grains between the incoming ones (those are read by earlier blocks' rows during
        # this phase and are finished in phase 3)
        lo = b0
        for q in range(inc_start[b], inc_start[b + 1] + 1):
            hi = inc_g[q] if q < inc_start[b + 1] else b1
            if hi > lo:
                m = _finish(lo, hi, pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, dt, stats, drift)
                amax = max(amax, m[0])
                almax = max(almax, m[1])
                vmax = max(vmax, m[2])
                wmax = max(wmax, m[3])
                kin += m[4]
                dvmax = max(dvmax, m[5])
                disp = max(disp, m[6])
            lo = hi + 1
    blk_g[b, G_DMAX] = dmax
    blk_g[b, G_NC] = ncontact
    blk_g[b, G_NTOP] = ntop
    blk_g[b, G_AMAX] = amax
    blk_g[b, G_ALMAX] = almax
    blk_g[b, G_VMAX] = vmax
    blk_g[b, G_WMAX] = wmax
    blk_g[b, G_KIN] = kin
    blk_g[b, G_DVMAX] = dvmax
    blk_g[b, G_DISP] = disp


@numba.njit(cache=True, parallel=True)
def _deferred_pass(pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, dt, inc_start, inc_g, blk_g,
                   stats, drift):
    """Phase 3 of a step (with a kick), after phase 2: :func:`_finish` for each block's grains
    with incoming pairs, which earlier blocks' rows read during phase 2; their measures
    combined into the block's row of ``blk_g``."""
    nblk = inc_start.shape[0] - 1
    for b in numba.prange(nblk):
        _deferred_block(np.int64(b), pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, dt, inc_start,
                        inc_g, blk_g, stats, drift)


@numba.njit(cache=True, _nrt=False)
def _deferred_block(b, pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, dt, inc_start, inc_g, blk_g,
                    stats, drift):
    """Block b of :func:`_deferred_pass`."""
    amax = blk_g[b, G_AMAX]
    almax = blk_g[b, G_ALMAX]
    vmax = blk_g[b, G_VMAX]
    wmax = blk_g[b, G_WMAX]
    kin = blk_g[b, G_KIN]
    dvmax = blk_g[b, G_DVMAX]
    disp = blk_g[b, G_DISP]
    for q in range(inc_start[b], inc_start[b + 1]):
        g = inc_g[q]
        m = _finish(g, g + 1, pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, dt, stats, drift)
        amax = max(amax, m[0])
        almax = max(almax, m[1])
        vmax = max(vmax, m[2])
        wmax = max(wmax, m[3])
        kin += m[4]
        dvmax = max(dvmax, m[5])
        disp = max(disp, m[6])
    blk_g[b, G_AMAX] = amax
    blk_g[b, G_ALMAX] = almax
    blk_g[b, G_VMAX] = vmax
    blk_g[b, G_WMAX] = wmax
    blk_g[b, G_KIN] = kin
    blk_g[b, G_DVMAX] = dvmax
    blk_g[b, G_DISP] = disp


@numba.njit(cache=True, parallel=True)
def _drift_pass(pos, vel, acc, omega, alpha, pos0, dt, blk_g):
    """First half kick and drift of velocity Verlet; block maxima of |v|^2 and of the squared
    displacement since ``pos0`` into ``blk_g`` (columns G_DVMAX, G_DISP)."""
    n, d = pos.shape
    r = omega.shape[1]
    nblk = blk_g.shape[0]
    for b in numba.prange(nblk):
        dvmax = 0.0
        disp = 0.0
        b0, b1 = block_bounds(np.int64(b), n, nblk)
        for i in range(b0, b1):
            v2 = 0.0
            s = 0.0
            for a in range(d):
                vel[i, a] += 0.5 * dt * acc[i, a]
                pos[i, a] += dt * vel[i, a]
                v2 += vel[i, a] * vel[i, a]
                x = pos[i, a] - pos0[i, a]
                s += x * x
            dvmax = max(dvmax, v2)
            disp = max(disp, s)
            for a in range(r):
                omega[i, a] += 0.5 * dt * alpha[i, a]
        blk_g[b, G_DVMAX] = dvmax
        blk_g[b, G_DISP] = disp


@numba.njit(cache=True, parallel=True)
def _displacement_pass(pos, pos0, blk_g):
    """Block maxima of the squared displacement since ``pos0`` into ``blk_g[:, G_DISP]``."""
    n, d = pos.shape
    nblk = blk_g.shape[0]
    for b in numba.prange(nblk):
        disp = 0.0
        b0, b1 = block_bounds(np.int64(b), n, nblk)
        for i in range(b0, b1):
            s = 0.0
            for a in range(d):
                x = pos[i, a] - pos0[i, a]
                s += x * x
            disp = max(disp, s)
        blk_g[b, G_DISP] = disp


@numba.njit(cache=True)
def _block_max(blk, col):
    m = 0.0
    for b in range(blk.shape[0]):
        m = max(m, blk[b, col])
    return m


@numba.njit(cache=True)
def _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, kick, stats, drift):
    """Phases 1, 2 and (with ``kick``) 3 of a step (see each); reduce the blocks into ``out``
    and the piston's contact force (its grains' forces summed in grain order) and
    acceleration; with ``stats`` the convergence measures as :func:`measure` (the kinetic
    energy summed by blocks: only its finiteness is used). The incoming lists
    (:func:`incoming_lists`) must be those of the current pair list."""
    nbr, gl, nlo, row, inc_start, inc_g, blk_g, top_f = ws[0], ws[1], ws[3], ws[4], ws[6], ws[7], ws[8], ws[9]
    inv_rad = ws[10]
    _incoming_pass(pos, vel, acc, omega, alpha, rad, inv_rad, mass, lateral, pair_ft, pair_ov, fpar, nbr, gl, nlo,
                   inc_start, inc_g)
    _row_pass(pos, vel, acc, omega, alpha, rad, inv_rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, row, inc_start, inc_g, blk_g, top_f, kick, stats,
              drift)
    if kick:
        _deferred_pass(pos, vel, acc, omega, alpha, rad, mass, inertia, pos0, fpar[F_DT], inc_start, inc_g,
                       blk_g, stats, drift)
    n = pos.shape[0]
    nblk = blk_g.shape[0]
    dmax = 0.0
    ncontact = 0
    fpiston = 0.0
    ntop = 0
    kin = 0.0
    for b in range(nblk):
        b0 = block_bounds(b, n, nblk)[0]
        dmax = max(dmax, blk_g[b, G_DMAX])
        ncontact += int(blk_g[b, G_NC])
        nt = int(blk_g[b, G_NTOP])
        for c in range(nt):
            fpiston -= top_f[b0 + c]
        ntop += nt
        kin += blk_g[b, G_KIN]
    piston[P_FCON] = fpiston
    piston[P_A] = piston_acceleration(piston, fpar[F_GAMMA])
    out[O_DMAX] = dmax
    out[O_NTOP] = ntop
    out[O_NCONTACT] = ncontact
    if stats:
        out[O_AMAX] = math.sqrt(_block_max(blk_g, G_AMAX))
        out[O_ALPHAMAX] = math.sqrt(_block_max(blk_g, G_ALMAX))
        out[O_VMAX] = math.sqrt(_block_max(blk_g, G_VMAX))
        out[O_WMAX] = math.sqrt(_block_max(blk_g, G_WMAX))
        if piston[P_MASS] < np.inf:
            out[O_APISTON] = abs(piston[P_A])
            kin += 0.5 * piston[P_MASS] * piston[P_V] * piston[P_V]
        else:
            out[O_APISTON] = 0.0
        out[O_KIN] = kin


@numba.njit(cache=True)
def compute_forces(pos, vel, omega, rad, mass, inertia, lateral, pair_i, pair_j, pair_ft, pair_ov, wall_ft,
                   wall_ov, piston, fpar, ipar, force, torque, out, ws):
    """Total force and torque on every grain (into ``force``, ``torque``), the contact force on
    the piston (``piston[P_FCON]``), largest overlap, top-wall and total contact counts (``out``).

    Also adds the background damping -gamma m v, -gamma I w. Contacts update their
    tangential history with slip = v_rel * fpar[F_DT] (0: evaluated, not advanced).
    """
    prepare_blocks(rad, ws)
    _forces(pos, vel, force, omega, torque, rad, mass, inertia, lateral, pos, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, False, False, False)


@numba.njit(cache=True)
def piston_acceleration(piston, gamma):
    """(contact force up - p A down - gamma M v) / M; zero for a fixed wall (mass inf)."""
    m = piston[P_MASS]
    if not (m < np.inf):
        return 0.0
    return (piston[P_FCON] - piston[P_FEXT]) / m - gamma * piston[P_V]


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


#: ``safety`` at which :func:`stable_dt` would step exactly at the estimated stability limit:
#: dt = (safety / SAFETY_AT_LIMIT) x dt_limit (default safety 0.05: half the limit).
SAFETY_AT_LIMIT = 0.1
#: 1 + m a^2 / I for a sphere turning about its contact point (arm a <= R, I = m (2R)^2 / 10):
#: the tangential spring acts on a mode of mass m / 3.5 (translation plus rotation).
ROTATION_FACTOR = 3.5


@numba.njit(cache=True, inline="always")
def verlet_limit(omega, zeta):
    """Largest stable dt of the engine's velocity Verlet for one damped oscillator
    x'' = -omega^2 x - 2 zeta omega v with the damping on the half-step velocity:
    omega dt < 2 (sqrt(1 + zeta^2) - zeta) (2 at zeta = 0, 0.83 at zeta = 1; the
    amplification matrix of the scheme, tests/test_dem.py)."""
    return 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta) / omega


@numba.njit(cache=True)
def stable_dt(fpar):
    """dt = (safety / SAFETY_AT_LIMIT) x the estimated stability limit of the explicit step.

    The stiffest spring is a wall contact of the largest grain (R12 = R_max, E*12 = 1)
    at the larger of the largest current overlap and the overlap floor (that of a
    contact carrying p d^2), acting on the lightest grain: k_n, omega_n^2 = k_n / m_min.
    Two modes of that contact bound the step (:func:`verlet_limit`):
    - normal: omega_n, damping ratio zeta;
    - tangential (mu > 0): the grain turning about its contact, mode mass m / 3.5
      (m a^2 / I <= 2.5), so omega_t^2 = 3.5 eta omega_n^2 (eta = k_t / k_n) and, since
      c_t = 2 zeta sqrt(m k_t) uses the translational mass (docs/method.md §2), damping ratio
      zeta sqrt(3.5).
    Measured on 40-grain packings (docs/dem.md) the true limit is 0.8-1.0 of this estimate
    for zeta in [0, 1], with and without friction; hence ``safety`` <= 0.06 (params).
    """
    k = C.normal_stiffness(fpar[F_DFLOOR], fpar[F_RMAX], C.effective_young(True))
    omega = math.sqrt(k / fpar[F_MMIN])
    zeta = fpar[F_ZETA]
    limit = verlet_limit(omega, zeta)
    if fpar[F_MU] > 0.0:
        omega_t = omega * math.sqrt(ROTATION_FACTOR * C.stiffness_ratio(fpar[F_POISSON]))
        limit = min(limit, verlet_limit(omega_t, zeta * math.sqrt(ROTATION_FACTOR)))
    return fpar[F_SAFETY] / SAFETY_AT_LIMIT * limit


@numba.njit(cache=True)
def measure(vel, acc, omega, alpha, mass, inertia, rad, piston, gamma, out):
    """Largest accelerations and speeds, kinetic energy (grains + piston) into ``out``."""
    n, d = vel.shape
    r = omega.shape[1]
    amax = 0.0
    almax = 0.0
    vmax = 0.0
    wmax = 0.0
    kin = 0.0
    for i in range(n):
        a2 = 0.0
        v2 = 0.0
        for a in range(d):
            a2 += acc[i, a] * acc[i, a]
            v2 += vel[i, a] * vel[i, a]
        al2 = 0.0
        w2 = 0.0
        for a in range(r):
            al2 += alpha[i, a] * alpha[i, a]
            w2 += omega[i, a] * omega[i, a]
        amax = max(amax, a2)
        almax = max(almax, al2)
        vmax = max(vmax, v2)
        wmax = max(wmax, w2 * rad[i] * rad[i])
        kin += 0.5 * (mass[i] * v2 + inertia[i] * w2)
    out[O_AMAX] = math.sqrt(amax)
    out[O_ALPHAMAX] = math.sqrt(almax)
    out[O_VMAX] = math.sqrt(vmax)
    out[O_WMAX] = math.sqrt(wmax)
    if piston[P_MASS] < np.inf:
        out[O_APISTON] = abs(piston[P_A])
        kin += 0.5 * piston[P_MASS] * piston[P_V] * piston[P_V]
    else:
        out[O_APISTON] = 0.0
    out[O_KIN] = kin


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
    needs more room (``ipar[I_NEEDED]`` pairs, ``ipar[I_WIDTH]`` neighbours per grain;
    the state is between steps), 3 when the
    state blew up (an overlap larger than the largest radius or non-finite motion at a
    check, or non-finite positions before a rebuild): the time step is unstable.
    With ``ipar[I_ADAPTIVE]`` the time step is reset at every check from
    :func:`stable_dt`.

    Two parallel passes per step (:func:`_pair_pass`, :func:`_grain_pass`); the first half
    kick and drift of the next step ride on the grain pass unless that step rebuilds the
    pair list or follows a check (then :func:`_drift_pass`).
    """
    n, d = pos.shape
    blk_g = ws[8]
    prepare_blocks(rad, ws)  # the lists may come from another engine path
    half_skin = 0.5 * fpar[F_SKIN]
    check = ipar[I_CHECK]
    n_steps = ipar[I_NSTEPS]
    # largest squared displacement since the last build (then kept by the drift)
    _displacement_pass(pos, pos0, blk_g)
    disp2 = _block_max(blk_g, G_DISP)
    drifted = False
    for step in range(n_steps):
        dt = fpar[F_DT]
        if not drifted:
            # rebuild when a grain may come within reach of a pair not in the list
            # before the next rebuild check (factor 2: the speed may grow in a step)
            reach = math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt
            if not math.isfinite(reach):  # the state blew up (unstable step): stop before the rebuild
                return 3
            if reach > half_skin:
                np_new = neighbours.rebuild(pos, rad, lateral, piston[P_H], fpar[F_SKIN], pair_i, pair_j,
                                            pair_ft, pair_ov, ipar[I_NPAIRS], ws[0], ws[2], ws[3],
                                            ws[4], ws[1], ws[5])
                if np_new < 0:
                    ipar[I_NEEDED] = ws[5][0]
                    ipar[I_WIDTH] = ws[5][1]
                    return 2
                ipar[I_NPAIRS] = np_new
                ipar[I_REBUILDS] += 1
                incoming_lists(ws[0], ws[3], ws[6], ws[7])
                for i in range(n):  # explicit loops: slice assignment compiles shape-check machinery
                    for a in range(d):
                        pos0[i, a] = pos[i, a]
                disp2 = 0.0
            _drift_pass(pos, vel, acc, omega, alpha, pos0, dt, blk_g)
            fpar[F_VMAX] = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            if piston[P_MASS] < np.inf:
                piston[P_V] += 0.5 * dt * piston[P_A]
                piston[P_H] += dt * piston[P_V]
        is_check = check > 0 and (ipar[I_STEPS] + 1) % check == 0
        # the next step's rebuild test is known now unless dt may change (a check)
        reach = math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt
        drifted = (not is_check and step + 1 < n_steps and math.isfinite(reach)
                   and not (reach > half_skin))
        _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
                pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, True, is_check, drifted)
        if piston[P_MASS] < np.inf:
            piston[P_V] += 0.5 * dt * piston[P_A]
        ipar[I_STEPS] += 1
        if drifted:
            fpar[F_VMAX] = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            if piston[P_MASS] < np.inf:
                piston[P_V] += 0.5 * dt * piston[P_A]
                piston[P_H] += dt * piston[P_V]
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
    return 0


@numba.njit(cache=True)
def stable_dt_at(fpar, dmax):
    """:func:`stable_dt` with the overlap floor raised to the current largest overlap."""
    floor = fpar[F_DFLOOR]
    fpar[F_DFLOOR] = max(floor, dmax)
    dt = stable_dt(fpar)
    fpar[F_DFLOOR] = floor
    return dt
