"""Helpers of the Snakemake workflow: closed-form record lengths and the per-sample pipeline.

:func:`crossing_time` uses only the closed forms (it runs while Snakemake builds
its job graph, before any file exists). :func:`run_sample` runs the whole
per-sample chain (make the sample, linearize, signal, statics, moduli, front,
summary) inside one process, so that a batch of samples pays the interpreter
and numba start-up once instead of once per stage and sample
(workflow/scripts/sample_batch.py; measured in config/README.md).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from .geometry import grain_mass
from .systems import default_chain_stiffness
from .theory import chain_travel_time, lattice_speed

#: Bulk layer excluded at each wall by the statics (docs/method.md §4); a container needs a
#: bulk (height > 2 layers + 1 d) to have bulk statics at all.
STATICS_LAYER = 3.0


def crossing_time(kind: str, spec: dict, pressure: float, size: str) -> float:
    """Time (d/sqrt(E*/rho)) for a front to cross one sample, estimated from theory.

    ``kind`` is the config section ("disordered", "lattices", "chains") and
    ``size`` the sample's size label (h<height>, r<rows>, n<balls>). Disordered
    packings and lattices use the perfect-lattice speed of docs/method.md §12 (with
    friction when the scene has it), which is an upper bound of the disordered
    speed, so the real arrival comes later than this estimate; chains use
    their exact wall-to-wall time (N+1) l / c with unit balls.
    """
    value = float(size[1:])
    if kind == "chains":
        return chain_travel_time(int(value), stiffness=default_chain_stiffness(pressure),
                                 mass=float(grain_mass(0.5)))
    height = value * math.sqrt(3.0) / 2.0 if kind == "lattices" else value
    return height / lattice_speed(pressure, friction=spec.get("friction", 0.0) > 0,
                                  poisson=spec.get("poisson", 0.0))


def _write_json(path, obj) -> None:
    """One JSON object, as `granwave ... --json` prints it (NaN -> null), written atomically."""
    from .io.files import jsonable
    from .io.files import atomic_text

    atomic_text(path, json.dumps(jsonable(obj), indent=1) + "\n")


def make_sample(kind: str, make: dict):
    """The sample's packing: DEM preparation, perfect lattice or chain (``make``: their options)."""
    if kind in ("disordered", "continuum"):
        from .dem.params import PrepareParams
        from .dem.protocol import prepare_packing

        return prepare_packing(PrepareParams(**make))
    if kind == "lattices":
        from .systems import triangular_lattice

        return triangular_lattice(**make)
    from .systems import chain

    return chain(**make)


def front_section(sig) -> dict:
    """The front section of a summary: what `granwave analyze front --json` prints (defaults)."""
    from . import api

    return api.front(sig)


def signal_of(system, path_linear: str, *, method: str, ic: str, t_max: float, samples: int,
              safety: float):
    """The top-wall signal of a linear system, as `granwave propagate` makes it.

    ``method``: modal, time or auto, as :func:`granwave.api.propagate` takes it (auto: the
    cheaper by :func:`granwave.api.choose_method`, the one home of that cost model). The
    signal's ``method_choice`` attribute says what was chosen and why.
    """
    from . import api
    from .params import PropagateParams

    system.attrs["linear_source"] = str(path_linear)
    sig = api.propagate(system, PropagateParams(method=method, ic=ic, t_max=t_max, samples=samples,
                                                safety=safety))
    reason = sig.attrs.get("method_reason")
    sig.attrs["method_choice"] = f"auto: {reason}" if reason else method
    return sig


def run_sample(sample: dict, log=print) -> list[dict]:
    """Run one sample's pipeline and write its files; return the timing of each stage.

    ``sample``: ``kind`` (disordered | lattices | chains | continuum), ``scene``, ``make`` (options of
    :func:`make_sample`), ``signal`` (method, ic, t_max, samples) and ``out``, the paths
    to write: packing, linear, signal, front, summary, and optionally statics and moduli
    (the stages a scene has); ``local_moduli`` (default True): False for global moduli only;
    ``moduli_may_fail`` (default False): a moduli solve that fails (no accurate solution of
    D u = f, e.g. a floppy mode under the imposed strain) writes
    ``{"c_l": null, "c_t": null, "error": ...}`` instead of stopping the batch.
    Each file is written atomically as soon as it is made.
    Downstream stages read the files back, so they see exactly what a separate
    `granwave` command would. Timings: one dict per stage with CPU and wall seconds.
    """
    from .analysis.statics import statics
    from .errors import ConvergenceError, InputError
    from .analysis.sweep import merge_summary, write_summary
    from .io import files
    from .linear.assemble import linearize
    from .linear.moduli import moduli

    out = sample["out"]
    timings = []

    def timed(stage, fn):
        c0, w0 = time.process_time(), time.perf_counter()
        result = fn()
        timings.append({"stage": stage, "cpu_s": time.process_time() - c0,
                        "wall_s": time.perf_counter() - w0})
        return result

    for path in out.values():
        Path(path).parent.mkdir(parents=True, exist_ok=True)

    def packing_stage():
        pk = make_sample(sample["kind"], sample["make"])
        files.write_packing(out["packing"], pk)
        return files.read_packing(out["packing"])

    packing = timed("packing", packing_stage)

    def linear_stage():
        pk = files.read_packing(out["packing"])
        pk.attrs["source_file"] = str(out["packing"])
        files.write_linear(out["linear"], linearize(pk))
        return files.read_linear(out["linear"])

    system = timed("linear", linear_stage)
    sig_opts = sample["signal"]

    def signal_stage():
        sig = signal_of(system, out["linear"], **sig_opts)
        sig.attrs["source_file"] = str(out["linear"])
        files.write_signal(out["signal"], sig)
        return files.read_signal(out["signal"])

    sig = timed("signal", signal_stage)
    sections = {}
    if "statics" in out:
        sections["statics"] = timed("statics", lambda: statics(packing, layer=STATICS_LAYER))
        _write_json(out["statics"], sections["statics"])
    if "moduli" in out:
        local = sample.get("local_moduli", True)  # continuum columns: global moduli only

        def moduli_stage():
            try:
                return moduli(packing, local=local, layer=STATICS_LAYER)
            except (ConvergenceError, InputError) as exc:
                if not sample.get("moduli_may_fail"):
                    raise
                # a tall column whose stiffness matrix has a floppy mode under the imposed
                # strain: no c_l for this packing (NaN in the continuum analysis), the batch goes on
                log(f"{out['moduli']}: no moduli: {exc}")
                return {"c_l": None, "c_t": None, "error": str(exc)}

        sections["moduli"] = timed("moduli", moduli_stage)
        _write_json(out["moduli"], sections["moduli"])
    sections["front"] = timed("front", lambda: front_section(sig))
    _write_json(out["front"], sections["front"])
    write_summary(out["summary"], merge_summary(attrs=sig.attrs, scene=sample["scene"], **sections))
    meta = {"n_grains": int(packing.n_grains), "n_dof": int(system.n_dof),
            "steps": int(packing.attrs.get("steps", 0))}
    for t in timings:
        t.update(meta)
    log(f"{out['summary']}: " + ", ".join(f"{t['stage']} {t['cpu_s']:.2f} s" for t in timings))
    return timings


SCENE_KINDS = ("disordered", "lattices", "chains", "continuum")


def _key(path) -> str:
    """A config key path as written in YAML terms: damping.scene, disordered.x.heights[1]."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def schema_error(config: dict, schema: dict) -> str | None:
    """The first schema violation of ``config`` as one line naming its key, or None.

    Checked before Snakemake's own validation (which fills in the defaults), whose
    message quotes the whole schema.
    """
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema)
    error = jsonschema.exceptions.best_match(validator.iter_errors(config))
    if error is None:
        return None
    if error.validator == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        extra = sorted(set(error.instance) - set(known))
        key = _key([*error.absolute_path, extra[0]]) if extra else _key(error.absolute_path)
        hint = f" (known keys: {', '.join(known)})" if known else ""
        return f"config: unknown key {key}{hint}"
    if "propertyNames" in error.absolute_schema_path:
        return (f"config: {_key([*error.absolute_path, error.instance])}: a scene name must start "
                "with a letter and hold only letters, digits and _ (it becomes part of paths and "
                "job names)")
    return f"config: {_key(error.absolute_path)}: {error.message}"


def samples_error(batches) -> str | None:
    """The first sample of ``batches`` (``[(name, scene, samples)]``, as the workflow builds them)
    whose options its stage would refuse, as one line naming the scene and sample; None if all
    pass. The workflow calls this at parse time, so that a value the CLI refuses (a pressure
    out of range, a seed too large, ...) stops a dry run instead of a job hours later."""
    from .errors import InputError
    from .params import ChainParams, LatticeParams, PrepareParams, PropagateParams

    makers = {"disordered": PrepareParams, "continuum": PrepareParams, "lattices": LatticeParams,
              "chains": ChainParams}
    for _name, scene, items in batches:
        for sample in items:
            where = f"config: {scene}, sample {sample['pressure']}/{sample['size']}/s{sample['seed']}"
            make = dict(sample["make"])
            if sample["kind"] == "chains":
                make["balls"] = make.pop("n_balls")
            sig = sample["signal"]
            try:
                makers[sample["kind"]](**make)
                PropagateParams(method=sig["method"], ic=sig["ic"], t_max=sig["t_max"],
                                samples=sig["samples"], safety=sig["safety"])
            except InputError as exc:
                return f"{where}: {exc}"
    return None


def cross_reference_error(config: dict) -> str | None:
    """The first inconsistency between keys of a (schema-valid, defaulted) config, or None.

    Checks: a scene name is used once over disordered / lattices / chains; a height
    series sits at pressures of its scene; the damping series names a disordered scene
    and one of its samples (its linear reference signal is that sample's); edge
    heights are two different heights.
    """
    owner = {}
    for kind in SCENE_KINDS:
        for scene in config.get(kind) or {}:
            if scene in owner:
                return f"config: scene {scene!r} is defined twice ({owner[scene]}.{scene} and {kind}.{scene})"
            owner[scene] = kind
    for scene, spec in (config.get("disordered") or {}).items():
        series = spec.get("series")
        if series:
            for i, p in enumerate(series["pressures"]):
                if p not in spec["pressures"]:
                    return (f"config: disordered.{scene}.series.pressures[{i}] = {p:g} is not one of "
                            f"disordered.{scene}.pressures ({', '.join(f'{q:g}' for q in spec['pressures'])})")
    damping = config.get("damping") or {}
    if damping.get("enabled"):
        scene = damping["scene"]
        if owner.get(scene) != "disordered":
            have = ", ".join(config.get("disordered") or {}) or "none"
            where = f" (it is a {owner[scene]} scene)" if scene in owner else ""
            return (f"config: damping.scene = {scene!r} is not a disordered scene{where}; "
                    f"disordered scenes: {have}")
        spec = config["disordered"][scene]
        series = spec.get("series") or {"pressures": [], "heights": []}
        if damping["pressure"] not in spec["pressures"]:
            return (f"config: damping.pressure = {damping['pressure']:g} is not one of "
                    f"disordered.{scene}.pressures ({', '.join(f'{q:g}' for q in spec['pressures'])})")
        heights = list(spec["heights"])
        if damping["pressure"] in series["pressures"]:
            heights += series["heights"]
        if damping["height"] not in heights:
            return (f"config: damping.height = {damping['height']:g} is not a height of "
                    f"disordered.{scene} at pressure {damping['pressure']:g} "
                    f"({', '.join(f'{h:g}' for h in sorted(set(heights)))})")
    edges = config.get("edge_heights")
    if edges and not edges[0] < edges[1]:
        return f"config: edge_heights = {list(edges)} must be two heights, lower first"
    return None
