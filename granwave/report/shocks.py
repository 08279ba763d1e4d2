"""The report's shocks section (docs/shocks.md, "The shocks scene"): per scene the strongly
nonlinear exponent against (α_c − 2)/2 and against the mean-field column over the same window, the
crossover strain's scaling with p against 1/(α_c − 1), and per pressure δ0, V_0, ε×/δ0 and the
contact fractions at the strongest push.

Input: the workflow's shocks analyses (``results/shocks/<scene>/analysis.json``, written by
``granwave analyze shocks --json``: :func:`granwave.analysis.shocks_scene.shocks_scene`). Every
number is copied from them; :func:`scene_tables` is also what docs/shocks.md's generated tables
are made of.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

from .numbers import MISSING, fmt, fmt_ci, fmt_count, fmt_range, num


def _ci(stat: Mapping, dof: float) -> list:
    """A stat's 95 % interval: its ``ci95``, or (a record written before stat() gave one) Student's
    t(0.975, ``dof``) times its error about its mean."""
    ci = stat.get("ci95")
    if ci is not None and len(ci) == 2:
        return list(ci)
    from ..analysis.shocks_scene import ci95

    d = num(dof)
    return ci95(num(stat.get("mean", stat.get("exponent"))), num(stat.get("error")), int(d) if d >= 1 else 0)


def shocks_inputs(items: Sequence[tuple[Path, object, str | None]]) -> dict[str, Mapping]:
    """{scene: that scene's analysis} of the shocks analyses among ``items``."""
    out: dict[str, Mapping] = {}
    for _path, obj, _ in items:
        if isinstance(obj, Mapping) and isinstance(obj.get("scenes"), Mapping):
            for scene, a in obj["scenes"].items():
                if isinstance(a, Mapping) and "pressures" in a:
                    out[str(scene)] = a
    return out


def cell(stat: Mapping | None, digits: int = 3) -> str:
    """mean [its 95 % interval] (Student, n − 1 degrees of freedom) over 5 packings or more; the
    range (min … max) over fewer."""
    stat = stat or {}
    n = num(stat.get("n"))
    if not (n >= 1):
        return MISSING
    if n < 5:
        if n == 1:
            return fmt(stat.get("mean"), None, digits)
        return fmt_range(stat.get("min"), stat.get("max"))
    lo, hi = _ci(stat, n - 1)
    return fmt_ci(stat.get("mean"), stat.get("error"), lo, hi, digits)


def _sigma(value: Mapping, expected: float) -> str:
    m, e = num(value.get("mean")), num(value.get("error"))
    if not (math.isfinite(m) and math.isfinite(e) and e > 0 and math.isfinite(expected)):
        return MISSING
    return f"{(m - expected) / e:+.1f} σ"


def summary_table(scenes: Mapping[str, Mapping]) -> list[str]:
    """One row per scene: exponent, its distance from (α_c−2)/2 in standard errors, the mean field's
    slope over the same window, the crossover's p-exponent against 1/(α_c − 1)."""
    md = ["| scene | law, μ | packings | exponent ψ (ε/δ0 window) | (α_c−2)/2 | ψ − (α_c−2)/2 | mean field, same window "
          "| ε× ∝ p^κ: κ | 1/(α_c−1) |", "|---|---|---|---|---|---|---|---|---|"]
    for scene, a in sorted(scenes.items()):
        t, sc = a["tail_exponent"], a["crossover_scaling"]
        lo, hi = (a.get("tail_window") or [math.nan, math.nan])[:2]
        window = f" ({fmt(lo, None, 2)} … {fmt(hi, None, 2)})" if math.isfinite(num(lo)) else ""
        kappa = (fmt_ci(sc.get("exponent"), sc.get("error"), *_ci(sc, num(sc.get("n")) - 2), 3)
                 + f" ({fmt_count(sc.get('n_pressures'))} pressures)" if math.isfinite(num(sc.get("exponent")))
                 else MISSING)
        md.append(f"| {scene} | {a['contact_law']}, {num(a['friction']):g} | {fmt_count(a['n_packings'])} | "
                  f"{cell(t)}{window} | {num(a['tail_exponent_expected']):g} | "
                  f"{_sigma(t, num(a['tail_exponent_expected']))} | {fmt(a.get('tail_exponent_mean_field'), None, 3)} | "
                  f"{kappa} | {fmt(a.get('crossover_scaling_expected'), None, 3)} |")
    return md


def pressure_table(a: Mapping) -> list[str]:
    """Per pressure: packings, δ0, V_0, ε×/δ0 (and how many reached it), the exponent, and the
    fractions of contacts opened (and slid) at the strongest push run there."""
    md = ["| p | packings | δ0 | V_0 | ε×/δ0 (reached) | ψ | smallest V/V_0 (at ε/δ0) | strongest push ε/δ0 | opened "
          "| slid | rise width (d) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for q in a["pressures"]:
        top = q["pushes"][-1] if q["pushes"] else {}
        md.append(f"| {num(q['pressure']):.0e} | {fmt_count(q['n_packings'])} | {cell(q['static_strain'])} | "
                  f"{cell(q['c0'])} | {cell(q['crossover_over_static'])} ({fmt_count(q['n_crossover_reached'])}) | "
                  f"{cell(q['tail_exponent'])} | {cell(q['softening']['ratio'])} ({cell(q['softening']['x'], 2)}) | "
                  f"{cell(top.get('x'))} | {cell(top.get('opened'))} | "
                  f"{cell(top.get('slid_fraction'))} | {cell(top.get('width'), 2)} |")
    return md


def scene_tables(scenes: Mapping[str, Mapping]) -> list[str]:
    """The summary table and one pressure table per scene (the report's and docs/shocks.md's)."""
    md = summary_table(scenes)
    for scene, a in sorted(scenes.items()):
        md += ["", f"**{scene}** ({a['contact_law']}, friction {num(a['friction']):g}; mean-field "
               f"crossover x× = {fmt(a.get('crossover_mean_field'), None, 3)}"
               + (f"; {fmt_count(a.get('n_excluded'))} packing{'s' if a.get('n_excluded') != 1 else ''} left out "
                  "without a linear push"
                  if a.get("n_excluded") else "")
               + (f"; {fmt_count(a.get('n_pushes_rejected'))} of {fmt_count(a.get('n_pushes'))} pushes "
                  "left out as failed picks" if a.get("n_pushes_rejected") else "") + ")", ""]
        md += pressure_table(a)
    return md


def shocks_section(scenes: Mapping[str, Mapping]) -> list[str]:
    """The section's Markdown lines (empty without a shocks scene)."""
    if not scenes:
        return []
    md = ["## Shocks: from the linear response to shocks", "",
          "Piston pushes at constant velocity v_p on the same packings, drives from the linear regime "
          "to ε/δ0 ~ 10² (docs/shocks.md, \"The shocks scene\"). ε = v_p/V is the strain behind the "
          "front, δ0 the mean overlap over the mean diameter, V_0 each packing's speed at its weakest "
          "push; ε× is where V first reaches 1.1 V_0 (its p-exponent κ over the pressures where at least half the packings reach it); ψ the log-log slope of V against ε over each "
          "packing's pushes at ε/δ0 ≥ the scene's window start (Gómez, Turner, van Hecke, Vitelli, "
          "PRL 108, 058001 (2012): ψ = (α_c − 2)/2, ε× ∝ δ0 ∝ p^(1/(α_c−1))). The mean-field column "
          "(jump conditions of a uniform column of such contacts) gives the slope a finite window "
          "can show. Each mean is followed by its 95 % interval in brackets (Student's t over the "
          "packings, n − 1 degrees of freedom: 2.26 standard errors over ten; κ's with n − 2); under 5 "
          "packings the range (min … max) instead. The "
          "opened fraction is of the contacts of t = 0, the slid one of all the contacts that existed "
          "(formed ones included), both counted until the front reaches the top wall (the incoming "
          "front's, not its reflection's); "
          "a smallest V/V_0 below 1 is the softening before the hardening. The rise width (10–90 % rise time × V) is the front as "
          "the bins see it where the speed is fitted: on disordered columns broadened by the bins' "
          "arrival spread, on these short columns multiplied by a still-forming front's speed: an upper "
          "estimate of the steady front's width, not a validated one.",
          ""]
    return md + scene_tables(scenes) + [""]
