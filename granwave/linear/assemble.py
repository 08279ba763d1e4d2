"""Linearization of a packing around mechanical equilibrium (docs/method.md §5).

Small oscillations obey ``M u'' = -D u``. This module builds the sparse
stiffness (dynamical) matrix D, the diagonal mass matrix M, the dof map, the
source vectors of initial conditions A and B and the detector vector
(docs/conventions.md "Source and detector"). The derivation of every term
is in docs/linear.md.

Degrees of freedom
------------------
Per non-rattler grain, in grain order: ``dim`` translations, then the
rotations when the packing has friction (1 about z in 2D, 3 in 3D; none for
a 1D chain or a frictionless packing). Rattlers (grains without a
force-carrying contact, i.e. without a contact of ``force_normal > 0``) are
left out, and so are contacts that carry no force.

Free spins (3D with friction). A grain with exactly two force-carrying
contacts can rotate about the line through its two contact points at no
energy cost: with ``r1``, ``r2`` the contact points seen from the centre and
``e = (r2 - r1)/|r2 - r1|``, the motion ``theta = e``, ``u = -e x r1`` moves
neither contact point. By default every rotation is kept, as the DEM
integrates it: each such spin is then a zero mode of D (an expected one,
counted in ``expected_zero_modes``; with prestress it becomes a slightly
negative or zero mode), seen by neither wall. ``remove_spins=True`` removes
it from the dofs as a rattler is: the grain keeps its 3 translations and only
the two rotations about axes normal to ``e`` (an orthonormal pair from
:func:`spin_basis`, dof_axis codes 6 and 7 instead of 3, 4, 5), i.e. the
constraint ``theta . e = 0``. The constrained D has the same energies, but
the constraint also stops the grain rolling along ``u`` (the spin is not
M-orthogonal to the kept motions), so its dynamics differ from the DEM's
(docs/decisions/0019-free-spins-default.md). ``attrs``: ``n_free_spins``,
``n_spins_removed``, ``spin_removed_grains``, ``spin_removed_axes``
(docs/moduli.md, "Free spins in 3D").

Material terms
--------------
Every contact is a normal spring ``k_n`` and (friction > 0) a tangential
spring ``k_t`` on the relative displacement of the contact point (j relative
to i), ``Delta = u_j + theta_j x (-a_j n) - u_i - theta_i x (a_i n) = B q`` with
q = (u_i, theta_i, u_j, theta_j); the block is ``B^T K B`` with
``K = k_n n n^T + k_t (I - n n^T)``. The stored contact data (k_n, k_t,
overlap, normal, forces) is used as it is, so linear-spring chains and
Hertz packings go through the same code; the contact law is never
re-evaluated here.

Prestress (geometric) terms, ``prestress=True``
-----------------------------------------------
D then equals minus the Jacobian of
:func:`granwave.dem.forces.frozen_history_forces` at zero displacement:
the rotation of the normal force, ``-(F_n/r)(I - n n)`` on relative
translation, the rotation of the stored F_t with the contact frame
(``-(1/r) n F_t^T``), and in the torques the change of the lever arm with the
overlap and the rotation of the arm with the normal. Wall normals do not
rotate, so walls only contribute the arm change. With F_t != 0 these terms
are not symmetric (the incremental tangential law is not conservative): D is
kept exactly as the Jacobian and its relative asymmetry is recorded in
``attrs['asymmetry']``; the eigensolver uses the symmetric part.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .. import contact_models as CM
from ..contact_models import options as CO
from ..errors import InputError
from ..io import schema as S
from ..geometry import n_rotations  # noqa: F401  (re-exported)
from ..model import LinearSystem, Packing
from ..resources import check_linearize
from ..provenance import SAMPLE_ATTRS
# the checks every linearize runs (granwave.linear.stiffness_check), also found here
from . import stiffness_check as SC
from .stiffness_check import (ZERO_MODE_THRESHOLD, asymmetry, check_stiffness, expected_zero_modes,  # noqa: F401
                              gershgorin_bound, omega2_max, symmetric_part)

_COPIED_ATTRS = (*SAMPLE_ATTRS, "converged", "max_acceleration", "n_grains",
                 *CO.options(),  # the contact sub-models' selection (granwave.contact_models)
                 "packing_digest")  # the identity of the packing (granwave.io.files.packing_digest)


def _torque_arm_matrix(n: np.ndarray, arm: np.ndarray, n_rot: int) -> np.ndarray:
    """(M, n_rot, dim) matrices A with torque = A @ F = (arm n) x F."""
    m, dim = n.shape
    if n_rot == 0:
        return np.zeros((m, 0, dim))
    if dim == 2:
        # (n x F)_z = n_x F_y - n_y F_x
        return (arm[:, None] * np.stack([-n[:, 1], n[:, 0]], axis=1))[:, None, :]
    return arm[:, None, None] * _cross_matrix(n)


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    """(M, 3, 3) matrices [v]_x with [v]_x w = v x w."""
    z = np.zeros(len(v))
    return np.stack([np.stack([z, -v[:, 2], v[:, 1]], 1),
                     np.stack([v[:, 2], z, -v[:, 0]], 1),
                     np.stack([-v[:, 1], v[:, 0], z], 1)], 1)


def _cross_with(ft: np.ndarray, n_rot: int) -> np.ndarray:
    """(M, n_rot, dim) matrices X with X @ w = w x F_t."""
    m, dim = ft.shape
    if n_rot == 0:
        return np.zeros((m, 0, dim))
    if dim == 2:
        # (w x F)_z = w_x F_y - w_y F_x
        return np.stack([ft[:, 1], -ft[:, 0]], axis=1)[:, None, :]
    return -_cross_matrix(ft)


def _cross_vec(a: np.ndarray, b: np.ndarray, n_rot: int) -> np.ndarray:
    """(M, n_rot): a x b (z-component in 2D)."""
    if n_rot == 0:
        return np.zeros((len(a), 0))
    if a.shape[1] == 2:
        return (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])[:, None]
    return np.cross(a, b)


def contact_dofs(first: np.ndarray, i: np.ndarray, j: np.ndarray, p: int) -> np.ndarray:
    """(M, 2p) global dof indices of each contact's (u_i, theta_i, u_j, theta_j); -1 for a wall.

    ``first`` is the first dof of every grain (:func:`dof_map`), p = dim + n_rot.
    """
    wall = j < 0
    loc = np.arange(p)
    idx_i = first[i][:, None] + loc
    idx_j = np.where(wall[:, None], -1, first[np.where(wall, 0, j)][:, None] + loc)
    return np.concatenate([idx_i, idx_j], axis=1)


def scatter_blocks(blocks: np.ndarray, idx: np.ndarray, n_dof: int) -> sp.csr_matrix:
    """Sum per-contact (2p x 2p) blocks into the sparse (n_dof x n_dof) matrix; wall halves
    (index -1) and exact zeros are dropped."""
    rows = np.broadcast_to(idx[:, :, None], blocks.shape).ravel()
    cols = np.broadcast_to(idx[:, None, :], blocks.shape).ravel()
    vals = blocks.ravel()
    ok = (rows >= 0) & (cols >= 0) & (vals != 0.0)
    D = sp.coo_matrix((vals[ok], (rows[ok], cols[ok])), shape=(n_dof, n_dof)).tocsr()
    D.sum_duplicates()
    D.eliminate_zeros()
    return D


def contact_blocks(packing: Packing, *, prestress: bool = False, n_rot: int | None = None):
    """Per-contact stiffness blocks (force-carrying contacts only).

    Returns ``(keep, blocks)``: ``keep`` the indices of the contacts used and
    ``blocks`` of shape (M, 2p, 2p), p = dim + n_rot, acting on
    q = (u_i, theta_i, u_j, theta_j); the generalized force on the pair is
    ``-blocks @ q``. For wall contacts the j half is unused (the wall is fixed).
    """
    c = packing.contacts
    dim = packing.dim
    if n_rot is None:
        n_rot = n_rotations(dim, packing.friction)
    keep = np.flatnonzero(c.force_normal > 0.0)
    n = np.asarray(c.normal[keep], float).reshape(len(keep), dim)
    kn = c.stiffness_normal[keep]
    kt = c.stiffness_tangential[keep] if packing.friction > 0.0 else np.zeros(len(keep))
    wall = c.j[keep] < 0
    ii = c.i[keep]
    jj = np.where(wall, 0, c.j[keep])
    delta = c.overlap[keep]
    # Contact-point arms (docs/conventions.md): a_i = R_i - delta/2 (wall: R_i - delta).
    arm_i = np.where(wall, packing.radius[ii] - delta, packing.radius[ii] - 0.5 * delta)
    arm_j = np.where(wall, 0.0, packing.radius[jj] - 0.5 * delta)
    m = len(keep)
    p = dim + n_rot
    eye = np.eye(dim)
    nn = n[:, :, None] * n[:, None, :]
    proj = eye - nn  # tangent-plane projector P
    K = kn[:, None, None] * nn + kt[:, None, None] * proj
    # Delta = B q, B = [-I, -A_i^T, I, -A_j^T]
    A_i = _torque_arm_matrix(n, arm_i, n_rot)
    A_j = _torque_arm_matrix(n, arm_j, n_rot)
    B = np.zeros((m, dim, 2 * p))
    B[:, :, :dim] = -eye
    B[:, :, dim:p] = -A_i.transpose(0, 2, 1)
    B[:, :, p:p + dim] = eye
    B[:, :, p + dim:] = -A_j.transpose(0, 2, 1)
    B[wall, :, p:] = 0.0
    blocks = np.einsum("mak,mab,mbl->mkl", B, K, B, optimize=True)
    blocks = 0.5 * (blocks + blocks.transpose(0, 2, 1))  # exactly symmetric despite roundoff
    if prestress and dim > 1:
        blocks += _geometric_blocks(c, keep, n, proj, wall, delta, arm_i, arm_j,
                                    packing.radius, n_rot)
    # the blocks of the selected contact sub-models that have their own (granwave.contact_models)
    CM.linear_blocks(blocks, CO.values_of_attrs(packing.attrs), n, wall, packing.radius[ii], packing.radius[jj],
                     dim, p)
    return keep, blocks


def _geometric_blocks(c, keep, n, proj, wall, delta, arm_i, arm_j, radius, n_rot):
    """-d(generalized force)/dq from the stored forces (docs/linear.md, "Prestress").

    With dr = u_j - u_i (wall: dr = -u_i), dn = P dr / r, d(arm) = c_a n.dr
    (c_a = 1/2 between grains, 1 against a wall) and the stored F_t carried
    into the new tangent plane, dF_t = -(F_t . dn) n:
      df_i   = [-(F_n/r) P - (1/r) n F_t^T] dr        (zero for walls: dn = 0)
      dtau_i = [c_a (n x F_t) n^T + (a_i/r) X(F_t) P] dr,   X(F) w = w x F
      df_j = -df_i,  dtau_j likewise with a_j.
    """
    m, dim = n.shape
    p = dim + n_rot
    fn = c.force_normal[keep]
    ft = np.asarray(c.force_tangential[keep], float).reshape(m, dim)
    ii = c.i[keep]
    jj = np.where(wall, 0, c.j[keep])
    dist = np.where(wall, np.inf, radius[ii] + radius[jj] - delta)
    inv_r = np.where(wall, 0.0, 1.0 / dist)
    c_a = np.where(wall, 1.0, 0.5)
    G_f = -(fn * inv_r)[:, None, None] * proj - inv_r[:, None, None] * (n[:, :, None] * ft[:, None, :])
    nxft = _cross_vec(n, ft, n_rot)  # (m, n_rot)
    X = _cross_with(ft, n_rot)  # (m, n_rot, dim)
    XP = np.einsum("mrd,mde->mre", X, proj)
    base = (c_a[:, None, None] * nxft[:, :, None] * n[:, None, :])
    H_i = base + (arm_i * inv_r)[:, None, None] * XP
    H_j = base + (arm_j * inv_r)[:, None, None] * XP
    # rows (f_i, tau_i, f_j, tau_j) as functions of dr; dr = T q, T = [-I, 0, I, 0]
    rows = np.zeros((m, 2 * p, dim))
    rows[:, :dim] = G_f
    rows[:, dim:p] = H_i
    rows[:, p:p + dim] = -G_f
    rows[:, p + dim:] = H_j
    geo = np.zeros((m, 2 * p, 2 * p))
    geo[:, :, :dim] = rows  # d/du_i of dr is -I; D = -d(force)/dq
    geo[:, :, p:p + dim] = -rows
    geo[wall, p:, :] = 0.0
    geo[wall, :, p:] = 0.0
    return geo


def dof_map(packing: Packing, n_rot: int):
    """Full dof layout: (first dof of each grain or -1 for rattlers, dof_grain, dof_axis)."""
    c = packing.contacts
    carrying = c.force_normal > 0.0
    active = np.zeros(packing.n_grains, bool)
    active[c.i[carrying]] = True
    jc = c.j[carrying]
    active[jc[jc >= 0]] = True
    p = packing.dim + n_rot
    grains = np.flatnonzero(active)
    first = np.full(packing.n_grains, -1, np.int64)
    first[grains] = p * np.arange(len(grains))
    dof_grain = np.repeat(grains, p).astype(np.int64)
    dof_axis = np.tile(np.arange(p), len(grains)).astype(np.int64)
    return first, dof_grain, dof_axis


#: dof_axis codes of the two rotations kept for a grain whose free spin is removed (3D).
SPIN_REDUCED_AXES = S.SPIN_REDUCED_AXES


def spin_basis(axis: np.ndarray) -> np.ndarray:
    """(k, 2, 3) orthonormal pair normal to each unit spin axis (k, 3), right-handed with it.

    Deterministic: the first vector is e x (the coordinate axis least aligned with e),
    normalized; the second e x first.
    """
    e = np.asarray(axis, float).reshape(-1, 3)
    ref = np.eye(3)[np.argmin(np.abs(e), axis=1)]
    b1 = np.cross(e, ref)
    b1 /= np.linalg.norm(b1, axis=1)[:, None]
    b2 = np.cross(e, b1)
    return np.stack([b1, b2], axis=1)


def free_spins(packing: Packing, n_rot: int) -> tuple[np.ndarray, np.ndarray]:
    """Grains with exactly two force-carrying contacts (3D, rotations on) and their spin axes.

    Returns ``(grains, axes)``: the unit vector along r2 - r1, r_k the contact
    point seen from the grain's centre (arm along the outward normal, the arms
    of :func:`contact_blocks`). Two contacts at the same point (no line) are
    not a spin: such grains are skipped.
    """
    if packing.dim != 3 or n_rot != 3:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    c = packing.contacts
    keep = np.flatnonzero(c.force_normal > 0.0)
    wall = c.j[keep] < 0
    ii = c.i[keep]
    jj = c.j[keep]
    delta = c.overlap[keep]
    n = np.asarray(c.normal[keep], float).reshape(len(keep), 3)
    R = packing.radius
    arm_i = np.where(wall, R[ii] - delta, R[ii] - 0.5 * delta)
    # contact points seen from each end: from i along +n, from j along -n
    owner = np.concatenate([ii, jj[~wall]])
    point = np.concatenate([arm_i[:, None] * n,
                            -(R[jj[~wall]] - 0.5 * delta[~wall])[:, None] * n[~wall]])
    count = np.bincount(owner, minlength=packing.n_grains)
    grains = np.flatnonzero(count == 2)
    order = np.argsort(owner, kind="stable")
    start = np.concatenate([[0], np.cumsum(count)])[grains]
    d = point[order[start + 1]] - point[order[start]]
    length = np.linalg.norm(d, axis=1)
    ok = length > 1e-12 * R[grains]
    return grains[ok].astype(np.int64), d[ok] / length[ok, None]


@dataclass
class DofLayout:
    """The dofs of a linear system and the map from them to the full per-grain layout.

    ``full_first`` / ``n_full``: every non-rattler grain with p = dim + n_rot
    dofs (what the contact blocks act on). ``T`` (n_full x n_dof, CSR): full
    dof vector = T @ reduced one; the identity unless free spins are removed.
    ``first``: first reduced dof of each grain (-1 for rattlers); the
    translations are ``first + axis`` for axis < dim in both layouts.
    """

    full_first: np.ndarray
    n_full: int
    T: sp.csr_matrix
    first: np.ndarray
    dof_grain: np.ndarray
    dof_axis: np.ndarray
    spin_grains: np.ndarray
    spin_axes: np.ndarray

    @property
    def reduced(self) -> bool:
        return len(self.spin_grains) > 0

    def to_reduced(self, D: sp.spmatrix) -> sp.csr_matrix:
        """T^T D T (the identity map when nothing is removed)."""
        return sp.csr_matrix(D) if not self.reduced else (self.T.T @ D @ self.T).tocsr()


def dof_layout(packing: Packing, n_rot: int, *, remove_spins: bool = True) -> DofLayout:
    """Dofs of the linear system: rattlers out and (3D) free spins out (module docstring)."""
    full_first, full_grain, full_axis = dof_map(packing, n_rot)
    n_full = len(full_grain)
    spins, axes = free_spins(packing, n_rot) if remove_spins else (np.zeros(0, np.int64), np.zeros((0, 3)))
    if not len(spins):
        T = sp.identity(n_full, format="csr")
        return DofLayout(full_first, n_full, T, full_first.copy(), full_grain, full_axis, spins, axes)
    dim = packing.dim
    p = dim + n_rot
    is_spin = np.zeros(packing.n_grains, bool)
    is_spin[spins] = True
    per_grain = np.where(full_first >= 0, np.where(is_spin, p - 1, p), 0)
    first = np.where(full_first >= 0, np.cumsum(per_grain) - per_grain, -1).astype(np.int64)
    grains = np.flatnonzero(full_first >= 0)
    dof_grain = np.repeat(grains, per_grain[grains]).astype(np.int64)
    dof_axis = np.concatenate([np.arange(p) if not is_spin[g] else
                               np.r_[np.arange(dim), SPIN_REDUCED_AXES] for g in grains]).astype(np.int64)
    rows, cols, vals = [], [], []
    keep = ~is_spin[dof_grain] | (dof_axis < dim)  # dofs copied one to one
    red = np.flatnonzero(keep)
    rows.append(full_first[dof_grain[red]] + dof_axis[red]); cols.append(red); vals.append(np.ones(len(red)))
    basis = spin_basis(axes)  # (k, 2, 3)
    for slot in range(2):
        red = first[spins] + dim + slot
        for comp in range(3):
            rows.append(full_first[spins] + dim + comp); cols.append(red); vals.append(basis[:, slot, comp])
    T = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_full, len(dof_grain)))
    return DofLayout(full_first, n_full, T, first, dof_grain, dof_axis, spins, axes)


def rotation_axes(system: LinearSystem) -> np.ndarray:
    """(n_dof, 3) unit axis of each rotation dof of a 3D system (zero rows for translations).

    Rotation dofs 3, 4, 5 turn about x, y, z; 6 and 7 about the pair
    :func:`spin_basis` of the grain's removed spin axis (``attrs``).
    """
    dim = int(system.attrs["dim"])
    out = np.zeros((system.n_dof, 3))
    axis = np.asarray(system.dof_axis)
    std = (axis >= dim) & (axis < 2 * dim)
    out[np.flatnonzero(std), axis[std] - dim] = 1.0
    red = np.isin(axis, SPIN_REDUCED_AXES)
    if np.any(red):
        grains = np.asarray(system.attrs["spin_removed_grains"], np.int64).ravel()
        basis = spin_basis(np.asarray(system.attrs["spin_removed_axes"], float).reshape(-1, 3))
        where = {int(g): k for k, g in enumerate(grains)}
        for d in np.flatnonzero(red):
            out[d] = basis[where[int(system.dof_grain[d])], axis[d] - SPIN_REDUCED_AXES[0]]
    return out


def normal_direction(dim: int) -> np.ndarray:
    """The wall motion of the normal (compressional) kick: along the last axis."""
    return np.eye(dim)[dim - 1]


def shear_direction(dim: int) -> np.ndarray:
    """The wall motion of the shear kick: along x, parallel to the walls (dim >= 2)."""
    if dim < 2:
        raise InputError("a shear kick needs a 2D or 3D packing (a chain has no direction along its walls)")
    return np.eye(dim)[0]


def wall_push(packing: Packing, contacts: np.ndarray, direction: np.ndarray, n_rot: int):
    """Per wall contact: (grain i, force K w (m, dim), torque (a_i n) x K w (m, n_rot)) when the
    wall moves by the unit vector w (:func:`wall_coupling`; the DEM pulse kicks with it too)."""
    c = packing.contacts
    dim = packing.dim
    w = np.asarray(direction, float)
    n = np.asarray(c.normal[contacts], float).reshape(len(contacts), dim)
    kn = c.stiffness_normal[contacts]
    kt = c.stiffness_tangential[contacts] if packing.friction > 0.0 else np.zeros(len(contacts))
    nw = n @ w
    force = kn[:, None] * nw[:, None] * n + kt[:, None] * (w[None, :] - nw[:, None] * n)  # K w
    i = c.i[contacts]
    arm = packing.radius[i] - c.overlap[contacts]
    torque = np.einsum("mrd,md->mr", _torque_arm_matrix(n, arm, n_rot), force)
    return i, force, torque


def wall_coupling(packing: Packing, layout: "DofLayout", contacts: np.ndarray, direction: np.ndarray,
                  n_rot: int) -> np.ndarray:
    """The generalized force g (n_dof,) on the grains when a wall moves by a unit vector w.

    ``contacts``: indices of force-carrying contacts with one wall. A contact of
    grain i with a fixed wall stretches by Delta = -(u_i + theta_i x (a_i n)) (the
    contact point's motion, arm a_i = R_i - delta along the normal n from the
    grain to the wall); moving the wall by w adds w to Delta, so the grain feels
    the force K w and the torque (a_i n) x (K w), K = k_n n n^T + k_t (I - n n^T)
    (k_t only with friction): g collects [K w; A_i K w] (A_i of
    :func:`_torque_arm_matrix`, as in :func:`contact_blocks`). The same vector
    read the other way is the detector: the force along w that the grains exert
    on that wall is g . u (the contact point's motion through K, projected on w).
    Normal kick, flat wall (n = -+ w): g = k_n w, no torque (the former source and
    detector, bit for bit); shear kick (w = e_x): k_t on x and the torque a_i k_t
    of the contact point dragged by the wall (docs/method.md §8). Free spins (3D)
    are folded in by T^T, as forces are.
    """
    dim = packing.dim
    i, force, torque = wall_push(packing, contacts, direction, n_rot)
    g = np.zeros(layout.n_full)
    first = layout.full_first[i]
    for a in range(dim):
        np.add.at(g, first + a, force[:, a])
    for r in range(n_rot):
        np.add.at(g, first + dim + r, torque[:, r])
    return g if not layout.reduced else np.asarray(layout.T.T @ g).ravel()


def linearize(packing: Packing, *, prestress: bool = False, force: bool = False,
              check: bool = True, progress=None, remove_spins: bool = False) -> LinearSystem:
    """Build ``M u'' = -D u`` for a packing in equilibrium (docs/method.md §5).

    Parameters
    ----------
    packing : the state (positions in d, stored contact forces in E* d^2 and
        stiffnesses in E* d; a chain may carry linear springs).
    prestress : add the geometric terms so that D is minus the Jacobian of the
        frozen-history forces (docs/conventions.md); off by default.
    force : accept a packing whose ``attrs['converged']`` is False.
    check : run the symmetry / positive-semi-definiteness check and count the
        zero modes (:func:`check_stiffness`); results go into ``attrs``.
    progress : a callable taking one line of text; above ``stiffness_check.DENSE_CHECK_MAX_DOF``
        dofs it hears the assembly time and the check's method, iterations and time.
    remove_spins : constrain the free spins (3D, module docstring) by theta . e = 0, one dof
        fewer each. Off by default: every rotation is kept, the dynamics the DEM integrates,
        with a zero mode per spin (zero or slightly negative with prestress); the constraint
        also stops the grain rolling (docs/decisions/0019-free-spins-default.md).

    Returns
    -------
    LinearSystem with D (CSR, units E* d per dof pair), M (rho d^3 for
    translations, rho d^5 for rotations), dof map, sources and detector.
    """
    t0 = time.perf_counter()
    attrs = packing.attrs
    check_linearize(packing.n_grains, len(packing.contacts), packing.dim, packing.friction)
    if "converged" in attrs and not bool(attrs["converged"]) and not force:
        raise InputError("the packing is not converged (attrs converged = False); "
                         "use force=True / --force to linearize it anyway")
    packing.require_finite()
    c = packing.contacts
    dim = packing.dim
    friction = float(attrs.get("friction", 0.0))
    n_rot = n_rotations(dim, friction)
    p = dim + n_rot
    layout = dof_layout(packing, n_rot, remove_spins=remove_spins)
    n_free = len(layout.spin_grains) if remove_spins else len(free_spins(packing, n_rot)[0])
    first, dof_grain, dof_axis = layout.first, layout.dof_grain, layout.dof_axis
    n_dof = len(dof_grain)
    if n_dof == 0:
        raise InputError("the packing has no force-carrying contact: nothing to linearize")

    keep, blocks = contact_blocks(packing, prestress=prestress, n_rot=n_rot)
    D = layout.to_reduced(scatter_blocks(blocks, contact_dofs(layout.full_first, c.i[keep], c.j[keep], p),
                                         layout.n_full))

    # Mass: translations m, rotations I.
    mass = np.where(dof_axis < dim, packing.mass[dof_grain], packing.inertia[dof_grain])

    # Source and detector (docs/conventions.md, docs/method.md §8 "Shear source"): the wall
    # coupling g(w) of the bottom-wall contacts (source) and of the top-wall ones (detector),
    # w the vertical (normal kick) or x (shear kick, with friction only).
    bottom = keep[c.is_bottom[keep]]
    top = keep[c.is_top[keep]]
    if not len(bottom) or not len(top):
        raise InputError("the packing does not touch both walls: no source or no detector")
    kb = wall_coupling(packing, layout, bottom, normal_direction(dim), n_rot)
    source_velocity = kb / mass
    source_displacement = kb / c.stiffness_normal[bottom].mean()
    detector = wall_coupling(packing, layout, top, normal_direction(dim), n_rot)
    shear_velocity = shear_detector = None
    if friction > 0.0:
        shear_velocity = wall_coupling(packing, layout, bottom, shear_direction(dim), n_rot) / mass
        shear_detector = wall_coupling(packing, layout, top, shear_direction(dim), n_rot)

    out_attrs = {k: attrs[k] for k in _COPIED_ATTRS if k in attrs}
    out_attrs.update(
        dim=dim, friction=friction, pressure=float(attrs.get("pressure", np.nan)),
        height=packing.height, lateral_width=float(packing.box[0]),  # the lateral (periodic) length
        prestress=bool(prestress),
        n_rotations=n_rot, n_dof=n_dof, n_contacts=int(len(keep)),
        n_rattlers=int(packing.n_grains - len(np.unique(dof_grain))),
        n_spins_removed=int(len(layout.spin_grains)),
        spin_removed_grains=layout.spin_grains.astype(np.int64),
        spin_removed_axes=layout.spin_axes.reshape(-1),
        n_bottom_contacts=int(len(bottom)), n_top_contacts=int(len(top)),
        expected_zero_modes=expected_zero_modes(dim, friction, n_free - len(layout.spin_grains)),
        packing_seed=attrs.get("seed", "none"),
        packing_git_revision=attrs.get("git_revision", "unknown"),
        packing_source=attrs.get("source_file", "none"),
        forced_unconverged=bool("converged" in attrs and not bool(attrs["converged"])),
    )
    if dim == 3 and n_rot == 3:  # only where spins exist: other files keep their bytes
        out_attrs["n_free_spins"] = int(n_free)
    system = LinearSystem(stiffness=D, mass=mass, dof_grain=dof_grain, dof_axis=dof_axis,
                          source_velocity=source_velocity, source_displacement=source_displacement,
                          detector=detector, shear_source_velocity=shear_velocity,
                          shear_detector=shear_detector, attrs=out_attrs)
    if progress is not None and n_dof > SC.DENSE_CHECK_MAX_DOF:
        progress(f"assembled D: {n_dof} dofs, {D.nnz} non-zeros in {time.perf_counter() - t0:.1f} s")
    if check:
        system.attrs.update(check_stiffness(system, progress=progress))
    return system
