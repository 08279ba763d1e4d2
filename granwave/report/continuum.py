"""The report's continuum section: the front against distance, c_tof/c_l and its approach to
1, and the attenuation and phase velocity of the coherent signal (docs/continuum.md).

Inputs: `granwave analyze continuum --json` (``front``) and `granwave analyze attenuation
--json` (``attenuation``) of each continuum scene; the workflow writes them to
``results/continuum/<scene>/{front,attenuation}.json``. Every number is copied or (c0/c_l)
divided from them; error bars are one standard error unless a confidence interval is named.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from .numbers import fmt, fmt_bound, fmt_count, fmt_named, fmt_positive, num, resolved


def _kind(obj) -> str | None:
    if isinstance(obj, Mapping) and "local" in obj and "approach" in obj:
        return "front"
    if isinstance(obj, Mapping) and "omega" in obj and "alpha" in obj:
        return "attenuation"
    return None


def continuum_inputs(items: Sequence[tuple[Path, object, str | None]]) -> dict[str, dict]:
    """{scene: {"front": obj, "attenuation": obj}}: the scene is the file's folder name."""
    from ..analysis.renamed_keys import HEIGHTS, current_keys

    out: dict[str, dict] = {}
    for path, obj, _ in items:
        kind = _kind(obj)
        if kind:  # the front's local exponents: chi_eff (alpha_eff in older files)
            out.setdefault(Path(path).parent.name, {})[kind] = current_keys(obj, HEIGHTS) \
                if kind == "front" else obj
    return out


def _ci(pair, digits=3) -> str:
    if not pair or any(v is None or not math.isfinite(float(v)) for v in pair):
        return "—"
    return f"[{fmt_bound(pair[0], digits)}, {fmt_bound(pair[1], digits)}]"


def unconstrained(name: str, ci, unit: str = "") -> str:
    """A phrase for a positive quantity whose 95 % interval ``ci`` reaches 0 or spans more than a
    decade: the interval and the one bound it gives ("the fit does not constrain L* ...")."""
    u = f" {unit}" if unit else ""
    lo, hi = (num(v) for v in (ci or (math.nan, math.nan)))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"the fit does not constrain {name} (no finite 95 % interval)"
    if hi <= 0:
        return f"the fit does not resolve {name} (95 % interval {_ci(ci)}{u}, at or below 0)"
    if lo <= 0:
        return (f"the fit does not constrain {name} (95 % interval {_ci(ci)}{u} reaches 0): "
                f"only {name} < {fmt_bound(hi)}{u}")
    return (f"the fit does not constrain {name} (95 % interval {_ci(ci)}{u}, over a decade wide): "
            f"only {name} > {fmt_bound(lo)}{u}")


def approach_sentence(app: Mapping) -> str:
    """One plain sentence on L* (where c_tof is within the tolerance of c_l)."""
    tol = float(app.get("tolerance", 0.05))
    lmax = app.get("L_max")
    status = app.get("status")
    fit = ""
    if app.get("L_star") is not None and math.isfinite(num(app.get("L_star"))):
        ci = app.get("L_star_ci")
        extra = (", an extrapolation beyond the tallest column." if app.get("L_star_extrapolated")
                 else ".")
        if resolved(app["L_star"], None, ci):
            fit = (f" The fit puts L* at {fmt_bound(app['L_star'], 3)} d (95 % interval "
                   f"{_ci(ci)} d)" + extra)
        else:  # an interval over a decade wide, or reaching 0: a bound, not an estimate
            phrase = unconstrained("L*", ci, "d")
            fit = " " + phrase[0].upper() + phrase[1:] + "."
    if status == "beyond":
        return (f"**L* > {float(lmax):.3g} d (lower bound)**: at the tallest distance measured "
                f"c_tof/c_l is still more than {tol:.0%} from 1 by over two standard errors." + fit)
    if status == "reached":
        return (f"**L* ≤ {float(lmax):.3g} d**: at the tallest distance c_tof is within {tol:.0%} of "
                f"c_l by over two standard errors." + fit)
    return (f"**L* undecided**: at the tallest distance ({float(lmax):.3g} d) the error bar of "
            f"c_tof/c_l straddles 1 ± {tol:g}." + fit if lmax is not None else "**L* undecided**.")


def alpha_cell(att: Mapping, i: int) -> str:
    """α at the i-th frequency: an estimate, or an upper bound when not resolved from 0."""
    return fmt_positive(att["alpha"][i], att["alpha_err"][i])


def q_cell(att: Mapping, i: int) -> str:
    """Q = ω/(2 α c_g) at the i-th frequency: an estimate only where α is resolved; else the
    lower bound ω/(2 (α + 2σ) c_g) from α's upper bound α + 2σ (σ its standard error)."""
    a, ea = num(att["alpha"][i]), num(att["alpha_err"][i])
    if resolved(a, ea):
        return fmt_positive(att["Q"][i], att["Q_err"][i])
    lower, upper = a - 2 * ea, a + 2 * ea
    # Q = ω/(2 α c_g) where the analysis gives the group velocity (older files: c)
    w, c = num(att["omega"][i]), num(att.get("c_group", att["c"])[i])
    if not (upper > 0 and w > 0 and c > 0):
        return "not resolved (α not resolved)"
    if lower > 0:  # α within a 95 % interval over a decade wide: Q within its image
        return f"[{fmt_bound(w / (2 * upper * c))}, {fmt_bound(w / (2 * lower * c))}] (95 %)"
    return f"> {fmt_bound(w / (2 * upper * c))} (α consistent with 0)"


def _warnings(obj: Mapping, keys) -> list[str]:
    """The packing rule's warnings of an analysis (granwave.analysis.packings), capitalised."""
    out = []
    for k in keys:
        w = (obj.get(k) or {}).get("warning")
        if w:
            out.append(w[0].upper() + w[1:] + ".")
    return out


def current_lambda(att: Mapping, front: Mapping | None = None) -> tuple[dict, bool]:
    """(λ*, recomputed): the result's continuum length when made by the current rule (one
    reference, its binding threshold named), else recomputed from its stored per-frequency
    columns (:func:`granwave.analysis.continuum_length.lambda_star_of_result`) against the c_ℓ
    of the contributing heights' packings from ``front``'s per-height table (c0 without it)."""
    from ..analysis.continuum_length import lambda_star_of_result

    lam = dict(att.get("continuum_length") or {})
    if "binding" in lam or not all(k in att for k in ("used", "alpha_ci95", "c_group", "c_err")):
        return lam, False
    per = (front or {}).get("per_height") or {}
    pairs = counts = None
    if per.get("c_l") is not None and len(per["c_l"]) == len(att["heights"]):
        pairs = list(zip(per["c_l"], per.get("c_l_sem") or [math.nan] * len(per["c_l"])))
        counts = per["count"]
    new = lambda_star_of_result(att, pairs, counts, c_tol=lam.get("c_tolerance"),
                                q_tol=lam.get("q_inverse_tolerance"))
    wc = lam.get("centroid_frequency")
    if wc is not None and len(wc) == len(att["heights"]):  # L_λ from the stored centroids
        import numpy as np

        from ..analysis.attenuation import _distance_at

        wc, L = np.asarray(wc, float), np.asarray(att["heights"], float)
        if math.isfinite(num(new.get("omega_star"))):
            v, st = _distance_at(wc, L, new["omega_star"])
            new.update({"L_lambda": v, "L_lambda_status": st} if st == "within" else
                       {"L_lambda": math.nan, "L_lambda_status": st, "L_lambda_bound": v})
        if new.get("omega_star_ci"):
            w_lo, w_hi = (num(x) for x in new["omega_star_ci"])
            lo, s_lo = _distance_at(wc, L, w_hi) if math.isfinite(w_hi) else (0.0, "below the shortest")
            hi, s_hi = _distance_at(wc, L, w_lo) if w_lo > 0 else (math.inf, "beyond the tallest")
            new["L_lambda_ci"] = [0.0 if s_lo == "below the shortest" else lo,
                                  math.inf if s_hi == "beyond the tallest" else hi]
    return new, True


def lambda_sentence(lam: Mapping, recomputed: bool = False) -> str:
    """The continuum length in frequency (λ*) in one sentence: its thresholds, its reference,
    its 95 % interval, the threshold that sets it and where it lies against the lateral cutoff."""
    ref = lam.get("reference", "c0")
    ref_txt = {"c_l": "c_ℓ of the contributing heights' packings", "c0": "the extrapolated c0",
               "c_l (given)": "the given c_ℓ"}.get(ref, str(ref))
    if lam.get("c_ref") is not None and math.isfinite(num(lam.get("c_ref"))):
        ref_txt += f" = {fmt(lam.get('c_ref'), lam.get('c_ref_err') or None)}"
        hs = lam.get("contributing_heights")
        if hs:
            ref_txt += " (" + ", ".join(f"{fmt(h, digits=3)}" for h in hs) + " d̄)"
    thr = (f"|c/c_ref − 1| ≤ {num(lam.get('c_tolerance')):g} and Q⁻¹ ≤ "
           f"{num(lam.get('q_inverse_tolerance')):g}, c_ref {ref_txt}")
    st = lam.get("status")
    how = (" (recomputed from the stored per-frequency results by the current rule)" if recomputed
           else "")
    binding = {"dispersion": "the dispersion bound |c/c_ref − 1|", "loss": "the loss bound Q⁻¹",
               "both": "both bounds"}.get(lam.get("binding"), None)
    above = lam.get("omega_star_above_cutoff")
    where = ("" if above is None else
             "; ω* lies above the column's lateral cutoff: this λ* is the waveguide's, not the medium's"
             if above else "; ω* lies below the column's lateral cutoff")
    ci = lam.get("lambda_star_ci")
    # the bootstrap interval (lambda_star_boot_ci) is not quoted: where the loss bound sets λ*
    # it held the truth in fewer than 90 % of the truth suite's seeds (docs/truth.md)
    lo, hi = (num(x) for x in (ci or (math.nan, math.nan)))
    if st == "within" and ci and (lo <= 0 or not math.isfinite(hi)):
        # a one-sided interval: the bound is the measurement, the point value only beside it
        bound = (f"λ* ≤ {fmt_bound(hi, 3)} d̄" if lo <= 0 and math.isfinite(hi) else
                 f"λ* ≥ {fmt_bound(lo, 3)} d̄" if lo > 0 else "λ* not bounded")
        txt = (f"Continuum length in frequency ({thr}): {bound} (95 %, from the per-frequency "
               f"intervals; point value {fmt_bound(lam.get('lambda_star'), 3)} d̄)")
    elif st == "within":
        txt = (f"Continuum length in frequency ({thr}): λ* = {fmt_bound(lam.get('lambda_star'), 3)} d̄"
               + (f" (95 % {_ci_open(ci)} d̄ from the per-frequency intervals)" if ci else ""))
    if st == "within":
        txt += f", ω* = {fmt(lam.get('omega_star'), digits=3)}" + (f", set by {binding}" if binding else "") + where
        if lam.get("L_lambda_status") == "within":
            txt += (f"; the pulse's spectral centroid falls to ω* at L_λ ≈ "
                    f"{fmt_bound(lam.get('L_lambda'), 3)} d̄"
                    + (f" (95 % {_ci_open(lam['L_lambda_ci'])} d̄)" if lam.get("L_lambda_ci") else ""))
        elif str(lam.get("L_lambda_status", "")).startswith("beyond"):
            txt += (f"; the pulse's spectral centroid is still above ω* at the tallest column "
                    f"(L_λ > {fmt_bound(lam.get('L_lambda_bound'), 3)} d̄)")
        return txt + how + "."
    if st == "whole band":
        return (f"Continuum length in frequency ({thr}): the bounds hold over the whole reliable "
                f"band, so λ* ≤ {fmt_bound(lam.get('lambda_bound'), 3)} d̄ (an upper bound)" + how + ".")
    if st == "beyond":
        return (f"Continuum length in frequency ({thr}): "
                + (f"{binding} " if binding else "the bounds ")
                + f"already fail at the band's bottom, so λ* > {fmt_bound(lam.get('lambda_bound'), 3)} d̄ "
                "(a lower bound)" + how + ".")
    return "Continuum length in frequency: undetermined (no reliable band or no reference)."


def _ci_open(pair) -> str:
    """A 95 % interval whose ends may be 0 or ∞ (one-sided)."""
    if not pair:
        return "—"
    lo, hi = num(pair[0]), num(pair[1])
    if not math.isfinite(hi) and lo > 0:
        return f"≥ {fmt_bound(lo, 3)}"
    if lo <= 0 and math.isfinite(hi):
        return f"≤ {fmt_bound(hi, 3)}"
    if lo <= 0 and not math.isfinite(hi):
        return "unbounded"
    return _ci(pair)


def low_frequency_phrase(att: Mapping, lam: Mapping) -> str:
    """c0 (the extrapolation, its error with the spread over fit spans and forms), the band's
    own lower bound on it, and c0/c_ℓ against λ*'s reference when that is the contributing
    heights' c_ℓ (recomputed for a record made before these fields)."""
    from ..analysis.continuum_length import low_frequency_of_result

    ref = lam.get("c_ref") if lam.get("reference") == "c_l" else None
    low = low_frequency_of_result(att, ref, lam.get("c_ref_err") or 0.0)
    fit = att.get("omega_fit") or [math.nan, math.nan]
    # no ± on the extrapolation: its interval undercovers where the band starts after c has
    # fallen (docs/truth.md, attenuation.c0); the band's bound is the measurement
    txt = (f"low-frequency extrapolation c0 = {fmt(low['c0'], digits=4)} √(E*/ρ) (c = c0 + c2 ω² "
           f"over ω = {fmt(fit[0], digits=3)} … {fmt(fit[-1], digits=3)}; not a measurement: it moves "
           f"by {fmt(low['c0_model_spread'], digits=2)} over fit spans and forms); "
           f"what the band itself says: c0 ≥ {fmt(low.get('c0_lower_bound'), digits=4)} (c at its "
           "bottom, 95 %)")
    if "c0_over_c_l" in low:
        txt += (f"; against the contributing heights' c_ℓ the band says c0/c_ℓ ≥ "
                f"{fmt(low.get('c0_over_c_l_lower_bound'), digits=4)} (95 %), the extrapolation "
                f"c0/c_ℓ = {fmt(low['c0_over_c_l'], digits=4)} (not a validated measurement: "
                "docs/truth.md)")
    return txt


def cutoff_sentence(att: Mapping) -> str:
    """Where the column's first lateral shear cutoff lies against the reliable band."""
    cut = att.get("omega_cutoff")
    if cut is None or not math.isfinite(num(cut)):
        return ("The column's first lateral shear cutoff 2π c_t/L1 was not given: whether α(ω) and "
                "c(ω) are the medium's or the waveguide's is not checked here.")
    band = att.get("band") or [math.nan, math.nan]
    where = ("the reliable band lies below it: α and c there are the medium's"
             if num(band[1]) <= num(cut) else
             "the reliable band reaches above it: there α and c are the waveguide's, not the medium's")
    return f"First lateral shear cutoff 2π c_t/L1 = {fmt(cut, digits=3)} √(E*/ρ)/d̄: {where}."


#: The report's words for the c_ℓ an analysis used (``c_l_kind`` of `analyze continuum`).
C_L_KINDS = {"slab": "c_ℓ and c_t of the bulk slab (its moduli over its own density)",
             "cell": "c_ℓ and c_t of the whole cell (its moduli over the bulk density)"}


#: the report's names of the candidate arrival rules (`candidates` of `analyze continuum`)
RULE_NAMES = {"peak": "peak", "energy": "energy centroid"}


def _rule_name(rule: str) -> str:
    if rule.startswith("edge_"):
        return f"{float(rule[5:]):.0%} edge"
    return RULE_NAMES.get(rule, rule)


def _candidate_cell(row: Mapping) -> str:
    """One candidate L*: the fit's value and 95 % interval, marked by what the data say."""
    value, ci = row.get("L_star"), row.get("L_star_ci")
    if value is None or not math.isfinite(num(value)):
        return "—"
    text = f"{fmt_bound(value, 3)} {_ci(ci)}" if resolved(value, None, ci) else f"{fmt_bound(value, 3)}"
    mark = {"reached": "", "undecided": " (undecided)", "beyond": " (beyond: extrapolated)"}
    return text + mark.get(row.get("status"), "")


def candidates_table(front: Mapping) -> list[str]:
    """Markdown lines: how the time-of-flight "L*" moves with the arrival rule, the tolerance and
    the c_ℓ reference (``candidates`` of `analyze continuum`), with each rule's last local ratio."""
    cand = front.get("candidates")
    if not cand:
        return []
    scales = cand["c_l_scales"]
    rows = {(r["rule"], r["tolerance"], r["c_l_scale"]): r for r in cand["table"]}
    md = ["Candidate L* (d̄, where the rule's local speed comes within the tolerance of c_ℓ × the "
          "reference factor; the approach fit's value and its 95 % interval; *beyond*: the tallest "
          "distance is still outside, so L* is the fit's extrapolation; *undecided*: the last "
          "ratio's error bar straddles the tolerance):", "",
          "| rule | tolerance | " + " | ".join(f"c_ℓ × {x:g}" for x in scales)
          + " | speed/c_ℓ at the tallest distance |",
          "|---|---|" + "---|" * len(scales) + "---|"]
    for rule, sp in cand["speeds"].items():
        last = f"{fmt(sp['ratio'][-1], sp['ratio_err'][-1])} (L = {fmt(sp['height'][-1], digits=3)})"
        for tol in cand["tolerances"]:
            cells = [_candidate_cell(rows.get((rule, tol, x), {})) for x in scales]
            md.append(f"| {_rule_name(rule)} | {tol:.0%} | " + " | ".join(cells) + f" | {last} |")
    return md + [""]


def continuum_section(scenes: Mapping[str, Mapping], dims: Mapping[str, int] | None = None) -> list[str]:
    """Markdown lines of the continuum section (one subsection per scene; ``dims``: each
    scene's dimension, from the config, for the comparison of widths)."""
    if not scenes:
        return []
    md = ["## Continuum: the front against distance and its approach to c_ℓ", "",
          "Columns of several heights L (source–detector distance, d̄); time-domain signals; c_ℓ "
          "and c_t from each packing's own moduli (which ones: each scene's line below). "
          "Local speeds are dL/dt between "
          "consecutive heights (group means), at the geometric mean height; the apparent speed is "
          "L/t of each packing. Error bars: one standard error over packings (docs/continuum.md).",
          ""]
    from ..analysis.renamed_keys import HEIGHTS, current_keys

    for scene, d in sorted(scenes.items()):
        front, att = d.get("front"), d.get("attenuation")
        front = current_keys(front, HEIGHTS) if front else front  # chi_eff: alpha_eff before
        md += [f"### {scene}", ""]
        if front:
            cl, ct = front.get("c_l", {}), front.get("c_t", {})
            md += [f"- pressure {front.get('pressure')}, {front['n_signals']} packings at "
                   f"{front['n_heights']} heights; {C_L_KINDS.get(front.get('c_l_kind'), 'c_ℓ')}: "
                   f"c_ℓ = {fmt(cl.get('mean'), cl.get('sem'))}, "
                   f"c_t = {fmt(ct.get('mean'), ct.get('sem'))} √(E*/ρ) (mean ± s.e. over all packings)"]
            bulk = front.get("c_l_bulk") or {}
            if bulk.get("c_l_inf") is not None and math.isfinite(float(bulk["c_l_inf"])):
                md[-1] += (f"; 1/c_ℓ² = 1/c_ℓ∞² + b/L over the packings gives "
                           f"c_ℓ∞ = {fmt(bulk['c_l_inf'], bulk.get('c_l_inf_err'))} (b = {fmt(bulk.get('b'), digits=3)})")
            md.append("")
            per = front["per_height"]
            md += ["| L (d̄) | n | c_ℓ | L/t₁₀ | (L/t₁₀)/c_ℓ | \\|A\\| (E* d̄²) | W (d̄/√(E*/ρ)) |",
                   "|---|---|---|---|---|---|---|"]
            for i in range(len(per["height"])):
                md.append(f"| {fmt(per['height'][i])} | {int(per['count'][i])} | "
                          f"{fmt(per['c_l'][i], per['c_l_sem'][i])} | "
                          f"{fmt(per['c_tof_apparent'][i], per['c_tof_apparent_sem'][i])} | "
                          f"{fmt(per['ratio_apparent'][i], per['ratio_apparent_err'][i])} | "
                          f"{fmt(per['amplitude'][i], per['amplitude_sem'][i])} | "
                          f"{fmt(per['width'][i], per['width_sem'][i])} |")
            loc = front["local"]
            md += ["", "| L mid (d̄) | c_tof | c_peak | c_zero | c_tof/c_ℓ | γ_eff | χ_eff |",
                   "|---|---|---|---|---|---|---|"]
            for i in range(len(loc["height"])):
                md.append(f"| {fmt(loc['height'][i])} | {fmt(loc['c_tof'][i], loc['c_tof_err'][i])} | "
                          f"{fmt(loc['c_peak'][i], loc['c_peak_err'][i])} | "
                          f"{fmt(loc['c_zero'][i], loc['c_zero_err'][i])} | "
                          f"{fmt(loc['ratio'][i], loc['ratio_err'][i])} | "
                          f"{fmt(loc['gamma_eff'][i], loc['gamma_eff_err'][i], 3)} | "
                          f"{fmt(loc['chi_eff'][i], loc['chi_eff_err'][i], 3)} |")
            app = front.get("approach", {})
            md += ["", f"Approach of the local c_tof/c_ℓ: {app.get('model', '')} fitted over "
                   f"{fmt_count(app.get('n'))} distances: β = "
                   f"{fmt_positive(app.get('beta'), app.get('beta_err'), app.get('beta_ci'), digits=3)} "
                   f"(95 % {_ci(app.get('beta_ci'))}), a = {fmt(app.get('a'), app.get('a_err'), 3)}."]
            free = app.get("free_limit") or {}
            if "r_inf" in free:
                ci = free.get("r_inf_ci")
                if resolved(free["r_inf"], free.get("r_inf_err"), ci):
                    md[-1] += (f" With the limit free: c_tof/c_ℓ → "
                               f"{fmt(free['r_inf'], free.get('r_inf_err'))} (95 % {_ci(ci)}).")
                else:
                    md[-1] += (" With the limit free, " + unconstrained("the limit of c_tof/c_ℓ", ci)
                               + ".")
            if app.get("fit_error"):
                md[-1] += f" The fit failed: {app['fit_error']}."
            md += ["", approach_sentence(app)]
            bci = app.get("L_star_boot_ci")
            if bci and all(v is not None for v in bci):
                md[-1] += (f" Bootstrap over the packings within each height through the whole chain "
                           f"(arrival times, local speeds, ratios, fit; {app.get('bootstrap')} "
                           f"resamplings): L* 95 % interval {_ci(bci)} d.")
            md += [f"**{w}**" for w in _warnings(front, ("packings_per_height", "packings"))]
            md.append("")
            md += candidates_table(front)
            appb = front.get("approach_bulk") or {}
            if appb.get("beta") is not None and math.isfinite(float(appb.get("beta") or math.nan)):
                md += [f"Against the bulk c_ℓ∞ instead (local c_tof/c_ℓ∞ = "
                       + ", ".join(fmt(r, e) for r, e in zip(loc["ratio_bulk"], loc["ratio_bulk_err"]))
                       + f"): β = {fmt_positive(appb.get('beta'), appb.get('beta_err'), appb.get('beta_ci'), digits=3)} "
                       f"(95 % {_ci(appb.get('beta_ci'))}), "
                       + (f"L* ≈ {fmt_bound(appb.get('L_star'), 3)} d (95 % {_ci(appb.get('L_star_ci'))})"
                          if resolved(appb.get('L_star'), None, appb.get('L_star_ci'))
                          else "and " + unconstrained("L*", appb.get("L_star_ci"), "d"))
                       + ".", ""]
        if att:
            band = att.get("band", [math.nan, math.nan])
            md += [f"Attenuation and phase velocity of the coherent (ensemble-mean) signal over "
                   f"{len(att['heights'])} heights ({att['n_signals']} signals): reliable band "
                   f"ω = {fmt(band[0], digits=3)} … {fmt(band[1], digits=3)} √(E*/ρ)/d̄ (a height "
                   f"counts at ω where its window after the arrival holds ≥ {att.get('min_periods', 0):g} "
                   f"period and its |S| is ≥ {att.get('min_snr', 0):g} × its noise floor; reliable where "
                   f"≥ {att.get('min_heights', 2)} heights count, the ln|S| fit passes χ² at "
                   f"p ≥ {att.get('min_fit_p', 0):g} and every counted |S| ≥ {att['threshold']:g} of its "
                   f"maximum)"]
            rel_idx = [i for i, ok in enumerate(att["reliable"]) if ok]
            if rel_idx:
                i0, i1 = rel_idx[0], rel_idx[-1]
                md[-1] += (f"; {fmt_named('α', fmt_positive(att['alpha'][i0], att['alpha_err'][i0]))} "
                           f"/d̄ at the band's bottom and "
                           f"{fmt_named('α', fmt_positive(att['alpha'][i1], att['alpha_err'][i1]))} "
                           f"/d̄ at its top")
            lam_now, recomputed = current_lambda(att, front)
            md[-1] += "; " + low_frequency_phrase(att, lam_now)
            if front and front.get("c_l", {}).get("mean") and lam_now.get("reference") != "c_l":
                # the extrapolation's ratios, without a ± (not a measurement, as c0 itself)
                cl = front["c_l"]
                r = float(att["c0"]) / float(cl["mean"]) if att.get("c0") else math.nan
                md[-1] += f", its c0/c_ℓ = {fmt(r, digits=4)} (mean c_ℓ of all packings)"
                bulk = front.get("c_l_bulk") or {}
                cb = bulk.get("c_l_inf")
                if cb is not None and math.isfinite(float(cb)) and att.get("c0"):
                    md[-1] += f", c0/c_ℓ∞ = {fmt(float(att['c0']) / float(cb), digits=4)} (bulk c_ℓ∞)"
            md[-1] += (f"; at the tallest column's spectral peak ω = {fmt(att.get('omega_ref'), digits=3)}: "
                       f"c = {fmt(att.get('c_ref'), att.get('c_ref_err'))}, "
                       + (f"{fmt_named('α', fmt_positive(att.get('alpha_ref'), att.get('alpha_ref_err')))} /d̄"
                          if num(band[0]) <= num(att.get("omega_ref")) <= num(band[1])
                          else "α not shown (this ω is outside the reliable band)"))
            md[-1] += (f" (error bars: the larger of the fit's standard error and the bootstrap over "
                       f"packings, {att.get('bootstrap', 0)} resamplings).")
            if "c_group" in att:
                md[-1] += (" The ln|S| and phase fits are weighted by each height's variance over its "
                           "packings, |S| is debiased for the incoherent remainder, and "
                           "Q = ω/(2 α c_g) with the group velocity c_g = dω/dk. "
                           + cutoff_sentence(att))
            if lam_now.get("status"):
                md[-1] += " " + lambda_sentence(lam_now, recomputed)
            md += [f"**{w}**" for w in _warnings(att, ("packings",))]
            md += ["", "Within the reliable band (outside it α and Q are not shown); α and Q are "
                   "positive, so an α whose 95 % interval (± 2 errors) reaches 0 is an upper bound "
                   "and Q then a lower bound, Q > ω/(2 (α + 2σ) c_g); where that interval spans more "
                   "than a decade only the interval is shown, for α and for Q:", "",
                   *(["| ω | α (1/d̄) | Q | c(ω) | c_g(ω) |", "|---|---|---|---|---|"]
                     if "c_group" in att else ["| ω | α (1/d̄) | Q | c(ω) |", "|---|---|---|---|"])]
            idx = [i for i, ok in enumerate(att["reliable"]) if ok]
            cut = num(att.get("omega_cutoff"))
            for i in idx[:: max(1, len(idx) // 8)]:
                row = (f"| {fmt(att['omega'][i], digits=3)}"
                       + (" (above the cutoff)" if math.isfinite(cut) and num(att["omega"][i]) > cut else "")
                       + f" | {alpha_cell(att, i)} | {q_cell(att, i)} | {fmt(att['c'][i], att['c_err'][i])} |")
                if "c_group" in att:
                    row += f" {fmt(att['c_group'][i], att['c_group_err'][i])} |"
                md.append(row)
            md.append("")
    md += width_comparison(scenes, dims or {})
    return md


def _at(att: Mapping, key: str, omega: float) -> tuple[float, float]:
    """``key`` and its error interpolated linearly at ``omega`` between the reliable frequencies
    of an attenuation result (nan outside them)."""
    idx = [i for i, ok in enumerate(att["reliable"]) if ok and att[key][i] is not None]
    w = [num(att["omega"][i]) for i in idx]
    if not idx or not w[0] <= omega <= w[-1]:
        return math.nan, math.nan
    value = [num(att[key][i]) for i in idx]
    error = [num(att[f"{key}_err"][i]) for i in idx]
    j = next((k for k in range(1, len(w)) if w[k] >= omega), 0)
    t = 0.0 if j == 0 or w[j] == w[j - 1] else (omega - w[j - 1]) / (w[j] - w[j - 1])
    lo = max(j - 1, 0)
    return value[lo] + t * (value[j] - value[lo]), error[lo] + t * (error[j] - error[lo])


def width_comparison(scenes: Mapping[str, Mapping], dims: Mapping[str, int], points: int = 5) -> list[str]:
    """Markdown lines comparing c(ω) and α(ω) of scenes of one dimension (``dims``: scene →
    2 or 3; scenes not in it are left out) at one pressure whose columns differ in width (so in
    their first lateral cutoff 2π c_t/L1), at ``points`` frequencies spread over the overlap of
    their reliable bands: each scene's value against the widest column's, in units of their
    combined standard error. Nothing unless two such scenes have both analyses."""
    groups: dict[tuple[int, float], list[tuple[str, Mapping]]] = {}
    for scene, d in sorted(scenes.items()):
        front, att = d.get("front"), d.get("attenuation")
        if front and att and att.get("omega_cutoff") and front.get("pressure") is not None \
                and scene in dims:
            groups.setdefault((int(dims[scene]), float(front["pressure"])), []).append((scene, att))
    md: list[str] = []
    for (dim, pressure), members in sorted(groups.items()):
        if len({num(a["omega_cutoff"]) for _, a in members}) < 2:
            continue
        members.sort(key=lambda m: num(m[1]["omega_cutoff"]))  # the widest column first
        (ref, ref_att), others = members[0], members[1:]
        lo = max(num(a["band"][0]) for _, a in members)
        hi = min(num(a["band"][1]) for _, a in members)
        names = ", ".join(f"`{n}` (cutoff {fmt(a['omega_cutoff'], digits=3)})" for n, a in members)
        md += [f"### The medium or the waveguide: {dim}D, p = {pressure:g}", "",
               f"c(ω) and α(ω) of {names}, interpolated between reliable frequencies, against the "
               f"widest column `{ref}`; Δ/σ: the difference over the two standard errors combined "
               "(frequencies above a column's cutoff are marked †)."]
        if not lo < hi:
            md += ["", f"Their reliable bands do not overlap (common range {fmt(lo, digits=3)} … "
                   f"{fmt(hi, digits=3)}): no comparison.", ""]
            continue
        head = ["ω"] + [f"c `{n}`" for n, _ in members] + [f"Δc/σ `{n}`" for n, _ in others] \
            + [f"α `{n}` (1/d̄)" for n, _ in members] + [f"Δα/σ `{n}`" for n, _ in others]
        md += ["", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for k in range(points):
            omega = lo + (hi - lo) * k / (points - 1)
            c = {n: _at(a, "c", omega) for n, a in members}
            al = {n: _at(a, "alpha", omega) for n, a in members}

            def sigmas(v, n):
                d, e = v[n][0] - v[ref][0], math.hypot(v[n][1], v[ref][1])
                return f"{d / e:+.1f}" if e > 0 and math.isfinite(d / e) else "—"

            def mark(n, a):
                return "†" if omega > num(a["omega_cutoff"]) else ""

            md.append(f"| {fmt(omega, digits=3)} | "
                      + " | ".join(fmt(*c[n]) + mark(n, a) for n, a in members) + " | "
                      + " | ".join(sigmas(c, n) for n, _ in others) + " | "
                      + " | ".join(fmt_positive(*al[n]) for n, _ in members) + " | "
                      + " | ".join(sigmas(al, n) for n, _ in others) + " |")
        md.append("")
        md += slope_comparison(members, lo, hi)
    return md


def slope_comparison(members, lo: float, hi: float) -> list[str]:
    """How far c falls across the common band [lo, hi] in each scene (c(lo) − c(hi), the two
    standard errors in quadrature: :func:`granwave.analysis.continuum_length.fall_across`) and
    each pair's difference in combined standard errors: whether the dispersion moves with width."""
    from ..analysis.continuum_length import fall_across

    falls = [(n, *fall_across(a, lo, hi)) for n, a in members]
    if not all(math.isfinite(f) for _, f, _ in falls):
        return []
    md = [f"Fall of c across the common band (c({fmt(lo, digits=3)}) − c({fmt(hi, digits=3)}), the "
          "two ends' standard errors in quadrature): "
          + "; ".join(f"`{n}` {fmt(f, e)}" for n, f, e in falls) + ". Differences: "]
    pairs = []
    for i in range(len(falls)):
        for j in range(i + 1, len(falls)):
            (a, fa, ea), (b, fb, eb) = falls[i], falls[j]
            pairs.append(f"`{b}` − `{a}` = {fmt(fb - fa, math.hypot(ea, eb))} "
                         f"({(fb - fa) / math.hypot(ea, eb):+.1f} σ)")
    big = any(abs(fb - fa) > 2 * math.hypot(ea, eb) for i, (_, fa, ea) in enumerate(falls)
              for (_, fb, eb) in falls[i + 1:])
    md[-1] += "; ".join(pairs) + (". At least one pair differs by more than 2 σ: the dispersion "
                                  "moves with width." if big else
                                  ". No pair differs by 2 σ, which shows neither that the dispersion "
                                  "moves with width nor that it does not: width independence is not "
                                  "resolved at this precision.")
    return md + [""]
