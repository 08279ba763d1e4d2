"""Checkpoints of GPU preparations and of ``--seeds`` (docs/dem.md "Checkpoints", docs/gpu.md).

The GPU runs run in numba's CUDA simulator in a subprocess (``tests/gpu_checkpoint_checks.py``;
the simulator is chosen when numba.cuda is first imported): the GPU engine's state taken into a
fresh engine goes on to the bytes of an uninterrupted one; and, with
GRANWAVE_GPU_CHECKPOINT_RUNS=1 (minutes each), whole preparations (one seed in 2D, in 3D and with
mean-flow compaction; two seeds advanced together) interrupted after a few checkpoints and
resumed hold the bytes of an uninterrupted GPU run. The rest needs no GPU: a checkpoint
belongs to the device that wrote it, ``--seeds`` with a ``{seed}`` pattern on the CPU, and
checkpoints removed only once every output is in place.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from granwave import api
from granwave.cli import main as cli
from granwave.dem import checkpoint as CK
from granwave.dem import protocol
from granwave.dem.params import PrepareParams
from granwave.errors import InputError
from granwave.io import atomic, files
from packing_bytes import packing_data

#: Two seeds of a column long enough for several chunks of 200 steps (13 780 and 10 360 steps).
SEEDS_ARGS = ["--grains", "40", "--tol", "1e-9", "--seeds", "2-3"]


# ---------------------------------------------------------------- the GPU, in the CUDA simulator
#: The whole preparations of gpu_checkpoint_checks.py take 3-5 minutes each in the simulator, too
#: long for the suite: they run when this variable is 1 (their run: benchmarks/results/gpu_history.md);
#: the suite runs the engine-level check (about 40 s).
WHOLE_RUNS = os.environ.get("GRANWAVE_GPU_CHECKPOINT_RUNS", "0") == "1"
CASES = ("single_2d", "single_3d", "single_mean_flow_2d", "seeds_2d")


def _simulated(*names) -> dict:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    script = Path(__file__).with_name("gpu_checkpoint_checks.py")
    r = subprocess.run([sys.executable, str(script), *names], capture_output=True, text=True, env=env,
                       timeout=3000)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def gpu():
    return _simulated(*CASES)


@pytest.mark.slow
def test_gpu_engine_state_taken_into_a_fresh_engine_goes_on_to_the_same_bytes():
    """What a GPU checkpoint relies on (gpu_checkpoint_checks.engine_state): the GPU engine's
    state() after some steps, restored into a fresh engine, continues to the bytes of one
    uninterrupted engine (state, pairs and histories, walls, piston, counters; device rebuilds
    and, in 2D, room made on the device's request), in 2D and 3D under a moving piston."""
    r = _simulated("engine_state")["engine_state"]
    for d in ("2d", "3d"):
        assert r[f"same_state_{d}"] and r[f"same_pairs_{d}"] and r[f"same_piston_{d}"] and r[f"same_counters_{d}"]
        assert r[f"rebuilds_after_restore_{d}"] >= 1 and r[f"pairs_{d}"] > 0 and r[f"piston_moved_{d}"] > 1e-3


@pytest.mark.slow
@pytest.mark.skipif(not WHOLE_RUNS, reason="whole GPU preparations in the simulator take minutes each: "
                                           "GRANWAVE_GPU_CHECKPOINT_RUNS=1 runs them")
@pytest.mark.parametrize("case", CASES)
def test_gpu_run_interrupted_and_resumed_gives_the_uninterrupted_file(gpu, case):
    """prepare-packing --device gpu --checkpoint (one seed; or --seeds 0-1 with a {seed} pattern,
    the seeds advanced together): killed after some checkpoints (exit 130, no packing, the
    checkpoints left, marked 'gpu'), refused in one line by --device cpu, then resumed: it says
    where each seed resumed, writes the bytes and attributes of an uninterrupted GPU run and
    removes the checkpoints."""
    r = gpu[case]
    assert r["stopped_exit"] == 130 and r["stopped_no_output"] and r["checkpoints_left"]
    assert r["device_attr"] == "gpu"
    for step, total in zip(r["checkpoint_steps"], r["straight_steps"]):
        assert 0 < step < total
    if case == "seeds_2d":  # the seeds were stopped at steps of their own (calls of 40 and 30 steps)
        assert len(set(r["checkpoint_steps"])) == 2
    assert r["cpu_refused_exit"] == 2 and r["cpu_refused_kept"]
    assert r["cpu_refused_line"].count("\n") == 0 and "written on the GPU" in r["cpu_refused_line"]
    assert r["resumed_exit"] == 0, r["resumed_output"]
    assert all(r["resumed_lines"]), r["resumed_output"]
    assert all(r["same"]) and r["checkpoints_removed"]


# ---------------------------------------------------------------- a checkpoint's device
def test_a_checkpoint_belongs_to_its_device(tmp_path):
    """A CPU checkpoint says so; resumed on the GPU it is refused in one line (the devices' runs
    part in the last bits), and a GPU one on the CPU likewise; nothing is removed."""
    path = tmp_path / "c.h5"
    params = PrepareParams(grains=40, seed=2, tol=1e-9)
    api.prepare_packing(params, checkpoint=path, checkpoint_every=0, keep_checkpoint=True)
    with h5py.File(path, "r") as f:
        assert f.attrs["device"] == "cpu"
    with pytest.raises(InputError, match=r"written on the CPU: resume it with --device cpu") as e:
        CK.Checkpoint(path, params, device="gpu").check()
    assert "\n" not in str(e.value)
    CK.Checkpoint(path, params).check()  # the CPU takes it
    with h5py.File(path, "r+") as f:
        f.attrs["device"] = "gpu"
    with pytest.raises(InputError, match=r"written on the GPU: resume it with --device gpu"):
        api.prepare_packing(params, checkpoint=path)
    assert path.exists()


# ---------------------------------------------------------------- --seeds on the CPU
def _cli(tmp_path, *args):
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        return CliRunner().invoke(cli, ["prepare-packing", *args])
    finally:
        os.chdir(cwd)


def test_seeds_on_the_cpu_resume_each_from_its_own_checkpoint(tmp_path, monkeypatch):
    """--seeds 2-3 --checkpoint 'ck_{seed}.h5' on the CPU (one seed after the other): killed in
    seed 3's run after seed 2 converged (exit 130): no packing of either seed, both checkpoints
    left (seed 2's at its last chunk); run again, each seed resumes from its own and the files
    are those of an uninterrupted --seeds run; the checkpoints are gone."""
    straight = _cli(tmp_path, *SEEDS_ARGS, "-q", "-o", "straight_{seed}.h5")
    assert straight.exit_code == 0, straight.output
    monkeypatch.setattr(protocol, "CALL_SECONDS", 1e-9)  # chunks of 200 steps after the first 2000
    keep = CK.Checkpoint.save
    saves = {}

    def save(self, run, history, speeds):
        keep(self, run, history, speeds)
        saves[self.path.name] = saves.get(self.path.name, 0) + 1
        if self.path.name == "ck_3.h5" and saves["ck_3.h5"] == 3:
            raise KeyboardInterrupt  # a kill right after seed 3's third checkpoint

    monkeypatch.setattr(CK.Checkpoint, "save", save)
    stopped = _cli(tmp_path, *SEEDS_ARGS, "-q", "--checkpoint", "ck_{seed}.h5", "--checkpoint-every", "0",
                   "-o", "p_{seed}.h5")
    monkeypatch.setattr(CK.Checkpoint, "save", keep)
    assert stopped.exit_code == 130, stopped.output
    assert not (tmp_path / "p_2.h5").exists() and not (tmp_path / "p_3.h5").exists()
    assert saves["ck_2.h5"] > 3  # seed 2 converged before seed 3 started
    steps = {}
    for s in (2, 3):
        with h5py.File(tmp_path / f"ck_{s}.h5", "r") as f:
            steps[s] = int(f.attrs["step"])
    resumed = _cli(tmp_path, *SEEDS_ARGS, "--checkpoint", "ck_{seed}.h5", "-o", "p_{seed}.h5")
    assert resumed.exit_code == 0, resumed.output
    for s in (2, 3):
        assert f"seed {s}: resumed from step {steps[s]} (ck_{s}.h5)" in resumed.output
        assert packing_data(tmp_path / f"p_{s}.h5") == packing_data(tmp_path / f"straight_{s}.h5")
        assert not (tmp_path / f"ck_{s}.h5").exists()


def test_seeds_a_failing_seed_leaves_every_checkpoint(tmp_path, monkeypatch):
    """When one seed does not converge, no file of any seed is written (all or none) and every
    seed's checkpoint stays, so that a second run goes on from them."""
    keep = protocol.Compression.relax

    def relax(self, attrs, **kw):
        if self.params.seed == 3:
            kw["checkpoint"].save(self, [], [])  # a checkpoint of its own, then no convergence
            raise protocol.StepBudgetExceeded("stand-in: did not converge", self.max_steps)
        return keep(self, attrs, **kw)

    monkeypatch.setattr(protocol.Compression, "relax", relax)
    r = _cli(tmp_path, *SEEDS_ARGS, "-q", "--checkpoint", "ck_{seed}.h5", "--checkpoint-every", "0",
             "-o", "p_{seed}.h5")
    assert r.exit_code == 1 and "stand-in: did not converge" in r.output, r.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ck_2.h5", "ck_3.h5"]


@pytest.mark.parametrize("args, message", [
    (["--checkpoint", "ck.h5"], "must contain {seed} (one checkpoint per seed)"),
    (["--checkpoint", "p_{seed}.h5"], "is the output file"),
])
def test_seeds_checkpoint_pattern_is_checked_in_one_line(tmp_path, args, message):
    r = _cli(tmp_path, *SEEDS_ARGS, *args, "-o", "p_{seed}.h5")
    assert r.exit_code == 2 and r.output.count("\n") == 1 and message in r.output, r.output
    assert list(tmp_path.iterdir()) == []


def test_api_seeds_refuse_another_runs_checkpoint_before_any_work(tmp_path, monkeypatch):
    """api.prepare_packings checks every seed's checkpoint before the first seed runs."""
    params = PrepareParams(grains=40, seed=9, tol=1e-9)
    api.prepare_packing(params, checkpoint=tmp_path / "ck_3.h5", checkpoint_every=0, keep_checkpoint=True)
    ran = []
    monkeypatch.setattr(protocol, "prepare_packing", lambda *a, **k: ran.append(1))
    with pytest.raises(InputError, match="ck_3.h5 belongs to another preparation"):
        api.prepare_packings(params, seeds=[2, 3], checkpoint=str(tmp_path / "ck_{seed}.h5"))
    with pytest.raises(InputError, match="must contain"):
        api.prepare_packings(params, seeds=[2, 3], checkpoint=str(tmp_path / "ck.h5"))
    assert ran == []


# ---------------------------------------------------------------- removed once the outputs exist
def test_after_outputs_runs_only_once_every_output_is_in_place(tmp_path):
    """The command line deletes a checkpoint through atomic.after_outputs: inside a command's
    block it waits for the renames and is dropped when the command fails; outside, at once."""
    seen = []
    with atomic.outputs_together():
        files.atomic_text(tmp_path / "a.txt", "a")
        atomic.after_outputs(lambda: seen.append((tmp_path / "a.txt").exists()))
        assert seen == []
    assert seen == [True]
    with pytest.raises(RuntimeError):
        with atomic.outputs_together():
            files.atomic_text(tmp_path / "b.txt", "b")
            atomic.after_outputs(lambda: seen.append("failed"))
            raise RuntimeError("a later output failed")
    assert seen == [True] and not (tmp_path / "b.txt").exists()
    atomic.after_outputs(lambda: seen.append("now"))
    assert seen == [True, "now"]
