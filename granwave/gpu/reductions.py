"""The DEM step's reductions on the device (:mod:`granwave.gpu.dem`): fixed shapes, no atomics.

The piston force, contact counts, largest overlap, speed and displacement of a step are reduced
in two stages of fixed shape: :func:`step_partials`, NPART blocks each summing a fixed grid
stride of the grains and pairs then a tree over its threads; :func:`finish`, one block combining
the NPART partial results in a fixed order, then the piston's acceleration and second half kick.
The convergence statistics are reduced by one block (:func:`measure_kernel`). The order of every
sum is therefore fixed (two runs give the same bytes), though not the CPU loop's. The batched
engine (:mod:`granwave.gpu.batch`) calls the same device functions (:func:`_partials`,
:func:`_finish`) per packing.

The kernels write maxima as ``if x > m: m = x`` (Python's max(m, x) exactly): numba 0.68's CUDA
target failed to type the builtin max() of two floats in these kernels (tests/test_gpu_ptx.py).
"""

from __future__ import annotations

import math

import numpy as np

from ..dem.mean_flow import M_GAMMA_M
from . import load_cuda, simulated
from . import neighbours as NB
from .compile import device_functions
from .neighbours import C_NPAIRS, C_STATUS, C_STEPS

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

DF = device_functions()
piston_acceleration = DF.piston_acceleration
grain_measures = DF.grain_measures

#: Threads per block of the reductions (fewer in the CUDA simulator; the order of the sums
#: depends on RBLOCK, fixed within a process).
RBLOCK = 4 if simulated() else 256
#: Blocks of the first reduction stage (a fixed number: the order of the sums is fixed).
NPART = 2 if simulated() else 264

# indices of the per-step reduction (``red``)
R_FPISTON, R_NTOP, R_NCONTACT, R_DMAX, R_VMAX2, R_DISP2, R_VMAX = range(7)
N_RED = 7  # the per-step partials use the first six; finish adds R_VMAX = sqrt(R_VMAX2)
assert (R_DISP2, R_VMAX) == (NB.R_DISP2, NB.R_VMAX)
# indices of the check statistics (``stat``)
S_AMAX2, S_ALMAX2, S_VMAX2, S_WMAX2, S_KIN = range(5)
N_STAT = 5


@cuda.jit(device=True)
def _tree(t, s_sum0, s_sum1, s_sum2, s_max0, s_max1, s_max2):
    """Tree reduction over a block's shared arrays: three sums and three maxima into slot 0."""
    cuda.syncthreads()
    half = RBLOCK // 2
    while half > 0:
        if t < half:
            s_sum0[t] += s_sum0[t + half]
            s_sum1[t] += s_sum1[t + half]
            s_sum2[t] += s_sum2[t + half]
            if s_max0[t + half] > s_max0[t]:
                s_max0[t] = s_max0[t + half]
            if s_max1[t + half] > s_max1[t]:
                s_max1[t] = s_max1[t + half]
            if s_max2[t + half] > s_max2[t]:
                s_max2[t] = s_max2[t + half]
        cuda.syncthreads()
        half //= 2


@cuda.jit(device=True)
def _block_reduce(t, fp, top, cnt, dmax, v2, disp, out):
    """A block's per-thread piston force, top contacts and contacts (summed) and largest
    overlap, |v|^2 and displacement^2 (maxima) combined by :func:`_tree` in its fixed order;
    thread 0 writes them to ``out[R_FPISTON … R_DISP2]`` (a partial's row, or the step's ``red``)."""
    s_fp = cuda.shared.array(RBLOCK, np.float64)
    s_top = cuda.shared.array(RBLOCK, np.float64)
    s_cnt = cuda.shared.array(RBLOCK, np.float64)
    s_dmax = cuda.shared.array(RBLOCK, np.float64)
    s_v2 = cuda.shared.array(RBLOCK, np.float64)
    s_disp = cuda.shared.array(RBLOCK, np.float64)
    s_fp[t] = fp
    s_top[t] = top
    s_cnt[t] = cnt
    s_dmax[t] = dmax
    s_v2[t] = v2
    s_disp[t] = disp
    _tree(t, s_fp, s_top, s_cnt, s_dmax, s_v2, s_disp)
    if t == 0:
        out[R_FPISTON] = s_fp[0]
        out[R_NTOP] = s_top[0]
        out[R_NCONTACT] = s_cnt[0]
        out[R_DMAX] = s_dmax[0]
        out[R_VMAX2] = s_v2[0]
        out[R_DISP2] = s_disp[0]


@cuda.jit
def step_partials(gfp, gtop, gdmax, gcount, gv2, gdisp2, pdelta, ctl, part):
    """NPART blocks: block b's share (a fixed grid stride) of the step's sums and maxima into
    ``part[b]`` (piston force, top contacts, contacts, largest overlap, |v|^2, displacement^2)."""
    if ctl[C_STATUS] != 0:
        return
    _partials(cuda.blockIdx.x, gfp, gtop, gdmax, gcount, gv2, gdisp2, pdelta, ctl[C_NPAIRS], part)


@cuda.jit(device=True)
def _partials(b, gfp, gtop, gdmax, gcount, gv2, gdisp2, pdelta, npairs, part):
    """Block b's share of :func:`step_partials` (the batched engine calls it per packing)."""
    t = cuda.threadIdx.x
    n = gfp.shape[0]
    stride = RBLOCK * NPART
    fp = 0.0
    top = 0.0
    cnt = 0.0
    dmax = 0.0
    v2 = 0.0
    disp = 0.0
    for i in range(b * RBLOCK + t, n, stride):
        fp += gfp[i]
        top += gtop[i]
        cnt += gcount[i]
        if gdmax[i] > dmax:
            dmax = gdmax[i]
        if gv2[i] > v2:
            v2 = gv2[i]
        if gdisp2[i] > disp:
            disp = gdisp2[i]
    for p in range(b * RBLOCK + t, npairs, stride):
        x = pdelta[p]
        if x >= 0.0:
            cnt += 1.0
            if x > dmax:
                dmax = x
    _block_reduce(t, fp, top, cnt, dmax, v2, disp, part[b])


@cuda.jit
def finish(part, piston1, fpar1, mflow, red, ctl):
    """One block: the NPART partial results combined in a fixed order into ``red``, then the
    piston's acceleration (damped at gamma_m under the rule 'mean-flow', non-empty ``mflow``)
    and second half kick; the step counted in ``ctl[C_STEPS]``."""
    if ctl[C_STATUS] != 0:
        return
    _finish(part, piston1[0], fpar1[0], mflow, red, ctl)  # the records, uploaded as one-element arrays


@cuda.jit(device=True)
def _finish(part, piston, fpar, mflow, red, ctl):
    """The block's work in :func:`finish` (the batched engine calls it per packing)."""
    t = cuda.threadIdx.x
    fp = 0.0
    top = 0.0
    cnt = 0.0
    dmax = 0.0
    v2 = 0.0
    disp = 0.0
    for b in range(t, NPART, RBLOCK):
        fp += part[b, R_FPISTON]
        top += part[b, R_NTOP]
        cnt += part[b, R_NCONTACT]
        if part[b, R_DMAX] > dmax:
            dmax = part[b, R_DMAX]
        if part[b, R_VMAX2] > v2:
            v2 = part[b, R_VMAX2]
        if part[b, R_DISP2] > disp:
            disp = part[b, R_DISP2]
    _block_reduce(t, fp, top, cnt, dmax, v2, disp, red)
    if t == 0:
        red[R_VMAX] = math.sqrt(red[R_VMAX2])
        ctl[C_STEPS] += 1
        piston.f_con = red[R_FPISTON]
        gamma_piston = mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar.gamma
        piston.a = piston_acceleration(piston, gamma_piston)
        if piston.mass < math.inf:
            piston.v += 0.5 * fpar.dt * piston.a


@cuda.jit
def measure_kernel(vel, acc, omega, alpha, mass, inertia, rad, stat):
    """One block: largest |a|^2, |alpha|^2, |v|^2, |w|^2 R^2 and the grains' kinetic energy."""
    _measure(cuda.threadIdx.x, vel, acc, omega, alpha, mass, inertia, rad, stat)


@cuda.jit(device=True)
def _measure(t, vel, acc, omega, alpha, mass, inertia, rad, stat):
    """:func:`measure_kernel`'s block (thread t of RBLOCK; the batched engine's
    :func:`granwave.gpu.batch.measure_batch` calls it per packing)."""
    n = vel.shape[0]
    s_a = cuda.shared.array(RBLOCK, np.float64)
    s_al = cuda.shared.array(RBLOCK, np.float64)
    s_v = cuda.shared.array(RBLOCK, np.float64)
    s_w = cuda.shared.array(RBLOCK, np.float64)
    s_k = cuda.shared.array(RBLOCK, np.float64)
    amax = 0.0
    almax = 0.0
    vmax = 0.0
    wmax = 0.0
    kin = 0.0
    for i in range(t, n, RBLOCK):
        a2, al2, v2, w2r2, k = grain_measures(i, vel, acc, omega, alpha, rad, mass, inertia)
        if a2 > amax:
            amax = a2
        if al2 > almax:
            almax = al2
        if v2 > vmax:
            vmax = v2
        if w2r2 > wmax:
            wmax = w2r2
        kin += k
    s_a[t] = amax
    s_al[t] = almax
    s_v[t] = vmax
    s_w[t] = wmax
    s_k[t] = kin
    cuda.syncthreads()
    half = RBLOCK // 2
    while half > 0:
        if t < half:
            if s_a[t + half] > s_a[t]:
                s_a[t] = s_a[t + half]
            if s_al[t + half] > s_al[t]:
                s_al[t] = s_al[t + half]
            if s_v[t + half] > s_v[t]:
                s_v[t] = s_v[t + half]
            if s_w[t + half] > s_w[t]:
                s_w[t] = s_w[t + half]
            s_k[t] += s_k[t + half]
        cuda.syncthreads()
        half //= 2
    if t == 0:
        stat[S_AMAX2] = s_a[0]
        stat[S_ALMAX2] = s_al[0]
        stat[S_VMAX2] = s_v[0]
        stat[S_WMAX2] = s_w[0]
        stat[S_KIN] = s_k[0]
