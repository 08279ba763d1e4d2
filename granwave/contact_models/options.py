"""The contact sub-models' options, file attributes and checks, in plain Python (no numba).

A selection of sub-models is a mapping ``values``: each kind's option (``contact_law``,
``rolling``, ...) to a sub-model's name, and every sub-model parameter (``harmonic_stiffness``,
...) to its value; :func:`values_of` makes it from ``PrepareParams`` (whose fields these are,
:func:`prepare_fields`), from keywords (:func:`resolve`) or from a file's attributes
(:func:`values_of_attrs`). The kinds' own parameters (``friction``, ``poisson``, ``damping``:
every sub-model of their kind takes them) are fields of ``PrepareParams`` too, but travel
beside a selection as before the kinds (``Engine(friction=...)``, ``packing.friction``); the
engine's selection (:func:`resolve`) holds them. All of it is read from the generated
``_table.py``.
"""

from __future__ import annotations

import math

from . import _table as T

KINDS = T.KINDS
SUBMODELS = T.SUBMODELS
PARAMETERS = T.PARAMETERS
KIND_PARAMETERS = T.KIND_PARAMETERS
#: every parameter by name: the kinds' and the sub-models'
ALL_PARAMETERS = {**T.KIND_PARAMETERS, **T.PARAMETERS}


def names(kind: str) -> tuple:
    """The names an option of ``kind`` accepts: its off name (if any), then its sub-models."""
    k = KINDS[kind]
    own = tuple(n for n, s in SUBMODELS.items() if s["kind"] == kind)
    return ((k["off"],) if k["off"] is not None else ()) + own


def options() -> tuple:
    """Every selection option and every parameter name (the keys of a full ``values``)."""
    return tuple(k["option"] for k in KINDS.values()) + tuple(PARAMETERS)


def normal_options() -> tuple:
    """The normal law's option and its sub-models' parameters."""
    return (KINDS["normal"]["option"],) + tuple(n for n, p in PARAMETERS.items() if p["kind"] == "normal")


def defaults() -> dict:
    """The default selection: each kind's default sub-model, every parameter's default."""
    return {**{k["option"]: k["default"] for k in KINDS.values()},
            **{n: p["default"] for n, p in PARAMETERS.items()}}


def prepare_fields() -> list[tuple[str, str, object, dict]]:
    """(name, type, default, metadata) of the ``PrepareParams`` fields: per kind its option (the
    choices with one-line summaries), then its own parameters and its sub-models'."""
    out = []
    for kind, k in KINDS.items():
        parts = [f"'{k['off']}'"] if k["off"] is not None else []
        parts += [f"'{n}' ({s['summary']})" for n, s in SUBMODELS.items() if s["kind"] == kind]
        needs = [n for n, s in SUBMODELS.items() if s["kind"] == kind and s["needs_friction"]]
        cpu = [n for n, s in SUBMODELS.items() if s["kind"] == kind and "gpu" not in s["devices"]]
        tail = (" Needs friction > 0." if needs else "") + (" CPU only." if cpu else "")
        out.append((k["option"], "str", k["default"],
                    dict(help=f"{k['help']}: {' or '.join(parts)}.{tail}", choices=names(kind))))
        for n, p in ALL_PARAMETERS.items():
            if p["kind"] == kind:
                meta = {key: p[key] for key in ("help", "units", "lo", "lo_open", "hi", "hi_open")}
                out.append((n, "float", p["default"], meta))
    return out


def kind_fields(kinds, default=None, own=True) -> list[tuple[str, str, object, dict]]:
    """:func:`prepare_fields` of the kinds ``kinds`` only (a stage that makes packings of those:
    a lattice's normal and tangential laws, a chain's normal law), without the kinds' own
    parameters unless ``own``; ``default``: {option: default} replacing a kind's default (None:
    the option may be left out: type ``str | None``)."""
    options = {KINDS[k]["option"]: k for k in kinds}
    out = []
    for name, kind, value, meta in prepare_fields():
        p = ALL_PARAMETERS.get(name)
        if name in options:
            if default and name in default:
                value = default[name]
                kind = "str | None" if value is None else kind
            out.append((name, kind, value, meta))
        elif p is not None and p["kind"] in kinds and (own or "submodel" in p):
            out.append((name, kind, value, meta))
    return out


def values_of(source) -> dict:
    """The selection of ``source``: an object with the options as attributes (PrepareParams) or a
    mapping; what it lacks takes the default."""
    get = source.get if isinstance(source, dict) else (lambda n, d: getattr(source, n, d))
    return {n: get(n, d) for n, d in defaults().items()}


def resolve(keywords: dict, where: str = "the engine") -> dict:
    """The selection of ``keywords`` (options and parameters by name; the rest default), with the
    kinds' own parameters where given; TypeError for a keyword that is none of these."""
    unknown = sorted(set(keywords) - set(options()) - set(KIND_PARAMETERS))
    if unknown:
        raise TypeError(f"{where} got unexpected keyword argument(s) {', '.join(map(repr, unknown))}")
    return {**values_of(dict(keywords)), **{n: float(keywords[n]) for n in KIND_PARAMETERS if n in keywords}}


def selected(values: dict) -> dict:
    """kind -> the selected sub-model's name (None where the kind is off); ValueError for an
    unknown name."""
    out = {}
    for kind, k in KINDS.items():
        name = str(values[k["option"]])
        if name not in names(kind):
            raise ValueError(f"unknown {k['option'].replace('_', ' ')} {name!r}: choose one of "
                             f"{', '.join(names(kind))}")
        out[kind] = None if name == k["off"] else name
    return out


def _in_range(name: str, value, p: dict) -> None:
    value = float(value)
    lo, hi = p["lo"], p["hi"]
    bad = not math.isfinite(value) or (lo is not None and (value < lo or (p["lo_open"] and value == lo))) or \
        (hi is not None and (value > hi or (p["hi_open"] and value == hi)))
    if bad:
        rng = " and ".join(([f"{'>' if p['lo_open'] else '>='} {lo:g}"] if lo is not None else []) +
                           ([f"{'<' if p['hi_open'] else '<='} {hi:g}"] if hi is not None else []))
        raise ValueError(f"{name} must be {rng}, got {value!r}")


def check(values: dict, friction: float | None = None) -> dict:
    """:func:`selected` of a valid selection: the selected sub-models' parameters (and the kinds'
    parameters it holds) in range and, with ``friction`` given, friction > 0 where a selected
    sub-model needs rotations; ValueError otherwise."""
    chosen = selected(values)
    for kind, name in chosen.items():
        for p in KINDS[kind]["parameters"]:
            if p in values:
                _in_range(p, values[p], KIND_PARAMETERS[p])
        if name is None:
            continue
        for p in SUBMODELS[name]["parameters"]:
            _in_range(p, values[p], PARAMETERS[p])
        if friction is not None and SUBMODELS[name]["needs_friction"] and not friction > 0.0:
            raise ValueError(f"{KINDS[kind]['option']} {name!r} needs friction > 0 (a frictionless packing "
                             "has no rotations)")
    return chosen


def attrs_of(values: dict, recorded: bool = True) -> dict:
    """What a file records of a selection: per kind its option, where it is not the default or the
    kind is always recorded (``recorded`` False: only where it is not the default), and the
    selected sub-model's parameters where it is not the default (files of the defaults are as
    before the sub-models)."""
    out = {}
    for kind, name in selected(values).items():
        k = KINDS[kind]
        if name != (None if k["default"] == k["off"] else k["default"]) or (recorded and k["recorded"]):
            out[k["option"]] = k["off"] if name is None else name
        if name is not None and name != k["default"]:
            out.update({p: float(values[p]) for p in SUBMODELS[name]["parameters"]})
    return out


def values_of_attrs(attrs) -> dict:
    """The selection a file records (absent: the defaults, as files made before the sub-models)."""
    base = defaults()
    return {n: (str(attrs[n]) if n in base and isinstance(base[n], str) else float(attrs[n]))
            if n in attrs else d for n, d in base.items()}


def history_width(dim: int, values: dict) -> int:
    """History columns per contact of the selected sub-models (after the tangential force's)."""
    return sum(SUBMODELS[n]["history_width"][int(dim)] for n in selected(values).values() if n is not None)


def history_datasets() -> tuple:
    """The ``contacts/`` datasets (and ``Contacts`` fields) of the kinds that keep a history."""
    return tuple(k["history"] for k in KINDS.values() if k["history"])


def off_kinds_on(values: dict) -> list[tuple[str, str]]:
    """(option, name) of every selected sub-model of a kind that can be off (all but the normal
    law): what runs that only the normal law reach (the DEM pulse, a lattice) refuse."""
    return [(KINDS[kind]["option"], name) for kind, name in selected(values).items()
            if name is not None and KINDS[kind]["off"] is not None]


def cpu_only(values: dict) -> str | None:
    """A sentence naming the first selected sub-model that runs on the CPU only, or None."""
    for kind, name in selected(values).items():
        if name is not None and "gpu" not in SUBMODELS[name]["devices"]:
            return (f"{SUBMODELS[name]['description']} runs on the CPU only for now ({KINDS[kind]['option']} "
                    f"{name}; use --device cpu)")
    return None


def with_fields(fields, after: str | None = None):
    """Class decorator, applied before ``@dataclass``: adds the fields ``(name, type, default)``
    (default: a value or a ``dataclasses.field``) after the field ``after`` (None: at the end), so
    that the class's own fields and the generated ones are declared once each."""
    def add(cls):
        own = dict(cls.__dict__.get("__annotations__", {}))
        new = {}
        for name, kind, default in fields:
            setattr(cls, name, default)
            new[name] = kind
        merged = {}
        for name, kind in own.items():
            merged[name] = kind
            if name == after:
                merged.update(new)
        if after is None or after not in own:
            merged.update(new)
        cls.__annotations__ = merged
        return cls
    return add
