"""The shear scene: V_s, V_p and c_t, c_l against pressure, G_max against p^(1/3), V_p/V_s and
the Poisson ratio from waves and moduli, and every pick's V/c_t against distance."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .common import C_UNIT, L_LABEL, need, new_figure, plain_log_ticks, save_figure, scene_title, value_text


def _col(rows, key, what="mean"):
    return np.array([float("nan") if r[key].get(what) is None else r[key][what] for r in rows], float)


def _errorbar(ax, x, rows, key, **kw):
    e = _col(rows, key, "sem")
    ax.errorbar(x, _col(rows, key), yerr=np.where(np.isfinite(e), e, 0.0), capsize=2, **kw)


def _line(ax, p, fit, **kw):
    if fit and fit.get("prefactor") is not None and fit.get("exponent") is not None:
        ax.plot(p, fit["prefactor"] * p ** fit["exponent"], **kw)


def shear_panels(analysis: Mapping, path, *, pdf: bool = False, scene: str | None = None) -> list[Path]:
    """Five panels from a shear scene's analysis (granwave.analysis.shear_scene):
    (a) V_s, V_p (waves, the scene's pick) and c_t, c_l (moduli) against p with the fitted power
    laws; (b) G_max = Φ3* V_s² and the moduli's G with the free fit and the p^(1/3) line;
    (c) V_p/V_s and c_l/c_t; (c') the effective Poisson ratios ν_eff from waves, moduli and tensor
    (a panel of their own, not a twin axis); (d) V/c_t of
    every pick against L at the reference wavelength, one line per pressure's heights, the ±5 %
    band shaded and c_l/c_t of the moduli dashed (the compressional precursor's speed: a pick
    there reads the P wave, docs/shear.md); a series of fewer than three heights as points
    without a line. Nothing is computed here."""
    rows = analysis["pressures"]
    need(len(rows) >= 1, "the shear analysis has no pressure")
    p = np.array([r["pressure"] for r in rows], float)
    pl = np.geomspace(p.min(), p.max(), 50) if p.size > 1 else p
    fits = analysis.get("fits", {})
    fig = new_figure((15, 9))
    grid = fig.add_gridspec(2, 6)  # three panels above, two below
    slots = [grid[0, 0:2], grid[0, 2:4], grid[0, 4:6], grid[1, 0:3], grid[1, 3:6]]

    ax = fig.add_subplot(slots[0])
    for k, (key, fit_key, label) in enumerate((("V_s", "V_s", r"$V_s$ (waves)"), ("c_t", "c_t", r"$c_t$ (moduli)"),
                                               ("V_p", "V_p", r"$V_p$ (waves)"), ("c_l", "c_l", r"$c_\ell$ (moduli)"))):
        _errorbar(ax, p, rows, key, fmt="o" if key.startswith("V") else "s", mfc=None if key.startswith("V") else "none",
                  color=f"C{k // 2}", label=label)
        _line(ax, pl, fits.get(fit_key), color=f"C{k // 2}", ls="-" if key.startswith("V") else ":", lw=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(f"speed  [{C_UNIT}]")
    ax.set_title(f"pick {analysis['pick']}, " + r"$\lambda$" + f" = {analysis['wavelengths'][0]:g}", fontsize=9)
    ax.legend(fontsize=8)

    ax = fig.add_subplot(slots[1])
    _errorbar(ax, p, rows, "G_max", fmt="o", color="C0", label=r"$G_{\max} = \Phi_3^* V_s^2$")
    _errorbar(ax, p, rows, "G_moduli", fmt="s", mfc="none", color="C1", label="G (moduli)")
    g = analysis.get("G_max", {})
    if g.get("free"):
        _line(ax, pl, g["free"], color="C0", lw=1, label="fit $G_{\\max} \\propto p^{\\kappa_G}$: κ_G = "
              + value_text(g["free"]["exponent"], g["free"].get("exponent_err")))
    if g.get("hertz"):
        _line(ax, pl, g["hertz"], color="k", ls="--", lw=1, label=r"$\propto p^{1/3}$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(r"shear modulus  [$E^*$]")
    ax.legend(fontsize=8)

    ax = fig.add_subplot(slots[2])
    _errorbar(ax, p, rows, "ratio_waves", fmt="o-", color="C0", label=r"$V_p/V_s$ (waves)")
    _errorbar(ax, p, rows, "ratio_moduli", fmt="s--", mfc="none", color="C1", label=r"$c_\ell/c_t$ (moduli)")
    ax.set_xscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel("speed ratio  [1]")
    ax.legend(fontsize=8)

    ax = fig.add_subplot(slots[3])
    for key, c, label in (("poisson_waves", "C2", "waves"), ("poisson_moduli", "C3", "moduli"),
                          ("poisson_tensor", "C4", "tensor")):
        _errorbar(ax, p, rows, key, fmt="^:", color=c, label=r"$\nu_{\rm eff}$ " + label)
    ax.set_xscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(r"effective Poisson ratio $\nu_{\rm eff}$  [1]")
    ax.legend(fontsize=8)

    ax = fig.add_subplot(slots[4])
    lam0 = analysis["wavelengths"][0]
    table = [r for r in analysis["pick_table"] if r["wavelength"] == lam0]
    heights = {}
    for r in table:
        heights.setdefault(r["pressure"], []).append(r)
    # the pressure with the most heights (ties: the highest)
    pmax = max(heights, key=lambda q: (len(heights[q]), q)) if heights else None
    if pmax is not None:
        rs = sorted(heights[pmax], key=lambda r: r["height"])
        L = np.array([r["height"] for r in rs], float)
        for k, name in enumerate(analysis["picks"]):
            y = np.array([np.nan if r.get(name) is None else r[name] for r in rs], float)
            e = np.array([np.nan if r.get(f"{name}_err") is None else r[f"{name}_err"] for r in rs], float)
            ax.errorbar(L, y, yerr=np.where(np.isfinite(e), e, 0.0), fmt="o-" if L.size >= 3 else "o",
                        capsize=2, color=f"C{k}", label=name)
        tol = analysis.get("tolerance", 0.05)
        ax.axhspan(1 - tol, 1 + tol, color="0.9", zorder=0)
        ax.axhline(1.0, color="k", lw=0.8)
        # c_l/c_t of the moduli: where the shear kick's compressional precursor arrives
        ratio = next((r.get("ratio_moduli") or {} for r in rows if r["pressure"] == pmax), {}).get("mean")
        if ratio is not None and np.isfinite(ratio):
            ax.axhline(ratio, color="k", ls="--", lw=0.8, label=r"$c_\ell/c_t$: P precursor")
        ax.set_title(f"p = {pmax:g}, " + r"$\lambda$" + f" = {lam0:g}", fontsize=9)
    ax.set_xscale("log")
    ax.set_xlabel(L_LABEL)
    ax.set_ylabel(r"$V/c_t$  [1]")
    ax.legend(fontsize=7, ncol=2)
    for a in fig.get_axes():
        plain_log_ticks(a)
    fig.suptitle(scene_title(f"shear waves of {analysis.get('source_scene', 'the packings')}: speeds, "
                             "moduli and arrival picks against pressure and distance",
                             scene=scene or analysis.get("scene"), height=analysis.get("fit_height"),
                             count=f"{analysis.get('n_records')} packings"), fontsize=10)
    return save_figure(fig, path, pdf=pdf)
