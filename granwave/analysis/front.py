"""Characteristic points of the coherent front of one signal (docs/method.md §9).

The rule (also in ``docs/front.md`` and ``granwave analyze front --help``)
--------------------------------------------------------------------------
1. **Lobes.** The signal is cut into *lobes*: maximal runs of samples of one
   sign (a sample that is exactly zero ends a lobe). A lobe's size is its
   largest |F|. Lobes smaller than ``noise_fraction`` (default 1e-3) of the
   largest |F| of the record are numerical ripples and are skipped.
2. **First pulse.** Scanning the remaining lobes in time order, the first
   pulse is the first lobe whose size reaches ``peak_fraction`` (default
   0.3) of the largest lobe seen so far *including the next lobe*. A
   precursor is a lobe much smaller than the one right after it, and is
   skipped. Why 0.3 and why the next lobe only: on the chain (docs/method.md §12) the
   lobes behind the front keep growing (Airy tail), so a fraction of the
   record's maximum would skip the front itself. Asymptotically (large N)
   the precursor of initial condition (B) is 0.196 of its main lobe, while
   the first lobe of (A) is 0.369 of the next one and the main lobe of (B)
   0.353 of the next one; 0.3 separates them for every N >= 10
   (tests/test_front.py checks N = 10 ... 1000).
3. **Peak.** The extremum of F inside that lobe: sample maximum of
   ``polarity × F``, refined by the parabola through it and its two
   neighbours (``refine=True``). ``t_peak`` is the vertex, ``amplitude`` is
   |F| at the vertex (always >= 0); ``polarity`` (+1 or -1) is the sign of
   the lobe.
4. **Leading edge.** ``t_lead10``: the first time inside the first pulse's
   lobe at which ``polarity × F`` reaches ``lead_fraction × amplitude``
   (default 0.1), linearly interpolated between the two samples that bracket
   it. On a signal that is quiet before the front this is the first time the
   signal reaches 10 % of the first peak.
5. **Zero crossing.** ``t_zero``: the first sign change after the peak (the
   end of the lobe), linearly interpolated.
6. **Width.** ``width = t_zero - t_lead10``: the duration of the first lobe
   from its 10 % leading edge to its zero crossing. (Used everywhere in
   granwave; ``rise = t_peak - t_lead10`` is reported as well.)

A signal whose first pulse never reaches its peak, or never comes back
through zero, inside the record raises :class:`granwave.errors.InputError`,
as does a signal already beyond ``lead_fraction`` of the peak at its first
sample (its leading edge is not in the record).

Units: times in d/sqrt(E*/rho), forces in E* d^2 (docs/method.md §1); the functions do
not care, they return the units they are given.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError
from ..params import FrontParams

# The defaults live with the stage's parameters (granwave.params.FrontParams).
DEFAULT_PEAK_FRACTION = FrontParams.peak_fraction
DEFAULT_LEAD_FRACTION = FrontParams.lead_fraction
DEFAULT_NOISE_FRACTION = FrontParams.noise_fraction


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
    reference: float  # largest lobe up to the next one, which peak_fraction is taken of
    peak_fraction: float
    lead_fraction: float
    noise_fraction: float
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
                   lead_fraction: float = DEFAULT_LEAD_FRACTION,
                   noise_fraction: float = DEFAULT_NOISE_FRACTION,
                   refine: bool = True) -> FrontFeatures:
    """Leading edge, first peak, zero crossing and width of the first pulse.

    Parameters
    ----------
    time, force : 1D arrays of equal length; strictly increasing times
        (d/sqrt(E*/rho)), force on the detector (E* d^2).
    peak_fraction : the first pulse is the first lobe at least this fraction
        of the largest lobe up to and including the next one (default 0.3).
    lead_fraction : level of the leading edge as a fraction of the peak (0.1).
    noise_fraction : lobes below this fraction of max |F| are ripples (1e-3).
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
    if not 0.0 <= noise_fraction < 1.0:
        raise InputError(f"noise_fraction must be in [0, 1), got {noise_fraction}")
    t, f = _validate(time, force)
    absf = np.abs(f)
    fmax = float(absf.max())
    if fmax == 0.0:
        raise InputError("the signal is identically zero: no front to analyse")

    # 1. lobes: runs of one sign; exact zeros end a lobe and belong to none
    sgn = np.sign(f)
    cut = np.flatnonzero(np.diff(sgn)) + 1
    starts = np.r_[0, cut]
    ends = np.r_[cut, t.size]  # exclusive
    keep = sgn[starts] != 0
    starts, ends = starts[keep], ends[keep]
    size = np.maximum.reduceat(absf, starts)[: starts.size] if starts.size else np.zeros(0)
    # reduceat over the kept starts runs to the next kept start; zeros in between add nothing
    big = size >= noise_fraction * fmax
    starts, ends, size = starts[big], ends[big], size[big]

    # 2. first lobe >= peak_fraction x the largest lobe so far including the next one
    seen = np.maximum.accumulate(size)
    nxt = np.r_[size[1:], 0.0]
    k = int(np.argmax(size >= peak_fraction * np.maximum(seen, nxt)))  # the largest lobe qualifies
    start, end = int(starts[k]), int(ends[k])
    reference = float(max(seen[k], nxt[k]))
    polarity = 1 if f[start] > 0 else -1
    y = polarity * f  # the lobe is positive in y

    # 3. peak
    kp = start + int(np.argmax(y[start:end]))
    if kp == t.size - 1:
        raise InputError(
            f"the first pulse never reaches its peak inside the record: |F| is still growing at "
            f"the last sample (t = {t[-1]:.6g}); record a longer signal")
    if end == t.size:
        raise InputError(
            f"the first pulse (peak at t = {t[kp]:.6g}) never crosses zero inside the record "
            f"(ends at t = {t[-1]:.6g}); record a longer signal")
    if refine and kp > 0:
        t_peak, a = _parabola_vertex(t[kp - 1:kp + 2], y[kp - 1:kp + 2])
    else:
        t_peak, a = float(t[kp]), float(y[kp])

    # 4. leading edge inside the lobe
    level = lead_fraction * a
    kl = start + int(np.argmax(y[start:kp + 1] >= level))
    if kl == 0:
        raise InputError(
            f"the signal is already at {y[0] / a:.3g} of its first peak at the first sample "
            f"(t = {t[0]:.6g}): its leading edge is not in the record")
    t_lead = _crossing(t, y, kl, level)

    # 5. zero crossing: the sample after the lobe has y <= 0
    t_zero = _crossing(t, y, end, 0.0)

    return FrontFeatures(
        t_lead10=t_lead, t_peak=t_peak, amplitude=a, polarity=polarity, t_zero=t_zero,
        width=t_zero - t_lead, rise=t_peak - t_lead, reference=reference,
        peak_fraction=float(peak_fraction), lead_fraction=float(lead_fraction),
        noise_fraction=float(noise_fraction), refine=bool(refine),
    )


def features_of_signals(signals, labels, **front_kw) -> list[dict]:
    """:func:`front_features` of several signals as dicts; a signal whose first pulse is
    incomplete raises InputError naming its label."""
    rows = []
    for s, lab in zip(signals, labels):
        try:
            rows.append(front_features(s.time, s.force, **front_kw).as_dict())
        except InputError as exc:
            raise InputError(f"{lab}: {exc}") from None
    return rows
