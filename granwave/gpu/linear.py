"""The time-domain linear propagation on one GPU (velocity Verlet, M u'' = -D u).

:func:`time_domain_signal_gpu` has the arguments, time-step rule, output grid and
attributes of :func:`granwave.linear.propagate.time_domain_signal`; only the stepping runs on
the device. D is stored in CSR (float64 values, int32 column indices) and every step is one
kernel, :func:`verlet_step`, one thread per row, which is velocity Verlet with the next step's
kick and drift fused in:

    a_i = -(D u)_i / m_i;  v_i <- v_i + dt/2 a_i  (the step's end: flushed like the CPU)
    v_i <- v_i + dt/2 a_i;  u'_i = u_i + dt v_i  (the next step's kick and drift, into u')

with u and u' two buffers swapped every step. Each row's sum runs over its CSR entries in
stored order, as on the CPU, and the arithmetic of each row is the CPU kernel's
(:func:`granwave.linear.propagate.verlet_steps`) in the same order: no atomics, so repeated
runs give identical bytes, and the signal agrees with the CPU one to rounding (the CUDA
compiler may fuse multiply-adds). The whole time loop stays on the device; at each output
sample a two-stage reduction (NPART blocks, then one) sums (kinetic, potential, a.M.a,
detector.u) in a fixed order into a device array (and, by the same kernels, g.u and g.v for the
step's error estimate, granwave.linear.step_rule), and only those samples (and requested
snapshots) come back to the host.
"""

from __future__ import annotations

import math
import time as _time
from typing import Callable

import numpy as np

from ..errors import InputError
from ..linear.assemble import asymmetry
from ..linear.propagate import (DEFAULT_SAFETY, MAX_TIME_STEPS, _check_ic, _check_snapshots,
                                carried_attrs, sample_times, stable_time_step)
from ..linear.step_rule import step_error
from ..model import LinearSystem, Signal
from ..resources import check_propagate
from . import load_cuda, simulated

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

#: Threads per block of the step and of the reductions, and blocks of the first reduction stage
#: (fixed numbers: the order of the sums is fixed; small in the simulator, which runs every
#: thread as a Python thread).
BLOCK = 8 if simulated() else 256
RBLOCK = 4 if simulated() else 256
NPART = 2 if simulated() else 264


@cuda.jit
def verlet_step(indptr, indices, data, minv, u, u_next, v, a, v_end, dt, flush, store):
    """One fused velocity-Verlet step of every row (module docstring). On entry ``u`` holds the
    drifted positions of this step and ``v`` the half-step velocities; on exit ``u_next`` and
    ``v`` hold those of the next step; with ``store`` the step's end state (v, a) is written
    to ``v_end``, ``a`` (the positions of the step's end are ``u``)."""
    i = cuda.grid(1)
    if i >= u.shape[0]:
        return
    half = 0.5 * dt
    acc = 0.0
    for k in range(indptr[i], indptr[i + 1]):
        acc += data[k] * u[indices[k]]
    ai = -acc * minv[i]
    vi = v[i] + half * ai
    if abs(vi) < flush:
        vi = 0.0
    if store:
        v_end[i] = vi
        a[i] = ai
    vi += half * ai
    ui = u[i] + dt * vi
    if abs(ui) < flush:
        ui = 0.0
    v[i] = vi
    u_next[i] = ui


@cuda.jit(device=True)
def _tree4(t, s0, s1, s2, s3):
    """Tree sum of a block's four shared arrays into slot 0."""
    cuda.syncthreads()
    half = RBLOCK // 2
    while half > 0:
        if t < half:
            s0[t] += s0[t + half]
            s1[t] += s1[t + half]
            s2[t] += s2[t + half]
            s3[t] += s3[t + half]
        cuda.syncthreads()
        half //= 2


@cuda.jit(device=True)
def _block_sum4(t, x0, x1, x2, x3, out):
    """A block's per-thread four sums combined by :func:`_tree4` in its fixed order; thread 0
    writes them to ``out[0 … 3]`` (a partial's row, or a sample's)."""
    s_kin = cuda.shared.array(RBLOCK, np.float64)
    s_pot = cuda.shared.array(RBLOCK, np.float64)
    s_ama = cuda.shared.array(RBLOCK, np.float64)
    s_f = cuda.shared.array(RBLOCK, np.float64)
    s_kin[t] = x0
    s_pot[t] = x1
    s_ama[t] = x2
    s_f[t] = x3
    _tree4(t, s_kin, s_pot, s_ama, s_f)
    if t == 0:
        out[0] = s_kin[0]
        out[1] = s_pot[0]
        out[2] = s_ama[0]
        out[3] = s_f[0]


@cuda.jit
def sample_partials(u, v, a, m, det, part):
    """NPART blocks: block b's share (fixed grid stride) of (v.M v, -u.M a, a.M a, detector.u)."""
    t = cuda.threadIdx.x
    b = cuda.blockIdx.x
    kin = 0.0
    pot = 0.0
    ama = 0.0
    f = 0.0
    for i in range(b * RBLOCK + t, u.shape[0], RBLOCK * NPART):
        mv = m[i] * v[i]
        ma = m[i] * a[i]
        kin += mv * v[i]
        pot -= u[i] * ma
        ama += a[i] * ma
        f += det[i] * u[i]
    _block_sum4(t, kin, pot, ama, f, part[b])


@cuda.jit
def sample_sums(part, out, k):
    """One block: out[k] = (1/2 v.M v, -1/2 u.M a, a.M a, detector.u) from the partial sums,
    combined in a fixed order."""
    t = cuda.threadIdx.x
    kin = 0.0
    pot = 0.0
    ama = 0.0
    f = 0.0
    for b in range(t, part.shape[0], RBLOCK):
        kin += part[b, 0]
        pot += part[b, 1]
        ama += part[b, 2]
        f += part[b, 3]
    _block_sum4(t, kin, pot, ama, f, out[k])
    if t == 0:
        out[k, 0] *= 0.5
        out[k, 1] *= 0.5


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (verlet_step, sample_partials, sample_sums)


def bytes_per_step(n_rows: int, nnz: int) -> int:
    """Bytes one :func:`verlet_step` must move at least: each CSR entry (8 B value, 4 B index)
    once, and per row its pointer, 1/m, u (read once), v (read and written) and u' (written);
    the gathered u[j] counted once (cached)."""
    return 12 * nnz + n_rows * (8 + 8 + 8 + 16 + 8)


def time_domain_signal_gpu(system: LinearSystem, *, ic: str, t_max: float, dt: float | None = None,
                           samples: int = 2001, safety: float = DEFAULT_SAFETY, snapshots=None,
                           progress: Callable[[str], None] | None = None,
                           progress_interval: float = 10.0) -> Signal:
    """:func:`granwave.linear.propagate.time_domain_signal` with the steps on the GPU."""
    ic = _check_ic(ic)
    check_propagate(system.n_dof, samples, 0 if snapshots is None else np.size(snapshots))
    times = sample_times(t_max, samples)
    h = times[1] - times[0]
    dt_auto, wmax = stable_time_step(system, safety=safety)
    if dt is None:
        dt = dt_auto
    if not (dt > 0 and math.isfinite(dt)):
        raise InputError(f"time step must be positive (got {dt})")
    sub = max(1, int(math.ceil(h / dt * (1 - 1e-12))))
    dt = h / sub
    if sub * (samples - 1) > MAX_TIME_STEPS:
        raise InputError(f"t_max {t_max:g} needs {sub * (samples - 1):.3g} time steps of {dt:.3g}, "
                         f"more than the kernel can count ({MAX_TIME_STEPS:.3g}): use a shorter --t-max")
    if wmax * dt >= 2.0:
        raise InputError(f"time step {dt:.3g} is unstable: omega_max dt = {wmax * dt:.3g} >= 2 "
                         f"(use dt <= {2 / wmax:.3g})")
    D = system.stiffness.tocsr()
    D.sort_indices()
    if D.nnz >= 2**31:
        raise InputError(f"{D.nnz} stiffness entries: more than the GPU kernel's 32-bit indices hold")
    n = system.n_dof
    m = np.ascontiguousarray(system.mass, dtype=np.float64)
    minv = 1.0 / m
    u = np.zeros(n)
    v = np.zeros(n)
    if ic == "A":
        v[:] = system.source_velocity
    else:
        u[:] = system.source_displacement
    a = -(D @ u) * minv
    flush = 1e-100 * max(np.abs(u).max(), dt * np.abs(v).max())
    symmetric = asymmetry(D) < 1e-12
    st = snap_k = snap_u = None
    if snapshots is not None and len(snapshots):
        st = _check_snapshots(snapshots, t_max)
        snap_k = np.rint(st / dt).astype(np.int64)
        snap_u = np.zeros((len(st), n))
        snap_u[snap_k == 0] = u
    sums0 = np.array([0.5 * np.dot(m * v, v), -0.5 * np.dot(u, m * a), np.dot(a, m * a),
                      np.dot(system.detector, u)])
    # the first step's kick and drift (the CPU kernel's first loop), on the host
    half = 0.5 * dt
    vh = v + half * a
    ud = u + dt * vh
    ud[np.abs(ud) < flush] = 0.0
    g_ptr = cuda.to_device(D.indptr.astype(np.int64))
    g_idx = cuda.to_device(D.indices.astype(np.int32))
    g_data = cuda.to_device(np.ascontiguousarray(D.data, dtype=np.float64))
    g_minv, g_m = cuda.to_device(minv), cuda.to_device(m)
    g_det = cuda.to_device(np.ascontiguousarray(system.detector, dtype=np.float64))
    # g = D^T M^-1 detector: F'' = -g.u and F''' = -g.v for the step's error estimate
    # (granwave.linear.step_rule), by the same reduction kernels with g as the detector
    g_vec = D.T @ (np.asarray(system.detector, dtype=np.float64) * minv)
    g_g = cuda.to_device(np.ascontiguousarray(g_vec))
    g_deriv = cuda.device_array((samples, 4)), cuda.device_array((samples, 4))
    bufs = [cuda.to_device(ud), cuda.device_array(n)]
    g_v, g_a, g_vend = cuda.to_device(vh), cuda.to_device(a), cuda.to_device(v)
    g_out = cuda.device_array((samples, 4))
    g_part = cuda.device_array((NPART, 4))
    blocks = max(1, (n + BLOCK - 1) // BLOCK)
    n_steps = sub * (samples - 1)
    snap_steps = set() if snap_k is None else set(int(s) for s in snap_k if s > 0)
    step = 0
    t_wall0 = t_last = _time.perf_counter()
    for k in range(1, samples):
        for s in range(sub):
            store = s == sub - 1
            cur = bufs[step % 2]
            verlet_step[blocks, BLOCK](g_ptr, g_idx, g_data, g_minv, cur, bufs[(step + 1) % 2], g_v, g_a,
                                       g_vend, dt, flush, store)
            step += 1
            if step in snap_steps:
                snap_u[snap_k == step] = cur.copy_to_host()
            if store:
                sample_partials[NPART, RBLOCK](cur, g_vend, g_a, g_m, g_det, g_part)
                sample_sums[1, RBLOCK](g_part, g_out, k)
                for x, out_x in ((cur, g_deriv[0]), (g_vend, g_deriv[1])):  # g.u, then g.v
                    sample_partials[NPART, RBLOCK](x, g_vend, g_a, g_m, g_g, g_part)
                    sample_sums[1, RBLOCK](g_part, out_x, k)
        if progress is not None:
            now = _time.perf_counter()
            if now - t_last >= progress_interval:
                cuda.synchronize()
                t_last = now = _time.perf_counter()
                rate = step / (now - t_wall0)
                progress(f"propagate (gpu): t = {k * h:.4g} / {t_max:.4g}, step {step}/{n_steps}, "
                         f"{rate:.0f} steps/s, ~{(n_steps - step) / rate:.0f} s left")
    sums = g_out.copy_to_host()
    sums[0] = sums0
    force = sums[:, 3].copy()
    curvature, jerk = -g_deriv[0].copy_to_host()[:, 3], -g_deriv[1].copy_to_host()[:, 3]
    curvature[0], jerk[0] = -np.dot(g_vec, u), -np.dot(g_vec, v)
    e = sums[:, 0] + sums[:, 1]
    eh = e - dt * dt / 8.0 * sums[:, 2]
    e0, eh0 = e[0], eh[0]
    dev = float(np.max(np.abs(e - e0))) if symmetric else 0.0
    devh = float(np.max(np.abs(eh - eh0))) if symmetric else 0.0
    attrs = carried_attrs(system.attrs)
    attrs.update(ic=ic, method="time", height=system.height, t_max=float(t_max), samples=int(samples),
                 dt=float(dt), integrator="velocity Verlet", safety=float(safety),
                 omega_max=float(wmax), omega_max_dt=float(wmax * dt), n_steps=int(n_steps),
                 step_error_estimate=step_error(times, force, curvature, jerk, dt, ic),
                 energy_initial=float(e0),
                 energy_max_rel_deviation=float(dev / e0) if symmetric and e0 > 0 else float("nan"),
                 modified_energy_max_rel_deviation=(float(devh / eh0) if symmetric and eh0 > 0
                                                    else float("nan")),
                 wall_time=float(_time.perf_counter() - t_wall0), device="gpu")
    sig = Signal(time=times, force=force, attrs=attrs)
    if st is not None:
        sig.snapshot_time = snap_k * dt
        sig.snapshot_displacement = snap_u
        sig.dof_grain, sig.dof_axis = system.dof_grain, system.dof_axis
    return sig
