"""The report's first page: what was run, and one row per headline result against its reference.

Each row of the findings table gives the measured value with its error and what it rests on
(n), the reference it is compared with (a closed form of docs/method.md, the affine effective
medium fed the measured z* and Φ3*, the chain's Airy exponents, Hertz–Mindlin's p^(1/3)), what
the estimator is worth (its validated bias and coverage from the truth suite,
:mod:`granwave.report.validated`, or "not validated"), a one-line verdict, and a link to the
table it comes from. Every number is read from the analyses; nothing is typed in.

Verdicts (:func:`verdict`): with an error, the difference from the reference in standard
errors ("agrees within 1σ", "within 2σ", "differs by 4σ: why"); a deterministic system (a
lattice, one chain) has no σ: the relative difference; fewer than 5 packings give no σ either
(a standard deviation of two is no error bar): the range of their values, and whether the
reference lies inside it.

To add a row from another section: a function returning :class:`Finding` objects, called from
:func:`findings_section`.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .numbers import MISSING, fmt, fmt_ci, fmt_count, fmt_range, num
from .validated import check_cell

#: Fewer packings than this: a range, not a ± (issue 61).
MIN_FOR_ERROR = 5


@dataclass
class Finding:
    quantity: str            # "speed exponent κ_tof (c_tof ∝ p^κ), frictional2d"
    measured: str            # "0.19 ± 0.02"
    n: str                   # what it rests on
    reference: str           # "1/6 = 0.1667 (fixed Hertzian network, docs/method.md §10)"
    verdict: str
    anchor: str              # the table's anchor on the page
    truth: str | Sequence[str] | None = None   # truth-suite key(s); None: no estimator

    def row(self) -> list[str]:
        return [self.quantity, self.measured, self.n, self.reference, check_cell(self.truth),
                self.verdict, f"[table](#{self.anchor})"]


# ---------------------------------------------------------------------- verdicts
def verdict(value, err, ref, *, why: str = "", ref_err: float = 0.0,
            no_sigma: str = "deterministic: no σ") -> str:
    """"agrees within 1σ" / "within 2σ" / "differs by Nσ: why" (σ: the errors combined);
    without an error, :func:`relative_verdict` saying why there is no σ (``no_sigma``)."""
    v, e, r = num(value), num(err), num(ref)
    if not (math.isfinite(v) and math.isfinite(r)):
        return "not measured"
    s = math.hypot(e, num(ref_err) if math.isfinite(num(ref_err)) else 0.0) if math.isfinite(e) else math.nan
    if not (s > 0):
        return relative_verdict(v, r, why=why, no_sigma=no_sigma)
    z = abs(v - r) / s
    if z <= 1:
        return "agrees within 1σ"
    if z <= 2:
        return "agrees within 2σ"
    return f"differs by {z:.0f}σ" + (f": {why}" if why else "")


def ci_verdict(value, err, ci, ref, *, why: str = "") -> str:
    """A fitted value against a reference by its own 95 % interval ``ci`` (Student t, where a fit
    of few points makes "within 2σ" too generous): "agrees: inside the 95 % interval (0.8σ)" or
    "differs by 6σ, outside the 95 % interval: why"; :func:`verdict` where ``ci`` is missing."""
    lo, hi = (num(x) for x in (ci or (math.nan, math.nan)))
    v, e, r = num(value), num(err), num(ref)
    if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(v) and math.isfinite(r)):
        return verdict(value, err, ref, why=why)
    z = f"{abs(v - r) / e:.1f}σ" if math.isfinite(e) and e > 0 else ""
    if lo <= r <= hi:
        return "agrees: inside the 95 % interval" + (f" ({z})" if z else "")
    return (f"differs by {z}, outside" if z else "differs: outside") + " the 95 % interval" + \
        (f": {why}" if why else "")


def bound_verdict(lower, ref) -> str:
    """A one-sided 95 % lower bound against a reference: "consistent (bound below)" or "above"."""
    lo, r = num(lower), num(ref)
    if not (math.isfinite(lo) and math.isfinite(r)):
        return "not measured"
    if lo <= r:
        return f"consistent: the bound lies {r - lo:.2g} below it"
    return f"above it: the bound exceeds it by {lo / r - 1:.1%}"


def relative_verdict(value, ref, *, why: str = "", tolerance: float = 0.01,
                     no_sigma: str = "deterministic: no σ") -> str:
    """A value without an error: "agrees within 1 %", "6.1 % above" or "2.5 × the reference",
    with why there is no σ (``no_sigma``) and, where it differs, ``why``."""
    v, r = num(value), num(ref)
    d = v / r - 1.0
    if abs(d) <= tolerance:
        return f"agrees within {tolerance:.0%} ({no_sigma})"
    size = f"{v / r:.2g} × the reference" if not 0.5 <= v / r <= 2 else \
        f"{abs(d):.1%} {'above' if d > 0 else 'below'}"
    return f"{size} ({no_sigma})" + (f": {why}" if why else "")


def range_verdict(values, ref, *, why: str = "") -> str:
    """Fewer than :data:`MIN_FOR_ERROR` packings: is the reference inside their range?"""
    v = np.asarray([x for x in map(num, values) if math.isfinite(x)], float)
    r = num(ref)
    if v.size == 0 or not math.isfinite(r):
        return "not measured"
    if v.min() <= r <= v.max():
        return f"reference within the range of the {v.size} packings (too few for a σ)"
    side = "above" if v.min() > r else "below"
    return f"all {v.size} packings {side} the reference (too few for a σ)" + (f": {why}" if why else "")


def mean_or_range(values) -> tuple[str, float, float]:
    """(cell, mean, standard error): ``mean ± sem`` from 5 packings on, else the range
    ``lo … hi`` (and a NaN error)."""
    v = np.asarray([x for x in map(num, values) if math.isfinite(x)], float)
    if v.size == 0:
        return MISSING, math.nan, math.nan
    if v.size < MIN_FOR_ERROR:
        return (fmt(v[0]) if v.size == 1 else fmt_range(v.min(), v.max())), float(v.mean()), math.nan
    sem = float(np.std(v, ddof=1) / math.sqrt(v.size))
    return fmt(v.mean(), sem), float(v.mean()), sem


# ---------------------------------------------------------------------- what was run
def cpu_seconds(timings: Sequence[Path]) -> tuple[float, float, int]:
    """(CPU-s, wall-s, stages) summed over the workflow's timing tables (results/timings/*.tsv:
    one row per stage of every sample and analysis, columns ``cpu_s``, ``wall_s``)."""
    cpu = wall = 0.0
    rows = 0
    for path in timings:
        with open(path, newline="") as f:
            for r in csv.DictReader(f, delimiter="\t"):
                c, w = num(r.get("cpu_s")), num(r.get("wall_s"))
                if math.isfinite(c):
                    cpu += c
                    wall += w if math.isfinite(w) else 0.0
                    rows += 1
    return cpu, wall, rows


def what_was_run(sums: Sequence[Mapping], scenes, timings: Sequence[Path], *,
                 continuum: Mapping, shear: Mapping, damping: Sequence[Mapping]) -> list[str]:
    """One line per scene (kind, packings, pressures, heights) and the run's CPU time."""
    by_scene: dict[str, list[Mapping]] = {}
    for s in sums:
        by_scene.setdefault(s["_scene"], []).append(s)
    lines = ["What was run (every number below comes from these runs):", ""]
    for scene, items in sorted(by_scene.items()):
        ps = sorted({num(s.get("pressure")) for s in items})
        hs = sorted({round(num(s.get("height")), 1) for s in items})
        kind = scenes.kind_of(scene)
        what = "systems" if kind in ("lattices", "chains") else "packings"
        lines.append(f"- **{scene}** ({kind}): {len(items)} {what} at p = "
                     + ", ".join(f"{p:g}" for p in ps) + " and L ≈ "
                     + (", ".join(f"{h:g}" for h in hs) if len(hs) <= 6 else f"{hs[0]:g} … {hs[-1]:g}"))
    for scene, d in sorted(continuum.items()):
        front = d.get("front") or {}
        if front:
            lines.append(f"- **{scene}** (continuum): {fmt_count(front.get('n_signals'))} columns at "
                         f"{fmt_count(front.get('n_heights'))} heights, p = {num(front.get('pressure')):g}")
    for scene, a in sorted(shear.items()):
        lines.append(f"- **{scene}** (shear): {fmt_count(a.get('n_records'))} packings of "
                     f"{a.get('source_scene', '?')} kicked along x and y")
    if damping:
        lines.append(f"- damping series: one packing, {len(damping)} dampings ζ in the nonlinear DEM")
    if timings:
        cpu, wall, rows = cpu_seconds(timings)
        lines.append(f"- CPU time: {cpu:.0f} CPU-s over {rows} stages ({wall:.0f} s wall), summed "
                     "from the run's own timing tables (results/timings; numba compilation and "
                     "the start-up of each job not included)")
    return lines + [""]


# ---------------------------------------------------------------------- the rows
def _z_span(groups) -> str:
    """"z* 3.2 → 3.9" over a scene's pressures (the lowest to the highest), or ""."""
    zs = []
    for p in groups.pressures():
        vals = [num(s["statics"].get("z_star")) for k in groups.keys() if k[0] == p
                for s in groups.cells[k] if isinstance(s.get("statics"), Mapping)]
        vals = [v for v in vals if math.isfinite(v)]
        if vals:
            zs.append((p, float(np.mean(vals))))
    if len(zs) < 2:
        return ""
    return f"z* goes from {zs[0][1]:.2f} at p = {zs[0][0]:g} to {zs[-1][1]:.2f} at {zs[-1][0]:g}"


def pressure_rows(sweeps, groups_by_scene, anchors: tuple[str, str] = ("sweeps", "speeds")) -> list[Finding]:
    """κ of c_tof (the sweep's fit through the height series) and of c_ℓ, c_t (through the
    per-pressure means of the tallest height measured at every pressure) against the 1/6 of a
    fixed Hertzian network."""
    from .tables import _with, power_exponent

    rows = []
    for path, obj, _ in sweeps:
        if not isinstance(obj, Mapping):
            continue
        scene = obj.get("scene") or Path(path).stem
        groups = groups_by_scene.get(scene)
        z = _z_span(groups) if groups is not None else ""
        why = ("a fixed network gives 1/6; contacts are added as p rises"
               + (f" ({z})" if z else "") + ", so the network stiffens faster")
        k, e, n, ci = (obj.get(f"kappa_tof{s}") for s in ("", "_err", "_n", "_ci95"))
        if math.isfinite(num(k)):
            rows.append(Finding(
                f"pressure exponent κ_tof of c_tof (c ∝ p^κ), {scene}", fmt_ci(k, e, *(ci or (None,) * 2), 3),
                f"{fmt_count(n)} pressures (fit through the height series)",
                "1/6 = 0.1667 (fixed Hertzian network, docs/method.md §10)",
                ci_verdict(k, e, ci, 1 / 6, why=why if num(k) > 1 / 6 else ""), anchors[0],
                truth=("sweep.exponent",)))
        if groups is None:
            continue
        ps = groups.pressures()
        tall = [gi for gi in {k[1] for k in groups.keys()}
                if all(any(k == (p, gi) and _with(groups.cells[k], "moduli") for k in groups.keys())
                       for p in ps)]
        if len(ps) < 2 or not tall:
            continue
        gi = max(tall, key=lambda g: np.mean([groups.height(k) for k in groups.keys() if k[1] == g]))
        L = np.mean([groups.height(k) for k in groups.keys() if k[1] == gi])
        items = [_with(groups.cells[(p, gi)], "moduli") for p in ps]
        packs = min(len(i) for i in items)
        for key, name, sub in (("c_l", "c_ℓ", "ℓ"), ("c_t", "c_t", "t")):
            means = [np.nanmean([num(s["moduli"].get(key)) for s in i]) for i in items]
            kv, ke, lo, hi = power_exponent(ps, means)
            if not math.isfinite(kv):
                continue
            rows.append(Finding(
                f"pressure exponent κ_{sub} of {name} (c ∝ p^κ), {scene}, L ≈ {L:.3g}",
                fmt_ci(kv, ke, lo, hi, 3),
                f"{len(ps)} pressures × ≥ {packs} packings (fit through their means)",
                "1/6 = 0.1667 (fixed Hertzian network, docs/method.md §10)",
                ci_verdict(kv, ke, (lo, hi), 1 / 6, why=why if kv > 1 / 6 else ""), anchors[1],
                truth=(f"moduli.{key}_exponent", "sweep.exponent")))
    return rows


def front_rows(h_by_scene, scenes, anchor: str) -> list[Finding]:
    """γ, χ of the main scene's (and the chains') height series against the chain's Airy values."""
    from .references import chain_exact_exponents

    rows = []
    exact = {ic: chain_exact_exponents(ic) for ic in ("A", "B")}
    for scene in sorted(h_by_scene):
        kind = scenes.kind_of(scene)
        poly = num(scenes.spec.get(scene, {}).get("polydispersity", 0) or 0)
        if kind == "lattices" or (kind == "chains" and not poly > 0):
            continue  # the exact references: a check of the code, in the exponents table
        for p, h in sorted(h_by_scene[scene].items())[-1:]:
            ic = scenes.ic_of(scene, h).upper()
            e = exact.get(ic, exact["A"])
            heights = h.get("per_height", {}).get("height") or []
            span = f"L = {min(heights):.3g}–{max(heights):.3g}" if heights else ""
            n = f"{fmt_count(h.get('n_signals'))} signals at {fmt_count(h.get('n_heights'))} heights"
            from .tables import slope_error_unknown

            two = slope_error_unknown(h)  # two heights, few packings: its ± is no error bar
            for sym, key, ref in (("γ", "gamma", e["gamma"]), ("χ", "chi", e["chi"])):
                v, err = h.get(key), None if two else h.get(f"{key}_err")
                if not math.isfinite(num(v)):
                    continue
                if kind == "chains":
                    why = "disorder of the chain's radii scatters the front"
                else:
                    why = ("the disordered packing's front decays and broadens faster than the "
                           "chain's, whose exponents come from the lattice's dispersion alone"
                           + (f"; {span}: local, not asymptotic values" if span else ""))
                rows.append(Finding(
                    f"{'amplitude' if key == 'gamma' else 'width'} exponent {sym}, {scene}, "
                    f"p = {p:g}", fmt(v, err, 3), n,
                    f"{fmt(ref, digits=4)} (identical-ball chain, Airy, ic {ic}; docs/method.md §12)",
                    verdict(v, err, ref, why=why, no_sigma="two heights, few packings: no σ"), anchor,
                    truth=(f"heights.{key}",) + (("heights.alpha",) if key == "chi" else ())))
    return rows


def lattice_rows(h_by_scene, scenes, anchor: str) -> list[Finding]:
    """The simulated lattices' c_peak and c_tof against the formula (highest pressure)."""
    from ..theory import law_lattice_speed

    rows = []
    for scene in sorted(s for s in h_by_scene if scenes.kind_of(s) == "lattices"):
        p, h = sorted(h_by_scene[scene].items())[-1]
        mu = scenes.friction_of(scene)
        # the scene's contact law (Hertz: granwave.theory.lattice_speed's formula)
        c = law_lattice_speed(p, scenes.contact_of(scene), friction=bool(math.isfinite(mu) and mu > 0),
                              poisson=scenes.poisson_of(scene))
        edges = h.get("edge_heights") or []
        for key, name, why, truth in (
                ("c_peak", "peak", "", "front.t_peak"),
                ("c_tof", "10 % edge", "the 10 % edge runs ahead of a pulse that broadens as it "
                 "travels (docs/method.md §9): c_peak is the speed to compare", "front.t_lead10")):
            v = num(h.get(key))
            if not math.isfinite(v):
                continue
            rows.append(Finding(f"{key}/c_theory ({name}), {scene}, p = {p:g}", fmt(v / c, digits=4),
                                "one lattice per height, L = " + "–".join(f"{x:.3g}" for x in edges),
                                f"1 (c_theory = {fmt(c, digits=4)}, docs/method.md §12)",
                                relative_verdict(v, c, why=why), anchor, truth=(truth,)))
    return rows


def effective_medium_rows(groups_by_scene, scenes, anchor: str, config: Mapping | None) -> list[Finding]:
    """The main scene's longitudinal and shear moduli against the affine effective medium fed
    each packing's own z*, Φ3*, σ1/σ2 and p (highest pressure, tallest height)."""
    from ..theory import effective_medium_moduli

    rows = []
    for scene, groups in groups_by_scene.items():
        if scenes.kind_of(scene) != "disordered" or not scenes.default_law(scene):
            continue  # the effective medium is Hertz's
        keys = [k for k in groups.keys() if any(isinstance(s.get("moduli"), Mapping)
                                                 and isinstance(s.get("statics"), Mapping)
                                                 for s in groups.cells[k])]
        if not keys:
            continue
        key = max(keys, key=lambda k: (k[0], groups.height(k)))
        poly = num((config or {}).get("disordered", {}).get(scene, {}).get("polydispersity", 0.2))
        poly = 0.2 if not math.isfinite(poly) else poly
        ratios = {"M": [], "G": []}
        for s in groups.cells[key]:
            st, mo = s.get("statics"), s.get("moduli")
            if not (isinstance(st, Mapping) and isinstance(mo, Mapping)):
                continue
            phi, z = num(mo.get("phi3_star")), num(st.get("z_star"))
            if not (phi > 0 and z > 0):
                continue
            emt = effective_medium_moduli(num(s["pressure"]), z=z, phi=phi, dim=int(mo.get("dim", 2)),
                                          friction=num(s.get("friction", 0)) > 0,
                                          poisson=num(s.get("poisson", 0.0)) if math.isfinite(
                                              num(s.get("poisson", 0.0))) else 0.0,
                                          mean_d3=1.0 + poly ** 2,
                                          stress_ratio=num(st.get("stress_ratio", 1.0)) if num(
                                              st.get("stress_ratio", 1.0)) > 0 else 1.0)
            ratios["M"].append(phi * num(mo.get("c_l")) ** 2 / emt["M"])
            ratios["G"].append(phi * num(mo.get("c_t")) ** 2 / emt["G"])
        for name, sym in (("M", "longitudinal modulus Φ3* c_ℓ² (2D C22)"), ("G", "shear modulus G")):
            vals = ratios[name]
            if not vals:
                continue
            cell, mean, sem = mean_or_range(vals)
            why = "the affine medium ignores the grains' relaxation, an upper bound (shear most)"
            rows.append(Finding(
                f"{sym} over the effective medium, {scene}, p = {key[0]:g}, L ≈ {groups.height(key):.3g}",
                cell, f"{len(vals)} packing{'s' if len(vals) != 1 else ''}",
                "1 (affine Hertz–Mindlin medium fed each packing's z*, Φ3*, σ1/σ2; "
                "granwave.theory.effective_medium_moduli)",
                verdict(mean, sem, 1.0, why=why) if len(vals) >= MIN_FOR_ERROR
                else range_verdict(vals, 1.0, why=why), anchor, truth=None))
    return rows


def continuum_rows(continuum: Mapping, anchor: str) -> list[Finding]:
    """c_tof/c_ℓ at the tallest distance (and L*), c_0/c_ℓ and λ* of the continuum scenes."""
    from ..analysis.continuum_length import low_frequency_of_result
    from .continuum import current_lambda, lambda_sentence

    rows = []
    for scene, d in sorted(continuum.items()):
        front, att = d.get("front") or {}, d.get("attenuation") or {}
        # λ* and c0/c_ℓ by the current rule (recomputed for a record made before it)
        lam, recomputed = current_lambda(att, front) if att else ({}, False)
        loc = front.get("local") or {}
        if loc.get("ratio"):
            r, e, L = loc["ratio"][-1], loc["ratio_err"][-1], loc["height"][-1]
            app = front.get("approach") or {}
            tol = num(app.get("tolerance", 0.05))
            status = app.get("status")
            why = (f"L* > {num(app.get('L_max')):.3g} (still more than {tol:.0%} above 1 at the "
                   "tallest column: the continuum is not reached)" if status == "beyond" else "")
            rows.append(Finding(
                f"c_tof/c_ℓ at the tallest distance (local, L = {num(L):.3g}), {scene}",
                fmt(r, e), f"{fmt_count(front.get('n_signals'))} columns at "
                f"{fmt_count(front.get('n_heights'))} heights",
                f"1 (continuum limit; c_ℓ of the {front.get('c_l_kind', '?')}, docs/continuum.md)",
                verdict(r, e, 1.0, why=why), anchor, truth=("heights.c_tof", "continuum.L_star")))
        if att.get("c0") is not None and lam.get("reference") == "c_l" and "omega" in att:
            low = low_frequency_of_result(att, lam.get("c_ref"), lam.get("c_ref_err") or 0.0)
            ratio, bound = num(low.get("c0_over_c_l")), num(low.get("c0_over_c_l_lower_bound"))
            # the band's bound is the measurement; the extrapolation beside it, without a ±
            # (its interval undercovers where the band starts after c has fallen)
            rows.append(Finding(f"c_0/c_ℓ (low-frequency limit against c_ℓ), {scene}",
                                f"≥ {fmt(bound, digits=4)} (95 %; extrapolation {fmt(ratio, digits=4)}, "
                                "not a measurement)",
                                f"{fmt_count(att.get('n_signals'))} signals at {len(att.get('heights', []))} heights",
                                "1 (the contributing heights' c_ℓ)", bound_verdict(bound, 1.0), anchor,
                                truth=("attenuation.c0_over_c_l_lower_bound",)))
        if lam.get("status"):
            text = lambda_sentence(lam, recomputed).removeprefix("Continuum length in frequency ")
            rows.append(Finding(f"continuum wavelength λ*, {scene}", _lambda_cell(lam),
                                f"{fmt_count(att.get('n_signals'))} signals", "— (a measurement)",
                                text[0].upper() + text[1:], anchor, truth=("continuum.lambda_star",)))
    return rows


def _lambda_cell(lam: Mapping) -> str:
    from .numbers import fmt_bound

    st = lam.get("status")
    if st == "within":
        ci = lam.get("lambda_star_ci") or [None, None]
        lo, hi = num(ci[0]), num(ci[1])
        if math.isfinite(lo) and lo > 0 and math.isfinite(hi):
            return f"{fmt_bound(lam.get('lambda_star'), 3)} d̄ (95 % {fmt_bound(lo, 3)} … {fmt_bound(hi, 3)})"
        if lo <= 0 and math.isfinite(hi):  # one-sided: the bound is the measurement
            return f"λ* ≤ {fmt_bound(hi, 3)} d̄ (95 %; point {fmt_bound(lam.get('lambda_star'), 3)})"
        if math.isfinite(lo) and lo > 0:
            return f"λ* ≥ {fmt_bound(lo, 3)} d̄ (95 %; point {fmt_bound(lam.get('lambda_star'), 3)})"
        return f"{fmt_bound(lam.get('lambda_star'), 3)} d̄ (not bounded)"
    if st == "whole band":
        return f"λ* ≤ {fmt_bound(lam.get('lambda_bound'), 3)} d̄"
    if st == "beyond":
        return f"λ* > {fmt_bound(lam.get('lambda_bound'), 3)} d̄"
    return "undetermined"


def shear_rows(shear: Mapping, anchor: str) -> list[Finding]:
    """G_max's pressure exponent against Hertz–Mindlin's 1/3, V_s/c_t at the highest pressure."""
    rows = []
    for scene, a in sorted(shear.items()):
        g = (a.get("fits") or {}).get("G_max") or {}
        if math.isfinite(num(g.get("exponent"))):
            ci = g.get("exponent_ci95") or (None, None)
            rows.append(Finding(f"G_max pressure exponent κ_G (G_max ∝ p^κ_G), {scene}",
                                fmt_ci(g["exponent"], g.get("exponent_err"), *ci, 3),
                                f"{len(a.get('pressures', []))} pressures",
                                "1/3 (Hertz–Mindlin effective medium)",
                                ci_verdict(g["exponent"], g.get("exponent_err"), ci, 1 / 3,
                                           why="contacts added with p, as for κ_tof"), anchor,
                                truth=("sweep.exponent",)))
        top = max(a.get("pressures", []), key=lambda r: num(r.get("pressure")), default=None)
        if top and (top.get("V_s_over_c_t") or {}).get("mean") is not None:
            from .shear import stat_cell

            vs = top["V_s_over_c_t"]
            n = int(num(top.get("n")))
            cell = stat_cell(vs, 3)
            m, e = num(vs.get("mean")), num(vs.get("sem"))
            rows.append(Finding(f"V_s/c_t (pick `{a.get('pick')}`), {scene}, p = {num(top['pressure']):g}",
                                cell, f"{n} packings", "1 (the moduli's c_t)",
                                verdict(m, e, 1.0) if n >= MIN_FOR_ERROR
                                else range_verdict([m - e, m + e], 1.0) if n == 2  # two: mean ± sem
                                else "too few packings for a σ", anchor,
                                truth=(f"shear.{a.get('pick')}",)))
    return rows


def findings_section(rows: Sequence[Finding], run_lines: Sequence[str]) -> list[str]:
    from .tables import table

    md = ['<a id="findings"></a>', "", "## Findings", ""] + list(run_lines)
    if not rows:
        return md + ["No headline result among the inputs (no height series, sweep, continuum or "
                     "shear analysis).", ""]
    md += ["One row per headline result: the measured value (± one standard error; a range "
           "where fewer than 5 packings enter; a pressure exponent as value [its Student 95 % "
           "interval], a bound as ≥ or ≤ at 95 %), what it rests on, the reference it is compared "
           "with, what its estimator is worth (bias and 95 % coverage measured by the truth suite "
           "on inputs with a known answer through the same code and defaults; "
           "\"not validated\" where the suite has no such check yet; — where no estimator is "
           "involved) and the verdict. The tables follow.", ""]
    md += table(["quantity", "measured", "n", "reference", "estimator (truth suite)", "verdict",
                 "from"], [r.row() for r in rows])
    return md
