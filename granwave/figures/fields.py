"""Fields of the pulse and of the modes (docs/method.md §7–§8): snapshots, the coherent
front in space and time, mode shapes."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .common import L_UNIT, T_LABEL, T_UNIT, need, new_figure, plane_axes, save_figure, scene_title

#: The longest arrow (|u| at or above the panel's scale), in mean diameters: long enough to see
#: on a 600-grain panel printed a few inches wide.
ARROW_LENGTH = 2.0

if TYPE_CHECKING:
    from ..analysis.pulse_field import RowFields
    from ..model import Modes, Packing, Signal


def _field(dof_grain, dof_axis, values, n_grains: int, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Translational field (N, dim) from a dof vector, and which grains have dofs."""
    dof_grain = np.asarray(dof_grain, int)
    dof_axis = np.asarray(dof_axis, int)
    u = np.zeros((n_grains, dim))
    trans = dof_axis < dim
    need(np.all(dof_grain < n_grains), "dof map refers to grains beyond the positions given")
    u[dof_grain[trans], dof_axis[trans]] = np.asarray(values)[trans]
    has = np.zeros(n_grains, bool)
    has[dof_grain] = True
    return u, has


def _arrows(ax, position, u, has, dim, box=None, radius=None, title="", scale=None):
    """Arrows of the in-plane field u; lengths and colours relative to ``scale`` (default: the
    panel's largest |u|), an arrow longer than ``scale`` drawn at that length (clipped)."""
    ax0, ax1 = plane_axes(dim)
    xy = position[:, [ax0, ax1]]
    uv = u[:, [ax0, ax1]]
    if radius is not None:
        from matplotlib.collections import EllipseCollection
        d = 2 * np.asarray(radius, float)
        ax.add_collection(EllipseCollection(d, d, np.zeros_like(d), units="xy", offsets=xy,
                                            offset_transform=ax.transData, facecolors="0.9",
                                            edgecolors="0.75", linewidths=0.3, zorder=0))
    mag = np.hypot(uv[:, 0], uv[:, 1])
    if scale is None:
        scale = mag[has].max() if has.any() and mag[has].max() > 0 else 1.0
    clip = np.minimum(1.0, scale / np.where(mag > 0, mag, 1.0))  # |arrow| ≤ scale
    q = ax.quiver(xy[has, 0], xy[has, 1], uv[has, 0] * clip[has] / scale,
                  uv[has, 1] * clip[has] / scale, np.minimum(mag[has] / scale, 1.0),
                  cmap="viridis", angles="xy", scale_units="xy", scale=1.0 / ARROW_LENGTH,
                  width=0.006, headwidth=3.5, headlength=4, pivot="tail", zorder=2)
    ax.set_aspect("equal")
    if box is not None:
        ax.set_xlim(0, box[ax0])
        ax.set_ylim(0, box[ax1])
    else:
        ax.autoscale_view()
    ax.set_xlabel(f"x  [{L_UNIT}]")
    ax.set_ylabel(f"{'yz'[dim - 2]}  [{L_UNIT}]")
    ax.set_title(title, fontsize=10)
    return q


def displacement_snapshot(signal: Signal, path, *, packing: Packing | None = None,
                          index: Sequence[int] | None = None, fields: RowFields | None = None,
                          pdf: bool = False, scene: str | None = None) -> list[Path]:
    """The pulse: displacement snapshots as arrows, and (with ``fields``) the coherent front.

    Top row: the snapshots of a signal file (translational dofs), all on ONE
    scale (stated in the suptitle), so that the panels compare: the
    :data:`ARROW_QUANTILE` quantile of |u| over the panels, longer arrows
    clipped to it. Not the largest |u|: the few grains at the kicked wall move
    far more than the front does, and on their scale the front's arrows
    vanish. Positions come from the signal's ``snapshots/position`` or else
    from ``packing``. ``index`` chooses the
    snapshots (default: up to four, evenly spread).

    Bottom row, when ``fields`` (:func:`granwave.analysis.pulse_field.row_fields`)
    is given: the row-averaged energy per unit height E(y, t) on a log colour
    scale, and the low-pass row-averaged vertical displacement (modes below
    the front's band), each with the detector's arrival times of the 10 % edge and of the
    first peak marked at y = L (no line from the source: arrivals fitted against L have an
    intercept t_i ≠ 0, docs/method.md §9).
    """
    need(signal.snapshot_time is not None and signal.snapshot_displacement is not None,
         "signal has no snapshots (rerun propagate with snapshot times)")
    position = signal.position if signal.position is not None else (
        packing.position if packing is not None else None)
    need(position is not None, "no grain positions: the signal stores none, give the packing")
    position = np.asarray(position, float)
    disp = np.atleast_2d(np.asarray(signal.snapshot_displacement, float))
    S = disp.shape[0]
    if index is None:
        index = sorted(set(np.linspace(0, S - 1, min(S, 4)).round().astype(int).tolist()))
    index = list(index)
    need(all(-S <= i < S for i in index), f"snapshot index out of range (the file has {S})")
    dim = position.shape[1]
    box = packing.box if packing is not None else None
    radius = packing.radius if packing is not None else None
    ncol = len(index)
    panels, scale = snapshot_panels(signal, index, position.shape[0], dim)
    rows = 2 if fields is not None else 1
    fig = new_figure((max(4.2 * ncol + 0.8, 12.0), 5.5 * rows))
    gs = fig.add_gridspec(rows, 1)
    top = gs[0].subgridspec(1, ncol)
    for k, (i, (u, has)) in enumerate(zip(index, panels)):
        ax = fig.add_subplot(top[0, k])
        q = _arrows(ax, position, u, has, dim, box, radius, scale=scale,
                    title=f"t = {float(signal.snapshot_time[i]):.4g} " + T_UNIT)
    largest = max((float(np.max(np.linalg.norm(u[has][:, list(plane_axes(dim))], axis=1)))
                   for u, has in panels if has.any()), default=0.0)
    fig.colorbar(q, ax=fig.axes[:ncol], label=rf"$|u|/u_{{{ARROW_QUANTILE * 100:g}\%}}$  [1], clipped at 1 "
                 "(one scale for all panels)", shrink=0.8)
    a = signal.attrs
    fig.suptitle(scene_title("the pulse: displacement snapshots", scene=scene, pressure=a.get("pressure"),
                             height=a.get("height"), count="one packing")
                 + f"\nfull arrow ({ARROW_LENGTH:g} d̄) = {scale:.3g} kick units, the "
                 f"{ARROW_QUANTILE * 100:g}th percentile of |u| over the panels (longer ones, up to "
                 f"{largest:.3g}, clipped): the same in every panel", fontsize=10)
    if fields is not None:
        _front_maps(fig, gs[1].subgridspec(1, 2), fields)
    return save_figure(fig, path, pdf=pdf)


ENERGY_DECADES = 1e-6
"""The energy map's colour scale spans max × 1e-6 … max (values below drawn at the floor)."""


ARROW_QUANTILE = 0.95
"""The snapshots' full arrow: this quantile of the in-plane |u| over every panel's grains."""


def snapshot_panels(signal: Signal, index: Sequence[int], n_grains: int, dim: int):
    """The translational fields of the chosen snapshots and their ONE scale: the
    :data:`ARROW_QUANTILE` quantile of the in-plane |u| over all of them (so that the panels
    compare, and a few loud grains at the source do not shrink the front's arrows to dots)."""
    disp = np.atleast_2d(np.asarray(signal.snapshot_displacement, float))
    panels = [_field(signal.dof_grain, signal.dof_axis, disp[i], n_grains, dim) for i in index]
    mags = [np.linalg.norm(u[has][:, list(plane_axes(dim))], axis=1) for u, has in panels if has.any()]
    mags = np.concatenate(mags) if mags else np.zeros(0)
    mags = mags[mags > 0]
    scale = float(np.quantile(mags, ARROW_QUANTILE)) if mags.size else 0.0
    return panels, scale or 1.0


def _front_maps(fig, grid, f: RowFields) -> None:
    """E(y, t) on a log scale and the low-pass row-mean displacement, with arrival lines."""
    from matplotlib.colors import LogNorm

    a = f.attrs
    L = float(a["height"])
    edges_t = np.concatenate([f.time, [2 * f.time[-1] - f.time[-2]]])
    w = float(a["row_width"])
    edges_y = np.concatenate([f.row_y - w / 2, [f.row_y[-1] + w / 2]])
    hi = float(np.max(f.energy)) if np.max(f.energy) > 0 else 1.0
    floor = hi * ENERGY_DECADES
    # Below the floor (and the rare negative split of ½ u·Du near a node) is drawn at the floor.
    e = np.clip(f.energy, floor, None)
    ax1 = fig.add_subplot(grid[0, 0])
    m1 = ax1.pcolormesh(edges_t, edges_y, e, norm=LogNorm(vmin=floor, vmax=hi), cmap="magma",
                        shading="flat")
    fig.colorbar(m1, ax=ax1, label=r"energy per unit height / total energy  [$1/\bar d$]")
    ax1.set_title("row-averaged energy density E(y, t) (log scale)", fontsize=10)
    ax2 = fig.add_subplot(grid[0, 1], sharey=ax1)
    d = f.displacement_low
    top = float(np.nanmax(np.abs(d))) if np.isfinite(d).any() else 0.0
    top = top or 1.0
    m2 = ax2.pcolormesh(edges_t, edges_y, d / top, vmin=-1, vmax=1, cmap="RdBu_r", shading="flat")
    fig.colorbar(m2, ax=ax2, label=r"$\bar u_y / \max|\bar u_y|$  [1]")
    ax2.set_title(f"low-pass row-mean vertical displacement (ω < {a['omega_cut']:.3g}: "
                  f"{a['modes_below_cut']} of {a['modes_nonzero']} modes)", fontsize=10)
    for ax in (ax1, ax2):
        for key, mk, name in (("t_lead10", "v", "10% edge"), ("t_peak", "o", "first peak")):
            t_arr = float(a[key])
            ax.plot([t_arr], [L], mk, color="cyan" if ax is ax1 else "k", ms=9, mec="k",
                    clip_on=False, zorder=5, label=f"{name} at the detector: t = {t_arr:.3g}")
        ax.set_xlim(f.time[0], f.time[-1])
        ax.set_ylim(0, L)
        ax.set_xlabel(T_LABEL)
        ax.legend(fontsize=8, loc="lower right")
    ax1.set_ylabel(f"height y above the source  [{L_UNIT}]")
    ax2.set_ylabel(f"height y  [{L_UNIT}]")


def mode_shapes(vectors: np.ndarray, dof_grain, dof_axis, position, path, *,
                omega: Sequence[float] | None = None, labels: Sequence[str] | None = None,
                radius=None, box=None, pdf: bool = False, scene: str | None = None,
                pressure=None) -> list[Path]:
    """Selected eigenmodes as displacement arrows (translational part).

    ``vectors`` has one mode per column (n_dof, K); ``dof_grain``/``dof_axis``
    come from the linear file, ``position`` (N, dim) from the packing. Each panel's full arrow
    is the larger of the 90th percentile of its |φ| and 1/20 of its largest (a localized mode's
    few large arrows clipped, the rest still visible).
    """
    vectors = np.asarray(vectors, float)
    if vectors.ndim == 1:
        vectors = vectors[:, None]
    need(vectors.shape[0] == len(dof_grain), "mode vectors and dof map differ in length")
    position = np.asarray(position, float)
    K = vectors.shape[1]
    need(K > 0, "no modes to draw")
    dim = position.shape[1]
    fig = new_figure((4.2 * K + 0.8, 5.5))
    for k in range(K):
        ax = fig.add_subplot(1, K, k + 1)
        u, has = _field(dof_grain, dof_axis, vectors[:, k], position.shape[0], dim)
        title = labels[k] if labels is not None else f"mode {k}"
        if omega is not None:
            title += f"\nω = {float(omega[k]):.4g} " + r"$\sqrt{E^*/\rho}/\bar d$"
        mag = np.linalg.norm(u[has][:, list(plane_axes(dim))], axis=1)
        mag = mag[mag > 0]
        scale = max(float(np.quantile(mag, 0.9)), float(mag.max()) / 20) if mag.size else 1.0
        q = _arrows(ax, position, u, has, dim, box, radius, title=title, scale=scale)
    fig.colorbar(q, ax=fig.axes, label=r"$|\phi|$ over the panel's full arrow  [1], clipped at 1",
                 shrink=0.8)
    height = None if box is None else float(np.asarray(box)[dim - 1])
    fig.suptitle(scene_title("mode shapes (translational part)", scene=scene, pressure=pressure,
                             height=height, count="one packing")
                 + "\nfull arrow: the larger of the panel's 90th percentile of |φ| and 1/20 of its "
                 "largest", fontsize=10)
    return save_figure(fig, path, pdf=pdf)


def select_modes(modes: Modes, *, dof_grain=None, dof_axis=None, dim: int | None = None,
                 ic: str = "A", zero_tol: float = 1e-9) -> dict[str, int]:
    """Lowest nonzero mode, the mode contributing most (|a_n b_n|) and the most
    localized one (smallest participation ratio over grains,
    :func:`granwave.analysis.spectrum.participation_ratio`; needs the vectors)."""
    omega2 = np.asarray(modes.omega2, float)
    nz = np.flatnonzero(omega2 > zero_tol * max(omega2.max(), 1e-300))
    need(nz.size > 0, "no nonzero modes")
    a = modes.amplitude_A if ic == "A" else modes.amplitude_B
    contrib = np.abs(np.asarray(a) * np.asarray(modes.coupling))
    out = {"lowest nonzero": int(nz[0]), "strongest |a_n b_n|": int(nz[np.argmax(contrib[nz])])}
    if modes.vectors is not None and dof_grain is not None:
        from ..analysis.spectrum import participation_ratio

        pr = participation_ratio(np.asarray(modes.vectors)[:, nz], dof_grain=dof_grain,
                                 dof_axis=dof_axis, dim=dim)
        out["most localized"] = int(nz[np.nanargmin(pr)])
    return out

