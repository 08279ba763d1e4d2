"""Per-sample summaries and the pressure sweep (docs/method.md §10).

A *summary* is one JSON object per sample (layout: ``docs/summaries.md``)::

    {"pressure": 1e-4, "seed": 3, "kind": "disordered", "height": 25.1,
     "statics": {...},   # granwave analyze statics --json
     "moduli":  {...},   # granwave analyze moduli --json (C11 ... C33, c_l, c_t, phi3_star)
     "front":   {...},   # granwave analyze front --json
     "tof":     {...}}   # granwave analyze heights --json (c_tof, c_peak, c_zero, gamma, chi...)

``pressure``, ``seed`` (an integer, or null for deterministic systems such
as lattices), ``kind`` and ``height`` are required; the four sections are
optional; any other top-level key (``scene``, ``friction``, ``poisson`` ...)
is kept. A summary file holds one such object, or a JSON list of them.
:func:`merge_summary` builds a summary object from a signal's (or
packing's) attributes and the JSON outputs of the analyze commands;
:func:`update_summary_file` adds pieces to a summary file in any order.

Height series (``granwave analyze heights --json``) belong to a pressure,
not to a sample: pass them to :func:`pressure_sweep` as ``height_series``.
At a pressure that has height series, their values (``tof.c_tof``, ...)
replace any ``tof`` sections of the summaries; their statistics are over
the height series of that pressure.

The sweep (choices)
-------------------
* Samples are grouped by pressure (equal to 12 significant digits).
* Every numeric leaf of every section is a *quantity* named
  ``section.key`` (nested objects add ``.key``, lists of numbers ``.0``,
  ``.1`` ...; lists of objects, strings, booleans and nulls are skipped).
  Per pressure: mean, sample standard deviation (1/(n-1)), standard error
  std/sqrt(n) and count of the finite values.
* Speeds per pressure: c_tof = ``tof.c_tof``, c_peak, c_zero likewise,
  c_l = ``moduli.c_l``, c_t = ``moduli.c_t``, each the mean over the
  pressure's samples. Their uncertainty is the standard error of the mean
  when the samples scatter; when they do not (one height series copied into
  every summary of its pressure, or a single sample) it is the mean of the
  ``<key>_err`` the summaries carry (e.g. ``tof.c_tof_err``), else NaN.
* c ∝ p^κ is fitted by least squares in log-log through the per-pressure
  means (:func:`granwave.analysis.fits.power_law_fit`): keys ``kappa_tof``,
  ``kappa_l``, ``kappa_t`` (and ``kappa_peak``, ``kappa_zero``; ``alpha_*`` before
  granwave 1.x, :mod:`granwave.analysis.renamed_keys`) with one
  standard error (NaN with two pressures; NaN and a note with fewer) and the 95 % interval
  ``*_ci95`` (± t(0.975, n − 2) errors: ± 4.3 errors with four pressures; "± 2 errors" holds
  the truth in 71–86 % of the truth suite's cases there, docs/truth.md).
  Fitting the means, not the samples, keeps a height series shared by all
  samples of a pressure from being counted many times.
* ``c_tof_over_c_l`` = mean c_tof / mean c_l, relative errors added in
  quadrature.
* With a crossover asked (``pressure-sweep --crossover``): the pressure p* where c_tof, c_l
  and c_t turn from p^(1/4) to p^(1/6) (or the exponents given), each with its 95 % interval
  (:mod:`granwave.analysis.crossover`), through the same per-pressure means and errors.
* Side by side: the triangular-lattice speeds of docs/method.md §12
  (:func:`granwave.theory.lattice_speed`, frictionless and frictional with
  the sweep's Poisson ratio), and for each measured speed the p^{1/6} curve
  through its value at the highest pressure (``<key>_p16``).

Units: pressures and moduli E*, speeds sqrt(E*/rho), lengths d.
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from ..errors import InputError
from ..io.files import atomic_text, load_json
from ..provenance import SAMPLE_ATTRS
from .ensemble import describe
from .fits import power_law_fit

SECTIONS = ("statics", "moduli", "front", "tof")
REQUIRED = ("pressure", "seed", "kind", "height")
EXPECTED_EXPONENT = 1.0 / 6.0
# speed name -> (quantity, key of its fitted exponent)
SPEEDS = {
    "c_tof": ("tof.c_tof", "kappa_tof"),
    "c_peak": ("tof.c_peak", "kappa_peak"),
    "c_zero": ("tof.c_zero", "kappa_zero"),
    "c_l": ("moduli.c_l", "kappa_l"),
    "c_t": ("moduli.c_t", "kappa_t"),
}
STATICS_TABLE = ("phi2", "phi3", "phi3_star", "z_star", "rattler_fraction", "mean_force_over_p",
                 "Z2", "Z3", "F2", "F2_strong", "stress_ratio")
MODULI_TABLE = (("statics", "stress_ratio"), ("moduli", "C11"), ("moduli", "C12"),
                ("moduli", "C22"), ("moduli", "C33"), ("moduli", "c_l"), ("moduli", "c_t"))


# ---------------------------------------------------------------- summaries
def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def validate_summary(obj, source: str = "summary") -> dict:
    """Check one summary object (layout: module docstring); return it."""
    if not isinstance(obj, dict):
        raise InputError(f"{source}: a summary must be a JSON object, got {type(obj).__name__}")
    missing = [k for k in REQUIRED if k not in obj]
    if missing:
        raise InputError(f"{source}: not a granwave summary (missing {', '.join(missing)})")
    p = obj["pressure"]
    if not _is_number(p) or not math.isfinite(p) or p <= 0:
        raise InputError(f"{source}: pressure must be a positive number, got {p!r}")
    h = obj["height"]
    if not _is_number(h) or not math.isfinite(h) or h <= 0:
        raise InputError(f"{source}: height must be a positive number, got {h!r}")
    seed = obj["seed"]
    if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool) or seed < 0):
        raise InputError(f"{source}: seed must be a non-negative integer or null, got {seed!r}")
    if not isinstance(obj["kind"], str):
        raise InputError(f"{source}: kind must be a string, got {obj['kind']!r}")
    for sec in SECTIONS:
        if sec in obj and obj[sec] is not None and not isinstance(obj[sec], dict):
            raise InputError(f"{source}: section {sec!r} must be a JSON object")
    return obj


def load_summaries(paths: Iterable) -> list[dict]:
    """Read summary files (each one object or a list of objects), validated."""
    summaries, series = load_inputs(paths)
    if series:
        raise InputError("a height series is not a sample summary (pass it as height_series)")
    return summaries


def is_height_series(obj) -> bool:
    """True for the JSON object of ``granwave analyze heights --json``."""
    return isinstance(obj, dict) and "c_tof" in obj and "per_height" in obj


def validate_height_series(obj, source: str = "height series") -> dict:
    if not is_height_series(obj):
        raise InputError(f"{source}: not the output of `granwave analyze heights --json`")
    p = obj.get("pressure")
    if not _is_number(p) or not math.isfinite(p) or p <= 0:
        raise InputError(f"{source}: a height series needs its signals' pressure, got {p!r}")
    return obj


def load_inputs(paths: Iterable) -> tuple[list[dict], list[dict]]:
    """Read JSON files that hold summaries (objects or lists) or height series; (summaries, series)."""
    summaries, series = [], []
    for path in paths:
        obj = load_json(path)
        if is_height_series(obj):
            series.append(validate_height_series(obj, str(path)))
            continue
        items = obj if isinstance(obj, list) else [obj]
        if not items:
            raise InputError(f"{path}: an empty list of summaries")
        for i, item in enumerate(items):
            src = f"{path}" if not isinstance(obj, list) else f"{path}[{i}]"
            summaries.append(validate_summary(item, src))
    return summaries, series


def _jsonable(x):
    from ..io.files import jsonable

    return jsonable(x)


def write_summary(path, summary) -> None:
    """Write one summary (or a list of summaries) as JSON, atomically; NaN becomes null."""
    from ..io.files import check_writable

    check_writable(path)
    items = summary if isinstance(summary, list) else [summary]
    for i, s in enumerate(items):
        validate_summary(_jsonable(s), f"summary {i}")
    atomic_text(path, json.dumps(_jsonable(summary), indent=1) + "\n")


#: Attributes of a signal / packing file copied into a summary by :func:`merge_summary`.
CARRIED_ATTRS = (*SAMPLE_ATTRS, "height", "ic", "method", "n_grains")


def _section_data(name: str, data):
    if data is None:
        return None
    if isinstance(data, dict):
        return data
    obj = load_json(data)
    if not isinstance(obj, dict):
        raise InputError(f"{data}: the {name} section must be one JSON object")
    return obj


def merge_summary(*, attrs: dict | None = None, base: dict | None = None, statics=None, moduli=None,
                  front=None, tof=None, validate: bool = True, **fields) -> dict:
    """One sample's summary object from its pieces (layout: module docstring).

    ``attrs``: root attributes of the sample's signal (or packing) file; the
    keys in :data:`CARRIED_ATTRS` are copied (the string "none" that HDF5
    stores for a missing value becomes null). ``base``: an existing summary
    to extend. ``fields`` (scene, seed, ...) set top-level keys last.
    Sections: dicts or paths of JSON files printed by ``analyze statics /
    moduli / front / heights --json``; they are merged key by key into the
    base's sections. With ``validate`` the result must be a complete summary.
    Returns a new JSON-ready dict; nothing is written.
    """
    summary = dict(base or {})
    for key in CARRIED_ATTRS:
        if attrs and key in attrs:
            v = attrs[key]
            summary[key] = None if isinstance(v, str) and v == "none" else v
    summary.update(fields)
    for name, data in (("statics", statics), ("moduli", moduli), ("front", front), ("tof", tof)):
        data = _section_data(name, data)
        if data is not None:
            summary[name] = {**(summary.get(name) or {}), **data}
    summary = _jsonable(summary)
    if validate:
        validate_summary(summary, "merged summary")
    return summary


def update_summary_file(path, *, section: str | None = None, data=None, **fields) -> dict:
    """Add to the summary file at ``path`` (created if missing) and return the result.

    ``fields`` set top-level keys (pressure, seed, kind, height, scene, ...);
    ``data`` (a dict, or the path of a JSON file printed by an ``analyze ...
    --json`` command) is merged into ``section`` (one of statics, moduli,
    front, tof), its keys replacing those already there. The required keys
    are checked once they are all present, so a workflow can add the pieces
    in any order. The file is written atomically.
    """
    path = Path(path)
    base = load_json(path) if path.exists() else {}
    if not isinstance(base, dict):
        raise InputError(f"{path}: update_summary_file works on a file holding one summary object")
    if (section is None) != (data is None):
        raise InputError("a section and its data go together")
    if section is not None and section not in SECTIONS:
        raise InputError(f"section must be one of {', '.join(SECTIONS)}, got {section!r}")
    sections = {section: data} if section is not None else {}
    summary = merge_summary(base=base, validate=False, **sections, **fields)
    if all(k in summary for k in REQUIRED):
        validate_summary(summary, str(path))
    from ..io.files import check_writable

    check_writable(path, replace_input=True)  # an update in place: the input is this file
    atomic_text(path, json.dumps(summary, indent=1) + "\n", replace_input=True)
    return summary


def flatten(summary: dict) -> dict[str, float]:
    """Numeric leaves of the sections as ``section.key[.sub|.index]`` -> float (rule: module doc)."""
    out: dict[str, float] = {}

    def walk(prefix, v):
        if _is_number(v):
            out[prefix] = float(v)
        elif isinstance(v, dict):
            for k, w in v.items():
                walk(f"{prefix}.{k}", w)
        elif isinstance(v, list) and v and all(_is_number(w) or isinstance(w, list) for w in v):
            for i, w in enumerate(v):
                walk(f"{prefix}.{i}", w)

    for sec in SECTIONS:
        if isinstance(summary.get(sec), dict):
            walk(sec, summary[sec])
    return out


# ---------------------------------------------------------------- sweep
def _pressure_key(p: float) -> float:
    return float(f"{float(p):.12g}")


def _speed_with_error(stats: dict, flat_rows: list[dict], quantity: str) -> tuple[float, float]:
    st = stats.get(quantity)
    if st is None or st["count"] == 0:
        return math.nan, math.nan
    values = {r[quantity] for r in flat_rows if quantity in r and math.isfinite(r[quantity])}
    if len(values) > 1:  # the samples scatter: standard error of the mean
        return st["mean"], st["sem"]
    errs = [r[quantity + "_err"] for r in flat_rows if quantity + "_err" in r]
    errs = [e for e in errs if math.isfinite(e)]
    return st["mean"], float(np.mean(errs)) if errs else math.nan


def pressure_sweep(summaries: Sequence[dict], *, height_series: Sequence[dict] = (),
                   poisson: float = 0.0, crossover: tuple | None = None) -> dict:
    """Group summaries by pressure and fit the speeds (docs/method.md §10); rules in the module docstring.

    Returns a JSON-ready dict: ``pressures``, ``quantities`` (names), ``per_pressure`` (one
    row per pressure: pressure, count, speeds with ``*_err``, lattice speeds, ``*_p16`` and
    ``stats`` {quantity: {mean, std, sem, count}}), the fitted exponents ``kappa_*`` with
    ``*_err``, and ``expected_exponent`` = 1/6. ``crossover`` = (low, high): also the crossover
    pressure of c_tof, c_l and c_t between c ~ p^low and p^high (granwave.analysis.crossover):
    ``crossover_<speed>`` (the fit) and its scalars ``p_star_<speed>``, ``p_star_<speed>_lo95``,
    ``p_star_<speed>_hi95``, ``log10_p_star_<speed>`` with ``_err``; a speed known at fewer than 3
    pressures gets a note instead.
    """
    from .. import theory

    summaries = [validate_summary(s, f"summary {i}") for i, s in enumerate(summaries)]
    height_series = [validate_height_series(h, f"height series {i}") for i, h in enumerate(height_series)]
    if not summaries and not height_series:
        raise InputError("no summaries given")
    if not 0.0 <= poisson < 1.0:
        raise InputError(f"poisson must be in [0, 1), got {poisson}")
    groups: dict[float, list[dict]] = {}
    for s in summaries:
        groups.setdefault(_pressure_key(s["pressure"]), []).append(s)
    hgroups: dict[float, list[dict]] = {}
    for h in height_series:
        hgroups.setdefault(_pressure_key(h["pressure"]), []).append(h)
    pressures = sorted(set(groups) | set(hgroups))
    flat = {}
    for p in pressures:
        rows_p = [flatten(s) for s in groups.get(p, [])]
        if p in hgroups:  # the height series define the tof quantities of this pressure
            rows_p = [{k: v for k, v in r.items() if not k.startswith("tof.")} for r in rows_p]
            rows_p += [flatten({"tof": h}) for h in hgroups[p]]
        flat[p] = rows_p
    quantities = sorted({k for p in pressures for r in flat[p] for k in r})
    rows = []
    for p in pressures:
        stats = {q: describe([r.get(q, math.nan) for r in flat[p]]) for q in quantities}
        mine = groups.get(p, [])
        row = {"pressure": p, "count": len(mine), "n_height_series": len(hgroups.get(p, [])),
               "kinds": sorted({s["kind"] for s in mine}),
               "mean_height": float(np.mean([s["height"] for s in mine])) if mine else math.nan}
        for name, (q, _) in SPEEDS.items():
            row[name], row[name + "_err"] = _speed_with_error(stats, flat[p], q)
        r = row["c_tof"] / row["c_l"] if row["c_l"] else math.nan
        row["c_tof_over_c_l"] = r
        row["c_tof_over_c_l_err"] = abs(r) * math.hypot(row["c_tof_err"] / row["c_tof"],
                                                        row["c_l_err"] / row["c_l"]) \
            if row["c_tof"] and row["c_l"] else math.nan
        row["lattice_frictionless"] = float(theory.lattice_speed(p, friction=False, poisson=poisson))
        row["lattice_frictional"] = float(theory.lattice_speed(p, friction=True, poisson=poisson))
        row["stats"] = stats
        rows.append(row)

    out = {"n_summaries": len(summaries), "n_height_series": len(height_series),
           "pressures": pressures, "poisson": float(poisson),
           "expected_exponent": EXPECTED_EXPONENT, "quantities": quantities}
    notes = []
    for name, (_, kappa) in SPEEDS.items():
        pts = [(row["pressure"], row[name]) for row in rows
               if math.isfinite(row[name]) and row[name] > 0]
        if len(pts) >= 2:
            fit = power_law_fit([a for a, _ in pts], [b for _, b in pts], what=f"{name} against pressure")
            out[kappa], out[kappa + "_err"], out[kappa + "_n"] = fit.exponent, fit.exponent_err, fit.n
            out[kappa + "_ci95"] = list(fit.exponent_ci95)  # Student t, n − 2 (granwave.analysis.fits)
        else:
            out[kappa], out[kappa + "_err"], out[kappa + "_n"] = math.nan, math.nan, len(pts)
            out[kappa + "_ci95"] = [math.nan, math.nan]
            notes.append(f"{kappa}: {name} known at {len(pts)} pressure(s), need 2")
        # p^(1/6) curve through the value at the highest pressure that has one
        if pts:
            p_ref, c_ref = pts[-1]
            for row in rows:
                row[name + "_p16"] = c_ref * (row["pressure"] / p_ref) ** EXPECTED_EXPONENT
        else:
            for row in rows:
                row[name + "_p16"] = math.nan
    if crossover is not None:
        _crossover_fits(out, rows, notes, *crossover)
    out["fit_notes"] = notes
    out["per_pressure"] = rows
    return out


#: the speeds whose crossover pressure ``pressure_sweep(crossover=...)`` fits, and their suffix
CROSSOVER_SPEEDS = {"c_tof": "tof", "c_l": "l", "c_t": "t"}


def _crossover_fits(out: dict, rows: list, notes: list, low: float, high: float) -> None:
    """The crossover fits of :func:`pressure_sweep` into ``out``; each row gets the fitted curve
    ``<speed>_crossover`` (NaN where there is none)."""
    from .crossover import crossover_fit

    for name, tag in CROSSOVER_SPEEDS.items():
        pts = [(row["pressure"], row[name], row[name + "_err"]) for row in rows
               if math.isfinite(row[name]) and row[name] > 0]
        for row in rows:
            row[name + "_crossover"] = math.nan
        if len(pts) < 3:
            notes.append(f"crossover of {name}: known at {len(pts)} pressure(s), need 3")
            continue
        p, c, e = (np.array(v, float) for v in zip(*pts))
        fit = crossover_fit(p, c, e if np.all(np.isfinite(e) & (e > 0)) else None, low=low, high=high,
                            what=f"{name} against pressure")
        out[f"crossover_{tag}"] = fit
        for key in ("p_star", "p_star_lo95", "p_star_hi95", "log10_p_star", "log10_p_star_err"):
            out[key.replace("p_star", f"p_star_{tag}", 1)] = fit[key]
        if fit["note"]:
            notes.append(f"crossover of {name}: {fit['note']}")
            continue
        for row in rows:
            x = math.log(row["pressure"] / fit["p_star"])
            row[name + "_crossover"] = fit["c_star"] * math.exp((low if x <= 0 else high) * x)


# ---------------------------------------------------------------- outputs
def write_sweep(path, result: dict, attrs: dict | None = None) -> None:
    """Write sweep.h5 (schema granwave.sweep) atomically."""
    from ..io import files as F
    from ..io import schema as S

    rows = result["per_pressure"]
    q = result["quantities"]
    mean = np.array([[row["stats"][k]["mean"] for k in q] for row in rows]).reshape(len(rows), len(q))
    std = np.array([[row["stats"][k]["std"] for k in q] for row in rows]).reshape(len(rows), len(q))
    count = np.array([[row["stats"][k]["count"] for k in q] for row in rows],
                     dtype=np.int64).reshape(len(rows), len(q))
    root = {k: v for k, v in result.items() if _is_number(v)}
    root["fit_notes"] = "; ".join(result.get("fit_notes", [])) or "none"
    root.update(attrs or {})
    with F.atomic_h5(path, S.SWEEP, root) as f:
        col = lambda key: np.array([row[key] for row in rows], dtype=float)  # noqa: E731
        F.put(f, S.SWEEP, "sweep/pressure", col("pressure"))
        F.put(f, S.SWEEP, "sweep/n_samples", np.array([row["count"] for row in rows], dtype=np.int64))
        F.put(f, S.SWEEP, "sweep/quantity", np.array([k.encode() for k in q], dtype="S"))
        F.put(f, S.SWEEP, "sweep/mean", mean)
        F.put(f, S.SWEEP, "sweep/std", std)
        F.put(f, S.SWEEP, "sweep/count", count)
        for key in ("c_tof", "c_tof_err", "c_l", "c_l_err", "c_t", "c_t_err", "c_tof_over_c_l",
                    "c_tof_over_c_l_err", "lattice_frictionless", "lattice_frictional"):
            F.put(f, S.SWEEP, f"sweep/{key}", col(key))


def read_sweep(path) -> dict:
    """Read sweep.h5 back: datasets by short name (``pressure``, ``mean`` ...) plus ``attrs``."""
    from ..io import files as F
    from ..io import schema as S

    with F.open_checked(path, S.SWEEP) as f:
        out = {}
        for name in S.DATASETS[S.SWEEP]:
            if name not in f:
                raise InputError(f"{path}: missing dataset {name}")
            v = F._read(f, path, name)  # native float64 / int64, or one line
            out[name.split("/", 1)[1]] = [b.decode() for b in v] if v.dtype.kind == "S" else v
        out["attrs"] = F.read_attrs(f)
    return out


def _fmt(m, s=None) -> str:
    if m is None or not math.isfinite(m):
        return "—"
    if s is None or not math.isfinite(s):
        return f"{m:.6g}"
    return f"{m:.6g} ± {s:.2g}"


def _table(result: dict, columns: Sequence[tuple[str, str, str | None]]) -> tuple[str, str]:
    """(markdown, csv) of per-pressure rows; columns are (label, mean key, err key or None)."""
    rows = result["per_pressure"]
    md = ["| p | n | " + " | ".join(c[0] for c in columns) + " |",
          "|---" * (len(columns) + 2) + "|"]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["pressure", "count"] + [x for c in columns for x in ((c[0], c[0] + "_err") if c[2] else (c[0],))])
    for row in rows:
        vals, cells = [], []
        for label, key, err in columns:
            m = row.get(key, math.nan)
            e = row.get(err, math.nan) if err else None
            cells.append(_fmt(m, e))
            vals += [m] if err is None else [m, e]
        md.append(f"| {row['pressure']:.6g} | {row['count']} | " + " | ".join(cells) + " |")
        w.writerow([repr(row["pressure"]), row["count"]] + ["" if not math.isfinite(v) else repr(float(v)) for v in vals])
    return "\n".join(md) + "\n", buf.getvalue()


def _stat_columns(result: dict, keys: Sequence[tuple[str, str]]) -> list[tuple[str, str, str]]:
    """Lift per-quantity mean/std into row keys for the table helper."""
    cols = []
    for sec, key in keys:
        q = f"{sec}.{key}"
        for row in result["per_pressure"]:
            st = row["stats"].get(q, {"mean": math.nan, "std": math.nan})
            row[f"_{q}_mean"], row[f"_{q}_std"] = st["mean"], st["std"]
        cols.append((key, f"_{q}_mean", f"_{q}_std"))
    return cols


def tables(result: dict) -> dict[str, tuple[str, str]]:
    """The static, moduli and speed tables as {name: (markdown, csv)}.

    statics: docs/method.md §4 quantities (mean ± std over samples); moduli: stress
    ratio and C11, C12, C22, C33, c_l, c_t (mean ± std); speeds: c_tof, c_l,
    c_t (± their uncertainty), c_tof/c_l, the lattice formulas and the
    p^{1/6} curves.
    """
    res = {**result, "per_pressure": [dict(r) for r in result["per_pressure"]]}
    statics = _table(res, _stat_columns(res, [("statics", k) for k in STATICS_TABLE]))
    moduli = _table(res, _stat_columns(res, MODULI_TABLE))
    speeds = _table(res, [("c_tof", "c_tof", "c_tof_err"), ("c_l", "c_l", "c_l_err"),
                          ("c_t", "c_t", "c_t_err"), ("c_tof/c_l", "c_tof_over_c_l", "c_tof_over_c_l_err"),
                          ("lattice (μ=0)", "lattice_frictionless", None),
                          ("lattice (μ>0)", "lattice_frictional", None),
                          ("c_tof ∝ p^1/6", "c_tof_p16", None), ("c_l ∝ p^1/6", "c_l_p16", None),
                          ("c_t ∝ p^1/6", "c_t_p16", None)]
                   + [(f"{name} crossover fit", f"{name}_crossover", None) for name in CROSSOVER_SPEEDS
                      if f"crossover_{CROSSOVER_SPEEDS[name]}" in res])
    return {"statics": statics, "moduli": moduli, "speeds": speeds}


def crossover_text(fit: dict) -> str:
    """p* of a crossover fit as text: the value and its 95 % interval (an open side as ≤ / ≥ the
    sweep's range), or why there is none."""
    if fit.get("note"):
        return f"not determined ({fit['note']})"
    lo, hi = fit["p_star_lo95"], fit["p_star_hi95"]
    interval = f"[{'…' if not math.isfinite(lo) else f'{lo:.3g}'}, {'…' if not math.isfinite(hi) else f'{hi:.3g}'}]"
    return f"{fit['p_star']:.3g} (95 %: {interval}, log10 p* = {fit['log10_p_star']:.3f} ± {fit['log10_p_star_err']:.2g})"


def write_tables(result: dict, folder, prefix: str = "sweep") -> list[str]:
    """Write ``<prefix>_{statics,moduli,speeds}.{md,csv}`` into ``folder``; return the paths."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"tables folder {folder} does not exist")
    written = []
    fits = ", ".join(f"{a} = {_fmt(result.get(a), result.get(a + '_err'))}"
                     for a in ("kappa_tof", "kappa_l", "kappa_t"))
    crossings = "".join(f"; p* of {name} = {crossover_text(result[f'crossover_{tag}'])}"
                        for name, tag in CROSSOVER_SPEEDS.items() if f"crossover_{tag}" in result)
    titles = {"statics": "Static quantities per pressure (mean ± std over samples, docs/method.md §4)",
              "moduli": "Stress ratio and elastic moduli per pressure (mean ± std, docs/method.md §6)",
              "speeds": f"Speeds per pressure (docs/method.md §10); fits c ∝ p^κ: {fits}; expected 1/6{crossings}"}
    for name, (md, text) in tables(result).items():
        md_path, csv_path = folder / f"{prefix}_{name}.md", folder / f"{prefix}_{name}.csv"
        atomic_text(md_path, f"# {titles[name]}\n\n{md}")
        atomic_text(csv_path, text)
        written += [str(md_path), str(csv_path)]
    return written
