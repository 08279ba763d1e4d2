"""Contact sub-models: the normal law as a selectable part (docs/dem.md, "How to add a contact model").

Each law is one small module (:mod:`.hertz`, :mod:`.harmonic`) declaring its name, integer
code, parameters and five scalar ``numba`` formulas of one signature each:
``force`` and ``stiffness`` (overlap, sqrt(R12), E*12, k), ``energy`` (overlap, R12, E*12, k),
``tangential_stiffness`` (overlap, R12, G*12, k) and ``unloading_scale`` (old, new overlap),
plus ``overlap_at_force`` in Python and the constants ``IMPACT_WORK``, ``STEP_CONTACTS`` and
``LAMMPS_NORMAL``. It is registered by one line in :data:`NORMAL_LAWS`, its name in
``granwave.params.CONTACT_LAWS`` and one branch in each ``law_*`` dispatcher below.

The engines carry the selected law as a :class:`ContactModel` named tuple (the law's code
and its stiffness k), built from the engine's parameters, and call the ``law_*``
dispatchers: one compiled signature for every law, a branch on the code per call
(Hertz's arithmetic is untouched, so its bits are those before the seam). The GPU kernels
compile these same functions for the device (:mod:`granwave.gpu.compile`,
:data:`DEVICE_FUNCTIONS`).

Rolling resistance (:mod:`.rolling`) is a second sub-model beside the normal law: its own named
tuple :class:`RollingModel` (model code and coefficients), built by
``granwave.dem.contact_law.rolling_of(fpar)`` and passed to the CPU engines' loops next to the
:class:`ContactModel`, whose signature (and the GPU's device copies) it leaves alone; its
per-contact history sits in the tangential history's arrays, after their ``dim`` columns.
"""

from __future__ import annotations

from collections import namedtuple

import numba

from ..params import CONTACT_LAWS, ROLLING_MODELS
from . import harmonic, hertz, rolling
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

#: the registry: law name -> module (one line per law; its CODE is its position here)
NORMAL_LAWS = {m.NAME: m for m in (hertz, harmonic)}
assert all(m.CODE == i for i, m in enumerate(NORMAL_LAWS.values()))
assert tuple(NORMAL_LAWS) == CONTACT_LAWS, "name the law in granwave.params.CONTACT_LAWS too"
HERTZ = hertz.CODE
HARMONIC = harmonic.CODE
DEFAULT_LAW = hertz.NAME

#: What the kernels receive of the contact model: ``normal`` the normal law's code,
#: ``stiffness`` its parameter k (harmonic: k_n = k E*12, d; Hertz: unused).
ContactModel = namedtuple("ContactModel", ("normal", "stiffness"))


#: What the CPU engines receive of the rolling sub-model: ``kind`` (rolling.NONE or rolling.SDS),
#: k_r (E* d), gamma_r (d^2 sqrt(rho E*)) and mu_r.
RollingModel = namedtuple("RollingModel", ("kind", "stiffness", "damping", "friction"))
assert rolling.NAMES == ROLLING_MODELS, "name the rolling model in granwave.params.ROLLING_MODELS too"
NO_ROLLING = RollingModel(rolling.NONE, 0.0, 0.0, 0.0)


def rolling_model(name: str = "none", stiffness: float = 0.0, damping: float = 0.0,
                  friction: float = 0.0) -> RollingModel:
    """The :class:`RollingModel` of the sub-model ``name`` and its coefficients; ValueError for
    an unknown name or a stiffness that is not > 0 (sds)."""
    if name not in rolling.NAMES:
        raise ValueError(f"unknown rolling model {name!r}: choose one of {', '.join(rolling.NAMES)}")
    if name == "none":
        return NO_ROLLING
    if not float(stiffness) > 0.0 or not float(damping) >= 0.0 or not float(friction) >= 0.0:
        raise ValueError(f"rolling sds needs stiffness > 0, damping >= 0, friction >= 0, got "
                         f"{stiffness!r}, {damping!r}, {friction!r}")
    return RollingModel(rolling.NAMES.index(name), float(stiffness), float(damping), float(friction))


def rolling_of_attrs(attrs) -> RollingModel:
    """The rolling model a packing was made with, from its attributes (none recorded: none)."""
    return rolling_model(str(attrs.get("rolling", "none")), float(attrs.get("rolling_stiffness", 0.0)),
                         float(attrs.get("rolling_damping", 0.0)), float(attrs.get("rolling_friction", 0.0)))


def rolling_attrs(model: RollingModel) -> dict:
    """What a file records of a rolling model (nothing for none: files as before the sub-model)."""
    if model.kind == rolling.NONE:
        return {}
    return dict(rolling=rolling.NAMES[model.kind], rolling_stiffness=model.stiffness,
                rolling_damping=model.damping, rolling_friction=model.friction)


def history_columns(dim: int, model: RollingModel) -> int:
    """Columns of a contact's history (pair_ft, wall_ft): the tangential force's, then the rolling
    sub-model's."""
    return int(dim) + (rolling.history_width(dim) if model.kind != rolling.NONE else 0)


@numba.njit(cache=True, inline="always")
def rolling_couple(roll, nx, ny, nz, rx, ry, rz, r12, fel, hx, hy, hz, dt):
    """The rolling sub-model's couple on grain i and its new history (rolling.sds_couple's
    arguments); none: zero couple, history unchanged."""
    if roll.kind == rolling.SDS:
        return rolling.sds_couple(roll.stiffness, roll.damping, roll.friction, nx, ny, nz, rx, ry, rz, r12, fel,
                                  hx, hy, hz, dt)
    return 0.0, 0.0, 0.0, hx, hy, hz


def law_module(name: str):
    """The module of the normal law ``name``; ValueError for an unknown one."""
    try:
        return NORMAL_LAWS[name]
    except KeyError:
        raise ValueError(f"unknown contact law {name!r}: choose one of {', '.join(NORMAL_LAWS)}") from None


def law_stiffness_k(name: str, harmonic_stiffness: float = 1.0) -> float:
    """The law's k from the user's parameters: harmonic k = k_n^pair / E*12^pair = 2 k_n^pair."""
    return 2.0 * float(harmonic_stiffness) if name == harmonic.NAME else 0.0


def contact_model(name: str = DEFAULT_LAW, harmonic_stiffness: float = 1.0) -> ContactModel:
    """The :class:`ContactModel` of the law ``name`` (Python side: tests, linearization);
    ValueError for an unknown law or a harmonic stiffness that is not > 0."""
    module = law_module(name)
    if module is harmonic and not float(harmonic_stiffness) > 0.0:
        raise ValueError(f"harmonic_stiffness must be > 0, got {harmonic_stiffness!r}")
    return ContactModel(module.CODE, law_stiffness_k(name, harmonic_stiffness))


def model_of_attrs(attrs) -> ContactModel:
    """The contact model a packing was made with, from its attributes (none recorded: Hertz)."""
    return contact_model(str(attrs.get("contact_law", DEFAULT_LAW)),
                         float(attrs.get("harmonic_stiffness", 1.0)))


def name_of(model: ContactModel) -> str:
    """The law's name of a :class:`ContactModel`."""
    return list(NORMAL_LAWS)[int(model.normal)]


@numba.njit(cache=True, inline="always")
def law_force(law, overlap, root_r12, e12):
    """Elastic normal force F_n (E* d^2) of the law ``law`` (a :class:`ContactModel`)."""
    if law.normal == HARMONIC:
        return harmonic.force(overlap, root_r12, e12, law.stiffness)
    return hertz.force(overlap, root_r12, e12, law.stiffness)


@numba.njit(cache=True, inline="always")
def law_stiffness(law, overlap, root_r12, e12):
    """Normal stiffness k_n = dF_n/dn (E* d)."""
    if law.normal == HARMONIC:
        return harmonic.stiffness(overlap, root_r12, e12, law.stiffness)
    return hertz.stiffness(overlap, root_r12, e12, law.stiffness)


@numba.njit(cache=True, inline="always")
def law_energy(law, overlap, r12, e12):
    """Elastic normal energy (E* d^3)."""
    if law.normal == HARMONIC:
        return harmonic.energy(overlap, r12, e12, law.stiffness)
    return hertz.energy(overlap, r12, e12, law.stiffness)


@numba.njit(cache=True, inline="always")
def law_tangential_stiffness(law, overlap, r12, g12):
    """Tangential stiffness k_t (E* d)."""
    if law.normal == HARMONIC:
        return harmonic.tangential_stiffness(overlap, r12, g12, law.stiffness)
    return hertz.tangential_stiffness(overlap, r12, g12, law.stiffness)


@numba.njit(cache=True, inline="always")
def law_unloading_scale(law, overlap_old, overlap_new):
    """k_t(n_new) / k_t(n_old): the tangential force's rescale on unloading (contact.py)."""
    if law.normal == HARMONIC:
        return harmonic.unloading_scale(overlap_old, overlap_new)
    return hertz.unloading_scale(overlap_old, overlap_new)


@numba.njit(cache=True, inline="always")
def law_step_stiffness(law, overlap, root_r12, e12):
    """The stiffness (E* d) the time-step estimate takes (dem.kernels.stable_dt): k_n times the
    law's STEP_CONTACTS (Hertz: k_n itself)."""
    if law.normal == HARMONIC:
        return harmonic.STEP_CONTACTS * harmonic.stiffness(overlap, root_r12, e12, law.stiffness)
    return hertz.stiffness(overlap, root_r12, e12, law.stiffness)


#: (module, name) of every njit function above and in the law modules, each after those it
#: calls: granwave.gpu.compile makes device copies of them in this order.
DEVICE_FUNCTIONS = tuple((m, f) for m in NORMAL_LAWS.values()
                         for f in ("force", "stiffness", "energy", "tangential_stiffness", "unloading_scale")) + \
    tuple((None, f) for f in ("law_force", "law_stiffness", "law_energy", "law_tangential_stiffness",
                              "law_unloading_scale"))
