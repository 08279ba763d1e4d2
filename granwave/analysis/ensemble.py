"""Ensemble average of signals over independent packings (docs/method.md §9).

Choices (also in ``docs/summaries.md`` and the CLI help)
--------------------------------------------------------
* **Common time grid.** If every signal has the same sample times (the usual
  case: one ``propagate`` setting for the whole ensemble) they are used as
  they are, without interpolation. Otherwise the grid is uniform on the
  *overlap* of the time ranges, [max of the first times, min of the last
  times], with the smallest sampling step found among the inputs (median
  step of each signal), and every signal is linearly interpolated onto it.
  An empty overlap is refused.
* **Mean and rms.** mean(t) = (1/n) Σ F_i(t); rms(t) = sqrt((1/n) Σ (F_i(t) -
  mean(t))²): the root-mean-square deviation of the packings from the
  average (population form, 1/n, so that two signals s ± δ give exactly |δ|).
* **Front statistics.** :func:`granwave.analysis.front.front_features` of
  every signal (on its own samples, not the interpolated ones): mean, sample
  standard deviation (1/(n-1); NaN for one signal), standard error of the
  mean std/sqrt(n) and count, for every numeric feature; and the features of
  the mean signal.
* Signals at different pressures, with different initial conditions, of
  different kinds of system (``kind``, ``dim``, ``friction``, ``poisson``,
  ``prestress``) or of different container heights are refused (their average
  means nothing). Heights of disordered packings differ slightly per sample
  (they must lie within the height group tolerance of ``analyze heights``,
  5 %): the mean and std of ``height`` are recorded.

Units: times d/sqrt(E*/rho), forces E* d^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..errors import InputError
from ..io import files as F
from ..io import schema as S
from .front import features_of_signals, front_features
from .heights import common_attr

if TYPE_CHECKING:
    from ..model import Signal


@dataclass
class Ensemble:
    """Average signal and rms deviation on a common time grid."""

    time: np.ndarray  # (T,) d/sqrt(E*/rho)
    mean: np.ndarray  # (T,) E* d^2
    rms: np.ndarray  # (T,) E* d^2
    attrs: dict = field(default_factory=dict)  # n_signals, grid, pressure, ic, ...

    @property
    def n_signals(self) -> int:
        return int(self.attrs["n_signals"])


def common_grid(times: Sequence[np.ndarray]) -> tuple[np.ndarray, str]:
    """The common time grid (rule: module docstring) and a word naming the rule used."""
    first = times[0]
    if all(t.shape == first.shape and np.array_equal(t, first) for t in times[1:]):
        return first.copy(), "identical"
    lo = max(float(t[0]) for t in times)
    hi = min(float(t[-1]) for t in times)
    if not hi > lo:
        raise InputError(f"the signals' time ranges do not overlap (latest start {lo:.6g}, "
                         f"earliest end {hi:.6g})")
    step = min(float(np.median(np.diff(t))) for t in times)
    n = int(math.floor((hi - lo) / step * (1 + 1e-12))) + 1
    return lo + step * np.arange(n), "overlap"


#: Attributes that name the kind of system: signals that differ in one are not one ensemble.
SYSTEM_ATTRS = ("kind", "dim", "friction", "poisson", "prestress")


def _one_height(signals, labels, rtol: float) -> None:
    """Refuse signals of different container heights: the heights must form one group of
    :func:`granwave.analysis.heights.group_heights` (disordered packings of one nominal
    height differ by a few per cent at most; a height series differs by factors)."""
    from .heights import group_heights

    h = np.array([float(s.attrs.get("height", np.nan)) for s in signals])
    have = np.isfinite(h)
    if have.sum() < 2:
        return
    groups = group_heights(h[have], rtol)
    if groups.max() > 0:
        idx = np.flatnonzero(have)
        lo, hi = idx[int(np.argmin(h[have]))], idx[int(np.argmax(h[have]))]
        raise InputError(f"mixed heights: {labels[lo]} has height={h[lo]:.6g}, {labels[hi]} has "
                         f"height={h[hi]:.6g} (more than {rtol:g} apart, relative): average the "
                         "signals of one container height (analyze heights takes a series)")


def ensemble_average(signals: Sequence["Signal"], *, labels: Sequence[str] | None = None,
                     height_rtol: float | None = None) -> Ensemble:
    """Mean signal and rms deviation over packings (docs/method.md §9); rule in the module docstring.

    ``height_rtol``: the relative gap of heights that still counts as one height (default:
    the group tolerance of ``analyze heights``).
    """
    from .heights import DEFAULT_GROUP_RTOL

    height_rtol = DEFAULT_GROUP_RTOL if height_rtol is None else height_rtol
    signals = list(signals)
    if not signals:
        raise InputError("no signals given")
    labels = list(labels) if labels is not None else [f"signal {i}" for i in range(len(signals))]
    for s, lab in zip(signals, labels):
        if s.time.ndim != 1 or s.time.size < 2 or s.force.shape != s.time.shape:
            raise InputError(f"{lab}: time and force must be 1D arrays of equal length >= 2")
        if np.any(np.diff(s.time) <= 0):
            raise InputError(f"{lab}: signal times must be strictly increasing")
    pressure = common_attr(signals, labels, "pressure", rtol=1e-9)
    ic = common_attr(signals, labels, "ic")
    for key in SYSTEM_ATTRS:  # among the signals that record it
        have = [(s, lab) for s, lab in zip(signals, labels) if s.attrs.get(key) is not None]
        if have:
            common_attr([s for s, _ in have], [lab for _, lab in have], key)
    _one_height(signals, labels, height_rtol)
    time, grid = common_grid([s.time for s in signals])
    if grid == "identical":
        stack = np.stack([s.force for s in signals])
    else:
        stack = np.stack([np.interp(time, s.time, s.force) for s in signals])
    mean = stack.mean(axis=0)
    rms = np.sqrt(np.mean((stack - mean) ** 2, axis=0))
    h = np.array([s.attrs.get("height", np.nan) for s in signals], dtype=float)
    attrs = {"n_signals": len(signals), "grid": grid, "pressure": pressure, "ic": ic,
             "height_mean": float(np.mean(h)),
             "height_std": float(np.std(h, ddof=1)) if h.size > 1 else math.nan}
    for key in ("kind", "dim", "friction", "method"):
        values = {str(s.attrs.get(key)) for s in signals}
        if len(values) == 1 and key in signals[0].attrs:
            attrs[key] = signals[0].attrs[key]
    return Ensemble(time=time, mean=mean, rms=rms, attrs=attrs)


def describe(values) -> dict:
    """mean, std (1/(n-1)), sem = std/sqrt(n) and count of the finite values."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    n = int(v.size)
    mean = float(v.mean()) if n else math.nan
    std = float(v.std(ddof=1)) if n > 1 else math.nan
    return {"mean": mean, "std": std, "sem": std / math.sqrt(n) if n > 1 else math.nan, "count": n}


def front_statistics(signals: Sequence["Signal"], *, labels: Sequence[str] | None = None,
                     **front_kw) -> dict:
    """Per-feature mean/std/sem/count of the front features over the signals.

    Each signal is analysed on its own samples. A signal whose first pulse is
    not complete raises InputError naming it (``labels``).
    """
    signals = list(signals)
    labels = list(labels) if labels is not None else [f"signal {i}" for i in range(len(signals))]
    rows = features_of_signals(signals, labels, **front_kw)
    # Measured quantities only: the rule's own parameters (peak_fraction, ...) are not statistics.
    keys = [k for k, v in rows[0].items() if isinstance(v, (int, float)) and not isinstance(v, bool)
            and not k.endswith("_fraction") and k not in ("t_window", "refine")]
    return {k: describe([r[k] for r in rows]) for k in keys}


def analyze_ensemble(signals: Sequence["Signal"], *, labels: Sequence[str] | None = None,
                     **front_kw) -> tuple[Ensemble, dict]:
    """Ensemble average plus front statistics and the front of the mean signal.

    Returns (ensemble, summary); ``summary`` holds ``front_stats`` (per feature
    mean/std/sem/count), ``front_of_mean`` (features of the averaged signal),
    and ``n_signals``, ``grid``, ``pressure``, ``ic``.
    """
    ens = ensemble_average(signals, labels=labels)
    stats = front_statistics(signals, labels=labels, **front_kw)
    try:
        of_mean = front_features(ens.time, ens.mean, **front_kw).as_dict()
    except InputError as exc:
        raise InputError(f"the mean signal: {exc}") from None
    summary = {**{k: ens.attrs[k] for k in ("n_signals", "grid", "pressure", "ic",
                                            "height_mean", "height_std")},
               "time_range": [float(ens.time[0]), float(ens.time[-1])], "n_times": int(ens.time.size),
               "max_rms_over_max_mean": float(ens.rms.max() / np.abs(ens.mean).max())
               if np.abs(ens.mean).max() > 0 else math.nan,
               "front_options": dict(front_kw),
               "front_stats": stats, "front_of_mean": of_mean}
    return ens, summary


# ---------------------------------------------------------------- file io
# These two belong with the other readers/writers; they live here until
# granwave/io/files.py takes them over (same atomic write and checked read).
def write_ensemble(path, ens: Ensemble, extra_attrs: dict | None = None) -> None:
    """Write an ensemble file (schema granwave.ensemble) atomically."""
    attrs = {**ens.attrs, **(extra_attrs or {})}
    with F.atomic_h5(path, S.ENSEMBLE, attrs) as f:
        F.put(f, S.ENSEMBLE, "ensemble/time", ens.time)
        F.put(f, S.ENSEMBLE, "ensemble/mean", ens.mean)
        F.put(f, S.ENSEMBLE, "ensemble/rms", ens.rms)


def read_ensemble(path) -> Ensemble:
    """Read an ensemble file, validated (:func:`granwave.io.validate.ensemble`) before use."""
    from ..io import validate as V

    with F.open_checked(path, S.ENSEMBLE) as f:
        a = F._read_all(f, path, S.ENSEMBLE)
        attrs = F.read_attrs(f)
    V.ensemble(path, a, attrs)
    return Ensemble(time=a["ensemble/time"], mean=a["ensemble/mean"], rms=a["ensemble/rms"], attrs=attrs)


# ---------------------------------------------------------------- heights
def local_exponents_of_means(height, mean, sem=None) -> dict:
    """Local exponents d log|y| / d log L between ensemble means at distinct heights.

    ``height``: nominal heights (group means, strictly increasing after sorting;
    equal heights are refused: take them as one ensemble first); ``mean``: the
    ensemble mean of y at each; ``sem``: its standard error (NaN or None where
    undetermined, e.g. one packing). The error of each local exponent is the
    two standard errors propagated:
    δe = sqrt((δy1/y1)² + (δy2/y2)²) / ln(L2/L1) (independent ensembles).
    Returns ``height_mid`` (geometric means), ``exponent`` and ``exponent_err``.
    """
    L = np.asarray(height, float)
    y = np.abs(np.asarray(mean, float))
    e = np.full(L.shape, np.nan) if sem is None else np.asarray(sem, float)
    if not (L.shape == y.shape == e.shape):
        raise InputError("height, mean and sem must have the same length")
    ok = np.isfinite(L) & np.isfinite(y) & (L > 0) & (y > 0)
    L, y, e = L[ok], y[ok], e[ok]
    order = np.argsort(L)
    L, y, e = L[order], y[order], e[order]
    if np.any(np.diff(L) <= 0):
        raise InputError("local exponents need distinct heights (average equal heights first)")
    if L.size < 2:
        return {"height_mid": np.zeros(0), "exponent": np.zeros(0), "exponent_err": np.zeros(0)}
    lnL, lny = np.log(L), np.log(y)
    rel = e / y
    return {"height_mid": np.sqrt(L[1:] * L[:-1]), "exponent": np.diff(lny) / np.diff(lnL),
            "exponent_err": np.hypot(rel[1:], rel[:-1]) / np.diff(lnL)}
