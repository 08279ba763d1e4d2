"""The per-contact law of the DEM engine: pair and wall contacts, as numba kernels.

Pure functions over float64 arrays (int64 indices); one code path for 2D and
3D (the dimension is read from array shapes) and for frictionless runs (the
rotation arrays then have zero columns), so each kernel compiles once.

Every piece of the contact law is called from :mod:`granwave.contact`; the
geometry follows docs/conventions.md. :func:`contact_force3` is the single
per-contact routine (scalars in and out): the engine's pair loops call it with
velocities and the real Coulomb law; :func:`granwave.dem.forces.frozen_history_forces`
calls its array form :func:`contact_force` with displacements (``dt = 1``), no
unloading rescale and no Coulomb cap. The GPU compiles these same functions for the device
(granwave.gpu.compile).
"""

from __future__ import annotations

import math

import numba

from .. import contact as C
from ..contact_models import _dispatch as CD
from ..contact_models._dispatch import couple_of, dashpot_of, friction_of, law_of  # noqa: F401  (the engines' readers)
from ..geometry import nearest_image
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


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
def contact_force3(nx, ny, nz, delta, r12, root_r12, e12, g12, meff, vx, vy, vz, hx, hy, hz, overlap_old, dt,
                   damping, tangential, rescale, law):
    """Force (fx, fy, fz) on i from one contact (the normal law of ``law``, the tangential law of
    ``tangential`` (Mindlin's spring with Coulomb friction by default), the damping law of
    ``damping``; docs/method.md §2); returns it and the elastic normal force. The single
    per-contact routine (scalar form); the three laws are sub-models of granwave.contact_models,
    reached through its generated dispatchers.

    Three components always (2D: the third is 0, and adding zeros leaves the 2D
    arithmetic unchanged). (nx, ny, nz) unit normal i -> j, ``delta`` > 0 the overlap,
    (vx, vy, vz) the contact-point velocity of j relative to i, (hx, hy, hz) the
    tangential history F_t, ``overlap_old`` the overlap when it was last updated, ``root_r12``
    sqrt(R12) (kept per pair by the engines: a square root less per contact and step).
    Returns (fx, fy, fz, elastic normal force, new history hx, hy, hz). Normal: the law's F_n
    plus the dashpot -c_n v_n (the damping law's coefficient at k_n), total never attractive.
    Tangential (where the tangential law acts: friction > 0): the history carried into the new
    tangent plane (contact.project_tangential3), scaled by the normal law's unloading factor
    where the tangential law says it unloads (its rule ``rescale``: contact.py docstring,
    preparation True, pulses False), then the tangential law's increment with slip = tangential
    velocity * dt (spring and slider); the dashpot c_t v_t (at k_t) is added to the force (not to
    the history) while the contact sticks. ``law``, ``damping``, ``tangential``: the sub-models'
    model tuples (granwave.contact_models).
    """
    fel = CD.law_force(law, delta, root_r12, e12)
    vn = vx * nx + vy * ny + vz * nz
    fn = fel
    if CD.dashpot_acts(damping):
        kn = CD.law_stiffness(law, delta, root_r12, e12)
        # approaching (vn < 0) gives a repulsive viscous force
        fn = C.total_normal_force(fel, -CD.dashpot_coefficient(damping, meff, kn, delta) * vn)
    if CD.friction_acts(tangential):
        tx = vx - vn * nx
        ty = vy - vn * ny
        tz = vz - vn * nz
        # Scalar forms of the law (contact.py): the history stays in registers.
        gx, gy, gz = C.project_tangential3(hx, hy, hz, nx, ny, nz)
        kt = CD.tangential_spring(tangential, CD.law_tangential_stiffness(law, delta, r12, g12), delta, e12)
        # contact.update_tangential3's steps, with the normal law's unloading factor
        if CD.tangential_unloads(tangential, overlap_old, delta, rescale):
            scale = CD.law_unloading_scale(law, overlap_old, delta)
            gx *= scale
            gy *= scale
            gz *= scale
        gx, gy, gz, slid = CD.tangential_increment(tangential, gx, gy, gz, tx * dt, ty * dt, tz * dt, kt, fel)
        ct = 0.0
        if CD.dashpot_acts(damping) and not slid:
            ct = CD.dashpot_coefficient(damping, meff, kt, delta)
        return (-fn * nx + gx + ct * tx, -fn * ny + gy + ct * ty, -fn * nz + gz + ct * tz, fel,
                gx, gy, gz)
    return -fn * nx, -fn * ny, -fn * nz, fel, hx, hy, hz


@numba.njit(cache=True)
def contact_force(n, delta, r12, e12, g12, meff, vrel, ft, overlap_old, dt, damping, tangential, fvec,
                  rescale=True, law=CD.NormalModel(0)):
    """Array form of :func:`contact_force3` (tests, frozen-history forces).

    ``n``, ``vrel``, ``ft``, ``fvec`` have length d = 2 or 3; ``ft`` is updated
    in place, the force on i is written into ``fvec``, the elastic normal force returned.
    ``damping``, ``tangential``, ``law``: the sub-models' model tuples (granwave.contact_models).
    """
    d = n.shape[0]
    three = d == 3
    fx, fy, fz, fel, hx, hy, hz = contact_force3(
        n[0], n[1], n[2] if three else 0.0, delta, r12, math.sqrt(r12), e12, g12, meff,
        vrel[0], vrel[1], vrel[2] if three else 0.0, ft[0], ft[1], ft[2] if three else 0.0,
        overlap_old, dt, damping, tangential, rescale, law)
    ft[0] = hx
    ft[1] = hy
    if three:
        ft[2] = hz
    fvec[0] = fx
    fvec[1] = fy
    if d == 3:
        fvec[2] = fz
    return fel


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
def _contact_velocity(vel, omega, i, j, ai, aj, nx, ny, nz):
    """(vx, vy, vz): velocity of j's surface relative to i's at their contact point, lever arms
    a_i, a_j along the unit normal n (i -> j): v_j - v_i - (a_i w_i + a_j w_j) x n
    (docs/conventions.md; vz = 0 in 2D)."""
    d = vel.shape[1]
    vx = vel[j, 0] - vel[i, 0]
    vy = vel[j, 1] - vel[i, 1]
    vz = vel[j, 2] - vel[i, 2] if d == 3 else 0.0
    if omega.shape[1] > 0:
        wx, wy, wz = _spin(omega, i, ai)
        ux, uy, uz = _spin(omega, j, aj)
        wx += ux
        wy += uy
        wz += uz
        vx -= wy * nz - wz * ny
        vy -= wz * nx - wx * nz
        vz -= wx * ny - wy * nx
    return vx, vy, vz


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
def wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov, i, k, h, vp, e_wall, g_wall, dt, damping,
                 tangential, rescale, law):
    """Grain i against wall k (0 bottom: normal -e_z at 0; 1 top: +e_z at h, moving at vp):
    the pair law (:func:`contact_force3`) on the wall's own history slots (``wall_ft``,
    ``wall_ov``, updated here) with R12 = R_i, the wall moduli and the grain's mass.

    Returns (delta, arm, nx, ny, nz, fx, fy, fz): the force on the grain; delta <= 0 when
    they do not touch (the history is then cleared and the force is zero). One copy for
    the one-thread loop, the parallel row pass and the GPU kernel.
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
            for a in range(wall_ft.shape[1]):  # the tangential history and a rolling one after it
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
    if CD.friction_acts(tangential):
        hx = wall_ft[w, 0]
        hy = wall_ft[w, 1]
        if d == 3:
            hz = wall_ft[w, 2]
    fx, fy, fz, fel, hx, hy, hz = contact_force3(nx, ny, nz, delta, R, math.sqrt(R), e_wall, g_wall, mass[i],
                                                 vx, vy, vz, hx, hy, hz, wall_ov[w], dt, damping, tangential,
                                                 rescale, law)
    if CD.friction_acts(tangential):
        wall_ft[w, 0] = hx
        wall_ft[w, 1] = hy
        if d == 3:
            wall_ft[w, 2] = hz
    wall_ov[w] = delta
    return delta, ai, nx, ny, nz, fx, fy, fz


@numba.njit(cache=True, inline="always")
def couple_history(hist, w, d):
    """The couple sub-model's history of contact slot ``w`` (columns d.. of the history; zeros in
    2D's z)."""
    return hist[w, d], hist[w, d + 1], hist[w, d + 2] if d == 3 else 0.0


@numba.njit(cache=True, inline="always")
def store_couple_history(hist, w, d, hx, hy, hz):
    hist[w, d] = hx
    hist[w, d + 1] = hy
    if d == 3:
        hist[w, d + 2] = hz


@numba.njit(cache=True, inline="always")
def relative_spin(omega, i, j):
    """w_i - w_j as (x, y, z) (j < 0: a wall, at rest; 2D: only z)."""
    wx, wy, wz = _spin(omega, i, 1.0)
    if j >= 0:
        ux, uy, uz = _spin(omega, j, 1.0)
        return wx - ux, wy - uy, wz - uz
    return wx, wy, wz


@numba.njit(cache=True, inline="always")
def pair_couple(omega, pair_ft, q, i, j, nx, ny, nz, r12, fel, dt, couple):
    """The couple (cx, cy, cz) on i of listed pair q = (i, j) (the opposite one on j) of the couple
    sub-model ``couple`` (granwave.contact_models, kind rolling); its history in ``pair_ft[q, d:]``
    updated."""
    d = pair_ft.shape[1] // 2
    rx, ry, rz = relative_spin(omega, i, j)
    hx, hy, hz = couple_history(pair_ft, q, d)
    cx, cy, cz, hx, hy, hz = CD.contact_couple(couple, nx, ny, nz, rx, ry, rz, r12, fel, hx, hy, hz, dt)
    store_couple_history(pair_ft, q, d, hx, hy, hz)
    return cx, cy, cz


@numba.njit(cache=True, inline="always")
def wall_couple(omega, rad, wall_ft, i, k, delta, nx, ny, nz, e_wall, dt, law, couple):
    """The couple on grain i from its touching wall k (R12 = R_i, the wall at rest, F_n the law's
    elastic force at ``delta``); its history in ``wall_ft[2 i + k, d:]`` updated."""
    d = wall_ft.shape[1] // 2
    w = 2 * i + k
    R = rad[i]
    fel = CD.law_force(law, delta, math.sqrt(R), e_wall)
    rx, ry, rz = relative_spin(omega, i, -1)
    hx, hy, hz = couple_history(wall_ft, w, d)
    cx, cy, cz, hx, hy, hz = CD.contact_couple(couple, nx, ny, nz, rx, ry, rz, R, fel, hx, hy, hz, dt)
    store_couple_history(wall_ft, w, d, hx, hy, hz)
    return cx, cy, cz


@numba.njit(cache=True, inline="always")
def torque_with_couple(arm, nx, ny, nz, fx, fy, fz, cx, cy, cz):
    """(arm n) x f + c, the torque of a contact with a rolling couple c, as the 3 components that one
    addition per component puts on the grain (2D: the third, z, is the one used)."""
    return (arm * (ny * fz - nz * fy) + cx, arm * (nz * fx - nx * fz) + cy, arm * (nx * fy - ny * fx) + cz)


@numba.njit(cache=True, inline="always")
def add_torque_with_couple(torque, k, arm, nx, ny, nz, fx, fy, fz, cx, cy, cz):
    """torque[k] += (arm n) x f + c in one addition per component (the engines' order with rolling:
    the same sum whether the torque is added at once or handed to another block first)."""
    tx, ty, tz = torque_with_couple(arm, nx, ny, nz, fx, fy, fz, cx, cy, cz)
    r = torque.shape[1]
    if r == 1:
        torque[k, 0] += tz
    elif r == 3:
        torque[k, 0] += tx
        torque[k, 1] += ty
        torque[k, 2] += tz


@numba.njit(cache=True, inline="always")
def pair_constants3(inv_rad_i, inv_rad_j, mass_i, mass_j):
    """(R12, sqrt(R12), m_eff) of two grains from their 1/R and masses: what the contact law
    needs of a pair that does not change while it is listed."""
    r12 = C.effective_radius(inv_rad_i, inv_rad_j)
    return r12, math.sqrt(r12), C.reduced_mass(mass_i, mass_j, False)


#: columns of the per-pair constants (``ws.pair_c``)
PC_R12, PC_ROOT, PC_MEFF = range(3)
N_PCOL = 3


@numba.njit(cache=True)
def pair_constants(pair_i, pair_j, npairs, rad, mass, pair_c):
    """R12, sqrt(R12) and m_eff of the first ``npairs`` listed pairs into ``pair_c``
    (:func:`pair_constants3`), after each rebuild of the pair list: per step that saves each
    contact two divisions and a square root, which share one execution unit with the
    contact's other seven to ten; the values are the ones the loop computed per step, so the
    bits are the same."""
    for p in range(npairs):
        i = pair_i[p]
        j = pair_j[p]
        pair_c[p, PC_R12], pair_c[p, PC_ROOT], pair_c[p, PC_MEFF] = pair_constants3(
            1.0 / rad[i], 1.0 / rad[j], mass[i], mass[j])


@numba.njit(cache=True, inline="always")
def _pair_law(pos, vel, omega, rad, lateral, pair_ft, pair_ov, p, i, j, dt, damping, tangential, rescale, e_pair,
              g_pair, r12, root_r12, meff, law):
    """Pair p = (i, j) with constants R12, sqrt(R12), m_eff (:func:`pair_constants3`):
    (touching, delta, a_i, a_j, n, force on i, new tangential history), with the arithmetic
    of the one-thread loop (dem/serial.py) so that the bits are its own. Reads the history,
    writes nothing."""
    d = pos.shape[1]
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
    ai = ri - 0.5 * delta
    aj = rj - 0.5 * delta
    vx, vy, vz = _contact_velocity(vel, omega, i, j, ai, aj, nx, ny, nz)
    hx = hy = hz = 0.0
    if CD.friction_acts(tangential):
        hx = pair_ft[p, 0]
        hy = pair_ft[p, 1]
        if d == 3:
            hz = pair_ft[p, 2]
    fx, fy, fz, fel, hx, hy, hz = contact_force3(nx, ny, nz, delta, r12, root_r12, e_pair, g_pair, meff,
                                                 vx, vy, vz, hx, hy, hz, pair_ov[p], dt, damping,
                                                 tangential, rescale, law)
    return True, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz
