"""attenuation.* and continuum.lambda_star / L_lambda: `analyze attenuation` (granwave.analysis.
attenuation.attenuation with the workflow's options: window 5 front widths, bootstrap 200,
--moduli's c_ℓ per signal, the lateral cutoff) on synthetic scenes with a known coherent answer
(benchmarks/truth_cases/_ensembles.py: dispersive, attenuating, per-packing jitter and an
incoherent remainder, the band starting where c has already fallen ≥ 1 % from c0).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from granwave.analysis.attenuation import attenuation
from granwave.params import AttenuationParams

from . import Case, at, interval
from ._ensembles import Design, ensemble

P = AttenuationParams  # the CLI's (and so the workflow's) defaults
CUTOFF = 0.0246  # continuum2d_p4's lateral cutoff 2π c_t / W (its band lies below it)

SETTINGS = {
    # name: (design, words, frequencies checked)
    "dispersion": (Design(), "2D scene design (8 … 512 d̄, 30/10 packings); c(ω) levels off 2.5 % "
                   "below c0, fallen 1.5 % at the band's bottom (ω ≈ 0.0117) and 2 % at 0.0152 "
                   "(dispersion sets λ*); α = 4 ω², jitter 0.1 L, remainder 0.3",
                   (0.012, 0.0152, 0.02, 0.03)),
    "loss": (Design().with_medium(fall=0.015, alpha2=8.0),
             "2D scene design; c(ω) levels off 1.5 % below c0, α = 8 ω² (Q⁻¹ sets λ*)",
             (0.012, 0.016, 0.02)),
    "wide": (Design(heights=(16.0, 32.0, 64.0, 128.0, 256.0), packings=(10,) * 5),
             "wide-column design (16 … 256 d̄, 10 packings each), medium as 'dispersion'",
             (0.02, 0.025, 0.03)),
}


@lru_cache(maxsize=None)
def analysed(name: str, seed: int) -> dict:
    """The attenuation analysis of one synthetic scene, reduced to what the cases read."""
    design = SETTINGS[name][0]
    signals, c_l = ensemble(design, seed)
    r = attenuation(signals, window_widths=P.window_widths, threshold=P.threshold,
                    max_error=P.max_error, min_periods=P.min_periods, min_snr=P.min_snr,
                    min_heights=P.min_heights, min_fit_p=P.min_fit_p, bootstrap=P.bootstrap,
                    seed=seed, c_l=c_l, omega_cutoff=CUTOFF, c_tol=P.continuum_c_tolerance,
                    q_tol=P.continuum_q_inverse)
    keep = ("omega", "reliable", "c", "c_err", "c_ci95", "alpha", "alpha_ci95", "c_group",
            "c_group_ci95", "Q", "Q_err", "alpha_err")
    out = {k: np.asarray(r[k]) for k in keep}
    out.update({k: r.get(k) for k in ("c0", "c0_err", "c0_over_c_l", "c0_over_c_l_err",
                                       "c0_lower_bound", "c0_over_c_l_lower_bound")})
    out["continuum_length"] = r["continuum_length"]
    return out


def _in_band(r, w):
    om, rel = r["omega"], r["reliable"]
    if not rel.any():
        return False
    return om[rel][0] <= w <= om[rel][-1]


def per_frequency(name: str, key: str, w: float):
    def run(seed):
        r = analysed(name, seed)
        if not _in_band(r, w):
            return math.nan, None, None  # not quoted there on this input
        ci = r[key + "_ci95"]
        return at(r["omega"], r[key], w), at(r["omega"], ci[:, 0], w), at(r["omega"], ci[:, 1], w)
    return run


def q_run(name: str, w: float):
    """Q as the report quotes it (granwave.report.continuum.q_cell): Q ± 2 errors where α is
    resolved (its interval above 0 and within a decade), else the bound ω/(2 α_upper c_g)."""
    def run(seed):
        r = analysed(name, seed)
        if not _in_band(r, w):
            return math.nan, None, None
        cg = at(r["omega"], r["c_group"], w)
        q, q_err = at(r["omega"], r["Q"], w), at(r["omega"], r["Q_err"], w)
        a, a_err = at(r["omega"], r["alpha"], w), at(r["omega"], r["alpha_err"], w)
        if a - 2 * a_err > 0 and a + 2 * a_err <= 10 * (a - 2 * a_err):
            return interval(q, q_err)
        return math.nan, (w / (2 * (a + 2 * a_err) * cg) if a + 2 * a_err > 0 else math.nan), math.inf
    return run


def scalar(name: str, key: str):
    def run(seed):
        r = analysed(name, seed)
        ci = r.get(key + "_ci95")
        if ci is None:
            return interval(r.get(key), r.get(key + "_err"))
        return r.get(key), ci[0], ci[1]
    return run


def lambda_run(name: str, which: str = "lambda_star_ci"):
    def run(seed):
        lam = analysed(name, seed)["continuum_length"]
        ci = lam.get(which) or (None, None)
        lo = -math.inf if ci[0] is None else ci[0]
        hi = math.inf if ci[1] is None else ci[1]
        est = lam["lambda_star"] if lam["status"] == "within" else math.nan
        return est, lo, hi
    return run


def l_lambda_run(name: str):
    def run(seed):
        lam = analysed(name, seed)["continuum_length"]
        if not lam.get("L_lambda_ci"):
            return math.nan, None, None  # no ω*, no L_λ quoted (λ* beyond the band's bottom)
        lo, hi = lam["L_lambda_ci"]
        return (lam.get("L_lambda", math.nan) if lam.get("L_lambda_status") == "within" else math.nan,
                lo, hi)
    return run


def fall_run(name: str, lo: float, hi: float):
    """c(lo) − c(hi) with the two ends' errors in quadrature (the report's width comparison:
    granwave.analysis.continuum_length.fall_across), ± 2 errors."""
    from granwave.analysis.continuum_length import fall_across

    def run(seed):
        r = analysed(name, seed)
        return interval(*fall_across({"omega": r["omega"], "reliable": r["reliable"], "c": r["c"],
                                      "c_err": r["c_err"]}, lo, hi))
    return run


def c0_bound_run(name: str, key: str = "c0_lower_bound"):
    """The band's own statement on c0 (or c0/c_ℓ): not below c at its bottom (a one-sided 95 %
    bound)."""
    def run(seed):
        b = analysed(name, seed).get(key)
        return math.nan, (math.nan if b is None else b), math.inf
    return run


def l_lambda_truth(design: Design) -> float:
    """Where the spectral centroid Σ ω |S|² / Σ |S|² of the coherent spectrum falls to the true ω*
    (the continuous L, by root finding on the medium's exact spectrum)."""
    from scipy import optimize

    m = design.medium
    ws, _ = m.omega_star(c_ref=m.c0)
    w = np.linspace(1e-5, 0.6, 20000)

    def centroid(L):
        a = np.abs(m.spectrum(w, L)) ** 2 * np.exp(-m.jitter * w**2 * L)
        return float((w * a).sum() / a.sum()) - ws

    return float(optimize.brentq(centroid, 1.0, 1e5))


def cases() -> list[Case]:
    out = []
    for name, (design, words, freqs) in SETTINGS.items():
        m = design.medium
        fast = name == "dispersion"
        for w in freqs:
            where = f"{words}; ω = {w:g}"
            out += [Case("attenuation.c_omega", where, float(m.c(w)), per_frequency(name, "c", w), fast),
                    Case("attenuation.alpha", where, float(m.alpha_coherent(w)),
                         per_frequency(name, "alpha", w), fast),
                    Case("attenuation.c_g", where, float(m.c_group(w)),
                         per_frequency(name, "c_group", w), fast),
                    Case("attenuation.Q", where, float(m.Q(w)), q_run(name, w), fast)]
        a, b = freqs[0], freqs[0] * 1.42  # a common band's span (the widths': 0.0129 … 0.0183)
        out.append(Case("attenuation.c_fall", f"{words}; c({a:g}) − c({b:.4g})",
                        float(m.c(a) - m.c(b)), fall_run(name, a, b), fast))
        out += [Case("attenuation.c0", words, m.c0, scalar(name, "c0"), fast),
                Case("attenuation.c0_over_c_l", words, 1.0, scalar(name, "c0_over_c_l"), fast),
                Case("attenuation.c0_lower_bound", words + "; c0 ≥ c(band bottom) − t·error",
                     m.c0, c0_bound_run(name), fast),
                Case("continuum.lambda_star", words + f" (truth set by {m.omega_star()[1]}); 95 % "
                     "interval from the per-frequency intervals", m.lambda_star(), lambda_run(name), fast),
                Case("attenuation.c0_over_c_l_lower_bound", words + "; c0/c_ℓ ≥ c(band bottom)/c_ℓ "
                     "− t·error (what the report quotes)", 1.0,
                     c0_bound_run(name, "c0_over_c_l_lower_bound"), fast),
                Case("continuum.lambda_star_bootstrap", words + f" (truth set by {m.omega_star()[1]}); "
                     "95 % interval from the bootstrap (in the output, not quoted)", m.lambda_star(),
                     lambda_run(name, "lambda_star_boot_ci"), fast),
                Case("continuum.L_lambda", words + "; 95 % interval from λ*'s", l_lambda_truth(design),
                     l_lambda_run(name), fast)]
    return out


CASES = cases()
