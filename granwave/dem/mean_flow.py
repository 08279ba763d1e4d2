"""Damping of the mean vertical flow apart from the fluctuations (compaction 'mean-flow').

The background damping of the preparation is a force -gamma m v on every grain. With the
'mean-flow' rule the velocity is split into the mean vertical flow of horizontal slabs
and the fluctuation about it: v_s, the mass-weighted mean vertical velocity of the grains
whose centre lies in slab s = floor(z / slab) (slabs of thickness ``slab`` from the
bottom wall, the last one open upwards), is damped at the rate gamma_m and the rest at
gamma. The force on grain i in slab s is

    -gamma m_i v_i + (gamma - gamma_m) m_i v_s e_z,

so the slab's momentum P_s = sum m_i v_i,z feels -gamma_m P_s and every velocity field
whose slab means vanish feels -gamma m v. The slabs' mean lateral flow (the column's
shear) has a rate gamma_l of its own, the same way: the force on grain i gets
(gamma - gamma_l) m_i u_s in each lateral direction, u_s the slab's mass-weighted mean
lateral velocity. The compaction keeps gamma_l = gamma (the term is then not added at all:
the bits of the rule without it); critical settling (:mod:`granwave.dem.settling`)
lowers it with gamma_m once the plug has arrived. Computed every step from the same (half-step)
velocities as the damping itself, in grain order (deterministic), by the one-thread loop
(:func:`granwave.dem.serial._force_loop`) and by one thread at the start of the parallel
engine's second pass (:func:`granwave.dem.kernels._slab_job`; each block adds it to its
grains once they are ready): the same bits. Each grain's term is added after its background
damping (:func:`add_slab_damping`, the same function in every engine).
"""

from __future__ import annotations

import numba
import numpy as np

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

#: Layout of the rule's parameters ``mflow`` (a float array; empty: rule off): the rates of the
#: mean vertical and the mean lateral flow, the slab thickness.
M_GAMMA_M, M_SLAB, M_GAMMA_L = 0, 1, 2
N_MFLOW = 3
#: Rows of the slabs' work array: mean vertical velocity, mass, then the mean lateral velocities
S_VZ, S_MASS, S_LATERAL = 0, 1, 2


@numba.njit(cache=True, _nrt=False)
def slab_means(pos, vel, mass, gamma, mflow, slabs):
    """The slabs' mean vertical velocities (row S_VZ of ``slabs``), masses (row S_MASS) and, where
    the lateral mean flow has a rate of its own (:func:`lateral_on`), mean lateral velocities
    (rows S_LATERAL + a), summed in grain order; grains above the last slab count in it, grains
    below 0 in the first. ``gamma``: the background damping rate."""
    n, d = pos.shape
    z = d - 1
    n_lat = z if lateral_on(gamma, mflow) else 0  # only where used: a serial pass every step
    inv_slab = 1.0 / mflow[M_SLAB]
    ns = slabs.shape[1]
    for row in range(slabs.shape[0]):
        for k in range(ns):
            slabs[row, k] = 0.0
    # Consecutive grains mostly share a slab (the gas is numbered layer by layer): a slab's sums
    # are carried in registers over such a run and stored when the slab changes. Each slab still
    # adds its grains' terms in grain order (the same bits); a memory chain through slabs[., k]
    # made the pass latency-bound, about twice as slow.
    k_run = -1
    vz = m = u0 = u1 = 0.0
    for i in range(n):
        k = _slab(pos[i, z], inv_slab, ns)
        if k != k_run:
            if k_run >= 0:
                _store_run(slabs, k_run, n_lat, vz, m, u0, u1)
            k_run = k
            vz = slabs[S_VZ, k]
            m = slabs[S_MASS, k]
            if n_lat > 0:
                u0 = slabs[S_LATERAL, k]
            if n_lat > 1:
                u1 = slabs[S_LATERAL + 1, k]
        vz += mass[i] * vel[i, z]
        m += mass[i]
        if n_lat > 0:
            u0 += mass[i] * vel[i, 0]
        if n_lat > 1:
            u1 += mass[i] * vel[i, 1]
    if k_run >= 0:
        _store_run(slabs, k_run, n_lat, vz, m, u0, u1)
    for k in range(ns):
        if slabs[S_MASS, k] > 0.0:
            slabs[S_VZ, k] /= slabs[S_MASS, k]
            for a in range(n_lat):
                slabs[S_LATERAL + a, k] /= slabs[S_MASS, k]


@numba.njit(cache=True, inline="always")
def _store_run(slabs, k, n_lat, vz, m, u0, u1):
    """Store the running sums of slab k (:func:`slab_means`)."""
    slabs[S_VZ, k] = vz
    slabs[S_MASS, k] = m
    if n_lat > 0:
        slabs[S_LATERAL, k] = u0
    if n_lat > 1:
        slabs[S_LATERAL + 1, k] = u1


@numba.njit(cache=True, inline="always")
def add_slab_damping(lo, hi, pos, mass, gamma, mflow, slabs, force):
    """Grains lo..hi-1: force[i, z] += (gamma - gamma_m) m_i v_s and, where gamma_l differs from
    gamma, force[i, a] += (gamma - gamma_l) m_i u_s,a for each lateral a (slab means from
    :func:`slab_means`); the one-thread loop applies it to all grains, the parallel engine per
    block, the GPU per grain."""
    d = pos.shape[1]
    z = d - 1
    inv_slab = 1.0 / mflow[M_SLAB]
    extra = gamma - mflow[M_GAMMA_M]
    extra_l = gamma - mflow[M_GAMMA_L]
    # the compaction (gamma_l = gamma): not added, so its bits are those of the rule without it
    n_lat = z if lateral_on(gamma, mflow) else 0
    ns = slabs.shape[1]
    for i in range(np.uint64(lo), np.uint64(hi)):  # unsigned: kernels.grains
        k = _slab(pos[i, z], inv_slab, ns)
        force[i, z] += extra * mass[i] * slabs[S_VZ, k]
        for a in range(n_lat):
            force[i, a] += extra_l * mass[i] * slabs[S_LATERAL + a, k]


@numba.njit(cache=True, inline="always")
def lateral_on(gamma, mflow):
    """Whether the slabs' mean lateral flow has a rate of its own (gamma_l != gamma): only then
    are its means summed and its term added."""
    return gamma - mflow[M_GAMMA_L] != 0.0


@numba.njit(cache=True, inline="always")
def _slab(height, inv_slab, ns):
    x = height * inv_slab
    if not x > 0.0:  # below the bottom wall (or not finite): the first slab
        return 0
    if x >= ns - 1:
        return ns - 1
    return int(x)


def slab_count(height: float, slab: float) -> int:
    """Slabs covering [0, height] with room above (the piston may rise a little)."""
    return int(height / slab) + 2
