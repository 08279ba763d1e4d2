"""The damping series (docs/method.md §11): one packing kicked in the nonlinear DEM."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .common import T_LABEL, need, new_figure, save_figure, scene_title

if TYPE_CHECKING:
    from ..model import Signal

#: The DEM signal over the kick's scale s has the linear model's units (force per unit kick).
DEM_F_LABEL = r"$\Delta F_{\rm top}/s$  [$E^*\bar d^{\,2}$]"


def _reference_label(reference: Signal) -> str:
    """Name the dashed curve: the linear model (its method) of the same packing."""
    method = str(reference.attrs.get("method", ""))
    if method == "dem":
        return f"DEM, ζ = {float(reference.attrs.get('damping', 0)):g} (reference)"
    return "linear model" + (f" ({method})" if method and method != "none" else "") + ", same packing"


def damping_series(signals: Sequence[Signal], path, *, reference: Signal | None = None,
                   labels: Sequence[str] | None = None, pdf: bool = False,
                   scene: str | None = None) -> list[Path]:
    """Signals of one packing for several contact dampings ζ, side by side.

    Each signal needs ``attrs['damping']``; panels are ordered by ζ and share
    the axes. ``reference`` (the linear model of the same packing) is drawn
    dashed in each panel and named in the legend. The DEM signals are
    F_sig / s, s the kick's scale (docs/damping.md), which is the linear
    model's normalization: the y axis says so. ``labels`` name the signals
    (file names) in error messages.
    """
    need(len(signals) > 0, "no signals to plot")
    labels = list(labels) if labels is not None else [f"signal {k}" for k in range(len(signals))]
    missing = [lab for lab, s in zip(labels, signals) if "damping" not in s.attrs]
    need(not missing, f"{missing[0] if missing else ''}: no 'damping' attribute (not a "
                      "`propagate --method dem` signal)")
    order = sorted(signals, key=lambda s: float(s.attrs["damping"]))
    n = len(order)
    nrow = math.ceil(n / 5)          # up to five panels a row, rows as even as they go:
    ncol = math.ceil(n / nrow)       # no empty slot beyond the last row's remainder
    fig = new_figure((3.6 * ncol + 0.5, 3.2 * nrow + 0.4))
    first = None
    for k, s in enumerate(order):
        ax = fig.add_subplot(nrow, ncol, k + 1, sharex=first, sharey=first)
        first = first or ax
        if reference is not None:
            ax.plot(reference.time, reference.force, "--", color="0.4", lw=0.9,
                    label=_reference_label(reference))
        ax.plot(s.time, s.force, color="C0", lw=1, label="nonlinear DEM")
        ax.set_title(f"ζ = {float(s.attrs['damping']):g}")
        ax.set_xlabel(T_LABEL)
        if k % ncol == 0:
            ax.set_ylabel(DEM_F_LABEL)
        else:  # the shared scale: its numbers once a row
            ax.tick_params(labelleft=False)
        if k == 0:
            ax.legend(fontsize=8)
    a = order[0].attrs
    amp, scale = a.get("amplitude"), a.get("scale")
    kick = (f"one kick amplitude: largest single-contact excursion {float(amp):g} mean overlaps"
            if amp is not None else "one kick amplitude")
    fig.suptitle(scene_title("nonlinear DEM kicks for several contact dampings ζ", scene=scene,
                             pressure=a.get("pressure"), height=a.get("height"), count="one packing")
                 + f"\n{kick}" + (f" (s = {float(scale):.3g})" if scale is not None else "")
                 + r"; the DEM signal over $s$ has the linear model's normalization (dashed)",
                 fontsize=9)
    return save_figure(fig, path, pdf=pdf)

