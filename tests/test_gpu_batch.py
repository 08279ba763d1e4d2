"""Ensembles per launch (granwave.gpu.batch) and the seeds of one request (api.prepare_packings,
``prepare-packing --seeds``).

The batched engine runs in numba's CUDA simulator, in a subprocess (the simulator is chosen
when numba.cuda is first imported; the rest of the suite must not see it), against each packing
advanced alone by the GPU engine and by the CPU engine (granwave.gpu.checks.batch). The
command-line and API tests need no GPU: ``--device cpu`` runs the seeds one after another.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import api
from granwave.cli import main as cli
from granwave.errors import InputError
from granwave.io.files import read_packing

TINY = dict(grains=10, pressure=1e-2, tol=1e-2)


@pytest.fixture(scope="module")
def batch():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    r = subprocess.run([sys.executable, "-m", "granwave.gpu.checks", "batch"], capture_output=True, text=True,
                       env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])["batch"]


@pytest.mark.slow
def test_gpu_batch_each_packing_equals_its_run_alone(batch):
    """Three packings (24, 20, 22 grains) advanced together through runs of different lengths,
    with the mean-flow rule, a loaded piston, checks, device rebuilds (two packings by the batched
    one-block rebuild, one by the multi-kernel rebuild of large packings), a settling switch
    between runs and one packing running out of pair slots mid-batch: each one's state, pair list,
    histories, piston, slabs and counters are the bytes of the same runs of the GPU engine alone,
    and its state equals the CPU engine's."""
    seeds = (0, 1, 2)
    assert len({batch[f"grains_seed{s}"] for s in seeds}) == 3  # different sizes in one layout
    assert len({batch[f"steps_seed{s}"] for s in seeds}) == 3  # each stopped at its own step
    for s in seeds:
        assert batch[f"same_seed{s}"], s
        assert batch[f"rebuilds_seed{s}"] >= 1, s  # device rebuilds within the batch
        assert batch[f"steps_seed{s}"] == batch[f"cpu_steps_seed{s}"]
        assert batch[f"cpu_abs_seed{s}"] < 1e-12, s
    assert batch["room_made_seed1"] >= 1  # the cut pair arrays were enlarged mid-batch
    assert batch["small_rebuild_launches"] > 0  # seeds 0, 1: one rebuild launch for both; seed 2 its own
    assert batch["rounds"] >= 2  # the rules between runs were applied between rounds


def test_prepare_packings_cpu_equals_single_runs():
    packings = api.prepare_packings(seeds=[2, 0], **TINY)
    for seed, p in zip((2, 0), packings):
        alone = api.prepare_packing(seed=seed, **TINY)
        assert p.attrs["seed"] == seed
        assert p.position.tobytes() == alone.position.tobytes()
        assert p.contacts.force_normal.tobytes() == alone.contacts.force_normal.tobytes()
        assert {k: str(v) for k, v in p.attrs.items()} == {k: str(v) for k, v in alone.attrs.items()}


@pytest.mark.parametrize("seeds", [[], [1, 1], [-1]])
def test_prepare_packings_refuses_bad_seeds(seeds):
    with pytest.raises(InputError, match="seeds"):
        api.prepare_packings(seeds=seeds, **TINY)


def _run(tmp_path, *args):
    runner = CliRunner()
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        return runner.invoke(cli, ["prepare-packing", *map(str, args)], catch_exceptions=False)
    finally:
        os.chdir(cwd)


@pytest.mark.parametrize("args,message", [
    (["--seeds", "0-x", "-o", "p_{seed}.h5"], "expected seeds and ranges"),
    (["--seeds", "3-1", "-o", "p_{seed}.h5"], "0 <= a <= b"),
    (["--seeds", "0,1,1", "-o", "p_{seed}.h5"], "listed twice"),
    (["--seeds", "0-2", "-o", "p.h5"], "must contain {seed}"),
    (["--seeds", "0-1", "--seed", "4", "-o", "p_{seed}.h5"], "give one of them"),
    (["--seeds", "0-1", "--checkpoint", "c.ckpt", "-o", "p_{seed}.h5"], "one checkpoint per seed"),
    (["--seeds", "0-1", "--checkpoint", "p_{seed}.h5", "-o", "p_{seed}.h5"], "is the output file"),
])
def test_prepare_seeds_bad_input_is_one_line_exit_2_no_files(tmp_path, args, message):
    r = _run(tmp_path, "--grains", 10, *args)
    assert r.exit_code == 2
    lines = [x for x in r.output.splitlines() if x.strip()]
    assert len(lines) == 1 and message in lines[0], r.output
    assert list(Path(tmp_path).iterdir()) == []


def test_prepare_seeds_cpu_writes_one_file_per_seed_as_single_runs(tmp_path):
    r = _run(tmp_path, "--grains", 10, "--pressure", 1e-2, "--tol", 1e-2, "--seeds", "3,5-6", "-q",
             "-o", "p_{seed}.h5")
    assert r.exit_code == 0, r.output
    assert sorted(x.name for x in Path(tmp_path).iterdir()) == ["p_3.h5", "p_5.h5", "p_6.h5"]
    r = _run(tmp_path, "--grains", 10, "--pressure", 1e-2, "--tol", 1e-2, "--seed", 5, "-q", "-o", "single.h5")
    assert r.exit_code == 0, r.output
    a, b = read_packing(tmp_path / "p_5.h5"), read_packing(tmp_path / "single.h5")
    assert a.position.tobytes() == b.position.tobytes()
    assert np.array_equal(a.contacts.i, b.contacts.i)
    differ = {k for k in a.attrs if str(a.attrs[k]) != str(b.attrs.get(k))} | (set(b.attrs) - set(a.attrs))
    assert differ <= {"command_line"}  # each file records how it was made (its own command line)


def test_prepare_seeds_gpu_without_a_gpu_is_one_line_exit_2_no_files(tmp_path):
    if os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0"):
        pytest.skip("the CUDA simulator is on: it counts as a GPU")
    try:
        from granwave.gpu import require_gpu

        require_gpu()
        pytest.skip("a GPU is usable here")
    except InputError:
        pass
    r = _run(tmp_path, "--grains", 10, "--seeds", "0-1", "--device", "gpu", "-o", "p_{seed}.h5")
    assert r.exit_code == 2
    assert len([x for x in r.output.splitlines() if x.strip()]) == 1, r.output
    assert list(Path(tmp_path).iterdir()) == []


# ---------------------------------------------------------------- the workflow with device: gpu
ROOT = Path(__file__).resolve().parents[1]
#: These dry runs plan GPU jobs on a machine that may have no GPU (CI has none): as a cluster's
#: login node plans them for its GPU nodes (granwave.workflow_config.device_error).
PLAN_ELSEWHERE = {**os.environ, "GRANWAVE_GPU_ELSEWHERE": "1"}


def _snakemake(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
                           "--configfile", str(ROOT / "config" / "config.yaml"), *args],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600, env=PLAN_ELSEWHERE)


def test_workflow_device_gpu_sends_each_heights_seeds_to_one_gpu_job(tmp_path):
    """device: gpu plans one job per DEM height (all its seeds, prepare-packing --seeds --device
    gpu), whose packings the batch jobs read; device: cpu (the default) plans none."""
    import re

    gpu = _snakemake(tmp_path, "--config", "device=gpu", "-n", "-p")
    out = gpu.stdout + gpu.stderr
    assert gpu.returncode == 0, out[-3000:]
    commands = re.findall(r"granwave prepare-packing .*", out)
    assert commands and all("--device gpu" in c and "--seeds " in c and "s{seed}.h5" in c for c in commands)
    assert any("--seeds 0,1" in c for c in commands)  # the seeds of one height in one command
    assert any("--compaction mean-flow" in c for c in commands)  # continuum columns too
    jobs = dict(re.findall(r"^(\w+)\s+(\d+)$", out, re.M))
    assert len([j for j in jobs if j.startswith("gpu_packings_")]) == len(commands)
    assert "prepare_packing" not in jobs and "batch_frictional2d_0" in jobs
    cpu = _snakemake(tmp_path, "-n", "--quiet", "rules")
    assert cpu.returncode == 0
    assert "gpu_packings_" not in cpu.stdout + cpu.stderr


TALL = """\
name: tall
results: results
ic: A
samples: 800
t_max_factor: 2.5
edge_heights: [8, 200]
disordered:
  tall2d:
    friction: 0.5
    pressures: [1.0e-4]
    heights: [8, 200]
    seeds: 2
damping:
  enabled: false
"""


def test_workflow_device_gpu_checkpoints_tall_heights_where_the_cpu_does(tmp_path):
    """device: gpu, a tall height (4800 grains >= TALL_GRAINS): its GPU job makes the checkpoints'
    folder and passes one checkpoint per seed, in the folder and under the names of the CPU's
    (common.smk's checkpoint_path: results/checkpoints/<scene>/p<p>/<size>/s<seed>.h5); the short
    height's job passes none."""
    import re

    (tmp_path / "tall.yaml").write_text(TALL)
    r = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
                        "--configfile", "tall.yaml", "--config", "device=gpu", "-n", "-p"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=600, env=PLAN_ELSEWHERE)
    out = r.stdout + r.stderr
    assert r.returncode == 0, out[-3000:]
    commands = sorted(set(re.findall(r"(?:mkdir -p \S+ && )?granwave prepare-packing .*", out)))
    assert len(commands) == 2, commands
    short, tall = sorted(commands, key=lambda c: "--grains 4800" in c)
    assert "--grains 192 " in short and "--checkpoint" not in short and not short.startswith("mkdir")
    folder = "results/checkpoints/tall2d/p0.0001/h200"
    assert tall.startswith(f"mkdir -p {folder} && granwave prepare-packing ")
    assert "--seeds 0,1 --device gpu" in tall and f"--checkpoint '{folder}/s{{seed}}.h5'" in tall


def test_batch_pipeline_reads_a_given_packing(tmp_path):
    """A sample whose packing is given (made by its height's GPU job) reads it and leaves the
    file as it was; the stages after it run as usual."""
    from granwave.io.files import write_packing
    from granwave.workflow_support import crossing_time, run_sample

    tail = "lat/p0.0001/r9/s0"
    out = {stage: str(tmp_path / stage / f"{tail}.h5") for stage in ("packing", "linear", "signal")}
    out.update({stage: str(tmp_path / stage / f"{tail}.json") for stage in ("front", "summary")})
    make = dict(rows=9, width=6, pressure=1e-4, friction=0.0, poisson=0.0)
    Path(out["packing"]).parent.mkdir(parents=True)
    write_packing(out["packing"], api.lattice(**make))
    before = Path(out["packing"]).read_bytes()
    sample = {"kind": "lattices", "scene": "lat", "pressure": "0.0001", "size": "r9", "seed": 0,
              "make": {**make, "rows": 3},  # would make another packing: it must not be made
              "signal": {"method": "modal", "ic": "A", "samples": 200, "safety": 0.1,
                         "t_max": 2.0 * crossing_time("lattices", {"friction": 0.0, "poisson": 0.0}, 1e-4, "r9")},
              "out": out, "packing_given": True}
    stages = [t["stage"] for t in run_sample(sample, log=lambda line: None)]
    assert stages[:3] == ["packing", "linear", "signal"]
    assert Path(out["packing"]).read_bytes() == before
    assert all(Path(p).is_file() for p in out.values())
