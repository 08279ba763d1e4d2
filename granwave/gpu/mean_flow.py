"""The compaction rule 'mean-flow' on the device: the slabs' mean velocities, every step.

The rule (:mod:`granwave.dem.mean_flow`) damps the mass-weighted mean vertical velocity of
horizontal slabs (and, once the settling rule lowers its rate, their mean lateral velocity)
at rates of their own. The CPU sums each slab's momentum and mass over its grains in
increasing grain index, serially. The device does the same sums in the same order, so the
means are the CPU's bit for bit (up to fused multiply-adds on a real GPU) and never depend on
the launch's timing:

1. :func:`slab_bin` (a thread per grain): each grain's slab (the CPU's ``_slab``, compiled
   from its source) and, per slab, the lowest and highest grain index in it (integer atomic
   min and max: their result does not depend on the order of the atomics);
2. :func:`slab_sums` (a thread per slab): the slab's sums over the grains of its index range
   that lie in it, in increasing index, then the means; the index range is reset for the
   next step.

No floating-point atomics. A slab's thread visits every grain between the lowest and the
highest index in it: the preparation's gas is numbered layer by layer from the bottom and a
compaction keeps that order up to local swaps, so the range is about the slab's own grains;
grains numbered in no relation to height (a packing made elsewhere) cost up to N per slab,
with the same result.

The term itself, (gamma - gamma_m) m_i v_s on the vertical force (and the lateral one where
gamma_l differs from gamma), is the CPU's :func:`granwave.dem.mean_flow.add_slab_damping`
compiled for the device (:data:`add_slab_damping`), called for one grain by the force kernel
of :mod:`granwave.gpu.dem` after the grain's background damping, as the CPU adds it.
"""

from __future__ import annotations

from ..dem import kernels as K
from ..dem.mean_flow import M_SLAB, S_LATERAL, S_MASS, S_VZ
from . import load_cuda
from .compile import device_functions
from .neighbours import C_STATUS

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

#: The CPU rule's helpers compiled for the device from their source (the same expressions;
#: :func:`granwave.gpu.compile.device_functions`).
slab_index = device_functions()._slab
lateral_on = device_functions().lateral_on
add_slab_damping = device_functions().add_slab_damping


@cuda.jit
def slab_bin(pos, mflow, slab_of, lo, hi, ctl):
    """Each grain's slab into ``slab_of``; per slab the lowest (``lo``) and highest (``hi``)
    index of its grains (integer atomics; ``lo`` = N and ``hi`` = -1 on entry)."""
    if ctl[C_STATUS] != 0:
        return
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        bin_grain(i, pos, mflow, slab_of, lo, hi)


@cuda.jit(device=True)
def bin_grain(i, pos, mflow, slab_of, lo, hi):
    """Grain i's slab into ``slab_of[i]``, and i into its slab's index range (:func:`slab_bin`)."""
    k = slab_index(pos[i, pos.shape[1] - 1], 1.0 / mflow[M_SLAB], lo.shape[0])
    slab_of[i] = k
    cuda.atomic.min(lo, k, i)
    cuda.atomic.max(hi, k, i)


@cuda.jit
def slab_sums(vel, mass, fpar1, mflow, slab_of, lo, hi, slabs, ctl):
    """Per slab (a thread each): mean vertical velocity, mass and, where the lateral mean flow
    has a rate of its own, mean lateral velocities into ``slabs`` (the rows of
    :func:`granwave.dem.mean_flow.slab_means`), summed over its grains in increasing index;
    then ``lo``, ``hi`` reset for the next step."""
    fpar = fpar1[0]  # the record (granwave.dem.layout), uploaded as a one-element array
    if ctl[C_STATUS] != 0:
        return
    for k in range(cuda.grid(1), lo.shape[0], cuda.gridsize(1)):
        sum_slab(k, vel, mass, fpar, mflow, slab_of, lo, hi, slabs)


@cuda.jit(device=True)
def sum_slab(k, vel, mass, fpar, mflow, slab_of, lo, hi, slabs):
    """Slab k's means into ``slabs`` and its index range reset (:func:`slab_sums`)."""
    n, d = vel.shape
    z = d - 1
    n_lat = z if lateral_on(fpar.gamma, mflow) else 0
    vz = 0.0
    m = 0.0
    u0 = 0.0
    u1 = 0.0
    for i in range(lo[k], hi[k] + 1):
        if slab_of[i] != k:
            continue
        vz += mass[i] * vel[i, z]
        m += mass[i]
        if n_lat > 0:
            u0 += mass[i] * vel[i, 0]
        if n_lat > 1:
            u1 += mass[i] * vel[i, 1]
    if m > 0.0:
        vz /= m
        u0 /= m
        u1 /= m
    slabs[S_VZ, k] = vz
    slabs[S_MASS, k] = m
    for a in range(slabs.shape[0] - S_LATERAL):  # rows the CPU zeroes and leaves when unused
        slabs[S_LATERAL + a, k] = 0.0
    if n_lat > 0:
        slabs[S_LATERAL, k] = u0
    if n_lat > 1:
        slabs[S_LATERAL + 1, k] = u1
    lo[k] = n
    hi[k] = -1


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (slab_bin, slab_sums)
