"""The coherent front against distance (docs/method.md §9): arrival times, A(L) and W(L)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..analysis.fits import inverse_slope, linear_fit, power_law_fit
from .common import L_LABEL, array, need, new_figure, plain_log_ticks, save_figure, scene_title, value_text

#: A local exponent whose standard error exceeds this is not drawn (with two packings per height
#: the differences of neighbouring means carry errors of order 1: no information, only clutter).
MAX_LOCAL_ERROR = 0.3

ARRIVAL_POINTS = (("t_lead10", "10% leading edge", "c_tof"), ("t_peak", "first peak", "c_peak"),
                  ("t_zero", "zero crossing", "c_zero"))


def arrival_times(data: Mapping, path, *, pdf: bool = False, scene: str | None = None) -> list[Path]:
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
            lab += f": {speed} = " + value_text(c, None if dc is None else float(dc), 4)
            ax.plot(Lx, t0 + Lx / c, "-", color=f"C{k}", lw=1)
        ax.plot([], [], "o-", color=f"C{k}", label=lab)
        drawn += 1
    need(drawn > 0, "no arrival times (t_lead10, t_peak, t_zero) in the data")
    ax.set_xlim(0, None)
    ax.set_ylim(0, None)
    ax.set_xlabel(L_LABEL)
    ax.set_ylabel(r"arrival time  [$\bar d/\sqrt{E^*/\rho}$]")
    ax.legend(title=r"fits $t = t_i + L/c$, speeds in $\sqrt{E^*/\rho}$")
    n = data.get("n_signals") or np.sum(np.isfinite(L))
    ax.set_title(scene_title("arrival times against distance", scene=scene or data.get("label"),
                             pressure=data.get("pressure"), height=L,
                             count=f"{int(n)} signals", width=80), fontsize=10)
    return save_figure(fig, path, pdf=pdf)


def amplitude_width(series: Mapping[str, Mapping], path, *, references: Mapping | None = None,
                    pdf: bool = False, scene: str | None = None) -> list[Path]:
    """A(L) and W(L) on log–log axes with their local exponents, several series.

    ``series``: label -> dict with ``height`` (one entry per nominal height),
    ``amplitude`` and ``width`` (the ensemble means there) and optionally
    ``amplitude_sem``, ``width_sem`` (their standard errors: error bars) and
    ``count``; and the fitted ``gamma``, ``gamma_err``, ``chi``, ``chi_err`` (``alpha`` in files
    of before the rename), ``amplitude_prefactor``, ``width_prefactor`` of the height analysis
    (drawn as lines; without them a power law is fitted through the means).
    Local exponents are taken between the ensemble means at consecutive
    distinct heights (:func:`granwave.analysis.ensemble.local_exponents_of_means`),
    with the propagated standard errors as error bars; those with an error above
    :data:`MAX_LOCAL_ERROR` are left out, and without any left the figure has no local row.
    ``references``: exponents drawn as dashed lines (default: the identical-ball chain's, for
    the initial condition of each series, ``ic``: γ = 2/3 (A) or 1 (B), χ = 1/3; one line per
    initial condition present).
    """
    from ..analysis.ensemble import local_exponents_of_means
    from ..analysis.renamed_keys import HEIGHTS, current_keys

    need(len(series) > 0, "no series to plot")
    chain = {"A": {"gamma": 2 / 3, "chi": 1 / 3}, "B": {"gamma": 1.0, "chi": 1 / 3}}
    if references is None:
        ics = sorted({str(s.get("ic", "A")).upper() for s in series.values()} & set(chain)) or ["A"]
        refs = {f" (chain {ic})" if len(ics) > 1 else "": chain[ic] for ic in ics}
    else:
        refs = {"": current_keys(dict(references), HEIGHTS)}
    series = {label: current_keys(dict(s), HEIGHTS) for label, s in series.items()}
    local = {}
    for label, s in series.items():
        for key in ("amplitude", "width"):
            if s.get(key) is None:
                continue
            sem = None if s.get(key + "_sem") is None else np.asarray(s[key + "_sem"], float)
            loc = local_exponents_of_means(np.asarray(s["height"], float),
                                           np.abs(np.asarray(s[key], float)), sem)
            # an error known to be large drops the point; none known (one exact system per
            # height, a chain) keeps it
            ok = ~(np.asarray(loc["exponent_err"], float) > MAX_LOCAL_ERROR)
            local[(label, key)] = (loc, ok)
    rows = 2 if any(ok.any() for _, ok in local.values()) else 1
    fig = new_figure((12, 8.5 if rows == 2 else 4.8))
    axA, axW = fig.add_subplot(rows, 2, 1), fig.add_subplot(rows, 2, 2)
    axg, axa = (fig.add_subplot(2, 2, 3, sharex=axA), fig.add_subplot(2, 2, 4, sharex=axW)) \
        if rows == 2 else (None, None)
    markers = "osD^vP*X"
    for k, (label, s) in enumerate(series.items()):
        L = array(s["height"], f"{label}: height")
        col, mk = f"C{k}", markers[k % len(markers)]
        for ax, axe, key, sign, sym, fkey in ((axA, axg, "amplitude", -1, "γ", "gamma"),
                                               (axW, axa, "width", 1, "χ", "chi")):
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
                two = np.unique(np.round(L[ok], 6)).size < 3  # a slope through two heights: no ±
                lab += f": {sym} = " + value_text(sign * expo, None if (err is None or two) else float(err))
            ax.errorbar(L, y, yerr=sem, fmt=mk, color=col, ms=5, capsize=3, label=lab)
            loc, keep = local.get((label, key), (None, None))
            if axe is not None and loc is not None and keep.any():
                e = loc["exponent_err"][keep]
                axe.errorbar(loc["height_mid"][keep], sign * loc["exponent"][keep],
                             yerr=e if np.isfinite(e).any() else None, fmt=mk + "-" if keep.sum() > 2 else mk,
                             color=col, ms=4, lw=0.8, capsize=3, label=label)
    for ax in (axA, axW):
        ax.set_xscale("log")
        ax.set_yscale("log")
        plain_log_ticks(ax)
        ax.legend(fontsize=8)
        ax.set_xlabel(L_LABEL)
    axA.set_ylabel(r"amplitude $A$ of the first peak  [$E^*\bar d^{\,2}$]")
    axW.set_ylabel(r"width $W$  [$\bar d/\sqrt{E^*/\rho}$]")
    if rows == 2:
        axg.set_ylabel(r"local $-\,d\log A/d\log L$  [1]")
        axa.set_ylabel(r"local $d\log W/d\log L$  [1]")
        for ax, key, name in ((axg, "gamma", "γ"), (axa, "chi", "χ")):
            for (tag, ref), ls in zip(refs.items(), ("--", ":")):
                if ref.get(key) is not None:
                    ax.axhline(ref[key], ls=ls, color="k", lw=1.2, zorder=5,
                               label=f"{name} = {ref[key]:.3g} (reference{tag})")
            ax.set_xlabel(L_LABEL)
            ax.legend(fontsize=8)
    axA.set_title(r"$A \propto L^{-\gamma}$: means ± standard error, line: fit", fontsize=10)
    axW.set_title(r"$W \propto L^{\chi}$: means ± standard error, line: fit", fontsize=10)
    Ls = np.concatenate([np.asarray(s["height"], float) for s in series.values()])
    counts = [int(np.sum(s["count"])) for s in series.values() if s.get("count") is not None]
    pressures = {float(s["pressure"]) for s in series.values() if s.get("pressure") is not None}
    dropped = sum(int((~ok).sum()) for _, ok in local.values())
    fig.suptitle(scene_title("amplitude and width of the front against distance",
                             scene=scene or ", ".join(series), height=Ls,
                             pressure=pressures.pop() if len(pressures) == 1 else None,
                             count=f"{sum(counts)} signals" if counts else None)
                 + (f"\n{dropped} local exponent(s) with a standard error above {MAX_LOCAL_ERROR:g} "
                    "not drawn" if dropped else ""), fontsize=10)
    return save_figure(fig, path, pdf=pdf)
