"""Characteristic points of the coherent front of one signal (SPEC §9).

The rule (also in ``docs/front.md`` and ``granwave analyze front --help``)
--------------------------------------------------------------------------
Let ``F_ref`` be the largest |F| of the record (or of the samples with
``time <= t_window`` when a window is given, to keep a large late tail out of
the reference).

1. **First pulse.** The signal is cut into *lobes*: maximal runs of samples of
   one sign (a sample that is exactly zero ends a lobe). The first pulse is
   the first lobe in which |F| reaches ``peak_fraction × F_ref`` (default
   0.5). Precursors of either sign and numerical ripples ahead of the front
   are smaller than that and are skipped as whole lobes; on the chain with
   initial condition (B) the precursor is about a quarter of the main lobe.
2. **Peak.** The extremum of F inside that lobe: sample maximum of
   ``polarity × F``, refined by the parabola through it and its two
   neighbours (``refine=True``). ``t_peak`` is the vertex, ``amplitude`` is
   |F| at the vertex (always >= 0); ``polarity`` (+1 or -1) is the sign of
   the lobe.
3. **Leading edge.** ``t_lead10``: the first time inside the first pulse's
   lobe at which ``polarity × F`` reaches ``lead_fraction × amplitude``
   (default 0.1), linearly interpolated between the two samples that bracket
   it. On a signal that is quiet before the front this is the first time the
   signal reaches 10 % of the first peak.
4. **Zero crossing.** ``t_zero``: the first sign change after the peak (the
   end of the lobe), linearly interpolated.
5. **Width.** ``width = t_zero - t_lead10``: the duration of the first lobe
   from its 10 % leading edge to its zero crossing. (Used everywhere in
   granwave; ``rise = t_peak - t_lead10`` is reported as well.)

A signal whose first pulse never reaches its peak, or never comes back
through zero, inside the record raises :class:`granwave.errors.InputError`,
as does a signal already beyond ``lead_fraction`` of the peak at its first
sample (its leading edge is not in the record).

Units: times in d/sqrt(E*/rho), forces in E* d^2 (SPEC §1); the functions do
not care, they return the units they are given.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError

DEFAULT_PEAK_FRACTION = 0.5
DEFAULT_LEAD_FRACTION = 0.1


@dataclass(frozen=True, kw_only=True)
class FrontFeatures:
    """Characteristic points of the first pulse (rule: module docstring).

    Times in the units of the input time axis, forces in those of the input
    force. ``amplitude`` is a magnitude; ``polarity`` is the sign of the lobe.
    """

    t_lead10: float
    t_peak: float
    amplitude: float
    polarity: int
    t_zero: float
    width: float  # t_zero - t_lead10
    rise: float  # t_peak - t_lead10
    reference: float  # F_ref, the largest |F| the peak_fraction is taken of
    peak_fraction: float
    lead_fraction: float
    t_window: float | None
    refine: bool

    def as_dict(self) -> dict:
        return asdict(self)


def _validate(time, force) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(time, dtype=float)
    f = np.asarray(force, dtype=float)
    if t.ndim != 1 or f.shape != t.shape:
        raise InputError(f"time and force must be 1D arrays of equal length (got {t.shape}, {f.shape})")
    if t.size < 3:
        raise InputError(f"a signal needs at least 3 samples (got {t.size})")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(f))):
        raise InputError("the signal contains NaN or infinite values")
    if np.any(np.diff(t) <= 0):
        raise InputError("signal times must be strictly increasing")
    return t, f


def _parabola_vertex(t3: np.ndarray, y3: np.ndarray) -> tuple[float, float]:
    """Vertex (time, value) of the parabola through three samples (any spacing)."""
    x = t3 - t3[1]  # centre on the middle sample for conditioning
    a, b, c = np.polyfit(x, y3, 2)
    if a >= 0.0:  # not a maximum (flat or kinked top): keep the sample
        return float(t3[1]), float(y3[1])
    xv = -b / (2.0 * a)
    # The vertex of a sampled maximum lies within half a step of the sample.
    xv = float(np.clip(xv, x[0] / 2.0, x[2] / 2.0))
    return float(t3[1] + xv), float(np.polyval([a, b, c], xv))


def _crossing(t: np.ndarray, y: np.ndarray, k: int, level: float) -> float:
    """Time where y crosses ``level`` between samples k-1 and k (linear)."""
    y0, y1 = y[k - 1], y[k]
    if y1 == y0:
        return float(t[k])
    return float(t[k - 1] + (level - y0) * (t[k] - t[k - 1]) / (y1 - y0))


def front_features(time, force, *, peak_fraction: float = DEFAULT_PEAK_FRACTION,
                   lead_fraction: float = DEFAULT_LEAD_FRACTION, t_window: float | None = None,
                   refine: bool = True) -> FrontFeatures:
    """Leading edge, first peak, zero crossing and width of the first pulse.

    Parameters
    ----------
    time, force : 1D arrays of equal length; strictly increasing times
        (d/sqrt(E*/rho)), force on the detector (E* d^2).
    peak_fraction : the first pulse is the first lobe whose |F| reaches this
        fraction of the reference amplitude F_ref (0 < peak_fraction <= 1).
    lead_fraction : level of the leading edge as a fraction of the peak (0.1).
    t_window : if given, F_ref = max |F| over samples with time <= t_window
        (use a few travel times to keep a larger late tail out of F_ref);
        otherwise over the whole record.
    refine : refine the peak by the parabola through three samples.

    Returns
    -------
    FrontFeatures; ``width = t_zero - t_lead10``. The rule is stated in the
    module docstring. Raises InputError when the first pulse is not complete
    inside the record.
    """
    if not 0.0 < peak_fraction <= 1.0:
        raise InputError(f"peak_fraction must be in (0, 1], got {peak_fraction}")
    if not 0.0 < lead_fraction < 1.0:
        raise InputError(f"lead_fraction must be in (0, 1), got {lead_fraction}")
    t, f = _validate(time, force)
    in_window = np.ones(t.size, bool) if t_window is None else (t <= t_window)
    if not in_window.any():
        raise InputError(f"t_window = {t_window} is before the first sample (t = {t[0]})")
    reference = float(np.max(np.abs(f[in_window])))
    if reference == 0.0:
        raise InputError("the signal is identically zero: no front to analyse")

    # 1. first sample reaching the threshold, and the lobe around it
    k0 = int(np.argmax(np.abs(f) >= peak_fraction * reference))
    polarity = 1 if f[k0] > 0 else -1
    y = polarity * f  # the lobe is positive in y
    before = np.nonzero(y[:k0] <= 0.0)[0]
    start = int(before[-1]) + 1 if before.size else 0  # first sample of the lobe
    after = np.nonzero(y[k0:] <= 0.0)[0]
    end = k0 + int(after[0]) if after.size else None  # first sample past the lobe

    # 2. peak
    stop = end if end is not None else t.size
    kp = start + int(np.argmax(y[start:stop]))
    if kp == t.size - 1:
        raise InputError(
            f"the first pulse never reaches its peak inside the record: |F| is still growing at "
            f"the last sample (t = {t[-1]:.6g}); record a longer signal")
    if end is None:
        raise InputError(
            f"the first pulse (peak at t = {t[kp]:.6g}) never crosses zero inside the record "
            f"(ends at t = {t[-1]:.6g}); record a longer signal")
    if refine and kp > 0:
        t_peak, a = _parabola_vertex(t[kp - 1:kp + 2], y[kp - 1:kp + 2])
    else:
        t_peak, a = float(t[kp]), float(y[kp])

    # 3. leading edge inside the lobe
    level = lead_fraction * a
    kl = start + int(np.argmax(y[start:kp + 1] >= level))
    if kl == 0:
        raise InputError(
            f"the signal is already at {y[0] / a:.3g} of its first peak at the first sample "
            f"(t = {t[0]:.6g}): its leading edge is not in the record")
    t_lead = _crossing(t, y, kl, level)

    # 4. zero crossing: end of the lobe
    t_zero = _crossing(t, y, end, 0.0)

    return FrontFeatures(
        t_lead10=t_lead, t_peak=t_peak, amplitude=a, polarity=polarity, t_zero=t_zero,
        width=t_zero - t_lead, rise=t_peak - t_lead, reference=reference,
        peak_fraction=float(peak_fraction), lead_fraction=float(lead_fraction),
        t_window=None if t_window is None else float(t_window), refine=bool(refine),
    )
