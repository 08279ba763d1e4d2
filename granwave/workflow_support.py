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
import os
import time
from pathlib import Path

from .geometry import grain_mass
from .systems import default_chain_stiffness
from .theory import chain_travel_time, lattice_speed
from .workflow_config import shear_record_length

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
    contact = spec.get("contact") or {}
    if kind == "chains":
        stiffness = default_chain_stiffness(pressure) if not contact else law_chain_stiffness(pressure, contact)
        return chain_travel_time(int(value), stiffness=stiffness, mass=float(grain_mass(0.5)))
    height = value * math.sqrt(3.0) / 2.0 if kind == "lattices" else value
    if contact:  # the scene's contact law: its lattice's row-chain speed (granwave.theory)
        from .theory import law_lattice_speed

        return height / law_lattice_speed(pressure, contact, friction=spec.get("friction", 0.0) > 0,
                                          poisson=spec.get("poisson", 0.0))
    return height / lattice_speed(pressure, friction=spec.get("friction", 0.0) > 0,
                                  poisson=spec.get("poisson", 0.0))


def law_chain_stiffness(pressure: float, contact: dict) -> float:
    """k_n (E* d) of two unit balls pressed together by the force ``pressure`` x 1 d^2 under the
    normal law of ``contact`` (a selection, granwave.contact_models.options)."""
    from . import contact_models as CM
    from .contact_models import options as CO

    values = CO.values_of(dict(contact))
    _, law = CM.normal_law(values)
    n = CM.overlap_at_force(values, pressure, 0.25, 0.5)
    return float(CM.law_stiffness(law, n, 0.5, 0.5))


def _write_json(path, obj) -> None:
    """One JSON object, as `granwave ... --json` prints it (NaN -> null), written atomically."""
    from .io.files import jsonable
    from .io.files import atomic_text

    atomic_text(path, json.dumps(jsonable(obj), indent=1) + "\n")


def make_sample(kind: str, make: dict, checkpoint=None):
    """The sample's packing: DEM preparation, perfect lattice or chain (``make``: their options).
    ``checkpoint``: a DEM preparation's checkpoint file (None: none; granwave.dem.checkpoint),
    resumed from when it exists and left in place (the caller removes it once the packing is written)."""
    if kind in ("disordered", "continuum"):
        from .dem.checkpoint import Checkpoint
        from .dem.params import PrepareParams
        from .dem.protocol import prepare_packing

        params = PrepareParams(**make)
        saved = None
        if checkpoint is not None:
            saved = Checkpoint(checkpoint, params)
            saved.check()
        return prepare_packing(params, checkpoint=saved)
    if kind == "lattices":
        from .systems import triangular_lattice

        return triangular_lattice(**make)
    from .systems import chain

    # a normal law given (the scene's contact): every contact its own k_n of that law
    return chain(**make, **({"stiffness_model": "law"} if "contact_law" in make else {}))


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


def run_batch(run, samples, *, log_path, timings_path, fields, failed_key,
              keys=("scene", "pressure", "size", "seed"), store=None) -> None:
    """A workflow batch (one process): ``run(sample, log)`` for every sample, its log lines
    into ``log_path``, and one row per sample and stage of ``fields`` into the tab-separated
    ``timings_path`` (the sample's ``keys``, then what ``run`` timed). A sample that fails
    (InputError, ConvergenceError) ends the batch with exit status 1 and its reason in the log
    (the sample named by ``sample['out'][failed_key]``).

    ``store``: the batch's finished-sample store (granwave.finished_store; None: none). A sample
    kept there by an earlier, cut run of the batch with the same recipe is restored (files and
    timing rows) instead of run; every sample run is kept there as it finishes; the store is
    removed once the timings table, the batch's last output, is written."""
    import csv
    import sys

    from . import finished_store
    from .errors import ConvergenceError, InputError

    with open(log_path, "w") as log:
        def say(line):
            print(line, file=log, flush=True)

        rows, computed = [], 0
        for sample in samples:
            label = sample["out"][failed_key]
            timings = finished_store.restore(store, sample, keys, label, say) if store else None
            if timings is None:
                try:
                    timings = run(sample, log=say)
                except (InputError, ConvergenceError) as exc:
                    print(f"{label}: {exc}", file=log)
                    sys.exit(1)
                if store:
                    finished_store.keep(store, sample, keys, timings, say)
                    computed += 1
                    finished_store.stop_for_tests(computed)
            rows += [{**{k: sample[k] for k in keys}, **t} for t in timings]
        with open(timings_path, "w", newline="") as f:
            writer = csv.DictWriter(f, fields, delimiter="\t")
            writer.writeheader()
            writer.writerows({k: r[k] for k in fields} for r in rows)
        if store:
            finished_store.remove(store, say)


def run_command(item: dict, log=print) -> list[dict]:
    """Run one light `granwave` command in this process, as a workflow job would run it alone.

    ``item``: ``args`` (the command line after `granwave`), ``stage`` (its name in the timings),
    ``out`` (the files it makes: ``result`` names the command, e.g. its JSON or figure) and
    optionally ``printed``, the file that gets what the command prints (written atomically after
    the command, as `granwave <args> > printed` would); without it the printed lines go to
    ``log``, as do warnings. The files hold the same bytes as the command run alone: the command
    line they record (provenance ``command_line``) is that command's, with the console script
    beside this interpreter. Returns the command's CPU and wall seconds under ``stage``; a
    refusal or a stage that did not converge raises InputError with the command's one-line
    message.
    """
    import contextlib
    import io
    import sys

    import click

    from .cli import main
    from .errors import InputError
    from .io.files import atomic_text

    args = [str(a) for a in item["args"]]
    for path in item["out"].values():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    script = Path(sys.executable).with_name("granwave")
    sys.argv = [str(script) if script.is_file() else "granwave", *args]  # provenance: command_line
    printed, warned, timings = io.StringIO(), io.StringIO(), []

    def command():
        with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(warned):
            main.main(args, prog_name="granwave", standalone_mode=False)

    try:
        _timed(timings, item["stage"], command)
    except click.ClickException as exc:
        raise InputError(exc.format_message()) from None
    finally:
        lines = warned.getvalue().splitlines() + ([] if item.get("printed") else printed.getvalue().splitlines())
        for line in lines:
            log(line)
    if item.get("printed"):
        atomic_text(item["printed"], printed.getvalue())
    log(f"{item['out']['result']}: {item['stage']} {timings[0]['cpu_s']:.2f} s")
    return timings


def _cpu_seconds() -> float:
    """CPU seconds of this process and of its finished children: the dense eigensolves run in a
    forked child (granwave.linear.lapack.dense_eigh), which time.process_time() does not see."""
    t = os.times()  # its children's part only: 10 ms ticks, too coarse for the short stages
    return time.process_time() + t.children_user + t.children_system


def _timed(timings: list, stage: str, fn):
    """``fn()``, its CPU seconds (forked eigensolves included) and wall seconds appended to
    ``timings`` under ``stage``."""
    c0, w0 = _cpu_seconds(), time.perf_counter()
    result = fn()
    timings.append({"stage": stage, "cpu_s": _cpu_seconds() - c0, "wall_s": time.perf_counter() - w0})
    return result


def run_sample(sample: dict, log=print) -> list[dict]:
    """Run one sample's pipeline and write its files; return the timing of each stage.

    ``sample``: ``kind`` (disordered | lattices | chains | continuum), ``scene``, ``make`` (options of
    :func:`make_sample`), ``signal`` (method, ic, t_max, samples) and ``out``, the paths
    to write: packing, linear, signal, front, summary, and optionally statics and moduli
    (the stages a scene has); ``local_moduli`` (default True): False for global moduli only;
    ``packing_given`` (default False): the packing file exists (made by the workflow's GPU job
    of its height) and is read, not made; ``moduli_may_fail`` (default False): a moduli solve that fails (no accurate solution of
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
        return _timed(timings, stage, fn)

    checkpoint = sample.get("checkpoint")  # a tall preparation's (workflow/rules/common.smk)
    for path in [*out.values(), *([checkpoint] if checkpoint else [])]:
        Path(path).parent.mkdir(parents=True, exist_ok=True)

    def packing_stage():
        pk = make_sample(sample["kind"], sample["make"], checkpoint)
        files.write_packing(out["packing"], pk)
        if checkpoint:
            Path(checkpoint).unlink(missing_ok=True)  # the packing is written
        return files.read_packing(out["packing"])

    if sample.get("packing_given"):  # made by its height's GPU job (workflow device: gpu)
        packing = timed("packing", lambda: files.read_packing(out["packing"]))
    else:
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
    # the packing's contact sub-models (granwave.contact_models: the normal law always, the others
    # where not the defaults), so that a summary says which law it measured
    from .contact_models import options as CO

    contact = CO.attrs_of(CO.values_of_attrs(packing.attrs))
    write_summary(out["summary"], merge_summary(attrs=sig.attrs, scene=sample["scene"], **contact, **sections))
    meta = {"n_grains": int(packing.n_grains), "n_dof": int(system.n_dof),
            "steps": int(packing.attrs.get("steps", 0))}
    for t in timings:
        t.update(meta)
    log(f"{out['summary']}: " + ", ".join(f"{t['stage']} {t['cpu_s']:.2f} s" for t in timings))
    return timings


# ---- compiling the kernels once, before the jobs that use them (workflow/rules/compile.smk)
#: Kernel families compiled by separate warm-up jobs. "dem" and "linear" share few kernels, so
#: they run side by side without compiling the same function twice; "pulse" (the DEM pulse's
#: own kernels) runs after "dem", whose force loop it calls, and only the damping pulses wait
#: for it, so the preparations start ~10 CPU-s earlier on a cold cache.
KERNEL_FAMILIES = ("dem", "pulse", "linear")


def _tiny_make(kind: str, make: dict) -> dict:
    """A lattice's or chain's ``make`` shrunk to a few grains, with the same options (the same
    kernels run); a packing's unchanged (the DEM needs its width and height)."""
    make = dict(make)
    if kind == "lattices":
        make["rows"] = min(int(make["rows"]), 10)
        make["width"] = min(int(make["width"]), 6)
    elif kind == "chains":
        make["n_balls"] = min(int(make["n_balls"]), 16)
    return make


def pulse_on_lattice(make: dict) -> bool:
    """Whether the DEM pulse's kernels can be compiled on a perfect lattice (:func:`pulse_lattice`)
    instead of a DEM packing of the scene ``make`` (PrepareParams' fields): a 2D scene without
    sub-model beyond the normal law (granwave.contact_models: a lattice has none). Then the pulse
    warm-up needs no DEM preparation, so no "dem" warm-up first."""
    from .contact_models import options as CO
    from .params import PrepareParams

    p = PrepareParams(**make)
    return p.dim == 2 and not CO.off_kinds_on(CO.values_of(p))


def pulse_lattice(make: dict):
    """A 4 x 4 triangular lattice with the pressure, friction, Poisson ratio and contact law of a
    2D scene's ``make``: the DEM pulse runs the same kernels on it as on the scene's packings (the
    same array types and contact model)."""
    from .contact_models import options as CO
    from .params import PrepareParams
    from .systems import triangular_lattice

    p = PrepareParams(**make)
    contact = {k: v for k, v in CO.values_of(p).items() if k in CO.normal_options()}
    return triangular_lattice(rows=4, width=4, pressure=p.pressure, friction=p.friction, poisson=p.poisson,
                              **contact)


def warm_kernels(family: str, samples: list[dict], folder, *, pulse: dict | None = None,
                 log=print) -> dict:
    """Compile one family of kernels into numba's cache by running tiny copies of the samples.

    On a cold cache every job of a parallel workflow would compile the kernels it uses, and
    two jobs starting together compile the same ones at once; one warm-up job per family,
    run before the others, compiles each kernel once. ``family``: "dem" (the preparation of
    every disordered and continuum sample's kind), "pulse" (the DEM pulse with ``pulse``'s
    options, on a tiny packing of ``pulse``'s scene, a lattice where :func:`pulse_on_lattice`) or "linear" (linearize, both signal methods, statics and moduli, on the lattices and
    chains). ``samples``: one sample per scene (:func:`run_sample`'s dicts); their files are
    written under ``folder``. Returns what ran and its CPU seconds.
    """
    from . import api
    from .params import PropagateParams

    if family not in KERNEL_FAMILIES:
        raise ValueError(f"unknown kernel family {family!r}")
    folder = Path(folder)
    ran = []
    for sample in samples:
        c0 = _cpu_seconds()
        tiny = {**sample, "make": _tiny_make(sample["kind"], sample["make"])}
        tag = f"{sample['scene']}"
        if family in ("dem", "pulse"):
            if sample["kind"] not in ("disordered", "continuum"):
                continue
            if family == "pulse" and not (pulse and sample["scene"] == pulse.get("scene")):
                continue
            if family == "pulse" and pulse_on_lattice(tiny["make"]):
                packing = pulse_lattice(tiny["make"])
            else:
                packing = make_sample(tiny["kind"], tiny["make"])
            if family == "pulse":
                api.propagate(packing, PropagateParams(method="dem", t_max=1.0, samples=10,
                                                       ic=pulse.get("ic", "A"),
                                                       damping=pulse.get("damping", 0.1)))
        else:
            if sample["kind"] not in ("lattices", "chains"):
                continue
            for method in ("time", "modal"):
                tiny["out"] = {k: str(folder / f"{tag}.{method}.{k}{Path(v).suffix}")
                               for k, v in sample["out"].items()}
                tiny["signal"] = {**sample["signal"], "samples": 50, "method": method}
                run_sample(tiny, log=lambda line: None)
        ran.append({"sample": tag, "cpu_s": round(_cpu_seconds() - c0, 2)})
        log(f"{family}: {tag}: {ran[-1]['cpu_s']} CPU-s")
    return {"family": family, "ran": ran}


# ---- the shear scene (workflow/rules/shear.smk; docs/shear.md "The shear scene")
def _nyquist_samples(system, t_max: float, samples: int) -> int:
    """At least ``samples``, and enough that the record resolves the system's highest frequency
    (Gershgorin bound): the picks convolve the signal on its own grid, so nothing may alias."""
    from .api import _omega_max_bound

    return max(int(samples), int(math.ceil(1.05 * t_max * _omega_max_bound(system) / math.pi)) + 1)


def run_shear_sample(sample: dict, log=print) -> list[dict]:
    """One packing of a shear scene: the shear and the compressional kick (impulses, time
    domain) on the source scene's linear system, every bender-element pick of both at each
    source wavelength, and one record (:func:`granwave.analysis.shear_scene.sample_record`).

    ``sample``: ``scene``, ``source_scene``, ``pressure``, ``size``, ``seed``, ``wavelengths``
    (d; f = c/λ with c the packing's own c_t, c_l), ``pulse``, ``method`` (propagate's: time, modal
    or auto; default time), ``safety``, ``samples``,
    ``record`` (crossings, :func:`shear_record_length`), ``in`` (``linear``, ``moduli``: the
    source scene's files) and ``out`` (``shear_signal``, ``normal_signal``, ``picks``). A packing
    whose moduli give no finite c_t or c_l is recorded with its reason and no picks.
    Returns the timing of each stage (CPU and wall seconds).
    """
    from . import api
    from .analysis.shear import shear_picks
    from .analysis.shear_scene import sample_record
    from .io import files
    from .params import PropagateParams

    timings = []

    def timed(stage, fn):
        return _timed(timings, stage, fn)

    out = sample["out"]
    for path in out.values():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    system = files.read_linear(sample["in"]["linear"])
    mod = json.loads(Path(sample["in"]["moduli"]).read_text())
    lams = [float(w) for w in sample["wavelengths"]]
    meta = {k: sample[k] for k in ("scene", "source_scene", "pressure", "size", "seed")}
    picks = {}
    error = None
    from .analysis.shear_scene import reference_speeds

    ref = reference_speeds(mod)  # the bulk slab's c_t, c_l (the whole cell's without a slab)
    for kind, key in (("shear", "c_t"), ("normal", "c_l")):
        c = ref[key]
        if c is None or not math.isfinite(float(c)) or float(c) <= 0:
            error = f"{sample['in']['moduli']}: no finite {key}"
            break
        c = float(c)
        height = float(system.attrs["height"])
        t_max = float(f"{shear_record_length(height, c, record=sample['record'], wavelengths=lams):.6g}")
        params = PropagateParams(method=sample.get("method", "time"), ic="A", source_kind=kind, t_max=t_max,
                                 samples=_nyquist_samples(system, t_max, sample["samples"]),
                                 safety=sample["safety"])

        def signal_stage():
            system.attrs["linear_source"] = str(sample["in"]["linear"])
            sig = api.propagate(system, params)
            sig.attrs["source_file"] = str(sample["in"]["linear"])
            files.write_signal(out[f"{kind}_signal"], sig)
            return sig

        sig = timed(f"{kind}_signal", signal_stage)
        picks[kind] = timed(f"{kind}_picks", lambda: [
            shear_picks(sig.time, sig.force, height=float(sig.attrs["height"]), frequency=c / lam,
                        pulse=sample["pulse"], c_t=c) for lam in lams])
    if error:
        log(error)
        rec = {**meta, "error": error, "dim": int(mod.get("dim", 2))}
    else:
        rec = sample_record(**meta, moduli=mod, shear=picks["shear"], normal=picks["normal"],
                            wavelengths=lams, pulse=sample["pulse"],
                            extra={"linear": str(sample["in"]["linear"])})
    _write_json(out["picks"], rec)
    for t in timings:
        t.update(n_dof=int(system.n_dof))
    log(f"{out['picks']}: " + ", ".join(f"{t['stage']} {t['cpu_s']:.2f} s" for t in timings))
    return timings


def run_shocks_sample(sample: dict, log=print) -> list[dict]:
    """One packing of a shocks scene (docs/shocks.md, "The shocks scene"): the DEM packing
    (made, or read when its file exists), then one piston push (the nonlinear DEM pulse,
    granwave.dem.pulse) per drive EPS of ``drives`` whose strain EPS δ̄/d̄ is at most
    ``max_strain``, and the packing's record (granwave.analysis.shocks_scene.packing_record:
    every push's front speed, ε = v_p/V, contact fractions and 10–90 % rise width).

    ``sample``: ``scene``, ``pressure``, ``size``, ``seed``, ``make`` (options of
    :func:`make_sample`), ``drives``, ``max_strain``, ``damping`` (ζ), ``samples`` (per record),
    ``bin`` (d), ``out`` (``packing``, ``record``). Returns the timing of each stage.
    """
    import numpy as np

    from .analysis.shocks_scene import packing_record, pulse_row, rise_width
    from .contact_models import options as CO
    from .dem.kick import mean_overlap
    from .dem.pulse import propagate_dem
    from .io import files

    timings = []
    out = sample["out"]
    for path in out.values():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    if Path(out["packing"]).exists():
        packing = files.read_packing(out["packing"])
    else:
        packing = _timed(timings, "packing", lambda: make_sample("disordered", sample["make"]))
        files.write_packing(out["packing"], packing)
    d0 = mean_overlap(packing) / float(np.mean(2.0 * packing.radius))
    rows, skipped = [], []
    for eps in sample["drives"]:
        if eps * d0 > sample["max_strain"]:
            skipped.append(float(eps))
            continue

        def push():
            return propagate_dem(packing, drive="piston", amplitude=float(eps), damping=sample["damping"],
                                 samples=sample["samples"], bin_width=sample["bin"])

        sig = _timed(timings, f"push_{eps:g}", push)
        width = rise_width(sig.time, sig.pulse["height"], sig.pulse["velocity"],
                           plateau=float(sig.attrs["piston_velocity"]), speed=float(sig.attrs["front_speed"]),
                           fit_range=sig.attrs["front_fit_range"])
        rows.append(pulse_row(sig.attrs, width=width))
    meta = {k: sample[k] for k in ("scene", "pressure", "size", "seed")}
    meta.update(pressure=float(sample["pressure"]), friction=float(packing.friction),
                contact_law=str(sample["make"].get("contact_law", CO.KINDS["normal"]["default"])),
                dim=int(packing.dim),
                n_grains=int(packing.n_grains), height=float(packing.height),
                lateral_width=float(packing.box[0]), damping=float(sample["damping"]),
                drives_skipped=skipped, max_strain=float(sample["max_strain"]),
                packing=str(out["packing"]), label=str(out["record"]))
    _write_json(out["record"], packing_record(meta, rows, static_strain=d0))
    log(f"{out['record']}: " + ", ".join(f"{t['stage']} {t['cpu_s']:.2f} s" for t in timings))
    for t in timings:
        t.update(n_dof=int(packing.n_grains * packing.dim))
    return timings


def warm_shocks(sample: dict, folder, log=print) -> dict:
    """Compile the shocks scene's kernels: :func:`run_shocks_sample` on a tiny copy of ``sample``
    (60 grains, two drives, 50 samples per record) with its files under ``folder``."""
    c0 = _cpu_seconds()
    tiny = {**sample, "make": {**sample["make"], "grains": 60, "aspect": 1.0}, "samples": 50,
            "drives": [min(sample["drives"]), 1.0], "max_strain": 1.0,
            "out": {k: str(Path(folder) / f"tiny.{k}{Path(v).suffix}") for k, v in sample["out"].items()}}
    run_shocks_sample(tiny, log=lambda line: None)
    done = {"family": "shocks", "ran": [{"sample": sample["scene"], "cpu_s": round(_cpu_seconds() - c0, 2)}]}
    log(f"shocks: {sample['scene']}: {done['ran'][0]['cpu_s']} CPU-s")
    return done
