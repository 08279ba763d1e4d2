"""Signals (docs/method.md §8–§9): several packings and their ensemble average, systems
side by side, the coherent part at several heights."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .common import F_LABEL, T_LABEL, need, new_figure, save_figure, scene_title, thin

if TYPE_CHECKING:
    from ..model import Signal


def _average(signals: Sequence[Signal]) -> dict | None:
    """The analysis's ensemble average of the signals as a dict (None for one signal)."""
    if len(signals) < 2:
        return None
    from ..analysis.ensemble import ensemble_average

    e = ensemble_average(signals)
    return {"time": e.time, "mean": e.mean, "rms": e.rms, "n": e.n_signals}


def _heights(signals) -> list[float]:
    return [float(s.attrs["height"]) for s in signals if "height" in s.attrs]


def signals_overlay(signals: Sequence[Signal], path, *, ensemble: Mapping | None = None,
                    max_traces: int = 30, pdf: bool = False, scene: str | None = None) -> list[Path]:
    """Several packings' signals overlaid, and the ensemble average ± rms band.

    ``ensemble`` is a dict with ``time``, ``mean``, ``rms`` and ``n`` (an
    ``analyze ensemble`` file); without it the average over the given signals is
    taken by the analysis (:func:`granwave.analysis.ensemble.ensemble_average`,
    the one ensemble average) when there are at least two.
    """
    need(len(signals) > 0, "no signals to plot")
    fig = new_figure((12, 4.8))
    ax = fig.add_subplot(1, 2, 1)
    for k, s in enumerate(signals[:max_traces]):
        ax.plot(s.time, s.force, lw=0.7, alpha=0.8)
    shown = min(len(signals), max_traces)
    ax.set_title(f"{shown} of {len(signals)} signals" if shown < len(signals) else
                 f"{len(signals)} signal{'s' if len(signals) != 1 else ''}")
    ax.set_xlabel(T_LABEL)
    ax.set_ylabel(F_LABEL)
    ax2 = fig.add_subplot(1, 2, 2, sharex=ax, sharey=ax)
    ens = dict(ensemble) if ensemble is not None else _average(signals)
    if ens is not None:
        t, m, r = thin(*(np.asarray(ens[k], float) for k in ("time", "mean", "rms")))
        ax2.fill_between(t, m - r, m + r, color="C1", alpha=0.3, lw=0, label="± rms")
        ax2.plot(t, m, color="C0", lw=1.2, label="mean")
        n = ens.get("n", ens.get("n_signals"))
        ax2.set_title("ensemble average" + (f" over {int(n)} packing{'s' if int(n) != 1 else ''}"
                                            if n is not None else ""))
        ax2.legend()
    else:  # one signal: no average, so no second panel
        fig.delaxes(ax2)
        ax2 = None
    if ax2 is not None:
        ax2.set_xlabel(T_LABEL)
        ax2.set_ylabel(F_LABEL)
    n = len(signals)
    fig.suptitle(scene_title("signals of several packings and their ensemble average", scene=scene,
                             pressure=signals[0].attrs.get("pressure"), height=_heights(signals),
                             count=f"{n} packing{'s' if n != 1 else ''}"))
    return save_figure(fig, path, pdf=pdf)


def signal_label(signal: Signal) -> str:
    """A short label from a signal's attributes (dimension, friction, kind)."""
    a = signal.attrs
    parts = []
    if "dim" in a:
        parts.append(f"{int(a['dim'])}D")
    if "friction" in a:
        parts.append("frictionless" if float(a["friction"]) == 0 else f"μ = {float(a['friction']):g}")
    if "kind" in a and str(a["kind"]) not in ("none", ""):
        parts.append(str(a["kind"]))
    if "pressure" in a:
        parts.append(f"p = {float(a['pressure']):.3g}")
    return ", ".join(parts) or str(a.get("method", "signal"))


def signal_comparison(signals: Sequence[Signal], path, *, labels: Sequence[str] | None = None,
                      speeds: Sequence[float | None] | None = None,
                      pdf: bool = False, scene: str | None = None) -> list[Path]:
    """Frictional 2D, frictionless 2D and 3D signals (any list) in one panel.

    Containers of different heights arrive at different times, so every label
    gives its source–detector distance L, and time is divided by L: with a speed c for
    every signal (e.g. its c_ℓ) the axis is t c / L, so that a front travelling at c sits
    at 1; without, t/L (the inverse of the speed at which a feature arrived). Every record is
    cut to the shortest one's range of that axis, so that none runs on alone. Forces are
    normalized by each signal's largest |F| before the cut.
    """
    need(len(signals) > 0, "no signals to compare")
    labels = list(labels) if labels is not None else [signal_label(s) for s in signals]
    speeds = list(speeds) if speeds is not None else [None] * len(signals)
    need(len(labels) == len(signals) and len(speeds) == len(signals),
          "give one label and one speed per signal")
    scaled = [c is not None for c in speeds]
    need(all(scaled) or not any(scaled), "give a speed for every signal or for none")
    fig = new_figure((8, 5))
    ax = fig.add_subplot(1, 1, 1)
    curves = []
    for s, lab, c in zip(signals, labels, speeds):
        f = np.asarray(s.force, float)
        peak = np.max(np.abs(f)) or 1.0
        lab = with_height(lab, s)
        if c is not None:
            need(c > 0, "speeds must be positive")
            x = np.asarray(s.time, float) * c / s.height
            lab = f"{lab} (c = {c:.3g})"
        else:
            x = np.asarray(s.time, float) / s.height
        curves.append((x, f / peak, lab))
    end = min(float(x[-1]) for x, _, _ in curves)  # the shortest record's end: no one runs on alone
    for x, y, lab in curves:
        keep = x <= end
        ax.plot(x[keep], y[keep], lw=1.2, label=lab)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlabel(r"$t\,c/L$  [1]" if scaled[0] else r"$t/L$  [$1/\sqrt{E^*/\rho}$]")
    ax.set_ylabel(r"$F_{\rm sig}/\max|F_{\rm sig}|$  [1]")
    ax.legend()
    ax.set_title(scene_title("signals of different systems, time over distance", scene=scene,
                             pressure=signals[0].attrs.get("pressure"), height=_heights(signals),
                             count="one packing each", width=90), fontsize=9)
    return save_figure(fig, path, pdf=pdf)


def with_height(label: str, signal: Signal) -> str:
    """``label`` with the signal's source–detector distance L (d̄)."""
    return f"{label}, L = {signal.height:.3g}"


def coherent_heights(series: Sequence[Mapping], path, *, pdf: bool = False,
                     scene: str | None = None, pressure=None) -> list[Path]:
    """The coherent (ensemble-averaged) signal at several heights.

    ``series``: dicts with ``height``, ``time``, ``mean`` and optionally ``rms``
    and ``n``. Left: raw; right: time divided by the height and force
    normalized by its peak, to show the broadening of the front.
    """
    need(len(series) > 0, "no coherent signals to plot")
    series = sorted(series, key=lambda s: float(s["height"]))
    fig = new_figure((12, 4.8))
    ax1, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    import matplotlib as mpl
    cmap = mpl.colormaps["viridis"]
    for k, s in enumerate(series):
        col = cmap(k / max(len(series) - 1, 1))
        t, m = np.asarray(s["time"], float), np.asarray(s["mean"], float)
        r = None if s.get("rms") is None else np.asarray(s["rms"], float)
        t, m, r = thin(t, m, r) if r is not None else (*thin(t, m), None)
        L = float(s["height"])
        lab = f"L = {L:.3g}" + (f" ({int(s['n'])} packings)" if s.get("n") is not None else "")
        ax1.plot(t, m, color=col, lw=1.1, label=lab)
        if r is not None:
            ax1.fill_between(t, m - r, m + r, color=col, alpha=0.12, lw=0)
        peak = np.max(np.abs(m)) or 1.0
        ax2.plot(t / L, m / peak, color=col, lw=1.1, label=lab)
    ax1.set_xlabel(T_LABEL)
    ax1.set_ylabel(r"$\langle F_{\rm sig}\rangle$  [$E^*\bar d^{\,2}$]")
    ax1.set_title("coherent part (ensemble average, band ± rms)")
    ax2.set_xlabel(r"$t/L$  [$1/\sqrt{E^*/\rho}$]")
    ax2.set_ylabel(r"$\langle F_{\rm sig}\rangle/\max|\langle F_{\rm sig}\rangle|$  [1]")
    ax2.set_title("scaled by height and peak")
    ax1.legend(fontsize=8)
    if pressure is None:
        pressure = next((s.get("attrs", {}).get("pressure") for s in series
                         if isinstance(s.get("attrs"), Mapping) and s["attrs"].get("pressure") is not None), None)
    counts = sorted({int(s["n"]) for s in series if s.get("n") is not None})
    fig.suptitle(scene_title("the coherent part of the signal at several heights", scene=scene,
                             pressure=pressure, height=[float(s["height"]) for s in series],
                             count=("–".join(map(str, counts[::max(len(counts) - 1, 1)])) + " packings per height")
                             if counts else None))
    return save_figure(fig, path, pdf=pdf)

