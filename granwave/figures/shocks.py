"""The shocks scene: the collapse V/V_0 against ε/δ0 with the mean-field curve, the speed against
the strain per pressure, the crossover strain against p, and the fractions of contacts that open
and slide against ε/δ0 (granwave.analysis.shocks_scene)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .common import C_UNIT, need, new_figure, save_figure, scene_title, value_text


def _col(rows, key, what="mean"):
    return np.array([np.nan if r[key].get(what) is None else r[key][what] for r in rows], float)


def shocks_panels(analysis: Mapping, path, *, pdf: bool = False, scene: str | None = None) -> list[Path]:
    """Four panels from one scene of a shocks analysis (``analysis["scenes"][scene]``, or the only
    one): (a) V/V_0 against ε/δ0 (means over the packings, one colour per pressure; error bars the
    standard error where there are 5 packings or more) with the mean-field column's curve;
    (b) V against ε per pressure; (c) ε× against p (the packings' mean, where at least half of them reach it) with the p^(2/3) line
    through its middle point and the mean-field x× δ0; (d) fractions of the contacts of t = 0 that
    opened and of all contacts that slid against ε/δ0. Nothing is computed here but the reference curves."""
    from ..analysis.shocks_scene import mean_field_speed

    scenes = analysis.get("scenes") or {}
    need(bool(scenes), "the shocks analysis has no scene")
    if scene is None or scene not in scenes:
        need(scene is None or len(scenes) == 1, f"scene {scene!r} is not in the shocks analysis ({', '.join(scenes)})")
        name = scene or next(iter(scenes))
        a = scenes[next(iter(scenes))] if scene not in scenes else scenes[scene]
    else:
        name, a = scene, scenes[scene]
    rows = a["pressures"]
    need(len(rows) >= 1, "the shocks analysis has no pressure")
    fig = new_figure((13, 9))
    axes = [fig.add_subplot(2, 2, k + 1) for k in range(4)]

    ax = axes[0]
    xs = []
    for k, r in enumerate(rows):
        pushes = r["pushes"]
        x, y, e = _col(pushes, "x"), _col(pushes, "ratio"), _col(pushes, "ratio", "error")
        xs.append(x)
        ax.errorbar(x, y, yerr=np.where(np.isfinite(e), e, 0.0), fmt="o-", ms=4, capsize=2, color=f"C{k}",
                    label=f"p = {r['pressure']:.0e} (n = {r['n_packings']})")
    xx = np.concatenate(xs)
    xx = xx[np.isfinite(xx) & (xx > 0)]
    if xx.size:
        grid = np.geomspace(xx.min(), xx.max(), 100)
        ax.plot(grid, mean_field_speed(grid, a["alpha"]), "k--", lw=1,
                label=f"mean-field column, α_c = {a['alpha']:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"strain behind the front over static strain $\varepsilon/\delta_0$  [1]")
    ax.set_ylabel(r"front speed over linear speed $V/V_0$  [1]")
    t = a["tail_exponent"]
    ax.set_title(f"V ∝ ε^ψ at ε/δ0 ≥ {a['tail_from']:g}: ψ = {value_text(t['mean'], t['error'])} "
                 f"(expected {a['tail_exponent_expected']:g})", fontsize=9)
    ax.legend(fontsize=8)

    ax = axes[1]
    for k, r in enumerate(rows):
        pushes = r["pushes"]
        ax.plot(_col(pushes, "strain"), _col(pushes, "front_speed"), "o-", ms=4, color=f"C{k}",
                label=f"p = {r['pressure']:.0e}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"strain behind the front $\varepsilon = v_p/V$  [1]")
    ax.set_ylabel(f"front speed $V$  [{C_UNIT}]")
    ax.legend(fontsize=8)

    ax = axes[2]
    p = np.array([r["pressure"] for r in rows], float)
    cross = _col(rows, "crossover")
    err = _col(rows, "crossover", "error")
    ok = np.isfinite(cross) & np.array([bool(r.get("crossover_counted", True)) for r in rows])
    if np.any(ok):
        ax.errorbar(p[ok], cross[ok], yerr=np.where(np.isfinite(err[ok]), err[ok], 0.0), fmt="o", capsize=2,
                    label=r"$\varepsilon_\times$ (V = 1.1 $V_0$)")
        mid = np.flatnonzero(ok)[len(np.flatnonzero(ok)) // 2]
        ax.plot(p, cross[mid] * (p / p[mid]) ** a["crossover_scaling_expected"], "k:", lw=1,
                label=f"∝ p^{a['crossover_scaling_expected']:.3g}")
    d0 = _col(rows, "static_strain")
    if np.isfinite(a.get("crossover_mean_field") or np.nan):
        ax.plot(p, a["crossover_mean_field"] * d0, "k--", lw=1, label=r"mean field $x_\times \delta_0$")
    ax.plot(p, d0, "s", mfc="none", color="C3", label=r"$\delta_0$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(r"strain  [1]")
    sc = a["crossover_scaling"]
    ax.set_title(f"ε× ∝ p^κ, κ = {value_text(sc['exponent'], sc['error'])}", fontsize=9)
    ax.legend(fontsize=8)

    ax = axes[3]
    for k, r in enumerate(rows):
        pushes = r["pushes"]
        x = _col(pushes, "x")
        ax.plot(x, _col(pushes, "opened"), "o-", ms=4, color=f"C{k}", label=f"opened, p = {r['pressure']:.0e}")
        if a["friction"] > 0:
            ax.plot(x, _col(pushes, "slid_fraction"), "^--", ms=4, color=f"C{k}",
                    label=f"slid, p = {r['pressure']:.0e}")
    ax.set_xscale("log")
    ax.set_xlabel(r"$\varepsilon/\delta_0$  [1]")
    ax.set_ylabel("fraction of contacts  [1]")
    ax.set_title("opened: of the contacts of t = 0" + ("; slid: of all that existed" if a["friction"] > 0 else "")
                 + " (whole record)", fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.suptitle(scene_title(f"from sound to shocks: piston pushes, {a['contact_law']} law, friction "
                             f"{a['friction']:g}", scene=name, count=f"{a['n_packings']} packings"))
    return save_figure(fig, path, pdf=pdf)
