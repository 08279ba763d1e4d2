"""The study's report (issue "Workflow" §3): results/report/index.md and index.html.

:func:`build_report` turns the analysis outputs into one Markdown page;
:func:`write_report` writes it and an HTML twin (a small Markdown-to-HTML
converter of our own, :func:`markdown_to_html`, so no extra dependency).
Every number on the page is computed here from the inputs:

* **per-sample summaries** (``results/summary/<scene>/p<p>/<size>/s<seed>.json``,
  layout in docs/summaries.md): the static and moduli tables per scene and
  pressure, as mean ± sample standard deviation over packings with their
  number, and the continuum speeds c_ℓ, c_t;
* **height-series results** (``granwave analyze heights --json``,
  ``results/heights/<scene>/p<p>.json``): c_tof, c_peak, c_zero with their
  uncertainties, γ and α;
* **pressure-sweep results** (``granwave pressure-sweep --json``): their fitted
  numbers are listed as given;
* **the theory** (:mod:`granwave.theory`): the triangular-lattice speeds, the
  p^{1/6} exponent (taken from the lattice formula) and the chain's exact γ
  and α (taken from the Airy asymptote at very large N, see
  :func:`chain_exact_exponents`);
* **figures**: every PNG of the figure folders, linked relative to the page,
  with the caption of its ``granwave plot`` subcommand (file named
  ``<subcommand>[_suffix].png``, see docs/figures.md).

Scenes: a file's scene is its ``scene`` key, else the first folder below the
input folder given (``summary/<scene>/...``), else the folder before the
``p<pressure>`` part of the workflow layout (``summary/<scene>/p<p>/<size>/s<seed>.json``,
``heights/<scene>/p<p>.json``), else its parent folder's name.
The scene's kind (disordered / lattices / chains) and its friction come from
the workflow config when given, else from the summaries (``kind``,
``friction``) or the scene name (``lattice*``, ``chain*``).

Fits over pressure: c ∝ p^α by least squares in log–log coordinates through
the per-pressure values (:func:`granwave.analysis.fits.power_law_fit`); the
uncertainty is one standard error (undetermined with two pressures).
"""

from __future__ import annotations

import html
import json
import math
import os
import re
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from .errors import InputError
from .io.files import atomic_text, load_json

# Preferred order of the static and moduli quantities (any other scalar follows).
STATICS_KEYS = ("phi2", "phi3", "phi3_star", "z_star", "rattler_fraction", "mean_force_over_p",
                "Z2", "Z3", "F2", "F2_strong", "stress_ratio")
MODULI_KEYS = ("C11", "C12", "C22", "C33", "c_l", "c_t", "phi3_star")
SPEED_KEYS = ("c_tof", "c_peak", "c_zero")
LABELS = {
    "phi2": "Φ2", "phi3": "Φ3", "phi3_star": "Φ3*", "z_star": "z*", "rattler_fraction": "f0 (rattlers)",
    "mean_force_over_p": "⟨N⟩/p", "Z2": "Z(2)", "Z3": "Z(3)", "F2": "F2 = ⟨n_y²⟩",
    "F2_strong": "F2^S (strong)", "stress_ratio": "σ1/σ2", "C11": "C11 [E*]", "C12": "C12 [E*]",
    "C22": "C22 [E*]", "C33": "C33 [E*]", "c_l": "c_ℓ [√(E*/ρ)]", "c_t": "c_t [√(E*/ρ)]",
}


# ====================================================================== reading
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


def _scene_of(path: Path, obj, guess: str | None) -> str:
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


def _num(x) -> float:
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
    keys = ("t_lead10", "t_peak", "t_zero", "amplitude", "width")
    if isinstance(obj.get("samples"), list) and obj["samples"]:
        rows = obj["samples"]
        data = {"height": np.array([_num(r.get("height")) for r in rows])}
        for k in keys:
            data[k] = np.array([_num(r.get(k)) for r in rows])
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


def chain_series(n_balls: Sequence[int], *, ic: str = "A") -> dict:
    """Front features of the exact identical-ball chain (theory) against L = N + 1.

    Units of the chain: ℓ = K = m = 1 (c = 1); L = N + 1 is the wall-to-wall
    distance. Each signal is the exact modal sum sampled 20 times per unit
    time from 0 to t0 + 10 N^{1/3}.
    """
    from .analysis.front import front_features
    from .theory import chain_wall_force

    ns = sorted({int(n) for n in n_balls})
    if not ns or ns[0] < 2:
        raise InputError("chain lengths must be at least 2")
    rows = []
    for n in ns:
        t = np.arange(0.0, n + 1 + 10 * n ** (1 / 3), 0.05)
        rows.append(front_features(t, chain_wall_force(t, n, ic=ic)).as_dict())
    out = {"height": np.array([n + 1.0 for n in ns])}
    for k in ("t_lead10", "t_peak", "t_zero", "amplitude", "width"):
        out[k] = np.array([r[k] for r in rows])
    return out


def chain_exact_exponents(ic: str = "A", *, n_balls: tuple[int, int] = (10**6, 8 * 10**6)) -> dict:
    """γ and α of the chain from the theory's Airy asymptote (SPEC §12).

    The front features of :func:`granwave.theory.chain_wall_force_airy` at two
    very large N give d log A / d log L and d log W / d log L; the corrections
    are of relative order N^{-1/3}·(1/N) and vanish at the digits shown.
    """
    from .analysis.front import front_features
    from .theory import chain_wall_force_airy

    feats = []
    for n in n_balls:
        w = n ** (1 / 3)
        t = (n + 1) + np.linspace(-15 * w, 15 * w, 6001)
        feats.append(front_features(t, chain_wall_force_airy(t, n, ic=ic)))
    lr = math.log((n_balls[1] + 1) / (n_balls[0] + 1))
    return {"gamma": -math.log(feats[1].amplitude / feats[0].amplitude) / lr,
            "alpha": math.log(feats[1].width / feats[0].width) / lr}


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
        return _num(val), _num(err)
    return _num(v), math.nan


def sweep_speeds(obj, *, source="sweep") -> dict:
    """Per-pressure speeds (``pressure``, ``c_tof``, ``c_l``, ``c_t`` and ``*_err``) from
    a ``pressure-sweep --json`` object (rows with a ``pressure`` key, or columns)."""
    rows = _rows_with_pressure(obj)
    out: dict = {}
    if rows:
        out["pressure"] = np.array([_num(r["pressure"]) for r in rows])
        for k in ("c_tof", "c_l", "c_t", "c_peak", "c_zero"):
            vals = [_value_err(r.get(k)) for r in rows]
            errs = [_num(r.get(k + "_err", r.get(k + "_std", e))) for r, (_, e) in zip(rows, vals)]
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


# ====================================================================== numbers
def fmt(x, err=None, digits: int = 4) -> str:
    """``x ± err`` with ``digits`` significant digits; '—' for missing numbers."""
    x = _num(x)
    if not math.isfinite(x):
        return "—"
    s = f"{x:.{digits}g}"
    e = _num(err)
    if err is not None and math.isfinite(e):
        s += " ± 0" if abs(e) <= 1e-12 * abs(x) else f" ± {e:.2g}"
    return s


def mean_std(values) -> tuple[float, float, int]:
    """Mean, sample standard deviation (NaN for one value) and count of finite values."""
    v = np.array([_num(x) for x in values], float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan, 0
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else math.nan, int(v.size)


def _scalars(section: Mapping, prefix: str = "") -> dict:
    out = {}
    for k, v in section.items():
        if isinstance(v, bool):
            continue
        if isinstance(v, (int, float)):
            out[prefix + k] = v
        elif isinstance(v, Mapping) and not prefix:
            out.update(_scalars(v, prefix=f"{k}."))
    return out


def _ordered_keys(preferred: Sequence[str], present: Iterable[str]) -> list[str]:
    present = list(dict.fromkeys(present))
    return [k for k in preferred if k in present] + [k for k in present if k not in preferred]


def _pressure_key(p) -> float:
    return float(f"{_num(p):.6g}")


def power_exponent(p, c) -> tuple[float, float]:
    """Fitted α of c ∝ p^α through the finite positive points (NaN if fewer than two)."""
    from .analysis.fits import power_law_fit

    p, c = np.asarray(p, float), np.asarray(c, float)
    ok = np.isfinite(p) & np.isfinite(c) & (p > 0) & (c > 0)
    if np.unique(p[ok]).size < 2:
        return math.nan, math.nan
    fit = power_law_fit(p[ok], c[ok])
    return fit.exponent, fit.exponent_err


# ====================================================================== report
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
                self.summary_friction.setdefault(sc, _num(s["friction"]))

    def kind_of(self, scene: str) -> str:
        if scene in self.kind:
            return self.kind[scene]
        if scene in self.summary_kind:
            return self.summary_kind[scene]
        name = scene.lower()
        return "lattices" if "lattice" in name else "chains" if "chain" in name else "disordered"

    def friction_of(self, scene: str) -> float:
        if "friction" in self.spec.get(scene, {}):
            return _num(self.spec[scene]["friction"])
        if scene in self.summary_friction:
            return self.summary_friction[scene]
        return math.nan

    def poisson_of(self, scene: str) -> float:
        return _num(self.spec.get(scene, {}).get("poisson", 0.0))

    def ic_of(self, scene: str, obj: Mapping | None = None) -> str:
        if obj is not None and obj.get("ic") not in (None, "none"):
            return str(obj["ic"])
        return str(self.spec.get(scene, {}).get("ic", "A"))


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return lines + [""]


def _section_table(groups: Mapping[float, list[Mapping]], section: str,
                   preferred: Sequence[str]) -> list[str] | None:
    """Quantities as rows, pressures as columns, mean ± std over the packings."""
    per_p = {}
    keys = []
    for p, items in sorted(groups.items()):
        vals = defaultdict(list)
        for s in items:
            sec = s.get(section)
            if isinstance(sec, Mapping):
                for k, v in _scalars(sec).items():
                    vals[k].append(v)
        if vals:
            per_p[p] = vals
            keys += list(vals)
    if not per_p:
        return None
    keys = _ordered_keys(preferred, keys)
    ps = sorted(per_p)
    header = ["quantity"] + [f"p = {p:.3g}" for p in ps]
    rows = [["packings"] + [str(max(len(v) for v in per_p[p].values())) for p in ps]]
    for k in keys:
        cells = []
        for p in ps:
            m, sd, n = mean_std(per_p[p].get(k, []))
            cells.append(fmt(m, sd if n > 1 else None) + (f" (n={n})" if 0 < n < len(groups[p]) else ""))
        rows.append([LABELS.get(k, k)] + cells)
    return _table(header, rows)


def build_report(*, summaries: Sequence[tuple[Path, object, str | None]] = (),
                 heights: Sequence[tuple[Path, object, str | None]] = (),
                 sweeps: Sequence[tuple[Path, object, str | None]] = (),
                 figures: Sequence[Path] = (), out_dir: Path = Path("."),
                 config: Mapping | None = None, config_path: str | None = None,
                 title: str = "granwave report", damping: Sequence[Mapping] = ()) -> str:
    """The report as Markdown (see the module docstring for every source).

    ``damping``: rows of `granwave analyze damping --json` (one per contact damping ζ).
    """
    from . import __version__
    from .provenance import git_revision

    from .analysis.sweep import validate_summary

    sums = []
    for path, obj, guess in summaries:
        items = obj if isinstance(obj, list) else [obj]  # a file holds one summary or a list
        for k, item in enumerate(items):
            validate_summary(item, f"{path}" + (f"[{k}]" if isinstance(obj, list) else ""))
            sums.append({**item, "_scene": _scene_of(path, item, guess), "_path": str(path)})
    hts = []
    for path, obj, guess in heights:
        if not isinstance(obj, Mapping):
            raise InputError(f"{path}: expected an `analyze heights --json` object")
        hts.append({**obj, "_scene": _scene_of(path, obj, guess), "_path": str(path)})
    scenes = Scenes(config, sums)

    name = (config or {}).get("name") or (Path(config_path).stem if config_path else "(none given)")
    md = [f"# {title}", ""]
    md += [f"- configuration: **{name}**" + (f" (`{config_path}`)" if config_path else ""),
           f"- granwave {__version__}, git revision `{git_revision()}`",
           f"- inputs: {len(sums)} sample summaries, {len(hts)} height series, "
           f"{len(sweeps)} pressure sweeps, {len(figures)} figures",
           "- units (SPEC §1): lengths d̄, pressures and moduli E*, forces E* d̄², "
           "speeds √(E*/ρ), times d̄/√(E*/ρ)", ""]

    by_scene: dict[str, dict[float, list]] = defaultdict(lambda: defaultdict(list))
    for s in sums:
        by_scene[s["_scene"]][_pressure_key(s["pressure"])].append(s)
    h_by_scene: dict[str, dict[float, Mapping]] = defaultdict(dict)
    for h in hts:
        if h.get("pressure") is not None:
            h_by_scene[h["_scene"]][_pressure_key(h["pressure"])] = h

    # ---- statics and moduli
    md += ["## Statics per pressure", "",
           "Mean ± standard deviation over the packings (first row: their number; "
           "`(n=…)` where a quantity is missing in some).", ""]
    md += _per_scene_tables(by_scene, "statics", STATICS_KEYS, "No static measurements among the inputs.")
    md += ["## Elastic moduli per pressure", ""]
    md += _per_scene_tables(by_scene, "moduli", MODULI_KEYS, "No moduli among the inputs.")

    # ---- speeds against pressure
    md += _speeds_section(by_scene, h_by_scene, scenes)

    # ---- front exponents
    md += _exponents_section(hts, scenes)

    # ---- lattices against the formula
    md += _lattice_section(h_by_scene, scenes)

    # ---- damping series (SPEC §11)
    if damping:
        md += _damping_section(damping)

    # ---- pressure sweeps as given
    if sweeps:
        md += ["## Pressure-sweep fits (`granwave pressure-sweep`)", "",
               "The fitted exponents c ∝ p^α of each sweep file, as computed by `pressure-sweep` "
               "(through the per-pressure means of the summaries).", ""]
        for path, obj, guess in sweeps:
            name = obj.get("scene") if isinstance(obj, Mapping) and obj.get("scene") else Path(path).stem
            md += [f"### {name}", ""] + _sweep_table(obj)
    # ---- figures
    md += ["## Figures", ""]
    if not figures:
        md += ["No figures given.", ""]
    from .plots import caption_for

    for f in figures:
        rel = Path(os.path.relpath(f, out_dir)).as_posix()
        cap = caption_for(f)
        md += [f"### {cap}", "", f"![{cap}]({rel})", ""]
        twin = Path(f).with_suffix(".pdf")
        if twin.exists() and twin != Path(f):
            md += [f"[PDF]({Path(os.path.relpath(twin, out_dir)).as_posix()})", ""]
    return "\n".join(md).rstrip() + "\n"


def _per_scene_tables(by_scene, section: str, keys, if_none: str) -> list[str]:
    """One mean ± std table of a summary section per scene, or ``if_none``."""
    md = []
    for scene in sorted(by_scene):
        t = _section_table(by_scene[scene], section, keys)
        if t:
            md += [f"### {scene}", ""] + t
    return md or [if_none, ""]


def _damping_section(rows: Sequence[Mapping]) -> list[str]:
    """Coherent amplitude and tail rms against the contact damping ζ (nonlinear DEM kicks)."""
    md = ["## Damping series (nonlinear DEM, SPEC §11)", "",
          "One packing kicked in the Hertz–Mindlin DEM with contact damping ζ (fraction of "
          "critical). Amplitude: first-pulse peak; tail rms: rms of the signal after the least "
          "damped signal's first zero crossing plus one pulse width (`granwave analyze damping`).", ""]
    body = [[fmt(r.get("damping")), fmt(r.get("amplitude")), fmt(r.get("width")),
             fmt(r.get("tail_rms")), fmt(r.get("tail_rms_over_amplitude"))]
            for r in sorted(rows, key=lambda r: float(r.get("damping", 0.0)))]
    return md + _table(["ζ", "amplitude A", "width W", "tail rms", "tail rms / A"], body) + [""]


def _sweep_table(obj) -> list[str]:
    if not isinstance(obj, Mapping):
        return ["(not a sweep object)", ""]
    alphas = [k for k in obj if k.startswith("alpha_") and not k.endswith(("_err", "_n"))]
    if alphas:
        rows = [[k, fmt(obj[k], obj.get(k + "_err")),
                 str(obj.get(k + "_n", "")) if obj.get(k + "_n") is not None else ""] for k in alphas]
        if obj.get("expected_exponent") is not None:
            rows.append(["expected (fixed Hertzian network)", fmt(obj["expected_exponent"]), ""])
        return _table(["exponent", "value", "pressures"], rows)
    scal = _scalars(obj)
    if not scal:
        return ["(no scalar results)", ""]
    return _table(["quantity", "value"], [[k, fmt(v, digits=5)] for k, v in scal.items()])


def _speeds_section(by_scene, h_by_scene, scenes: Scenes) -> list[str]:
    from .theory import lattice_speed

    md = ["## Sound speeds against pressure", "",
          "c_tof, c_peak, c_zero: height series (`analyze heights`; ± one standard error); "
          "c_ℓ = √(C22/Φ3*), c_t = √(C33/Φ3*): mean ± std over packings. "
          "Exponents: fit c ∝ p^α over the pressures.", ""]
    q1, q2 = 1e-6, 1e-4
    hertz = math.log(lattice_speed(q2) / lattice_speed(q1)) / math.log(q2 / q1)
    md += [f"Fixed Hertzian network (triangular-lattice formula, SPEC §12): α = {hertz:.4f}.", ""]
    names = sorted(s for s in set(by_scene) | set(h_by_scene) if scenes.kind_of(s) == "disordered")
    if not names:
        return md + ["No disordered scenes among the inputs.", ""]
    for scene in names:
        ps = sorted(set(by_scene.get(scene, {})) | set(h_by_scene.get(scene, {})))
        cols = defaultdict(list)
        rows = []
        for p in ps:
            items = by_scene.get(scene, {}).get(p, [])
            h = h_by_scene.get(scene, {}).get(p, {})
            row = [f"{p:.3g}", str(len(items))]
            vals = {}
            for k in SPEED_KEYS:
                v, e = _num(h.get(k)), _num(h.get(k + "_err"))
                if not math.isfinite(v):  # fall back to the per-sample time-of-flight section
                    v, e, _ = mean_std([(s.get("tof") or {}).get(k) for s in items])
                vals[k] = (v, e)
                row.append(fmt(v, e))
            for k in ("c_l", "c_t"):
                m, sd, n = mean_std([(s.get("moduli") or {}).get(k) for s in items])
                vals[k] = (m, sd)
                row.append(fmt(m, sd if n > 1 else None))
            (ct, ect), (cl, ecl) = vals["c_tof"], vals["c_l"]
            r = ct / cl if cl else math.nan
            er = abs(r) * math.hypot(ect / ct if ct else math.nan, ecl / cl if cl else math.nan)
            row.append(fmt(r, er if math.isfinite(er) else None))
            rows.append(row)
            for k, (v, _) in vals.items():
                cols[k].append(v)
            cols["p"].append(p)
        md += [f"### {scene}", ""]
        md += _table(["p [E*]", "packings", "c_tof", "c_peak", "c_zero", "c_ℓ", "c_t", "c_tof/c_ℓ"], rows)
        fits = [[k, fmt(*power_exponent(cols["p"], cols[k]))]
                for k in ("c_tof", "c_peak", "c_zero", "c_l", "c_t")]
        md += _table(["speed", "exponent α (c ∝ p^α)"], fits)
    return md


def _exponents_section(hts, scenes: Scenes) -> list[str]:
    md = ["## Front scaling with distance: γ and α", "",
          "A ∝ L^−γ and W ∝ L^α from the height series (± one standard error), against "
          "the identical-ball chain's exact values (Airy asymptote of `granwave.theory`, "
          "SPEC §12).", ""]
    exact = {ic: chain_exact_exponents(ic) for ic in ("A", "B")}
    md += _table(["chain (exact)", "γ", "α"],
                 [[f"initial condition {ic}", fmt(e["gamma"]), fmt(e["alpha"])] for ic, e in exact.items()])
    if not hts:
        return md + ["No height series among the inputs.", ""]
    hts = [h for h in hts if h.get("gamma") is not None or h.get("alpha") is not None]
    rows = []
    for h in sorted(hts, key=lambda h: (scenes.kind_of(h["_scene"]), h["_scene"], _num(h.get("pressure")))):
        ic = scenes.ic_of(h["_scene"], h)
        e = exact.get(ic.upper(), exact["A"])
        g, ge = _num(h.get("gamma")), _num(h.get("gamma_err"))
        a, ae = _num(h.get("alpha")), _num(h.get("alpha_err"))
        rows.append([h["_scene"], scenes.kind_of(h["_scene"]), fmt(h.get("pressure"), digits=3), ic,
                     fmt(g, ge), fmt(a, ae), fmt(e["gamma"]), fmt(e["alpha"]),
                     fmt(g / e["gamma"]) if math.isfinite(g) else "—",
                     fmt(a / e["alpha"]) if math.isfinite(a) else "—"])
    md += _table(["scene", "kind", "p", "ic", "γ", "α", "γ chain", "α chain", "γ/γ chain",
                  "α/α chain"], rows)
    return md


def _lattice_section(h_by_scene, scenes: Scenes) -> list[str]:
    from .theory import lattice_speed

    md = ["## Triangular lattices against the formula", "",
          "c_theory = 3^{19/12}/(2^{3/2} π^{1/2}) p^{1/6} (× √(1 + η/3) with friction), "
          "`granwave.theory.lattice_speed`; the simulated speeds from the height series.", ""]
    names = sorted(s for s in h_by_scene if scenes.kind_of(s) == "lattices")
    if not names:
        return md + ["No lattice height series among the inputs.", ""]
    rows = []
    for scene in names:
        mu = scenes.friction_of(scene)
        frictional = bool(math.isfinite(mu) and mu > 0)
        for p, h in sorted(h_by_scene[scene].items()):
            c = lattice_speed(p, friction=frictional, poisson=scenes.poisson_of(scene))
            row = [scene, fmt(mu, digits=3), f"{p:.3g}", fmt(c)]
            for k in SPEED_KEYS:
                v, e = _num(h.get(k)), _num(h.get(k + "_err"))
                row += [fmt(v, e), fmt(v / c)]
            rows.append(row)
    md += _table(["scene", "μ", "p", "c_theory", "c_tof", "c_tof/c_theory", "c_peak",
                  "c_peak/c_theory", "c_zero", "c_zero/c_theory"], rows)
    return md


# ====================================================================== HTML
_INLINE = [
    (re.compile(r"!\[([^\]]*)\]\(([^)\s]+)\)"),
     lambda m: f'<img src="{m.group(2)}" alt="{m.group(1)}">'),
    (re.compile(r"\[([^\]]+)\]\(([^)\s]+)\)"), lambda m: f'<a href="{m.group(2)}">{m.group(1)}</a>'),
    (re.compile(r"`([^`]+)`"), lambda m: f"<code>{m.group(1)}</code>"),
    (re.compile(r"\*\*([^*]+)\*\*"), lambda m: f"<strong>{m.group(1)}</strong>"),
]


def _inline(text: str) -> str:
    text = html.escape(text, quote=False)
    for rx, sub in _INLINE:
        text = rx.sub(sub, text)
    return text


def markdown_to_html(md: str, title: str = "granwave report") -> str:
    """The small Markdown subset the report uses: headings, paragraphs, '-' lists,
    pipe tables, images, links, `code` and **bold**."""
    out = ["<!DOCTYPE html>", '<html><head><meta charset="utf-8">',
           f"<title>{html.escape(title)}</title>",
           "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}"
           "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
           "padding:.2em .6em;text-align:right}td:first-child,th:first-child{text-align:left}"
           "img{max-width:100%}</style>", "</head><body>"]
    lines = md.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.strip():
            i += 1
            continue
        m = re.match(r"(#{1,6})\s+(.*)", line)
        if m:
            n = len(m.group(1))
            out.append(f"<h{n}>{_inline(m.group(2))}</h{n}>")
            i += 1
        elif line.startswith("|"):
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append([c.strip() for c in lines[i].strip().strip("|").split("|")])
                i += 1
            out.append("<table>")
            for k, r in enumerate(rows):
                if k == 1 and all(re.fullmatch(r":?-+:?", c) for c in r):
                    continue
                tag = "th" if k == 0 else "td"
                out.append("<tr>" + "".join(f"<{tag}>{_inline(c)}</{tag}>" for c in r) + "</tr>")
            out.append("</table>")
        elif line.startswith("- "):
            out.append("<ul>")
            while i < len(lines) and lines[i].startswith("- "):
                out.append(f"<li>{_inline(lines[i][2:])}</li>")
                i += 1
            out.append("</ul>")
        else:
            para = []
            while (i < len(lines) and lines[i].strip() and not lines[i].startswith(("#", "|", "- "))):
                para.append(lines[i])
                i += 1
            out.append(f"<p>{_inline(' '.join(para))}</p>")
    out.append("</body></html>")
    return "\n".join(out) + "\n"


# ====================================================================== writing
def write_report(path, markdown: str, *, title: str = "granwave report") -> list[Path]:
    """Write ``path`` (Markdown) and the HTML twin beside it (same stem, .html), atomically."""
    path = Path(path)
    if path.suffix.lower() != ".md":
        raise InputError(f"{path}: the report must be a .md file")
    path.parent.mkdir(parents=True, exist_ok=True)
    html_path = path.with_suffix(".html")
    atomic_text(path, markdown)
    atomic_text(html_path, markdown_to_html(markdown, title))
    return [path, html_path]


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
    """The workflow config (YAML or JSON) as a dict."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such config file")
    text = path.read_text()
    try:
        import yaml

        obj = yaml.safe_load(text)
    except ImportError:  # pragma: no cover - pyyaml ships with snakemake
        obj = json.loads(text)
    except Exception as exc:  # yaml.YAMLError
        raise InputError(f"{path}: not a YAML file ({exc.__class__.__name__})") from None
    if not isinstance(obj, dict):
        raise InputError(f"{path}: the config must be a mapping")
    return obj
