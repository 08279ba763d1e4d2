"""Small hand-built states and a reference force routine for checking the linear path.

These are independent of :mod:`granwave.systems` and :mod:`granwave.dem` on
purpose: the tests cross-check those modules against them, and they let the
linearization be tested on its own.

- :func:`reference_chain`: 1D chain of identical balls with linear springs K.
- :func:`reference_lattice`: perfect triangular lattice of identical Hertzian
  balls (rows parallel to the walls), contact force p/sqrt(3), wall force p.
- :func:`reference_frozen_forces`: the frozen-history forces of
  docs/conventions.md written out contact by contact in plain numpy (slow,
  for small systems only), so the prestress terms can be checked by finite
  differences even without the DEM engine.
"""

from __future__ import annotations

import math

import numpy as np

from .. import contact as law
from ..geometry import grain_inertia, grain_mass
from ..model import Contacts, Packing



def reference_chain(n_balls: int, *, stiffness: float = 1.0, pressure: float = 1e-3) -> Packing:
    """Chain of ``n_balls`` unit balls (mass pi/6) tied by springs ``stiffness`` to each other and the walls.

    Every spring carries the force ``pressure`` (chain: force = pressure x 1 d^2),
    overlap pressure/stiffness, spacing 1 - overlap.
    """
    delta = pressure / stiffness
    ell = 1.0 - delta
    n = n_balls
    pos = (0.5 - delta + ell * np.arange(n))[:, None]
    height = 2 * (0.5 - delta) + (n - 1) * ell
    i = np.concatenate([np.arange(n - 1), [0, n - 1]])
    j = np.concatenate([np.arange(1, n), [-1, -2]])
    normal = np.concatenate([np.ones(n - 1), [-1.0, 1.0]])[:, None]
    m = n + 1
    contacts = Contacts(i=i.astype(np.int64), j=j.astype(np.int64), normal=normal,
                        overlap=np.full(m, delta), force_normal=np.full(m, pressure),
                        force_tangential=np.zeros((m, 1)), stiffness_normal=np.full(m, stiffness),
                        stiffness_tangential=np.zeros(m))
    return Packing(position=pos, radius=np.full(n, 0.5), mass=grain_mass(np.full(n, 0.5)),
                   inertia=grain_inertia(np.full(n, 0.5)), box=np.array([height]), contacts=contacts,
                   attrs=dict(dim=1, pressure=pressure, friction=0.0, poisson=0.0, seed=0,
                              converged=True, max_acceleration=0.0, kind="chain",
                              spacing=ell, spring_stiffness=stiffness))


def _hertz_overlap(force: float, r12: float, e12: float) -> float:
    return (force / (4.0 / 3.0 * math.sqrt(r12) * e12)) ** (2.0 / 3.0)


def reference_lattice(rows: int, width: int, *, pressure: float, friction: float = 0.0,
                      poisson: float = 0.0) -> Packing:
    """Perfect triangular lattice, ``rows`` rows of ``width`` unit balls, periodic in x.

    Grain contacts carry p/sqrt(3) (docs/method.md §12), wall contacts p. Row r is
    shifted by half a spacing when r is odd.
    """
    if width < 3 or rows < 1:
        raise ValueError("need width >= 3 and rows >= 1")
    R = 0.5
    f = pressure / math.sqrt(3.0)
    d_g = _hertz_overlap(f, 0.25, 0.5)
    d_w = _hertz_overlap(pressure, R, 1.0)
    ell = 1.0 - d_g
    kn_g = law.normal_stiffness(d_g, 0.25, 0.5)
    kn_w = law.normal_stiffness(d_w, R, 1.0)
    kt_g = law.tangential_stiffness(d_g, 0.25, law.effective_shear(poisson, False))
    kt_w = law.tangential_stiffness(d_w, R, law.effective_shear(poisson, True))
    idx = lambda r, k: r * width + (k % width)  # noqa: E731
    ci, cj, nrm, kind = [], [], [], []
    for r in range(rows):
        for k in range(width):
            ci.append(idx(r, k)); cj.append(idx(r, k + 1)); nrm.append((1.0, 0.0)); kind.append(0)
            if r + 1 < rows:
                # neighbours above: x offsets -1/2 and +1/2
                k_left = k - 1 if r % 2 == 0 else k
                for kk, sx in ((k_left, -0.5), (k_left + 1, 0.5)):
                    ci.append(idx(r, k)); cj.append(idx(r + 1, kk))
                    nrm.append((sx, math.sqrt(3.0) / 2)); kind.append(0)
    for k in range(width):
        ci.append(idx(0, k)); cj.append(-1); nrm.append((0.0, -1.0)); kind.append(1)
        ci.append(idx(rows - 1, k)); cj.append(-2); nrm.append((0.0, 1.0)); kind.append(1)
    kind = np.array(kind)
    wall = kind == 1
    m = len(ci)
    contacts = Contacts(
        i=np.array(ci, np.int64), j=np.array(cj, np.int64), normal=np.array(nrm),
        overlap=np.where(wall, d_w, d_g), force_normal=np.where(wall, pressure, f),
        force_tangential=np.zeros((m, 2)),
        stiffness_normal=np.where(wall, kn_w, kn_g),
        stiffness_tangential=np.where(wall, kt_w, kt_g) if friction > 0 else np.zeros(m),
    )
    n = rows * width
    r_of = np.repeat(np.arange(rows), width)
    k_of = np.tile(np.arange(width), rows)
    pos = np.stack([(k_of + 0.5 * (r_of % 2)) * ell,
                    R - d_w + r_of * ell * math.sqrt(3.0) / 2], axis=1)
    box = np.array([width * ell, 2 * (R - d_w) + (rows - 1) * ell * math.sqrt(3.0) / 2])
    return Packing(position=pos, radius=np.full(n, R), mass=grain_mass(np.full(n, R)),
                   inertia=grain_inertia(np.full(n, R)), box=box, contacts=contacts,
                   attrs=dict(dim=2, pressure=pressure, friction=friction, poisson=poisson, seed=0,
                              converged=True, max_acceleration=0.0, kind="lattice",
                              rows=rows, width=width))


def _cross(a, b):
    if len(a) == 2:
        return np.array([a[0] * b[1] - a[1] * b[0]])
    return np.cross(a, b)


def _rot_cross(theta, v):
    """theta x v with theta (1,) about z in 2D or (3,) in 3D; v (dim,)."""
    if len(v) == 2:
        return theta[0] * np.array([-v[1], v[0]])
    return np.cross(theta, v)


def reference_frozen_forces(packing: Packing, displacement: np.ndarray, rotation: np.ndarray,
                            *, hertz: bool = True):
    """Frozen-history forces (docs/conventions.md), contact by contact (slow; small systems).

    The normal force is Hertz at the new overlap (``hertz=False``: the stored
    force plus k_n times the overlap change, as for linear springs); the
    stored F_t is carried into the new tangent plane (``contact.project_tangential``)
    plus k_t times the tangential relative displacement of the contact point;
    arms from the new overlap. Returns (force (N, dim), torque (N, n_rot)).
    """
    c = packing.contacts
    dim = packing.dim
    n_rot = rotation.shape[1]
    force = np.zeros((packing.n_grains, dim))
    torque = np.zeros((packing.n_grains, n_rot))
    R = packing.radius
    for k in range(len(c)):
        if c.force_normal[k] <= 0:
            continue
        i, j = int(c.i[k]), int(c.j[k])
        n0 = c.normal[k]
        wall = j < 0
        if wall:
            n1 = n0.copy()
            delta = c.overlap[k] + n0 @ displacement[i]
            arm_i, arm_j = R[i] - delta, 0.0
            rel = -displacement[i]
            th_i, th_j = rotation[i], np.zeros(n_rot)
            r12, e12 = R[i], 1.0
        else:
            dist0 = R[i] + R[j] - c.overlap[k]
            r = n0 * dist0 + displacement[j] - displacement[i]
            dist = np.linalg.norm(r)
            n1 = r / dist
            delta = R[i] + R[j] - dist
            arm_i, arm_j = R[i] - delta / 2, R[j] - delta / 2
            rel = displacement[j] - displacement[i]
            th_i, th_j = rotation[i], rotation[j]
            r12, e12 = 1.0 / (1.0 / R[i] + 1.0 / R[j]), 0.5
        if hertz:
            fn = law.normal_force(delta, r12, e12)
        else:
            fn = c.force_normal[k] + c.stiffness_normal[k] * (delta - c.overlap[k])
        ft = c.force_tangential[k].astype(float).copy()
        if dim > 1:
            law.project_tangential(ft, n1)
        if n_rot:
            # contact-point displacement of j relative to i (rotation x arm)
            rel = rel + _rot_cross(th_j, -arm_j * n1) - _rot_cross(th_i, arm_i * n1)
        slip = rel - (rel @ n1) * n1
        if packing.friction > 0 and dim > 1:
            ft = ft + c.stiffness_tangential[k] * slip
        f_i = -fn * n1 + ft
        force[i] += f_i
        if n_rot:
            torque[i] += _cross(arm_i * n1, ft)
        if not wall:
            force[j] -= f_i
            if n_rot:
                torque[j] += _cross(arm_j * n1, ft)
    return force, torque


def finite_difference_stiffness(system, forces, n_grains: int, *, eps: float = 1e-7) -> np.ndarray:
    """Dense -d(generalized force)/dq by central differences over the system's dofs.

    ``forces(displacement, rotation) -> (force, torque)`` on all grains, e.g.
    ``lambda u, t: frozen_history_forces(packing, u, t)``; ``n_grains`` all grains
    of the packing (rattlers included). Dofs follow the
    system's ``dof_grain`` / ``dof_axis``; ``eps`` in d (and radians).
    """
    dim = int(system.attrs["dim"])
    n_rot = int(system.attrs.get("n_rotations", 0))
    n = system.n_dof
    out = np.zeros((n, n))
    tr = system.dof_axis < dim
    rot = np.flatnonzero(~tr)
    if n_rot == 3:  # rotation dofs about their own axes (a removed spin leaves two of them)
        from .assemble import rotation_axes
        axes = rotation_axes(system)[rot]
    else:
        axes = np.ones((len(rot), n_rot))

    def gen_force(q):
        u = np.zeros((n_grains, dim))
        t = np.zeros((n_grains, n_rot))
        u[system.dof_grain[tr], system.dof_axis[tr]] = q[tr]
        np.add.at(t, system.dof_grain[rot], q[rot, None] * axes)
        f, tau = forces(u, t)
        g = np.empty(n)
        g[tr] = f[system.dof_grain[tr], system.dof_axis[tr]]
        g[rot] = np.sum(tau[system.dof_grain[rot]] * axes, axis=1)
        return g

    for a in range(n):
        q = np.zeros(n)
        q[a] = eps
        out[:, a] = -(gen_force(q) - gen_force(-q)) / (2 * eps)
    return out
