"""The continuum scene: speeds, c_tof/c_l, amplitude and width against L, alpha(omega), c(omega)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .common import C_UNIT, L_LABEL, array, need, new_figure, plain_log_ticks, save_figure, scene_title, value_text


def _errorbar(ax, x, y, e, **kw):
    e = np.where(np.isfinite(e), e, 0.0)
    ax.errorbar(x, y, yerr=e, capsize=2, **kw)


def continuum_panels(front: Mapping, attenuation: Mapping | None, path, *,
                     pdf: bool = False, scene: str | None = None) -> list[Path]:
    """Six panels from `analyze continuum --json` (``front``) and `analyze attenuation --json`.

    (a) local speeds c_tof, c_peak, c_zero and c_l, c_t against L; (b) c_tof/c_l (local and
    apparent L/t) with the fit 1 + a L^-beta and the ±tolerance band; (c) amplitude and
    (d) width against L (means ± standard error) with the local exponents γ_eff, δ_eff on a
    twin axis; (e) α(ω) and (f) c(ω) with error bars, the reliable band shaded, c_l dashed
    (the bulk c_l∞ dotted, with the local c_tof/c_l∞ in (b), when the analysis gives it).
    α and c are drawn at the reliable frequencies only, as points with error bars (outside
    the band the analysis does not stand behind them). Nothing is computed here: every number
    comes from the two analyses.
    """
    from ..analysis.renamed_keys import HEIGHTS, current_keys

    front = current_keys(front, HEIGHTS)  # chi_eff (alpha_eff in files of before the rename)
    loc, per = front["local"], front["per_height"]
    Lm = array(loc["height"], "local height")
    L = array(per["height"], "height")
    need(Lm.size >= 1, "the continuum analysis has fewer than two heights")
    fig = new_figure((13, 11))
    ax = fig.add_subplot(3, 2, 1)
    for k, name in enumerate(("tof", "peak", "zero")):
        _errorbar(ax, Lm, np.asarray(loc[f"c_{name}"], float), np.asarray(loc[f"c_{name}_err"], float),
                  fmt="o-", color=f"C{k}", label=f"c_{name} (local dL/dt)")
    _errorbar(ax, L, np.asarray(per["c_l"], float), np.asarray(per["c_l_sem"], float), fmt="s--",
              color="k", label=r"$c_\ell$ (own moduli)")
    bulk = (front.get("c_l_bulk") or {}).get("c_l_inf")
    if bulk is not None and np.isfinite(bulk):
        ax.axhline(bulk, color="k", ls=":", lw=1, label=r"$c_{\ell\infty}$ (walls extrapolated out)")
    if np.any(np.isfinite(np.asarray(per["c_t"], float))):
        ax.plot(L, per["c_t"], "^:", color="0.5", label=r"$c_t$")
    ax.set_xscale("log")
    ax.set_xlabel(L_LABEL)
    ax.set_ylabel(f"speed  [{C_UNIT}]")
    ax.legend(fontsize=8)

    ax = fig.add_subplot(3, 2, 2)
    _errorbar(ax, Lm, np.asarray(loc["ratio"], float), np.asarray(loc["ratio_err"], float), fmt="o",
              color="C0", label=r"$c_{\rm tof}/c_\ell$ local")
    _errorbar(ax, L, np.asarray(per["ratio_apparent"], float),
              np.asarray(per["ratio_apparent_err"], float), fmt="s", color="C1", mfc="none",
              label=r"apparent $L/t_{10}$ over $c_\ell$")
    if "ratio_bulk" in loc and np.any(np.isfinite(np.asarray(loc["ratio_bulk"], float))):
        _errorbar(ax, Lm, np.asarray(loc["ratio_bulk"], float), np.asarray(loc["ratio_bulk_err"], float),
                  fmt="D", color="C2", mfc="none", label=r"$c_{\rm tof}/c_{\ell\infty}$ local")
    app = front.get("approach", {})
    tol = float(app.get("tolerance", 0.05))
    xs = np.geomspace(min(Lm.min(), L.min()), max(L.max(), min(float(app.get("L_star") or 0), 1e5)) * 1.2, 100)
    if np.isfinite(app.get("beta", np.nan) or np.nan):
        from ..report.numbers import fmt, fmt_bound, num, resolved

        ci = app.get("L_star_ci")
        if resolved(app.get("L_star"), None, ci):
            lstar = f"$L^*$ = {fmt_bound(app.get('L_star'), 3)}"
        elif app.get("status") == "beyond":  # the one bound the data give
            lstar = f"$L^*$ > {fmt_bound(app.get('L_max'), 3)} (not reached)"
        elif ci and num(ci[0]) > 0:
            lstar = f"$L^*$ > {fmt_bound(ci[0], 2)} (95 %; the fit does not bound it above)"
        else:
            lstar = "$L^*$ not constrained by the fit"
        lab = (rf"$1 + a L^{{-\beta}}$, $\beta$ = {fmt(app['beta'], app.get('beta_err'), 3)}, "
               + lstar)
        ax.plot(xs, 1 + app["a"] * xs ** -app["beta"], "-", color="C0", lw=1, label=lab)
    ax.axhspan(1 - tol, 1 + tol, color="0.9", zorder=0, label=f"±{tol:g}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel(L_LABEL)
    ax.set_ylabel(r"$c_{\rm tof}/c_\ell$  [1]")
    ax.legend(fontsize=8)

    for k, (key, eff, sign, label, unit) in enumerate((
            ("amplitude", "gamma_eff", r"$\gamma_{\rm eff}$", "|A|", r"$E^*\bar d^{\,2}$"),
            ("width", "chi_eff", r"$\chi_{\rm eff}$", "W", r"$\bar d/\sqrt{E^*/\rho}$"))):
        ax = fig.add_subplot(3, 2, 3 + k)
        _errorbar(ax, L, np.asarray(per[key], float), np.asarray(per[key + "_sem"], float), fmt="o-",
                  color="C0", label=f"{label} (mean ± s.e.)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(L_LABEL)
        ax.set_ylabel(f"{'amplitude' if key == 'amplitude' else 'width'} {label}  [{unit}]")
        tw = ax.twinx()
        _errorbar(tw, Lm, np.asarray(loc[eff], float), np.asarray(loc[eff + "_err"], float), fmt="s",
                  color="C3", label=sign)
        tw.set_ylabel(f"local exponent {sign}  [1]", color="C3")
        ax.legend(fontsize=8, loc="upper left")
        tw.legend(fontsize=8, loc="lower right")

    if attenuation:
        om = array(attenuation["omega"], "omega")
        rel = np.asarray(attenuation["reliable"], bool)
        for k, (key, ylabel) in enumerate((("alpha", r"attenuation $\alpha(\omega)$  [1/$\bar d$]"),
                                           ("c", f"phase velocity $c(\\omega)$  [{C_UNIT}]"))):
            ax = fig.add_subplot(3, 2, 5 + k)
            y = np.asarray([np.nan if v is None else v for v in attenuation[key]], float)
            e = np.asarray([np.nan if v is None else v for v in attenuation[key + "_err"]], float)
            ax.errorbar(om[rel], y[rel], yerr=np.where(np.isfinite(e[rel]), e[rel], 0.0), fmt="o",
                        ms=3, color="C0", capsize=2, label="reliable band, ± one standard error")
            if rel.any():
                ax.axvspan(om[rel][0], om[rel][-1], color="0.93", zorder=0)
                lo, hi = np.nanmin(y[rel] - np.nan_to_num(e[rel])), np.nanmax(y[rel] + np.nan_to_num(e[rel]))
                pad = 0.2 * (hi - lo) if hi > lo else 1.0
                ax.set_ylim(lo - pad, hi + pad)
                ax.set_xlim(0, min(om[-1], 1.5 * om[rel][-1]))
            cut = attenuation.get("omega_cutoff")
            if cut is not None and np.isfinite(cut):
                ax.axvline(cut, color="C3", ls="-.", lw=1,
                           label=r"lateral cutoff $2\pi c_t/L_1$")
            if key == "c":
                cl = front.get("c_l", {}).get("mean")
                if cl:
                    ax.axhline(cl, color="k", ls="--", lw=1, label=r"$c_\ell$ (mean)")
                if bulk is not None and np.isfinite(bulk):
                    ax.axhline(bulk, color="k", ls=":", lw=1, label=r"$c_{\ell\infty}$")
                c0 = attenuation.get("c0")
                if c0 is not None and np.isfinite(c0):
                    ax.plot([0], [c0], "D", color="C3", clip_on=False,
                            label="$c_0$ = " + value_text(c0, attenuation.get("c0_err"), 4))
            ax.set_xlabel(r"$\omega$  [$\sqrt{E^*/\rho}/\bar d$]")
            ax.set_ylabel(ylabel)
            ax.legend(fontsize=8)
    for a in fig.get_axes():
        plain_log_ticks(a)
    fig.suptitle(scene_title("the front against distance and the coherent signal's attenuation and "
                             "phase velocity", scene=scene, pressure=front.get("pressure"), height=L,
                             count=f"{front.get('n_signals')} packings"), fontsize=10)
    return save_figure(fig, path, pdf=pdf)
