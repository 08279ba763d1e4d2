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
   heights (:func:`granwave.analysis.fits.linear_fit`); α = −slope.
5. **Phase velocity.** The phase of S(ω, L) e^{iω t_ref(L)} (t_ref = the mean signal's
   peak time, which removes the bulk of the delay) is unwrapped along ω and shifted by a
   multiple of 2π to lie in (−π, π] at the reference frequency (the spectral peak of the
   tallest height); adding −ω t_ref back gives φ(ω, L) = φ0(ω) − k(ω) L, a straight line
   over the heights: k = −slope, c(ω) = ω / k.
6. **Q.** Q(ω) = ω / (2 α(ω) c(ω)) (amplitude decay e^{−αL} = e^{−ωt/(2Q)} at t = L/c).
7. **Error bars.** ``*_fit_err``: one standard error of the slope (undetermined, NaN, with
   two heights); ``*_boot_err``: standard deviation over ``bootstrap`` resamplings of the
   packings at every height (with replacement; windows and t_ref kept), NaN with one
   packing per height. ``*_err`` is the larger of the two.
8. **Reliable band.** The contiguous run of frequencies around the reference frequency
   where ω > 0, every height's |S(ω, L)| is at least ``threshold`` of its own maximum, and
   the phase velocity is known to ``max_error`` (relative error of c, default 0.1; at the
   lowest frequencies the phase differences between heights are too small to give k).
9. **Low-frequency limit.** c(ω) = c0 + c2 ω² fitted over the lower half of the reliable
   band (weighted by 1/c_err², ``numpy.polyfit`` with its covariance); ``c0`` and its
   error, the larger of the fit's and the bootstrap's (the same fit on every resampling),
   and ``c0 / c_l`` when the effective-medium c_l is given.

``c_ref``, ``alpha_ref``: the values at the reference frequency (the tallest height's
spectral peak), the best-determined point of the band.

Units: times d/sqrt(E*/rho), ω rad per that time unit, lengths d, α per d, speeds
sqrt(E*/rho). The functions do not care: they return the units they are given.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..errors import InputError
from .ensemble import ensemble_average
from .front import front_features
from .heights import group_heights

if TYPE_CHECKING:
    from ..model import Signal

DEFAULT_WINDOW_WIDTHS = 5.0
DEFAULT_THRESHOLD = 0.05


def window(time: np.ndarray, t_end: float, taper: float) -> np.ndarray:
    """1 up to t_end - taper, a half cosine down to 0 at t_end, 0 after."""
    w = np.ones_like(time, dtype=float)
    start = t_end - taper
    ramp = (time > start) & (time < t_end)
    w[ramp] = 0.5 * (1.0 + np.cos(np.pi * (time[ramp] - start) / taper))
    w[time >= t_end] = 0.0
    return w


def front_window(time, mean, *, window_widths: float = DEFAULT_WINDOW_WIDTHS,
                 **front_kw) -> tuple[float, float, float]:
    """(t_ref, t_end, taper) of one mean signal by the rule of the module docstring."""
    try:
        f = front_features(time, mean, **front_kw)
    except InputError as exc:
        raise InputError(f"the mean signal: {exc}") from None
    return f.t_peak, f.t_zero + window_widths * f.width, f.width


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


def _slopes(L: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares slope of every column of Y (heights x freq) against L, and its error."""
    n = L.size
    x = L - L.mean()
    sxx = float(x @ x)
    slope = x @ (Y - Y.mean(axis=0)) / sxx
    if n <= 2:
        return slope, np.full(slope.shape, np.nan)
    resid = Y - Y.mean(axis=0) - np.outer(x, slope)
    return slope, np.sqrt((resid**2).sum(axis=0) / (n - 2) / sxx)


def _alpha_c(L, omega, S, t_ref, i_ref):
    """(alpha, alpha_fit_err, c, c_fit_err, k, k_err) at every ω from spectra at heights L."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lnA = np.log(np.abs(S))
        a_slope, a_err = _slopes(L, lnA)
        phi = _unwrapped_phase(omega, S, t_ref, i_ref)
        p_slope, p_err = _slopes(L, phi)
        k = -p_slope
        c = omega / k
        c_err = omega * p_err / k**2
    return -a_slope, a_err, c, np.abs(c_err), k, p_err


DEFAULT_MAX_ERROR = 0.1


def reliable_band(omega, S, threshold: float, i_ref: int, rel_err=None,
                  max_error: float = DEFAULT_MAX_ERROR) -> np.ndarray:
    """Boolean mask of the reliable band (rule 8 of the module docstring)."""
    amp = np.abs(S)
    ok = np.all(amp >= threshold * amp.max(axis=1, keepdims=True), axis=0) & (omega > 0)
    if rel_err is not None:
        ok &= ~(np.asarray(rel_err) > max_error)  # NaN (undetermined) errors do not exclude
    mask = np.zeros(omega.size, bool)
    if not ok[i_ref]:
        return mask
    lo = i_ref
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    hi = i_ref
    while hi < omega.size - 1 and ok[hi + 1]:
        hi += 1
    mask[lo:hi + 1] = True
    return mask


def low_frequency_limit(omega, c, band, c_err=None) -> dict:
    """c0 of c(ω) = c0 + c2 ω² over the lower half of the band (rule 9)."""
    idx = np.flatnonzero(band & np.isfinite(c))
    if idx.size < 4:
        return {"c0": math.nan, "c0_err": math.nan, "c2": math.nan, "omega_fit": [math.nan, math.nan]}
    lower = idx[: max(4, idx.size // 2)]
    e = None if c_err is None else np.asarray(c_err)[lower]
    w = 1.0 / e if e is not None and np.all(np.isfinite(e) & (e > 0)) else None
    coef, cov = np.polyfit(omega[lower] ** 2, c[lower], 1, w=w, cov=True)  # errors scaled by the misfit
    return {"c0": float(coef[1]), "c0_err": float(math.sqrt(cov[1, 1])), "c2": float(coef[0]),
            "omega_fit": [float(omega[lower[0]]), float(omega[lower[-1]])]}


def attenuation_from_groups(groups: Sequence[Sequence["Signal"]], *,
                            window_widths: float = DEFAULT_WINDOW_WIDTHS,
                            threshold: float = DEFAULT_THRESHOLD, max_error: float = DEFAULT_MAX_ERROR,
                            bootstrap: int = 200,
                            seed: int = 0, c_l: float | None = None,
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
    ens = [ensemble_average(list(s), labels=list(lab)) for s, lab in zip(groups, labels)]
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
    record_end = np.array([min(float(s.time[-1]) for s in g) for g in groups])
    clipped = np.array([w[1] > r for w, r in zip(win, record_end)])
    t_end = np.array([min(w[1], r) for w, r in zip(win, record_end)])
    # the taper (one front width) stays behind the peak when the record cuts the window
    taper = np.array([min(w[2], 0.5 * (te - tr)) for w, te, tr in zip(win, t_end, t_ref)])
    omega, S = spectra(grid, means, t_end, taper)
    i_ref = int(np.argmax(np.abs(S[-1])))
    alpha, alpha_fit, c, c_fit, k, k_fit = _alpha_c(L, omega, S, t_ref, i_ref)

    n_boot = int(bootstrap) if all(len(g) > 1 for g in groups) else 0
    boot_a, boot_c = [], []
    if n_boot:
        rng = np.random.default_rng(seed)
        stacks = [np.array([on_grid(s.time, s.force) for s in g]) for g in groups]
        for _ in range(n_boot):
            m = np.array([st[rng.integers(0, st.shape[0], st.shape[0])].mean(axis=0) for st in stacks])
            _, Sb = spectra(grid, m, t_end, taper)
            a_b, _, c_b, _, _, _ = _alpha_c(L, omega, Sb, t_ref, i_ref)
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
        band = reliable_band(omega, S, threshold, i_ref, c_err / np.abs(c), max_error)
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
        "max_error": float(max_error),
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
               Q_err=Q_err[keep], spectrum_amplitude=np.abs(S[:, keep]))
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
