"""The report's table of speed exponents per contact law (docs/method.md §2 "Low-pressure laws", §10).

For every lattice and disordered scene with height series at 3 or more pressures: its contact law
(the config's ``contact``; Hertz-Mindlin where none), the exponent κ of c_tof ∝ p^κ over all its
pressures and over the lower and the upper half of them (least squares in log–log through the
per-pressure values, :func:`granwave.analysis.fits.power_law_fit`, ± one standard error), beside
the exponents of the law itself at the lowest and the highest pressure (the local slope of the
lattice row chain's speed, :func:`granwave.theory.law_lattice_speed`: 1/4 for an asperity, 1/6
for Hertz), and the crossover pressure p* where c_tof turns from p^{1/4} to p^{1/6} with its 95 %
interval: the estimator of ``pressure-sweep --crossover`` (:func:`granwave.analysis.sweep.
pressure_sweep`, its defaults), run on the scene's height series, with its validated bias where
the truth suite has measured it (:func:`granwave.report.validated.check_cell`, key ``sweep.p_star``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from .inputs import Scenes, num
from .numbers import fmt
from .validated import check_cell

#: the truth suite's key of the p* estimator (benchmarks/truth_cases/laws.py)
P_STAR_KEY = "sweep.p_star"


def law_label(contact: Mapping) -> str:
    """The scene's normal law and the parameters it sets, e.g. ``cone (cone_slope 0.05)``."""
    from ..contact_models import options as CO

    values = CO.values_of(dict(contact))
    name = values[CO.KINDS["normal"]["option"]]
    own = [f"{k} {contact[k]:g}" for k in contact if k in CO.PARAMETERS]
    others = [f"{k} {contact[k]}" for k in contact if k != CO.KINDS["normal"]["option"] and k not in CO.PARAMETERS]
    return name + (f" ({', '.join(own + others)})" if own or others else "")


def law_exponent(p: float, contact: Mapping, friction: bool) -> float:
    """The law's own exponent of the lattice speed at ``p``: d ln c / d ln p of
    :func:`granwave.theory.law_lattice_speed` over p .. 1.01 p."""
    from ..theory import law_lattice_speed

    c0, c1 = (law_lattice_speed(q, dict(contact), friction=friction) for q in (p, 1.01 * p))
    return math.log(c1 / c0) / math.log(1.01)


def laws_section(h_by_scene: Mapping[str, Mapping], scenes: Scenes) -> list[str]:
    """The section's Markdown lines (module docstring); empty where no scene has 3 pressures."""
    from ..analysis.fits import power_law_fit
    from ..analysis.sweep import crossover_text, pressure_sweep
    from ..params import SweepParams
    from .tables import table

    names = sorted(s for s in h_by_scene if scenes.kind_of(s) in ("lattices", "disordered")
                   and len(h_by_scene[s]) >= 3)
    if not names:
        return []
    d = SweepParams()
    rows = []
    for scene in names:
        series = [h for _, h in sorted(h_by_scene[scene].items()) if num(h.get("c_tof")) > 0]
        if len(series) < 3:
            continue
        p = [num(h["pressure"]) for h in series]
        c = [num(h["c_tof"]) for h in series]
        half = len(p) // 2

        def kappa(a, b):
            fit = power_law_fit(p[a:b], c[a:b], what=f"{scene}: c_tof against p")
            return fmt(fit.exponent, fit.exponent_err)
        contact = scenes.contact_of(scene)
        mu = scenes.friction_of(scene)
        frictional = bool(math.isfinite(mu) and mu > 0)
        fit = pressure_sweep([], height_series=[dict(h) for h in series],
                             crossover=(d.crossover_low, d.crossover_high))["crossover_tof"]
        rows.append([scene, scenes.kind_of(scene), law_label(contact), f"{p[0]:.3g}–{p[-1]:.3g} ({len(p)})",
                     kappa(0, len(p)), kappa(0, max(half, 2)), kappa(min(half, len(p) - 2), len(p)),
                     f"{law_exponent(p[0], contact, frictional):.4f} / {law_exponent(p[-1], contact, frictional):.4f}",
                     crossover_text(fit)])
    if not rows:
        return []
    md = ["## Speed exponents per contact law (docs/method.md §2, §10)", "",
          "c_tof ∝ p^κ from each scene's height series (the front's 10 % edge between the edge heights, "
          "§9): κ over all its pressures and over the lower and upper half of them (± one standard "
          "error of the slope; none with two pressures), beside the law's own exponent of the lattice "
          "speed at the lowest / highest pressure (`granwave.theory.law_lattice_speed`: 1/4 for an "
          "asperity, 1/6 for Hertz), and the crossover pressure p* where c_tof turns from p^{1/4} to "
          "p^{1/6} (`pressure-sweep --crossover`, its 95 % interval; a law without a crossover still "
          "gets a nominal p*: read it with the two halves' κ). p in E*, κ dimensionless. The p* "
          f"estimator on series of known p*: {check_cell(P_STAR_KEY)}.", ""]
    return md + table(["scene", "kind", "contact law", "p (n)", "κ (all)", "κ (lower half)", "κ (upper half)",
                       "law's κ at the lowest / highest p", "p* (95 %)"], rows)
