"""The report's inputs: JSON files and folders, their scenes, figures and the config.

Scenes: a file's scene is its ``scene`` key, else the first folder below the
input folder given (``summary/<scene>/...``), else the folder before the
``p<pressure>`` part of the workflow layout (``summary/<scene>/p<p>/<size>/s<seed>.json``,
``heights/<scene>/p<p>.json``), else its parent folder's name. The scene's
kind (disordered / lattices / chains) and its friction come from the
workflow config when given, else from the summaries (``kind``, ``friction``)
or the scene name (``lattice*``, ``chain*``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from ..analysis.renamed_keys import HEIGHTS, current_keys
from ..errors import InputError
from ..io.files import load_json


def collect_json(paths: Iterable) -> list[tuple[Path, object, str | None]]:
    """(path, object, scene guess) for JSON files and folders (searched recursively)."""
    out = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            files = sorted(p.rglob("*.json"))
            for f in files:
                rel = f.relative_to(p).parts
                out.append((f, load_json(f), rel[0] if len(rel) > 1 else None))
        elif p.is_file():
            out.append((p, load_json(p), None))
        else:
            raise InputError(f"{p}: no such file or folder")
    return out


_PRESSURE_DIR = re.compile(r"p[0-9][0-9.eE+-]*")


def scene_of(path: Path, obj, guess: str | None) -> str:
    """The ``scene`` key, else the folder given's first level, else the folder before
    ``p<pressure>`` in the workflow layout (``<stage>/<scene>/p<p>/...``), else the parent."""
    if isinstance(obj, Mapping) and obj.get("scene"):
        return str(obj["scene"])
    if guess:
        return guess
    parts = Path(path).parts
    for k in range(len(parts) - 1, 0, -1):
        stem = Path(parts[k]).stem if k == len(parts) - 1 else parts[k]
        if _PRESSURE_DIR.fullmatch(stem):
            return parts[k - 1]
    return Path(path).parent.name or "all"


def label_from_path(path) -> str:
    """A series label from a heights file path: ``<scene> <file stem>``."""
    path = Path(path)
    return f"{path.parent.name} {path.stem}".strip() if path.parent.name else path.stem


def num(x) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v


def heights_arrays(obj: Mapping, *, source="heights") -> dict:
    """Per-sample (or per-height) arrays from an ``analyze heights --json`` object.

    Returns ``height``, ``t_lead10``, ``t_peak``, ``t_zero``, ``amplitude``,
    ``width`` (arrays), and the scalars of the object (c_tof, gamma, ...).
    """
    if not isinstance(obj, Mapping):
        raise InputError(f"{source}: expected a JSON object from `granwave analyze heights --json`")
    obj = current_keys(obj, HEIGHTS)  # files written before the renames (alpha: chi)
    keys = ("t_lead10", "t_peak", "t_zero", "amplitude", "width")
    if isinstance(obj.get("samples"), list) and obj["samples"]:
        rows = obj["samples"]
        data = {"height": np.array([num(r.get("height")) for r in rows])}
        for k in keys:
            data[k] = np.array([num(r.get(k)) for r in rows])
    elif isinstance(obj.get("per_height"), Mapping):
        ph = obj["per_height"]
        data = {"height": np.asarray(ph.get("height"), float)}
        for k in keys:
            data[k] = None if ph.get(k) is None else np.asarray(ph[k], float)
    elif obj.get("height") is not None or obj.get("heights") is not None:
        data = {"height": np.asarray(obj.get("height", obj.get("heights")), float)}
        for k in keys:
            data[k] = None if obj.get(k) is None else np.asarray(obj[k], float)
    else:
        raise InputError(f"{source}: no per-sample or per-height arrival times found")
    if data["height"].size == 0:
        raise InputError(f"{source}: no heights")
    for k, v in obj.items():
        if k not in data and isinstance(v, (int, float, str)) and not isinstance(v, bool):
            data[k] = v
    return data


def heights_means(obj: Mapping, *, source="heights") -> dict:
    """Per-nominal-height ensemble means of an ``analyze heights --json`` object.

    Reads the ``per_height`` table the height analysis wrote (nominal heights
    = groups of nearly equal L, docs/summaries.md): ``height``, ``count``,
    ``amplitude``, ``width`` (means) and ``amplitude_sem``, ``width_sem``
    (std/sqrt(count); NaN for one packing), plus the analysis's fitted
    ``gamma``, ``chi`` (with ``_err``; ``alpha`` in older files) and prefactors.
    """
    if not isinstance(obj, Mapping) or not isinstance(obj.get("per_height"), Mapping):
        raise InputError(f"{source}: no per-height table (expected `granwave analyze heights --json`)")
    obj = current_keys(obj, HEIGHTS)
    ph = obj["per_height"]
    out = {"height": np.asarray(ph.get("height"), float)}
    if out["height"].size == 0:
        raise InputError(f"{source}: no heights")
    count = np.asarray(ph.get("count", np.ones(out["height"].size)), float)
    out["count"] = count
    for k in ("amplitude", "width"):
        if ph.get(k) is None:
            continue
        out[k] = np.asarray(ph[k], float)
        std = np.asarray([num(x) for x in ph.get(k + "_std") or [math.nan] * count.size], float)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[k + "_sem"] = np.where(count > 1, std / np.sqrt(count), math.nan)
    for k in ("gamma", "gamma_err", "chi", "chi_err", "amplitude_prefactor", "width_prefactor",
              "n_signals", "pressure", "ic"):
        if obj.get(k) is not None:
            out[k] = obj[k]
    return out


def _rows_with_pressure(obj, depth: int = 0):
    """Find a table of per-pressure rows in a JSON object (list of dicts with 'pressure')."""
    if isinstance(obj, list) and obj and all(isinstance(r, Mapping) and "pressure" in r for r in obj):
        return obj
    if isinstance(obj, Mapping) and depth < 3:
        for key in ("pressures", "rows", "per_pressure", "speeds", "table"):
            r = _rows_with_pressure(obj.get(key), depth + 1) if key in obj else None
            if r:
                return r
        for v in obj.values():
            r = _rows_with_pressure(v, depth + 1)
            if r:
                return r
    return None


def _value_err(v) -> tuple[float, float]:
    if isinstance(v, Mapping):
        val = v.get("mean", v.get("value"))
        err = v.get("err", v.get("std", v.get("sem")))
        return num(val), num(err)
    return num(v), math.nan


def sweep_speeds(obj, *, source="sweep") -> dict:
    """Per-pressure speeds (``pressure``, ``c_tof``, ``c_l``, ``c_t`` and ``*_err``) from
    a ``pressure-sweep --json`` object (rows with a ``pressure`` key, or columns)."""
    rows = _rows_with_pressure(obj)
    out: dict = {}
    if rows:
        out["pressure"] = np.array([num(r["pressure"]) for r in rows])
        for k in ("c_tof", "c_l", "c_t", "c_peak", "c_zero"):
            vals = [_value_err(r.get(k)) for r in rows]
            errs = [num(r.get(k + "_err", r.get(k + "_std", e))) for r, (_, e) in zip(rows, vals)]
            if any(np.isfinite(v) for v, _ in vals):
                out[k] = np.array([v for v, _ in vals])
                out[k + "_err"] = np.array(errs)
    elif isinstance(obj, Mapping) and (obj.get("pressure") is not None or obj.get("pressures") is not None):
        out["pressure"] = np.asarray(obj.get("pressure", obj.get("pressures")), float)
        for k in ("c_tof", "c_l", "c_t", "c_peak", "c_zero"):
            for suffix in ("", "_err"):
                if obj.get(k + suffix) is not None:
                    out[k + suffix] = np.asarray(obj[k + suffix], float)
    if "pressure" not in out or not any(k in out for k in ("c_tof", "c_l", "c_t")):
        raise InputError(f"{source}: no per-pressure speeds (c_tof, c_l, c_t) found")
    return out


class Scenes:
    """Kind and friction of each scene, from the config, the summaries or the name."""

    def __init__(self, config: Mapping | None, summaries: Sequence[Mapping] = ()):
        self.kind: dict[str, str] = {}
        self.spec: dict[str, Mapping] = {}
        for kind in ("disordered", "lattices", "chains"):
            for name, spec in ((config or {}).get(kind) or {}).items():
                self.kind[name] = kind
                self.spec[name] = spec or {}
        self.summary_kind: dict[str, str] = {}
        self.summary_friction: dict[str, float] = {}
        for s in summaries:
            sc = s.get("_scene")
            k = str(s.get("kind", ""))
            if "lattice" in k:
                self.summary_kind.setdefault(sc, "lattices")
            elif "chain" in k:
                self.summary_kind.setdefault(sc, "chains")
            if s.get("friction") is not None:
                self.summary_friction.setdefault(sc, num(s["friction"]))

    def kind_of(self, scene: str) -> str:
        if scene in self.kind:
            return self.kind[scene]
        if scene in self.summary_kind:
            return self.summary_kind[scene]
        name = scene.lower()
        return "lattices" if "lattice" in name else "chains" if "chain" in name else "disordered"

    def friction_of(self, scene: str) -> float:
        if "friction" in self.spec.get(scene, {}):
            return num(self.spec[scene]["friction"])
        if scene in self.summary_friction:
            return self.summary_friction[scene]
        return math.nan

    def poisson_of(self, scene: str) -> float:
        return num(self.spec.get(scene, {}).get("poisson", 0.0))

    def ic_of(self, scene: str, obj: Mapping | None = None) -> str:
        if obj is not None and obj.get("ic") not in (None, "none"):
            return str(obj["ic"])
        return str(self.spec.get(scene, {}).get("ic", "A"))


def find_figures(paths: Iterable) -> list[Path]:
    """PNG files from files and folders (folders searched recursively, sorted)."""
    out = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            out += sorted(f for f in p.rglob("*.png") if not f.name.startswith("."))
        elif p.is_file():
            out.append(p)
        else:
            raise InputError(f"{p}: no such figure or folder")
    return list(dict.fromkeys(out))


def load_config(path) -> dict:
    """The workflow config (YAML or JSON) as a dict, read as strictly as the workflow reads it
    (no duplicate keys, text only, a mapping at the top level)."""
    from ..io.files import record_input
    from ..workflow_config import read_config_file

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such config file")
    record_input(path)  # an input: no output of this command may replace it
    obj, message = read_config_file(path)
    if message:
        raise InputError(message)
    return obj
