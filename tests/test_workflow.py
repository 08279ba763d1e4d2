"""The Snakemake workflow: config validation, lint, the SLURM profile, and a tiny end-to-end run.

The end-to-end run uses tests/data/tiny_workflow.yaml (every rule family once, on the
smallest systems that still have a front) and checks that the report contains every
table and every figure the workflow made.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from quick_plan import dry_run

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "workflow" / "Snakefile"
TINY = ROOT / "tests" / "data" / "tiny_workflow.yaml"


def snakemake(*args, cwd):
    return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE), *args],
                          cwd=cwd, capture_output=True, text=True, timeout=1200)


def test_config_typo_fails_at_once(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("t_max_factor", "t_max_factr"))
    run = snakemake("-n", "--configfile", str(bad), cwd=tmp_path)
    assert run.returncode != 0
    assert "t_max_factr" in run.stdout + run.stderr


def _tiny_config():
    import yaml

    from granwave.workflow_config import SCENE_KINDS

    cfg = yaml.safe_load(TINY.read_text())
    for kind in SCENE_KINDS:
        cfg.setdefault(kind, {})
    return cfg


def _schema():
    import yaml

    return yaml.safe_load((ROOT / "workflow" / "schemas" / "config.schema.yaml").read_text())


def _edit(cfg, change):
    import copy

    cfg = copy.deepcopy(cfg)
    change(cfg)
    return cfg


def _rename(section, old, new):
    def change(cfg):
        cfg[section][new] = cfg[section].pop(old)
    return change


def _set(value, *keys):
    def change(cfg):
        node = cfg
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value
    return change


# (change to the tiny config, the key the one-line error must name)
SCHEMA_CASES = [
    (_rename("disordered", "frictional2d", "frictional-2d"), "disordered.frictional-2d"),
    (_rename("lattices", "lattice_frictionless", "2lattice"), "lattices.2lattice"),
    (_set(1, "chains", "chain_A", "typo"), "chains.chain_A.typo"),
    (_set([6, "x"], "disordered", "frictional2d", "heights"), "disordered.frictional2d.heights[1]"),
    (_set(-1e-4, "disordered", "frictional2d", "pressures", 0), "disordered.frictional2d.pressures[0]"),
    (_set("C", "ic"), "ic"),
]
CROSS_CASES = [
    (_set("frictional2x", "damping", "scene"), "damping.scene"),
    (_set("chain_A", "damping", "scene"), "damping.scene"),
    (_set(1e-6, "damping", "pressure"), "damping.pressure"),
    (_set(12, "damping", "height"), "damping.height"),
    (_set({"pressures": [1e-6], "heights": [20], "seeds": 1}, "disordered", "frictional2d", "series"),
     "disordered.frictional2d.series.pressures[0]"),
    (_rename("chains", "chain_A", "frictional2d"), "frictional2d"),
    (_set([10, 6], "edge_heights"), "edge_heights"),
]


@pytest.mark.parametrize("change, key", SCHEMA_CASES)
def test_schema_error_is_one_line_naming_the_key(change, key):
    from granwave.workflow_config import cross_reference_error, schema_error

    assert schema_error(_tiny_config(), _schema()) is None
    assert cross_reference_error(_tiny_config()) is None
    message = schema_error(_edit(_tiny_config(), change), _schema())
    assert message and "\n" not in message and key in message, message


@pytest.mark.parametrize("change, key", CROSS_CASES)
def test_cross_reference_error_is_one_line_naming_the_key(change, key):
    from granwave.workflow_config import cross_reference_error, schema_error

    cfg = _edit(_tiny_config(), change)
    assert schema_error(cfg, _schema()) is None  # the schema alone accepts it
    message = cross_reference_error(cfg)
    assert message and "\n" not in message and key in message, message


def test_config_naming_a_missing_scene_stops_with_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("  scene: frictional2d", "  scene: frictional2x"))
    run = snakemake("-n", "--configfile", str(bad), cwd=tmp_path)
    assert run.returncode == 2
    lines = [line for line in run.stderr.splitlines() if line.startswith("config:")]
    assert lines == ["config: damping.scene = 'frictional2x' is not a disordered scene; "
                     "disordered scenes: frictional2d, frictionless2d"], run.stderr
    assert "Traceback" not in run.stdout + run.stderr


def test_lint_is_clean(tmp_path):
    run = snakemake("--lint", "--configfile", str(TINY), cwd=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Congratulations, your workflow is in a good condition!" in run.stdout + run.stderr


def test_unlock_needs_no_cores_with_tall_columns(tmp_path):
    """`snakemake --unlock` (docs/cluster.md "Resuming", after kill -9) parses the workflow without
    --cores: a config with tall columns (threads from the cores) must still parse."""
    run = snakemake("--unlock", "--configfile", str(ROOT / "config" / "continuum.yaml"), cwd=tmp_path)
    assert run.returncode == 0, (run.stdout + run.stderr)[-3000:]
    assert "Unlocked working directory" in run.stdout + run.stderr


@pytest.mark.parametrize("config", ["config.yaml"])
def test_slurm_profile_dry_run_resolves_resources(tmp_path, config):
    pytest.importorskip("snakemake_executor_plugin_slurm")
    run = snakemake("-n", "--profile", str(ROOT / "workflow" / "profiles" / "slurm"),
                    "--configfile", str(ROOT / "config" / config), cwd=tmp_path)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-3000:]
    total = re.search(r"^total\s+(\d+)", out, re.M)
    # the per-sample pipelines run as batches of config batch_size samples (rules/batches.smk),
    # a scene's analyses, the study's figures and the main sample's extras as one job each: the
    # whole study in ~20 jobs (the exact count: tests/test_generated_docs.py)
    assert total and int(total.group(1)) > 15
    assert re.search(r"^batch_frictional2d_0\s+1$", out, re.M), out[-3000:]
    # a scene's height series, ensembles and sweep run in one job (rules/analysis.smk)
    assert re.search(r"^analyses_frictional2d\s+1$", out, re.M), out[-3000:]
    assert not re.search(r"^(heights|ensemble|pressure_sweep)\s+\d+$", out, re.M), out[-3000:]
    assert "This was a dry-run" in out


def test_light_commands_and_reference_samples_share_jobs():
    """The quick config plans the main sample's extras, the continuum analyses and the lattice
    and chain samples as a few jobs (docs/decisions/0020-quick-workflow-budget.md), not one
    process per file: no per-file rule among its jobs."""
    returncode, out = dry_run("config/config.yaml")
    assert returncode == 0, out[-3000:]
    jobs = dict(re.findall(r"^(\w+)\s+(\d+)$", out, re.M))
    for name in ("sample_extras", "continuum_continuum2d", "batch_reference_0", "analyses_reference",
                 "figures_study", "analyses_frictional2d"):
        assert jobs.get(name) == "1", (name, out[-3000:])
    per_file = {"damping_signal", "damping_table", "eigensolve", "eigensolve_vectors", "spectrum",
                "snapshot_signal", "continuum_front", "continuum_attenuation", "heights", "ensemble",
                "pressure_sweep", "linearize", "propagate", "prepare_packing"}
    assert not per_file & set(jobs), out[-3000:]
    assert not [name for name in jobs if name.startswith(("batch_lattice", "batch_chain", "figure_"))
                and name != "figure_shear"], out[-3000:]


@pytest.mark.slow
def test_tiny_workflow_interrupted_then_finished_end_to_end(tmp_path):
    """The tiny workflow end to end, through an interruption: SIGTERM (what a scheduler or `kill`
    sends) once its first job has finished, then the same command finishes the rest (after
    SIGKILL, when snakemake hung on the SIGTERM, once `--unlock` has removed its lock); the
    finished run's report holds every table and every figure the workflow made, no temporary
    file of an interrupted atomic write is left, a second rerun has nothing to do, and a config
    that adds a height plans its samples at once. One run of the workflow for both properties
    (they were two runs of it): all but the jobs finished before the signal run in the rerun,
    from the same empty start as a run never cut."""
    import os
    import signal
    import time

    cmd = [sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE), "--cores", "2",
           "--configfile", str(TINY)]
    first = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, start_new_session=True)
    # terminate once the first job has finished (not after a fixed sleep, which a loaded
    # machine can spend before any job ends), a moment later so that the next jobs are running
    lines = []
    deadline = time.monotonic() + 600
    for line in first.stdout:
        lines.append(line)
        if re.search(r"[1-9]\d* of \d+ steps", line) or time.monotonic() > deadline:
            break
    time.sleep(2)
    os.killpg(first.pid, signal.SIGTERM)
    try:
        rest = first.communicate(timeout=120)[0]
        killed = False
    except subprocess.TimeoutExpired:
        # snakemake can hang in its SIGTERM handler (seen when the signal met its scheduler);
        # a batch scheduler then sends SIGKILL after its grace period, and so do we
        os.killpg(first.pid, signal.SIGKILL)
        rest = first.communicate(timeout=60)[0]
        killed = True
    log = "".join(lines) + rest
    if killed:  # a killed snakemake leaves its lock: what its error message tells the user to do
        unlock = subprocess.run(cmd + ["--unlock"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert unlock.returncode == 0, (unlock.stdout + unlock.stderr)[-2000:]
    done = [int(m) for m in re.findall(r"(\d+) of \d+ steps", log)]
    total = int(re.search(r"of (\d+) steps", log).group(1)) if done else None
    assert first.returncode != 0 and done and done[-1] < total, log[-2000:]
    rerun = snakemake("--cores", "2", "--configfile", str(TINY), cwd=tmp_path)
    assert rerun.returncode == 0, (rerun.stdout + rerun.stderr)[-5000:]
    # no temporary file of an interrupted atomic write is left looking like an output
    assert not [p for p in (tmp_path / "results").rglob("*") if p.name.endswith(".tmp")]
    report = (tmp_path / "results" / "report" / "index.md").read_text()
    assert (tmp_path / "results" / "report" / "index.html").is_file()
    for heading in ["## Statics per pressure", "## Elastic moduli per pressure",
                    "## Sound speeds against pressure", "## Front scaling with distance",
                    "## Triangular lattices against the formula",
                    "## Damping series", "## Continuum: the front against distance",
                    "## Provenance and numerical checks",
                    "## Figures"]:
        assert heading in report, heading
    figures = sorted(p.name for p in (tmp_path / "results" / "figures").glob("*.png"))
    assert len(figures) >= 12, figures
    for name in figures:
        assert f"figures/{name}" in report, name
    assert "tiny" in report  # the config it came from
    # Rerunning with nothing changed does nothing.
    again = snakemake("--cores", "2", "--configfile", str(TINY), cwd=tmp_path)
    assert again.returncode == 0
    assert "Nothing to be done" in again.stdout + again.stderr
    # A config that adds a height plans its samples at once, not a kernel warm-up alone (the
    # warm-ups' params follow the scenes and are unrecorded: common.smk unrecorded).
    taller = tmp_path / "taller.yaml"
    taller.write_text(TINY.read_text().replace("heights: [6, 10, 14]", "heights: [6, 10, 14, 18]"))
    plan = snakemake("-n", "--quiet", "rules", "--cores", "2", "--configfile", str(taller), cwd=tmp_path)
    jobs = dict(re.findall(r"^(\w+)\s+(\d+)$", plan.stdout + plan.stderr, re.M))
    assert plan.returncode == 0 and "compile_kernels" not in jobs, (plan.stdout + plan.stderr)[-3000:]
    assert any(name.startswith("batch_continuum_tiny") for name in jobs), jobs


def _lattice_sample(tmp_path, method, safety):
    from granwave.workflow_support import crossing_time

    tail = "lat/p0.0001/r9/s0"
    out = {stage: str(tmp_path / method / stage / f"{tail}.h5") for stage in ("packing", "linear", "signal")}
    out.update({stage: str(tmp_path / method / stage / f"{tail}.json")
                for stage in ("statics", "moduli", "front", "summary")})
    spec = {"friction": 0.0, "poisson": 0.0}
    return {"kind": "lattices", "scene": "lat", "pressure": "0.0001", "size": "r9", "seed": 0,
            "make": dict(rows=9, width=6, pressure=1e-4, friction=0.0, poisson=0.0),
            "signal": {"method": method, "ic": "A", "samples": 800, "safety": safety,
                       "t_max": 2.5 * crossing_time("lattices", spec, 1e-4, "r9")},
            "out": out}


def test_batch_sample_pipeline_writes_every_file_and_time_domain_matches_modal(tmp_path):
    """One sample through the batch pipeline by both signal methods: every file written, and the
    time domain at safety 0.002 gives the front of the exact modal sum to ~1e-6 (the error
    of velocity Verlet falls as the square of the step: docs/tradeoffs.md)."""
    import json

    from granwave.analysis.sweep import validate_summary
    from granwave.io.files import read_signal
    from granwave.workflow_support import run_sample

    fronts = {}
    for method in ("modal", "time"):
        sample = _lattice_sample(tmp_path, method, 0.002)
        stages = [t["stage"] for t in run_sample(sample, log=lambda line: None)]
        assert stages == ["packing", "linear", "signal", "statics", "moduli", "front"]
        for path in sample["out"].values():
            assert Path(path).is_file(), path
        summary = json.loads(Path(sample["out"]["summary"]).read_text())
        validate_summary(summary)
        assert summary["front"]["method"] == method
        assert read_signal(sample["out"]["signal"]).attrs["method_choice"] == method
        fronts[method] = summary["front"]
    for key in ("t_lead10", "t_peak", "amplitude", "width"):
        assert fronts["time"][key] == pytest.approx(fronts["modal"][key], rel=1e-5), key
    assert not list(tmp_path.rglob("*.tmp"))


def test_auto_signal_method_picks_the_cheaper_prediction(tmp_path):
    from granwave.api import choose_method
    from granwave.io.files import read_linear, read_signal
    from granwave.params import PropagateParams
    from granwave.workflow_support import run_sample

    sample = _lattice_sample(tmp_path, "auto", 0.1)
    run_sample(sample, log=lambda line: None)
    sig = read_signal(sample["out"]["signal"])
    linear = read_linear(sample["out"]["linear"])
    method, reason = choose_method(linear, PropagateParams(t_max=sample["signal"]["t_max"], samples=800,
                                                           safety=0.1, method="auto"))
    assert sig.attrs["method"] == method
    assert sig.attrs["method_choice"] == f"auto: {reason}"
    # a 100x finer time step makes the time domain 100x dearer: a small system then takes the modal sum
    finer, _ = choose_method(linear, PropagateParams(t_max=sample["signal"]["t_max"], samples=800,
                                                     safety=0.001, method="auto"))
    assert finer == "modal"


def test_lone_continuum_packing_is_prepared_with_the_scenes_compaction_rule(tmp_path):
    """A single packing asked for outside its batch (the per-sample rule, e.g. to run only the
    tallest column) must be made as its batch would make it: with the scene's compaction rule."""
    from quick_plan import CONTINUUM_PACKINGS, command_of, continuum_packing_commands

    target = CONTINUUM_PACKINGS[2]  # the tallest column, in the dry run shared with test_checkpoint.py
    returncode, out = continuum_packing_commands()
    assert returncode == 0, out[-3000:]
    command = command_of(out, target, "granwave prepare-packing")
    assert "--compaction mean-flow" in command and "--grains 51200" in command, command
    # and its moduli are the global ones only, as in a batch (the local solve of a 2048 d
    # column ran for minutes in LSQR where the global one takes seconds)
    moduli = "results/moduli/continuum2d_p4/p0.0001/h2048/s0.json"
    run = snakemake(moduli, "-n", "-p", "--configfile", str(ROOT / "config" / "continuum.yaml"),
                    "--allowed-rules", "prepare_packing", "moduli", cwd=tmp_path)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-3000:]
    command = next(line for line in out.splitlines() if "granwave analyze moduli" in line)
    assert "--local" not in command, command


def _chain_signal(path, n, shift):
    """An exact chain wall force (modal sum) of n balls, delayed by ``shift`` steps, as a file."""
    import numpy as np

    from granwave import theory
    from granwave.io import files
    from granwave.model import Signal

    dt = 0.05
    t = np.arange(0.0, theory.chain_travel_time(n) + 12.0, dt)
    files.write_signal(path, Signal(t, theory.chain_wall_force(t - shift * dt, n, ic="A"),
                                    attrs=dict(ic="A", method="modal", height=n + 1.0 + 0.01 * shift,
                                               pressure=1e-4, kind="chain")))
    return str(path)


def test_scene_analyses_in_one_process_write_what_each_command_writes_alone(tmp_path):
    """The analyses job of a scene (workflow/scripts/analysis_batch.py) runs `granwave analyze
    heights / ensemble` in its own process (workflow_support.run_command): the printed JSON has
    the bytes of the command run alone, the ensemble file the same arrays and attributes, its
    command line the command's; a refused command raises one line and leaves no file."""
    import h5py
    import numpy as np

    from granwave.errors import InputError
    from granwave.workflow_support import run_command

    signals = [_chain_signal(tmp_path / f"s{k}.h5", n, k) for k, n in enumerate((40, 40, 80, 80))]
    h5 = str(tmp_path / "ens.h5")
    items = [{"stage": "heights", "out": {"result": str(tmp_path / "heights.json")},
              "printed": str(tmp_path / "heights.json"),
              "args": ["analyze", "heights", *signals, "--edge-heights", "41,81", "--json"]},
             {"stage": "ensemble", "out": {"result": str(tmp_path / "ens.json"), "h5": h5},
              "printed": str(tmp_path / "ens.json"),
              "args": ["analyze", "ensemble", *signals[:2], "-o", h5, "--json"]}]

    def h5_contents(path):
        with h5py.File(path) as f:
            attrs = dict(f.attrs)
            arrays = {name: f[name][()] for name in ("ensemble/time", "ensemble/mean", "ensemble/rms")}
        return attrs, arrays

    for item in items:
        alone = subprocess.run([sys.executable, "-m", "granwave", *item["args"]], cwd=tmp_path,
                               capture_output=True, text=True, timeout=300)
        assert alone.returncode == 0, alone.stderr
        written = {} if "h5" not in item["out"] else h5_contents(h5)
        Path(h5).unlink(missing_ok=True)
        lines = []
        timings = run_command(item, log=lines.append)
        assert [t["stage"] for t in timings] == [item["stage"]] and timings[0]["cpu_s"] > 0
        assert Path(item["printed"]).read_text() == alone.stdout
        if written:
            attrs, arrays = h5_contents(h5)
            for name, values in written[1].items():
                np.testing.assert_array_equal(arrays[name], values)
            assert attrs.pop("command_line").endswith(" " + " ".join(item["args"]))
            assert set(attrs) == set(written[0]) - {"command_line"}
            for key in attrs:
                assert str(attrs[key]) == str(written[0][key]), key
    # a refused command: one line, no output
    bad = {"stage": "ensemble", "out": {"result": str(tmp_path / "bad.json"), "h5": str(tmp_path / "bad.h5")},
           "printed": str(tmp_path / "bad.json"),
           "args": ["analyze", "ensemble", str(tmp_path / "missing.h5"), "-o", str(tmp_path / "bad.h5"), "--json"]}
    with pytest.raises(InputError) as refused:
        run_command(bad, log=lambda line: None)
    assert "missing.h5" in str(refused.value) and "\n" not in str(refused.value)
    assert not (tmp_path / "bad.json").exists() and not (tmp_path / "bad.h5").exists()
    assert not list(tmp_path.rglob("*.tmp"))


def test_stage_timings_count_the_forked_eigensolve():
    """A batch's stage timings (workflow_support._timed) include the CPU of the child process in
    which a dense eigensolve of >= 400 dofs runs (granwave.linear.lapack.dense_eigh); the parent
    itself only waits."""
    import time

    import numpy as np

    from granwave.linear.lapack import INTERRUPTIBLE_MIN_DOF, dense_eigh
    from granwave.workflow_support import _timed

    n = 2 * INTERRUPTIBLE_MIN_DOF
    a = np.random.default_rng(0).random((n, n))
    timings, parent = [], time.process_time()
    _timed(timings, "eigensolve", lambda: dense_eigh(a + a.T))
    parent = time.process_time() - parent
    assert timings[0]["stage"] == "eigensolve"
    assert timings[0]["cpu_s"] > parent + 0.05  # the child's n^3 work, seen only through its rusage


def test_pulse_warm_up_runs_on_a_lattice_of_the_scene_only_where_the_kernels_are_the_same():
    """The DEM pulse's warm-up compiles on a small lattice (no DEM preparation, no wait for the
    "dem" warm-up) for a 2D scene without rolling resistance, with the scene's pressure, friction
    and contact law; a 3D scene or one with rolling resistance keeps a DEM packing."""
    from granwave.workflow_support import pulse_lattice, pulse_on_lattice

    make = {"dim": 2, "grains": 192, "pressure": 1e-5, "friction": 0.3, "contact_law": "harmonic",
            "harmonic_stiffness": 0.5}
    assert pulse_on_lattice(make)
    assert not pulse_on_lattice({**make, "dim": 3})
    assert not pulse_on_lattice({**make, "rolling": "sds"})
    lattice = pulse_lattice(make)
    assert lattice.position.shape == (16, 2)
    assert lattice.attrs["friction"] == 0.3 and lattice.attrs["pressure"] == 1e-5
    assert lattice.attrs["contact_law"] == "harmonic"
