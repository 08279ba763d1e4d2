"""The coherent front against distance (docs/method.md §9): arrival times, A(L) and W(L)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..analysis.fits import inverse_slope, linear_fit, power_law_fit
from .common import L_LABEL, array, fmt_err, need, new_figure, save_figure

ARRIVAL_POINTS = (("t_lead10", "10% leading edge", "c_tof"), ("t_peak", "first peak", "c_peak"),
                  ("t_zero", "zero crossing", "c_zero"))


def arrival_times(data: Mapping, path, *, pdf: bool = False) -> list[Path]:
    """Arrival times of the 10% edge, the first peak and the zero crossing against L.

    ``data``: ``height`` (array) and ``t_lead10``, ``t_peak``, ``t_zero`` arrays
    (missing ones are skipped). Lines t = t0 + L/c: the fits over all heights that
    `analyze heights` wrote (``c_tof_all``, ``t0_t_lead10_all``, ... with ``_err``)
    when the data hold them, else least-squares fits here; the speeds in the legend.
    """
    L = array(data["height"], "height")
    fig = new_figure((8, 5.5))
    ax = fig.add_subplot(1, 1, 1)
    drawn = 0
    Lx = np.linspace(0, L.max() * 1.05, 50)
    for k, (key, name, speed) in enumerate(ARRIVAL_POINTS):
        if data.get(key) is None:
            continue
        t = np.asarray(data[key], float)
        ax.plot(L, t, "o", color=f"C{k}", ms=5)
        lab = name
        c, t0 = data.get(speed + "_all"), data.get(f"t0_{key}_all")
        if c is not None and t0 is not None:  # the analysis's own fit
            c, t0, dc = float(c), float(t0), data.get(speed + "_all_err")
        elif np.sum(np.isfinite(t)) >= 2:
            ok = np.isfinite(t)
            fit = linear_fit(L[ok], t[ok], what=f"{key} against height")
            (c, dc), t0 = inverse_slope(fit), fit.intercept
        else:
            c = None
        if c is not None:
            lab += f": c = {c:.4g}" + fmt_err(None if dc is None else float(dc))
            ax.plot(Lx, t0 + Lx / c, "-", color=f"C{k}", lw=1)
        ax.plot([], [], "o-", color=f"C{k}", label=lab)
        drawn += 1
    need(drawn > 0, "no arrival times (t_lead10, t_peak, t_zero) in the data")
    ax.set_xlim(0, None)
    ax.set_ylim(0, None)
    ax.set_xlabel(L_LABEL)
    ax.set_ylabel(r"arrival time  [$\bar d/\sqrt{E^*/\rho}$]")
    ax.legend(title=r"fits $t = t_0 + L/c$, $c$ in $\sqrt{E^*/\rho}$")
    if data.get("label"):
        ax.set_title(str(data["label"]))
    return save_figure(fig, path, pdf=pdf)


def amplitude_width(series: Mapping[str, Mapping], path, *, references: Mapping | None = None,
                    pdf: bool = False) -> list[Path]:
    """A(L) and W(L) on log–log axes with their local exponents, several series.

    ``series``: label -> dict with ``height`` (one entry per nominal height),
    ``amplitude`` and ``width`` (the ensemble means there) and optionally
    ``amplitude_sem``, ``width_sem`` (their standard errors: error bars) and
    ``count``; and the fitted ``gamma``, ``gamma_err``, ``alpha``, ``alpha_err``,
    ``amplitude_prefactor``, ``width_prefactor`` of the height analysis (drawn
    as lines; without them a power law is fitted through the means).
    Local exponents are taken between the ensemble means at consecutive
    distinct heights (:func:`granwave.analysis.ensemble.local_exponents_of_means`),
    with the propagated standard errors as error bars. ``references``: exponents
    drawn as dashed lines (default: the chain's γ = 2/3 and δ = 1/3 (key ``alpha``: W ∝ L^δ)).
    """
    from ..analysis.ensemble import local_exponents_of_means

    need(len(series) > 0, "no series to plot")
    ref = {"gamma": 2 / 3, "alpha": 1 / 3} if references is None else dict(references)
    fig = new_figure((12, 8.5))
    axA, axW = fig.add_subplot(2, 2, 1), fig.add_subplot(2, 2, 2)
    axg, axa = fig.add_subplot(2, 2, 3, sharex=axA), fig.add_subplot(2, 2, 4, sharex=axW)
    markers = "osD^vP*X"
    for k, (label, s) in enumerate(series.items()):
        L = array(s["height"], f"{label}: height")
        col, mk = f"C{k}", markers[k % len(markers)]
        for ax, axe, key, sign, sym, fkey in ((axA, axg, "amplitude", -1, "γ", "gamma"),
                                               (axW, axa, "width", 1, "δ", "alpha")):
            if s.get(key) is None:
                continue
            y = np.abs(np.asarray(s[key], float))
            sem = s.get(key + "_sem")
            sem = None if sem is None else np.asarray(sem, float)
            lab = label
            ok = (L > 0) & (y > 0) & np.isfinite(y)
            if s.get(fkey) is not None and s.get(key + "_prefactor") is not None:
                expo, err, pref = sign * float(s[fkey]), s.get(fkey + "_err"), float(s[key + "_prefactor"])
            elif np.unique(L[ok]).size >= 2:
                fit = power_law_fit(L[ok], y[ok], what=f"{label}: {key} against height")
                expo, err, pref = fit.exponent, fit.exponent_err, fit.prefactor
            else:
                expo = None
            if expo is not None:
                Lx = np.geomspace(L[ok].min(), L[ok].max(), 20)
                ax.plot(Lx, pref * Lx ** expo, "-", color=col, lw=0.8)
                lab += f": {sym} = {sign * expo:.3f}" + fmt_err(None if err is None else float(err))
            ax.errorbar(L, y, yerr=sem, fmt=mk, color=col, ms=5, capsize=3, label=lab)
            loc = local_exponents_of_means(L, y, sem)
            if loc["height_mid"].size:
                e = loc["exponent_err"]
                axe.errorbar(loc["height_mid"], sign * loc["exponent"],
                             yerr=e if np.isfinite(e).any() else None, fmt=mk + "-", color=col,
                             ms=4, lw=0.8, capsize=3, label=label)
    for ax in (axA, axW):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.legend(fontsize=8)
    axA.set_ylabel(r"amplitude $A$ of the first peak  [$E^*\bar d^{\,2}$]")
    axW.set_ylabel(r"width $W$  [$\bar d/\sqrt{E^*/\rho}$]")
    axg.set_ylabel(r"local $-\,d\log A/d\log L$")
    axa.set_ylabel(r"local $d\log W/d\log L$")
    for ax, key, name in ((axg, "gamma", "γ"), (axa, "alpha", "δ")):
        if ref.get(key) is not None:
            ax.axhline(ref[key], ls="--", color="k", lw=1.2, zorder=5,
                       label=f"{name} = {ref[key]:.3g} (reference)")
        ax.set_xlabel(L_LABEL)
        ax.legend(fontsize=8)
    axA.set_title(r"$A \propto L^{-\gamma}$: ensemble means ± standard error, line: fit")
    axW.set_title(r"$W \propto L^{\delta}$: ensemble means ± standard error, line: fit")
    return save_figure(fig, path, pdf=pdf)
