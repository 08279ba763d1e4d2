"""Numba kernels of the DEM engine: per-contact law application and force loops.

Pure functions over float64 arrays (int64 indices); one code path for 2D and
3D (the dimension is read from array shapes) and for frictionless runs (the
rotation arrays then have zero columns), so each kernel compiles once.

Every piece of the contact law is called from :mod:`granwave.contact`; the
geometry follows docs/conventions.md. :func:`contact_force` is the single
per-contact routine: the engine calls it with velocities and the real Coulomb
law, :func:`granwave.dem.forces.frozen_history_forces` with displacements
(``dt = 1``), no unloading rescale and no Coulomb cap.

Layout of the small parameter arrays (indices below):
``fpar``: dt, zeta, mu, poisson, background damping rate, skin, dt safety,
overlap floor for the time step, acceleration tol, velocity tol, largest
radius, smallest mass, last max speed; ``piston``: height, velocity,
acceleration, mass (inf = fixed wall), downward force p*A, contact force.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from ..geometry import nearest_image
from . import neighbours

# The two vector routines of contact.py, compiled inline into the force loops
# (the same Python code as contact.py's; only the compilation differs).
project_tangential = numba.njit(cache=True, inline="always")(C.project_tangential.py_func)
update_tangential = numba.njit(cache=True, inline="always")(C.update_tangential.py_func)

# fpar indices
F_DT, F_ZETA, F_MU, F_POISSON, F_GAMMA, F_SKIN, F_SAFETY, F_DFLOOR, F_TOLA, F_TOLV, F_RMAX, F_MMIN, \
    F_VMAX = range(13)
N_FPAR = 13
# piston indices
P_H, P_V, P_A, P_MASS, P_FEXT, P_FCON = range(6)
N_PISTON = 6
# ipar indices
I_NPAIRS, I_NSTEPS, I_STEPS, I_CHECK, I_ADAPTIVE, I_REBUILDS, I_NEEDED = range(7)
N_IPAR = 7
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
def contact_force(n, delta, r12, e12, g12, meff, vrel, ft, overlap_old, dt, zeta, mu, slip, fvec):
    """Force on i from one contact (Hertz-Mindlin, SPEC §2), written into ``fvec``.

    ``n`` unit normal i -> j, ``delta`` > 0 the overlap, ``vrel`` the contact-point
    velocity of j relative to i, ``ft`` the tangential history (updated in place),
    ``overlap_old`` the overlap when ``ft`` was last updated. Normal: Hertz plus
    viscous c_n = 2 zeta sqrt(m_eff k_n) on the normal velocity, total never
    attractive. Tangential (mu > 0): ``ft`` carried into the new tangent plane,
    then contact.update_tangential with slip = tangential vrel * dt; a viscous
    part c_t v_t is added to the force (not to the history) while the contact
    sticks. Returns the elastic normal force.
    """
    d = n.shape[0]
    fel = C.normal_force(delta, r12, e12)
    vn = 0.0
    for a in range(d):
        vn += vrel[a] * n[a]
    fn = fel
    if zeta > 0.0:
        kn = C.normal_stiffness(delta, r12, e12)
        # approaching (vn < 0) gives a repulsive viscous force
        fn = C.total_normal_force(fel, -C.damping_coefficient(zeta, meff, kn) * vn)
    if mu > 0.0:
        project_tangential(ft, n)
        kt = C.tangential_stiffness(delta, r12, g12)
        for a in range(d):
            slip[a] = (vrel[a] - vn * n[a]) * dt
        slid = update_tangential(ft, slip, overlap_old, delta, kt, fel, mu)
        ct = 0.0
        if zeta > 0.0 and not slid:
            ct = C.damping_coefficient(zeta, meff, kt)
        for a in range(d):
            fvec[a] = -fn * n[a] + ft[a] + ct * (vrel[a] - vn * n[a])
    else:
        for a in range(d):
            fvec[a] = -fn * n[a]
    return fel


@numba.njit(cache=True)
def compute_forces(pos, vel, omega, rad, mass, inertia, lateral, pair_i, pair_j, npairs, pair_ft,
                   pair_ov, wall_ft, wall_ov, piston, fpar, force, torque, out):
    """Total force and torque on every grain and the contact force on the piston.

    Contacts update their tangential history with slip = v_rel * fpar[F_DT]
    (velocities at the half step of velocity Verlet, i.e. exactly the
    displacement of the step). Also adds the background damping -gamma m v,
    -gamma I w. Statistics into ``out``: largest overlap, number of
    top-wall contacts and of contacts.
    """
    n_grains, d = pos.shape
    r = omega.shape[1]
    dt = fpar[F_DT]
    zeta = fpar[F_ZETA]
    mu = fpar[F_MU]
    poisson = fpar[F_POISSON]
    gamma = fpar[F_GAMMA]
    e_pair = C.effective_young(False)
    e_wall = C.effective_young(True)
    g_pair = C.effective_shear(poisson, False)
    g_wall = C.effective_shear(poisson, True)
    h = piston[P_H]
    vp = piston[P_V]
    # 3-vectors even in 2D (third component 0: same arithmetic, fixed-length loops
    # that the compiler unrolls); ftv: scratch copy of a history row (no views)
    nv = np.zeros(3)
    vrel = np.zeros(3)
    slip = np.zeros(3)
    fvec = np.zeros(3)
    dx = np.zeros(3)
    ftv = np.zeros(3)
    force[:, :] = 0.0
    torque[:, :] = 0.0
    dmax = 0.0
    ncontact = 0
    for p in range(npairs):
        i = pair_i[p]
        j = pair_j[p]
        r2 = 0.0
        for a in range(d):
            x = pos[j, a] - pos[i, a]
            if a < d - 1:
                x = nearest_image(x, lateral[a])
            dx[a] = x
            r2 += x * x
        rs = rad[i] + rad[j]
        if r2 >= rs * rs:
            if pair_ov[p] != 0.0:  # the contact opened: its history is destroyed
                pair_ov[p] = 0.0
                for a in range(d):
                    pair_ft[p, a] = 0.0
            continue
        dist = math.sqrt(r2)
        delta = rs - dist
        for a in range(d):
            nv[a] = dx[a] / dist
            vrel[a] = vel[j, a] - vel[i, a]
        ai = rad[i] - 0.5 * delta
        aj = rad[j] - 0.5 * delta
        if r > 0:
            rotation_velocity(vrel, nv, omega, i, j, ai, aj)
        r12 = C.effective_radius(1.0 / rad[i], 1.0 / rad[j])
        meff = C.reduced_mass(mass[i], mass[j], False)
        if mu > 0.0:
            for a in range(d):
                ftv[a] = pair_ft[p, a]
        contact_force(nv, delta, r12, e_pair, g_pair, meff, vrel, ftv, pair_ov[p], dt, zeta, mu, slip, fvec)
        if mu > 0.0:
            for a in range(d):
                pair_ft[p, a] = ftv[a]
        pair_ov[p] = delta
        for a in range(d):
            force[i, a] += fvec[a]
            force[j, a] -= fvec[a]
        if r > 0:
            add_torque(torque, i, ai, nv, fvec)
            add_torque(torque, j, aj, nv, fvec)
        if delta > dmax:
            dmax = delta
        ncontact += 1
    # walls: k = 0 bottom (normal -e_z, at 0), k = 1 top (normal +e_z, at h, velocity vp)
    fpiston = 0.0
    ntop = 0
    for i in range(n_grains):
        y = pos[i, d - 1]
        R = rad[i]
        for k in range(2):
            delta = R - y if k == 0 else R - (h - y)
            w = 2 * i + k
            if delta <= 0.0:
                if wall_ov[w] != 0.0:
                    wall_ov[w] = 0.0
                    for a in range(d):
                        wall_ft[w, a] = 0.0
                continue
            for a in range(d):
                nv[a] = 0.0
                vrel[a] = -vel[i, a]
            nv[d - 1] = -1.0 if k == 0 else 1.0
            if k == 1:
                vrel[d - 1] += vp
            ai = R - delta
            if r > 0:
                rotation_velocity(vrel, nv, omega, i, -1, ai, 0.0)
            if mu > 0.0:
                for a in range(d):
                    ftv[a] = wall_ft[w, a]
            contact_force(nv, delta, R, e_wall, g_wall, mass[i], vrel, ftv, wall_ov[w], dt, zeta, mu, slip,
                          fvec)
            if mu > 0.0:
                for a in range(d):
                    wall_ft[w, a] = ftv[a]
            wall_ov[w] = delta
            for a in range(d):
                force[i, a] += fvec[a]
            if r > 0:
                add_torque(torque, i, ai, nv, fvec)
            if k == 1:
                fpiston -= fvec[d - 1]
                ntop += 1
            if delta > dmax:
                dmax = delta
            ncontact += 1
    if gamma > 0.0:
        for i in range(n_grains):
            for a in range(d):
                force[i, a] -= gamma * mass[i] * vel[i, a]
            for a in range(r):
                torque[i, a] -= gamma * inertia[i] * omega[i, a]
    piston[P_FCON] = fpiston
    out[O_DMAX] = dmax
    out[O_NTOP] = ntop
    out[O_NCONTACT] = ncontact


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


@numba.njit(cache=True)
def stable_dt(fpar):
    """dt = safety * 2 pi sqrt(m_min / k_max), the stiffest possible normal spring.

    k_max = contact.normal_stiffness at the larger of the largest current
    overlap and the overlap floor (that of a contact carrying p d^2), for a
    wall contact of the largest grain (R12 = R_max, E*12 = 1: the stiffest
    kind). 2 pi sqrt(m/k) is that spring's oscillation period.
    """
    k = C.normal_stiffness(fpar[F_DFLOOR], fpar[F_RMAX], C.effective_young(True))
    return fpar[F_SAFETY] * 2.0 * math.pi * math.sqrt(fpar[F_MMIN] / k)


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


@numba.njit(cache=True)
def run_chunk(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out):
    """Advance ``ipar[I_NSTEPS]`` velocity-Verlet steps (or stop early).

    State on entry and exit: positions, velocities and accelerations at the same
    time (``acc``/``alpha`` valid). Returns 0 when all steps ran, 1 when the
    convergence candidate test passed at a check (every ``ipar[I_CHECK]``
    steps: piston touching grains, every |a|, |alpha| and |a_piston| below
    F_TOLA, every |v|, |w| R and |v_piston| below F_TOLV), 2 when the pair list
    needs more room (``ipar[I_NEEDED]`` pairs; the state is between steps).
    With ``ipar[I_ADAPTIVE]`` the time step is reset at every check from
    :func:`stable_dt`.
    """
    n, d = pos.shape
    r = omega.shape[1]
    gamma = fpar[F_GAMMA]
    half_skin = 0.5 * fpar[F_SKIN]
    check = ipar[I_CHECK]
    disp2 = 0.0  # largest squared displacement since the last build (kept by the drift loop)
    for i in range(n):
        s = 0.0
        for a in range(d):
            x = pos[i, a] - pos0[i, a]
            s += x * x
        disp2 = max(disp2, s)
    for step in range(ipar[I_NSTEPS]):
        dt = fpar[F_DT]
        # rebuild when a grain may come within reach of a pair not in the list
        # before the next rebuild check (factor 2: the speed may grow in a step)
        if math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt > half_skin:
            np_new = neighbours.rebuild(pos, rad, lateral, piston[P_H], fpar[F_SKIN], pair_i, pair_j,
                                        pair_ft, pair_ov, ipar[I_NPAIRS])
            if np_new < 0:
                ipar[I_NEEDED] = -np_new
                return 2
            ipar[I_NPAIRS] = np_new
            ipar[I_REBUILDS] += 1
            pos0[:, :] = pos
            disp2 = 0.0
        # half kick, drift
        vmax2 = 0.0
        disp2 = 0.0
        for i in range(n):
            v2 = 0.0
            s = 0.0
            for a in range(d):
                vel[i, a] += 0.5 * dt * acc[i, a]
                pos[i, a] += dt * vel[i, a]
                v2 += vel[i, a] * vel[i, a]
                x = pos[i, a] - pos0[i, a]
                s += x * x
            vmax2 = max(vmax2, v2)
            disp2 = max(disp2, s)
            for a in range(r):
                omega[i, a] += 0.5 * dt * alpha[i, a]
        fpar[F_VMAX] = math.sqrt(vmax2)
        if piston[P_MASS] < np.inf:
            piston[P_V] += 0.5 * dt * piston[P_A]
            piston[P_H] += dt * piston[P_V]
        compute_forces(pos, vel, omega, rad, mass, inertia, lateral, pair_i, pair_j, ipar[I_NPAIRS],
                       pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, acc, alpha, out)
        to_accelerations(acc, alpha, mass, inertia)
        piston[P_A] = piston_acceleration(piston, gamma)
        # second half kick
        for i in range(n):
            for a in range(d):
                vel[i, a] += 0.5 * dt * acc[i, a]
            for a in range(r):
                omega[i, a] += 0.5 * dt * alpha[i, a]
        if piston[P_MASS] < np.inf:
            piston[P_V] += 0.5 * dt * piston[P_A]
        ipar[I_STEPS] += 1
        if check > 0 and ipar[I_STEPS] % check == 0:
            measure(vel, acc, omega, alpha, mass, inertia, rad, piston, gamma, out)
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
