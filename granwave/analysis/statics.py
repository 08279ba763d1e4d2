"""Static characterization of a packing (docs/method.md §4), in 1D, 2D and 3D.

Choices where docs/method.md §4 leaves room (also in ``granwave analyze statics --help``):

- **Force-carrying contact**: F_n > ``force_tol`` × p d̄² (default 1e-9).
- **Rattlers**: grains with fewer than ``min_contacts`` force-carrying
  contacts (default 2), found iteratively: a rattler's contacts are dropped
  and its neighbours re-examined until nothing changes. A grain in
  equilibrium with a single contact carries no force through it (the
  residual of a converged DEM packing may leave a tiny force there), so
  with the default this is the rule "grains that carry no force" of docs/method.md §4;
  ``min_contacts=1`` is the literal rule (no force-carrying contact at all).
- **Bulk**: the slab l <= y <= H − l (y the vertical coordinate, H the
  wall-to-piston distance, l = ``layer``, default 3 d̄). Bulk grains are
  those whose centre is in the slab.
- **Solid fractions**: the disks' area (Φ2) and the spheres' volume (Φ3,
  Φ3*) that lies inside the slab, each grain cut exactly by the two planes,
  divided by the slab's area L1 (H − 2l) (2D; Φ3 uses a one-diameter-thick
  layer) or volume L1 L2 (H − 2l) (3D; Φ2 is then NaN). In 1D both are NaN.
- **Contact statistics** (z*, ⟨N⟩/p, Z2, Z3, F2, F2_strong): over the
  force-carrying contacts of bulk non-rattler grains, each contact counted
  once per bulk non-rattler grain it touches (a contact between two bulk
  grains weighs 1, one reaching out of the slab ½ — so a perfect lattice
  gives the values of its six directions exactly). z* = force-carrying
  contacts per bulk non-rattler grain (wall contacts included). Strong
  contacts: F_n above that (weighted) mean by more than a relative 1e-9
  (so a perfect lattice, all forces equal, has none: F2_strong = NaN). F2 = ⟨n_y²⟩, n_y the vertical
  component of the normal (isotropic 2D value 1/2).
- **Stress**: over the whole cell, walls included,
  σ = (1/V) Σ_contacts (−f_i) ⊗ b, with f_i the force on grain i and b the
  branch vector: for a grain pair the vector r_ij from i to j (nearest
  periodic image), for a wall contact the arm from the centre to the
  contact point, (R_i − δ) n (docs/conventions.md). V = L1 × H × 1 d̄ (2D),
  L1 L2 H (3D), H × 1 d̄² (1D). Compressive stress is positive.
  stress_ratio = σ11/σ_vv (first lateral over vertical).
- **max_force_residual**: max over grains of the net contact force and of
  the net torque (Σ arm × F_t, arms a_i = R_i − δ/2 for grain pairs and
  R_i − δ against a wall, docs/conventions.md), divided by p d̄² (p d̄³).
- **piston_balance**: Σ F_n over top-wall contacts / (p × wall area) − 1,
  wall area L1 × 1 d̄ (2D), L1 L2 (3D), 1 d̄² (1D).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..geometry import cube
from ..model import Packing
from ..params import BULK_LAYER

KEYS = ("phi2", "phi3", "phi3_star", "z_star", "rattler_fraction", "mean_force_over_p", "Z2", "Z3",
        "F2", "F2_strong", "stress", "stress_ratio", "max_force_residual", "piston_balance")


def branch_vectors(packing: Packing) -> np.ndarray:
    """(M, dim) branch vector of every contact: r_ij (nearest image) or the wall arm (R_i − δ) n."""
    c = packing.contacts
    pos, box = packing.position, packing.box
    b = np.empty_like(c.normal)
    wall = c.j < 0
    pair = ~wall
    d = pos[c.j[pair]] - pos[c.i[pair]]
    lateral = box[:-1]
    for a in range(len(lateral)):
        d[:, a] -= lateral[a] * np.round(d[:, a] / lateral[a])
    b[pair] = d
    b[wall] = ((packing.radius[c.i[wall]] - c.overlap[wall]))[:, None] * c.normal[wall]
    return b


def contact_arms(packing: Packing) -> tuple[np.ndarray, np.ndarray]:
    """Lever arms (a_i, a_j) of every contact: R − δ/2 for grain pairs, R_i − δ against a wall."""
    c = packing.contacts
    wall = c.j < 0
    a_i = packing.radius[c.i] - np.where(wall, c.overlap, 0.5 * c.overlap)
    a_j = np.where(wall, 0.0, packing.radius[np.maximum(c.j, 0)] - 0.5 * c.overlap)
    return a_i, a_j


def net_force_and_torque(packing: Packing) -> tuple[np.ndarray, np.ndarray]:
    """Net contact force (N, dim) and torque (N, 1 in 2D / 3 in 3D / 0 in 1D) on every grain."""
    c = packing.contacts
    n, dim = packing.n_grains, packing.dim
    f_on_i = -c.force_normal[:, None] * c.normal + c.force_tangential
    pair = c.j >= 0
    force = np.zeros((n, dim))
    np.add.at(force, c.i, f_on_i)
    np.add.at(force, c.j[pair], -f_on_i[pair])
    a_i, a_j = contact_arms(packing)
    if dim == 1:
        return force, np.zeros((n, 0))
    if dim == 2:
        cross = (c.normal[:, 0] * c.force_tangential[:, 1] - c.normal[:, 1] * c.force_tangential[:, 0])[:, None]
    else:
        cross = np.cross(c.normal, c.force_tangential)
    # torque on i: (a_i n) x F_t; on j: (-a_j n) x (-F_t) = (a_j n) x F_t
    torque = np.zeros((n, cross.shape[1]))
    np.add.at(torque, c.i, a_i[:, None] * cross)
    np.add.at(torque, c.j[pair], a_j[pair, None] * cross[pair])
    return force, torque


def find_rattlers(packing: Packing, *, min_contacts: int = 2, force_tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """(rattler mask (N,), mask (M,) of the force-carrying contacts between non-rattlers).

    Iterative rule of the module docstring: grains with fewer than
    ``min_contacts`` contacts with F_n > force_tol × p d̄² are rattlers.
    """
    c = packing.contacts
    n = packing.n_grains
    active = c.force_normal > force_tol * packing.pressure
    rattler = np.zeros(n, bool)
    while True:
        count = np.bincount(c.i[active], minlength=n)
        pair = active & (c.j >= 0)
        count += np.bincount(c.j[pair], minlength=n)
        new = (count < min_contacts) & ~rattler
        if not new.any():
            return rattler, active
        rattler |= new
        active &= ~rattler[c.i] & ~np.where(c.j >= 0, rattler[np.maximum(c.j, 0)], False)


def _amount_in_slab(y: np.ndarray, radius: np.ndarray, lo: float, hi: float, kind: str) -> np.ndarray:
    """Part of each grain between the planes lo and hi: disk area, sphere volume or rod length."""

    def below(level):
        u = np.clip(level - y, -radius, radius)
        if kind == "area":
            return radius**2 * np.arccos(-u / radius) + u * np.sqrt(radius**2 - u**2)
        if kind == "volume":
            return np.pi * (radius + u) ** 2 * (2.0 * radius - u) / 3.0
        return radius + u

    return below(hi) - below(lo)


def statics(packing: Packing, *, layer: float = BULK_LAYER, min_contacts: int = 2,
            force_tol: float = 1e-9) -> dict:
    """Bulk statistics, stress and balance checks of a packing (docs/method.md §4; choices: module docstring).

    ``layer`` l (d̄): thickness excluded next to the bottom wall and the piston.
    Returns a dict with the keys of :data:`KEYS` (NaN where not meaningful)
    plus ``layer``, ``n_bulk_grains``, ``n_rattlers_bulk``, ``min_contacts``.
    """
    if not (np.isfinite(layer) and layer >= 0):
        raise InputError(f"layer must be a non-negative thickness, got {layer}")
    p = packing.pressure
    if not p > 0:
        raise InputError(f"packing pressure must be positive, got {p}")
    dim, n = packing.dim, packing.n_grains
    c = packing.contacts
    height = packing.height
    lo, hi = layer, height - layer
    if hi <= lo:
        raise InputError(f"layer {layer} leaves no bulk in a packing of height {height:.6g} "
                         f"(need 2 l < H)")
    y = packing.position[:, -1]
    bulk = (y >= lo) & (y <= hi)
    rattler, active = find_rattlers(packing, min_contacts=min_contacts, force_tol=force_tol)
    n_bulk = int(bulk.sum())
    if n_bulk == 0:
        raise InputError(f"no grain centre lies in the bulk slab {lo:.6g} <= y <= {hi:.6g}")

    # solid fractions, grains cut exactly by the slab planes
    lateral = packing.box[:-1]
    slab = float(np.prod(lateral)) * (hi - lo)  # 2D: L1 (H-2l) [x 1 d]; 3D: L1 L2 (H-2l)
    phi2 = phi3 = phi3_star = float("nan")
    if dim >= 2:
        vol = _amount_in_slab(y, packing.radius, lo, hi, "volume")
        phi3 = float(vol.sum() / slab)
        phi3_star = float(vol[~rattler].sum() / slab)
        if dim == 2:
            phi2 = float(_amount_in_slab(y, packing.radius, lo, hi, "area").sum() / slab)

    # contact statistics over bulk non-rattlers, each contact once per such grain it touches
    carrier = bulk & ~rattler
    jj = np.maximum(c.j, 0)
    weight = (active & carrier[c.i]).astype(float) + (active & (c.j >= 0) & carrier[jj]).astype(float)
    n_carrier = int(carrier.sum())
    z_star = float(weight.sum() / n_carrier) if n_carrier else float("nan")
    rattler_fraction = float((bulk & rattler).sum() / n_bulk)
    fn = c.force_normal
    wsum = weight.sum()
    if wsum > 0:
        mean_n = float(np.sum(weight * fn) / wsum)
        z2 = float(np.sum(weight * fn**2) / wsum / mean_n**2)
        z3 = float(np.sum(weight * cube(fn)) / wsum / mean_n**3)
        ny2 = c.normal[:, -1] ** 2
        f2 = float(np.sum(weight * ny2) / wsum)
        strong = weight * (fn > mean_n * (1.0 + 1e-9))  # strictly above: equal forces give none
        f2_strong = float(np.sum(strong * ny2) / strong.sum()) if strong.sum() > 0 else float("nan")
    else:
        mean_n = z2 = z3 = f2 = f2_strong = float("nan")

    # stress over the whole cell, walls included (compression positive)
    b = branch_vectors(packing)
    minus_f = fn[:, None] * c.normal - c.force_tangential  # -(force on i)
    volume = float(np.prod(packing.box))  # x 1 d in 2D, x 1 d^2 in 1D
    stress = minus_f.T @ b / volume
    stress_ratio = float(stress[0, 0] / stress[-1, -1]) if stress[-1, -1] != 0 else float("nan")

    force, torque = net_force_and_torque(packing)
    worst = np.max(np.linalg.norm(force, axis=1)) if n else 0.0
    if torque.shape[1]:
        worst = max(worst, np.max(np.linalg.norm(torque, axis=1)))
    area = float(np.prod(lateral)) if dim >= 2 else 1.0  # 2D: L1 x 1 d; 1D: 1 d^2
    top = c.is_top
    piston_balance = float(fn[top].sum() / (p * area) - 1.0)

    return dict(
        phi2=phi2, phi3=phi3, phi3_star=phi3_star, z_star=z_star, rattler_fraction=rattler_fraction,
        mean_force_over_p=mean_n / p, Z2=z2, Z3=z3, F2=f2, F2_strong=f2_strong,
        stress=stress, stress_ratio=stress_ratio, max_force_residual=float(worst / p),
        piston_balance=piston_balance, layer=float(layer), n_bulk_grains=n_bulk,
        n_rattlers_bulk=int((bulk & rattler).sum()), min_contacts=int(min_contacts),
    )
