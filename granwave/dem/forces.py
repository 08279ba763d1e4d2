"""Contact tables and forces with frozen contact history (docs/conventions.md).

:func:`frozen_history_forces` is the contract between the DEM engine and the
linearization: forces after a small displacement and rotation of the grains
from the stored packing, with the stored contact list and tangential forces
as history, no unloading rescale and no Coulomb cap. It calls the engine's own
per-contact routine :func:`granwave.dem.kernels.contact_force` (with dt = 1
and the displacement in place of the velocity), so the two cannot diverge.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from .. import contact_models as CM
from ..contact_models import _dispatch as CD
from ..contact_models import options as CO
from ..geometry import BOTTOM_WALL, TOP_WALL, n_rotations, nearest_image
from ..model import Contacts, Packing
from . import kernels as K
from .contact_law import relative_spin
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True)
def _frozen_kernel(pos, rad, lateral, h, ci, cj, ft_stored, disp, rot, poisson, tangential, law, force, torque,
                   couple, hist_stored, damping):
    n_grains, d = pos.shape
    r = rot.shape[1]
    e_pair = C.effective_young(False)
    e_wall = C.effective_young(True)
    g_pair = C.effective_shear(poisson, False)
    g_wall = C.effective_shear(poisson, True)
    nv = np.zeros(d)
    du = np.zeros(d)
    fvec = np.zeros(d)
    ft = np.zeros(d)
    force[:, :] = 0.0
    torque[:, :] = 0.0
    for c in range(ci.shape[0]):
        i = ci[c]
        j = cj[c]
        R = rad[i]
        if j >= 0:
            r2 = 0.0
            for a in range(d):
                x = (pos[j, a] + disp[j, a]) - (pos[i, a] + disp[i, a])
                if a < d - 1:
                    x = nearest_image(x, lateral[a])
                nv[a] = x
                r2 += x * x
            dist = math.sqrt(r2)
            delta = R + rad[j] - dist
            for a in range(d):
                nv[a] /= dist
                du[a] = disp[j, a] - disp[i, a]
            ai = R - 0.5 * delta
            aj = rad[j] - 0.5 * delta
            r12 = C.effective_radius(1.0 / R, 1.0 / rad[j])
            e12 = e_pair
            g12 = g_pair
        else:
            y = pos[i, d - 1] + disp[i, d - 1]
            delta = R - y if j == BOTTOM_WALL else R - (h - y)
            for a in range(d):
                nv[a] = 0.0
                du[a] = -disp[i, a]
            nv[d - 1] = -1.0 if j == BOTTOM_WALL else 1.0
            ai = R - delta
            aj = 0.0
            r12 = R
            e12 = e_wall
            g12 = g_wall
        if delta <= 0.0:  # the contact opened: no force, history gone
            continue
        if r > 0:
            K.rotation_velocity(du, nv, rot, i, j, ai, aj)
        for a in range(d):
            ft[a] = ft_stored[c, a]
        # overlap_old = delta: no unloading rescale; the packing's tangential law without its slider
        # (models.uncapped); ``damping``: the default damping law at 0, no dashpot
        K.contact_force(nv, delta, r12, e12, g12, 1.0, du, ft, delta, 1.0, damping, tangential, fvec, np.bool_(False), law)
        for a in range(d):
            force[i, a] += fvec[a]
        if r > 0:
            K.add_torque(torque, i, ai, nv, fvec)
        if j >= 0:
            for a in range(d):
                force[j, a] -= fvec[a]
            if r > 0:
                K.add_torque(torque, j, aj, nv, fvec)
        if r > 0 and couple.code != 0:  # the couple sub-model's spring: couple c on i, -c on j
            rx, ry, rz = relative_spin(rot, i, j)
            cx, cy, cz = CD.spring_couple(couple, nv[0], nv[1], nv[2] if d == 3 else 0.0, rx, ry, rz, r12,
                                          hist_stored[c, 0], hist_stored[c, 1], hist_stored[c, 2] if d == 3 else 0.0)
            if r == 1:
                torque[i, 0] += cz
                if j >= 0:
                    torque[j, 0] -= cz
            else:
                torque[i, 0] += cx
                torque[i, 1] += cy
                torque[i, 2] += cz
                if j >= 0:
                    torque[j, 0] -= cx
                    torque[j, 1] -= cy
                    torque[j, 2] -= cz


def frozen_history_forces(packing: Packing, displacement=None, rotation=None):
    """Total force (N, dim) and torque (N, n_rot) on every grain after displacing
    the grains by ``displacement`` (N, dim) and rotating them by ``rotation``
    (N, n_rot) from the stored state (docs/conventions.md).

    Normal force: the packing's normal law (attribute ``contact_law``, Hertz when absent;
    granwave.contact_models) at the new overlap along the new normal. Tangential:
    stored F_t carried into the new tangent plane (contact.project_tangential)
    plus k_t(new overlap) times the tangential relative displacement of the
    contact point (rotation x arm included); no unloading rescale, no Coulomb
    cap. A couple sub-model (kind rolling, granwave.contact_models; e.g. ``rolling sds``): its
    ``spring_couple`` of the stored history and the rotations (no dashpot, no cap). Walls fixed; only the
    stored contacts act (a contact whose overlap becomes <= 0 gives nothing). Units: E* d^2 and
    E* d^3.
    """
    n, d = packing.position.shape
    friction = packing.friction
    r = n_rotations(d, friction)
    disp = np.zeros((n, d)) if displacement is None else np.ascontiguousarray(displacement, dtype=float)
    rot = np.zeros((n, r)) if rotation is None or r == 0 else np.ascontiguousarray(
        np.asarray(rotation, dtype=float).reshape(n, r))
    if disp.shape != (n, d):
        raise ValueError(f"displacement must have shape {(n, d)}, got {disp.shape}")
    c = packing.contacts
    force = np.zeros((n, d))
    torque = np.zeros((n, r))
    values = CO.values_of_attrs(packing.attrs)
    # the tangential law's constants with the packing's friction (0: none) and poisson
    contact = {**values, "friction": float(friction), "poisson": float(packing.attrs.get("poisson", 0.0))}
    _frozen_kernel(np.ascontiguousarray(packing.position, dtype=float),
                   np.ascontiguousarray(packing.radius, dtype=float),
                   np.ascontiguousarray(packing.box[:-1], dtype=float), float(packing.box[-1]),
                   np.ascontiguousarray(c.i, dtype=np.int64), np.ascontiguousarray(c.j, dtype=np.int64),
                   np.ascontiguousarray(c.force_tangential, dtype=float).reshape(len(c), d), disp, rot,
                   float(packing.attrs.get("poisson", 0.0)), CM.uncapped(CM.model_of("tangential", contact)),
                   CM.model_of("normal", values), force, torque, CM.couple_model(values),
                   CM.stored_couple_history(c, d), CM.damping_model(0.0))
    return force, torque


def contact_table(position, radius, lateral, height, pair_i, pair_j, pair_ft, wall_ft, *, friction,
                  poisson, law=None, couple=None, tangential=None) -> Contacts:
    """Force-carrying contacts (overlap > 0) of a state, elastic forces only, of the normal law
    ``law`` (a normal model tuple, granwave.contact_models; None: the default law); ``couple``: the
    couple sub-model's model tuple, whose history (the columns of ``pair_ft`` and ``wall_ft`` after
    the first ``dim``) is stored carried into the tangent plane.

    Pairs (sorted by i, j) first, then bottom-wall (j = -1) and top-wall (j = -2)
    contacts by grain. F_t is the history carried into the current tangent
    plane; k_t is reported as 0 for frictionless systems (no tangential spring).
    """
    n, d = position.shape
    dx = position[pair_j] - position[pair_i]
    for a in range(d - 1):
        dx[:, a] -= lateral[a] * np.round(dx[:, a] / lateral[a])
    dist = np.sqrt(np.sum(dx * dx, axis=1))
    delta = radius[pair_i] + radius[pair_j] - dist
    keep = delta > 0.0
    ci = [pair_i[keep]]
    cj = [pair_j[keep]]
    normal = [dx[keep] / dist[keep, None]]
    overlap = [delta[keep]]
    ft = [pair_ft[keep, :d]]
    keeps = pair_ft.shape[1] > d  # a couple sub-model's history after the tangential one
    rd = [pair_ft[keep, d:]]
    y = position[:, d - 1]
    for k, (j_wall, dlt) in enumerate(((BOTTOM_WALL, radius - y), (TOP_WALL, radius - (height - y)))):
        on = np.nonzero(dlt > 0.0)[0]
        ci.append(on)
        cj.append(np.full(len(on), j_wall, np.int64))
        nrm = np.zeros((len(on), d))
        nrm[:, d - 1] = -1.0 if j_wall == BOTTOM_WALL else 1.0
        normal.append(nrm)
        overlap.append(dlt[on])
        ft.append(wall_ft[2 * on + k, :d])
        rd.append(wall_ft[2 * on + k, d:])
    ci = np.concatenate(ci).astype(np.int64)
    cj = np.concatenate(cj).astype(np.int64)
    normal = np.concatenate(normal)
    overlap = np.concatenate(overlap)
    ft = np.array(np.concatenate(ft), dtype=float)
    rd = np.array(np.concatenate(rd), dtype=float) if keeps else None
    m = len(ci)
    law = CM.model_of("normal", CO.defaults()) if law is None else law
    tangential = CM.tangential_model(friction) if tangential is None else tangential
    fn = np.zeros(m)
    kn = np.zeros(m)
    kt = np.zeros(m)
    for k in range(m):
        wall = bool(cj[k] < 0)
        r12 = C.effective_radius(1.0 / radius[ci[k]], 0.0 if wall else 1.0 / radius[cj[k]])
        e12 = C.effective_young(wall)
        root = math.sqrt(r12)
        fn[k] = CM.law_force(law, overlap[k], root, e12)
        kn[k] = CM.law_stiffness(law, overlap[k], root, e12)
        if friction > 0.0:  # the tangential law's k_t (Mindlin: the normal law's)
            kt[k] = CM.tangential_spring(tangential, CM.law_tangential_stiffness(law, overlap[k], r12,
                                                                                  C.effective_shear(poisson, wall)),
                                         overlap[k], e12)
            C.project_tangential(ft[k], normal[k])
        else:
            ft[k] = 0.0
        if rd is not None:  # carried into the tangent plane, as the next step would
            n3 = np.zeros(3)
            n3[:d] = normal[k]
            h3 = np.zeros(3)
            h3[:d] = rd[k]
            rd[k] = np.array(CD.couple_in_plane(couple, *h3, *n3))[:d]
    history = {CO.KINDS[CM.COUPLE_KIND]["history"]: rd}
    return Contacts(i=ci, j=cj, normal=normal, overlap=overlap, force_normal=fn, force_tangential=ft,
                    stiffness_normal=kn, stiffness_tangential=kt, **history)


def contacts_of_engine(engine) -> Contacts:
    """The force-carrying contacts of an :class:`~granwave.dem.integrator.Engine` now."""
    m = engine.n_pairs
    return contact_table(engine.position, engine.radius, engine.lateral, engine.height,
                         engine.pair_i[:m], engine.pair_j[:m], engine.pair_ft[:m], engine.wall_ft,
                         friction=engine.friction, poisson=float(engine.fpar.poisson),
                         law=K.law_of(engine.fpar), couple=K.couple_of(engine.fpar),
                         tangential=K.friction_of(engine.fpar))


def static_residual(packing: Packing, piston_mass: float | None = None, piston_force: float | None = None):
    """Largest |F|/m, |tau|/I over the grains and |F_top - p A|/M of the piston, from the stored
    contacts alone (no velocities): the equilibrium test of a packing.

    Returns (max translational, max rotational, piston) accelerations; the piston entry is the
    relative imbalance |F_top / (p A) - 1| when ``piston_mass`` is None.
    """
    force, torque = frozen_history_forces(packing)
    a = np.sqrt(np.sum(force**2, axis=1)) / packing.mass
    al = np.sqrt(np.sum(torque**2, axis=1)) / packing.inertia if torque.shape[1] else np.zeros(1)
    c = packing.contacts
    ftop = float(np.sum(c.force_normal[c.is_top]))
    if piston_force is None:
        from ..geometry import wall_area
        piston_force = packing.pressure * wall_area(packing.box[:-1])
    ap = abs(ftop - piston_force) / piston_mass if piston_mass else abs(ftop / piston_force - 1.0)
    return float(a.max(initial=0.0)), float(al.max(initial=0.0)), float(ap)
