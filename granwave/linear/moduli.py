"""Elastic moduli of a confined packing, global and scale dependent (docs/method.md §6).

Everything here is a static response of the linear model of docs/method.md §5: the
grains relax non-affinely (``D u = f``) under an imposed global strain, an
imposed body force or imposed displacements, and the stress change or the
elastic energy gives a modulus. The full derivation and the choices made
where the method leaves room are in ``docs/moduli.md``; in short:

Cell, strain and stress conventions
-----------------------------------
Axes as in docs/conventions.md: lateral axes periodic, the last axis
vertical, bottom wall fixed at 0, top wall at ``box[-1]``. Cell volume
``V = L1 x L2 x 1`` (one diameter thick) in 2D, ``L1 L2 L3`` in 3D.
Compressive stress and shrinking strain count positive: a global strain is
the affine field ``u(x) = -G x`` with the displacement gradient ``G``
(``G = eps e_a e_a`` for a normal strain, ``G = 2 eps e_a e_b`` for a shear:
simple shear, the lateral displacement grows along ``b``), so that
``eps_11 > 0`` shrinks the periodic width, ``eps_22 > 0`` moves the top wall
down and ``eps_12`` moves the top wall along x by ``-2 eps_12 L2``.
The stress is docs/method.md §4's ``sigma_ab = (1/V) sum_c F^a b^b`` with ``F`` the
force exerted *by* grain i *on* its partner (minus the force on i) and ``b``
the branch vector from the centre of i to the centre of j (nearest image)
or, for a wall contact, to the contact point on the wall plane
(``b = a_i n``, ``a_i = R_i - delta``). Then ``sigma_22 = p`` for a packing
pressed by the piston, and in 2D
``sigma_11 = C11 eps_11 + C12 eps_22``, ``sigma_22 = C12 eps_11 + C22 eps_22``,
``sigma_12 = 2 C33 eps_12``. In 3D the Voigt matrix (order 11, 22, 33, 23,
13, 12; z vertical; ``sigma_4 = C_4j eps_j`` with engineering shear strains
``eps_4 = 2 eps_23`` ...) is reported; its vertical components are C33 (normal)
and C44, C55 (shear).

How a strain is imposed
-----------------------
Every force-carrying contact sees the affine relative displacement of its
contact point ``-G b`` (grain pairs across the periodic boundary through
their nearest-image branch vector; wall contacts through the motion of the
wall: the top wall moves with the affine field, the bottom wall at 0 does not
move). The grains then relax: ``D u' = f`` with ``f`` the generalized force of
the affine contact displacements; ``u'`` holds translations and, with
friction, rotations. The relaxed contact forces give the stress change;
because the model is linear the moduli do not depend on the amplitude.
With ``prestress=True`` the blocks contain the geometric terms of docs/method.md §5,
and the stress change also contains the change of the branch vectors and of
the volume (``F dB`` and ``-sigma dV/V``): the Cauchy stress increment.

Frictionless walls cannot drag a packing sideways: a shear that moves the
top wall parallel to itself would then relax completely. For the shear
loadings (global shear with the vertical, body force along a lateral axis)
the lateral degrees of freedom of the grains touching a wall are therefore
held at their affine value ("no-slip wall grains", ``grip`` below) when the
packing is frictionless; with friction the tangential wall springs do it.

Zero modes
----------
Without friction rigid lateral translations are zero modes of D; the systems ``D u = f`` are
consistent and the contact forces are the same for every solution. How they are solved (sparse
LU with zero-mean constraints, minimum-norm fallbacks) is :mod:`granwave.linear.static_solve`'s;
the fraction of the load left unbalanced, ``||D u - f|| / ||f||``, is reported per kind of
loading (``global_unbalanced``, ``body_force_unbalanced``, ``lines_unbalanced``). The
dofs are those of ``linearize`` with rattlers and, in 3D, the free spins of
two-contact grains removed (:func:`granwave.linear.assemble.dof_layout`): a free
spin costs no energy and no load acts on it, so removing it changes no modulus
and keeps D regular (a linear system that keeps the spins is checked after the
same reduction). The solver used is reported in ``attrs``-like keys of the result.

Scale-dependent moduli (``local=True``)
---------------------------------------
(a) Body force: every non-rattler grain i receives the force
``f0 sin(n pi y_i / L2) V_i / Phi3*`` along x (shear type) or y (normal
type), ``V_i`` the grain's volume; ``sum_i V_i / Phi3* = V``, so ``f0`` is a
force per unit volume. Walls fixed. The continuum solution of
``C u'' = -f0 sin(n pi y/L2)`` with ``u(0) = u(L2) = 0`` stores
``W = L1 L2^3 f0^2 / (4 n^2 pi^2 C)`` (2D, thickness 1; in 3D ``L1 L2 L3^3``),
so the apparent modulus is ``C = L1 L2^3 f0^2 / (4 n^2 pi^2 W)``, with
``W = u^T D u / 2`` of the relaxed linear model. n = 1, 2.
(b) Lines: n + 2 equally spaced horizontal lines ``y_k = k H/(n+1)``,
k = 0..n+1 (the outer two are the wall planes; the walls stay fixed). The
continuum reference field is 0 on even lines, ``+u0`` on k = 1, 5, ...,
``-u0`` on k = 3, 7, ..., linear in between; every non-rattler grain crossed
by an interior line (``|y_i - y_k| < R_i``, 0 < k < n+1) gets that field at
its own centre along x (shear type) or y (normal type); the wall-touching
grains are free (frictionless shear: held at the field value, as ``grip``);
every other degree of freedom (including rotations) relaxes. A continuum with
that piecewise-linear displacement stores ``W = (n+1)^2 L1 C u0^2 / (2 L2)``
(3D: ``L1 L2``), which defines C. n = 1, 3.
Both are reported as ratios to the global normal (C22; 3D C33) and shear
(C33; 3D C55) moduli.

Bulk slab
---------
The whole cell's moduli include the layers at the two walls, softer and less dense than the
bulk. Under the vertical normal strain and the wall shears nothing acts inside the column, so
the traction on every horizontal plane is the cell's stress change; the strain of the slab
``layer <= y <= H - layer`` is the least-squares slope of its grains' total displacements
against y. Slab modulus = cell modulus x imposed strain / slab strain (``C22_slab``,
``C33_slab``; 3D ``C33_slab``, ``C44_slab``, ``C55_slab``). Its density ``phi3_star_slab`` is
the volume between the same planes of the same grains (those of D and M: the rattler rule of
the linear model), so ``c_l_slab = sqrt(C22_slab / phi3_star_slab)`` uses one volume and one
rattler rule. On a triangular lattice C22_slab is the bulk value K h / l exactly (tested).

Phi3* (the mass density entering the sound speeds c_l = sqrt(C22/Phi3*),
c_t = sqrt(C33/Phi3*)) is docs/method.md §4's bulk value from
:func:`granwave.analysis.statics.statics` (slab excluding ``layer`` next to each
wall, its rattler rule); when the cell has no bulk slab, the whole-cell value.
The body force is normalized with the whole-cell value ``phi3_star_cell``
(volume of the non-rattler spheres / V, rattlers = grains without a
force-carrying contact, as in D), so that ``sum_i V_i / Phi3* = V`` exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError
from ..geometry import grain_measure
from ..model import LinearSystem, Packing
from ..params import BULK_LAYER
from .assemble import contact_blocks, contact_dofs, dof_layout, n_rotations, scatter_blocks
from .static_solve import StaticSolver as _Solver

#: Default strain (and body-force / displacement) amplitude. The model is linear:
#: the moduli do not depend on it (tested).
DEFAULT_AMPLITUDE = 1e-6


# ----------------------------------------------------------------------------- cell data
@dataclass
class _Cell:
    """Per-contact data of a packing in the form the moduli need."""

    dim: int
    n_rot: int
    p: int  # dofs per grain
    box: np.ndarray
    volume: float
    friction: float
    prestress: bool
    ii: np.ndarray  # (M,) grain i
    jj: np.ndarray  # (M,) grain j (0 for walls)
    wall: np.ndarray  # (M,) bool
    normal: np.ndarray  # (M, dim)
    branch: np.ndarray  # (M, dim) centre of i -> centre of j (wall: -> contact point)
    force_i: np.ndarray  # (M, dim) stored force on i
    blocks: np.ndarray  # (M, 2p, 2p)
    first: np.ndarray  # (N,) first dof of each grain, -1 for rattlers
    dof_grain: np.ndarray
    dof_axis: np.ndarray
    stiffness: sp.csr_matrix  # D assembled from the same blocks
    idx: np.ndarray  # (M, 2p) full-layout dof index of each block row, -1 for wall halves
    layout: object  # granwave.linear.assemble.DofLayout: full dofs = layout.T @ dofs
    grain_volume: np.ndarray  # (N,)
    active: np.ndarray  # (N,) bool, non-rattler
    position: np.ndarray  # (N, dim)
    radius: np.ndarray  # (N,)
    touches_wall: np.ndarray  # (N,) bool
    solvers: dict = field(default_factory=dict)
    unbalanced: dict = field(default_factory=dict)  # loading kind -> largest unbalanced fraction
    relaxed: dict = field(default_factory=dict)  # (a, b, amplitude, held) -> relaxed u of a strain

    @property
    def n_dof(self) -> int:
        return len(self.dof_grain)

    @property
    def phi3_star(self) -> float:
        return float(self.grain_volume[self.active].sum() / self.volume)


def _check_packing(packing: Packing) -> None:
    if packing.dim not in (2, 3):
        raise InputError(f"elastic moduli need a 2D or 3D packing (got dim = {packing.dim})")
    packing.require_finite()
    c = packing.contacts
    if np.any(packing.box <= 0):
        raise InputError("packing box sizes must be positive")
    keep = c.force_normal > 0
    if not np.any(keep & c.is_bottom) or not np.any(keep & c.is_top):
        raise InputError("the packing does not touch both walls: no strain can be imposed")


def _cell(packing: Packing, prestress: bool) -> _Cell:
    _check_packing(packing)
    dim = packing.dim
    friction = float(packing.attrs.get("friction", 0.0))
    n_rot = n_rotations(dim, friction)
    p = dim + n_rot
    keep, blocks = contact_blocks(packing, prestress=prestress, n_rot=n_rot)
    c = packing.contacts
    wall = c.j[keep] < 0
    ii = c.i[keep]
    jj = np.where(wall, 0, c.j[keep])
    n = np.asarray(c.normal[keep], float).reshape(len(keep), dim)
    delta = c.overlap[keep]
    R = packing.radius
    # Branch vector: centre-to-centre (R_i + R_j - delta) n, wall: a_i n with a_i = R_i - delta;
    # along the stored normal that D's blocks use (statics.branch_vectors takes the positions).
    length = np.where(wall, R[ii] - delta, R[ii] + R[jj] - delta)
    branch = length[:, None] * n
    force_i = (-c.force_normal[keep][:, None] * n
               + np.asarray(c.force_tangential[keep], float).reshape(len(keep), dim))
    layout = dof_layout(packing, n_rot)  # rattlers and (3D) free spins removed, as in linearize
    first, dof_grain, dof_axis = layout.first, layout.dof_grain, layout.dof_axis
    idx = contact_dofs(layout.full_first, ii, np.where(wall, -1, jj), p)
    D = layout.to_reduced(scatter_blocks(blocks, idx, layout.n_full))
    volume = float(np.prod(packing.box))  # 2D: L1 x L2 x one diameter
    active = first >= 0
    touches = np.zeros(packing.n_grains, bool)
    touches[ii[wall]] = True
    return _Cell(dim=dim, n_rot=n_rot, p=p, box=np.asarray(packing.box, float), volume=volume,
                 friction=friction, prestress=prestress, ii=ii, jj=jj, wall=wall, normal=n,
                 branch=branch, force_i=force_i, blocks=blocks, first=first,
                 dof_grain=dof_grain, dof_axis=dof_axis, stiffness=D, idx=idx, layout=layout,
                 grain_volume=grain_measure(R, 3), active=active,
                 position=np.asarray(packing.position, float), radius=np.asarray(R, float),
                 touches_wall=touches)


def _note(cell: _Cell, kind: str, solver: _Solver) -> None:
    """Keep the largest unbalanced load fraction per loading kind (global, body_force, lines)."""
    cell.unbalanced[kind] = max(cell.unbalanced.get(kind, 0.0), solver.unbalanced)


def _solver(cell: _Cell, fixed: np.ndarray) -> _Solver:
    key = fixed.tobytes()
    if key not in cell.solvers:
        cell.solvers[key] = _Solver(cell, fixed)
    return cell.solvers[key]


def _gather(cell: _Cell, u: np.ndarray) -> np.ndarray:
    """(M, 2p) block vectors q = (u_i, theta_i, u_j, theta_j) from a dof vector (walls: 0)."""
    full = cell.layout.T @ u if cell.layout.reduced else u
    ext = np.concatenate([full, [0.0]])
    return ext[np.where(cell.idx >= 0, cell.idx, len(full))]


def _scatter(cell: _Cell, g: np.ndarray) -> np.ndarray:
    """Dof vector summing per-contact generalized forces g (M, 2p) (wall halves dropped)."""
    out = np.zeros(cell.layout.n_full)
    ok = cell.idx >= 0
    np.add.at(out, cell.idx[ok], g[ok])
    return cell.layout.T.T @ out if cell.layout.reduced else out


# ----------------------------------------------------------------------------- global moduli
def _strain_components(dim: int):
    """Voigt order: (a, b) pairs; normal first, then shears (vertical ones first in 3D)."""
    if dim == 2:
        return [(0, 0), (1, 1), (0, 1)]
    return [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]


def _gradient(dim: int, a: int, b: int) -> np.ndarray:
    """Displacement gradient G of u = -G x for a unit strain eps_ab (shrinking positive).

    Normal: G = e_a e_a. Shear (a < b): simple shear G = 2 e_a e_b, the
    displacement along a growing along b (b vertical for the wall shears).
    """
    G = np.zeros((dim, dim))
    G[a, b] = 1.0 if a == b else 2.0
    return G


def _affine_q(cell: _Cell, G: np.ndarray) -> np.ndarray:
    """Per-contact q (M, 2p) carrying the affine relative displacement -G b.

    Only relative displacements matter (every block annihilates a common
    translation of i and j): grain pairs get it on the j half, wall contacts
    (relative displacement = -u_i) as +G b on the i half.
    """
    dim, p = cell.dim, cell.p
    d = cell.branch @ G.T  # G b per contact
    q = np.zeros((len(cell.ii), 2 * p))
    q[~cell.wall, p:p + dim] = -d[~cell.wall]
    q[cell.wall, :dim] = d[cell.wall]
    return q


def _relative_translation(cell: _Cell, q: np.ndarray) -> np.ndarray:
    """Relative translation of j (or of the wall) with respect to i, per contact."""
    dim, p = cell.dim, cell.p
    return np.where(cell.wall[:, None], -q[:, :dim], q[:, p:p + dim] - q[:, :dim])


def static_stress(cell: _Cell) -> np.ndarray:
    """sigma_ab = (1/V) sum_c (-f_i)^a b^b over force-carrying contacts (compression > 0)."""
    return -(cell.force_i.T @ cell.branch) / cell.volume


def _stress_change(cell: _Cell, q: np.ndarray, dlog_volume: float) -> np.ndarray:
    """Stress increment for the total per-contact displacement q (M, 2p)."""
    gen = -np.einsum("mkl,ml->mk", cell.blocks, q)
    df_i = gen[:, :cell.dim]
    ds = -(df_i.T @ cell.branch) / cell.volume
    if cell.prestress:
        rel = _relative_translation(cell, q)
        dbranch = np.where(cell.wall[:, None],
                           np.sum(rel * cell.normal, axis=1)[:, None] * cell.normal, rel)
        ds = ds - (cell.force_i.T @ dbranch) / cell.volume - static_stress(cell) * dlog_volume
    return ds


def _grip_mask(cell: _Cell) -> np.ndarray:
    """Lateral translation dofs of grains touching a wall (the no-slip wall grains)."""
    g = cell.touches_wall[cell.dof_grain]
    return g & (cell.dof_axis < cell.dim - 1)


def _use_grip(cell: _Cell, grip: bool | None) -> bool:
    return (cell.friction <= 0.0) if grip is None else bool(grip)


def _respond(cell: _Cell, G: np.ndarray, amplitude: float, fixed: np.ndarray):
    """Relax under the affine strain amplitude * G; returns (stress change / amplitude, u', method)."""
    q_aff = amplitude * _affine_q(cell, G)
    f = _scatter(cell, -np.einsum("mkl,ml->mk", cell.blocks, q_aff))
    solver = _solver(cell, fixed)
    u, method = solver.solve(f[solver.free], np.zeros(int(fixed.sum())))
    _note(cell, "global", solver)
    q = q_aff + _gather(cell, u)
    dlogv = -amplitude * float(np.trace(G)) if np.allclose(G, np.diag(np.diag(G))) else 0.0
    ds = _stress_change(cell, q, dlogv) + _grip_virial(cell, fixed, cell.stiffness @ u - f)
    return ds / amplitude, u, method


def _grip_virial(cell: _Cell, fixed: np.ndarray, reaction: np.ndarray) -> np.ndarray:
    """Virial of the forces that hold the no-slip wall grains (like wall contacts).

    The holding force on a held dof is ``D u' - f`` there; it acts as if
    transmitted by the nearer wall at the foot of the perpendicular from the
    grain's centre, branch vector ``(0, .., -y_i)`` (bottom) or
    ``(0, .., H - y_i)`` (top).
    """
    out = np.zeros((cell.dim, cell.dim))
    dofs = np.flatnonzero(fixed)
    if not len(dofs):
        return out
    vertical = cell.dim - 1
    H = cell.box[vertical]
    g = cell.dof_grain[dofs]
    a = cell.dof_axis[dofs]
    y = cell.position[g, vertical]
    b_vert = np.where(y < 0.5 * H, -y, H - y)
    lateral = a < cell.dim
    np.add.at(out, (a[lateral], np.full(int(lateral.sum()), vertical)),
              -reaction[dofs][lateral] * b_vert[lateral] / cell.volume)
    return out


def _voigt_pairs(dim: int):
    return _strain_components(dim)


def global_response(cell: _Cell, *, amplitude: float = DEFAULT_AMPLITUDE,
                    grip: bool | None = None) -> tuple[np.ndarray, list[str]]:
    """Voigt stiffness matrix C (3x3 in 2D, 6x6 in 3D) and the solver used per strain."""
    dim = cell.dim
    pairs = _strain_components(dim)
    nv = len(pairs)
    C = np.zeros((nv, nv))
    methods = []
    vertical = dim - 1
    for col, (a, b) in enumerate(pairs):
        G = _gradient(dim, a, b)
        fixed = np.zeros(cell.n_dof, bool)
        if a != b and b == vertical and _use_grip(cell, grip):
            fixed = _grip_mask(cell)
        ds, u, method = _respond(cell, G, amplitude, fixed)
        cell.relaxed[(a, b, amplitude, bool(fixed.any()))] = u  # the bulk slab reads its strain here
        methods.append(method)
        # sigma_cd with F along c and b along d (d vertical for the wall shears): the
        # traction on planes normal to d, energy-conjugate to the simple shear G_cd.
        for row, (c_, d_) in enumerate(pairs):
            C[row, col] = ds[c_, d_]
        if a != b:
            C[:, col] *= 0.5  # engineering shear strain 2 eps_ab
    return C, methods


# ----------------------------------------------------------------------------- bulk slab
#: Thinnest slab (d) whose strain is measured; thinner: no slab moduli (NaN).
SLAB_MIN_THICKNESS = 1.0


def slab_bounds(cell: _Cell, layer: float) -> tuple[float, float] | None:
    """The bulk slab ``layer <= y <= H - layer`` (d), or None when it is thinner than
    ``SLAB_MIN_THICKNESS``."""
    H = float(cell.box[-1])
    lo, hi = float(layer), H - float(layer)
    return (lo, hi) if hi - lo >= SLAB_MIN_THICKNESS else None


def slab_grains(cell: _Cell, lo: float, hi: float) -> np.ndarray:
    """Grains the linear model moves (non-rattlers: those with dofs in D and M) whose centre
    lies in the slab."""
    y = cell.position[:, -1]
    return np.flatnonzero(cell.active & (y >= lo) & (y <= hi))


def slab_density(cell: _Cell, lo: float, hi: float) -> float:
    """Phi3* of the slab: the volume between the planes lo and hi of the grains the linear model
    moves (the rattler rule of D and M), over L1 (hi - lo) x 1 d (3D: L1 L2 (hi - lo))."""
    from ..analysis.statics import _amount_in_slab

    y = cell.position[cell.active, -1]
    vol = _amount_in_slab(y, cell.radius[cell.active], lo, hi, "volume")
    return float(vol.sum() / (np.prod(cell.box[:-1]) * (hi - lo)))


def slab_strain_ratio(cell: _Cell, G: np.ndarray, u: np.ndarray, axis: int, lo: float,
                      hi: float) -> tuple[float, float]:
    """(slab gradient / imposed gradient, relative standard error of the slab gradient).

    The total displacement along ``axis`` of a slab grain is the affine ``-(G x)_axis`` plus
    its relaxed translation ``u``; its slope against the height y (least squares over the
    slab grains) is the slab's gradient, to be compared with the imposed ``-G[axis, vertical]``.
    The standard error assumes independent residuals (the non-affine displacements are
    correlated in space, so it is a lower bound).
    """
    vertical = cell.dim - 1
    grains = slab_grains(cell, lo, hi)
    if grains.size < 3:
        return math.nan, math.nan
    y = cell.position[grains, vertical]
    total = -(cell.position[grains] @ G.T)[:, axis] + u[cell.first[grains] + axis]
    slope, intercept = np.polyfit(y, total, 1)
    imposed = -G[axis, vertical]
    resid = total - (slope * y + intercept)
    spread = float(np.sum((y - y.mean()) ** 2))
    err = math.sqrt(float(resid @ resid) / max(grains.size - 2, 1) / spread) if spread > 0 else math.nan
    return float(slope / imposed), (err / abs(slope) if slope != 0 else math.nan)


def slab_response(cell: _Cell, C: np.ndarray, lo: float, hi: float, *,
                  amplitude: float = DEFAULT_AMPLITUDE, grip: bool | None = None) -> dict:
    """Moduli of the bulk slab for the loadings whose stress is uniform along the column.

    Under the vertical normal strain and the wall shears no force acts inside the column, so
    the traction on every horizontal plane, the stress change ``C eps`` of the whole cell, is
    the same in the slab; the slab's strain is read from its grains' displacements
    (:func:`slab_strain_ratio`). Modulus of the slab = whole-cell modulus / (slab strain /
    imposed strain). ``C`` from :func:`global_response` of the same cell (Voigt, E*).

    Returns {Voigt key: (modulus, strain ratio, relative error of the slab gradient)}: 2D
    ``C22`` (vertical normal) and ``C33`` (shear); 3D ``C33``, ``C44`` (yz), ``C55`` (xz).
    """
    dim = cell.dim
    vertical = dim - 1
    pairs = _strain_components(dim)
    names = {2: {(1, 1): "C22", (0, 1): "C33"},
             3: {(2, 2): "C33", (1, 2): "C44", (0, 2): "C55"}}[dim]
    out = {}
    for col, (a, b) in enumerate(pairs):
        if b != vertical:
            continue
        G = _gradient(dim, a, b)
        fixed = _grip_mask(cell) if (a != b and _use_grip(cell, grip)) else np.zeros(cell.n_dof, bool)
        u = cell.relaxed.get((a, b, amplitude, bool(fixed.any())))
        if u is None:
            _, u, _ = _respond(cell, G, amplitude, fixed)
        ratio, err = slab_strain_ratio(cell, G, u / amplitude, a, lo, hi)
        value = C[col, col] / ratio if ratio > 0 else math.nan
        out[names[(a, b)]] = (float(value), float(ratio), float(err))
    return out


# ----------------------------------------------------------------------------- local moduli
def _energy(cell: _Cell, u: np.ndarray) -> float:
    D = cell.stiffness
    return 0.5 * float(u @ (D @ u) if not cell.prestress else u @ (0.5 * (D + D.T) @ u))


def body_force_modulus(cell: _Cell, *, axis: int, n: int, amplitude: float = DEFAULT_AMPLITUDE,
                       grip: bool | None = None) -> float:
    """Apparent modulus from a sinusoidal body force along ``axis`` (docs/method.md §6 (a)).

    A body force on floppy grains (free to move at no energy cost) cannot be
    balanced: that part is dropped (least-squares solution) and the largest
    dropped fraction ||D u - f||/||f|| is reported as ``body_force_unbalanced``.
    """
    dim = cell.dim
    vertical = dim - 1
    H = cell.box[vertical]
    area = float(np.prod(cell.box[:-1]))  # L1 (x one diameter) in 2D
    phi = cell.phi3_star
    y = cell.position[:, vertical]
    f_grain = amplitude * np.sin(n * np.pi * y / H) * cell.grain_volume / phi
    f = np.zeros(cell.n_dof)
    sel = cell.dof_axis == axis
    f[sel] = f_grain[cell.dof_grain[sel]]
    fixed = np.zeros(cell.n_dof, bool)
    if axis != vertical and _use_grip(cell, grip):
        fixed = _grip_mask(cell)
        f[fixed] = 0.0
    solver = _solver(cell, fixed)
    u, _ = solver.solve(f[solver.free], np.zeros(int(fixed.sum())), consistent=False)
    _note(cell, "body_force", solver)
    W = _energy(cell, u)
    return area * H**3 * amplitude**2 / (4.0 * n**2 * np.pi**2 * W) if W > 0 else float("inf")


def line_field(y: np.ndarray, H: float, n: int) -> np.ndarray:
    """The continuum reference field of the line loading, per unit u0, at heights ``y``.

    Piecewise linear between the n + 2 lines y_k = k H / (n + 1), with the
    value 0 on even k (the walls k = 0 and n + 1 included), +1 on k = 1, 5, ...
    and -1 on k = 3, 7, ...
    """
    k = np.arange(n + 2)
    value = np.where(k % 2 == 0, 0.0, np.where((k // 2) % 2 == 0, 1.0, -1.0))
    return np.interp(y, k * H / (n + 1), value)


def line_grains(cell: _Cell, n: int) -> np.ndarray:
    """Non-rattler grains crossed by an interior line y_k = k H / (n + 1), k = 1 .. n."""
    vertical = cell.dim - 1
    H = cell.box[vertical]
    y = cell.position[:, vertical]
    crossed = np.zeros(len(y), bool)
    for k in range(1, n + 1):
        crossed |= np.abs(y - k * H / (n + 1)) < cell.radius
    return np.flatnonzero(cell.active & crossed)


def line_modulus(cell: _Cell, *, axis: int, n: int, amplitude: float = DEFAULT_AMPLITUDE,
                 grip: bool | None = None) -> float:
    """Apparent modulus from displacements imposed along n interior lines (docs/method.md §6 (b)).

    Every non-rattler grain crossed by an interior line gets, along ``axis``,
    the continuum field :func:`line_field` at its own centre (times
    ``amplitude`` = u0); the walls stay fixed, the grains touching them are
    free, everything else relaxes. For a lateral axis with ``grip`` (default:
    frictionless packings, whose walls cannot hold a grain sideways) the
    lateral dof of each wall-touching grain is held at the field at its centre
    too, as the global shear holds it at the affine value.
    W = (n + 1)^2 L1 C u0^2 / (2 H) (3D: L1 L2) defines C.
    """
    dim = cell.dim
    vertical = dim - 1
    H = cell.box[vertical]
    area = float(np.prod(cell.box[:-1]))
    y = cell.position[:, vertical]
    grains = line_grains(cell, n)
    if axis != vertical and _use_grip(cell, grip):
        grains = np.union1d(grains, np.flatnonzero(cell.active & cell.touches_wall))
    fixed = np.zeros(cell.n_dof, bool)
    value = np.zeros(cell.n_dof)
    dofs = cell.first[grains] + axis
    fixed[dofs] = True
    value[dofs] = amplitude * line_field(y[grains], H, n)
    solver = _solver(cell, fixed)
    u, _ = solver.solve(np.zeros(len(solver.free)), value[fixed])
    _note(cell, "lines", solver)
    W = _energy(cell, u)
    return 2.0 * H * W / ((n + 1) ** 2 * area * amplitude**2)


# ----------------------------------------------------------------------------- entry point
def check_matches(cell: _Cell, system: LinearSystem) -> None:
    """Refuse a linear system that was not built from this packing (same dofs and D).

    A system that keeps the free spins (``linearize``'s default) is compared after the same
    reduction as the cell's (its D restricted by theta . e = 0): static loads see no spin."""
    D = sp.csr_matrix(system.stiffness)
    lay = cell.layout
    full = np.asarray(lay.full_first)[np.asarray(system.dof_grain)] + np.asarray(system.dof_axis)
    if (lay.reduced and system.n_dof == lay.n_full and int(system.attrs.get("n_spins_removed", 0)) == 0
            and np.array_equal(full, np.arange(lay.n_full))):
        D = lay.to_reduced(D)
    elif (system.n_dof != cell.n_dof or not np.array_equal(system.dof_grain, cell.dof_grain)
            or not np.array_equal(system.dof_axis, cell.dof_axis)):
        raise InputError("the linear file does not belong to this packing (different dofs)")
    ref = sp.linalg.norm(cell.stiffness)
    diff = sp.linalg.norm(D - cell.stiffness)
    if not diff <= 1e-9 * ref:
        raise InputError("the linear file's stiffness matrix does not match this packing "
                         f"(relative difference {diff / ref:.2g})")


def _phi3_star(packing: Packing, cell: _Cell, layer: float) -> tuple[float, str]:
    """Phi3* for the sound speeds: docs/method.md §4's bulk value (granwave.analysis.statics,
    slab ``layer`` <= y <= H - ``layer``), or the whole cell when there is no bulk."""
    try:
        from ..analysis.statics import statics
        value = float(statics(packing, layer=layer)["phi3_star"])
        if math.isfinite(value) and value > 0:
            return value, f"bulk (statics, layer {layer:g})"
    except (ImportError, InputError):
        pass
    return cell.phi3_star, "whole cell (no bulk slab)"


def _slab_outputs(cell: _Cell, C: np.ndarray, layer: float, *, amplitude: float,
                  grip: bool | None) -> dict:
    """The bulk slab's moduli, density and sound speeds (keys ``*_slab``; docs/moduli.md).

    One volume and one rattler rule for all of them: the slab ``layer <= y <= H - layer``
    and the grains the linear model moves. NaN (and ``slab`` None) when the slab is thinner
    than ``SLAB_MIN_THICKNESS``.
    """
    bounds = slab_bounds(cell, layer)
    keys = ("C22", "C33") if cell.dim == 2 else ("C33", "C44", "C55")
    nan = float("nan")
    out = {"slab": None if bounds is None else [bounds[0], bounds[1]],
           "phi3_star_slab": nan, "c_l_slab": nan, "c_t_slab": nan, "n_slab_grains": 0}
    for key in keys:
        out.update({f"{key}_slab": nan, f"{key}_slab_strain_factor": nan, f"{key}_slab_fit_err": nan})
    if bounds is None:
        return out
    lo, hi = bounds
    res = slab_response(cell, C, lo, hi, amplitude=amplitude, grip=grip)
    for key, (value, ratio, err) in res.items():
        out.update({f"{key}_slab": value, f"{key}_slab_strain_factor": ratio, f"{key}_slab_fit_err": err})
    phi = slab_density(cell, lo, hi)
    normal = out[f"{keys[0]}_slab"]
    shear = out["C33_slab"] if cell.dim == 2 else 0.5 * (out["C44_slab"] + out["C55_slab"])
    out["phi3_star_slab"] = phi
    out["n_slab_grains"] = int(slab_grains(cell, lo, hi).size)
    out["c_l_slab"] = math.sqrt(normal / phi) if normal > 0 and phi > 0 else nan
    out["c_t_slab"] = math.sqrt(shear / phi) if shear > 0 and phi > 0 else nan
    return out


def moduli(packing: Packing, *, local: bool = False, prestress: bool = False,
           amplitude: float = DEFAULT_AMPLITUDE, grip: bool | None = None,
           system: LinearSystem | None = None, force: bool = False,
           layer: float = BULK_LAYER) -> dict:
    """Global (and with ``local`` the scale-dependent) elastic moduli of a packing (docs/method.md §6).

    Parameters
    ----------
    packing : a 2D or 3D packing in equilibrium (stored contact stiffnesses and forces).
    local : also compute the body-force (n = 1, 2) and line (n = 1, 3) moduli.
    prestress : include the geometric (prestress) terms in D and in the stress change.
    amplitude : strain (and body-force density / line displacement) amplitude; the
        results do not depend on it (linear model).
    grip : hold the lateral dofs of wall-touching grains in the shear loadings;
        default (None): only for frictionless packings (docs/moduli.md).
    system : optional linear system of this packing (``granwave linearize`` output);
        it is checked against the packing (same dofs, same D) and its
        ``attrs['prestress']`` is used. The contact geometry always comes from
        the packing (a linear file does not hold it).
    force : accept a packing whose ``attrs['converged']`` is False.
    layer : thickness next to each wall left out of the bulk Phi3* (docs/method.md §4) and of
        the bulk slab.

    Returns
    -------
    dict with, in 2D, ``C11, C12, C22, C33`` (E*), in 3D ``C11 C22 C33 C12 C13 C23 C44 C55
    C66`` (Voigt, z vertical), ``voigt`` (the full matrix), ``c_l``, ``c_t``
    (sqrt(E*/rho)) from ``phi3_star`` (bulk, as granwave.analysis.statics; whole
    cell when the cell has no bulk: ``phi3_star_region`` says which),
    ``phi3_star_cell`` (whole cell, normalizes the body force), ``static_stress``, the solver used,
    and with ``local`` the ratios ``C22_body_n1_ratio`` ... (3D: ``C33_...``, ``C55_...``);
    the bulk slab's ``slab`` ([lo, hi], d; None when thinner than 1 d), ``C22_slab``,
    ``C33_slab`` (3D ``C33_slab``, ``C44_slab``, ``C55_slab``) with ``*_slab_strain_factor``
    (slab strain / imposed strain) and ``*_slab_fit_err`` (relative standard error of the
    slab's slope), ``phi3_star_slab``, ``c_l_slab``, ``c_t_slab``, ``n_slab_grains``;
    ``n_spins_removed`` (3D free spins left out of the dofs) and the unbalanced load
    fractions ``global_unbalanced`` (and with ``local`` ``body_force_unbalanced``,
    ``lines_unbalanced``).
    """
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise InputError(f"amplitude must be a positive finite number (got {amplitude!r})")
    attrs = packing.attrs
    if "converged" in attrs and not bool(attrs["converged"]) and not force:
        raise InputError("the packing is not converged (attrs converged = False); "
                         "use force=True / --force to measure it anyway")
    if system is not None:
        prestress = bool(system.attrs.get("prestress", False))
    cell = _cell(packing, prestress)
    if system is not None:
        check_matches(cell, system)
    dim = cell.dim
    C, methods = global_response(cell, amplitude=amplitude, grip=grip)
    phi, region = _phi3_star(packing, cell, layer)
    out: dict = {"dim": dim}
    if dim == 2:
        out.update(C11=C[0, 0], C12=0.5 * (C[0, 1] + C[1, 0]), C22=C[1, 1], C33=C[2, 2])
        normal_key, shear_key = "C22", "C33"
        c_normal, c_shear = C[1, 1], C[2, 2]
    else:
        out.update(C11=C[0, 0], C22=C[1, 1], C33=C[2, 2],
                   C12=0.5 * (C[0, 1] + C[1, 0]), C13=0.5 * (C[0, 2] + C[2, 0]),
                   C23=0.5 * (C[1, 2] + C[2, 1]), C44=C[3, 3], C55=C[4, 4], C66=C[5, 5])
        normal_key, shear_key = "C33", "C55"
        c_normal, c_shear = C[2, 2], 0.5 * (C[3, 3] + C[4, 4])
    out["c_l"] = math.sqrt(c_normal / phi) if c_normal > 0 else float("nan")
    out["c_t"] = math.sqrt(c_shear / phi) if c_shear > 0 else float("nan")
    out["phi3_star"] = phi
    out["phi3_star_region"] = region
    out["phi3_star_cell"] = cell.phi3_star
    out.update(_slab_outputs(cell, C, layer, amplitude=amplitude, grip=grip))
    out["voigt"] = C
    out["static_stress"] = static_stress(cell)
    out["prestress"] = bool(prestress)
    out["grip_wall_grains"] = _use_grip(cell, grip)
    out["solver"] = sorted(set(methods))
    out["n_dof"] = cell.n_dof
    out["n_spins_removed"] = int(len(cell.layout.spin_grains))
    out["global_unbalanced"] = cell.unbalanced.get("global", 0.0)
    if local:
        vertical = dim - 1
        # A local measurement whose loaded sub-problem is floppy (e.g. a few rows of a
        # frictionless lattice between imposed lines) has no modulus: NaN and the reason,
        # instead of losing the global moduli and the other local ones.
        failures = {}

        def measured(key, compute):
            try:
                return compute()
            except InputError as exc:
                failures[key] = str(exc)
                return float("nan")

        for kind, axis, ref_key, ref in (("normal", vertical, normal_key, c_normal),
                                         ("shear", 0, shear_key, c_shear)):
            for n in (1, 2):
                Cb = measured(f"{ref_key}_body_n{n}", lambda: body_force_modulus(
                    cell, axis=axis, n=n, amplitude=amplitude, grip=grip))
                out[f"{ref_key}_body_n{n}"] = Cb
                out[f"{ref_key}_body_n{n}_ratio"] = Cb / ref if ref > 0 else float("nan")
            for n in (1, 3):
                Cl = measured(f"{ref_key}_lines_n{n}", lambda: line_modulus(
                    cell, axis=axis, n=n, amplitude=amplitude, grip=grip))
                out[f"{ref_key}_lines_n{n}"] = Cl
                out[f"{ref_key}_lines_n{n}_ratio"] = Cl / ref if ref > 0 else float("nan")
        out["body_force_unbalanced"] = cell.unbalanced.get("body_force", 0.0)
        out["lines_unbalanced"] = cell.unbalanced.get("lines", 0.0)
        out["local_failures"] = failures
    return out
