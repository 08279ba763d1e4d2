"""The per-grain part of a DEM step, written once for the three engines.

After its pair forces, a grain gets, in this order, its bottom and top wall contacts
(:func:`grain_walls`), then the background damping -gamma m v, -gamma I w (:func:`grain_damping`)
and (compaction rule 'mean-flow') its slab's mean-flow term
(:func:`granwave.dem.mean_flow.add_slab_damping`). The convergence measures of a grain (|a|^2, |alpha|^2,
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

from .contact_law import _add_torque3, add_torque_with_couple, wall_contact, wall_couple
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True, inline="always")
def grain_walls(i, pos, vel, omega, rad, mass, wall_ft, wall_ov, h, vp, e_wall, g_wall, dt, damping, tangential,
                rescale, law, couple, force, torque, dmax, count):
    """Add grain i's wall contacts to ``force[i]``, ``torque[i]`` (after its pair terms): k = 0
    bottom, normal -e_z at 0; k = 1 top, normal +e_z at height ``h``, moving at ``vp``
    (:func:`granwave.dem.contact_law.wall_contact`, with the rolling sub-model ``couple``'s couple).
    The CPU engines call it for the grains of the wall list only
    (:func:`granwave.dem.workspace.wall_list`: no other can touch a wall), the GPU for every grain.

    ``dmax``, ``count``: the caller's largest overlap and contact count so far. Returns (top,
    ntop, dmax, count): the upward force of the top contact on the grain (0 without one; the
    piston feels -top), 1 if it touches the top wall, else 0, and the updated largest overlap
    and count."""
    d = pos.shape[1]
    r = omega.shape[1]
    top = 0.0
    ntop = 0
    for k in range(2):
        delta, ai, nx, ny, nz, fx, fy, fz = wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov, i, k, h, vp,
                                                         e_wall, g_wall, dt, damping, tangential, rescale, law)
        if delta <= 0.0:
            continue
        force[i, 0] += fx
        force[i, 1] += fy
        if d == 3:
            force[i, 2] += fz
        if r > 0:
            if couple.code != 0:
                cx, cy, cz = wall_couple(omega, rad, wall_ft, i, k, delta, nx, ny, nz, e_wall, dt, law, couple)
                add_torque_with_couple(torque, i, ai, nx, ny, nz, fx, fy, fz, cx, cy, cz)
            else:
                _add_torque3(torque, i, ai, nx, ny, nz, fx, fy, fz)
        if k == 1:
            top = fz if d == 3 else fy
            ntop = 1
        if delta > dmax:
            dmax = delta
        count += 1
    return top, ntop, dmax, count


@numba.njit(cache=True, inline="always")
def grain_damping(i, vel, omega, mass, inertia, gamma, force, torque):
    """Add grain i's background damping -gamma m v, -gamma I w (``gamma`` > 0: the callers skip
    it otherwise), after its wall contacts. The rule 'mean-flow''s slab term follows it:
    :func:`granwave.dem.mean_flow.add_slab_damping`, shared by the engines too."""
    for a in range(vel.shape[1]):
        force[i, a] -= gamma * mass[i] * vel[i, a]
    for a in range(omega.shape[1]):
        torque[i, a] -= gamma * inertia[i] * omega[i, a]


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
