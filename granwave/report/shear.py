"""The report's shear section (docs/shear.md, "The shear scene"): Vstat_cell(p), V_p(p), G_max(p)
against p^(1/3) and the measured exponent, V_p/V_s and the Poisson ratio from waves and from
the moduli, and the pick table (which pick lands within 5 % of c_t at which distance and
wavelength).

Input: the workflow's shear analyses (``results/shear/<scene>/analysis.json``, written by
:func:`granwave.analysis.shear_scene.shear_scene`). Every number is copied from them;
errors are one standard error (over packings, or of a fit through the per-pressure means).
:func:`pick_table` is also what docs/shear.md's generated table is made of.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from .numbers import MISSING, fmt, fmt_ci, fmt_count, fmt_positive, fmt_range, num


def _is_analysis(obj) -> bool:
    return isinstance(obj, Mapping) and "pick_table" in obj and "pressures" in obj


def shear_inputs(items: Sequence[tuple[Path, object, str | None]]) -> dict[str, Mapping]:
    """{scene: analysis} of the shear analyses among ``items`` (the scene: the analysis's own
    ``scene``, else the file's folder name)."""
    out: dict[str, Mapping] = {}
    for path, obj, _ in items:
        if _is_analysis(obj):
            out[str(obj.get("scene") or Path(path).parent.name)] = obj
    return out


#: A compressional pick this many times c_ℓ (the packing's long-wave speed, which dispersion
#: only lowers) cannot be the wave: the pick has skipped a cycle of the pulse.
FASTEST_P = 1.1


def stat_cell(stat: Mapping | None, digits: int = 4) -> str:
    """mean ± standard error over 5 packings or more; over fewer the range of the values (two
    values are exactly mean ± sem) or, where it cannot be had, the mean without a ±."""
    stat = stat or {}
    n = stat.get("n")
    if n is not None and num(n) < 5:
        if stat.get("min") is not None and stat.get("max") is not None:
            return fmt_range(stat["min"], stat["max"])
        m, e = num(stat.get("mean")), num(stat.get("sem"))
        if num(n) == 2 and math.isfinite(e):
            return fmt_range(m - e, m + e)
        return fmt(m, None, digits) + (f" (mean of {fmt_count(n)})" if num(n) > 1 else "")
    return fmt(stat.get("mean"), stat.get("sem"), digits)


def _fit(fit: Mapping | None) -> str:
    if not fit:
        return MISSING
    ci = fit.get("exponent_ci95") or (None, None)
    return fmt_ci(fit.get("exponent"), fit.get("exponent_err"), *ci, 3)


def compressional_ratio(analysis: Mapping) -> dict[float, Mapping]:
    """{pressure: c_ℓ/c_t of the moduli (mean and standard error over the packings of the fit
    height)}: the speed, in units of c_t, at which the shear kick's compressional precursor
    arrives (docs/shear.md); a pick near it reads that precursor, not the shear wave."""
    return {num(r["pressure"]): r.get("ratio_moduli") or {} for r in analysis.get("pressures", [])}


def pick_table(analysis: Mapping) -> list[str]:
    """The pick table as Markdown lines: per pressure, wavelength and height, c_ℓ/c_t (the
    compressional precursor's speed, :func:`compressional_ratio`), every pick's V/c_t (mean ±
    standard error over the packings) and the picks within the tolerance."""
    picks = list(analysis["picks"])
    tol = num(analysis.get("tolerance", 0.05))
    ratio = compressional_ratio(analysis)
    lines = ["| p (E*) | λ (d̄) | L (d̄) | n | c_ℓ/c_t (P) | " + " | ".join(f"`{p}`" for p in picks)
             + f" | within {tol:.0%} |", "|---|---|---|---|---|" + "---|" * len(picks) + "---|"]
    for row in analysis["pick_table"]:
        cells = [fmt(row.get(p), row.get(f"{p}_err"), 3) for p in picks]
        ok = ", ".join(f"`{p}`" for p in row.get("within_5pct", [])) or "none"
        lines.append(f"| {num(row['pressure']):g} | {num(row['wavelength']):g} | "
                     f"{fmt(row.get('height'), digits=3)} | {fmt_count(row.get('n'))} | "
                     f"{stat_cell(ratio.get(num(row['pressure'])), 3)} | "
                     + " | ".join(cells) + f" | {ok} |")
    return lines


def _verdict(analysis: Mapping) -> str:
    """Which picks come within the tolerance at every height, some, or never (over all rows)."""
    rows = analysis["pick_table"]
    if not rows:
        return ""
    always = [p for p in analysis["picks"] if all(p in r.get("within_5pct", []) for r in rows)]
    never = [p for p in analysis["picks"] if not any(p in r.get("within_5pct", []) for r in rows)]
    tol = f"{num(analysis.get('tolerance', 0.05)):.0%}"
    parts = [f"within {tol} of c_t in every row: " + (", ".join(f"`{p}`" for p in always) or "no pick"),
             f"in no row: " + (", ".join(f"`{p}`" for p in never) or "none")]
    return "Over the rows below, " + "; ".join(parts) + "."


def shear_section(scenes: Mapping[str, Mapping]) -> list[str]:
    """The section's Markdown lines (empty without a shear scene)."""
    if not scenes:
        return []
    md = ["## Shear waves: V_s, V_p, G_max and the arrival picks", "",
          "Packings of a frictional scene kicked along x (shear) and along y (compressional) as a "
          "bender element would (docs/shear.md): both kicks are impulses convolved with the source "
          "pulse at f = c/λ (c the packing's own c_t or c_ℓ from its moduli); V = L/T of the scene's "
          "pick. Speeds in √(E*/ρ), moduli in E* (grain density 1; G_max = Φ3* V_s²); errors one "
          "standard error over packings (rows) or of the fit through the per-pressure means "
          "(exponents).", ""]
    for scene, a in sorted(scenes.items()):
        dim = int(a.get("dim", 2))
        md += [f"### {scene} ({dim}D, packings of {a.get('source_scene', '?')})", ""]
        h = a.get("fit_height")
        md += [f"- pick `{a['pick']}`, {a.get('pulse')} pulse, λ = {num(a['wavelengths'][0]):g} d̄; "
               f"speeds at the nominal height {num(h):g} d̄; {fmt_count(a['n_records'])} packings in all"
               + (f" ({fmt_count(a['n_skipped'])} without moduli, skipped)" if a.get("n_skipped") else ""),
               ""]
        md += ["| p (E*) | n | V_s | c_t | V_s/c_t | V_p | c_ℓ | V_p/c_ℓ | G_max | G (moduli) |",
               "|---|---|---|---|---|---|---|---|---|---|"]
        for r in a["pressures"]:
            md.append(f"| {num(r['pressure']):g} | {fmt_count(r['n'])} | {stat_cell(r['V_s'])} | {stat_cell(r['c_t'])} | "
                      f"{stat_cell(r['V_s_over_c_t'], 3)} | {stat_cell(r['V_p'])} | {stat_cell(r['c_l'])} | "
                      f"{stat_cell(r['V_p_over_c_l'], 3)} | {stat_cell(r['G_max'])} | {stat_cell(r['G_moduli'])} |")
        if all("c_t_cell" in r for r in a["pressures"]):
            refs = sorted({x for r in a["pressures"] for x in r.get("speed_reference", [])})
            md += ["", f"c_t, c_ℓ above: {' and '.join(refs) or '?'} (the bulk slab's own strain and "
                   "density, one rattler rule; the whole cell's where a column has no slab). Beside "
                   "them the whole cell's c_t (its moduli over its own Φ3*)"
                   + (" and, in 3D, the eigen-speed of the whole cell's in-plane shear block "
                      "[[C55, C45], [C45, C44]] polarised nearest x, the direction the kick excites "
                      "(c_t,x):" if dim == 3 else ":"), ""]
            head = "| p (E*) | c_t | c_t (cell) | V_s/c_t (cell) |" + (" C45/√(C44 C55) | c_t,x (cell) | V_s/c_t,x |" if dim == 3 else "")
            md += [head, "|---|---|---|---|" + ("---|---|---|" if dim == 3 else "")]
            for r in a["pressures"]:
                line = (f"| {num(r['pressure']):g} | {stat_cell(r['c_t'])} | {stat_cell(r['c_t_cell'])} | "
                        f"{stat_cell(r['V_s_over_c_t_cell'], 3)} |")
                if dim == 3:
                    line += f" {stat_cell(r['C45_ratio'], 3)} | {stat_cell(r['c_t_x_cell'])} | {stat_cell(r['V_s_over_c_t_x_cell'], 3)} |"
                md.append(line)
        fast = [r for r in a["pressures"] if num((r.get("V_p_over_c_l") or {}).get("mean")) > FASTEST_P]
        if fast:
            md += ["", f"**V_p above {FASTEST_P:g} c_ℓ at p = "
                   + ", ".join(f"{num(r['pressure']):g}" for r in fast)
                   + "**: faster than the packing's compressional waves, so the pick locked onto an "
                   "earlier cycle of the pulse (V = c/(1 − λ/L) for one period; docs/shear.md); V_p, "
                   "V_p/V_s and ν_eff (waves) of those rows are not measurements."]
        f = a.get("fits", {})
        md += ["", "Pressure exponents (c ∝ p^κ, G ∝ p^κ_G; the fitted slope [its 95 % interval], "
               "Student t with n − 2 degrees of freedom):", "",
               "| quantity | from waves | from the moduli |", "|---|---|---|",
               f"| shear speed | κ_s = {_fit(f.get('V_s'))} | {_fit(f.get('c_t'))} |",
               f"| compressional speed | κ_p = {_fit(f.get('V_p'))} | {_fit(f.get('c_l'))} |",
               f"| G_max | κ_G = {_fit(f.get('G_max'))} | {_fit(f.get('G_moduli'))} |", ""]
        g = a.get("G_max", {})
        hz, free = g.get("hertz"), g.get("free")
        if hz and free:
            dev = num(g.get("deviation_from_hertz"))
            md += [f"G_max against p^(1/3) (Hertz–Mindlin effective medium): G_max = "
                   f"{fmt_positive(hz['prefactor'], hz.get('prefactor_err'), digits=3)} × p^(1/3), rms log "
                   f"residual {fmt(hz['rms_log_residual'], digits=2)}; with the measured exponent "
                   f"κ_G = {_fit(free)}: G_max prefactor "
                   f"{fmt_positive(free['prefactor'], free.get('prefactor_err'), digits=3)} (× p^κ_G), "
                   f"rms log residual {fmt(free['rms_log_residual'], digits=2)}"
                   + (f"; κ_G − 1/3 = {fmt(dev, digits=2)} standard errors." if math.isfinite(dev) else "."),
                   ""]
        si = a.get("si")
        if si:
            if si.get("poisson_mismatch"):
                md += [f"**Not {si['material']} beads:** {si['poisson_mismatch']}. The table below "
                       f"scales these packings with {si['material']}'s E* and ρ only.", ""]
            if dim == 2:
                md += ["2D moduli are those of a layer one d̄ thick (docs/units.md, the \"3D pressure\" "
                       "convention): × d̄ gives the modulus per unit length of wall (MPa × mm = kN/m).",
                       ""]
            md += [f"In SI units for {si['material']} grains (E* = {num(si['E_star_GPa']):.4g} GPa, "
                   f"ρ = {num(si['density']):g} kg/m³) of mean diameter {num(si['diameter_mm']):g} mm "
                   f"(docs/units.md; f: the source frequency of λ = {num(si['wavelength']):g} d̄):", "",
                   "| p (kPa) | V_s (m/s) | c_t (m/s) | V_p (m/s) | c_ℓ (m/s) | G_max (MPa) | G moduli (MPa) "
                   "| f shear (kHz) | f compr. (kHz) |", "|---|---|---|---|---|---|---|---|---|"]
            for r in si["rows"]:
                md.append(f"| {fmt(r['pressure_kPa'], digits=3)} | {stat_cell(r['V_s_m_s'], 3)} | {stat_cell(r['c_t_m_s'], 3)} | "
                          f"{stat_cell(r['V_p_m_s'], 3)} | {stat_cell(r['c_l_m_s'], 3)} | {stat_cell(r['G_max_MPa'], 3)} | "
                          f"{stat_cell(r['G_moduli_MPa'], 3)} | {fmt(r['f_shear_kHz'], digits=3)} | "
                          f"{fmt(r['f_normal_kHz'], digits=3)} |")
            md.append("")
        md += [f"V_p/V_s and the packing's effective Poisson ratio ν_eff: from waves V_p/V_s, from the "
               f"moduli c_ℓ/c_t, then ν_eff by the isotropic formula "
               f"`{a.get('poisson_formula', '')}` (r the speed ratio); the tensor's own ratio "
               f"`{a.get('tensor_formula', '')}` differs where the packing is anisotropic.", "",
               "| p (E*) | V_p/V_s | c_ℓ/c_t | ν_eff (waves) | ν_eff (moduli) | ν_eff (tensor) |",
               "|---|---|---|---|---|---|"]
        for r in a["pressures"]:
            md.append(f"| {num(r['pressure']):g} | {stat_cell(r['ratio_waves'], 3)} | {stat_cell(r['ratio_moduli'], 3)} | "
                      f"{stat_cell(r['poisson_waves'], 3)} | {stat_cell(r['poisson_moduli'], 3)} | "
                      f"{stat_cell(r['poisson_tensor'], 3)} |")
        md += ["", f"Pick table: V/c_t of every pick (docs/shear.md) per pressure, wavelength and "
               f"nominal height (L its mean wall-to-wall distance). c_ℓ/c_t (P): the moduli's ratio "
               f"at that pressure (packings of the fit height), the speed of the compressional "
               f"precursor the shear kick launches; a pick near or above it reads that precursor, not "
               f"the shear wave. " + _verdict(a), ""]
        md += pick_table(a) + [""]
    return md
