"""Figures of a packing's statics (docs/method.md §4): force and stiffness networks, contact roses.

Choices (see docs/figures.md):
- networks and roses use grain–grain contacts only unless ``walls=True``
  (the wall contacts are drawn in the networks as segments to the wall);
- a contact between periodic images is drawn as two half-visible segments:
  from each grain towards the nearest image of the other, clipped by the box;
- "strong" contacts carry a normal force above the mean normal force of the
  contacts shown, "weak" ones the rest.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..analysis.statics import branch_vectors
from .common import L_UNIT, need, new_figure, plane_axes, save_figure, scene_title

if TYPE_CHECKING:
    from ..model import Packing


def contact_segments(packing: Packing, *, walls: bool = True):
    """Segments (K, 2, 2) of the drawn plane and the contact index of each.

    A grain–grain contact whose nearest image crosses a periodic boundary gives
    two segments (from i towards the image of j, from j towards the image of i);
    the part outside the box is cut by the axes limits.
    """
    c = packing.contacts
    ax0, ax1 = plane_axes(packing.dim)
    pos = packing.position[:, [ax0, ax1]]
    d = branch_vectors(packing)[:, [ax0, ax1]]
    keep = np.ones(len(c), bool) if walls else ~c.is_wall
    idx = np.flatnonzero(keep)
    start = pos[c.i[idx]]
    segs = [np.stack([start, start + d[idx]], axis=1)]
    owners = [idx]
    grain = idx[~c.is_wall[idx]]
    if grain.size:
        straight = packing.position[c.j[grain]] - packing.position[c.i[grain]]
        wrapped = np.any(np.abs(straight - branch_vectors(packing)[grain]) > 1e-9, axis=1)
        g = grain[wrapped]
        if g.size:
            s2 = pos[c.j[g]]
            segs.append(np.stack([s2, s2 - d[g]], axis=1))
            owners.append(g)
    return np.concatenate(segs), np.concatenate(owners)


def _draw_grains(ax, packing: Packing, *, color="0.85", rattler_color=None) -> None:
    from matplotlib.collections import EllipseCollection

    ax0, ax1 = plane_axes(packing.dim)
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
    ax0, ax1 = plane_axes(packing.dim)
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
def _title(what: str, packing: Packing, scene: str | None) -> str:
    a = packing.attrs
    return scene_title(what, scene=scene, pressure=a.get("pressure"), height=packing.height,
                       count=f"{packing.n_grains} grains, one packing")


def force_network(packing: Packing, path, *, pdf: bool = False, walls: bool = False,
                  bins: int = 40, max_width: float = 4.0, scene: str | None = None) -> list[Path]:
    """Force network beside stiffness network, and their histograms (docs/method.md §4).

    Line widths are proportional to the normal force (left) and the normal
    stiffness k_n (right), each relative to its maximum. The histograms show
    F/⟨F⟩ and k_n/⟨k_n⟩ as probability densities (same area, 1), on linear and
    logarithmic axes; ``walls`` adds the wall contacts to the histograms.
    """
    c = packing.contacts
    need(len(c) > 0, "packing has no force-carrying contacts")
    fig = new_figure((12, 10))
    gs = fig.add_gridspec(2, 2, height_ratios=[1.6, 1])
    _network(fig.add_subplot(gs[0, 0]), packing, c.force_normal, "C3",
             "force network: width ∝ $F_n$", max_width)
    _network(fig.add_subplot(gs[0, 1]), packing, c.stiffness_normal, "C0",
             r"stiffness network: width ∝ $k_n$", max_width)
    keep = _weights(c, walls)
    f = c.force_normal[keep]
    k = c.stiffness_normal[keep]
    need(f.size > 0 and f.mean() > 0, "no grain-grain contacts to histogram")
    fr, kr = f / f.mean(), k / k.mean()
    edges = np.linspace(0, max(fr.max(), kr.max()) * 1.0001, bins + 1)
    for j, log in enumerate((False, True)):
        ax = fig.add_subplot(gs[1, j])
        ax.hist(fr, bins=edges, density=True, histtype="step", lw=1.5, color="C3",
                label=r"$F_n/\langle F_n\rangle$")
        ax.hist(kr, bins=edges, density=True, histtype="step", lw=1.5, color="C0",
                label=r"$k_n/\langle k_n\rangle$")
        ax.set_xlabel(r"$F_n/\langle F_n\rangle$,  $k_n/\langle k_n\rangle$  [1]")
        ax.set_ylabel("probability density  [1]")
        if log:
            ax.set_yscale("log")
        ax.legend(title=f"{f.size} contacts")
    fig.suptitle(_title("force and stiffness networks", packing, scene))
    return save_figure(fig, path, pdf=pdf)


def contact_angles(packing: Packing, *, walls: bool = False):
    """Contact-normal angles in the drawn plane and the strong-contact mask."""
    c = packing.contacts
    keep = _weights(c, walls)
    ax0, ax1 = plane_axes(packing.dim)
    n = c.normal[keep]
    f = c.force_normal[keep]
    theta = np.arctan2(n[:, ax1], n[:, ax0])
    return theta, f > f.mean()


def contact_roses(packing: Packing, path, *, pdf: bool = False, walls: bool = False,
                  bins: int = 36, scene: str | None = None) -> list[Path]:
    """Polar histograms of contact directions: all, strong (F > ⟨F⟩) and weak contacts.

    Each contact counts with n and −n (the rose is centrally symmetric); radii
    are probability densities per radian (isotropic value 1/2π), on one radial scale in all
    three panels, its tick labels on a white ground at 22.5°. In 3D the angle is that of the
    normal's projection on the x–z plane.
    """
    need(len(packing.contacts) > 0, "packing has no force-carrying contacts")
    theta, strong = contact_angles(packing, walls=walls)
    need(theta.size > 0, "no grain-grain contacts to histogram")
    fig = new_figure((13, 4.8))
    edges = np.linspace(-np.pi, np.pi, bins + 1)
    width = edges[1] - edges[0]
    sets = [("all contacts", np.ones_like(strong)), ("strong: $F_n>\\langle F_n\\rangle$", strong),
            ("weak: $F_n\\leq\\langle F_n\\rangle$", ~strong)]
    hists = []
    for title, mask in sets:
        t = theta[mask]
        both = np.concatenate([t, np.angle(np.exp(1j * (t + np.pi)))])
        h, _ = np.histogram(both, bins=edges, density=True) if both.size else (np.zeros(bins), None)
        hists.append((t, h))
    top = 1.1 * max(float(np.max(h)) for _, h in hists)  # one radial scale for the three panels
    for k, ((title, _), (t, h)) in enumerate(zip(sets, hists)):
        ax = fig.add_subplot(1, 3, k + 1, projection="polar")
        ax.bar(edges[:-1] + width / 2, h, width=width, color=f"C{k}", alpha=0.75, edgecolor="k",
               lw=0.3)
        ax.plot(np.linspace(0, 2 * np.pi, 200), np.full(200, 1 / (2 * np.pi)), "k--", lw=0.8)
        ax.set_ylim(0, top)
        ax.set_rlabel_position(22.5)
        ax.tick_params(axis="y", labelsize=7)
        for lab in ax.get_yticklabels():  # readable over the bars
            lab.set_bbox({"facecolor": "white", "alpha": 0.8, "edgecolor": "none", "pad": 0.5})
        if t.size:
            F2 = np.mean(np.sin(t) ** 2)
            title += f"\n{t.size} contacts, F2 = $\\langle n_y^2\\rangle$ = {F2:.3f}"
        ax.set_title(title, fontsize=10)
    fig.suptitle(_title("contact directions: density per radian [1/rad] (dashed: isotropic 1/2π; "
                        "angle from the horizontal)", packing, scene))
    return save_figure(fig, path, pdf=pdf)

