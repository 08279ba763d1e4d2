"""The report's tables: cells, Markdown pipe tables, and one builder per section.

Rules (also in docs/figures.md, "The report"):

* **Rows per scene, pressure and container height.** Bulk statistics of
  different heights are never pooled: the summaries of a scene are split into
  nominal heights (:func:`granwave.analysis.heights.group_heights`, relative
  tolerance 5 %, over the whole scene so that one nominal height keeps its
  label across pressures), and every row is one (pressure, nominal height).
  A deterministic system (a lattice, a chain) is one row per size.
* **Every table states its units, what n counts and which error its ± is.**
  Statistics tables give mean ± sample standard deviation over the n packings
  (the spread of the ensemble); speed tables give ± one standard error (of the
  mean over packings, or of the regression slope for time-of-flight speeds).
  A row of fewer than :data:`MIN_FOR_ERROR` packings shows the range
  min … max of their values instead: a ± from two or three values says little.
* **Numbers** (:mod:`granwave.report.numbers`): value ± error with the error
  to 1–2 significant digits and the value rounded to match, counts as
  integers, positive quantities not resolved shown as bounds.
* **Cells.** One value: the value. Values all equal: the value and "(all n
  equal)". Fewer than 5 values: their range. Values all zero within precision (|x| ≤ 1e-12 × the row's largest
  modulus): "0 (< 1e-12 × max Cij)". A quantity measured on fewer packings than
  the row's n shows "(n = k)".
* **Diagnostics apart.** Numerical checks and fixed parameters (layer,
  min_contacts, residuals, piston balance, dimension, dof counts, ...) go to a
  provenance table: the value when every packing has the same, else the range
  min … max — never a mean ± std.
* **No empty tables.** A section without data is one line saying why.
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from collections.abc import Mapping, Sequence

import numpy as np

from ..analysis.ensemble import describe
from ..analysis.heights import group_heights
from .inputs import Scenes, num
from .numbers import fmt, fmt_bound, fmt_ci, fmt_count, fmt_positive, fmt_range  # noqa: F401  (one rule)
from .references import chain_exact_exponents

STATICS_KEYS = ("phi2", "phi3", "phi3_star", "z_star", "rattler_fraction", "mean_force_over_p",
                "Z2", "Z3", "F2", "F2_strong", "stress_ratio")
MODULI_KEYS = ("C11", "C12", "C22", "C33", "c_l", "c_t", "phi3_star")
MODULUS_KEYS = ("C11", "C12", "C22", "C33")
LOCAL_RATIO = re.compile(r"C\d\d_(body|lines)_n\d+_ratio")
LOCAL_ANY = re.compile(r"C\d\d_(body|lines)_n\d+(_ratio)?")  # shown as ratios, not diagnostics
SPEED_KEYS = ("c_tof", "c_peak", "c_zero")
LABELS = {
    "phi2": "Φ2", "phi3": "Φ3", "phi3_star": "Φ3*", "z_star": "z*", "rattler_fraction": "f0",
    "mean_force_over_p": "⟨F_n⟩/p", "Z2": "Z(2)", "Z3": "Z(3)", "F2": "F2", "F2_strong": "F2^S",
    "stress_ratio": "σ1/σ2", "C11": "C11", "C12": "C12", "C22": "C22", "C33": "C33",
    "c_l": "c_ℓ", "c_t": "c_t",
}
ZERO_RTOL = 1e-12
GROUP_RTOL = 0.05
MIN_FOR_ERROR = 5  # fewer packings: the range of their values, not a ± (issue 61)


# ====================================================================== cells
def cell(values, *, error: str = "std", zero_scale: float | None = None, of: int | None = None) -> str:
    """One table cell from the values over packings (rules: module docstring).

    ``error``: "std" (spread) or "sem" (standard error of the mean);
    ``zero_scale``: the magnitude below 1e-12 of which a value is zero;
    ``of``: the row's n (a smaller count is shown).
    """
    v = np.array([num(x) for x in values], float)
    v = v[np.isfinite(v)]
    n = v.size
    if n == 0:
        return "—"
    suffix = f" (n = {n})" if of is not None and n < of else ""
    if zero_scale and np.all(np.abs(v) <= ZERO_RTOL * zero_scale):
        return f"0 (< {ZERO_RTOL:.0e} × max Cij)" + suffix
    d = describe(v)
    if n == 1:
        return (fmt_count(v[0]) if v[0] == round(v[0]) else fmt(v[0])) + suffix
    if np.all(v == v[0]):
        same = fmt_count(v[0]) if v[0] == round(v[0]) else fmt(v[0])
        return f"{same} (all {n} equal)" + suffix
    if n < MIN_FOR_ERROR:
        return fmt_range(v.min(), v.max()) + suffix
    return fmt(d["mean"], d[error]) + suffix


def value_or_range(values) -> str:
    """A diagnostic over packings: the value when all agree, else ``min … max``."""
    v = np.array([num(x) for x in values], float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "—"
    integers = bool(np.all(v == np.round(v)))
    if np.all(v == v[0]):
        return fmt_count(v[0]) if integers else fmt(v[0], digits=3)
    return fmt_range(v.min(), v.max())


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown pipe table (and a blank line)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return lines + [""]


def _scalars(section: Mapping) -> dict:
    """Numeric leaves of a summary section (one level of nesting as ``outer.inner``)."""
    out = {}
    for k, v in section.items():
        if isinstance(v, bool):
            continue
        if isinstance(v, (int, float)):
            out[k] = v
        elif isinstance(v, Mapping):
            out.update({f"{k}.{kk}": vv for kk, vv in v.items()
                        if isinstance(vv, (int, float)) and not isinstance(vv, bool)})
    return out


def pressure_key(p) -> float:
    """Pressures equal to 6 significant digits are one pressure."""
    return float(f"{num(p):.6g}")


# ====================================================================== grouping
class Groups:
    """Summaries of one scene by (pressure, nominal height); heights grouped over the scene."""

    def __init__(self, items: Sequence[Mapping]):
        h = np.array([num(s.get("height")) for s in items], float)
        g = group_heights(h, GROUP_RTOL) if h.size else np.zeros(0, int)
        self.cells: dict[tuple[float, int], list[Mapping]] = defaultdict(list)
        for s, gi in zip(items, g):
            self.cells[(pressure_key(s["pressure"]), int(gi))].append(s)
        self.n_heights = int(g.max()) + 1 if g.size else 0

    def keys(self):
        return sorted(self.cells)

    def height(self, key) -> float:
        return float(np.mean([num(s["height"]) for s in self.cells[key]]))

    def pressures(self) -> list[float]:
        return sorted({p for p, _ in self.cells})


def _with(items, section) -> list[Mapping]:
    return [s for s in items if isinstance(s.get(section), Mapping)]


# ====================================================================== statics / moduli
def quantity_table(groups: Groups, section: str, keys: Sequence[str], *,
                   zero_keys: Sequence[str] = ()) -> list[str] | None:
    """Rows (p, L, n) × the section's quantities, mean ± std over the n packings (a range
    where n < 5)."""
    rows, present = [], []
    for key in groups.keys():
        items = _with(groups.cells[key], section)
        if not items:
            continue
        vals = [_scalars(s[section]) for s in items]
        present += [k for k in keys if any(k in v for v in vals)]
        rows.append((key, items, vals))
    present = [k for k in keys if k in present]
    if not rows or not present:
        return None
    body = []
    for key, items, vals in rows:
        n = len(items)
        scale = max((abs(np.nanmean([num(v.get(k)) for v in vals])) for k in zero_keys
                     if any(k in v for v in vals)), default=0.0)
        cells = [cell([v.get(k) for v in vals], of=n,
                      zero_scale=scale if k in zero_keys else None) for k in present]
        body.append([f"{key[0]:.3g}", f"{groups.height(key):.3g}", str(n)] + cells)
    return table(["p", "L", "n"] + [label(k) for k in present], body)


def label(key: str) -> str:
    """Column name of a quantity (local moduli ratios as 'C22 lines n=1')."""
    m = re.fullmatch(r"(C\d\d)_(body|lines)_n(\d+)_ratio", key)
    return f"{m[1]} {m[2]}, order {m[3]}" if m else LABELS.get(key, key)


def diagnostics_table(groups: Groups, sections: Mapping[str, Sequence[str]]) -> list[str] | None:
    """Provenance: every numeric key of the sections not shown as a quantity, one row per key
    (a long table reads in Markdown, a wide one does not), one column per pressure: the value
    when every packing there has the same, else the range min … max over its heights."""
    cols: list[tuple[str, str]] = []
    for key in groups.keys():
        for sec, shown in sections.items():
            for s in _with(groups.cells[key], sec):
                for k in _scalars(s[sec]):
                    if k not in shown and not LOCAL_ANY.fullmatch(k) and (sec, k) not in cols:
                        cols.append((sec, k))
    if not cols:
        return None
    ps = groups.pressures()
    items = {p: [s for key in groups.keys() if key[0] == p for s in groups.cells[key]] for p in ps}
    body = [[f"`{k}` ({sec})"] + [value_or_range([_scalars(s[sec]).get(k) for s in _with(items[p], sec)])
                                 for p in ps] for sec, k in cols]
    return table(["diagnostic (section)"] + [f"p = {p:.3g} (n = {len(items[p])})" for p in ps], body)


def _layer(groups: Groups) -> float:
    """The statics' wall-layer thickness l (d̄) as the summaries give it (3 when none does)."""
    for items in groups.cells.values():
        for s in _with(items, "statics"):
            if num(s["statics"].get("layer")) > 0:
                return num(s["statics"]["layer"])
    return 3.0


def count_notes(scene: str, groups: Groups, sections: Sequence[str], *,
                moduli_off: bool = False) -> list[str]:
    """One line per (p, L) where the sections were measured on different packings, saying why."""
    notes = []
    layer = _layer(groups)
    for key in groups.keys():
        items = groups.cells[key]
        have = {sec: len(_with(items, sec)) for sec in sections}
        if len(set(have.values())) > 1:
            L = groups.height(key)
            why = []
            for sec in sections:
                lack = [s["_path"] for s in items if not isinstance(s.get(sec), Mapping)]
                if not lack:
                    continue
                if sec == "statics" and L <= 2 * layer + 1:
                    why.append(f"no statics: the container has no bulk (L ≤ 2 l + 1 with wall "
                               f"layers l = {layer:g} d̄)")
                elif sec == "moduli" and moduli_off:
                    why.append("no moduli: switched off for this scene (config `moduli: false`)")
                else:
                    why.append(f"no {sec} in {', '.join(lack)}")
            parts = ", ".join(f"{n} with {sec}" for sec, n in have.items())
            notes.append(f"- {scene}, p = {key[0]:.3g}, L ≈ {L:.3g}: {len(items)} "
                         f"packing{'s' if len(items) != 1 else ''}, {parts}; {'; '.join(why)}.")
    return notes


def close_packing_note(groups: Groups) -> list[str]:
    """One line when a row's mean Φ2 exceeds the close packing of equal discs π/(2√3)."""
    close = math.pi / (2 * math.sqrt(3))
    rows = [[v for v in (num(s["statics"].get("phi2")) for s in _with(items, "statics")) if math.isfinite(v)]
            for items in groups.cells.values()]
    over = [float(np.mean(r)) for r in rows if r]  # rows without a Φ2 (3D scenes) have none to compare
    over = [v for v in over if round(v, 4) > round(close, 4)]  # as shown
    if not over:
        return []
    return [f"Φ2 above the close packing of equal discs, π/(2√3) = {close:.4f} (up to "
            f"{max(over):.4f} here), is a matter of definition, not of the packing: Φ2 counts "
            "every disc's whole area, so the overlaps of compressed contacts count twice (about "
            "twice the mean overlap over d̄), and the bulk slab L − 2l cuts the discs exactly but holds "
            "a non-integer number of rows, so a lattice's row-density ripple does not average out "
            "in a short container (docs/method.md §4).", ""]


def statics_section(groups_by_scene: Mapping[str, Groups], scenes: Scenes | None = None) -> list[str]:
    md = ["## Statics per pressure and container height", "",
          "One row per scene, pressure p [E*] and nominal container height L [d̄] (mean of the "
          "row's packings); n: the packings in the row. Every quantity is dimensionless "
          "(docs/method.md §4): mean ± sample standard deviation over the n packings (the "
          "ensemble's spread) where n ≥ 5, the range min … max of the values where fewer; bulk "
          "quantities exclude the wall layers of thickness l.", ""]
    any_table = False
    for scene, groups in groups_by_scene.items():
        t = quantity_table(groups, "statics", STATICS_KEYS)
        if t:
            md += [f"### {scene}", ""] + t
            off = scenes is not None and scenes.spec.get(scene, {}).get("moduli") is False
            notes = count_notes(scene, groups, ["statics", "moduli"], moduli_off=off)
            md += (["Packings not in this table:", ""] + notes + [""]) if notes else []
            md += close_packing_note(groups)
            any_table = True
    return md if any_table else md + ["No static measurements among the inputs.", ""]


def moduli_section(groups_by_scene: Mapping[str, Groups], scenes: Scenes) -> list[str]:
    md = ["## Elastic moduli per pressure and container height", "",
          "C11, C12, C22, C33 in E* (2D: a layer one d̄ thick, docs/units.md); c_ℓ = √(C22/Φ3*), "
          "c_t = √(C33/Φ3*) in √(E*/ρ), of the whole cell's moduli over the bulk Φ3*; Φ3* "
          "dimensionless (docs/method.md §6). Mean ± sample standard deviation over the n "
          "packings of the row where n ≥ 5, the range min … max where fewer. Local moduli: "
          "ratios to the global C22 or C33 (dimensionless; body force of order 1, 2 and imposed "
          "lines of order 1, 3, docs/method.md §6).", ""]
    any_table = False
    for scene, groups in groups_by_scene.items():
        t = quantity_table(groups, "moduli", MODULI_KEYS, zero_keys=MODULUS_KEYS)
        local = sorted({k for items in groups.cells.values() for s in _with(items, "moduli")
                        for k in _scalars(s["moduli"]) if LOCAL_RATIO.fullmatch(k)})
        tl = quantity_table(groups, "moduli", local) if local else None
        if t or tl:
            md += [f"### {scene}", ""] + (t or [])
            md += (["Local moduli as ratios to the global C22 or C33:", ""] + tl) if tl else []
            any_table = True
        elif scenes.kind_of(scene) != "chains" and any(_with(i, "statics") for i in groups.cells.values()):
            md += [f"### {scene}", "", "No moduli computed for this scene (the workflow config's "
                   "`moduli: false`, or no `analyze moduli` output among the summaries).", ""]
    return md if any_table else md + ["No moduli among the inputs.", ""]


def provenance_section(groups_by_scene: Mapping[str, Groups]) -> list[str]:
    md = ["## Provenance and numerical checks", "",
          "Fixed parameters and diagnostics of the summaries, one row per diagnostic and one "
          "column per pressure (every height of it): the value when every packing has the same, "
          "else the range min … max (not statistics). Residuals and piston balance are relative "
          "(docs/method.md §3–§6).", ""]
    any_table = False
    notes = []
    for scene, groups in groups_by_scene.items():
        t = diagnostics_table(groups, {"statics": STATICS_KEYS, "moduli": MODULI_KEYS})
        if t:
            md += [f"### {scene}", ""] + t
            any_table = True
        notes += count_notes(scene, groups, [sec for sec in ("statics", "moduli", "front")
                                             if any(_with(i, sec) for i in groups.cells.values())])
    if not any_table:
        md += ["No diagnostics among the inputs.", ""]
    if notes:
        md += ["Rows whose tables count different packings:", ""] + notes + [""]
    return md


# ====================================================================== speeds
def power_exponent(p, c) -> tuple[float, float, float, float]:
    """Fitted ν of c ∝ p^ν through the finite positive points: (ν, its standard error, the two
    ends of its 95 % interval, Student t with n − 2 degrees of freedom); NaN if fewer than two
    pressures (no interval with two)."""
    from ..analysis.fits import power_law_fit

    p, c = np.asarray(p, float), np.asarray(c, float)
    ok = np.isfinite(p) & np.isfinite(c) & (p > 0) & (c > 0)
    if np.unique(p[ok]).size < 2:
        return math.nan, math.nan, math.nan, math.nan
    fit = power_law_fit(p[ok], c[ok])
    return (fit.exponent, fit.exponent_err, *fit.exponent_ci95)


def _sem(values) -> tuple[float, float, int]:
    d = describe([num(x) for x in values])
    return d["mean"], d["sem"], d["count"]


def speeds_section(groups_by_scene: Mapping[str, Groups], h_by_scene: Mapping[str, Mapping],
                   scenes: Scenes) -> list[str]:
    from ..theory import lattice_speed

    hertz = math.log(lattice_speed(1e-4) / lattice_speed(1e-6)) / math.log(100)
    md = ["## Sound speeds against pressure", "",
          "Speeds in √(E*/ρ), p in E*, L in d̄. Every ± is one standard error: of the mean over "
          "n ≥ 5 packings for c_ℓ and c_t (over fewer: the range of their values), of the fitted "
          "slope for the time-of-flight speeds c_tof, c_peak, c_zero (`analyze heights`, "
          "docs/method.md §9; no ± where the edge heights hold fewer than 5 packings each: the "
          "slope's residual is then the scatter of so few); c_tof/c_ℓ with relative errors in quadrature (a range over the packings' c_ℓ "
          "where fewer than 5). c_ℓ and c_t: the whole cell's moduli over the bulk Φ3* "
          "(`moduli.c_l`, `moduli.c_t`, as in the moduli table; the continuum section uses the "
          "bulk slab's). Exponents: least-squares fit c ∝ p^κ through the per-pressure means of "
          "one height, printed as the value [its 95 % interval] (Student t with n − 2 degrees "
          "of freedom: with four pressures ± 2 standard errors would hold κ in only ~80 % of "
          "cases, docs/truth.md): they differ from the sweep section's, "
          "which pools every height of a pressure, and from the shear section's, of its own fit "
          f"height. Fixed Hertzian network (triangular-lattice formula, docs/method.md §12): "
          f"κ = {hertz:.4f}.", ""]
    names = sorted(s for s in set(groups_by_scene) | set(h_by_scene) if scenes.kind_of(s) == "disordered")
    if not names:
        return md + ["No disordered scenes among the inputs.", ""]
    for scene in names:
        md += [f"### {scene}", ""]
        groups = groups_by_scene.get(scene)
        series = h_by_scene.get(scene, {})
        cont, fits = [], []
        cl_of: dict[tuple[float, int], tuple[float, float]] = {}
        if groups is not None:
            per_height = defaultdict(lambda: ([], [], []))
            for key in groups.keys():
                items = _with(groups.cells[key], "moduli")
                if not items:
                    continue
                cls = [s["moduli"].get("c_l") for s in items]
                cl, ecl, n = _sem(cls)
                ct, ect, _ = _sem([s["moduli"].get("c_t") for s in items])
                cl_of[key] = (cl, ecl if n >= MIN_FOR_ERROR else math.nan, cls)
                cont.append([f"{key[0]:.3g}", f"{groups.height(key):.3g}", str(n),
                             cell(cls, error="sem"),
                             cell([s["moduli"].get("c_t") for s in items], error="sem")])
                ph = per_height[key[1]]
                ph[0].append(key[0]), ph[1].append(cl), ph[2].append(ct)
            for gi, (ps, cls, cts) in sorted(per_height.items()):
                if len(set(ps)) >= 2:
                    Ls = [groups.height(k) for k in groups.keys() if k[1] == gi]
                    label = f"L ≈ {np.mean(Ls):.3g}"
                    fits += [[f"κ_ℓ of c_ℓ ({label})", fmt_ci(*power_exponent(ps, cls)), str(len(ps))],
                             [f"κ_t of c_t ({label})", fmt_ci(*power_exponent(ps, cts)), str(len(ps))]]
        if cont:
            md += ["Continuum speeds from the global moduli, per pressure and height "
                   "(n packings; ± standard error of the mean, a range where n < 5):", ""]
            md += table(["p", "L", "n", "c_ℓ", "c_t"], cont)
        else:
            md += ["No moduli for this scene, so no c_ℓ or c_t (the workflow config's "
                   "`moduli: false`, or no `analyze moduli` output).", ""]
        if series:
            tof, cols = [], defaultdict(list)
            for p, h in sorted(series.items()):
                edges = h.get("edge_heights") or []
                hi = max(edges) if edges else math.nan
                # c_ℓ of the taller edge height: the packings the front crossed farthest
                cl, ecl, cls = math.nan, math.nan, []
                if groups is not None and math.isfinite(hi):
                    near = [k for k in groups.keys() if k[0] == p and k in cl_of
                            and abs(groups.height(k) - hi) <= GROUP_RTOL * hi]
                    if near:
                        cl, ecl, cls = cl_of[near[0]]
                row = [f"{p:.3g}", "–".join(f"{x:.3g}" for x in edges) or "—",
                       fmt_count(h.get("n_signals")) + (f" ({aliased_of(h)[0]} aliased)"
                                                         if aliased_of(h)[0] else "")]
                few = slope_error_unknown(h, edges)  # two edge heights, few packings at one
                for k in SPEED_KEYS:
                    row.append(fmt(h.get(k), None if few else h.get(k + "_err")))
                    cols[k].append(num(h.get(k)))
                ct, ect = num(h.get("c_tof")), math.nan if few else num(h.get("c_tof_err"))
                r = ct / cl if cl else math.nan
                er = abs(r) * math.hypot(ect / ct if ct else math.nan, ecl / cl if cl else math.nan)
                few = [c for c in map(num, cls) if math.isfinite(c) and c > 0]
                if 1 < len(few) < MIN_FOR_ERROR:  # too few packings for a ±: the range
                    row += [cell(cls, error="sem"), fmt_range(ct / max(few), ct / min(few))]
                else:
                    row += [fmt(cl, ecl), fmt(r, er if math.isfinite(er) else None)]
                tof.append(row)
                cols["p"].append(p)
            header = ["p", "edge heights", "n", "c_tof", "c_peak", "c_zero", "c_ℓ (taller)", "c_tof/c_ℓ"]
            if all(r[6] == "—" for r in tof):  # no moduli: no c_ℓ columns (said above)
                header, tof = header[:6], [r[:6] for r in tof]
            md += ["Time-of-flight speeds between the two edge heights (n signals in the "
                   "height series" + ("; c_ℓ of the packings at the taller):" if len(header) > 6 else "):"), ""]
            md += table(header, tof)
            md += aliased_note(list(series.values()))
            if len(cols["p"]) >= 2:
                fits = [[f"κ_{k[2:]} of {k}", fmt_ci(*power_exponent(cols["p"], cols[k])), str(len(cols["p"]))]
                        for k in SPEED_KEYS] + fits
        else:
            hs = sorted({round(groups.height(k), 1) for k in groups.keys()}) if groups else []
            md += [f"No time-of-flight speeds: the scene has {len(hs) or 'no'} container height"
                   f"{'s' if len(hs) != 1 else ''} (L ≈ {', '.join(f'{x:g}' for x in hs) or '—'}) "
                   "at each pressure, and c_tof, c_peak, c_zero need a height series of two or "
                   "more heights (docs/method.md §9).", ""]
        if fits:
            md += table(["speed", "exponent κ (c ∝ p^κ)", "pressures"], fits)
        elif cont or series:
            md += ["One pressure: no exponent fit.", ""]
    return md


# ====================================================================== aliasing
def aliased_of(h: Mapping) -> tuple[int, float]:
    """(aliased signals, largest Nyquist ratio h ω_max/π among them) of a height series;
    (0, nan) for a series that records none (``analyze heights`` output before the flag)."""
    samples = [s for s in (h.get("samples") or []) if isinstance(s, Mapping)]
    flagged = [s for s in samples if s.get("aliased")]
    n = int(h["n_aliased"]) if h.get("n_aliased") is not None else len(flagged)
    ratios = [num(s.get("nyquist_ratio")) for s in flagged]
    ratios = [r for r in ratios if math.isfinite(r)]
    return n, max(ratios, default=math.nan)


def aliased_note(series: Sequence[Mapping]) -> list[str]:
    """One paragraph when some of the series' signals are aliased (else nothing)."""
    marked = [(h, *aliased_of(h)) for h in series]
    marked = [(h, n, r) for h, n, r in marked if n > 0]
    if not marked:
        return []
    worst = max((r for _, _, r in marked if math.isfinite(r)), default=math.nan)
    total = sum(n for _, n, _ in marked)
    return [f"Rows marked \"aliased\": {total} signal{'s' if total != 1 else ''} in "
            f"{len(marked)} height series {'were' if total != 1 else 'was'} sampled more coarsely "
            "than the Nyquist interval π/ω_max of the system's highest mode (AliasingWarning of "
            "`granwave propagate`"
            + (f"; largest h ω_max/π = {fmt_bound(worst, 3)}" if math.isfinite(worst) else "")
            + "). They stay in the fits: their samples are the exact signal at the sample times, "
            "and the front is far slower than the highest mode; but a spectrum of such a record "
            "folds the modes above π/h, and a narrow pulse is resolved by fewer samples. Rerun "
            "with more `samples` (or a shorter `t_max`) to remove the mark.", ""]


def slope_error_unknown(h: Mapping, heights: Sequence[float] | None = None) -> bool:
    """Whether a height series' fitted slope (γ, χ over every height; c_tof, c_peak, c_zero
    over ``heights``, its two edge heights) rests on two heights with fewer than
    :data:`MIN_FOR_ERROR` packings at one of them: its residual error is then the scatter of
    so few packings, no error bar (issue 61), and the report shows the slope without a ±."""
    ph = h.get("per_height") if isinstance(h.get("per_height"), Mapping) else {}
    hs = [num(x) for x in ph.get("height") or []]
    counts = [num(x) for x in ph.get("count") or []]
    if heights is not None and hs and counts:
        pick = [c for x, c in zip(hs, counts) if any(abs(x - e) <= GROUP_RTOL * e for e in heights)]
        return len(pick) < 3 and (min(pick, default=0) < MIN_FOR_ERROR)
    n_h = num(h.get("n_heights"))
    if counts:
        return n_h < 3 and min(counts) < MIN_FOR_ERROR
    return n_h < 3 and num(h.get("n_signals")) / max(n_h, 1) < MIN_FOR_ERROR


def n_at_k(h: Mapping) -> str:
    """The "n at k" cell of a height series, marked when some of its signals are aliased."""
    n_al, _ = aliased_of(h)
    cell_ = f"{fmt_count(h.get('n_signals'))} at {fmt_count(h.get('n_heights'))}"
    return cell_ + (f" ({n_al} aliased)" if n_al else "")


# ====================================================================== exponents
def exponents_section(hts: Sequence[Mapping], scenes: Scenes, all_scenes: Sequence[str]) -> list[str]:
    md = ["## Front scaling with distance: γ and χ", "",
          "A ∝ L^−γ and W ∝ L^χ fitted over every signal of a height series (± one standard "
          "error of the fitted slope; none with two points), against the identical-ball chain's "
          "exact values (Airy asymptote, docs/method.md §12); no ± where the series has two "
          "heights only and fewer than 5 packings at one (the scatter of so few is no error bar). "
          "n: signals at the nominal heights "
          "counted after \"at\". γ and χ are dimensionless (the fits' JSON keys: `gamma`, `chi`; "
          "`alpha` in files written before the rename).", ""]
    exact = {ic: chain_exact_exponents(ic) for ic in ("A", "B")}
    md += table(["chain (exact)", "γ", "χ"],
                [[f"initial condition {ic}", fmt(e["gamma"]), fmt(e["chi"])] for ic, e in exact.items()])
    with_fit = [h for h in hts if h.get("gamma") is not None or h.get("chi") is not None]
    rows = []
    for h in sorted(with_fit, key=lambda h: (scenes.kind_of(h["_scene"]), h["_scene"], num(h.get("pressure")))):
        ic = scenes.ic_of(h["_scene"], h)
        e = exact.get(ic.upper(), exact["A"])
        g, a = num(h.get("gamma")), num(h.get("chi"))
        two = slope_error_unknown(h)  # two heights, few packings: its ± says nothing
        ge, ae = (None, None) if two else (h.get("gamma_err"), h.get("chi_err"))
        heights = (h.get("per_height") or {}).get("height") or [num(x.get("height")) for x in (
            h.get("samples") or []) if isinstance(x, Mapping)]
        rows.append([h["_scene"], scenes.kind_of(h["_scene"]), fmt(h.get("pressure"), digits=3), ic,
                     n_at_k(h), fmt_range(min(heights), max(heights)) if heights else "—",
                     fmt(g, ge), fmt(a, ae), fmt(g / e["gamma"], num(ge) / e["gamma"]),
                     fmt(a / e["chi"], num(ae) / e["chi"])])
    if rows:
        md += table(["scene", "kind", "p", "ic", "n at heights", "L", "γ", "χ", "γ/γ chain",
                     "χ/χ chain"], rows)
        md += ["What the ratios say: above 1, the front decays (γ) or broadens (χ) faster with "
               "distance than the identical-ball chain's, whose exponents come from the dispersion "
               "of a perfect lattice alone; a disordered packing scatters the short waves of the "
               "front as well. The fits are over the heights listed (L): over a short range they are "
               "local values, not asymptotes — even the exact chain reaches its Airy values only as "
               "N^(−1/3) → 0, so a fit of its own over a finite range of N lies off them.", ""]
        md += aliased_note(with_fit)
    else:
        md += ["No height series among the inputs.", ""]
    have = {h["_scene"] for h in with_fit}
    lonely = sorted(s for s in all_scenes if s not in have and scenes.kind_of(s) == "disordered")
    if lonely:
        md += [f"No γ or χ for {', '.join(lonely)}: no height series of theirs among the inputs (a "
               "height series needs two or more heights at one pressure; a continuum scene's local "
               "exponents are in the continuum section).", ""]
    return md


# ====================================================================== lattices
def lattice_section(h_by_scene: Mapping[str, Mapping], scenes: Scenes) -> list[str]:
    from ..theory import law_lattice_speed

    md = ["## Triangular lattices against the formula", "",
          "c_theory = 3^{19/12}/(2^{3/2} π^{1/2}) p^{1/6} (× √(1 + η/3) with friction), "
          "`granwave.theory.lattice_speed`, for Hertz; for another contact law of the scene its "
          "row chain's speed at the same order, `granwave.theory.law_lattice_speed`; simulated speeds from "
          "the arrival times of the two "
          "lattices of the edge heights [d̄] (one deterministic lattice per height: no ±). Speeds in "
          "√(E*/ρ), p in E*; the ratios are dimensionless. The formula is the long-wave speed: "
          "c_peak is the speed to compare with it; the 10 % edge runs ahead of a pulse that "
          "broadens as it travels (docs/method.md §9), so c_tof exceeds the formula by several "
          "per cent on a perfect lattice — a property of the pick, not a failure of the formula "
          "(`analyze heights`' zero crossing lags behind likewise).", ""]
    names = sorted(s for s in h_by_scene if scenes.kind_of(s) == "lattices")
    if not names:
        return md + ["No lattice height series among the inputs.", ""]
    rows = []
    for scene in names:
        mu = scenes.friction_of(scene)
        frictional = bool(math.isfinite(mu) and mu > 0)
        for p, h in sorted(h_by_scene[scene].items()):
            c = law_lattice_speed(p, scenes.contact_of(scene), friction=frictional, poisson=scenes.poisson_of(scene))
            edges = h.get("edge_heights") or []
            row = [scene, fmt(mu, digits=3), f"{p:.3g}", "–".join(f"{x:.3g}" for x in edges) or "—",
                   fmt(c)]
            for k in SPEED_KEYS:
                v = num(h.get(k))
                row += [fmt(v, h.get(k + "_err")), fmt(v / c, num(h.get(k + "_err")) / c)]
            rows.append(row)
    return md + table(["scene", "μ", "p", "edge heights", "c_theory", "c_tof", "c_tof/c_theory", "c_peak",
                       "c_peak/c_theory", "c_zero", "c_zero/c_theory"], rows) \
        + aliased_note([h for scene in names for h in h_by_scene[scene].values()])


# ====================================================================== damping, sweeps
def damping_section(rows: Sequence[Mapping]) -> list[str]:
    """Coherent amplitude and tail rms against the contact damping ζ (nonlinear DEM kicks)."""
    md = ["## Damping series (nonlinear DEM, docs/method.md §11)", "",
          "One packing (n = 1) kicked in the Hertz–Mindlin DEM with contact damping ζ (fraction "
          "of critical, dimensionless). Amplitude A and tail rms in the DEM signal's units (force "
          "change over the kick's scale, the linear model's normalization), width W in "
          "d̄/√(E*/ρ). Tail rms: rms of the signal over one window for every ζ, from the "
          "latest end of a first pulse (max over ζ of its zero crossing plus one pulse width) to "
          "the end of the record (`granwave analyze damping`)"]
    starts = sorted({num(r.get("tail_start")) for r in rows if math.isfinite(num(r.get("tail_start")))})
    if starts:
        md[-1] += f": t ≥ {' / '.join(fmt(t, digits=4) for t in starts)} d̄/√(E*/ρ)"
    md[-1] += "."
    if any(r.get("tail_in_pulse") for r in rows):
        md[-1] += (" Rows marked \"window in pulse\": their own first pulse ends after the window "
                   "starts, so part of the pulse counts as tail.")
    md.append("")
    body = [[fmt(r.get("damping")), fmt(r.get("amplitude")), fmt(r.get("width")),
             fmt(r.get("tail_rms")) + (" (window in pulse)" if r.get("tail_in_pulse") else ""),
             fmt(r.get("tail_rms_over_amplitude"))]
            for r in sorted(rows, key=lambda r: float(r.get("damping", 0.0)))]
    return md + table(["ζ", "amplitude A", "width W", "tail rms", "tail rms / A"], body)


SWEEP_SPEEDS = {"tof": "c_tof", "peak": "c_peak", "zero": "c_zero", "l": "c_ℓ", "t": "c_t"}


def sweep_label(key: str) -> str:
    """``kappa_tof`` → "κ of c_tof (`kappa_tof`)": the report's symbol, the file's key."""
    speed = SWEEP_SPEEDS.get(key.removeprefix("kappa_"))
    return f"κ of {speed} (`{key}`)" if speed else key


def sweep_table(obj) -> list[str]:
    """The fitted exponents κ (c ∝ p^κ) of a ``pressure-sweep --json`` object, as given (files
    written before the rename: their ``alpha_*``)."""
    from ..analysis.renamed_keys import SWEEP, current_keys

    if not isinstance(obj, Mapping):
        return ["(not a sweep object)", ""]
    obj = current_keys(obj, SWEEP)
    alphas = [k for k in obj if k.startswith("kappa_") and not k.endswith(("_err", "_n", "_ci95"))]
    fitted = [k for k in alphas if math.isfinite(num(obj[k]))]
    if alphas and not fitted:  # no empty table: say why
        notes = obj.get("fit_notes") or []
        why = "; ".join(str(n) for n in (notes.values() if isinstance(notes, Mapping) else notes))
        return [f"No exponent fitted{': ' + why if why else ' (fewer than two pressures)'}.", ""]
    alphas = fitted
    if alphas:
        # the value and its 95 % interval (Student t with n − 2: few pressures, docs/truth.md)
        rows = [[sweep_label(k), fmt_ci(obj[k], obj.get(k + "_err"), *(obj.get(k + "_ci95") or (None,) * 2)),
                 str(obj.get(k + "_n", "")) if obj.get(k + "_n") is not None else ""] for k in alphas]
        if obj.get("expected_exponent") is not None:
            rows.append(["expected (fixed Hertzian network)", fmt(obj["expected_exponent"]), ""])
        return table(["exponent", "value [95 %]", "pressures"], rows)
    scal = _scalars(obj)
    if not scal:
        return ["(no scalar results)", ""]
    return table(["quantity", "value"], [[k, fmt(v, digits=5)] for k, v in scal.items()])
