"""Container-height series: arrival times, speeds and scaling exponents (docs/method.md §9).

Input: signals from containers of several heights L (source-detector
distance = the signal's ``height`` attribute, bottom wall to top wall), one
or more packings per height, all at one pressure and one initial condition.

Choices (also in ``docs/summaries.md`` and the CLI help)
--------------------------------------------------------
* **Grouping.** Disordered packings of the same nominal height differ
  slightly in L. Heights are sorted and split into groups wherever
  consecutive heights differ by more than ``group_rtol`` (relative, default
  5 %). A group is one *nominal height*; its mean L and the mean (and sample
  standard deviation) of every feature are reported.
* **Regressions use every sample as its own point** at its own L (not the
  group means), so the spread between packings enters the uncertainties.
* **Speeds.** Arrival time against distance is a straight line t = t0 + L/c;
  c = 1/slope, δc = δslope/slope². ``c_tof`` (10 % leading edge), ``c_peak``
  and ``c_zero`` (first zero crossing) are taken between the two nominal
  heights nearest to ``edge_heights`` (default 8 and 25 d, docs/method.md §9), and the
  same three from the fit over all heights as ``c_tof_all``, ``c_peak_all``,
  ``c_zero_all``. None of them is adjusted.
* **Exponents.** |A|(L) ~ L^-gamma and W(L) ~ L^chi (W = t_zero - t_lead10,
  :mod:`granwave.analysis.front`), fitted in log-log over every sample.
  Local effective exponents d log|A|/d log L and d log W/d log L are taken
  between consecutive nominal heights (group means), reported at the
  geometric mean height of each pair; ``gamma_local`` is -d log|A|/d log L.
* With exactly two samples in a fit the uncertainty is undetermined (NaN). Every fitted
  quantity also carries its 95 % interval (``*_ci95``: ± t(0.975, n − 2) errors, the
  speeds' inverted from the slope's), which "± 2 errors" undercovers with few samples (two
  packings at each of the two edge heights: two degrees of freedom, P(|t₂| < 2) = 0.82;
  docs/truth.md).
* **Aliasing is recorded, not hidden.** A signal whose sample interval
  exceeds the Nyquist interval of its highest mode (``aliased`` attribute,
  :func:`granwave.api.propagate`) still holds the exact signal at its sample
  times and stays in the fits; each sample carries its ``aliased`` flag and
  ``nyquist_ratio``, and ``n_aliased`` counts them, so a report can say so.

Units: lengths d, times d/sqrt(E*/rho), speeds sqrt(E*/rho), forces E* d^2.
"""

from __future__ import annotations

from ..contact_models import options as CO

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..errors import InputError
from ..params import HeightsParams
from .fits import inverse_ci, inverse_slope, linear_fit, local_exponents, power_law_fit
from .front import features_of_signals

if TYPE_CHECKING:  # annotations only
    from ..model import Signal

DEFAULT_EDGE_HEIGHTS = HeightsParams.edge_heights  # defaults: granwave.params
DEFAULT_GROUP_RTOL = HeightsParams.group_tolerance
FEATURES = ("t_lead10", "t_peak", "t_zero", "amplitude", "width")


def group_heights(heights, rtol: float = DEFAULT_GROUP_RTOL) -> np.ndarray:
    """Group index (0, 1, ... in increasing height) of each height.

    A new group starts wherever a height exceeds the previous (sorted) one by
    more than ``rtol`` times the previous one.
    """
    h = np.asarray(heights, dtype=float)
    order = np.argsort(h, kind="stable")
    hs = h[order]
    new = np.concatenate([[False], np.diff(hs) > rtol * hs[:-1]])
    groups = np.empty(h.size, dtype=np.int64)
    groups[order] = np.cumsum(new)
    return groups


def common_attr(signals: Sequence[Signal], labels: Sequence[str], key: str, *, rtol: float = 0.0):
    """The common value of attribute ``key`` (None if no signal has it); refuse a mix."""
    values = [s.attrs.get(key) for s in signals]
    have = [v is not None for v in values]
    if not any(have):
        return None
    if not all(have):
        missing = labels[have.index(False)]
        raise InputError(f"{missing}: no {key!r} attribute while other signals have one")
    ref = values[0]
    for v, lab in zip(values, labels):
        if isinstance(ref, (int, float)) and not isinstance(ref, bool):
            same = math.isclose(float(v), float(ref), rel_tol=rtol, abs_tol=0.0) if rtol else float(v) == float(ref)
        else:
            same = v == ref
        if not same:
            raise InputError(f"mixed {key}: {labels[0]} has {key}={ref!r}, {lab} has {key}={v!r}")
    return ref


#: What the signals of one height series must share, among those that record it: one kind of
#: column (dimension, friction, Poisson ratio, scene kind, prestress, contact law, lateral width).
STUDY_ATTRS = ("dim", "friction", "poisson", "kind", "prestress", "contact_law", "lateral_width")
#: Relative spread of lateral widths within one series: a prepared packing's width follows from
#: its drawn radii and the config's width through the aspect (a few per cent apart), a series
#: of another width is a factor apart.
WIDTH_RTOL = 0.1


def one_study(signals: Sequence[Signal], labels: Sequence[str], *, what: str,
              source_kind: str = "normal") -> None:
    """Refuse (InputError, one line) signals that do not make one height series of ``what``:
    another source kind than ``source_kind`` (a shear signal is no compressional front), a mix
    of STUDY_ATTRS, or one packing counted twice (the same ``packing_digest``: the same file,
    or two signals of one packing, would enter the statistics as two packings)."""
    for s, lab in zip(signals, labels):
        kind = s.attrs.get("source_kind", "normal")
        if kind != source_kind:
            raise InputError(f"{lab}: a {kind} signal (source_kind {kind}): {what} takes "
                             f"{source_kind} signals only")
    for key in STUDY_ATTRS:
        have = [(s, lab) for s, lab in zip(signals, labels) if s.attrs.get(key) not in (None, "none")]
        if key == "contact_law" and have:  # a file that names no law is of the default, Hertz
            have = [(_with_default(s, key, CO.KINDS["normal"]["default"]), lab) for s, lab in zip(signals, labels)]
        if have:
            common_attr([s for s, _ in have], [lab for _, lab in have], key,
                        rtol=WIDTH_RTOL if key == "lateral_width" else 0.0)
    seen = {}
    for s, lab in zip(signals, labels):
        digest = s.attrs.get("packing_digest")
        if not isinstance(digest, str) or digest in ("", "none"):
            continue
        if digest in seen:
            raise InputError(f"{seen[digest]} and {lab} are signals of one packing (packing_digest "
                             f"{digest}): each packing counts once in {what}")
        seen[digest] = lab
    older = {key: [lab for s, lab in zip(signals, labels) if s.attrs.get(key) in (None, "", "none")]
             for key in OLDER_ATTRS}
    older = {key: labs for key, labs in older.items() if labs}
    if older:
        import warnings

        from ..errors import OlderFileWarning

        named = "; ".join(f"{_some(labs)} record{'s' if len(labs) == 1 else ''} no {key} ({OLDER_ATTRS[key]})"
                          for key, labs in older.items())
        warnings.warn(OlderFileWarning(
            f"{named}: written by an older granwave, not checked in {what}; remake them from their "
            "packings (granwave linearize, then propagate) to have them checked"), stacklevel=2)


#: Attributes an older signal may lack, and what goes unchecked without them.
OLDER_ATTRS = {"lateral_width": "its width not compared", "packing_digest": "one packing given twice not seen"}


def _some(labels) -> str:
    """``a.h5``, ``a.h5 and b.h5``, ``a.h5 and 4 more``: a few names on one line."""
    labels = list(labels)
    if len(labels) <= 2:
        return " and ".join(labels)
    return f"{labels[0]} and {len(labels) - 1} more"


def _with_default(signal, key: str, value):
    """``signal`` itself where it records ``key``, else a stand-in whose attrs give ``value``."""
    if signal.attrs.get(key) not in (None, "none"):
        return signal
    from types import SimpleNamespace

    return SimpleNamespace(attrs={**signal.attrs, key: value})


def _pick_edge_groups(group_heights_: np.ndarray, targets: tuple[float, float]) -> tuple[int, int]:
    """The two distinct groups nearest to the two target heights (lower target first)."""
    lo_t, hi_t = sorted(targets)
    g_lo = int(np.argmin(np.abs(group_heights_ - lo_t)))
    rest = [g for g in range(group_heights_.size) if g != g_lo]
    g_hi = rest[int(np.argmin(np.abs(group_heights_[rest] - hi_t)))]
    return tuple(sorted((g_lo, g_hi)))


def _speeds(L: np.ndarray, feats: dict[str, np.ndarray], mask: np.ndarray, suffix: str) -> dict:
    out = {}
    for name, key in (("c_tof", "t_lead10"), ("c_peak", "t_peak"), ("c_zero", "t_zero")):
        fit = linear_fit(L[mask], feats[key][mask], what=f"{key} against height")
        c, dc = inverse_slope(fit)
        out[name + suffix] = c
        out[name + suffix + "_err"] = dc
        out[name + suffix + "_ci95"] = list(inverse_ci(fit))  # Student t, n − 2 (granwave.analysis.fits)
        out["t0_" + key + suffix] = fit.intercept  # arrival-time offset at L = 0
    return out


def height_series_from_features(heights, features: Sequence[dict], *,
                                edge_heights: tuple[float, float] = DEFAULT_EDGE_HEIGHTS,
                                group_rtol: float = DEFAULT_GROUP_RTOL) -> dict:
    """Speeds, exponents and per-height means from per-sample front features.

    ``heights``: source-detector distance of each sample (d); ``features``:
    one :meth:`FrontFeatures.as_dict` per sample (keys t_lead10, t_peak,
    t_zero, amplitude, width at least). Returns a JSON-ready dict (see the
    module docstring for every choice).
    """
    L = np.asarray(heights, dtype=float)
    if L.size == 0:
        raise InputError("no signals given")
    if len(features) != L.size:
        raise InputError("one feature set per height is needed")
    if not np.all(np.isfinite(L)) or np.any(L <= 0):
        raise InputError("heights must be positive and finite")
    if not 0 <= group_rtol < 1:
        raise InputError(f"group_rtol must be in [0, 1), got {group_rtol}")
    feats = {k: np.array([float(f[k]) for f in features]) for k in FEATURES}
    feats["amplitude"] = np.abs(feats["amplitude"])
    groups = group_heights(L, group_rtol)
    n_groups = int(groups.max()) + 1
    if n_groups < 2:
        raise InputError(
            f"need signals from at least two different heights (all {L.size} signal(s) are at "
            f"L ≈ {L.mean():.4g}, grouped with relative tolerance {group_rtol:g})")

    g_height = np.array([L[groups == g].mean() for g in range(n_groups)])
    g_count = np.bincount(groups, minlength=n_groups)

    def gstat(values, fn):
        return np.array([fn(values[groups == g]) for g in range(n_groups)])

    def sd(v):
        return float(np.std(v, ddof=1)) if v.size > 1 else math.nan

    per_height = {"height": g_height, "count": g_count,
                  "height_std": gstat(L, sd)}
    for k in FEATURES:
        per_height[k] = gstat(feats[k], np.mean)
        per_height[k + "_std"] = gstat(feats[k], sd)

    g_lo, g_hi = _pick_edge_groups(g_height, edge_heights)
    edge_mask = (groups == g_lo) | (groups == g_hi)
    out = {
        "n_signals": int(L.size),
        "n_heights": n_groups,
        "group_rtol": float(group_rtol),
        "edge_heights_requested": [float(h) for h in edge_heights],
        "edge_heights": [float(g_height[g_lo]), float(g_height[g_hi])],
    }
    out.update(_speeds(L, feats, edge_mask, ""))
    out.update(_speeds(L, feats, np.ones(L.size, bool), "_all"))

    amp = power_law_fit(L, feats["amplitude"], what="amplitude against height")
    wid = power_law_fit(L, feats["width"], what="width against height")
    out.update(gamma=-amp.exponent, gamma_err=amp.exponent_err, amplitude_prefactor=amp.prefactor,
               chi=wid.exponent, chi_err=wid.exponent_err, width_prefactor=wid.prefactor,
               gamma_ci95=[-amp.exponent_ci95[1], -amp.exponent_ci95[0]],
               chi_ci95=list(wid.exponent_ci95))
    h_mid, a_loc = local_exponents(g_height, per_height["amplitude"])
    _, w_loc = local_exponents(g_height, per_height["width"])
    out.update(heights_local=h_mid, gamma_local=-a_loc, chi_local=w_loc)
    out["per_height"] = per_height
    out["samples"] = [{"height": float(h), **{k: float(feats[k][i]) for k in FEATURES}}
                      for i, h in enumerate(L)]
    return out


def height_series(signals: Sequence[Signal], *, labels: Sequence[str] | None = None,
                  edge_heights: tuple[float, float] = DEFAULT_EDGE_HEIGHTS,
                  group_rtol: float = DEFAULT_GROUP_RTOL, **front_kw) -> dict:
    """Height-series analysis of signals (docs/method.md §9); see the module docstring.

    ``labels`` name the signals in error messages (file names in the CLI).
    ``front_kw`` (peak_fraction, lead_fraction, ...) go to
    :func:`granwave.analysis.front.front_features` unchanged (its defaults
    otherwise), so every signal is analysed by the same rule.
    Refuses (InputError) an empty list, signals at different pressures or
    with different initial conditions, fewer than two nominal heights, and a
    signal whose first pulse is not complete in the record.
    """
    signals = list(signals)
    if not signals:
        raise InputError("no signals given")
    labels = list(labels) if labels is not None else [f"signal {i}" for i in range(len(signals))]
    pressure = common_attr(signals, labels, "pressure", rtol=1e-9)
    ic = common_attr(signals, labels, "ic")
    features = features_of_signals(signals, labels, **front_kw)
    out = height_series_from_features([s.height for s in signals], features,
                                      edge_heights=edge_heights, group_rtol=group_rtol)
    out = {"pressure": pressure, "ic": ic, "front_options": dict(front_kw), **out}
    for i, lab in enumerate(labels):
        out["samples"][i]["source"] = str(lab)
    flags = [bool(sig.attrs.get("aliased", False)) for sig in signals]
    for i, sig in enumerate(signals):
        ratio = sig.attrs.get("nyquist_ratio")
        out["samples"][i]["aliased"] = flags[i]
        out["samples"][i]["nyquist_ratio"] = None if ratio is None else float(ratio)
    out["n_aliased"] = int(sum(flags))
    return out
