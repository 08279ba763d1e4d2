"""What every figure shares: the blank figure, the atomic save, axis labels with units.

Figures are drawn on :class:`matplotlib.figure.Figure` objects with the Agg
canvas (no pyplot state, no display needed). Sizes are fixed (no tight
bounding box), so a figure of ``size=(w, h)`` inches is ``w*DPI x h*DPI``
pixels. Axes carry the units of docs/method.md §1: lengths in d̄ (mean
diameter), forces in E* d̄², stiffnesses in E* d̄, times in d̄/sqrt(E*/ρ),
speeds in sqrt(E*/ρ), pressures in E*.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.files import atomic_file, check_writable

DPI = 100
"""Resolution of the PNG files (pixels per inch)."""

FORMATS = ("png", "pdf", "svg")

# Axis labels with units (docs/method.md §1).
L_UNIT = r"$\bar d$"
T_UNIT = r"$\bar d/\sqrt{E^*/\rho}$"
T_LABEL = r"time $t$  [$\bar d/\sqrt{E^*/\rho}$]"
F_LABEL = r"$F_{\rm sig}$  [$E^*\bar d^{\,2}$]"
C_UNIT = r"$\sqrt{E^*/\rho}$"
L_LABEL = r"source–detector distance $L$  [$\bar d$]"


def new_figure(size: tuple[float, float]):
    """A blank constrained-layout figure of ``size`` inches on the Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def output_paths(path: str | os.PathLike, pdf: bool = False) -> list[Path]:
    """The files a figure saved to ``path`` produces (the PDF twin when ``pdf``)."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise InputError(f"{path}: figure name must end in .png, .pdf or .svg")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"cannot write {path}: folder {folder} does not exist")
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder")
    out = [path]
    if pdf and fmt != "pdf":
        out.append(path.with_suffix(".pdf"))
    return out


#: Most points a drawn curve keeps (docs/figures.md): a longer series is thinned by :func:`thin`.
#: A figure is at most a few thousand pixels wide, so 20 000 points (the minimum and the
#: maximum of each of 10 000 equal bins) draw the same picture as 10^9 points, whose paths
#: would take ~16 GB of memory and as much PDF or SVG.
MAX_POINTS = 20_000


def thin_indices(y: np.ndarray, max_points: int = MAX_POINTS) -> np.ndarray | slice:
    """Indices of the points of ``y`` to draw: all up to ``max_points``; else, in order, the
    first, the last and the minimum and maximum of each of ``max_points // 2 - 1`` equal
    bins (the envelope at any zoom the figure can show)."""
    y = np.asarray(y)
    n = len(y)
    if n <= max_points:
        return slice(None)
    bins = max(1, max_points // 2 - 1)
    edges = np.linspace(0, n, bins + 1).astype(np.int64)
    keep = [np.array([0, n - 1])]
    finite = np.where(np.isfinite(y), y, 0.0)
    for lo, hi in zip(edges[:-1], edges[1:]):
        if hi > lo:
            seg = finite[lo:hi]
            keep.append(np.array([lo + int(np.argmin(seg)), lo + int(np.argmax(seg))]))
    return np.unique(np.concatenate(keep))


def thin(x, *ys, max_points: int = MAX_POINTS):
    """``x`` and every array of ``ys`` at the points :func:`thin_indices` keeps for ``ys[0]``."""
    idx = thin_indices(ys[0], max_points)
    return (np.asarray(x)[idx], *(np.asarray(y)[idx] for y in ys))


def _thin_lines(fig) -> None:
    """Thin every curve of ``fig`` longer than :data:`MAX_POINTS` (the rule of :func:`thin`)."""
    for ax in fig.get_axes():
        for line in ax.get_lines():
            x, y = line.get_xdata(orig=True), line.get_ydata(orig=True)
            if np.ndim(y) == 1 and np.size(y) > MAX_POINTS and np.size(x) == np.size(y):
                line.set_data(*thin(x, y))


def save_figure(fig, path: str | os.PathLike, *, pdf: bool = False) -> list[Path]:
    """Save ``fig`` atomically to ``path`` (and its .pdf twin); return the files. Curves
    longer than :data:`MAX_POINTS` are thinned first (:func:`thin`)."""
    paths = output_paths(path, pdf)
    for p in paths:  # every file checked before the first is written (the PDF twin too)
        check_writable(p)
    _thin_lines(fig)
    for p in paths:
        fmt = p.suffix.lower().lstrip(".")
        with atomic_file(p, suffix=f".{fmt}") as tmp:
            fig.savefig(tmp, format=fmt, dpi=DPI)
    return paths


def need(cond: bool, message: str) -> None:
    """Refuse bad input with one line (InputError)."""
    if not cond:
        raise InputError(message)


def array(x, name: str) -> np.ndarray:
    """``x`` as a non-empty float array, else a one-line InputError naming it."""
    a = np.asarray(x, dtype=float)
    need(a.ndim >= 1 and a.size > 0, f"{name}: no data to plot")
    return a


def plane_axes(dim: int) -> tuple[int, int]:
    """Columns drawn as (horizontal, vertical): x–y in 2D, x–z in 3D."""
    return (0, dim - 1)


def fmt_err(x: float | None, digits: str = ".2g") -> str:
    """" ± err" or nothing when the uncertainty is undetermined (NaN, two points)."""
    return "" if x is None or not np.isfinite(x) else f" ± {x:{digits}}"


def value_text(value, err=None, digits: int = 3) -> str:
    """A legend's number by the report's rule (granwave.report.numbers.fmt): the error to one or
    two significant digits and the value rounded to match; ``digits`` digits without an error."""
    from ..report.numbers import fmt

    return fmt(value, err, digits)


def scene_title(what: str, *, scene: str | None = None, pressure=None, height=None,
                count: str | None = None, width: int = 110) -> str:
    """A figure's title: what it shows, then its scene, p, L and n where they apply, e.g.
    "signals and their ensemble average — frictional2d, p = 1e-04, L = 25.4, n = 2 packings"."""
    parts = [scene] if scene else []
    if pressure is not None and np.isfinite(float(pressure)):
        parts.append(f"p = {float(pressure):.3g}")
    if height is not None:
        h = np.atleast_1d(np.asarray(height, float))
        h = h[np.isfinite(h)]
        if h.size:
            from ..report.numbers import fmt_bound

            lo, hi = float(h.min()), float(h.max())
            parts.append(f"L = {fmt_bound(lo, 3)}" if np.isclose(lo, hi, rtol=0.05)
                         else f"L = {fmt_bound(lo, 3)}–{fmt_bound(hi, 3)}")
    if count:
        parts.append(f"n = {count}")
    import textwrap

    return textwrap.fill(what, width) + ("\n" + textwrap.fill(", ".join(parts), width) if parts else "")


def plain_log_ticks(ax, which: str = "xy") -> None:
    """Label a log axis in one notation (matplotlib otherwise mixes 10^k with 2×10^k): over
    more than two decades the decades only, as 10^k; over fewer plain numbers (0.02, 0.05,
    0.1, 20, 50) at 1, 2 and 5 × 10^k. No minor labels."""
    from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation, LogLocator, NullFormatter

    for name in which:
        axis = ax.xaxis if name == "x" else ax.yaxis
        if axis.get_scale() != "log":
            continue
        lo, hi = sorted(ax.get_xlim() if name == "x" else ax.get_ylim())
        if lo > 0 and hi / lo > 100:
            axis.set_major_locator(LogLocator(base=10))
            axis.set_major_formatter(LogFormatterSciNotation())
        else:
            axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
            axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())
