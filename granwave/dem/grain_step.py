"""The per-grain part of a DEM step, written once for the three engines.

After its pair forces, a grain gets, in this order, its bottom and top wall contacts, the
background damping -gamma m v, -gamma I w and (compaction rule 'mean-flow') its slab's
mean-flow term: :func:`grain_terms`. The convergence measures of a grain (|a|^2, |alpha|^2,
|v|^2, |w|^2 R^2, kinetic energy) are :func:`grain_measures`. The one-thread loop
(:func:`granwave.dem.serial._force_loop`), the parallel row pass
(:func:`granwave.dem.passes._row_block`, :func:`granwave.dem.passes.measure`,
:func:`granwave.dem.passes._finish`) and the GPU kernels (:mod:`granwave.gpu.dem`, which
compiles these same functions for the device, :mod:`granwave.gpu.compile`) call them, so each
grain's force and measures are the same operations in the same order on every engine; only
the reductions over grains (sums and maxima) differ in where they are taken.
"""

from __future__ import annotations

import numba

from .contact_law import _add_torque3, add_torque_with_couple, wall_contact, wall_rolling
from .mean_flow import add_slab_damping
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True, inline="always")
def grain_terms(i, near_wall, pos, vel, omega, rad, mass, inertia, wall_ft, wall_ov, h, vp, e_wall, g_wall, dt,
                zeta, mu, gamma, rescale, law, roll, mflow, slabs, force, torque, dmax, count):
    """Add to ``force[i]``, ``torque[i]`` (after grain i's pair terms): its wall contacts
    (``near_wall``: whether it may touch one, :func:`granwave.dem.workspace.wall_list`; k = 0
    bottom, normal -e_z at 0; k = 1 top, normal +e_z at height ``h``, moving at ``vp``;
    :func:`granwave.dem.contact_law.wall_contact`, with the rolling sub-model ``roll``'s couple),
    then with ``gamma`` > 0 the background damping and, with a non-empty ``mflow``, the slab
    term of the rule 'mean-flow' (the slab means in ``slabs`` must be this step's,
    :func:`granwave.dem.mean_flow.slab_means`).

    ``dmax``, ``count``: the caller's largest overlap and contact count so far. Returns (top,
    ntop, dmax, count): the upward force of the top contact on the grain (0 without one; the
    piston feels -top), 1 if it touches the top wall, else 0, and the updated largest overlap
    and count."""
    d = pos.shape[1]
    r = omega.shape[1]
    top = 0.0
    ntop = 0
    if near_wall:
        for k in range(2):
            delta, ai, nx, ny, nz, fx, fy, fz = wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov, i, k, h,
                                                             vp, e_wall, g_wall, dt, zeta, mu, rescale, law)
            if delta <= 0.0:
                continue
            force[i, 0] += fx
            force[i, 1] += fy
            if d == 3:
                force[i, 2] += fz
            if r > 0:
                if roll.kind != 0:
                    cx, cy, cz = wall_rolling(omega, rad, wall_ft, i, k, delta, nx, ny, nz, e_wall, dt, law, roll)
                    add_torque_with_couple(torque, i, ai, nx, ny, nz, fx, fy, fz, cx, cy, cz)
                else:
                    _add_torque3(torque, i, ai, nx, ny, nz, fx, fy, fz)
            if k == 1:
                top = fz if d == 3 else fy
                ntop = 1
            if delta > dmax:
                dmax = delta
            count += 1
    if gamma > 0.0:
        for a in range(d):
            force[i, a] -= gamma * mass[i] * vel[i, a]
        for a in range(r):
            torque[i, a] -= gamma * inertia[i] * omega[i, a]
        if mflow.shape[0] > 0:
            add_slab_damping(i, i + 1, pos, mass, gamma, mflow, slabs, force)
    return top, ntop, dmax, count


@numba.njit(cache=True, inline="always")
def grain_measures(i, vel, acc, omega, alpha, rad, mass, inertia):
    """Grain i's convergence measures: (|a|^2, |alpha|^2, |v|^2, |w|^2 R^2, kinetic energy
    (m v^2 + I w^2) / 2); the engines take the maxima and the sum over grains."""
    d = vel.shape[1]
    r = omega.shape[1]
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
    return a2, al2, v2, w2 * rad[i] * rad[i], 0.5 * (mass[i] * v2 + inertia[i] * w2)
