"""Pulse propagation in the linear model and the detector signal (docs/method.md §8).

Two methods that must agree:

- :func:`modal_signal`: F_sig(t) = sum_n a_n b_n sin(omega_n t) (IC A) or
  cos (IC B) from a :class:`~granwave.model.Modes` (docs/conventions.md
  "Modal solution"); vectorized over modes, chunked over time so memory
  stays bounded (about ``chunk_elements`` doubles at a time).
- :func:`time_domain_signal`: velocity Verlet (symplectic, second order)
  integration of M u'' = -D u with the sparse D, no eigendecomposition.
  Time step rule: dt <= ``safety`` x 2/omega_max, omega_max^2 = 1.02 x a loose
  Lanczos estimate (tol 1e-2, an upper bound) on M^-1/2 D M^-1/2
  (:func:`granwave.linear.assemble.omega2_max`), default
  safety 0.1 (omega_max dt <= 0.2: well inside the stability limit 2, and a
  phase error (omega dt)^2/24 <= 0.17% even for the highest mode). The
  step is then shortened so that an integer number of steps fits between
  two output samples; the output grid is the same as the modal one
  (``samples`` equally spaced times from 0 to t_max).

Energy: velocity Verlet on a linear system conserves exactly the modified
energy E_h = 1/2 v.M v + 1/2 u.D u - dt^2/8 a.M a (a = -M^-1 D u); the plain
energy oscillates by O((omega dt)^2) without drift. Both deviations are
recorded in the signal attributes (only when D is symmetric; with prestress
and tangential forces D is not, and no energy exists).
"""

from __future__ import annotations

import math
import time as _time
from typing import Callable

import numba
import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..threads import at_most  # (importing it selects the threading layer first)
from ..model import LinearSystem, Modes, Signal
from ..resources import check_propagate, check_run_time, check_time_domain, predicted_seconds
from ..provenance import SAMPLE_ATTRS, carried
from .assemble import asymmetry, omega2_max, symmetric_part
from .step_rule import step_error
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .. import team

#: Default fraction of the stability limit 2/omega_max used as time step.
DEFAULT_SAFETY = 0.1

#: Attributes carried from the linear / modes file into the signal file.
CARRIED_ATTRS = (*SAMPLE_ATTRS, "prestress", "n_dof", "n_rattlers", "packing_seed", "packing_source",
                 "packing_git_revision", "n_zero_modes", "linear_source", "modes_source",
                 "packing_digest", "linear_digest", "source_kind", "contact_law", "lateral_width")


def sample_times(t_max: float, samples: int) -> np.ndarray:
    """The output grid: ``samples`` equally spaced times from 0 to t_max."""
    if not (t_max > 0 and math.isfinite(t_max)):
        raise InputError(f"t_max must be a positive finite time (got {t_max})")
    if samples < 2:
        raise InputError(f"need at least 2 samples (got {samples})")
    return np.linspace(0.0, t_max, samples)


def _check_ic(ic: str) -> str:
    ic = str(ic).upper()
    if ic not in ("A", "B"):
        raise InputError(f"initial condition must be A or B (got {ic!r})")
    return ic


def carried_attrs(attrs: dict) -> dict:
    return carried(attrs, CARRIED_ATTRS)


def _modal_coefficients(modes: Modes, ic: str) -> tuple[np.ndarray, np.ndarray]:
    ic = _check_ic(ic)
    n_neg = int(modes.attrs.get("n_negative_modes", 0))
    if n_neg or np.any(modes.omega2 < 0):
        spins = int(modes.attrs.get("n_free_spins", 0)) - int(modes.attrs.get("n_spins_removed", 0))
        hint = (f"; with prestress the {spins} free spins kept are such modes: use the time domain "
                "or linearize --remove-spins" if spins > 0 and modes.attrs.get("prestress") else
                " (use the time domain to see the instability, or fix the packing)")
        raise InputError(f"the modes include {max(n_neg, int(np.sum(modes.omega2 < 0)))} negative "
                         "eigenvalue(s): no oscillatory modal solution" + hint)
    if len(modes.omega2) and not np.max(modes.omega2) > 0:
        raise InputError(f"all {len(modes.omega2)} modes have omega^2 = 0: none oscillates, so no "
                         "pulse propagates (modes of a system without stiffness, or a damaged file)")
    omega = np.sqrt(modes.omega2)
    amp = modes.amplitude_A if ic == "A" else modes.amplitude_B
    return omega, amp


def modal_signal(modes: Modes, *, ic: str, times: np.ndarray,
                 chunk_elements: int = 4_000_000) -> np.ndarray:
    """F_sig(t) = sum_n a_n b_n sin(omega_n t) (A) or cos(omega_n t) (B), in E* d^2.

    ``times`` in d/sqrt(E*/rho). Zero modes of IC A are not summed (their
    linear growth, slope ``modes.attrs['zero_mode_drift_A']``, is reported,
    not added); for IC B they add a constant. Memory: at most
    ``chunk_elements`` doubles of sin(omega t) at a time.
    """
    omega, amp = _modal_coefficients(modes, ic)
    trig = np.sin if _check_ic(ic) == "A" else np.cos
    weight = amp * modes.coupling
    times = np.asarray(times, float)
    out = np.empty(len(times))
    step = max(1, chunk_elements // max(1, len(omega)))
    for start in range(0, len(times), step):
        t = times[start:start + step]
        out[start:start + step] = trig(np.outer(t, omega)) @ weight
    return out


def modal_displacement(modes: Modes, *, ic: str, times: np.ndarray) -> np.ndarray:
    """Displacement fields u(t) (S, n_dof) from the modes; needs stored eigenvectors."""
    if modes.vectors is None:
        raise InputError("displacement snapshots from modes need the eigenvectors: rerun "
                         "eigensolve with --vectors, or use --method time")
    omega, amp = _modal_coefficients(modes, ic)
    trig = np.sin if _check_ic(ic) == "A" else np.cos
    times = np.asarray(times, float)
    return (trig(np.outer(times, omega)) * amp) @ modes.vectors.T


def modal_propagate(modes: Modes, *, ic: str, t_max: float, samples: int = 2001,
                    snapshots=None, dof_grain=None, dof_axis=None) -> Signal:
    """The modal signal (and optional snapshots) as a :class:`Signal`.

    Snapshots need the eigenvectors in ``modes`` and the dof map
    (``dof_grain``, ``dof_axis`` of the linear system) to be stored.
    """
    ic = _check_ic(ic)
    check_propagate(len(modes.omega2), samples, 0 if snapshots is None else np.size(snapshots))
    times = sample_times(t_max, samples)
    force = modal_signal(modes, ic=ic, times=times)
    attrs = carried_attrs(modes.attrs)
    attrs.update(ic=ic, method="modal", height=modes.height, t_max=float(t_max),
                 samples=int(samples), dt=float(times[1] - times[0]),
                 n_modes=int(len(modes.omega2)), modal_truncated=bool(modes.attrs.get("partial", False)),
                 zero_mode_drift=float(modes.attrs.get("zero_mode_drift_A", 0.0)) if ic == "A" else 0.0)
    sig = Signal(time=times, force=force, attrs=attrs)
    if snapshots is not None and len(snapshots):
        if dof_grain is None or dof_axis is None:
            raise InputError("snapshots need the dof map of the linear system (dof_grain, dof_axis)")
        st = _check_snapshots(snapshots, t_max)
        sig.snapshot_time = st
        sig.snapshot_displacement = modal_displacement(modes, ic=ic, times=st)
        sig.dof_grain, sig.dof_axis = np.asarray(dof_grain), np.asarray(dof_axis)
    return sig


def _check_snapshots(snapshots, t_max: float) -> np.ndarray:
    st = np.asarray(snapshots, float).ravel()
    if np.any(~np.isfinite(st)) or np.any(st < 0) or np.any(st > t_max):
        raise InputError(f"snapshot times must lie in [0, t_max = {t_max:g}]")
    return st


#: Rows per block of the parallel reductions (energies): fixed, so that the sums do not
#: depend on the thread count.
SUM_BLOCK = 4096
#: Below this many rows the time domain runs on one thread (the same results): a parallel
#: region per step costs more than it saves on a small system (:func:`granwave.threads.at_most`).
MIN_PARALLEL_ROWS = 20000


@numba.njit(cache=True, inline="always")
def _drift_row(i, u, v, a, dt, flush):
    """First half kick and drift of row i: v += dt/2 a, u += dt v (flushed)."""
    v[i] += 0.5 * dt * a[i]
    u[i] += dt * v[i]
    if abs(u[i]) < flush:
        u[i] = 0.0


@numba.njit(cache=True, inline="always")
def _kick_row(i, indptr, indices, data, minv, u, v, a, dt, flush):
    """a = -M^-1 D u and the second half kick of row i (v flushed); reads u only."""
    acc = 0.0
    for k in range(indptr[i], indptr[i + 1]):
        acc += data[k] * u[indices[k]]
    a[i] = -acc * minv[i]
    v[i] += 0.5 * dt * a[i]
    if abs(v[i]) < flush:
        v[i] = 0.0


@numba.njit(cache=True)
def _drift_rows(lo, hi, u, v, a, dt, flush):
    """:func:`_drift_row` for rows lo..hi-1. The rows are counted unsigned: with signed indices
    numba checks each for wraparound, and the loop ran 2x slower (measured, 3e4 rows)."""
    for i in range(np.uint64(lo), np.uint64(hi)):
        _drift_row(i, u, v, a, dt, flush)


@numba.njit(cache=True)
def _kick_rows(lo, hi, indptr, indices, data, minv, u, v, a, dt, flush):
    """:func:`_kick_row` for rows lo..hi-1 (counted unsigned, as :func:`_drift_rows`)."""
    for i in range(np.uint64(lo), np.uint64(hi)):
        _kick_row(i, indptr, indices, data, minv, u, v, a, dt, flush)


#: Chunks of rows per thread in the team (:func:`_verlet_team`): a thread done early takes over
#: the far end of a late one's share. 16 balanced best at 16 threads (fewer chunks leave a late
#: thread's work where it is, more cost claims; docs/linear.md "Shared chunks").
CHUNKS_PER_THREAD = 16
#: Above this many threads each step is one phase (:func:`_verlet_team_fused`): a chunk's kick
#: and the next step's drift at once, the drift writing a second buffer of u, one barrier a
#: step instead of two. The saved barrier pays on many threads; on few, the fused kick-drift of
#: a row costs more than the two apart (docs/linear.md "Early break and one barrier a step").
FUSED_ABOVE = 4


@numba.njit(cache=True, inline="always")
def _drift_claimed(claims, t, threads, k, phase, u, v, a, dt, flush):
    """Thread t's drift phase in a team: :func:`_drift_rows` of each chunk (of k per thread) that
    :func:`granwave.team.next_chunk` gives it in ``phase``."""
    n = u.shape[0]
    nchunk = k * threads
    c, j = team.next_chunk(claims, t, threads, k, 0, phase)
    while c >= 0:
        _drift_rows(c * n // nchunk, (c + 1) * n // nchunk, u, v, a, dt, flush)
        c, j = team.next_chunk(claims, t, threads, k, j, phase)


@numba.njit(cache=True, parallel=True)
def _verlet_team(indptr, indices, data, minv, u, v, a, dt, n_steps, flush, sync, claims, k):
    """``n_steps`` steps in one parallel region (granwave.team). The rows are cut into
    ``k`` (:data:`CHUNKS_PER_THREAD`) chunks per thread, each thread owning k consecutive ones; per step
    the threads drift the chunks they claim (:func:`granwave.team.next_chunk`: their own, and
    the far end of a late thread's share), wait for all (the kick reads every row of u), kick
    the chunks they claim and wait again (the next drift rewrites rows that others read).
    ``claims``: k * team size zeros; the phase after barrier ``gen`` is gen + 1."""
    n = u.shape[0]
    threads = team.team_size(sync)
    nchunk = k * threads
    for t in numba.prange(threads):  # one iteration per thread
        if team.enter(sync, threads):
            gen = 0
            for _ in range(n_steps):
                _drift_claimed(claims, t, threads, k, gen + 1, u, v, a, dt, flush)
                gen = team.barrier(sync, threads, gen)
                c, j = team.next_chunk(claims, t, threads, k, 0, gen + 1)
                while c >= 0:
                    _kick_rows(c * n // nchunk, (c + 1) * n // nchunk, indptr, indices, data, minv,
                               u, v, a, dt, flush)
                    c, j = team.next_chunk(claims, t, threads, k, j, gen + 1)
                gen = team.barrier(sync, threads, gen)


@numba.njit(cache=True, inline="always")
def _kick_drift_row(i, indptr, indices, data, minv, u, u_next, v, a, dt, flush):
    """:func:`_kick_row` of row i (reading u), then the next step's :func:`_drift_row` of the
    row with its displacement written to ``u_next`` (u is not written: other threads may still
    read it); the same operations in the same order, so the same bits."""
    _kick_row(i, indptr, indices, data, minv, u, v, a, dt, flush)
    v[i] += 0.5 * dt * a[i]
    x = u[i] + dt * v[i]
    if abs(x) < flush:
        x = 0.0
    u_next[i] = x


@numba.njit(cache=True)
def _kick_drift_rows(lo, hi, indptr, indices, data, minv, u, u_next, v, a, dt, flush):
    """:func:`_kick_drift_row` for rows lo..hi-1 (counted unsigned, as :func:`_drift_rows`)."""
    for i in range(np.uint64(lo), np.uint64(hi)):
        _kick_drift_row(i, indptr, indices, data, minv, u, u_next, v, a, dt, flush)


@numba.njit(cache=True, inline="always")
def _fused_rows(lo, hi, s, n_steps, indptr, indices, data, minv, u, u_other, v, a, dt, flush):
    """Rows lo..hi-1 of step s of :func:`_verlet_team_fused`: step s reads buffer s % 2 of the
    displacement (u for even s) and, unless it is the last, drifts into the other."""
    if s % 2 == 0:
        src, dst = u, u_other
    else:
        src, dst = u_other, u
    if s == n_steps - 1:
        _kick_rows(lo, hi, indptr, indices, data, minv, src, v, a, dt, flush)
    else:
        _kick_drift_rows(lo, hi, indptr, indices, data, minv, src, dst, v, a, dt, flush)


@numba.njit(cache=True, parallel=True)
def _verlet_team_fused(indptr, indices, data, minv, u, u_other, v, a, dt, n_steps, flush, sync, claims, k):
    """The steps of :func:`_verlet_team` with one barrier a step: the first kick-drift, then per
    step each claimed chunk's kick and the next step's kick-drift (:func:`_fused_rows`), the
    displacement alternating between u and ``u_other`` so that no row another thread may still
    read is written before the barrier. The result's displacement is in buffer
    (n_steps - 1) % 2 (u_other when that is 1: the caller copies it back)."""
    n = u.shape[0]
    threads = team.team_size(sync)
    nchunk = k * threads
    for t in numba.prange(threads):  # one iteration per thread
        if team.enter(sync, threads):
            gen = 0
            _drift_claimed(claims, t, threads, k, gen + 1, u, v, a, dt, flush)
            gen = team.barrier(sync, threads, gen)
            for s in range(n_steps):
                c, j = team.next_chunk(claims, t, threads, k, 0, gen + 1)
                while c >= 0:
                    _fused_rows(c * n // nchunk, (c + 1) * n // nchunk, s, n_steps, indptr, indices, data, minv,
                                u, u_other, v, a, dt, flush)
                    c, j = team.next_chunk(claims, t, threads, k, j, gen + 1)
                gen = team.barrier(sync, threads, gen)


@numba.njit(cache=True, parallel=True)
def _drift_pass(u, v, a, dt, flush):
    """:func:`_drift_row` over every row as a numba parallel loop (one region)."""
    for i in numba.prange(u.shape[0]):
        _drift_row(i, u, v, a, dt, flush)


@numba.njit(cache=True, parallel=True)
def _kick_pass(indptr, indices, data, minv, u, v, a, dt, flush):
    """:func:`_kick_row` over every row as a numba parallel loop (one region)."""
    for i in numba.prange(u.shape[0]):
        _kick_row(i, indptr, indices, data, minv, u, v, a, dt, flush)


@numba.njit(cache=True)
def _verlet_regions(indptr, indices, data, minv, u, v, a, dt, n_steps, flush):
    """The same steps as two numba parallel loops per step (where a team cannot run)."""
    for _ in range(n_steps):
        _drift_pass(u, v, a, dt, flush)
        _kick_pass(indptr, indices, data, minv, u, v, a, dt, flush)


def verlet_steps(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, minv: np.ndarray,
                 u: np.ndarray, v: np.ndarray, a: np.ndarray, dt: float, n_steps: int,
                 flush: float, sync: np.ndarray | None = None, u_other: np.ndarray | None = None) -> None:
    """``n_steps`` velocity-Verlet steps of u'' = -M^-1 D u in place (D in CSR arrays).

    Per step a kick-drift of every row (:func:`_drift_rows`), then the matvec and the second
    half kick (:func:`_kick_rows`); one pass over D per step and no temporaries. On numba's
    current thread count, in one parallel region for all the steps, the two phases separated by
    spin barriers (:mod:`granwave.team`): numba's own loops opened two regions per step, and at
    16 threads, where a region cost 7 us and a barrier 1.2 us, the team ran 3e4 dofs at
    6.1-7.3x one thread against 5.6-6.2x for the two regions, and with the rows in shared
    chunks (:data:`CHUNKS_PER_THREAD`) 6.5-7.5x; with the early break of the claims and one
    barrier a step above :data:`FUSED_ABOVE` threads 7.5-9.4x (docs/linear.md). Each row's
    arithmetic is that of the former serial loops, whichever thread runs it, so the result is
    bit for bit the same for any thread count. Entries of u and v below ``flush``
    in magnitude are set to 0: ahead of the front the field decays super-exponentially, and
    products of such values (energies, detector) fall into denormal floating point, which
    made the run 5-8x slower on a 28665-dof lattice (measured). ``sync``: a
    :func:`granwave.team.new_sync` vector to reuse between calls (else one is made). On more
    than :data:`FUSED_ABOVE` threads each step is one phase with one barrier
    (:func:`_verlet_team_fused`, the same bits), which needs a second displacement buffer:
    ``u_other``, an array like u to reuse between calls (else one is made). Where no
    team can run (:func:`granwave.team.usable`), numba's two parallel loops per step
    (:func:`_verlet_regions`, the same bits).
    """
    if n_steps <= 0:
        return
    if team.usable():
        threads = numba.get_num_threads()
        sync = team.new_sync() if sync is None else sync
        team.reset_team(sync, threads)
        claims = np.zeros(CHUNKS_PER_THREAD * int(team.team_size(sync)), np.int64)
        if threads > FUSED_ABOVE:
            u_other = np.empty_like(u) if u_other is None else u_other
            _verlet_team_fused(indptr, indices, data, minv, u, u_other, v, a, dt, n_steps, flush, sync, claims,
                               CHUNKS_PER_THREAD)
            if team.entered(sync) and (n_steps - 1) % 2:
                u[:] = u_other
        else:
            _verlet_team(indptr, indices, data, minv, u, v, a, dt, n_steps, flush, sync, claims,
                         CHUNKS_PER_THREAD)
        if team.entered(sync):
            return
        team.give_up("time domain")  # the threads never all ran at once: nothing was done
    _verlet_regions(indptr, indices, data, minv, u, v, a, dt, n_steps, flush)


@numba.njit(cache=True, parallel=True)
def _block_sums(u, v, a, m, out):
    n = u.shape[0]
    for b in numba.prange(out.shape[0]):
        kin = 0.0
        pot = 0.0
        ama = 0.0
        for i in range(b * SUM_BLOCK, min(n, (b + 1) * SUM_BLOCK)):
            mv = m[i] * v[i]
            ma = m[i] * a[i]
            kin += mv * v[i]
            pot -= u[i] * ma
            ama += a[i] * ma
        out[b, 0] = kin
        out[b, 1] = pot
        out[b, 2] = ama


@numba.njit(cache=True)
def state_sums(u: np.ndarray, v: np.ndarray, a: np.ndarray, m: np.ndarray,
               det_index: np.ndarray, det_value: np.ndarray,
               blocks: np.ndarray) -> tuple[float, float, float, float]:
    """(1/2 v.M v, -1/2 u.M a, a.M a, detector.u).

    The energies are summed per block of SUM_BLOCK rows in parallel, then over the
    blocks in order (``blocks``: ceil(n / SUM_BLOCK) x 3 scratch): the same bits for
    any thread count. The detector sum runs over its nonzero entries
    (``det_index``, ``det_value``) in increasing order: the same bits as the full
    sum over all rows (the skipped terms are zeros). Written out rather than numpy
    dot products: under CPU contention the threaded BLAS ddot took ~10 ms for 3e4
    doubles (measured), 20x the whole Verlet step.
    """
    _block_sums(u, v, a, m, blocks)
    kin = 0.0
    pot = 0.0
    ama = 0.0
    for b in range(blocks.shape[0]):
        kin += blocks[b, 0]
        pot += blocks[b, 1]
        ama += blocks[b, 2]
    force = 0.0
    for k in range(det_index.shape[0]):
        force += det_value[k] * u[det_index[k]]
    return 0.5 * kin, 0.5 * pot, ama, force


@numba.njit(cache=True)
def sparse_dot(index: np.ndarray, value: np.ndarray, x: np.ndarray) -> float:
    """sum_k value[k] x[index[k]], in increasing k (the same bits on every run)."""
    acc = 0.0
    for k in range(index.shape[0]):
        acc += value[k] * x[index[k]]
    return acc


#: The time-domain kernel counts its steps in a 64-bit integer.
MAX_TIME_STEPS = 2**63 - 1

#: Stored entries of D swept per call of the stepping kernel (about 20-50 ms of work on one
#: core); the run is cut into calls of that size so that signals and progress are not held up.
CHUNK_WORK = 20_000_000


def stable_time_step(system: LinearSystem, *, safety: float = DEFAULT_SAFETY) -> tuple[float, float]:
    """(dt = safety x 2/omega_max, omega_max) for velocity Verlet."""
    if not (0 < safety < 1):
        raise InputError(f"safety factor must be in (0, 1) (got {safety})")
    D = system.stiffness
    if asymmetry(D) > 0:
        D = symmetric_part(D)
    s = 1.0 / np.sqrt(system.mass)
    # A loose Lanczos (tol 1e-2) is enough: the Ritz value lies within ~tol below
    # omega^2_max, so 1.02 x it bounds omega^2_max from above. Measured on a 3e5-dof
    # lattice: tol 1e-2 takes 1.5 s and is 0.3% low; tol 1e-4 takes 88 s; the
    # Gershgorin bound is instant but 40% high (a 20% smaller step).
    w2 = omega2_max((sp.diags(s) @ D @ sp.diags(s)).tocsr(), tol=1e-2)
    if not w2 > 0:
        raise InputError(f"D has no positive eigenvalue (largest omega^2 = {w2:.3g}): no mode "
                         "oscillates, so velocity Verlet has no stable time step (a negative-"
                         "definite or zero stiffness matrix is not a packing's)")
    wmax = math.sqrt(1.02 * w2)
    return safety * 2.0 / wmax, wmax


def time_domain_signal(system: LinearSystem, *, ic: str, t_max: float, dt: float | None = None,
                       samples: int = 2001, safety: float = DEFAULT_SAFETY, snapshots=None,
                       progress: Callable[[str], None] | None = None,
                       progress_interval: float = 10.0) -> Signal:
    """Integrate M u'' = -D u by velocity Verlet and record F_sig = detector . u.

    Parameters
    ----------
    system : the linear system (D used as stored, also when not symmetric).
    ic : "A" (initial velocity source_velocity) or "B" (initial displacement
        source_displacement).
    t_max : last output time (d/sqrt(E*/rho)); ``samples`` equally spaced outputs.
    dt : requested time step; default ``safety`` x 2/omega_max. The step used
        is the largest <= dt with an integer number of steps per output interval.
    snapshots : times at which to store the displacement field (rounded to the
        nearest step; the stored times are the exact step times).
    progress : called with a one-line message about every ``progress_interval`` s.
    """
    ic = _check_ic(ic)
    check_time_domain(system.n_dof, system.stiffness.nnz, samples, 0 if snapshots is None else np.size(snapshots))
    times = sample_times(t_max, samples)
    h = times[1] - times[0]
    dt_auto, wmax = stable_time_step(system, safety=safety)
    if dt is None:
        dt = dt_auto
    if not (dt > 0 and math.isfinite(dt)):
        raise InputError(f"time step must be positive (got {dt})")
    ratio = h / dt * (1 - 1e-12)  # inf for a denormal dt
    if not ratio * (samples - 1) <= MAX_TIME_STEPS:
        raise InputError(f"t_max {t_max:g} needs {ratio * (samples - 1):.3g} time steps of {dt:.3g}, "
                         f"more than the kernel can count ({MAX_TIME_STEPS:.3g}): use a shorter --t-max")
    sub = max(1, int(math.ceil(ratio)))
    dt = h / sub
    if sub * (samples - 1) > MAX_TIME_STEPS:
        raise InputError(f"t_max {t_max:g} needs {sub * (samples - 1):.3g} time steps of {dt:.3g}, "
                         f"more than the kernel can count ({MAX_TIME_STEPS:.3g}): use a shorter --t-max")
    if wmax * dt >= 2.0:
        raise InputError(f"time step {dt:.3g} is unstable: omega_max dt = {wmax * dt:.3g} >= 2 "
                         f"(use dt <= {2 / wmax:.3g})")
    check_run_time(predicted_seconds("time-domain", system.stiffness.nnz, sub * (samples - 1)),
                   f"the time-domain run ({sub * (samples - 1):.3g} steps of {system.n_dof} dofs)", progress)
    D = system.stiffness.tocsr()
    D.sort_indices()
    indptr = D.indptr.astype(np.int64)
    indices = D.indices.astype(np.int64)
    data = np.ascontiguousarray(D.data, dtype=np.float64)
    m = system.mass
    minv = 1.0 / m
    det = np.asarray(system.detector, dtype=np.float64)
    det_index = np.flatnonzero(det).astype(np.int64)
    det_value = np.ascontiguousarray(det[det_index])
    # F'' = -g.u and F''' = -g.v (u'' = -M^-1 D u): the signal's derivatives that the step's
    # error estimate needs (granwave.linear.step_rule); g is nonzero beside the detector only
    g = D.T @ (det * minv)
    g_index = np.flatnonzero(g).astype(np.int64)
    g_value = np.ascontiguousarray(g[g_index])
    blocks = np.zeros(((system.n_dof + SUM_BLOCK - 1) // SUM_BLOCK, 3))
    u = np.zeros(system.n_dof)
    v = np.zeros(system.n_dof)
    if ic == "A":
        v[:] = system.source_velocity
    else:
        u[:] = system.source_displacement
    a = -(D @ u) * minv
    # 1e-100 of the initial amplitude: far below any physical signal, and products of
    # two such numbers (energies, detector) stay far above the denormal range (1e-308)
    flush = 1e-100 * max(np.abs(u).max(), dt * np.abs(v).max())
    symmetric = asymmetry(D) < 1e-12  # roundoff in summing duplicate entries is ~1e-17

    def energies_and_force():
        kin, pot, ama, f = state_sums(u, v, a, m, det_index, det_value, blocks)
        return kin + pot, kin + pot - dt * dt / 8.0 * ama, f

    e0, eh0, f0 = energies_and_force()
    dev, devh = 0.0, 0.0
    snap_t, snap_k, snap_u = None, None, None
    if snapshots is not None and len(snapshots):
        st = _check_snapshots(snapshots, t_max)
        snap_k = np.rint(st / dt).astype(np.int64)
        snap_t = snap_k * dt
        snap_u = np.zeros((len(st), system.n_dof))
        for s_idx in np.flatnonzero(snap_k == 0):
            snap_u[s_idx] = u
    force = np.empty(samples)
    force[0] = f0
    curvature, jerk = np.empty(samples), np.empty(samples)
    curvature[0], jerk[0] = -sparse_dot(g_index, g_value, u), -sparse_dot(g_index, g_value, v)
    step = 0
    n_steps = sub * (samples - 1)
    t_wall0 = t_last = _time.perf_counter()
    sync = team.new_sync()
    u_other = np.empty_like(u)  # the second displacement buffer of the many-thread team
    # Steps per kernel call: a kernel does not return to Python until it is done, so Ctrl-C,
    # SIGTERM and progress lines wait for it; about CHUNK_WORK stored entries of D per call
    # (tens of ms) keeps them prompt at any --dt. Splitting a run into calls keeps its bits.
    chunk = max(1, CHUNK_WORK // max(int(D.nnz), 1))

    def report():
        nonlocal t_last
        now = _time.perf_counter()
        if progress is not None and now - t_last >= progress_interval and step > 0:
            t_last = now
            rate = step / (now - t_wall0)
            progress(f"propagate: t = {step * dt:.4g} / {t_max:.4g}, step {step}/{n_steps}, "
                     f"{rate:.0f} steps/s, ~{(n_steps - step) / rate:.0f} s left")

    for k in range(1, samples):
        with at_most(system.n_dof, MIN_PARALLEL_ROWS):
            if snap_k is None or not np.any((snap_k > step) & (snap_k <= step + sub)):
                left = sub
                while left > 0:
                    n = min(left, chunk)
                    verlet_steps(indptr, indices, data, minv, u, v, a, dt, n, flush, sync, u_other)
                    step += n
                    left -= n
                    if left:
                        report()
            else:  # a snapshot falls inside this sample interval: go step by step
                for _ in range(sub):
                    verlet_steps(indptr, indices, data, minv, u, v, a, dt, 1, flush, sync, u_other)
                    step += 1
                    for s_idx in np.flatnonzero(snap_k == step):
                        snap_u[s_idx] = u
        e, eh, force[k] = energies_and_force()
        curvature[k], jerk[k] = -sparse_dot(g_index, g_value, u), -sparse_dot(g_index, g_value, v)
        if symmetric:
            dev = max(dev, abs(e - e0))
            devh = max(devh, abs(eh - eh0))
        report()
    attrs = carried_attrs(system.attrs)
    attrs.update(ic=ic, method="time", height=system.height, t_max=float(t_max), samples=int(samples),
                 dt=float(dt), integrator="velocity Verlet", safety=float(safety),
                 omega_max=float(wmax), omega_max_dt=float(wmax * dt), n_steps=int(n_steps),
                 step_error_estimate=step_error(times, force, curvature, jerk, dt, ic),
                 energy_initial=float(e0),
                 energy_max_rel_deviation=float(dev / e0) if symmetric and e0 > 0 else float("nan"),
                 modified_energy_max_rel_deviation=(float(devh / eh0) if symmetric and eh0 > 0
                                                    else float("nan")),
                 wall_time=float(_time.perf_counter() - t_wall0))
    sig = Signal(time=times, force=force, attrs=attrs)
    if snap_t is not None:
        sig.snapshot_time = snap_t
        sig.snapshot_displacement = snap_u
        sig.dof_grain, sig.dof_axis = system.dof_grain, system.dof_axis
    return sig
