"""The front against distance L and its approach to the effective-medium speed c_l.

Input: signals of containers of several heights L (one pressure, one initial condition,
one or more packings per height) and, per signal, the packing's own effective-medium
speeds c_l = sqrt(C22/Phi3*) and c_t (``granwave analyze moduli``).

The rule (also in ``docs/continuum.md`` and ``granwave analyze continuum --help``)
---------------------------------------------------------------------------------
* **Front features** of every signal: :func:`granwave.analysis.front.front_features`
  (10 % edge t_lead10, peak t_peak, zero crossing t_zero, amplitude, width).
* **Nominal heights**: :func:`granwave.analysis.heights.group_heights`; per height the
  mean, std and standard error (:func:`granwave.analysis.ensemble.describe`) of every
  feature, of L, c_l and c_t, and of the *apparent* speeds L / t of each packing
  (``c_tof_apparent`` = L / t_lead10, ``c_peak_apparent``, ``c_zero_apparent``). A height
  with a single packing takes the relative scatter pooled over the other heights
  (``per_height.error_model`` = "pooled"), never zero.
* **Local speeds against L**: between consecutive nominal heights,
  c = (L2 − L1) / (t2 − t1) from the group means, at the geometric mean height;
  δc = c sqrt(δt1² + δt2² + (δL1² + δL2²) c^-2) / (t2 − t1) with the standard errors
  (independent packings). ``ratio`` = c_tof_local / c_l with c_l the mean of every
  packing of the two heights, its error both errors propagated.
* **Local exponents**: γ_eff(L) = −d ln|A| / d ln L and α_eff(L) = d ln W / d ln L
  between consecutive heights with errors
  (:func:`granwave.analysis.ensemble.local_exponents_of_means`).
* **Global fits**: :func:`granwave.analysis.heights.height_series_from_features`
  (c_tof, c_peak, c_zero between the two smallest heights and over all heights, γ, α).
* **Approach to c_l**: :func:`approach_fit` of the local ratio against L.
* **Errors** (issue #47): the local errors use the scatter model shared across heights
  (:func:`scatter_model`: each arrival time's scatter one power law of L); a bootstrap over the
  packings within each height runs through the chain (:func:`resample_local`: means, local
  speeds, ratios and their errors, the approach fit and L*; ``local.*_boot_err``,
  ``approach.L_star_boot_ci``); ``ratio_err`` is the larger of the propagated and the
  bootstrap error. ``packings`` / ``packings_per_height``: the rule of
  :mod:`granwave.analysis.packings` (10 packings per height for fits, 5 for a height's numbers).
* **Candidates** (:func:`continuum`): the arrival time at edge levels of 2 … 50 %, the peak
  and the first lobe's energy centroid (:func:`arrival_times`), their local speeds and the L*
  of each at tolerances 3, 5, 10 % and c_l references × 0.99, 1, 1.01
  (:func:`candidate_lengths`).
* **Bulk c_l** (reported beside, not used by default): each packing's c_l comes from its
  global C22, which includes the softer layers at the two walls; in series with the bulk
  they add a fixed compliance, so 1/c_l² = 1/c_l∞² + b/L (:func:`bulk_speed`, fitted over
  the packings). ``local.ratio_bulk`` = c_tof_local / c_l∞ and ``approach_bulk`` its fit.

Units: lengths d, times d/sqrt(E*/rho), speeds sqrt(E*/rho), forces E* d^2.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Sequence

import numpy as np
from scipy import optimize, stats

from ..errors import InputError
from .ensemble import describe, local_exponents_of_means
from .front import features_of_signals
from .heights import FEATURES, common_attr, group_heights, height_series_from_features, one_study
from .packings import MIN_PACKINGS, packing_check

if TYPE_CHECKING:
    from ..model import Signal

DEFAULT_TOLERANCE = 0.05
SPEEDS = (("tof", "t_lead10"), ("peak", "t_peak"), ("zero", "t_zero"))


def _power_approach(L, a, beta):
    return 1.0 + a * np.power(L, -beta)


def _free_limit(L, r_inf, a, beta):
    return r_inf + a * np.power(L, -beta)


def approach_fit(L, ratio, err=None, *, tolerance: float = DEFAULT_TOLERANCE,
                 confidence: float = 0.95, draws: int = 4000, seed: int = 0) -> dict:
    """Fit ratio(L) = 1 + a L^-beta and give L*, where |ratio − 1| = tolerance.

    ``L``, ``ratio``, ``err``: distances (d), the measured c_tof / c_l and its standard
    error (None or NaN: unweighted). ``scipy.optimize.curve_fit``; confidence intervals
    (level ``confidence``) of a and beta from the Student t of n − 2 degrees of freedom
    times the standard errors (errors taken as absolute when every err is known, else
    scaled by the scatter). L* = (|a| / tolerance)^(1/beta); its interval from ``draws``
    parameter sets drawn from the fit's normal distribution, its covariance widened by
    (t/z)² to the Student-t width (percentiles, seeded).
    With four or more points also ratio = r_inf + a L^-beta (the limit free).

    ``status``: ``reached`` when the measured ratio at the largest L is within tolerance of
    1 by more than two standard errors (then L* <= L_max); ``beyond`` when it is above
    tolerance there by more than two errors: ``L_star_lower_bound`` = the largest L
    measured (L* lies beyond it, and L* from the fit is an extrapolation);
    ``undecided`` otherwise (the error bar at L_max straddles the tolerance).
    """
    L = np.asarray(L, float)
    r = np.asarray(ratio, float)
    e = np.full(L.shape, np.nan) if err is None else np.asarray(err, float)
    ok = np.isfinite(L) & np.isfinite(r) & (L > 0)
    L, r, e = L[ok], r[ok], e[ok]
    if L.size < 3:
        raise InputError(f"the approach fit needs at least 3 distances (got {L.size})")
    known = bool(np.all(np.isfinite(e) & (e > 0)))
    sigma = e if known else None
    out = {"model": "c_tof/c_l = 1 + a L^-beta", "tolerance": float(tolerance),
           "confidence": float(confidence), "n": int(L.size), "weighted": known,
           "L_max": float(L.max())}
    # status from the data alone
    i = int(np.argmax(L))
    dev, de = abs(r[i] - 1.0), (e[i] if np.isfinite(e[i]) else 0.0)
    if dev + 2 * de < tolerance:
        out["status"] = "reached"
    elif dev - 2 * de > tolerance:
        out["status"] = "beyond"
        out["L_star_lower_bound"] = float(L.max())
    else:
        out["status"] = "undecided"
    dof = L.size - 2
    tq = float(stats.t.ppf(0.5 + confidence / 2, dof)) if dof > 0 else math.nan
    a0 = float((r[0] - 1.0) * L[0] ** 0.5)
    try:
        p, cov = optimize.curve_fit(_power_approach, L, r, p0=(a0 if a0 else 0.1, 0.5),
                                    sigma=sigma, absolute_sigma=known, maxfev=20000)
    except (RuntimeError, ValueError, optimize.OptimizeWarning) as exc:
        out.update(fit_error=str(exc), a=math.nan, beta=math.nan, L_star=math.nan)
        return out
    perr = np.sqrt(np.diag(cov)) if np.all(np.isfinite(cov)) else np.full(2, np.nan)
    a, beta = (float(v) for v in p)
    out.update(a=a, a_err=float(perr[0]), beta=beta, beta_err=float(perr[1]),
               beta_ci=[float(beta - tq * perr[1]), float(beta + tq * perr[1])],
               a_ci=[float(a - tq * perr[0]), float(a + tq * perr[0])],
               chi2=float(np.sum(((r - _power_approach(L, a, beta)) / (e if known else 1.0)) ** 2)))
    with np.errstate(over="ignore", divide="ignore"):
        out["L_star"] = float(np.power(abs(a) / tolerance, 1.0 / beta)) if beta > 0 else math.inf
    if np.all(np.isfinite(cov)):
        rng = np.random.default_rng(seed)
        # widened by (t / z)^2 so that the interval has the Student-t width of a and beta's
        z = float(stats.norm.ppf(0.5 + confidence / 2))
        widen = (tq / z) ** 2 if math.isfinite(tq) else 1.0
        draw = rng.multivariate_normal(p, cov * widen, size=draws)
        good = draw[:, 1] > 0
        with np.errstate(over="ignore", divide="ignore"):
            ls = (np.abs(draw[good, 0]) / tolerance) ** (1.0 / draw[good, 1])
        q = (1 - confidence) / 2
        out["L_star_ci"] = [float(np.quantile(ls, q)), float(np.quantile(ls, 1 - q))] if ls.size else \
            [math.nan, math.nan]
        out["L_star_ci_draws_with_beta_positive"] = int(good.sum())
    out["L_star_extrapolated"] = bool(out["L_star"] > L.max())
    if L.size >= 4:
        try:
            pf, cf = optimize.curve_fit(_free_limit, L, r, p0=(1.0, a, max(beta, 0.1)), sigma=sigma,
                                        absolute_sigma=known, maxfev=20000)
            ef = np.sqrt(np.diag(cf))
            tf = float(stats.t.ppf(0.5 + confidence / 2, L.size - 3)) if L.size > 3 else math.nan
            out["free_limit"] = {"r_inf": float(pf[0]), "r_inf_err": float(ef[0]),
                                 "r_inf_ci": [float(pf[0] - tf * ef[0]), float(pf[0] + tf * ef[0])],
                                 "a": float(pf[1]), "beta": float(pf[2]), "beta_err": float(ef[2])}
        except (RuntimeError, ValueError, optimize.OptimizeWarning) as exc:
            out["free_limit"] = {"fit_error": str(exc)}
    return out


def bulk_speed(L, c_l) -> dict:
    """c_l∞ of 1/c_l² = 1/c_l∞² + b/L fitted over packings (heights L, speeds c_l; NaN left out).

    The wall layers' compliance in series with the bulk's: C22(L)⁻¹ = C22∞⁻¹ + (2δ/L)
    (C_w⁻¹ − C22∞⁻¹) at a bulk density independent of L. ``numpy.polyfit`` in 1/L, its
    covariance scaled by the misfit; ``c_l_inf_err`` one standard error. NaN with fewer
    than three packings or two distinct heights.
    """
    L = np.asarray(L, float)
    c = np.asarray(c_l, float)
    ok = np.isfinite(L) & np.isfinite(c) & (L > 0) & (c > 0)
    nan = {"model": "1/c_l^2 = 1/c_l_inf^2 + b/L", "c_l_inf": math.nan, "c_l_inf_err": math.nan,
           "b": math.nan, "n": int(ok.sum())}
    if ok.sum() < 3 or np.unique(np.round(L[ok], 6)).size < 2:
        return nan
    coef, cov = np.polyfit(1.0 / L[ok], 1.0 / c[ok] ** 2, 1, cov=True)
    if coef[1] <= 0:
        return nan
    ci = float(coef[1] ** -0.5)
    return {**nan, "c_l_inf": ci, "c_l_inf_err": float(0.5 * ci**3 * math.sqrt(cov[1, 1])),
            "b": float(coef[0])}


def _local_speed(L, Lerr, t, terr):
    """Speeds between consecutive rows: (L_mid, c, c_err) from means and standard errors."""
    dL, dt = np.diff(L), np.diff(t)
    c = dL / dt
    with np.errstate(invalid="ignore"):
        err = np.abs(c) / np.abs(dt) * np.sqrt(terr[1:] ** 2 + terr[:-1] ** 2
                                               + (Lerr[1:] ** 2 + Lerr[:-1] ** 2) / c**2)
    return np.sqrt(L[1:] * L[:-1]), c, err


def _pooled_where_thin(groups: Sequence[dict]) -> np.ndarray:
    """Each height's standard deviation; a height with a single packing (no scatter of its own)
    gets |mean| times the coefficient of variation pooled over the heights with two or more
    (weights n - 1). Counting it as exact instead gives it all the weight of a fit and too
    narrow intervals. The pooled relative scatter of the shorter heights overstates that of a
    taller one where the scatter falls with height (arrival-time jitter, as 1/sqrt(L)): the
    errors are then conservative. NaN where no height has two packings."""
    std = np.array([x["std"] for x in groups])
    dof = np.array([x["count"] - 1 for x in groups], float)
    mean = np.array([x["mean"] for x in groups])
    ok = (dof > 0) & np.isfinite(std) & np.isfinite(mean) & (mean != 0)
    if not ok.any():
        return std
    cv2 = np.sum(dof[ok] * (std[ok] / mean[ok]) ** 2) / np.sum(dof[ok])
    thin = ~(dof > 0)
    std[thin] = np.abs(mean[thin]) * math.sqrt(cv2)
    return std


def resample_local(g, L, times: dict, cl, std: dict, *, n_boot: int, seed: int = 0) -> dict:
    """Local speeds and c_tof/c_l of ``n_boot`` resamplings of the packings within each height.

    ``g``: each packing's height group; ``L``, ``cl``: per packing; ``times``: {speed name:
    per-packing arrival times}; ``std``: {name: per-height standard deviation} (pooled where a
    height is thin, :func:`_pooled_where_thin`), for ``cl`` and every time. A height with n ≥ 2
    packings is resampled with replacement, its deviations from its mean widened by
    sqrt(n / (n − 1)) (the resampled means then scatter with s²/n, not the plug-in
    (n − 1) s²/n²); a height with one packing cannot be resampled: its time and c_l are drawn
    about their values with the pooled standard deviation (its L is exact). Returns
    {"c_<name>": (n_boot x pairs), "c_l": ..., "ratio": ..., "height": ...}.
    """
    rng = np.random.default_rng(seed)
    n_g = int(g.max()) + 1
    members = [np.flatnonzero(g == k) for k in range(n_g)]
    counts = np.array([m.size for m in members])
    out = {f"c_{name}": np.empty((n_boot, n_g - 1)) for name in times}
    out.update(c_l=np.empty((n_boot, n_g - 1)), height=np.empty((n_boot, n_g - 1)))
    keys = ["L", "cl", *times]
    values = {"L": L, "cl": cl, **times}
    out["ratio_err"] = np.empty((n_boot, n_g - 1))
    first = next(iter(times))
    for b in range(n_boot):
        mean = {k: np.empty(n_g) for k in keys}
        sem = {k: np.empty(n_g) for k in keys}
        for k, m in enumerate(members):
            n = m.size
            if n > 1:
                j = m[rng.integers(0, n, n)]
                widen = math.sqrt(n / (n - 1))
                for q in keys:
                    x = values[q]
                    y = x[m].mean() + widen * (x[j] - x[m].mean())
                    mean[q][k] = y.mean()
                    sem[q][k] = y.std(ddof=1) / math.sqrt(n)
            else:
                mean["L"][k], sem["L"][k] = L[m[0]], 0.0
                for q in keys[1:]:
                    mean[q][k] = values[q][m[0]] + std[q][k] * rng.standard_normal()
                    sem[q][k] = std[q][k]
        for q in keys[1:]:
            sem[q] = scatter_model(mean["L"], sem[q] * np.sqrt(counts), counts) / np.sqrt(counts)
        dL = np.diff(mean["L"])
        for name in times:
            out[f"c_{name}"][b] = dL / np.diff(mean[name])
        w = counts.astype(float)
        out["c_l"][b] = (w[1:] * mean["cl"][1:] + w[:-1] * mean["cl"][:-1]) / (w[1:] + w[:-1])
        out["height"][b] = np.sqrt(mean["L"][1:] * mean["L"][:-1])
        # the ratio's error as the analysis computes it, from this resampling's own scatter
        with np.errstate(invalid="ignore", divide="ignore"):
            _, c, ce = _local_speed(mean["L"], sem["L"], mean[first], sem[first])
            cle = np.sqrt(w[1:] ** 2 * sem["cl"][1:] ** 2 + w[:-1] ** 2 * sem["cl"][:-1] ** 2) / (w[1:] + w[:-1])
            r = c / out["c_l"][b]
            out["ratio_err"][b] = np.abs(r) * np.hypot(ce / np.abs(c), cle / out["c_l"][b])
    with np.errstate(invalid="ignore", divide="ignore"):
        out["ratio"] = out["c_tof"] / out["c_l"]
    return out


def _L_star_draws(heights, ratios, err, tolerance, p0) -> np.ndarray:
    """L* = (|a| / tolerance)^(1/β) of ratio = 1 + a L^−β fitted to every row of ``ratios``
    (at the rows of ``heights``), weighted by the rows of ``err`` where all are known (None:
    unweighted); +inf where β ≤ 0, NaN where the fit fails."""
    out = np.full(len(ratios), np.nan)
    err = [None] * len(ratios) if err is None else err
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for i, (h, r, e) in enumerate(zip(heights, ratios, err)):
            ok = np.isfinite(h) & np.isfinite(r) & (h > 0)
            if ok.sum() < 3:
                continue
            sigma = e[ok] if e is not None and np.all(np.isfinite(e[ok]) & (e[ok] > 0)) else None
            try:
                p, _ = optimize.curve_fit(_power_approach, h[ok], r[ok], p0=p0, sigma=sigma,
                                          maxfev=5000)
            except (RuntimeError, ValueError, optimize.OptimizeWarning):
                continue
            with np.errstate(over="ignore", divide="ignore"):
                out[i] = (abs(p[0]) / tolerance) ** (1.0 / p[1]) if p[1] > 0 else math.inf
    return out


def scatter_model(L, std, counts) -> np.ndarray:
    """The scatter of a feature between packings as one power law of height, std = s L^q,
    fitted in log-log over the heights with two or more packings (weights 2 (n − 1), the
    inverse variance of ln std), evaluated at every height. Each height's own standard
    deviation from ten packings is uncertain by ~ 1/sqrt(2 (n − 1)) ≈ 24 %; weights taken
    from it favour the heights whose scatter happens to come out small and bias the fit (the
    approach fit's L* by +3 % in a synthetic study, docs/continuum.md). The model pools all
    heights. Returns ``std`` unchanged where fewer than three heights have a positive scatter
    of their own."""
    L = np.asarray(L, float)
    std = np.asarray(std, float)
    dof = np.asarray(counts, float) - 1
    own = (dof > 0) & np.isfinite(std) & (std > 0) & (L > 0)
    if own.sum() < 3:
        return std
    coef = np.polyfit(np.log(L[own]), np.log(std[own]), 1, w=np.sqrt(2 * dof[own]))
    return np.exp(np.polyval(coef, np.log(L)))


def continuum_from_features(heights, features: Sequence[dict], c_l, c_t=None, *,
                            tolerance: float = DEFAULT_TOLERANCE, group_rtol: float = 0.05,
                            bootstrap: int = 200, seed: int = 0, confidence: float = 0.95) -> dict:
    """The analysis of the module docstring from per-sample front features.

    ``heights``: L of each sample (d); ``features``: :meth:`FrontFeatures.as_dict` per
    sample; ``c_l``, ``c_t``: each sample's effective-medium speeds (NaN where unknown);
    ``bootstrap``: resamplings of the packings within each height, through the chain (arrival
    times, local speeds, ratios, the approach fit and L*; :func:`resample_local`).
    """
    L = np.asarray(heights, float)
    cl = np.asarray(c_l, float)
    ct = np.full(L.shape, np.nan) if c_t is None else np.asarray(c_t, float)
    if not (L.shape == cl.shape == ct.shape) or len(features) != L.size:
        raise InputError("one height, one c_l (and c_t) and one feature set per signal are needed")
    feats = {k: np.array([abs(float(f[k])) if k == "amplitude" else float(f[k]) for f in features])
             for k in FEATURES}
    g = group_heights(L, group_rtol)
    n_g = int(g.max()) + 1
    if n_g < 2:
        raise InputError("need signals from at least two different heights")
    per = {}

    def put(name, values):
        d = [describe(values[g == k]) for k in range(n_g)]
        per[name] = np.array([x["mean"] for x in d])
        per[name + "_std"] = _pooled_where_thin(d)
        per[name + "_sem"] = per[name + "_std"] / np.sqrt([max(x["count"], 1) for x in d])
        return d

    counts = np.array([x["count"] for x in put("height", L)])
    per["count"] = counts
    # which heights borrow their scatter from the others (one packing: no scatter of their own)
    per["error_model"] = np.array(["pooled" if n < 2 else "sample" for n in counts])
    for k in FEATURES:
        put(k, feats[k])
    put("c_l", cl)
    put("c_t", ct)
    for name, key in SPEEDS:
        put(f"c_{name}_apparent", L / feats[key])
    with np.errstate(invalid="ignore", divide="ignore"):
        per["ratio_apparent"] = per["c_tof_apparent"] / per["c_l"]
        per["ratio_apparent_err"] = np.abs(per["ratio_apparent"]) * np.hypot(
            per["c_tof_apparent_sem"] / per["c_tof_apparent"], per["c_l_sem"] / per["c_l"])

    local = {}
    # each packing's (L, t) pair is exact; the scatter of L between packings enters through the
    # means (unknown with one packing per height everywhere: then only t's scatter counts)
    Lm, Le = per["height"], np.where(np.isfinite(per["height_sem"]), per["height_sem"], 0.0)
    root_n = np.sqrt(np.maximum(counts, 1))
    for name, key in SPEEDS:
        # the errors that weight the fits: the scatter model shared across heights
        per[key + "_std_model"] = scatter_model(Lm, per[key + "_std"], counts)
        mid, c, ce = _local_speed(Lm, Le, per[key], per[key + "_std_model"] / root_n)
        local["height"] = mid
        local[f"c_{name}"] = c
        local[f"c_{name}_err"] = ce
    pair_cl = np.array([cl[(g == k) | (g == k + 1)] for k in range(n_g - 1)], dtype=object)
    cl_pair = [describe(v) for v in pair_cl]
    local["c_l"] = np.array([d["mean"] for d in cl_pair])
    # the pair's c_l error from the scatter model (as in the bootstrap), counts as weights
    cl_sem = scatter_model(Lm, per["c_l_std"], counts) / root_n
    w = counts.astype(float)
    local["c_l_err"] = np.sqrt(w[1:] ** 2 * cl_sem[1:] ** 2 + w[:-1] ** 2 * cl_sem[:-1] ** 2) / (w[1:] + w[:-1])
    with np.errstate(invalid="ignore", divide="ignore"):
        local["ratio"] = local["c_tof"] / local["c_l"]
        local["ratio_err"] = np.abs(local["ratio"]) * np.hypot(
            local["c_tof_err"] / np.abs(local["c_tof"]), local["c_l_err"] / local["c_l"])
    n_boot = int(bootstrap) if n_g > 1 else 0
    boot = None
    if n_boot > 1:
        boot = resample_local(g, L, {name: feats[key] for name, key in SPEEDS}, cl,
                              {"cl": scatter_model(Lm, per["c_l_std"], counts),
                               **{name: per[key + "_std_model"] for name, key in SPEEDS}},
                              n_boot=n_boot, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            for name, _ in SPEEDS:
                local[f"c_{name}_boot_err"] = np.nanstd(boot[f"c_{name}"], axis=0, ddof=1)
            local["ratio_boot_err"] = np.nanstd(boot["ratio"], axis=0, ddof=1)
        # the error of each ratio: the larger of the propagated one and the bootstrap's
        local["ratio_err_propagated"] = local["ratio_err"]
        local["ratio_err"] = np.fmax(local["ratio_err"], local["ratio_boot_err"])
    bulk = bulk_speed(L, cl)
    with np.errstate(invalid="ignore", divide="ignore"):
        local["ratio_bulk"] = local["c_tof"] / bulk["c_l_inf"]
        local["ratio_bulk_err"] = np.abs(local["ratio_bulk"]) * np.hypot(
            local["c_tof_err"] / np.abs(local["c_tof"]), bulk["c_l_inf_err"] / bulk["c_l_inf"])
    amp = local_exponents_of_means(Lm, per["amplitude"], per["amplitude_sem"])
    wid = local_exponents_of_means(Lm, per["width"], per["width_sem"])
    local["gamma_eff"] = -amp["exponent"]
    local["gamma_eff_err"] = amp["exponent_err"]
    local["chi_eff"] = wid["exponent"]
    local["chi_eff_err"] = wid["exponent_err"]

    series = height_series_from_features(L, features, edge_heights=(float(Lm[0]), float(Lm[1])),
                                         group_rtol=group_rtol)
    out = {"n_signals": int(L.size), "n_heights": n_g,
           "c_l": describe(cl), "c_t": describe(ct), "c_l_bulk": bulk,
           "global": {k: v for k, v in series.items() if k not in ("per_height", "samples")},
           "per_height": per, "local": local}
    err = local["ratio_err"] if np.all(np.isfinite(local["ratio_err"])) else None
    try:
        out["approach"] = approach_fit(local["height"], local["ratio"], err, tolerance=tolerance)
    except InputError as exc:
        out["approach"] = {"fit_error": str(exc), "status": "undecided"}
    app = out["approach"]
    if boot is not None and math.isfinite(app.get("beta", math.nan)):
        # L* of every resampling, with the weights of the fit itself: the whole chain's interval
        draws = _L_star_draws(boot["height"], boot["ratio"], None if err is None else boot["ratio_err"],
                              tolerance, (app["a"], app["beta"]))
        good = draws[~np.isnan(draws)]
        q = (1 - confidence) / 2
        app["bootstrap"] = n_boot
        app["L_star_boot_failed"] = int(np.isnan(draws).sum())
        if good.size > 1:
            lo, med, hi = np.quantile(good, [q, 0.5, 1 - q], method="inverted_cdf")
            app["L_star_boot_ci"] = [float(lo), float(hi)]
            app["L_star_boot_median"] = float(med)
            app["L_star_boot_beta_nonpositive"] = int(np.isinf(good).sum())
    out["packings"] = packing_check(counts, per["height"], fit=True)
    out["packings_per_height"] = packing_check(counts, per["height"], fit=False)
    per["quotable"] = counts >= MIN_PACKINGS
    out["approach_bulk"] = (_safe_fit(local["height"], local["ratio_bulk"], local["ratio_bulk_err"],
                                      tolerance) if math.isfinite(bulk["c_l_inf"])
                            else {"fit_error": "no bulk c_l", "status": "undecided"})
    out["approach_apparent"] = _safe_fit(per["height"], per["ratio_apparent"],
                                         per["ratio_apparent_err"], tolerance)
    return out


def _safe_fit(L, r, e, tolerance):
    try:
        return approach_fit(L, r, e if np.all(np.isfinite(e) & (e > 0)) else None, tolerance=tolerance)
    except InputError as exc:
        return {"fit_error": str(exc), "status": "undecided"}


EDGE_LEVELS = (0.02, 0.05, 0.1, 0.2, 0.5)
TOLERANCES = (0.03, 0.05, 0.10)
CL_SCALES = (0.99, 1.0, 1.01)


def arrival_times(time, force, levels: Sequence[float] = EDGE_LEVELS, **front_kw) -> dict:
    """Every candidate arrival time of one signal: the leading edge at each fraction in
    ``levels`` of the first peak (``edge_<level>``, :func:`granwave.analysis.front.front_features`
    with that ``lead_fraction``), the peak (``peak``) and the energy centroid of the first lobe,
    Σ t F² / Σ F² over t ≤ t_zero (``energy``)."""
    from .front import front_features

    front_kw = {k: v for k, v in front_kw.items() if k != "lead_fraction"}
    out = {}
    for lev in levels:
        f = front_features(time, force, lead_fraction=float(lev), **front_kw)
        out[f"edge_{lev:g}"] = f.t_lead10
    out["peak"] = f.t_peak
    t, y = np.asarray(time, float), np.asarray(force, float)
    lobe = t <= f.t_zero
    e = y[lobe] ** 2
    out["energy"] = float(np.sum(t[lobe] * e) / np.sum(e))
    return out


def candidate_lengths(heights, times: dict, c_l, *, tolerances: Sequence[float] = TOLERANCES,
                      cl_scales: Sequence[float] = CL_SCALES, group_rtol: float = 0.05,
                      draws: int = 1000) -> dict:
    """How each candidate "L*" moves with the picking rule, the tolerance and the c_ℓ reference.

    ``times``: {rule: per-packing arrival times} (:func:`arrival_times`); ``c_l``: per packing.
    Per rule, the local speed ΔL/Δt between consecutive heights (group means, errors from the
    scatter model shared across heights, :func:`scatter_model`) and its ratio to c_ℓ (the
    mean of both heights' packings) times each scale in ``cl_scales``; the approach fit
    (:func:`approach_fit`) at each tolerance. Returns {"speeds": {rule: {height, c, c_err,
    ratio, ratio_err}}, "table": [one row per rule, tolerance and c_ℓ scale: L_star, its
    interval, status, beta]}.
    """
    L = np.asarray(heights, float)
    cl = np.asarray(c_l, float)
    g = group_heights(L, group_rtol)
    n_g = int(g.max()) + 1
    counts = np.array([(g == k).sum() for k in range(n_g)])
    root_n = np.sqrt(counts)
    Lm = np.array([L[g == k].mean() for k in range(n_g)])
    Le = np.array([describe(L[g == k])["sem"] for k in range(n_g)])
    Le = np.where(np.isfinite(Le), Le, 0.0)
    cl_pair = np.array([np.nanmean(cl[(g == k) | (g == k + 1)]) for k in range(n_g - 1)])
    speeds, table = {}, []
    for rule, t in times.items():
        t = np.asarray(t, float)
        d = [describe(t[g == k]) for k in range(n_g)]
        std = scatter_model(Lm, _pooled_where_thin(d), counts)
        mid, c, ce = _local_speed(Lm, Le, np.array([x["mean"] for x in d]), std / root_n)
        with np.errstate(invalid="ignore", divide="ignore"):
            speeds[rule] = {"height": mid, "c": c, "c_err": ce, "ratio": c / cl_pair,
                            "ratio_err": ce / cl_pair}
        for scale in cl_scales:
            r, e = c / (cl_pair * scale), ce / (cl_pair * scale)
            for tol in tolerances:
                row = {"rule": rule, "tolerance": float(tol), "c_l_scale": float(scale)}
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        fit = approach_fit(mid, r, e if np.all(np.isfinite(e) & (e > 0)) else None,
                                           tolerance=tol, draws=draws)
                except InputError as exc:
                    fit = {"fit_error": str(exc), "status": "undecided", "L_star": math.nan}
                row.update({k: fit.get(k) for k in ("L_star", "L_star_ci", "status", "beta",
                                                      "L_star_extrapolated", "fit_error")
                            if k in fit})
                table.append(row)
    return {"speeds": speeds, "table": table, "edge_levels": [float(x) for x in EDGE_LEVELS],
            "tolerances": [float(x) for x in tolerances], "c_l_scales": [float(x) for x in cl_scales]}


def continuum(signals: Sequence["Signal"], c_l, c_t=None, *, labels: Sequence[str] | None = None,
              tolerance: float = DEFAULT_TOLERANCE, group_rtol: float = 0.05, bootstrap: int = 200,
              seed: int = 0, candidates: bool = True, c_l_kind: str = "given",
              c_l_by_kind: dict | None = None, **front_kw) -> dict:
    """:func:`continuum_from_features` of signals (one pressure, one initial condition).

    ``c_l_kind`` names the c_l given (``slab`` or ``cell`` from `analyze moduli`, recorded as
    ``c_l_kind``); ``c_l_by_kind`` ({kind: per-signal c_l}) adds every kind's summary
    (``c_l_by_kind``) and per-sample values beside the one used.
    """
    signals = list(signals)
    if not signals:
        raise InputError("no signals given")
    labels = list(labels) if labels is not None else [f"signal {i}" for i in range(len(signals))]
    pressure = common_attr(signals, labels, "pressure", rtol=1e-9)
    ic = common_attr(signals, labels, "ic")
    one_study(signals, labels, what="analyze continuum (compressional fronts)")
    feats = features_of_signals(signals, labels, **front_kw)
    out = continuum_from_features([s.height for s in signals], feats, c_l, c_t,
                                  tolerance=tolerance, group_rtol=group_rtol, bootstrap=bootstrap,
                                  seed=seed)
    if candidates:
        arr = [arrival_times(s.time, s.force, **front_kw) for s in signals]
        out["candidates"] = candidate_lengths([s.height for s in signals],
                                              {k: [a[k] for a in arr] for k in arr[0]}, c_l,
                                              group_rtol=group_rtol)
    kinds = {k: np.asarray(v, float) for k, v in (c_l_by_kind or {}).items()}
    out["c_l_kind"] = c_l_kind
    out["c_l_by_kind"] = {k: describe(v) for k, v in kinds.items()}
    return {"pressure": pressure, "ic": ic, "front_options": dict(front_kw), **out,
            "samples": [{"source": str(lab), "height": s.height, "c_l": float(a),
                         **{f"c_l_{k}": float(v[i]) for k, v in kinds.items()},
                         **{k: float(f[k]) for k in FEATURES}}
                        for i, (lab, s, a, f) in enumerate(zip(labels, signals,
                                                                np.asarray(c_l, float), feats))]}
