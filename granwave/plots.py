"""The study's figures (issue "Analysis" §6): one function per figure.

Every function takes data objects (:class:`~granwave.model.Packing`,
:class:`~granwave.model.Signal`, :class:`~granwave.model.Modes`, plain dicts
and arrays) and an output path, draws one figure and saves it atomically
(temporary file in the same folder, then rename) as PNG — plus a PDF beside
it when ``pdf=True``. They return the list of files written.

Figures are drawn on :class:`matplotlib.figure.Figure` objects with the Agg
canvas (no pyplot state, no display needed). Sizes are fixed (no tight
bounding box), so a figure of ``size=(w, h)`` inches is ``w*DPI x h*DPI``
pixels. Axes carry the units of SPEC §1: lengths in d̄ (mean diameter),
forces in E* d̄², stiffnesses in E* d̄, times in d̄/sqrt(E*/ρ), speeds in
sqrt(E*/ρ), pressures in E*.

Choices made here (see docs/figures.md):
- networks and roses use grain–grain contacts only unless ``walls=True``
  (the wall contacts are drawn in the networks as segments to the wall);
- a contact between periodic images is drawn as two half-visible segments:
  from each grain towards the nearest image of the other, clipped by the box;
- "strong" contacts carry a normal force above the mean normal force of the
  contacts shown, "weak" ones the rest (SPEC §4);
- effective exponents are finite differences of log A and log W between
  neighbouring heights, placed at the geometric mean of the two heights.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .analysis.fits import inverse_slope, linear_fit, local_exponents, power_law_fit
from .errors import InputError

if TYPE_CHECKING:  # annotations only: importing granwave.model first hits the model <-> io cycle
    from .model import Modes, Packing, Signal

DPI = 100
"""Resolution of the PNG files (pixels per inch)."""

FORMATS = ("png", "pdf", "svg")

# Axis labels with units (SPEC §1).
L_UNIT = r"$\bar d$"
T_LABEL = r"time $t$  [$\bar d/\sqrt{E^*/\rho}$]"
F_LABEL = r"$F_{\rm sig}$  [$E^*\bar d^{\,2}$]"
C_UNIT = r"$\sqrt{E^*/\rho}$"
L_LABEL = r"source–detector distance $L$  [$\bar d$]"


# ====================================================================== saving
def _new_figure(size: tuple[float, float]):
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


def save_figure(fig, path: str | os.PathLike, *, pdf: bool = False) -> list[Path]:
    """Save ``fig`` atomically to ``path`` (and its .pdf twin); return the files."""
    paths = output_paths(path, pdf)
    for p in paths:
        fmt = p.suffix.lower().lstrip(".")
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=f".{fmt}.tmp", dir=p.parent)
        os.close(fd)
        try:
            fig.savefig(tmp, format=fmt, dpi=DPI)
            os.replace(tmp, p)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
    return paths


# ====================================================================== helpers
def _need(cond: bool, message: str) -> None:
    if not cond:
        raise InputError(message)


def _array(x, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    _need(a.ndim >= 1 and a.size > 0, f"{name}: no data to plot")
    return a


def _plane_axes(dim: int) -> tuple[int, int]:
    """Columns drawn as (horizontal, vertical): x–y in 2D, x–z in 3D."""
    return (0, dim - 1)


def _branch_vectors(packing: Packing) -> np.ndarray:
    """Centre of i to centre of j (nearest periodic image), or to the wall contact point."""
    c = packing.contacts
    pos = packing.position
    d = np.zeros((len(c), packing.dim))
    grain = ~c.is_wall
    if grain.any():
        d[grain] = pos[c.j[grain]] - pos[c.i[grain]]
        per = np.asarray(packing.box[:-1], float)
        d[grain, :-1] -= per * np.round(d[grain, :-1] / per)
    wall = c.is_wall
    if wall.any():
        reach = packing.radius[c.i[wall]] - c.overlap[wall]
        d[wall] = c.normal[wall] * reach[:, None]
    return d


def contact_segments(packing: Packing, *, walls: bool = True):
    """Segments (K, 2, 2) of the drawn plane and the contact index of each.

    A grain–grain contact whose nearest image crosses a periodic boundary gives
    two segments (from i towards the image of j, from j towards the image of i);
    the part outside the box is cut by the axes limits.
    """
    c = packing.contacts
    ax0, ax1 = _plane_axes(packing.dim)
    pos = packing.position[:, [ax0, ax1]]
    d = _branch_vectors(packing)[:, [ax0, ax1]]
    keep = np.ones(len(c), bool) if walls else ~c.is_wall
    idx = np.flatnonzero(keep)
    start = pos[c.i[idx]]
    segs = [np.stack([start, start + d[idx]], axis=1)]
    owners = [idx]
    grain = idx[~c.is_wall[idx]]
    if grain.size:
        straight = packing.position[c.j[grain]] - packing.position[c.i[grain]]
        wrapped = np.any(np.abs(straight - _branch_vectors(packing)[grain]) > 1e-9, axis=1)
        g = grain[wrapped]
        if g.size:
            s2 = pos[c.j[g]]
            segs.append(np.stack([s2, s2 - d[g]], axis=1))
            owners.append(g)
    return np.concatenate(segs), np.concatenate(owners)


def _draw_grains(ax, packing: Packing, *, color="0.85", rattler_color=None) -> None:
    from matplotlib.collections import EllipseCollection

    ax0, ax1 = _plane_axes(packing.dim)
    xy = packing.position[:, [ax0, ax1]]
    diam = 2 * np.asarray(packing.radius, float)
    colors = np.array([color] * packing.n_grains, dtype=object)
    if rattler_color is not None:
        carrying = np.zeros(packing.n_grains, bool)
        carrying[packing.contacts.i] = True
        cj = packing.contacts.j
        carrying[cj[cj >= 0]] = True
        colors[~carrying] = rattler_color
    ax.add_collection(EllipseCollection(diam, diam, np.zeros_like(diam), units="xy", offsets=xy,
                                        offset_transform=ax.transData, facecolors=list(colors),
                                        edgecolors="none", zorder=0))


def _box_axes(ax, packing: Packing, title: str) -> None:
    ax0, ax1 = _plane_axes(packing.dim)
    ax.set_xlim(0, packing.box[ax0])
    ax.set_ylim(0, packing.box[ax1])
    ax.set_aspect("equal")
    ax.set_xlabel(f"x  [{L_UNIT}]")
    ax.set_ylabel(f"{'yz'[packing.dim - 2]}  [{L_UNIT}]")
    ax.set_title(title)


def _network(ax, packing: Packing, weight: np.ndarray, color: str, title: str,
             max_width: float) -> None:
    from matplotlib.collections import LineCollection

    _draw_grains(ax, packing, rattler_color="0.95")
    segs, owner = contact_segments(packing, walls=True)
    w = np.asarray(weight, float)[owner]
    scale = np.max(w) if w.size and np.max(w) > 0 else 1.0
    ax.add_collection(LineCollection(segs, linewidths=max_width * w / scale, colors=color,
                                     capstyle="round", zorder=2))
    _box_axes(ax, packing, title)


def _weights(c, walls: bool):
    keep = np.ones(len(c), bool) if walls else ~c.is_wall
    return keep


# ====================================================================== statics
def force_network(packing: Packing, path, *, pdf: bool = False, walls: bool = False,
                  bins: int = 40, max_width: float = 4.0) -> list[Path]:
    """Force network beside stiffness network, and their histograms (SPEC §4).

    Line widths are proportional to the normal force (left) and the normal
    stiffness k_n (right), each relative to its maximum. The histograms show
    F/⟨F⟩ and k_n/⟨k_n⟩ as probability densities (same area, 1), on linear and
    logarithmic axes; ``walls`` adds the wall contacts to the histograms.
    """
    c = packing.contacts
    _need(len(c) > 0, "packing has no force-carrying contacts")
    fig = _new_figure((12, 10))
    gs = fig.add_gridspec(2, 2, height_ratios=[1.6, 1])
    p = packing.attrs.get("pressure")
    ptxt = f" (p = {float(p):.3g} E*)" if p is not None else ""
    _network(fig.add_subplot(gs[0, 0]), packing, c.force_normal, "C3",
             f"force network{ptxt}: width ∝ $F_n$", max_width)
    _network(fig.add_subplot(gs[0, 1]), packing, c.stiffness_normal, "C0",
             r"stiffness network: width ∝ $k_n$", max_width)
    keep = _weights(c, walls)
    f = c.force_normal[keep]
    k = c.stiffness_normal[keep]
    _need(f.size > 0 and f.mean() > 0, "no grain-grain contacts to histogram")
    fr, kr = f / f.mean(), k / k.mean()
    edges = np.linspace(0, max(fr.max(), kr.max()) * 1.0001, bins + 1)
    for j, log in enumerate((False, True)):
        ax = fig.add_subplot(gs[1, j])
        ax.hist(fr, bins=edges, density=True, histtype="step", lw=1.5, color="C3",
                label=r"$F_n/\langle F_n\rangle$")
        ax.hist(kr, bins=edges, density=True, histtype="step", lw=1.5, color="C0",
                label=r"$k_n/\langle k_n\rangle$")
        ax.set_xlabel(r"$F_n/\langle F_n\rangle$,  $k_n/\langle k_n\rangle$")
        ax.set_ylabel("probability density")
        if log:
            ax.set_yscale("log")
        ax.legend(title=f"{f.size} contacts")
    return save_figure(fig, path, pdf=pdf)


def contact_angles(packing: Packing, *, walls: bool = False):
    """Contact-normal angles in the drawn plane and the strong-contact mask."""
    c = packing.contacts
    keep = _weights(c, walls)
    ax0, ax1 = _plane_axes(packing.dim)
    n = c.normal[keep]
    f = c.force_normal[keep]
    theta = np.arctan2(n[:, ax1], n[:, ax0])
    return theta, f > f.mean()


def contact_roses(packing: Packing, path, *, pdf: bool = False, walls: bool = False,
                  bins: int = 36) -> list[Path]:
    """Polar histograms of contact directions: all, strong (F > ⟨F⟩) and weak contacts.

    Each contact counts with n and −n (the rose is centrally symmetric); radii
    are probability densities per radian (isotropic value 1/2π). In 3D the
    angle is that of the normal's projection on the x–z plane.
    """
    _need(len(packing.contacts) > 0, "packing has no force-carrying contacts")
    theta, strong = contact_angles(packing, walls=walls)
    _need(theta.size > 0, "no grain-grain contacts to histogram")
    fig = _new_figure((13, 4.8))
    edges = np.linspace(-np.pi, np.pi, bins + 1)
    width = edges[1] - edges[0]
    sets = [("all contacts", np.ones_like(strong)), ("strong: $F_n>\\langle F_n\\rangle$", strong),
            ("weak: $F_n\\leq\\langle F_n\\rangle$", ~strong)]
    for k, (title, mask) in enumerate(sets):
        ax = fig.add_subplot(1, 3, k + 1, projection="polar")
        t = theta[mask]
        both = np.concatenate([t, np.angle(np.exp(1j * (t + np.pi)))])
        h, _ = np.histogram(both, bins=edges, density=True) if both.size else (np.zeros(bins), None)
        ax.bar(edges[:-1] + width / 2, h, width=width, color=f"C{k}", alpha=0.75, edgecolor="k",
               lw=0.3)
        ax.plot(np.linspace(0, 2 * np.pi, 200), np.full(200, 1 / (2 * np.pi)), "k--", lw=0.8)
        if t.size:
            F2 = np.mean(np.sin(t) ** 2)
            title += f"\n{t.size} contacts, $\\langle n_y^2\\rangle$ = {F2:.3f}"
        ax.set_title(title, fontsize=10)
    fig.suptitle("contact directions (density per radian; dashed: isotropic 1/2π; "
                 "angle from the horizontal axis)")
    return save_figure(fig, path, pdf=pdf)


# ====================================================================== fields
def _field(dof_grain, dof_axis, values, n_grains: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Translational field (N, dim) from a dof vector, and which grains have dofs."""
    dof_grain = np.asarray(dof_grain, int)
    dof_axis = np.asarray(dof_axis, int)
    u = np.zeros((n_grains, dim))
    trans = dof_axis < dim
    _need(np.all(dof_grain < n_grains), "dof map refers to grains beyond the positions given")
    u[dof_grain[trans], dof_axis[trans]] = np.asarray(values)[trans]
    has = np.zeros(n_grains, bool)
    has[dof_grain] = True
    return u, has


def _arrows(ax, position, u, has, dim, box=None, radius=None, title=""):
    ax0, ax1 = _plane_axes(dim)
    xy = position[:, [ax0, ax1]]
    uv = u[:, [ax0, ax1]]
    if radius is not None:
        from matplotlib.collections import EllipseCollection
        d = 2 * np.asarray(radius, float)
        ax.add_collection(EllipseCollection(d, d, np.zeros_like(d), units="xy", offsets=xy,
                                            offset_transform=ax.transData, facecolors="0.9",
                                            edgecolors="0.75", linewidths=0.3, zorder=0))
    mag = np.hypot(uv[:, 0], uv[:, 1])
    scale = mag[has].max() if has.any() and mag[has].max() > 0 else 1.0
    q = ax.quiver(xy[has, 0], xy[has, 1], uv[has, 0] / scale, uv[has, 1] / scale, mag[has] / scale,
                  cmap="viridis", angles="xy", scale_units="xy", scale=0.8, width=0.004,
                  pivot="tail", zorder=2)
    ax.set_aspect("equal")
    if box is not None:
        ax.set_xlim(0, box[ax0])
        ax.set_ylim(0, box[ax1])
    else:
        ax.autoscale_view()
    ax.set_xlabel(f"x  [{L_UNIT}]")
    ax.set_ylabel(f"{'yz'[dim - 2]}  [{L_UNIT}]")
    ax.set_title(title + f"\nlongest arrow = {scale:.3g} " + L_UNIT, fontsize=10)
    return q


def displacement_snapshot(signal: Signal, path, *, packing: Packing | None = None,
                          index: Sequence[int] | None = None, pdf: bool = False) -> list[Path]:
    """Displacement-field snapshots of a signal file as arrows (translational dofs).

    Positions come from the signal's ``snapshots/position`` or else from
    ``packing``. Each panel is scaled to its largest displacement (stated in the
    title); colour is the magnitude relative to it. ``index`` chooses the
    snapshots (default: up to four, evenly spread).
    """
    _need(signal.snapshot_time is not None and signal.snapshot_displacement is not None,
          "signal has no snapshots (rerun propagate with snapshot times)")
    position = signal.position if signal.position is not None else (
        packing.position if packing is not None else None)
    _need(position is not None, "no grain positions: the signal stores none, give the packing")
    position = np.asarray(position, float)
    disp = np.atleast_2d(np.asarray(signal.snapshot_displacement, float))
    S = disp.shape[0]
    if index is None:
        index = sorted(set(np.linspace(0, S - 1, min(S, 4)).round().astype(int).tolist()))
    index = list(index)
    _need(all(-S <= i < S for i in index), f"snapshot index out of range (the file has {S})")
    dim = position.shape[1]
    box = packing.box if packing is not None else None
    radius = packing.radius if packing is not None else None
    ncol = len(index)
    fig = _new_figure((4.2 * ncol + 0.8, 5.5))
    for k, i in enumerate(index):
        ax = fig.add_subplot(1, ncol, k + 1)
        u, has = _field(signal.dof_grain, signal.dof_axis, disp[i], position.shape[0], dim)
        q = _arrows(ax, position, u, has, dim, box, radius,
                    title=f"t = {float(signal.snapshot_time[i]):.4g} " + r"$\bar d/\sqrt{E^*/\rho}$")
    fig.colorbar(q, ax=fig.axes, label=r"$|u|/|u|_{\max}$", shrink=0.8)
    return save_figure(fig, path, pdf=pdf)


def mode_shapes(vectors: np.ndarray, dof_grain, dof_axis, position, path, *,
                omega: Sequence[float] | None = None, labels: Sequence[str] | None = None,
                radius=None, box=None, pdf: bool = False) -> list[Path]:
    """Selected eigenmodes as displacement arrows (translational part).

    ``vectors`` has one mode per column (n_dof, K); ``dof_grain``/``dof_axis``
    come from the linear file, ``position`` (N, dim) from the packing.
    """
    vectors = np.asarray(vectors, float)
    if vectors.ndim == 1:
        vectors = vectors[:, None]
    _need(vectors.shape[0] == len(dof_grain), "mode vectors and dof map differ in length")
    position = np.asarray(position, float)
    K = vectors.shape[1]
    _need(K > 0, "no modes to draw")
    dim = position.shape[1]
    fig = _new_figure((4.2 * K + 0.8, 5.5))
    for k in range(K):
        ax = fig.add_subplot(1, K, k + 1)
        u, has = _field(dof_grain, dof_axis, vectors[:, k], position.shape[0], dim)
        title = labels[k] if labels is not None else f"mode {k}"
        if omega is not None:
            title += f", ω = {float(omega[k]):.4g} " + r"$\sqrt{E^*/\rho}/\bar d$"
        q = _arrows(ax, position, u, has, dim, box, radius, title=title)
    fig.colorbar(q, ax=fig.axes, label=r"$|\phi|/|\phi|_{\max}$", shrink=0.8)
    return save_figure(fig, path, pdf=pdf)


def select_modes(modes: Modes, *, dof_grain=None, dof_axis=None, dim: int | None = None,
                 ic: str = "A", zero_tol: float = 1e-9) -> dict[str, int]:
    """Lowest nonzero mode, the mode contributing most (|a_n b_n|) and the most
    localized one (smallest participation ratio over grains,
    :func:`granwave.analysis.spectrum.participation_ratio`; needs the vectors)."""
    omega2 = np.asarray(modes.omega2, float)
    nz = np.flatnonzero(omega2 > zero_tol * max(omega2.max(), 1e-300))
    _need(nz.size > 0, "no nonzero modes")
    a = modes.amplitude_A if ic == "A" else modes.amplitude_B
    contrib = np.abs(np.asarray(a) * np.asarray(modes.coupling))
    out = {"lowest nonzero": int(nz[0]), "strongest |a_n b_n|": int(nz[np.argmax(contrib[nz])])}
    if modes.vectors is not None and dof_grain is not None:
        from .analysis.spectrum import participation_ratio

        pr = participation_ratio(np.asarray(modes.vectors)[:, nz], dof_grain=dof_grain,
                                 dof_axis=dof_axis, dim=dim)
        out["most localized"] = int(nz[np.nanargmin(pr)])
    return out


# ====================================================================== signals
def _common_grid(signals: Sequence[Signal]):
    t0 = np.asarray(signals[0].time)
    for s in signals[1:]:
        if len(s.time) != len(t0) or not np.allclose(s.time, t0):
            return None
    return t0


def ensemble_stats(signals: Sequence[Signal]) -> dict | None:
    """Mean and rms deviation over signals on a common time grid (else None)."""
    t = _common_grid(signals)
    if t is None or len(signals) < 2:
        return None
    F = np.stack([np.asarray(s.force, float) for s in signals])
    return {"time": t, "mean": F.mean(0), "rms": F.std(0), "n": len(signals)}


def signals_overlay(signals: Sequence[Signal], path, *, ensemble: Mapping | None = None,
                    max_traces: int = 30, pdf: bool = False) -> list[Path]:
    """Several packings' signals overlaid, and the ensemble average ± rms band.

    ``ensemble`` is a dict with ``time``, ``mean``, ``rms`` (an ensemble file);
    without it the average is taken over the given signals when they share a
    time grid.
    """
    _need(len(signals) > 0, "no signals to plot")
    fig = _new_figure((12, 4.8))
    ax = fig.add_subplot(1, 2, 1)
    for k, s in enumerate(signals[:max_traces]):
        ax.plot(s.time, s.force, lw=0.7, alpha=0.8)
    shown = min(len(signals), max_traces)
    ax.set_title(f"{shown} of {len(signals)} signals" if shown < len(signals) else
                 f"{len(signals)} signals")
    ax.set_xlabel(T_LABEL)
    ax.set_ylabel(F_LABEL)
    ax2 = fig.add_subplot(1, 2, 2, sharex=ax, sharey=ax)
    ens = dict(ensemble) if ensemble is not None else ensemble_stats(signals)
    if ens is not None:
        t, m, r = (np.asarray(ens[k], float) for k in ("time", "mean", "rms"))
        ax2.fill_between(t, m - r, m + r, color="C1", alpha=0.3, lw=0, label="± rms")
        ax2.plot(t, m, color="C0", lw=1.2, label="mean")
        n = ens.get("n", ens.get("n_signals"))
        ax2.set_title("ensemble average" + (f" over {int(n)} packings" if n is not None else ""))
        ax2.legend()
    else:
        ax2.text(0.5, 0.5, "no common time grid: no average", ha="center", transform=ax2.transAxes)
    ax2.set_xlabel(T_LABEL)
    ax2.set_ylabel(F_LABEL)
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
                      pdf: bool = False) -> list[Path]:
    """Frictional 2D, frictionless 2D and 3D signals (any list) in one panel.

    With a speed c for a signal its time axis is t c / L (L its height), so
    that fronts arriving at the expected time sit at 1; without, raw time.
    Forces are normalized by each signal's largest |F|.
    """
    _need(len(signals) > 0, "no signals to compare")
    labels = list(labels) if labels is not None else [signal_label(s) for s in signals]
    speeds = list(speeds) if speeds is not None else [None] * len(signals)
    _need(len(labels) == len(signals) and len(speeds) == len(signals),
          "give one label and one speed per signal")
    scaled = [c is not None for c in speeds]
    _need(all(scaled) or not any(scaled), "give a speed for every signal or for none")
    fig = _new_figure((8, 5))
    ax = fig.add_subplot(1, 1, 1)
    for s, lab, c in zip(signals, labels, speeds):
        f = np.asarray(s.force, float)
        peak = np.max(np.abs(f)) or 1.0
        t = np.asarray(s.time, float)
        if c is not None:
            _need(c > 0, "speeds must be positive")
            t = t * c / s.height
            lab = f"{lab} (c = {c:.3g})"
        ax.plot(t, f / peak, lw=1.2, label=lab)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlabel(r"$t\,c/L$" if scaled[0] else T_LABEL)
    ax.set_ylabel(r"$F_{\rm sig}/\max|F_{\rm sig}|$")
    ax.legend()
    ax.set_title("signals of different systems")
    return save_figure(fig, path, pdf=pdf)


def coherent_heights(series: Sequence[Mapping], path, *, pdf: bool = False) -> list[Path]:
    """The coherent (ensemble-averaged) signal at several heights.

    ``series``: dicts with ``height``, ``time``, ``mean`` and optionally ``rms``
    and ``n``. Left: raw; right: time divided by the height and force
    normalized by its peak, to show the broadening of the front.
    """
    _need(len(series) > 0, "no coherent signals to plot")
    series = sorted(series, key=lambda s: float(s["height"]))
    fig = _new_figure((12, 4.8))
    ax1, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    import matplotlib as mpl
    cmap = mpl.colormaps["viridis"]
    for k, s in enumerate(series):
        col = cmap(k / max(len(series) - 1, 1))
        t, m = np.asarray(s["time"], float), np.asarray(s["mean"], float)
        L = float(s["height"])
        lab = f"L = {L:.3g}" + (f" ({int(s['n'])} packings)" if s.get("n") is not None else "")
        ax1.plot(t, m, color=col, lw=1.1, label=lab)
        if s.get("rms") is not None:
            r = np.asarray(s["rms"], float)
            ax1.fill_between(t, m - r, m + r, color=col, alpha=0.12, lw=0)
        peak = np.max(np.abs(m)) or 1.0
        ax2.plot(t / L, m / peak, color=col, lw=1.1, label=lab)
    ax1.set_xlabel(T_LABEL)
    ax1.set_ylabel(r"$\langle F_{\rm sig}\rangle$  [$E^*\bar d^{\,2}$]")
    ax1.set_title("coherent part (ensemble average, band ± rms)")
    ax2.set_xlabel(r"$t/L$  [$1/\sqrt{E^*/\rho}$]")
    ax2.set_ylabel(r"$\langle F_{\rm sig}\rangle/\max|\langle F_{\rm sig}\rangle|$")
    ax2.set_title("scaled by height and peak")
    ax1.legend(fontsize=8)
    return save_figure(fig, path, pdf=pdf)


# ====================================================================== fronts
ARRIVAL_POINTS = (("t_lead10", "10% leading edge", "c_tof"), ("t_peak", "first peak", "c_peak"),
                  ("t_zero", "zero crossing", "c_zero"))


def effective_exponents(L, y) -> tuple[np.ndarray, np.ndarray]:
    """d log|y| / d log L between neighbouring distinct heights, at their geometric means.

    Several samples at one height are averaged first (mean of |y|).
    """
    L, y = np.asarray(L, float), np.abs(np.asarray(y, float))
    ok = (L > 0) & (y > 0) & np.isfinite(y)
    Lu, inv = np.unique(L[ok], return_inverse=True)
    if Lu.size < 2:
        return np.zeros(0), np.zeros(0)
    ym = np.bincount(inv, weights=y[ok]) / np.bincount(inv)
    return local_exponents(Lu, ym)


def _fmt_err(x: float, digits: str = ".2g") -> str:
    """" ± err" or nothing when the uncertainty is undetermined (NaN, two points)."""
    return "" if x is None or not np.isfinite(x) else f" ± {x:{digits}}"


def arrival_times(data: Mapping, path, *, pdf: bool = False) -> list[Path]:
    """Arrival times of the 10% edge, the first peak and the zero crossing against L.

    ``data``: ``height`` (array) and ``t_lead10``, ``t_peak``, ``t_zero`` arrays
    (missing ones are skipped); lines are least-squares fits t = t0 + L/c, the
    speeds 1/slope given in the legend.
    """
    L = _array(data["height"], "height")
    fig = _new_figure((8, 5.5))
    ax = fig.add_subplot(1, 1, 1)
    drawn = 0
    for k, (key, name, _) in enumerate(ARRIVAL_POINTS):
        if data.get(key) is None:
            continue
        t = np.asarray(data[key], float)
        ax.plot(L, t, "o", color=f"C{k}", ms=5)
        lab = name
        if np.sum(np.isfinite(t)) >= 2:
            ok = np.isfinite(t)
            fit = linear_fit(L[ok], t[ok], what=f"{key} against height")
            Lx = np.linspace(0, L.max() * 1.05, 50)
            c, dc = inverse_slope(fit)
            lab += f": c = {c:.4g}" + _fmt_err(dc)
            ax.plot(Lx, fit.intercept + fit.slope * Lx, "-", color=f"C{k}", lw=1)
        ax.plot([], [], "o-", color=f"C{k}", label=lab)
        drawn += 1
    _need(drawn > 0, "no arrival times (t_lead10, t_peak, t_zero) in the data")
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
    """A(L) and W(L) on log–log axes with their effective exponents, several series.

    ``series``: label -> dict with ``height``, ``amplitude``, ``width`` arrays
    (any lengths ≥ 1; fits need 2). ``references``: exponents drawn as dashed
    lines in the lower panels (default: the chain's γ = 2/3 and α = 1/3).
    """
    _need(len(series) > 0, "no series to plot")
    ref = {"gamma": 2 / 3, "alpha": 1 / 3} if references is None else dict(references)
    fig = _new_figure((12, 8.5))
    axA, axW = fig.add_subplot(2, 2, 1), fig.add_subplot(2, 2, 2)
    axg, axa = fig.add_subplot(2, 2, 3, sharex=axA), fig.add_subplot(2, 2, 4, sharex=axW)
    markers = "osD^vP*X"
    for k, (label, s) in enumerate(series.items()):
        L = _array(s["height"], f"{label}: height")
        col, mk = f"C{k}", markers[k % len(markers)]
        for ax, axe, key, sign, sym in ((axA, axg, "amplitude", -1, "γ"),
                                         (axW, axa, "width", 1, "α")):
            if s.get(key) is None:
                continue
            y = np.abs(np.asarray(s[key], float))
            lab = label
            ok = (L > 0) & (y > 0) & np.isfinite(y)
            if np.unique(L[ok]).size >= 2:
                fit = power_law_fit(L[ok], y[ok], what=f"{label}: {key} against height")
                Lx = np.geomspace(L[ok].min(), L[ok].max(), 20)
                ax.plot(Lx, fit.prefactor * Lx ** fit.exponent, "-", color=col, lw=0.8)
                lab += f": {sym} = {sign * fit.exponent:.3f}" + _fmt_err(fit.exponent_err)
            ax.plot(L, y, mk, color=col, ms=5, label=lab)
            Lm, e = effective_exponents(L, y)
            if Lm.size:
                axe.plot(Lm, sign * e, mk + "-", color=col, ms=4, lw=0.8, label=label)
    for ax in (axA, axW):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.legend(fontsize=8)
    axA.set_ylabel(r"amplitude $A$ of the first peak  [$E^*\bar d^{\,2}$]")
    axW.set_ylabel(r"width $W$  [$\bar d/\sqrt{E^*/\rho}$]")
    axg.set_ylabel(r"$-\,d\log A/d\log L$")
    axa.set_ylabel(r"$d\log W/d\log L$")
    for ax, key, name in ((axg, "gamma", "γ"), (axa, "alpha", "α")):
        if ref.get(key) is not None:
            ax.axhline(ref[key], ls="--", color="k", lw=0.8, label=f"{name} = {ref[key]:.3g} (reference)")
        ax.set_xlabel(L_LABEL)
        ax.legend(fontsize=8)
    axA.set_title(r"$A \propto L^{-\gamma}$")
    axW.set_title(r"$W \propto L^{\alpha}$")
    return save_figure(fig, path, pdf=pdf)


# ====================================================================== pressure
def speeds_vs_pressure(sweep: Mapping, path, *, lattice_theory: Callable | None = None,
                       lattice_points: Sequence[Mapping] = (), poisson: float = 0.0,
                       pdf: bool = False) -> list[Path]:
    """c_tof, c_ℓ and 2 c_t against p (log–log) with the lattice theory and guides.

    ``sweep``: ``pressure`` array and any of ``c_tof``, ``c_l``, ``c_t`` arrays
    (and ``*_err`` for error bars). ``lattice_theory(p, friction=bool, poisson=ν)``
    gives the triangular-lattice speed (default :func:`granwave.theory` when
    available); ``lattice_points``: dicts ``pressure``, ``speed``, ``friction``
    (and optional ``label``) from simulated lattices, drawn as markers. Guide
    lines p^{1/6} and p^{1/4} go through the geometric middle of c_tof.
    """
    p = _array(sweep["pressure"], "pressure")
    _need(np.all(p > 0), "pressures must be positive for a log axis")
    fig = _new_figure((8, 6))
    ax = fig.add_subplot(1, 1, 1)
    styles = {"c_tof": ("o", "C0", r"$c_{\rm tof}$"), "c_l": ("s", "C1", r"$c_\ell$"),
              "c_t": ("^", "C2", r"$2\,c_t$")}
    anchor = None
    for key, (mk, col, lab) in styles.items():
        if sweep.get(key) is None:
            continue
        factor = 2.0 if key == "c_t" else 1.0
        y = np.asarray(sweep[key], float) * factor
        err = sweep.get(key + "_err")
        err = None if err is None else np.asarray(err, float) * factor
        ax.errorbar(p, y, yerr=err, fmt=mk, color=col, ms=6, capsize=3, label=lab)
        ok = (y > 0) & np.isfinite(y)
        if np.unique(p[ok]).size >= 2:
            fit = power_law_fit(p[ok], y[ok], what=f"{key} against pressure")
            px = np.geomspace(p[ok].min(), p[ok].max(), 20)
            ax.plot(px, fit.prefactor * px ** fit.exponent, "-", color=col, lw=0.7,
                    label=f"fit: {lab} ∝ $p^{{{fit.exponent:.3f}}}$" + _fmt_err(fit.exponent_err))
        if anchor is None and ok.any():
            anchor = (float(np.exp(np.mean(np.log(p[ok])))), float(np.exp(np.mean(np.log(y[ok])))))
    _need(anchor is not None, "no speeds (c_tof, c_l, c_t) in the sweep")
    prange = np.geomspace(p.min() / 2, p.max() * 2, 50)
    if lattice_points:
        prange = np.geomspace(min(prange[0], min(float(q["pressure"]) for q in lattice_points)),
                              max(prange[-1], max(float(q["pressure"]) for q in lattice_points)), 50)
    if lattice_theory is None:
        lattice_theory = _theory_lattice_speed()
    if lattice_theory:
        for fr, ls in ((False, "-"), (True, "--")):
            ax.plot(prange, [lattice_theory(q, friction=fr, poisson=poisson) for q in prange],
                    ls, color="k", lw=1,
                    label="triangular lattice theory, " + ("frictional" if fr else "frictionless"))
    for q in lattice_points:
        fr = bool(q.get("friction", 0))
        ax.plot(float(q["pressure"]), float(q["speed"]), "*" if fr else "P", ms=10,
                color="0.3" if fr else "0.55",
                label=q.get("label") or ("lattice simulation, " + ("frictional" if fr else "frictionless")))
    p0, c0 = anchor
    for e, ls in ((1 / 6, ":"), (1 / 4, "-.")):
        ax.plot(prange, c0 * (prange / p0) ** e, ls, color="C7", lw=1,
                label=f"$p^{{{'1/6' if e < 0.2 else '1/4'}}}$ guide")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(r"pressure $p$  [$E^*$]")
    ax.set_ylabel(f"speed  [{C_UNIT}]")
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8)
    return save_figure(fig, path, pdf=pdf)


def _theory_lattice_speed() -> Callable:
    from .theory import lattice_speed

    return lambda p, *, friction, poisson=0.0: float(lattice_speed(p, friction=friction,
                                                                    poisson=poisson))


# ====================================================================== spectrum
def spectrum(modes: Modes, path, *, ic: str = "A", bins: int = 60, zero_tol: float = 1e-9,
             pdf: bool = False) -> list[Path]:
    """Density of eigenfrequencies ω and each mode's weight a_n b_n in the signal.

    Zero modes (ω² ≤ zero_tol × max ω²) are left out and counted in the title.
    """
    _need(ic in ("A", "B"), "ic must be A or B")
    omega2 = _array(modes.omega2, "omega2")
    nz = omega2 > zero_tol * max(float(omega2.max()), 1e-300)
    omega = np.sqrt(omega2[nz])
    a = np.asarray(modes.amplitude_A if ic == "A" else modes.amplitude_B, float)[nz]
    w = a * np.asarray(modes.coupling, float)[nz]
    fig = _new_figure((9, 7))
    ax1 = fig.add_subplot(2, 1, 1)
    ax2 = fig.add_subplot(2, 1, 2, sharex=ax1)
    ax1.hist(omega, bins=bins, density=True, color="C0", alpha=0.7)
    ax1.set_ylabel(r"density of states $g(\omega)$  [$\bar d/\sqrt{E^*/\rho}$]")
    ax1.set_title(f"{omega.size} modes, {int((~nz).sum())} zero modes left out")
    ml, sl, bl = ax2.stem(omega, w, markerfmt=".", basefmt="k-")
    sl.set_linewidth(0.6)
    ax2.set_xlabel(r"$\omega$  [$\sqrt{E^*/\rho}/\bar d$]")
    ax2.set_ylabel(f"$a_n b_n$ (initial condition {ic})  [$E^*\\bar d^{{\\,2}}$]")
    return save_figure(fig, path, pdf=pdf)


# ====================================================================== damping
def damping_series(signals: Sequence[Signal], path, *, reference: Signal | None = None,
                   pdf: bool = False) -> list[Path]:
    """Signals of one packing for several contact dampings ζ, side by side.

    Each signal needs ``attrs['damping']``; panels are ordered by ζ and share
    the axes. ``reference`` (e.g. the linear model) is drawn dashed in each.
    """
    _need(len(signals) > 0, "no signals to plot")
    missing = [k for k, s in enumerate(signals) if "damping" not in s.attrs]
    _need(not missing, f"signal(s) {missing} have no 'damping' attribute")
    order = sorted(signals, key=lambda s: float(s.attrs["damping"]))
    n = len(order)
    ncol = min(n, 4)
    nrow = math.ceil(n / ncol)
    fig = _new_figure((3.6 * ncol + 0.5, 3.2 * nrow + 0.4))
    first = None
    for k, s in enumerate(order):
        ax = fig.add_subplot(nrow, ncol, k + 1, sharex=first, sharey=first)
        first = first or ax
        if reference is not None:
            ax.plot(reference.time, reference.force, "--", color="0.5", lw=0.9, label="reference")
        ax.plot(s.time, s.force, color="C0", lw=1)
        ax.set_title(f"ζ = {float(s.attrs['damping']):g}")
        ax.set_xlabel(T_LABEL)
        if k % ncol == 0:
            ax.set_ylabel(F_LABEL)
        if reference is not None and k == 0:
            ax.legend(fontsize=8)
    return save_figure(fig, path, pdf=pdf)


# ====================================================================== chain
def chain_airy(path, *, n_balls: Sequence[int] = (25, 50, 100, 200), ic: str = "A",
               exact: Callable | None = None, airy: Callable | None = None,
               window: float = 12.0, samples: int = 800, pdf: bool = False) -> list[Path]:
    """Chain wall force (exact modal sum) against the Airy asymptote, co-moving frame.

    Units of the chain: ℓ = 1, c = 1 (so t0 = N + 1). The x axis is
    s = 2τ / N^{1/3} with τ = t − t0; the force is scaled by N^{2/3} (A) or N (B),
    so the curves of every N collapse on the Airy shape for large N.

    ``exact(t, n_balls, ic)`` and ``airy(t, n_balls, ic)`` return the force on
    the far wall at times t > 0; by default :func:`granwave.theory.chain_wall_force`
    and :func:`granwave.theory.chain_wall_force_airy` (K = m = ℓ = 1).
    """
    _need(ic in ("A", "B"), "ic must be A or B")
    n_balls = [int(n) for n in n_balls]
    _need(len(n_balls) > 0 and min(n_balls) >= 2, "give chain lengths of at least 2 balls")
    if exact is None or airy is None:
        e2, a2 = _theory_chain()
        exact, airy = exact or e2, airy or a2
    power = 2 / 3 if ic == "A" else 1.0
    fig = _new_figure((12, 5))
    ax1, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    import matplotlib as mpl
    cmap = mpl.colormaps["plasma"]
    for k, N in enumerate(sorted(n_balls)):
        col = cmap(0.85 * k / max(len(n_balls) - 1, 1))
        t0 = N + 1.0
        half = window * N ** (1 / 3) / 2
        t = np.linspace(max(t0 - 2 * half, 0.5), t0 + half, samples)
        F = np.asarray(exact(t, N, ic), float)
        s = 2 * (t - t0) / N ** (1 / 3)
        ax1.plot(t, F, color=col, lw=1, label=f"N = {N}")
        ax2.plot(s, F * N ** power, color=col, lw=1.3, label=f"exact, N = {N}")
        if airy is not None:
            ax2.plot(s, np.asarray(airy(t, N, ic), float) * N ** power, "--", color=col, lw=0.9)
    if airy is not None:
        ax2.plot([], [], "k--", lw=0.9, label="Airy asymptote")
    ax1.set_xlabel(r"time $t$  [$\ell/c$]")
    ax1.set_ylabel(r"wall force $F$  [$K\ell$]")
    ax1.set_title(f"1D chain, initial condition {ic}: exact modal sum")
    ax2.set_xlabel(r"$s = 2(t-t_0)c/(\ell N^{1/3})$,  $t_0 = (N+1)\ell/c$")
    ax2.set_ylabel(f"$F\\,N^{{{'2/3' if ic == 'A' else '1'}}}$  [$K\\ell$]")
    ax2.set_title("co-moving frame")
    ax2.set_xlim(-window, window / 2)
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    return save_figure(fig, path, pdf=pdf)


def _theory_chain():
    from .theory import chain_wall_force, chain_wall_force_airy

    return (lambda t, n, ic: chain_wall_force(t, n, ic=ic),
            lambda t, n, ic: chain_wall_force_airy(t, n, ic=ic))


# ====================================================================== registry
FIGURES: dict[str, str] = {
    "network": "Force network (width ∝ normal force) beside the stiffness network (width ∝ k_n), "
               "with the force and stiffness histograms",
    "roses": "Contact-direction roses for all, strong and weak contacts",
    "snapshot": "Displacement field of the pulse (snapshots)",
    "signals": "Signals of several packings and the ensemble average ± rms",
    "compare": "Signals of the frictional 2D, frictionless 2D and 3D systems",
    "coherent": "Coherent part of the signal at several heights",
    "arrivals": "Arrival times of the 10% edge, the peak and the zero crossing against distance",
    "exponents": "Amplitude A(L) and width W(L) with their effective exponents",
    "speeds": "Sound speeds against pressure with the lattice theory and p^1/6, p^1/4 guides",
    "spectrum": "Eigen-spectrum and the modes' weights a_n b_n in the signal",
    "modes": "Selected mode shapes",
    "damping": "Signals for several contact dampings ζ",
    "airy": "Chain signals against the Airy shape in the co-moving frame",
}
"""Figure name (the ``granwave plot`` subcommand) -> caption used by the report."""


def caption_for(filename: str | os.PathLike) -> str:
    """The caption of a figure file named after its ``granwave plot`` subcommand."""
    stem = Path(filename).stem
    for name in sorted(FIGURES, key=len, reverse=True):
        if stem == name or stem.startswith(name + "_") or stem.startswith(name + "-"):
            rest = stem[len(name) + 1:]
            return FIGURES[name] + (f" ({rest.replace('_', ' ')})" if rest else "")
    return stem.replace("_", " ")
