"""The time domain's step rule: a stated accuracy of the signal, checked on each run.

Velocity Verlet on a linear mode of frequency omega runs at the frequency omega_h with
sin(omega_h dt / 2) = omega dt / 2, i.e. omega_h = omega (1 + (omega dt)^2 / 24 + ...), and with
an initial velocity (IC A) an amplitude 1 / sqrt(1 - (omega dt)^2 / 4) = 1 + (omega dt)^2 / 8 + ...
times the exact one (IC B: the exact amplitude). Summed over the modes, to leading order in dt^2,
the computed signal departs from the exact one by

    F_h(t) - F(t) = -(dt^2 / 24) (t F'''(t) + 3 F''(t))      (IC B: without the 3 F'' term)

(docs/linear.md "Accuracy of the time domain"). The phase term grows with t and with the third
derivative of the signal, so it is set by what the signal contains, not by omega_max: the shear
kick's signal holds more of the high, rotation-dominated modes than the compressional one, and
its coda grows late in the record. The integrators record F'' = -g.u and F''' = -g.v at every
output sample (g = D^T M^-1 detector, a sparse vector beside the detector's dofs), so each run
carries this estimate of its own error (:func:`step_error`), and :func:`accurate_signal` repeats
a run whose estimate exceeds the tolerance with the step the estimate's dt^2 scaling asks for.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Callable

import numpy as np

from ..errors import InputError

#: A repeated run aims at this fraction of the tolerance: the estimate is leading order in dt^2
#: (measured within 5 % of the true error below 1 % of max|F|, docs/tradeoffs.md), and the step
#: is then rounded down to a whole number per sample interval.
RERUN_TARGET = 0.7
#: Runs at most (the first included); past a large estimate, where the leading order overstates
#: the error, the second run already lands below the target.
MAX_RUNS = 4


class StepAccuracyWarning(UserWarning):
    """A time-domain signal whose estimated step error exceeds the tolerance asked for."""


def step_error(times: np.ndarray, force: np.ndarray, curvature: np.ndarray, jerk: np.ndarray,
               dt: float, ic: str) -> float:
    """Leading-order estimate of max_t |F_h(t) - F(t)| / max_t |F(t)| over the record.

    ``curvature`` = F'' and ``jerk`` = F''' of the computed signal at the sample ``times``
    (d/sqrt(E*/rho)); ``dt``: the step used. 0 for a record that is zero throughout.
    """
    e = np.asarray(times) * np.asarray(jerk)
    if ic == "A":
        e = e + 3.0 * np.asarray(curvature)
    num = dt * dt / 24.0 * float(np.max(np.abs(e), initial=0.0))
    den = float(np.max(np.abs(force), initial=0.0))
    if num == 0.0:
        return 0.0
    return num / den if den > 0 else math.inf


def check_tolerance(tolerance: float) -> float:
    tolerance = float(tolerance)
    if not (0.0 <= tolerance < 1.0):
        raise InputError(f"the time domain's tolerance must be in [0, 1) (a fraction of max|F|; "
                         f"0: no check), got {tolerance}")
    return tolerance


def accurate_signal(integrate: Callable, system, *, tolerance: float,
                    dt: float | None = None, progress: Callable[[str], None] | None = None,
                    rerun_ok: Callable[[float], bool] | None = None, **kw):
    """``integrate(system, dt=..., **kw)`` (a time-domain integrator: CPU or GPU), repeated
    with a shorter step until its ``step_error_estimate`` is at most ``tolerance``.

    The first run uses ``dt`` (None: the integrator's rule, ``safety`` x 2/omega_max); a run
    above the tolerance is followed by one at dt x sqrt(RERUN_TARGET tolerance / estimate), at
    most :data:`MAX_RUNS` runs in all. ``tolerance`` 0: the first run as it is. The signal
    records ``step_tolerance``, ``step_runs``, ``step_first_dt`` and ``wall_time_all_runs`` (s);
    one still above the tolerance emits a :class:`StepAccuracyWarning`. ``rerun_ok(dt)``: asked
    before each repetition (None: always yes); a no returns the signal as it is, with
    ``step_rerun_declined`` True and ``step_declined_dt`` the step it would have taken, and no
    warning (the caller takes another method: ``method auto``).
    """
    tolerance = check_tolerance(tolerance)
    t0 = time.perf_counter()
    sig = integrate(system, dt=dt, progress=progress, **kw)
    first, runs = float(sig.attrs["dt"]), 1
    while tolerance > 0 and sig.attrs["step_error_estimate"] > tolerance and runs < MAX_RUNS:
        est = float(sig.attrs["step_error_estimate"])
        dt = float(sig.attrs["dt"]) * math.sqrt(RERUN_TARGET * tolerance / est) if math.isfinite(est) \
            else 0.5 * float(sig.attrs["dt"])
        if rerun_ok is not None and not rerun_ok(dt):
            sig.attrs.update(step_rerun_declined=True, step_declined_dt=dt, step_tolerance=tolerance,
                             step_runs=runs, step_first_dt=first)
            return sig
        if progress is not None:
            progress(f"propagate: estimated step error {est:.3g} of max|F| at dt = {sig.attrs['dt']:.4g} "
                     f"exceeds the tolerance {tolerance:g}: again with dt <= {dt:.4g}")
        sig = integrate(system, dt=dt, progress=progress, **kw)
        runs += 1
    est = float(sig.attrs["step_error_estimate"])
    if tolerance > 0 and est > tolerance:
        warnings.warn(StepAccuracyWarning(
            f"the time-domain signal's estimated step error {est:.3g} of max|F| still exceeds the "
            f"tolerance {tolerance:g} after {runs} runs (dt = {sig.attrs['dt']:.3g}): use a smaller "
            "--dt, or --method modal"), stacklevel=3)
    sig.attrs.update(step_tolerance=tolerance, step_runs=runs, step_first_dt=first,
                     wall_time_all_runs=float(time.perf_counter() - t0))
    return sig
