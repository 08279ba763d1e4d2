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
    with the mean-flow rule, a loaded piston, checks, device rebuilds, a settling switch between
    runs and one packing running out of pair slots mid-batch: each one's state, pair list,
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
    (["--seeds", "0-1", "--checkpoint", "c.ckpt", "-o", "p_{seed}.h5"], "--checkpoint runs one seed"),
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
