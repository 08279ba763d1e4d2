"""The contact sub-models for the engines, the linearization and LAMMPS (Python side; numba).

Generic over the registry (:mod:`.registry`): the kernels' model tuples of a selection
(:func:`models_of`, :func:`fill_params`), the history columns, the linearization's blocks, the
LAMMPS words. The dispatchers the kernels call (``law_force``, ``contact_couple``, ...) are the
generated ``_dispatch.py``'s, re-exported here. The named helpers at the end (``contact_model``,
``rolling_model``, ...) keep the calls of the tests and scripts written before the registry.
"""

from __future__ import annotations

import contextlib
import importlib

from . import _dispatch as D
from . import options as O
from ._dispatch import *  # noqa: F401,F403  (law_force, ..., contact_couple, law_of, couple_of, models)
from ._dispatch import MODELS, DampingModel, NormalModel, RollingModel, TangentialModel
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


def module(name: str):
    """The module of the sub-model ``name``."""
    return importlib.import_module(O.SUBMODELS[name]["module"])


def model_of(kind: str, values: dict, chosen: dict | None = None):
    """The kernels' model tuple of ``kind`` for the selection ``values`` (code and constants;
    zeros where the kind is off)."""
    name = (O.check(values) if chosen is None else chosen)[kind]
    tup = MODELS[kind]
    if name is None:
        return tup(0, *([0.0] * (len(tup._fields) - 1)))
    return tup(O.SUBMODELS[name]["code"], *module(name).kernel_constants(values))


def own_constants(kind: str, model) -> tuple:
    """The constants of a model tuple that its sub-model takes (its ``CONSTANTS``; the tuple is
    sized for the kind's largest count)."""
    name = next((n for n, s in O.SUBMODELS.items() if s["kind"] == kind and s["code"] == int(model.code)), None)
    return tuple(model[1:1 + len(O.SUBMODELS[name]["constants"])]) if name is not None else ()


def overlap_at_force(values: dict, f: float, r12: float, e12: float) -> float:
    """The overlap (d) at which a contact of the selection's normal law carries the normal force
    ``f`` (E* d^2) given R12 (d) and E*12 (E*)."""
    module_, model = normal_law(values)
    return module_.overlap_at_force(f, r12, e12, *own_constants("normal", model))


def models_of(values: dict) -> dict:
    """kind -> model tuple of a selection holding the kinds' own parameters (:func:`.options.resolve`);
    ValueError for an invalid one."""
    chosen = O.check(values)
    return {kind: model_of(kind, values, chosen) for kind in O.KINDS}


def normal_law(values: dict) -> tuple:
    """(module, model tuple) of the selection's normal law (its Python side: ``overlap_at_force``,
    ``IMPACT_WORK``; its kernels' model); ValueError for an invalid selection."""
    chosen = O.check(values)
    return module(chosen["normal"]), model_of("normal", values, chosen)


#: the kind whose sub-model the engines call as a couple with a history (read by ``couple_of``)
COUPLE_KIND = next(k for k, v in O.KINDS.items() if v["history"])


def couple_model(values: dict):
    """The model tuple of the selection's couple sub-model (zeros where it is off)."""
    return model_of(COUPLE_KIND, values)


def stored_couple_history(contacts, dim: int):
    """The contacts' stored couple history (M, dim) (``Contacts`` field of the couple kind's
    history); zeros where none is stored."""
    import numpy as np

    h = getattr(contacts, O.KINDS[COUPLE_KIND]["history"])
    if h is None:
        return np.zeros((len(contacts), dim))
    return np.ascontiguousarray(h, dtype=float).reshape(len(contacts), dim)


def fill_params(fpar, values: dict) -> None:
    """The selection's codes and constants into the engine's record ``fpar``
    (granwave.dem.layout.PARAMS, the fields of ``_table.PARAMS_FIELDS``)."""
    for kind, m in models_of(values).items():
        setattr(fpar, f"{kind}_code", m.code)
        for field, value in zip(O.KINDS[kind]["fields"], m[1:]):
            setattr(fpar, field, value)


@contextlib.contextmanager
def without_dashpot(fpar):
    """The engine's record ``fpar`` with the damping law's constants at 0 inside the ``with``
    block, then as before: no damping law acts with its constants at 0 (granwave.contact_models.
    kinds; tests/test_contact_registry.py checks each), so the dashpot is off whatever the law."""
    names = O.KINDS["damping"]["fields"]
    saved = [float(getattr(fpar, f)) for f in names]
    for f in names:
        setattr(fpar, f, 0.0)
    try:
        yield fpar
    finally:
        for f, v in zip(names, saved):
            setattr(fpar, f, v)


def uncapped(tangential):
    """The tangential model tuple ``tangential`` without its slider: mu (every tangential law's first
    constant, granwave.contact_models.kinds) infinite, where the law acts (the frozen-history
    forces of the linearization's contract); a law that does not act is returned as it is."""
    if not tangential[1] > 0.0:
        return tangential
    return tangential._replace(c0=float("inf"))


def history_columns(dim: int, values: dict) -> int:
    """Columns of a contact's history (pair_ft, wall_ft): the tangential force's, then those of the
    selected sub-models."""
    return int(dim) + O.history_width(dim, values)


def linear_blocks(blocks, values: dict, n, wall, r_i, r_j, dim: int, p: int) -> None:
    """Add the stiffness blocks of the selected sub-models that have their own
    (granwave.linear.assemble; the normal law's are its k_n and k_t, in the contact table)."""
    for name in O.check(values).values():
        if name is not None and hasattr(module(name), "linear_blocks"):
            module(name).linear_blocks(blocks, values, n, wall, r_i, r_j, dim, p)


def no_lammps(values: dict) -> str | None:
    """A sentence naming the first selected sub-model without a LAMMPS equivalent and why (its
    ``NO_LAMMPS``), or None."""
    for kind, name in O.check(values).items():
        if name is not None and O.SUBMODELS[name]["lammps"] is not None:
            return (f"no LAMMPS equivalent of the {O.KINDS[kind]['option'].replace('_', ' ')} {name!r}: "
                    f"{O.SUBMODELS[name]['lammps']}")
    return None


def lammps_parts(values: dict, e12_pair: float, e12_wall: float, g12_pair: float, g12_wall: float) -> tuple:
    """(the normal law's LAMMPS words and stiffnesses, its restitution scale, the other selected
    sub-models' fragments) of a selection (granwave.interop.lammps); ValueError for a sub-model
    without a LAMMPS equivalent (its ``NO_LAMMPS``)."""
    chosen = O.check(values)
    reason = no_lammps(values)
    if reason is not None:
        raise ValueError(reason)
    normal = module(chosen["normal"])
    fragments = []
    for kind, name in chosen.items():
        if O.KINDS[kind]["off"] is None or name is None:
            continue  # the pair style's fixed words (normal, damping, tangential): lammps_words
        fragments.append(module(name).lammps_fragment(values))
    return (normal.lammps_words(values, e12_pair, e12_wall, g12_pair, g12_wall), normal.LAMMPS_RESTITUTION_SCALE,
            fragments)


# ------------------------------------------------------------- the named helpers (before the registry)
#: the normal laws: name -> module, in code order
NORMAL_LAWS = {n: module(n) for n in O.names("normal")}
DEFAULT_LAW = O.KINDS["normal"]["default"]
ContactModel = NormalModel
NO_ROLLING = RollingModel(0)
#: rolling resistance's names (its off name first)
ROLLING_NAMES = O.names("rolling")


def law_module(name: str):
    """The module of the normal law ``name``; ValueError for an unknown one."""
    if name not in NORMAL_LAWS:
        raise ValueError(f"unknown contact law {name!r}: choose one of {', '.join(NORMAL_LAWS)}")
    return NORMAL_LAWS[name]


def contact_model(name: str = DEFAULT_LAW, harmonic_stiffness: float = 1.0) -> NormalModel:
    """The normal law's model tuple (tests, linearization); ValueError for an unknown law or a
    harmonic stiffness that is not > 0."""
    law_module(name)
    return model_of("normal", O.values_of(dict(contact_law=name, harmonic_stiffness=harmonic_stiffness)))


def model_of_attrs(attrs) -> NormalModel:
    """The normal law a packing was made with, from its attributes (none recorded: Hertz)."""
    return model_of("normal", O.values_of_attrs(attrs))


def name_of(model: NormalModel) -> str:
    """The law's name of a normal model tuple."""
    return list(NORMAL_LAWS)[int(model.code)]


def rolling_model(name: str = "none", stiffness: float = 0.0, damping: float = 0.0,
                  friction: float = 0.0) -> RollingModel:
    """The rolling model tuple of ``name`` and its coefficients; ValueError for an unknown name or a
    coefficient out of range."""
    return model_of("rolling", O.values_of(dict(rolling=name, rolling_stiffness=stiffness,
                                                rolling_damping=damping, rolling_friction=friction)))


def rolling_of_attrs(attrs) -> RollingModel:
    """The rolling model a packing was made with, from its attributes (none recorded: none)."""
    return model_of("rolling", O.values_of_attrs(attrs))


def damping_model(zeta: float) -> DampingModel:
    """The default damping law's model tuple at ``zeta`` (tests, scripts)."""
    return model_of("damping", O.resolve(dict(damping=zeta)))


def tangential_model(friction: float) -> TangentialModel:
    """The default tangential law's model tuple at ``friction`` mu (tests, scripts)."""
    return model_of("tangential", O.resolve(dict(friction=friction)))


def lammps_words(values: dict, friction: float, poisson: float, damping: float) -> tuple:
    """(the normal law's words and stiffnesses (pair and wall), the other selected sub-models'
    fragments, and the function ``side -> words`` of the pair style's fixed part
    ``NORMAL kn e tangential ... damping ...`` for ``"pair"`` or ``"wall"``) of a selection and the
    kinds' parameters (granwave.interop.lammps); ValueError where a selected sub-model has no
    LAMMPS equivalent."""
    from .. import contact as C

    values = {**values, "friction": float(friction), "poisson": float(poisson), "damping": float(damping)}
    chosen = O.check(values)
    e12 = (C.effective_young(False), C.effective_young(True))
    g12 = (C.effective_shear(poisson, False), C.effective_shear(poisson, True))
    words, scale, fragments = lammps_parts(values, *e12, *g12)
    tangential = module(chosen["tangential"])
    ratio = tangential.lammps_stiffness_ratio(values, words)
    damp = module(chosen["damping"]).lammps_words(values, scale, words["normal"], ratio)

    def fixed(side: str) -> str:
        t = tangential.lammps_tangential(values, words, side, damp["xgammat"])
        return (f"{words['normal']} {words['kn_' + side]:.17g} {damp['normal_damping']:.17g} {t} "
                f"damping {damp['damping_words']}")
    return dict(words, **damp), fragments, fixed
