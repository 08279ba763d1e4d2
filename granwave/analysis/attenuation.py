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
   heights usable at that ω (rule 8a, 8b); α = −slope. |S| is the debiased coherent amplitude
   sqrt(|S̄|² − noise²) (:func:`coherent_spectra`); each height is weighted by 1/var of its
   ln|S| over its packings (one packing: the per-packing variance pooled over the others).
5. **Phase velocity.** The phase of S(ω, L) e^{iω t_ref(L)} (t_ref = the mean signal's
   peak time, which removes the bulk of the delay) is unwrapped along ω and shifted by a
   multiple of 2π to lie in (−π, π] at the reference frequency (the spectral peak of the
   tallest height); adding −ω t_ref back gives φ(ω, L) = φ0(ω) − k(ω) L, a straight line
   over the same heights, weighted by 1/var of the phase: k = −slope, c(ω) = ω / k; the
   group velocity c_g = dω/dk (:func:`group_velocity`).
6. **Q.** Q(ω) = ω / (2 α(ω) c_g(ω)) (amplitude decay e^{−αL} = e^{−ωt/(2Q)} at t = L/c_g).
7. **Error bars.** ``*_fit_err``: the weighted slope's absolute standard error, widened by
   sqrt(χ²/(n − 2)) where that exceeds 1 (unweighted where a variance is unknown: the
   scatter's, NaN with two heights); ``*_boot_err``: standard deviation over ``bootstrap``
   resamplings of the packings at every height (with replacement, deviations widened by
   sqrt(n/(n − 1)); debiased amplitudes, weights and fits recomputed; windows, t_ref and the
   heights used at each ω kept; a height with one packing drawn about its value with the
   pooled variance); NaN when no height has two packings. ``*_err`` is the larger of the
   two; ``*_ci95`` = value ± t(0.975, n_min − 1) × error. Fewer than 10 packings at a
   height: ``packings.quotable`` false (:mod:`granwave.analysis.packings`).
8. **Which heights, which frequencies.** A height enters the fits at ω only where
   (a) the window after its front's arrival, D = t_end − t_lead10, holds at least
   ``min_periods`` periods (ω D ≥ 2π ``min_periods``, default 1): below that the
   record's end cuts the wave at that frequency (short columns, whose records are short,
   bias α and c there; half a period let α come out +70 % high where a short column enters); (b) its coherent amplitude |S(ω, L)| is at least
   ``min_snr`` (default 2) times the noise floor, the standard error of the complex mean
   spectrum over its packings (:func:`noise_floor`; not applied with one packing).
   A frequency is *reliable* where (c) at least ``min_heights`` (default 3) heights are
   usable and the ln|S| fit over them is acceptable: χ² of its residuals against the
   variance of ln|S| per height, with n − 2 degrees of freedom, has p ≥ ``min_fit_p``
   (default 0.01; not applied with one packing per height); (d) every usable height's |S| is at
   least ``threshold`` of its own maximum; (e) c(ω) is known to ``max_error`` (relative).
   The reliable band is the contiguous run of reliable frequencies around the reference
   frequency (the run nearest to it when the reference frequency is not reliable).
9. **Low-frequency limit.** c(ω) = c0 + c2 ω² fitted over the band's lowest part,
   ω_lo ≤ ω ≤ 2 ω_lo (at least 4 frequencies; weighted by 1/c_err², ``numpy.polyfit`` with
   its covariance); ``c0`` and its error, the larger of the fit's and the bootstrap's (the
   same fit on every resampling) combined in quadrature with the spread of c0 over fit spans
   and forms (``c0_model_spread``, :func:`granwave.analysis.continuum_length.c0_model_spread`;
   ``c0_stat_err`` without it), and ``c0 / c_l`` against the reference c_l of rule 10.

10. **Continuum length.** λ* against one reference (:mod:`granwave.analysis.continuum_length`):
   the c_l of the packings of the heights that enter the fits up to ω* when per-packing c_l are
   given (``c_l`` a sequence, one per signal), the given c_l when it is one number, else c0.
   λ* = 2π c(ω*)/ω*, ω* where from the band's bottom up |c/c_ref − 1| first exceeds ``c_tol``
   or Q⁻¹ first exceeds ``q_tol`` (``binding`` says which; ``omega_star_above_cutoff``
   whether it is above the lateral cutoff); 95 % interval from the per-frequency intervals
   (``lambda_star_ci``) and, beside it, from the bootstrap (``lambda_star_boot_ci``, the
   reference drawn about its value with its error); ``L_lambda`` where the pulse's spectral
   centroid reaches ω* (:func:`continuum_distance`).
11. **Lateral cutoff.** ``omega_cutoff`` (2π c_t / W, :func:`lateral_cutoff`), when given, is
   recorded and the frequencies above it marked: there α and c are the waveguide's.

``c_ref``, ``alpha_ref``: the values at the reference frequency (the tallest height's
spectral peak), the best-determined point of the band.

Units: times d/sqrt(E*/rho), ω rad per that time unit, lengths d, α per d, speeds
sqrt(E*/rho). The functions do not care: they return the units they are given.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Sequence

import numpy as np
from scipy import stats

from ..errors import InputError
from .continuum_length import (c0_model_spread, c0_ratio_lower_bound, continuum_wavelength,
                               contributing_reference)
from .ensemble import ensemble_average
from .front import front_features
from .heights import common_attr, group_heights, one_study
from .packings import packing_check, pooled_variance

if TYPE_CHECKING:
    from ..model import Signal

DEFAULT_WINDOW_WIDTHS = 5.0
DEFAULT_THRESHOLD = 0.05
DEFAULT_MAX_ERROR = 0.1
DEFAULT_MIN_PERIODS = 1.0
DEFAULT_MIN_SNR = 2.0
DEFAULT_MIN_HEIGHTS = 3
DEFAULT_MIN_FIT_P = 0.01
DEFAULT_C0_SPAN = 2.0
DEFAULT_C_TOL = 0.02  # continuum length: |c/c_ref − 1| at most this
DEFAULT_Q_TOL = 0.05  # and Q⁻¹ at most this
__all__ = ["attenuation", "attenuation_from_groups", "continuum_wavelength", "continuum_distance",
           "lateral_cutoff", "coherent_spectra", "noise_floor", "usable", "reliable_band",
           "low_frequency_limit", "group_velocity", "fit_p_value", "spectra", "front_window", "window"]


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


def _slopes(L: np.ndarray, Y: np.ndarray, use: np.ndarray | None = None, var: np.ndarray | None = None):
    """Least-squares slope of every column of Y (heights x freq) against L over the rows
    ``use`` marks (heights x freq booleans; all rows when None), weighted by 1/``var`` (heights
    x freq variances of Y) where every used row of the column has a finite positive variance,
    unweighted in the other columns.

    Returns (slope, slope_err, resid, n, chi2): weighted, the slope's standard error is the
    absolute one, 1/sqrt(Σ w (L − L̄)²), times sqrt(χ²/(n − 2)) where that exceeds 1 (a misfit
    widens it, never narrows it); unweighted, the scatter's (NaN with fewer than three rows).
    The slope is NaN with fewer than two rows; ``resid`` (heights x freq) is 0 on the rows not
    used; ``chi2`` = Σ w resid² (NaN in unweighted columns).
    """
    use = np.ones(Y.shape, bool) if use is None else np.asarray(use, bool)
    if var is None:
        weighted = np.zeros(Y.shape[1], bool)
        w = use.astype(float)
    else:
        v = np.asarray(var, float)
        good = np.isfinite(v) & (v > 0)
        weighted = np.all(good | ~use, axis=0) & use.any(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(weighted[None, :], np.where(use & good, 1.0 / np.where(good, v, 1.0), 0.0),
                         use.astype(float))
    Yz = np.where(use, Y, 0.0)
    n = use.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        sw = w.sum(axis=0)
        Lbar = (w * L[:, None]).sum(axis=0) / sw
        Ybar = (w * Yz).sum(axis=0) / sw
        x = np.where(use, L[:, None] - Lbar[None, :], 0.0)
        sxx = (w * x * x).sum(axis=0)
        slope = (w * x * (Yz - Ybar[None, :])).sum(axis=0) / sxx
        resid = np.where(use, Yz - Ybar[None, :] - x * slope[None, :], 0.0)
        chi2 = (w * resid**2).sum(axis=0)
        scatter = np.where(n > 2, np.sqrt(chi2 / (n - 2) / sxx), np.nan)
        absolute = np.sqrt(1.0 / sxx)
        birge = np.where(n > 2, np.sqrt(chi2 / np.maximum(n - 2, 1)), 1.0)
        err = np.where(weighted, absolute * np.fmax(birge, 1.0), scatter)
    slope = np.where(n >= 2, slope, np.nan)
    return slope, err, resid, n.astype(int), np.where(weighted, chi2, np.nan)


def _fit_lines(L, omega, lnA, phi, use=None, var_lnA=None, var_phi=None):
    """(alpha, alpha_fit_err, c, c_fit_err, k, k_err, lnA_resid, chi2) at every ω from ln|S| and
    the unwrapped phase at heights L (heights x ω), each ω fitted over the heights ``use``
    marks (all when None), weighted by the variances where given (:func:`_slopes`)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a_slope, a_err, a_res, _, chi2 = _slopes(L, lnA, use, var_lnA)
        p_slope, p_err, _, _, _ = _slopes(L, phi, use, var_phi)
        k = -p_slope
        c = omega / k
        c_err = omega * p_err / k**2
    return -a_slope, a_err, c, np.abs(c_err), k, p_err, a_res, chi2


def _alpha_c(L, omega, S, t_ref, i_ref, use=None):
    """:func:`_fit_lines` of the spectra S (heights x ω), unweighted, ln|S| not debiased."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lnA = np.log(np.abs(S))
    return _fit_lines(L, omega, lnA, _unwrapped_phase(omega, S, t_ref, i_ref), use)[:7]


def group_velocity(omega, k) -> np.ndarray:
    """c_g = dω/dk = 1 / (dk/dω), by central differences of k(ω) on the frequency grid."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return 1.0 / np.gradient(np.asarray(k, float), np.asarray(omega, float))


def fit_p_value(resid, S, noise, use, var=None) -> np.ndarray:
    """p-value, at every ω, of the ln|S| fit's χ² = Σ (resid / σ)² over the heights used, with
    σ² = ``var`` (the variance of ln|S| per height, :func:`coherent_spectra`) when given, else
    σ = noise / |S| (the noise floor's share of the coherent amplitude), and n − 2 degrees of
    freedom (rule 8c). NaN with fewer than three heights or an unknown σ."""
    use = np.asarray(use, bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        sig = np.sqrt(np.asarray(var, float)) if var is not None else np.asarray(noise) / np.abs(S)
        sig = np.where(sig > 0, sig, np.nan)
        chi2 = np.where(use, (resid / sig) ** 2, 0.0).sum(axis=0)
        dof = use.sum(axis=0) - 2
        known = np.all(np.isfinite(sig) | ~use, axis=0) & (dof > 0)
        p = stats.chi2.sf(chi2, np.maximum(dof, 1))
    return np.where(known, p, np.nan)


def coherent_spectra(P: np.ndarray) -> dict:
    """The coherent spectrum of one height from its packings' spectra P (packings x ω).

    ``S`` = the mean; ``noise`` = :func:`noise_floor`; ``lnA`` = ln of the debiased coherent
    amplitude, ½ ln(|S̄|² − noise²): the incoherent remainder adds its variance to the mean's
    power, E|S̄|² = |⟨S⟩|² + σ²/n, so |S̄| alone is biased up by ≈ σ²/(2 n |⟨S⟩|) (NaN where
    |S̄| ≤ noise; not corrected with one packing); ``var_lnA``, ``var_phi``: the variances of
    ln|S̄| and of its phase, Σ Re(δ_i/S̄)² / (n (n − 1)) and the same with Im, δ_i = S_i − S̄
    (first order in δ; the jitter of arrival times goes mostly into the phase, an incoherent
    remainder into both); NaN with one packing.
    """
    P = np.asarray(P)
    n = P.shape[0]
    S = P.mean(axis=0)
    noise = noise_floor(P)
    with np.errstate(invalid="ignore", divide="ignore"):
        if n < 2:
            var_lnA = var_phi = np.full(S.shape, np.nan)
            lnA = np.log(np.abs(S))
        else:
            r = (P - S) / S
            # identical packings (a scatter at the rounding level): no variance of their own
            flat = noise <= 1e-9 * np.abs(S)
            var_lnA = (r.real**2).sum(axis=0) / (n * (n - 1))
            var_phi = (r.imag**2).sum(axis=0) / (n * (n - 1))
            power = np.abs(S) ** 2 - noise**2
            lnA = np.where(power > 0, 0.5 * np.log(np.where(power > 0, power, 1.0)), np.nan)
            var_lnA[flat] = np.nan
            var_phi[flat] = np.nan
    return {"S": S, "noise": noise, "lnA": lnA, "var_lnA": var_lnA, "var_phi": var_phi, "n": n}


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
    if not ok[i_ref]:  # the run of reliable frequencies nearest to it instead (ties: the longer)
        # (not the longest anywhere: that can be a run of the short columns alone far above the
        # tallest column's spectrum, a different band; benchmarks/truth_cases/attenuation.py)
        edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(int), [0]))))
        starts, stops = edges[::2], edges[1::2]
        gap = np.where(i_ref < starts, starts - i_ref, i_ref - (stops - 1))
        best = np.lexsort((-(stops - starts), gap))[0]
        i_ref = int(starts[best])
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


def _distance_at(wc, L, w: float) -> tuple[float, str]:
    """Where the centroids ``wc`` (one per height L, falling with L) reach ``w``: (L, "within"),
    interpolated in ln L, or the bound (L[0], "below the shortest") / (L[-1], "beyond the tallest")."""
    below = wc <= w
    if below.all() or (below.any() and int(np.argmax(below)) == 0):
        return float(L[0]), "below the shortest"
    if not below.any():
        return float(L[-1]), "beyond the tallest"
    k = int(np.argmax(below))
    # ln ω_c linear in ln L between the two heights: the centroid of a spectrum losing
    # e^{−α L} with α ∝ ω² falls as L^−½ (linear in ω_c instead put L_λ ~2 % long)
    f = (np.log(wc[k - 1]) - np.log(w)) / (np.log(wc[k - 1]) - np.log(wc[k]))
    return float(np.exp(np.log(L[k - 1]) + f * (np.log(L[k]) - np.log(L[k - 1])))), "within"


def continuum_distance(heights, omega, amplitude, omega_star: float, omega_star_ci=None) -> dict:
    """The distance beyond which the coherent pulse is made of wavelengths longer than λ*: where
    the spectral centroid ω_c(L) = Σ ω |S|² / Σ |S|² of each height's coherent spectrum falls
    to ω* (ln ω_c interpolated linearly in ln L between the heights; a bound outside them).
    With ω*'s 95 %
    interval ``omega_star_ci`` also ``L_lambda_ci`` (0 or ∞ where an end lies outside the
    heights)."""
    amp = np.nan_to_num(np.asarray(amplitude, float))
    with np.errstate(invalid="ignore", divide="ignore"):
        wc = (omega[None, :] * amp**2).sum(axis=1) / (amp**2).sum(axis=1)
    L = np.asarray(heights, float)
    out = {"centroid_frequency": wc, "L_lambda": math.nan, "L_lambda_status": "undetermined"}
    if not math.isfinite(omega_star):
        return out
    value, status = _distance_at(wc, L, omega_star)
    if status == "within":
        out.update(L_lambda=value, L_lambda_status=status)
    else:
        out.update(L_lambda_status=status, L_lambda_bound=value)
    if omega_star_ci is not None:
        w_lo, w_hi = omega_star_ci
        lo, s_lo = _distance_at(wc, L, w_hi) if math.isfinite(w_hi) else (0.0, "below the shortest")
        hi, s_hi = _distance_at(wc, L, w_lo) if w_lo > 0 else (math.inf, "beyond the tallest")
        out["L_lambda_ci"] = [0.0 if s_lo == "below the shortest" else lo,
                              math.inf if s_hi == "beyond the tallest" else hi]
    return out


def lateral_cutoff(c_t: float, width: float) -> float:
    """The first lateral shear cutoff of a column of lateral period ``width``: ω = 2π c_t / W.
    Above it the lowest transverse mode of the waveguide propagates and α(ω), c(ω) are the
    column's, not the medium's."""
    if not (c_t > 0 and width > 0):
        raise InputError(f"the lateral cutoff needs c_t > 0 and a width > 0 (got {c_t}, {width})")
    return 2.0 * math.pi * float(c_t) / float(width)


def attenuation_from_groups(groups: Sequence[Sequence["Signal"]], *,
                            window_widths: float = DEFAULT_WINDOW_WIDTHS,
                            threshold: float = DEFAULT_THRESHOLD, max_error: float = DEFAULT_MAX_ERROR,
                            bootstrap: int = 200, min_periods: float = DEFAULT_MIN_PERIODS,
                            min_snr: float = DEFAULT_MIN_SNR, min_heights: int = DEFAULT_MIN_HEIGHTS,
                            min_fit_p: float = DEFAULT_MIN_FIT_P, seed: int = 0, c_l=None,
                            omega_cutoff: float | None = None, c_tol: float = DEFAULT_C_TOL,
                            q_tol: float = DEFAULT_Q_TOL,
                            labels: Sequence[Sequence[str]] | None = None, **front_kw) -> dict:
    """α(ω), Q(ω), c(ω) from signals already grouped by nominal height (rule: module docstring).

    ``groups``: one list of signals per height (at least two heights, all on one pressure and
    initial condition). Returns a JSON-ready dict: ``omega``, ``alpha``, ``c``, ``c_group``,
    ``Q`` and their ``*_err``, ``*_fit_err``, ``*_boot_err``; ``reliable`` (mask), ``band``
    [ω_lo, ω_hi], ``omega_ref``, per-height ``heights``, ``counts``, ``t_ref``, ``t_end``,
    ``error_model``; the low-frequency limit ``c0``, ``c0_err`` (and ``c0_over_c_l`` with
    ``c0_over_c_l_lower_bound``, the band's one-sided 95 % bound on it, when ``c_l`` is given:
    one speed, or one sequence of per-packing speeds per group, the reference then the
    contributing heights' packings, rule 10); ``continuum_length`` (λ*, rule 10);
    ``omega_cutoff`` and ``above_cutoff`` when the lateral cutoff is given;
    ``packings`` (:func:`granwave.analysis.packings.packing_check`, the rule for fits).
    """
    if len(groups) < 2:
        raise InputError("attenuation needs signals at two or more different heights")
    if omega_cutoff is not None and not omega_cutoff > 0:
        raise InputError(f"the lateral cutoff must be a positive frequency (got {omega_cutoff})")
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
    stacks = [np.array([on_grid(s.time, s.force) for s in g]) for g in groups]
    # every packing's windowed spectrum: the mean of the spectra is the spectrum of the mean
    P = [spectra(grid, st, [te] * len(st), [tp] * len(st)) for st, te, tp in zip(stacks, t_end, taper)]
    omega = P[0][0]
    P = [p[1] for p in P]
    coh = [coherent_spectra(p) for p in P]
    S = np.array([h["S"] for h in coh])
    noise = np.array([h["noise"] for h in coh])
    counts = np.array([len(g) for g in groups])
    # a height with one packing borrows the per-packing variance pooled over the others
    var_lnA, pooled = pooled_variance(np.array([h["var_lnA"] for h in coh]) * counts[:, None], counts - 1)
    var_phi, _ = pooled_variance(np.array([h["var_phi"] for h in coh]) * counts[:, None], counts - 1)
    var_lnA, var_phi = var_lnA / counts[:, None], var_phi / counts[:, None]
    error_model = np.array(["pooled" if n < 2 else "sample" for n in counts])
    lnA = np.array([h["lnA"] for h in coh])
    i_ref = int(np.argmax(np.abs(S[-1])))
    phi = _unwrapped_phase(omega, S, t_ref, i_ref)
    duration = t_end - t_lead
    use = usable(omega, S, noise, duration, min_periods=min_periods, min_snr=min_snr)
    use &= np.isfinite(lnA)
    n_used = use.sum(axis=0)
    need = max(2, min(int(min_heights), L.size))  # two heights given: both needed, no χ² test
    alpha, alpha_fit, c, c_fit, k, k_fit, resid, chi2 = _fit_lines(L, omega, lnA, phi, use, var_lnA,
                                                                    var_phi)
    cg = group_velocity(omega, k)
    fit_p = fit_p_value(resid, S, noise, use, var=var_lnA)

    # Bootstrap over the packings of every height, through the chain: mean spectra, noise
    # floors, debiased amplitudes, weights and fits of every resampling (windows, t_ref and the
    # heights used at each ω kept). A height with one packing cannot be resampled: its ln|S|
    # and phase are drawn about their values with the pooled variances instead.
    n_boot = int(bootstrap) if np.any(counts > 1) else 0
    boot = {"alpha": [], "c": [], "cg": []}
    if n_boot:
        rng = np.random.default_rng(seed)
        # only the frequencies up to the last one where two heights are usable matter to the
        # fits (the phase is unwrapped from ω = 0 up, so the prefix is kept whole)
        top = int(max(i_ref, np.flatnonzero(n_used >= 2)[-1] if np.any(n_used >= 2) else 0)) + 2
        top = min(top, omega.size)
        draws = top  # the single-packing heights' draws keep this length: the same random stream
        # ... and only up to twice the last frequency where `need` used heights clear the band's
        # amplitude threshold (reliable_band): the band lies below it and the arrays written
        # reach twice the band's top (+ 2 for the group velocity's differences). The spectra
        # run to the finest record's Nyquist frequency, ~100x further: the bootstrap's cost.
        amp = np.abs(S)
        strong = ((amp >= threshold * amp.max(axis=1, keepdims=True)) & use).sum(axis=0) >= need
        if strong.any():
            top = min(top, 2 * int(np.flatnonzero(strong)[-1]) + 4)
        om, Sb0, Pb = omega[:top], S[:, :top], [p[:, :top] for p in P]
        pad = np.full(omega.size - top, np.nan)
        for _ in range(n_boot):
            lb, pb, vb, vp = [], [], [], []
            for h, p in enumerate(Pb):
                if counts[h] > 1:
                    # deviations widened by sqrt(n / (n − 1)): the resampled means then scatter
                    # with the unbiased variance s²/n, not the plug-in (n − 1) s² / n²
                    n_h = counts[h]
                    dev = p[rng.integers(0, n_h, n_h)] - Sb0[h]
                    cb = coherent_spectra(Sb0[h] + math.sqrt(n_h / (n_h - 1)) * dev)
                    lb.append(cb["lnA"])
                    pb.append(cb["S"])
                    vb.append(cb["var_lnA"])
                    vp.append(cb["var_phi"])
                else:
                    lb.append(lnA[h, :top] + np.sqrt(var_lnA[h, :top]) * rng.standard_normal(draws)[:top])
                    pb.append(Sb0[h] * np.exp(1j * np.sqrt(var_phi[h, :top]) * rng.standard_normal(draws)[:top]))
                    vb.append(var_lnA[h, :top])
                    vp.append(var_phi[h, :top])
            phib = _unwrapped_phase(om, np.array(pb), t_ref, i_ref)
            a_b, _, c_b, _, k_b, *_ = _fit_lines(L, om, np.array(lb), phib, use[:, :top], np.array(vb),
                                                 np.array(vp))
            boot["alpha"].append(np.concatenate([a_b, pad]))
            boot["c"].append(np.concatenate([c_b, pad]))
            boot["cg"].append(np.concatenate([group_velocity(om, k_b), pad]))
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: no estimate there

        def spread(key):
            return (np.nanstd(boot[key], axis=0, ddof=1) if n_boot > 1
                    else np.full(omega.size, np.nan))
        alpha_boot, c_boot, cg_boot = spread("alpha"), spread("c"), spread("cg")
        alpha_err = np.fmax(alpha_fit, alpha_boot)
        c_err = np.fmax(c_fit, c_boot)
        # the group velocity's error: the bootstrap's; without one, the phase fit's error of k
        # differenced like k (an upper bound: neighbouring errors are correlated)
        cg_fit = np.abs(cg) ** 2 * np.abs(np.gradient(k_fit, omega)) if omega.size > 1 else k_fit
        cg_err = cg_boot if n_boot > 1 else cg_fit
        # Q = ω / (2 α c_g): the amplitude e^{−αL} decays in time t = L / c_g as e^{−ωt/(2Q)}
        Q = omega / (2.0 * alpha * cg)
        Q_err = np.abs(Q) * np.hypot(alpha_err / alpha, cg_err / cg)

    # the quoted 95 % intervals, value ± ci95_factor × error: Student t with the degrees of
    # freedom of the thinnest height (n − 1; 1 where a height has a single packing)
    dof95 = int(max(1, counts.min() - 1))
    ci95 = float(stats.t.ppf(0.975, dof95))
    with np.errstate(invalid="ignore", divide="ignore"):
        band = reliable_band(omega, S, threshold, i_ref, c_err / np.abs(c), max_error, use=use,
                             n_used=n_used, min_heights=need, fit_p=fit_p, min_fit_p=min_fit_p)
    low = low_frequency_limit(omega, c, band, c_err)
    # neighbouring frequencies of a zero-padded spectrum are not independent: the bootstrap
    # over packings gives the honest error of c0 (the larger of the two is kept)
    c0_boot = [low_frequency_limit(omega, cb, band, c_err)["c0"] for cb in boot["c"]]
    low["c0_fit_err"] = low["c0_err"]
    low["c0_boot_err"] = float(np.nanstd(c0_boot, ddof=1)) if len(c0_boot) > 1 else math.nan
    low["c0_err"] = float(np.fmax(low["c0_fit_err"], low["c0_boot_err"]))
    # the c0-model error: the spread of c0 over fit spans and forms, in quadrature
    low.update(c0_model_spread(omega, c, band, c_err))
    low["c0_stat_err"] = low["c0_err"]
    # what the band itself says of the low-frequency limit: c is not below c at the band's
    # bottom where the dispersion is normal (the extrapolation c0 can miss it; docs/truth.md)
    if band.any():
        i_lo = int(np.flatnonzero(band)[0])
        low["c0_lower_bound"] = float(c[i_lo] - ci95 * c_err[i_lo])
    if math.isfinite(low["c0_model_spread"]):
        low["c0_err"] = float(math.hypot(low["c0_stat_err"], low["c0_model_spread"]))
    alpha_ci = np.stack([alpha - ci95 * alpha_err, alpha + ci95 * alpha_err], 1)
    # the continuum length in frequency against one reference (granwave.analysis.continuum_length)
    lam_kw = dict(c_tol=c_tol, q_tol=q_tol, c_err=c_err, alpha_ci=alpha_ci, ci_factor=ci95,
                  omega_cutoff=omega_cutoff)
    c_l_groups = None if c_l is None or np.isscalar(c_l) else [np.asarray(x, float) for x in c_l]
    if c_l_groups is not None:
        c_l_groups = [c_l_groups[i] for i in order]
        # first the heights used at the band's bottom, then those used up to ω* (one pass more)
        bottom = float(omega[band][0]) if band.any() else math.nan
        ref = contributing_reference(c_l_groups, use, band, omega, bottom)
        cont = continuum_wavelength(omega, c, alpha, cg, band, ref["c_ref"], c_ref_err=ref["c_ref_err"],
                                    reference="c_l", **lam_kw)
        upto = cont["omega_star"] if cont["status"] != "beyond" else bottom
        ref2 = contributing_reference(c_l_groups, use, band, omega, upto)
        if ref2["contributing_heights"] != ref["contributing_heights"]:
            ref = ref2
            cont = continuum_wavelength(omega, c, alpha, cg, band, ref["c_ref"],
                                        c_ref_err=ref["c_ref_err"], reference="c_l", **lam_kw)
        cont["contributing_heights"] = [float(L[h]) for h in ref["contributing_heights"]]
        ref_value, ref_err = ref["c_ref"], ref["c_ref_err"]
    elif c_l is not None:
        ref_value, ref_err = float(c_l), 0.0
        cont = continuum_wavelength(omega, c, alpha, cg, band, ref_value, reference="c_l (given)", **lam_kw)
    else:
        ref_value, ref_err = low["c0"], low["c0_err"]
        cont = continuum_wavelength(omega, c, alpha, cg, band, ref_value, c_ref_err=ref_err,
                                    reference="c0", **lam_kw)
    cont.update(continuum_distance(L, omega, np.exp(lnA), cont["omega_star"], cont.get("omega_star_ci")))
    if n_boot > 1:
        # every resampling's λ* against the reference drawn about its value with its error
        rng_ref = np.random.default_rng([int(seed), 1])
        refs = ref_value + (ref_err if math.isfinite(ref_err) else 0.0) * rng_ref.standard_normal(n_boot)
        if c_l is None:  # c0 as reference: each resampling's own c0, its model spread drawn
            spread = low["c0_model_spread"] if math.isfinite(low["c0_model_spread"]) else 0.0
            refs = np.asarray(c0_boot) + spread * rng_ref.standard_normal(n_boot)
        lam_b = [continuum_wavelength(omega, cb, ab, gb, band, rb, c_tol=c_tol, q_tol=q_tol)
                 for cb, ab, gb, rb in zip(boot["c"], boot["alpha"], boot["cg"], refs)]
        vals = np.array([d["lambda_star"] if d["status"] == "within" else
                         (math.inf if d["status"] == "beyond" else -math.inf) if d["status"] != "undetermined"
                         else math.nan for d in lam_b])
        vals = vals[~np.isnan(vals)]
        if vals.size > 1:
            # ±inf: a resampling whose thresholds fail at the band's bottom (λ* beyond) or hold
            # over the whole band (λ* within its top): the interval then reaches past the band
            lo, hi = np.quantile(vals, [0.025, 0.975], method="inverted_cdf")
            cont["lambda_star_boot_ci"] = [float(lo), float(hi)]
            cont["lambda_star_boot_err"] = float(np.std(vals[np.isfinite(vals)], ddof=1)) \
                if np.isfinite(vals).sum() > 1 else math.nan
            cont["lambda_star_boot_status"] = {k: int(sum(d["status"] == k for d in lam_b))
                                               for k in ("within", "whole band", "beyond", "undetermined")}
    out = {
        "n_signals": int(sum(len(g) for g in groups)),
        "heights": L, "counts": counts, "error_model": error_model,
        "packings": packing_check(counts, L, fit=True),
        "t_ref": t_ref, "t_end": t_end, "taper": taper, "window_clipped": clipped,
        "window_widths": float(window_widths), "threshold": float(threshold),
        "max_error": float(max_error), "min_periods": float(min_periods), "min_snr": float(min_snr),
        "min_heights": need, "min_fit_p": float(min_fit_p), "duration": duration,
        "bootstrap": n_boot, "seed": int(seed), "front_options": dict(front_kw),
        "weighted": "1/var of ln|S| and of the phase per height", "amplitude": "debiased",
        "Q_definition": "omega / (2 alpha c_group)",
        "ci95_factor": ci95, "ci95_dof": dof95,
        "continuum_length": cont,
        "omega_ref": float(omega[i_ref]), "c_ref": float(c[i_ref]), "c_ref_err": float(c_err[i_ref]),
        "alpha_ref": float(alpha[i_ref]), "alpha_ref_err": float(alpha_err[i_ref]),
        "band": [float(omega[band][0]), float(omega[band][-1])] if band.any() else [math.nan, math.nan],
        **low,
    }
    if c_l is not None:
        out["c_l"] = float(ref_value)
        out["c_l_err"] = float(ref_err)
        out["c_l_reference"] = ("the packings of the contributing heights" if c_l_groups is not None
                                else "given")
        r0 = low["c0"] / ref_value
        out["c0_over_c_l"] = r0
        out["c0_over_c_l_err"] = abs(r0) * math.hypot(low["c0_err"] / low["c0"],
                                                      ref_err / ref_value if ref_err else 0.0)
        if band.any():  # what the band supports of c0/c_ℓ (the extrapolation's r0 is not validated)
            out["c0_over_c_l_lower_bound"] = c0_ratio_lower_bound(c[i_lo], c_err[i_lo], ref_value,
                                                                  ref_err or 0.0, ci95)
    out["omega_cutoff"] = None if omega_cutoff is None else float(omega_cutoff)
    if omega_cutoff is not None:
        out["band_above_cutoff"] = bool(band.any() and omega[band][-1] > omega_cutoff)
    # Keep the arrays up to twice the band's top (or the whole spectrum when no band).
    top = int(np.flatnonzero(band)[-1]) if band.any() else omega.size - 1
    keep = slice(0, min(omega.size, 2 * top + 2))
    out.update(omega=omega[keep], reliable=band[keep], alpha=alpha[keep], alpha_err=alpha_err[keep],
               alpha_fit_err=alpha_fit[keep], alpha_boot_err=alpha_boot[keep], c=c[keep],
               c_err=c_err[keep], c_fit_err=c_fit[keep], c_boot_err=c_boot[keep],
               c_group=cg[keep], c_group_err=cg_err[keep], Q=Q[keep],
               alpha_ci95=alpha_ci[keep],
               c_ci95=np.stack([c - ci95 * c_err, c + ci95 * c_err], 1)[keep],
               c_group_ci95=np.stack([cg - ci95 * cg_err, cg + ci95 * cg_err], 1)[keep],
               Q_err=Q_err[keep], spectrum_amplitude=np.abs(S[:, keep]),
               coherent_amplitude=np.exp(lnA[:, keep]), noise_floor=noise[:, keep],
               used=use[:, keep], n_used=n_used[keep], fit_p=fit_p[keep])
    if omega_cutoff is not None:
        out["above_cutoff"] = omega[keep] > omega_cutoff
    return out


def attenuation(signals: Sequence["Signal"], *, labels: Sequence[str] | None = None,
                group_rtol: float = 0.05, c_l=None, **kw) -> dict:
    """:func:`attenuation_from_groups` of any set of signals, grouped by their ``height``;
    ``c_l``: None, one speed, or one per signal (each packing's own c_l, same order)."""
    signals = list(signals)
    if not signals:
        raise InputError("no signals given")
    labels = list(labels) if labels is not None else [f"signal {i}" for i in range(len(signals))]
    common_attr(signals, labels, "pressure", rtol=1e-9)
    common_attr(signals, labels, "ic")
    one_study(signals, labels, what="analyze attenuation (compressional signals)")
    g = group_heights([s.height for s in signals], group_rtol)
    n = int(g.max()) + 1
    if n < 2:
        raise InputError(f"attenuation needs signals at two or more different heights (all "
                         f"{len(signals)} are at one height, relative tolerance {group_rtol:g})")
    groups = [[s for s, gi in zip(signals, g) if gi == k] for k in range(n)]
    labs = [[lab for lab, gi in zip(labels, g) if gi == k] for k in range(n)]
    if c_l is not None and not np.isscalar(c_l):
        c_l = np.asarray(c_l, float)
        if c_l.size != len(signals):
            raise InputError(f"one c_l per signal is needed ({len(signals)} signals, {c_l.size} c_l)")
        c_l = [c_l[g == k] for k in range(n)]
    out = attenuation_from_groups(groups, labels=labs, c_l=c_l, **kw)
    out["group_rtol"] = float(group_rtol)
    return out
