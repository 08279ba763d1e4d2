"""The report's table of speed exponents per contact law (docs/method.md §2 "Low-pressure laws", §10).

For every lattice and disordered scene with height series at 3 or more pressures: its contact law
(the config's ``contact``; Hertz-Mindlin where none), the exponent ν of c_tof ∝ p^ν over all its
pressures and over the lower and the upper half of them (least squares in log–log through the
per-pressure values, :func:`granwave.analysis.fits.power_law_fit`, ± one standard error), beside
the exponents of the law itself at the lowest and the highest pressure (the local slope of the
lattice row chain's speed, :func:`granwave.theory.law_lattice_speed`: 1/4 for an asperity, 1/6
for Hertz), and the crossover pressure p* where c_tof turns from p^{1/4} to p^{1/6} with its 95 %
interval: the estimator of ``pressure-sweep --crossover`` (:func:`granwave.analysis.sweep.
pressure_sweep`, its defaults), run on the scene's height series, with its validated bias where
the truth suite has measured it (its table shipped with the package, data/truth.json, key
``sweep.p_star``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

from .inputs import Scenes, num
from .numbers import fmt

TRUTH = Path(__file__).resolve().parents[1] / "data" / "truth.json"


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


def _validated_bias() -> str:
    """The truth suite's word on the p* estimator (its relative bias and 95 % coverage), or ""."""
    try:
        rows = json.loads(TRUTH.read_text())["estimators"]["sweep.p_star"]
    except (OSError, ValueError, KeyError, TypeError):
        return ""
    parts = [f"{r.get('setting', '?')}: relative bias {fmt(num(r.get('bias_rel')), num(r.get('bias_err')))}, "
             f"95 % coverage {fmt(num(r.get('coverage95')), digits=2)} ({r.get('verdict', '?')})" for r in rows]
    return " Its check on series of known p* (the truth suite): " + "; ".join(parts) + "."


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

        def nu(a, b):
            fit = power_law_fit(p[a:b], c[a:b], what=f"{scene}: c_tof against p")
            return fmt(fit.exponent, fit.exponent_err)
        contact = scenes.contact_of(scene)
        mu = scenes.friction_of(scene)
        frictional = bool(math.isfinite(mu) and mu > 0)
        fit = pressure_sweep([], height_series=[dict(h) for h in series],
                             crossover=(d.crossover_low, d.crossover_high))["crossover_tof"]
        rows.append([scene, scenes.kind_of(scene), law_label(contact), f"{p[0]:.3g}–{p[-1]:.3g} ({len(p)})",
                     nu(0, len(p)), nu(0, max(half, 2)), nu(min(half, len(p) - 2), len(p)),
                     f"{law_exponent(p[0], contact, frictional):.4f} / {law_exponent(p[-1], contact, frictional):.4f}",
                     crossover_text(fit)])
    if not rows:
        return []
    md = ["## Speed exponents per contact law (docs/method.md §2, §10)", "",
          "c_tof ∝ p^ν from each scene's height series (the front's 10 % edge between the heights L1–L2, "
          "§9): ν over all its pressures and over the lower and upper half of them (± one standard "
          "error; none with two pressures), beside the law's own exponent of the lattice speed at the "
          "lowest / highest pressure (`granwave.theory.law_lattice_speed`: 1/4 for an asperity, 1/6 for "
          "Hertz), and the pressure p* where c_tof turns from p^{1/4} to p^{1/6} "
          "(`pressure-sweep --crossover`, its 95 % interval; a law without a crossover still gets a "
          "nominal p*: read it with the two halves' ν). p in E*, ν dimensionless." + _validated_bias(), ""]
    return md + table(["scene", "kind", "contact law", "p (n)", "ν (all)", "ν (lower half)", "ν (upper half)",
                       "law's ν at p_min / p_max", "p* (95 %)"], rows)
