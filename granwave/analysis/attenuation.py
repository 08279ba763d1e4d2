"""Attenuation alpha(omega), quality factor Q(omega) and phase velocity c(omega) of the
coherent signal, from ensemble-averaged signals at several source-detector distances.

The rule (also in ``docs/continuum.md`` and ``granwave analyze attenuation --help``)
-----------------------------------------------------------------------------------
1. **Coherent signals.** Signals are grouped into nominal heights L
   (:func:`granwave.analysis.heights.group_heights`) and averaged per height
   (:func:`granwave.analysis.ensemble.ensemble_average`): the packing-to-packing
   fluctuations average out, the coherent part stays.
2. **Window.** Each mean signal is kept from its first sample to
   ``t_end = t_zero + window_widths × W`` (front of the mean signal,
   :func:`granwave.analysis.front.front_features`; W = t_zero - t_lead10), or the end of
   the shortest record at that height if it comes first (``window_clipped``), the last W
   of it (at most half the time from the peak to t_end) tapered by a half cosine, zero after. The window excludes the late coda,
   which the few packings of an ensemble do not average out.
3. **Spectra.** S(ω, L) = Σ_n F(t_n) e^{-iω t_n} Δt (``numpy.fft.rfft``, zero-padded to
   at least 4 × the longest window, on the common sampling step of all heights).
4. **Attenuation.** At each ω, ln|S(ω, L)| = ln|S0(ω)| − α(ω) L, a straight line over the
   heights usable at that ω (rule 8a, 8b); α = −slope.
5. **Phase velocity.** The phase of S(ω, L) e^{iω t_ref(L)} (t_ref = the mean signal's
   peak time, which removes the bulk of the delay) is unwrapped along ω and shifted by a
   multiple of 2π to lie in (−π, π] at the reference frequency (the spectral peak of the
   tallest height); adding −ω t_ref back gives φ(ω, L) = φ0(ω) − k(ω) L, a straight line
   over the same heights: k = −slope, c(ω) = ω / k.
6. **Q.** Q(ω) = ω / (2 α(ω) c(ω)) (amplitude decay e^{−αL} = e^{−ωt/(2Q)} at t = L/c).
7. **Error bars.** ``*_fit_err``: one standard error of the slope (undetermined, NaN, with
   two heights); ``*_boot_err``: standard deviation over ``bootstrap`` resamplings of the
   packings at every height (with replacement; windows, t_ref and the heights used at each
   ω kept); NaN with one packing per height. ``*_err`` is the larger of the two.
8. **Which heights, which frequencies.** A height enters the fits at ω only where
   (a) the window after its front's arrival, D = t_end − t_lead10, holds at least
   ``min_periods`` periods (ω D ≥ 2π ``min_periods``, default 0.5): below that the
   record's end cuts the wave at that frequency (short columns, whose records are short,
   bias α negative and c upward there); (b) its coherent amplitude |S(ω, L)| is at least
   ``min_snr`` (default 2) times the noise floor, the standard error of the complex mean
   spectrum over its packings (:func:`noise_floor`; not applied with one packing).
   A frequency is *reliable* where (c) at least ``min_heights`` (default 3) heights are
   usable and the ln|S| fit over them is acceptable: χ² of its residuals against the
   noise floor's σ = noise/|S|, with n − 2 degrees of freedom, has p ≥ ``min_fit_p``
   (default 0.01; not applied with one packing per height); (d) every usable height's |S| is at
   least ``threshold`` of its own maximum; (e) c(ω) is known to ``max_error`` (relative).
   The reliable band is the contiguous run of reliable frequencies around the reference
   frequency (the longest run when the reference frequency is not reliable).
9. **Low-frequency limit.** c(ω) = c0 + c2 ω² fitted over the band's lowest part,
   ω_lo ≤ ω ≤ 2 ω_lo (at least 4 frequencies; weighted by 1/c_err², ``numpy.polyfit`` with
   its covariance); ``c0`` and its error, the larger of the fit's and the bootstrap's (the
   same fit on every resampling), and ``c0 / c_l`` when the effective-medium c_l is given.

``c_ref``, ``alpha_ref``: the values at the reference frequency (the tallest height's
spectral peak), the best-determined point of the band.

Units: times d/sqrt(E*/rho), ω rad per that time unit, lengths d, α per d, speeds
sqrt(E*/rho). The functions do not care: they return the units they are given.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np
from scipy import stats

from ..errors import InputError
from .ensemble import ensemble_average
from .front import front_features
from .heights import group_heights

if TYPE_CHECKING:
    from ..model import Signal

DEFAULT_WINDOW_WIDTHS = 5.0
DEFAULT_THRESHOLD = 0.05
DEFAULT_MAX_ERROR = 0.1
DEFAULT_MIN_PERIODS = 0.5
DEFAULT_MIN_SNR = 2.0
DEFAULT_MIN_HEIGHTS = 3
DEFAULT_MIN_FIT_P = 0.01
DEFAULT_C0_SPAN = 2.0


def window(time: np.ndarray, t_end: float, taper: float) -> np.ndarray:
    """1 up to t_end - taper, a half cosine down to 0 at t_end, 0 after."""
    w = np.ones_like(time, dtype=float)
    start = t_end - taper
    ramp = (time > start) & (time < t_end)
    w[ramp] = 0.5 * (1.0 + np.cos(np.pi * (time[ramp] - start) / taper))
    w[time >= t_end] = 0.0
    return w


def front_window(time, mean, *, window_widths: float = DEFAULT_WINDOW_WIDTHS,
                 **front_kw) -> tuple[float, float, float, float]:
    """(t_ref, t_end, taper, t_lead10) of one mean signal by the rule of the module docstring."""
    try:
        f = front_features(time, mean, **front_kw)
    except InputError as exc:
        raise InputError(f"the mean signal: {exc}") from None
    return f.t_peak, f.t_zero + window_widths * f.width, f.width, f.t_lead10


def spectra(time: np.ndarray, means: np.ndarray, t_end: Sequence[float],
            taper: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """(omega, S): windowed spectra of the rows of ``means`` on the uniform grid ``time``."""
    dt = float(time[1] - time[0])
    n_fft = 1 << int(math.ceil(math.log2(4 * time.size)))
    rows = [m * window(time - time[0], te - time[0], tp) for m, te, tp in zip(means, t_end, taper)]
    S = np.fft.rfft(np.asarray(rows), n=n_fft, axis=1) * dt
    omega = 2.0 * np.pi * np.fft.rfftfreq(n_fft, dt)
    if time[0] != 0.0:  # spectra relative to t = 0, not to the first sample
        S = S * np.exp(-1j * omega * time[0])[None, :]
    return omega, S


def _unwrapped_phase(omega, S, t_ref, i_ref) -> np.ndarray:
    """φ(ω, L) of every row: unwrap after removing ω t_ref, anchor at i_ref, add the delay back."""
    psi = np.unwrap(np.angle(S * np.exp(1j * omega[None, :] * np.asarray(t_ref)[:, None])), axis=1)
    psi -= 2.0 * np.pi * np.round(psi[:, i_ref:i_ref + 1] / (2.0 * np.pi))
    return psi - omega[None, :] * np.asarray(t_ref)[:, None]


def _slopes(L: np.ndarray, Y: np.ndarray, use: np.ndarray | None = None):
    """Least-squares slope of every column of Y (heights x freq) against L over the rows
    ``use`` marks (heights x freq booleans; all rows when None).

    Returns (slope, slope_err, resid, n): the slope's standard error is NaN with fewer than
    three rows (no residual), the slope NaN with fewer than two; ``resid`` (heights x freq)
    is 0 on the rows not used.
    """
    use = np.ones(Y.shape, bool) if use is None else np.asarray(use, bool)
    w = use.astype(float)
    Yz = np.where(use, Y, 0.0)
    n = w.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        Lbar = (w * L[:, None]).sum(axis=0) / n
        Ybar = Yz.sum(axis=0) / n
        x = (L[:, None] - Lbar[None, :]) * w
        sxx = (x * x).sum(axis=0)
        slope = (x * (Yz - Ybar[None, :])).sum(axis=0) / sxx
        resid = (Yz - Ybar[None, :] - x * slope[None, :]) * w
        ss = (resid**2).sum(axis=0)
        err = np.where(n > 2, np.sqrt(ss / (n - 2) / sxx), np.nan)
    slope = np.where(n >= 2, slope, np.nan)
    return slope, err, resid, n.astype(int)


def _alpha_c(L, omega, S, t_ref, i_ref, use=None):
    """(alpha, alpha_fit_err, c, c_fit_err, k, k_err, lnA_resid) at every ω from spectra at
    heights L, each ω fitted over the heights ``use`` marks (all when None)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lnA = np.log(np.abs(S))
        a_slope, a_err, a_res, _ = _slopes(L, lnA, use)
        phi = _unwrapped_phase(omega, S, t_ref, i_ref)
        p_slope, p_err, _, _ = _slopes(L, phi, use)
        k = -p_slope
        c = omega / k
        c_err = omega * p_err / k**2
    return -a_slope, a_err, c, np.abs(c_err), k, p_err, a_res


def fit_p_value(resid, S, noise, use) -> np.ndarray:
    """p-value, at every ω, of the ln|S| fit's χ² = Σ (resid / σ)² over the heights used, with
    σ = noise / |S| (the noise floor's share of the coherent amplitude) and n − 2 degrees of
    freedom (rule 8c). NaN with fewer than three heights or an unknown noise floor."""
    use = np.asarray(use, bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        sig = np.asarray(noise) / np.abs(S)
        chi2 = np.where(use, (resid / sig) ** 2, 0.0).sum(axis=0)
        dof = use.sum(axis=0) - 2
        known = np.all(np.isfinite(sig) | ~use, axis=0) & (dof > 0)
        p = stats.chi2.sf(chi2, np.maximum(dof, 1))
    return np.where(known, p, np.nan)




def noise_floor(spectra_of_packings: np.ndarray) -> np.ndarray:
    """Standard error of the complex mean spectrum over packings (rows), at every ω:
    sqrt(Σ_i |S_i − S̄|² / (n (n − 1))) — the incoherent part left in the coherent mean.
    NaN with one packing."""
    P = np.asarray(spectra_of_packings)
    n = P.shape[0]
    if n < 2:
        return np.full(P.shape[1], np.nan)
    return np.sqrt((np.abs(P - P.mean(axis=0)) ** 2).sum(axis=0) / (n * (n - 1)))


def usable(omega, S, noise, duration, *, min_periods: float = DEFAULT_MIN_PERIODS,
           min_snr: float = DEFAULT_MIN_SNR) -> np.ndarray:
    """Heights x ω booleans: where a height's coherent spectrum can enter the fits (rule 8a, 8b).

    (a) the window after the front's arrival, ``duration`` = t_end − t_lead10 per height,
    holds at least ``min_periods`` periods 2π/ω; (b) |S(ω, L)| ≥ ``min_snr`` × ``noise``
    (:func:`noise_floor`; NaN noise, i.e. one packing, does not exclude).
    """
    D = np.asarray(duration, float)[:, None]
    ok = (omega[None, :] * D >= 2.0 * np.pi * min_periods) & (omega[None, :] > 0)
    ok &= ~(np.abs(S) < min_snr * np.asarray(noise))
    return ok


def reliable_band(omega, S, threshold: float, i_ref: int, rel_err=None,
                  max_error: float = DEFAULT_MAX_ERROR, use=None, n_used=None,
                  min_heights: int = DEFAULT_MIN_HEIGHTS, fit_p=None,
                  min_fit_p: float = DEFAULT_MIN_FIT_P) -> np.ndarray:
    """Boolean mask of the reliable band (rule 8 of the module docstring).

    ``use``: heights x ω of the usable heights (all when None); ``n_used``: their number per ω;
    ``fit_p``: p-value of the ln|S| fit per ω (:func:`fit_p_value`; NaN: not applied).
    """
    amp = np.abs(S)
    use = np.ones(amp.shape, bool) if use is None else np.asarray(use, bool)
    big = amp >= threshold * amp.max(axis=1, keepdims=True)
    ok = np.all(big | ~use, axis=0) & (omega > 0)
    if n_used is not None:
        ok &= np.asarray(n_used) >= min_heights
    if fit_p is not None:
        ok &= ~(np.asarray(fit_p) < min_fit_p)
    if rel_err is not None:
        ok &= ~(np.asarray(rel_err) > max_error)  # NaN (undetermined) errors do not exclude
    mask = np.zeros(omega.size, bool)
    if not ok.any():
        return mask
    if not ok[i_ref]:  # the longest run of reliable frequencies instead
        edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(int), [0]))))
        starts, stops = edges[::2], edges[1::2]
        i_ref = int(starts[np.argmax(stops - starts)])
    lo = i_ref
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    hi = i_ref
    while hi < omega.size - 1 and ok[hi + 1]:
        hi += 1
    mask[lo:hi + 1] = True
    return mask


def low_frequency_limit(omega, c, band, c_err=None, span: float = DEFAULT_C0_SPAN) -> dict:
    """c0 of c(ω) = c0 + c2 ω² over the lowest part of the band, ω_lo ≤ ω ≤ ``span`` × ω_lo
    (at least 4 frequencies; rule 9). Weighted by 1/c_err² when every error is known;
    ``numpy.polyfit``'s covariance (scaled by the misfit) gives ``c0_err``."""
    idx = np.flatnonzero(band & np.isfinite(c))
    nan = {"c0": math.nan, "c0_err": math.nan, "c2": math.nan, "omega_fit": [math.nan, math.nan]}
    if idx.size < 4:
        return nan
    low = idx[omega[idx] <= span * omega[idx[0]]]
    lower = low if low.size >= 4 else idx[:4]
    e = None if c_err is None else np.asarray(c_err)[lower]
    w = 1.0 / e if e is not None and np.all(np.isfinite(e) & (e > 0)) else None
    try:
        coef, cov = np.polyfit(omega[lower] ** 2, c[lower], 1, w=w, cov=True)
    except (ValueError, np.linalg.LinAlgError):
        return nan
    return {"c0": float(coef[1]), "c0_err": float(math.sqrt(cov[1, 1])), "c2": float(coef[0]),
            "omega_fit": [float(omega[lower[0]]), float(omega[lower[-1]])]}


def attenuation_from_groups(groups: Sequence[Sequence["Signal"]], *,
                            window_widths: float = DEFAULT_WINDOW_WIDTHS,
                            threshold: float = DEFAULT_THRESHOLD, max_error: float = DEFAULT_MAX_ERROR,
                            bootstrap: int = 200, min_periods: float = DEFAULT_MIN_PERIODS,
                            min_snr: float = DEFAULT_MIN_SNR, min_heights: int = DEFAULT_MIN_HEIGHTS,
                            min_fit_p: float = DEFAULT_MIN_FIT_P, seed: int = 0, c_l: float | None = None,
                            labels: Sequence[Sequence[str]] | None = None, **front_kw) -> dict:
    """α(ω), Q(ω), c(ω) from signals already grouped by nominal height (rule: module docstring).

    ``groups``: one list of signals per height (at least two heights, all on one pressure and
    initial condition). Returns a JSON-ready dict: ``omega``, ``alpha``, ``c``, ``Q`` and their
    ``*_err``, ``*_fit_err``, ``*_boot_err``; ``reliable`` (mask), ``band`` [ω_lo, ω_hi],
    ``omega_ref``, per-height ``heights``, ``counts``, ``t_ref``, ``t_end``; the low-frequency
    limit ``c0``, ``c0_err`` (and ``c0_over_c_l`` when ``c_l`` is given).
    """
    if len(groups) < 2:
        raise InputError("attenuation needs signals at two or more different heights")
    labels = labels or [[f"height {g} signal {i}" for i in range(len(s))] for g, s in enumerate(groups)]
    ens = [ensemble_average(list(s), labels=list(lab), height_rtol=math.inf)  # grouped by the caller
           for s, lab in zip(groups, labels)]
    L = np.array([e.attrs["height_mean"] for e in ens])
    order = np.argsort(L)
    groups = [list(groups[i]) for i in order]
    labels = [list(labels[i]) for i in order]
    ens, L = [ens[i] for i in order], L[order]
    if np.any(np.diff(L) <= 0):
        raise InputError("attenuation needs distinct heights")
    dt = min(float(np.median(np.diff(e.time))) for e in ens)
    t_hi = max(float(e.time[-1]) for e in ens)
    grid = np.arange(0.0, t_hi + 0.5 * dt, dt)

    def on_grid(t, f):
        return np.interp(grid, t, f, left=0.0, right=0.0)

    means = np.array([on_grid(e.time, e.mean) for e in ens])
    win = [front_window(grid, m, window_widths=window_widths, **front_kw) for m in means]
    t_ref = np.array([w[0] for w in win])
    t_lead = np.array([w[3] for w in win])
    record_end = np.array([min(float(s.time[-1]) for s in g) for g in groups])
    clipped = np.array([w[1] > r for w, r in zip(win, record_end)])
    t_end = np.array([min(w[1], r) for w, r in zip(win, record_end)])
    # the taper (one front width) stays behind the peak when the record cuts the window
    taper = np.array([min(w[2], 0.5 * (te - tr)) for w, te, tr in zip(win, t_end, t_ref)])
    omega, S = spectra(grid, means, t_end, taper)
    i_ref = int(np.argmax(np.abs(S[-1])))
    stacks = [np.array([on_grid(s.time, s.force) for s in g]) for g in groups]
    noise = np.array([noise_floor(spectra(grid, st, [te] * len(st), [tp] * len(st))[1])
                      for st, te, tp in zip(stacks, t_end, taper)])
    duration = t_end - t_lead
    use = usable(omega, S, noise, duration, min_periods=min_periods, min_snr=min_snr)
    n_used = use.sum(axis=0)
    need = max(2, min(int(min_heights), L.size))  # two heights given: both needed, no χ² test
    alpha, alpha_fit, c, c_fit, k, k_fit, resid = _alpha_c(L, omega, S, t_ref, i_ref, use)
    fit_p = fit_p_value(resid, S, noise, use)

    n_boot = int(bootstrap) if all(len(g) > 1 for g in groups) else 0
    boot_a, boot_c = [], []
    if n_boot:
        rng = np.random.default_rng(seed)
        for _ in range(n_boot):
            m = np.array([st[rng.integers(0, st.shape[0], st.shape[0])].mean(axis=0) for st in stacks])
            _, Sb = spectra(grid, m, t_end, taper)
            a_b, _, c_b, *_ = _alpha_c(L, omega, Sb, t_ref, i_ref, use)
            boot_a.append(a_b)
            boot_c.append(c_b)
    with np.errstate(invalid="ignore", divide="ignore"):
        alpha_boot = np.std(boot_a, axis=0, ddof=1) if n_boot > 1 else np.full(omega.size, np.nan)
        c_boot = np.std(boot_c, axis=0, ddof=1) if n_boot > 1 else np.full(omega.size, np.nan)
        alpha_err = np.fmax(alpha_fit, alpha_boot)
        c_err = np.fmax(c_fit, c_boot)
        Q = omega / (2.0 * alpha * c)
        Q_err = np.abs(Q) * np.hypot(alpha_err / alpha, c_err / c)

    with np.errstate(invalid="ignore", divide="ignore"):
        band = reliable_band(omega, S, threshold, i_ref, c_err / np.abs(c), max_error, use=use,
                             n_used=n_used, min_heights=need, fit_p=fit_p, min_fit_p=min_fit_p)
    low = low_frequency_limit(omega, c, band, c_err)
    # neighbouring frequencies of a zero-padded spectrum are not independent: the bootstrap
    # over packings gives the honest error of c0 (the larger of the two is kept)
    c0_boot = [low_frequency_limit(omega, cb, band, c_err)["c0"] for cb in boot_c]
    low["c0_fit_err"] = low["c0_err"]
    low["c0_boot_err"] = float(np.nanstd(c0_boot, ddof=1)) if len(c0_boot) > 1 else math.nan
    low["c0_err"] = float(np.fmax(low["c0_fit_err"], low["c0_boot_err"]))
    out = {
        "n_signals": int(sum(len(g) for g in groups)),
        "heights": L, "counts": np.array([len(g) for g in groups]),
        "t_ref": t_ref, "t_end": t_end, "taper": taper, "window_clipped": clipped,
        "window_widths": float(window_widths), "threshold": float(threshold),
        "max_error": float(max_error), "min_periods": float(min_periods), "min_snr": float(min_snr),
        "min_heights": need, "min_fit_p": float(min_fit_p), "duration": duration,
        "bootstrap": n_boot, "seed": int(seed), "front_options": dict(front_kw),
        "omega_ref": float(omega[i_ref]), "c_ref": float(c[i_ref]), "c_ref_err": float(c_err[i_ref]),
        "alpha_ref": float(alpha[i_ref]), "alpha_ref_err": float(alpha_err[i_ref]),
        "band": [float(omega[band][0]), float(omega[band][-1])] if band.any() else [math.nan, math.nan],
        **low,
    }
    if c_l is not None:
        out["c_l"] = float(c_l)
        out["c0_over_c_l"] = low["c0"] / c_l
        out["c0_over_c_l_err"] = low["c0_err"] / c_l
    # Keep the arrays up to twice the band's top (or the whole spectrum when no band).
    top = int(np.flatnonzero(band)[-1]) if band.any() else omega.size - 1
    keep = slice(0, min(omega.size, 2 * top + 2))
    out.update(omega=omega[keep], reliable=band[keep], alpha=alpha[keep], alpha_err=alpha_err[keep],
               alpha_fit_err=alpha_fit[keep], alpha_boot_err=alpha_boot[keep], c=c[keep],
               c_err=c_err[keep], c_fit_err=c_fit[keep], c_boot_err=c_boot[keep], Q=Q[keep],
               Q_err=Q_err[keep], spectrum_amplitude=np.abs(S[:, keep]), noise_floor=noise[:, keep],
               used=use[:, keep], n_used=n_used[keep], fit_p=fit_p[keep])
    return out


def attenuation(signals: Sequence["Signal"], *, labels: Sequence[str] | None = None,
                group_rtol: float = 0.05, **kw) -> dict:
    """:func:`attenuation_from_groups` of any set of signals, grouped by their ``height``."""
    signals = list(signals)
    if not signals:
        raise InputError("no signals given")
    labels = list(labels) if labels is not None else [f"signal {i}" for i in range(len(signals))]
    g = group_heights([s.height for s in signals], group_rtol)
    n = int(g.max()) + 1
    if n < 2:
        raise InputError(f"attenuation needs signals at two or more different heights (all "
                         f"{len(signals)} are at one height, relative tolerance {group_rtol:g})")
    groups = [[s for s, gi in zip(signals, g) if gi == k] for k in range(n)]
    labs = [[lab for lab, gi in zip(labels, g) if gi == k] for k in range(n)]
    out = attenuation_from_groups(groups, labels=labs, **kw)
    out["group_rtol"] = float(group_rtol)
    return out
