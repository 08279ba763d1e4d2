"""The continuum length in frequency λ*, against one stated reference, and what sets it.

The rule (also in ``docs/continuum.md``, "The continuum length in frequency")
------------------------------------------------------------------------------
* **Reference.** λ* compares c(ω) with one speed c_ref: the effective-medium c_ℓ of the
  packings of the *contributing heights* — those that enter the fits at some band frequency
  up to ω* (:func:`contributing_reference`; ``reference`` "c_l") — when the packings' c_ℓ are
  given, else the low-frequency limit c0 of the band (``reference`` "c0"). c0 extrapolates
  c0 + c2 ω² from the band's lowest octave to ω = 0: where the band starts after c has already
  fallen, it depends on the fit's span and form (:func:`c0_model_spread`), and that spread is
  added to its error in quadrature before it serves as a reference.
* **λ*.** ω* is where, from the band's bottom up, the first of the two thresholds fails:
  |c/c_ref − 1| > ``c_tol`` (*dispersion*) or Q⁻¹ = 2 α c_g / ω > ``q_tol`` (*loss*),
  interpolated linearly between the last frequency that passes and the first that fails;
  λ* = 2π c(ω*)/ω*. ``binding`` says which threshold fails there ("dispersion", "loss" or
  "both"); ``omega_star_above_cutoff`` whether ω* lies above the column's first lateral
  cutoff (then λ* is the waveguide's, not the medium's).
* **Its 95 % interval from the per-frequency intervals** (``lambda_star_ci``): a frequency
  *may fail* where the 95 % interval of c/c_ref (c's and c_ref's errors in quadrature, the
  analysis's Student-t factor) reaches beyond 1 ± c_tol or α's 95 % interval reaches Q⁻¹ >
  q_tol; it *must fail* where the interval lies wholly beyond. ω* lies between the last
  frequency before the first that may fail and the first that must fail, so λ* lies between
  their λ = 2πc/ω. No frequency that may fail below the band's top: λ* ≤ the top's λ (lower
  end 0); the band's bottom may already fail: λ* may exceed the bottom's λ (upper end ∞).
  The same interval follows from a stored result's per-frequency columns
  (:func:`lambda_star_of_result`), so records made before this rule can be re-read.
* **Status**: ``within`` (a crossing inside the band), ``whole band`` (the point estimates
  pass up to the band's top: λ* ≤ its λ), ``beyond`` (the bottom already fails: λ* > its λ),
  ``undetermined`` (no band or no reference).

Units: ω in √(E*/ρ)/d̄, speeds √(E*/ρ), lengths d̄ (the functions return the units given).
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_C_TOL = 0.02
DEFAULT_Q_TOL = 0.05
#: the c0 fits whose spread is the c0-model error: spans (× the band's lowest frequency) and
#: degrees of the polynomial in ω² (1: c0 + c2 ω²; 2: + c4 ω⁴, where 6 frequencies allow it)
C0_SPANS = (1.5, 2.0, 3.0)
C0_DEGREES = (1, 2)


def _fit_c0(omega, c, idx, span, degree, c_err=None):
    low = idx[omega[idx] <= span * omega[idx[0]]]
    need = 2 * degree + 2  # a few more points than parameters
    if low.size < need:
        if idx.size < need:
            return math.nan
        low = idx[:need]
    e = None if c_err is None else np.asarray(c_err, float)[low]
    w = 1.0 / e if e is not None and np.all(np.isfinite(e) & (e > 0)) else None
    try:
        coef = np.polyfit(omega[low] ** 2, c[low], degree, w=w)
    except (ValueError, np.linalg.LinAlgError):
        return math.nan
    return float(coef[-1])


def c0_model_spread(omega, c, band, c_err=None) -> dict:
    """c0 of the band's low end by every fit of :data:`C0_SPANS` × :data:`C0_DEGREES`; the
    spread is half their range (the c0-model error, added to c0's error in quadrature)."""
    omega = np.asarray(omega, float)
    c = np.asarray(c, float)
    idx = np.flatnonzero(np.asarray(band, bool) & np.isfinite(c))
    fits = []
    if idx.size >= 4:
        for span in C0_SPANS:
            for deg in C0_DEGREES:
                v = _fit_c0(omega, c, idx, span, deg, c_err)
                if math.isfinite(v):
                    fits.append({"span": span, "degree": deg, "c0": v})
    vals = [f["c0"] for f in fits]
    spread = 0.5 * (max(vals) - min(vals)) if len(vals) > 1 else math.nan
    return {"c0_model_fits": fits, "c0_model_spread": float(spread)}


def contributing_reference(c_l_groups, used, band, omega, omega_star=math.nan) -> dict:
    """c_ℓ of the packings of the heights that enter the fits at some band frequency up to
    ``omega_star`` (the whole band when it is NaN): mean and standard error over those
    packings. ``c_l_groups``: one array of per-packing c_ℓ per height (NaN: unknown)."""
    used = np.asarray(used, bool)
    band = np.asarray(band, bool)
    upto = band & (np.asarray(omega, float) <= omega_star) if math.isfinite(omega_star) else band
    if not upto.any():
        upto = band
    heights = [h for h in range(used.shape[0]) if (used[h] & upto).any()]
    vals = np.concatenate([np.asarray(c_l_groups[h], float) for h in heights]) if heights else np.zeros(0)
    vals = vals[np.isfinite(vals)]
    n = vals.size
    return {"c_ref": float(vals.mean()) if n else math.nan,
            "c_ref_err": float(vals.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan,
            "contributing_heights": heights, "n_packings": int(n)}


def continuum_wavelength(omega, c, alpha, c_group, band, c0, *, c_tol: float = DEFAULT_C_TOL,
                         q_tol: float = DEFAULT_Q_TOL, c_err=None, alpha_ci=None,
                         c_ref_err: float = 0.0, ci_factor: float = 2.0,
                         omega_cutoff: float | None = None, reference: str = "c0") -> dict:
    """λ* against the reference speed ``c0`` (rule: module docstring). ``c_err``: c's standard
    errors; ``alpha_ci``: α's 95 % intervals (ω × 2); with both, ``lambda_star_ci`` from the
    per-frequency intervals. ``c_ref_err``: the reference's standard error; ``ci_factor``:
    the 95 % factor of the errors (the analysis's Student t)."""
    omega = np.asarray(omega, float)
    c = np.asarray(c, float)
    idx = np.flatnonzero(np.asarray(band, bool))
    out = {"c_tolerance": float(c_tol), "q_inverse_tolerance": float(q_tol), "omega_star": math.nan,
           "lambda_star": math.nan, "lambda_bound": math.nan, "status": "undetermined",
           "binding": None, "reference": reference, "c_ref": float(c0),
           "c_ref_err": float(c_ref_err), "omega_star_above_cutoff": None}
    if not idx.size or not math.isfinite(c0):
        return out
    w = omega[idx]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = c[idx] / c0
        qinv = 2.0 * np.asarray(alpha, float)[idx] * np.asarray(c_group, float)[idx] / w
    g_disp = np.abs(ratio - 1.0) - c_tol
    g_loss = qinv - q_tol
    g = np.fmax(g_disp, g_loss)  # an unknown α (NaN): the dispersion alone decides there
    fail = ~(g <= 0)  # both unknown: fails
    lam = 2.0 * math.pi * c[idx] / w
    if fail[0]:
        out.update(status="beyond", lambda_bound=float(lam[0]),
                   binding=_which(g_disp[0], g_loss[0]))
    elif not fail.any():
        out.update(status="whole band", omega_star=float(w[-1]), lambda_star=float(lam[-1]),
                   lambda_bound=float(lam[-1]))
    else:
        j = int(np.argmax(fail))
        f = -g[j - 1] / (g[j] - g[j - 1]) if np.isfinite(g[j]) and g[j] != g[j - 1] else 0.0
        ws = float(w[j - 1] + f * (w[j] - w[j - 1]))
        cs = float(c[idx[j - 1]] + f * (c[idx[j]] - c[idx[j - 1]]))
        out.update(status="within", omega_star=ws, lambda_star=float(2.0 * math.pi * cs / ws),
                   binding=_which(g_disp[j], g_loss[j]))
    if omega_cutoff is not None and math.isfinite(out["omega_star"]):
        out["omega_star_above_cutoff"] = bool(out["omega_star"] > omega_cutoff)
    if c_err is not None and alpha_ci is not None:
        out.update(_crossing_interval(w, idx, c, c0, c_tol, q_tol, np.asarray(c_err, float),
                                      np.asarray(alpha_ci, float), np.asarray(c_group, float),
                                      c_ref_err, ci_factor, lam))
    return out


def _which(gd, gl) -> str:
    d, lo = bool(gd > 0), bool(gl > 0)
    return "both" if d and lo else "dispersion" if d else "loss" if lo else "dispersion"


def _crossing_interval(w, idx, c, c_ref, c_tol, q_tol, c_err, alpha_ci, c_group, ref_err,
                       factor, lam) -> dict:
    with np.errstate(invalid="ignore", divide="ignore"):
        r = c[idx] / c_ref
        r_err = np.abs(r) * np.hypot(c_err[idx] / c[idx], ref_err / c_ref if ref_err else 0.0)
        r_lo, r_hi = r - factor * r_err, r + factor * r_err
        q_lo = 2.0 * alpha_ci[idx, 0] * c_group[idx] / w
        q_hi = 2.0 * alpha_ci[idx, 1] * c_group[idx] / w
    known = np.isfinite(r_lo) & np.isfinite(r_hi) & np.isfinite(q_lo) & np.isfinite(q_hi)
    may = ~known | (r_lo < 1.0 - c_tol) | (r_hi > 1.0 + c_tol) | (q_hi > q_tol)
    must = known & ((r_hi < 1.0 - c_tol) | (r_lo > 1.0 + c_tol) | (q_lo > q_tol))
    k = int(np.argmax(may)) if may.any() else None
    j = int(np.argmax(must)) if must.any() else None
    hi = math.inf if k == 0 else (float(lam[k - 1]) if k is not None else float(lam[-1]))
    lo = float(lam[j]) if j is not None else 0.0
    w_lo = 0.0 if k == 0 else (float(w[k - 1]) if k is not None else float(w[-1]))
    w_hi = float(w[j]) if j is not None else math.inf
    return {"lambda_star_ci": [lo, hi], "omega_star_ci": [w_lo, w_hi],
            "lambda_star_ci_rule": "per-frequency 95 % intervals"}


def lambda_star_of_result(att: dict, c_l_per_height=None, counts=None, *, c_tol=None,
                          q_tol=None) -> dict:
    """λ* of a stored `analyze attenuation` result by this module's rule, from its per-frequency
    columns (omega, reliable, used, c, c_err, alpha, alpha_ci95, c_group, ci95_factor). The c_ℓ
    reference: ``c_l_per_height`` one (mean, standard error) per height of the result and
    ``counts`` their packings (the ``per_height`` c_l, c_l_sem and count of `analyze continuum`
    on the same packings); the reference is the counts-weighted mean over the contributing
    heights, its error the weighted standard errors in quadrature. Without them: against c0
    with its model spread in its error."""
    omega = np.asarray(att["omega"], float)
    band = np.asarray(att["reliable"], bool)
    c = np.asarray(att["c"], float)
    c_err = np.asarray(att["c_err"], float)
    alpha = np.asarray(att["alpha"], float)
    alpha_ci = np.asarray(att["alpha_ci95"], float)
    cg = np.asarray(att["c_group"], float)
    used = np.asarray(att["used"], bool)
    lam_old = att.get("continuum_length") or {}
    c_tol = lam_old.get("c_tolerance", DEFAULT_C_TOL) if c_tol is None else c_tol
    q_tol = lam_old.get("q_inverse_tolerance", DEFAULT_Q_TOL) if q_tol is None else q_tol
    factor = float(att.get("ci95_factor", 2.0))
    cut = att.get("omega_cutoff")
    kw = dict(c_tol=c_tol, q_tol=q_tol, c_err=c_err, alpha_ci=alpha_ci, ci_factor=factor,
              omega_cutoff=cut)
    if c_l_per_height is None:
        spread = c0_model_spread(omega, c, band, c_err)["c0_model_spread"]
        ref_err = math.hypot(float(att.get("c0_stat_err", att.get("c0_err", math.nan))),
                             spread if math.isfinite(spread) else 0.0)
        return continuum_wavelength(omega, c, alpha, cg, band, float(att["c0"]), c_ref_err=ref_err,
                                    reference="c0", **kw)
    means = np.asarray([m for m, _ in c_l_per_height], float)
    sems = np.asarray([e for _, e in c_l_per_height], float)
    n = np.asarray(counts, float)
    bottom = float(omega[band][0]) if band.any() else math.nan

    def reference(upto):
        mask = band & (omega <= upto) if math.isfinite(upto) else band
        hs = [h for h in range(used.shape[0]) if (used[h] & (mask if mask.any() else band)).any()]
        wts = n[hs] / n[hs].sum()
        return float((wts * means[hs]).sum()), float(math.sqrt((wts**2 * sems[hs] ** 2).sum())), hs

    c_ref, err, hs = reference(bottom)
    out = continuum_wavelength(omega, c, alpha, cg, band, c_ref, c_ref_err=err, reference="c_l", **kw)
    upto = out["omega_star"] if out["status"] != "beyond" else bottom
    c_ref2, err2, hs2 = reference(upto)
    if hs2 != hs:
        out = continuum_wavelength(omega, c, alpha, cg, band, c_ref2, c_ref_err=err2, reference="c_l",
                                   **kw)
        hs = hs2
    out["contributing_heights"] = [float(att["heights"][h]) for h in hs]
    return out


def _stored_number(att: dict, *keys: str) -> float:
    """The first of ``keys`` that a stored result holds as a number; NaN where none does (a
    result without c0 stores null: too few heights in its band)."""
    for key in keys:
        value = att.get(key)
        if value is not None:
            return float(value)
    return math.nan


def c0_ratio_lower_bound(c_lo: float, c_lo_err: float, c_ref: float, c_ref_err: float,
                         t: float) -> float:
    """What the band supports of c0/c_ref: c(ω_lo)/c_ref − t·σ, σ the ratio's error from the two
    relative errors in quadrature (a one-sided 95 % bound for ``t`` = t(0.975, dof)), since c does
    not fall below c(ω_lo) towards ω → 0 where the dispersion is normal. NaN without a reference."""
    if not (c_ref and math.isfinite(c_ref) and math.isfinite(c_lo)):
        return math.nan
    r = c_lo / c_ref
    rel = math.hypot(c_lo_err / c_lo if c_lo else 0.0, (c_ref_err or 0.0) / c_ref)
    return float(r - t * abs(r) * rel)


def low_frequency_of_result(att: dict, c_ref: float | None = None, c_ref_err: float = 0.0) -> dict:
    """c0 of a stored result with its model spread (:func:`c0_model_spread`) added to its error,
    the band's own lower bound c(ω_lo) − t·error, and c0/c_ref with the band's lower bound on it
    (:func:`c0_ratio_lower_bound`)."""
    omega = np.asarray(att["omega"], float)
    band = np.asarray(att["reliable"], bool)
    c = np.asarray(att["c"], float)
    c_err = np.asarray(att["c_err"], float)
    out = dict(c0_model_spread(omega, c, band, c_err))
    stat = _stored_number(att, "c0_stat_err", "c0_err")
    c0 = _stored_number(att, "c0")
    spread = out["c0_model_spread"]
    out.update(c0=c0, c0_stat_err=stat,
               c0_err=math.hypot(stat, spread) if math.isfinite(spread) else stat)
    t = float(att.get("ci95_factor", 2.0))
    i = int(np.flatnonzero(band)[0]) if band.any() else None
    if i is not None:
        out["c0_lower_bound"] = float(c[i] - t * c_err[i])
    if c_ref:
        r = c0 / c_ref
        out.update(c0_over_c_l=r, c0_over_c_l_err=abs(r) * math.hypot(out["c0_err"] / c0,
                                                                      (c_ref_err or 0.0) / c_ref))
        if i is not None:
            out["c0_over_c_l_lower_bound"] = c0_ratio_lower_bound(c[i], c_err[i], c_ref,
                                                                  c_ref_err or 0.0, t)
    return out


def fall_across(att: dict, lo: float, hi: float) -> tuple[float, float]:
    """c(lo) − c(hi) of a result's reliable c(ω) (linearly interpolated), with the two
    standard errors in quadrature: how far c falls across [lo, hi]."""
    omega = np.asarray(att["omega"], float)
    band = np.asarray(att["reliable"], bool)
    c = np.asarray(att["c"], float)[band]
    e = np.asarray(att["c_err"], float)[band]
    w = omega[band]
    if not w.size or lo < w[0] or hi > w[-1]:
        return math.nan, math.nan
    c_lo, c_hi = np.interp(lo, w, c), np.interp(hi, w, c)
    e_lo, e_hi = np.interp(lo, w, e), np.interp(hi, w, e)
    return float(c_lo - c_hi), float(math.hypot(e_lo, e_hi))
