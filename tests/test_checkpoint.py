"""Checkpoints of prepare-packing: a run stopped after a checkpoint and resumed gives the bytes of
an uninterrupted run; another run's checkpoint is refused; a real process killed by SIGTERM
resumes from its checkpoint (docs/dem.md "Checkpoints")."""

import os
import signal
import subprocess
import sys
import time

import h5py
import numba
import numpy as np
import pytest
from click.testing import CliRunner

from granwave import api
from granwave.cli import main
from granwave.dem import checkpoint as CK
from granwave.dem import kernels as K
from granwave.dem import protocol, serial
from granwave.dem.params import PrepareParams
from granwave.errors import InputError
from granwave.io import files
from granwave.provenance import FILE_ATTRS

#: the mean-flow rule with critical settling and the adaptive end game, overdamped (b = 3) so
#: that both rules act in this short column: their state crosses the checkpoint
RULES = PrepareParams(grains=120, aspect=3.0, background_damping=3.0, seed=11, tol=1e-9,
                      compaction="mean-flow", reference_height=2.0, mean_flow_settling="critical",
                      end_game="adaptive")


class Stop(Exception):
    """Stands for a kill right after a checkpoint was written."""


def _bytes(packing) -> bytes:
    c = packing.contacts
    return b"".join(np.ascontiguousarray(x).tobytes() for x in (
        packing.position, packing.radius, packing.box, c.i, c.j, c.normal, c.overlap, c.force_normal,
        c.force_tangential, c.stiffness_normal, c.stiffness_tangential))


def _same_attrs(a: dict, b: dict) -> None:
    assert sorted(a) == sorted(b)
    for k in a:
        assert np.array_equal(a[k], b[k], equal_nan=isinstance(a[k], float)), k


def _stopped_run(monkeypatch, params, path, stop_when) -> int:
    """Run with a checkpoint after every chunk of 200 steps and stop right after the first
    checkpoint for which ``stop_when(run, saves)`` holds; returns the step it holds."""
    keep = CK.Checkpoint.save

    def save(self, run, history, speeds):
        keep(self, run, history, speeds)
        if stop_when(run, self.saves):
            raise Stop(run.engine.steps)

    monkeypatch.setattr(CK.Checkpoint, "save", save)
    with pytest.raises(Stop) as stopped:
        api.prepare_packing(params, checkpoint=path, checkpoint_every=0)
    monkeypatch.setattr(CK.Checkpoint, "save", keep)
    with h5py.File(path, "r") as f:
        assert f.attrs["step"] == stopped.value.args[0]
    return int(stopped.value.args[0])


def _mid_rules(run, saves) -> bool:
    """Both rules under way: the settling switched, the end game started with a fit half done."""
    eg = run.end_game
    return run.settling.done and eg.started and eg.changes > 0 and 0 < len(eg._fit[0]) < 20


@pytest.mark.parametrize("params, stop_when", [
    (PrepareParams(grains=90, seed=11, tol=1e-9), lambda run, saves: saves == 5),
    (PrepareParams(dim=3, grains=60, seed=12, tol=1e-9), lambda run, saves: saves == 5),
    (RULES, _mid_rules),
], ids=["2d-frictional", "3d-frictional", "2d-mean-flow-settling-end-game"])
def test_resumed_run_gives_the_bytes_of_an_uninterrupted_one(params, stop_when, monkeypatch, tmp_path):
    """Straight with the default chunks; stopped after a checkpoint and resumed with chunks of 200
    steps (CALL_SECONDS far below a chunk's time), checkpoints still written as it goes on (at
    every 20th chunk: not at each, which were 780 files and most of this test's time in 3D):
    positions, contacts and forces byte for byte, every attribute equal, the progress says where
    it resumed, the checkpoint is gone."""
    straight = api.prepare_packing(params)
    path = tmp_path / "run.ckpt.h5"
    monkeypatch.setattr(protocol, "CALL_SECONDS", 1e-9)
    step = _stopped_run(monkeypatch, params, path, stop_when)
    assert 0 < step < straight.attrs["steps"]
    lines, asked, saves = [], [], []
    keep = CK.Checkpoint.save
    monkeypatch.setattr(CK.Checkpoint, "due", lambda self: asked.append(1) or len(asked) % 20 == 0)
    monkeypatch.setattr(CK.Checkpoint, "save", lambda self, *a: (saves.append(1), keep(self, *a)))
    resumed = api.prepare_packing(params, checkpoint=path, progress=lines.append)
    assert len(saves) == len(asked) // 20 > 0  # it went on writing checkpoints after the resume
    assert lines[0] == f"resumed from step {step} ({path})"
    assert _bytes(resumed) == _bytes(straight)
    _same_attrs(resumed.attrs, straight.attrs)
    assert not path.exists()
    if params is RULES:
        a = straight.attrs
        assert 0 < a["settling_step"] < step and 0 < a["end_game_step"] < step and a["end_game_changes"] > 1


def test_the_block_engine_resumes_to_the_same_bytes(monkeypatch, tmp_path):
    """The parallel engine's passes (on one thread here) carry neighbour lists, pair constants and
    incoming pairs in their workspace from call to call: restored, the bytes are the same."""
    params = PrepareParams(grains=90, seed=11, tol=1e-9)
    monkeypatch.setattr(serial, "run_chunk", K.run_chunk)
    straight = api.prepare_packing(params)
    path = tmp_path / "run.ckpt.h5"
    monkeypatch.setattr(protocol, "CALL_SECONDS", 1e-9)
    step = _stopped_run(monkeypatch, params, path, lambda run, saves: saves == 7)
    assert 0 < step < straight.attrs["steps"]
    resumed = api.prepare_packing(params, checkpoint=path)
    assert _bytes(resumed) == _bytes(straight)


def test_a_checkpoint_is_written_only_when_due(monkeypatch, tmp_path):
    """With the default interval (600 s) a short run writes none; keep_checkpoint keeps one."""
    params = PrepareParams(grains=40, seed=2, tol=1e-9)
    saved = []
    monkeypatch.setattr(CK.Checkpoint, "save", lambda self, *a: saved.append(a))
    api.prepare_packing(params, checkpoint=tmp_path / "c.h5")
    assert saved == [] and not (tmp_path / "c.h5").exists()
    monkeypatch.undo()
    api.prepare_packing(params, checkpoint=tmp_path / "c.h5", checkpoint_every=0, keep_checkpoint=True)
    with h5py.File(tmp_path / "c.h5", "r") as f:
        assert f.attrs["kind"] == CK.KIND and f.attrs["params_digest"] == CK.params_digest(params)


def test_another_runs_checkpoint_is_refused(monkeypatch, tmp_path):
    """A checkpoint of another seed, of other code, or a file that is not one: one line, no run."""
    path = tmp_path / "c.h5"
    params = PrepareParams(grains=40, seed=2, tol=1e-9)
    api.prepare_packing(params, checkpoint=path, checkpoint_every=0, keep_checkpoint=True)
    ran = []
    monkeypatch.setattr(protocol, "prepare_packing", lambda *a, **k: ran.append(1))
    with pytest.raises(InputError, match=r"belongs to another preparation \(seed 2 \(this run: 3\)\)"):
        api.prepare_packing(PrepareParams(grains=40, seed=3, tol=1e-9), checkpoint=path)
    monkeypatch.setattr(CK, "source_digest", lambda: "0" * 32)
    with pytest.raises(InputError, match="written by other granwave code"):
        api.prepare_packing(params, checkpoint=path)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f.attrs["kind"] = "something else"
    with pytest.raises(InputError, match="is not a granwave checkpoint"):
        api.prepare_packing(params, checkpoint=other)
    (tmp_path / "junk.h5").write_text("not HDF5")
    with pytest.raises(InputError, match="cannot be read"):
        api.prepare_packing(params, checkpoint=tmp_path / "junk.h5")
    assert ran == []


def test_cli_refuses_a_mismatching_checkpoint_in_one_line(tmp_path):
    path = tmp_path / "c.h5"
    api.prepare_packing(PrepareParams(grains=40, seed=2, tol=1e-9), checkpoint=path, checkpoint_every=0,
                        keep_checkpoint=True)
    out = tmp_path / "p.h5"
    r = CliRunner().invoke(main, ["prepare-packing", "--grains", "40", "--seed", "5", "--tol", "1e-9",
                                  "--checkpoint", str(path), "-o", str(out)])
    assert r.exit_code == 2, r.output
    assert r.output.count("\n") == 1 and "belongs to another preparation" in r.output
    assert not out.exists() and path.exists()
    r = CliRunner().invoke(main, ["prepare-packing", "--grains", "40", "--checkpoint", str(out), "-o", str(out)])
    assert r.exit_code == 2 and "is the output file" in r.output


def _packing_file(path) -> tuple[bytes, dict]:
    p = files.read_packing(path)
    with h5py.File(path, "r") as f:
        attrs = {k: v for k, v in f.attrs.items() if k not in FILE_ATTRS}
    return _bytes(p), attrs


def test_sigterm_then_resume_gives_the_file_of_an_uninterrupted_run(tmp_path):
    """A real prepare-packing process with --checkpoint stopped by SIGTERM (a scheduler's time
    limit) after its first checkpoint exits 130 with no packing; run again, it says where it
    resumed, writes the packing of an uninterrupted run (data and attributes but the command
    line) and removes the checkpoint."""
    args = ["prepare-packing", "--grains", "500", "--seed", "7", "--threads", "1"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    straight = tmp_path / "straight.h5"
    done = subprocess.run([sys.executable, "-m", "granwave", *args, "-q", "-o", str(straight)],
                          capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    out, ck = tmp_path / "p.h5", tmp_path / "p.ckpt.h5"
    cmd = [sys.executable, "-m", "granwave", *args, "--checkpoint", str(ck), "--checkpoint-every", "0",
           "-o", str(out)]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 300
    while not ck.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert ck.exists(), "no checkpoint written"
    proc.send_signal(signal.SIGTERM)
    rest = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, rest
    assert not out.exists() and ck.exists()
    with h5py.File(ck, "r") as f:
        step = int(f.attrs["step"])
    resumed = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert resumed.stderr.startswith(f"resumed from step {step} ({ck})")
    assert not ck.exists()
    a, b = _packing_file(straight), _packing_file(out)
    assert a[0] == b[0] and b[1]["steps"] > step
    _same_attrs(a[1], b[1])


def test_workflow_samples_resume_from_their_checkpoint(monkeypatch, tmp_path):
    """A batch's sample with a checkpoint (workflow_support.make_sample) goes on from it to the
    bytes of a straight preparation."""
    from granwave import workflow_support

    make = dict(grains=90, seed=11, tol=1e-9)
    straight = workflow_support.make_sample("continuum", make)
    path = tmp_path / "s.h5"
    monkeypatch.setattr(protocol, "CALL_SECONDS", 1e-9)
    step = _stopped_run(monkeypatch, PrepareParams(**make), path, lambda run, saves: saves == 4)
    assert 0 < step < straight.attrs["steps"]
    resumed = workflow_support.make_sample("continuum", make, str(path))
    assert _bytes(resumed) == _bytes(straight) and path.exists()  # run_sample removes it once written


def test_workflow_gives_tall_packings_threads_and_a_checkpoint():
    """The per-sample rule of a tall column (12 800 grains) gets a thread per 4000 grains (three of
    16 cores, two of 2) and a checkpoint under the results folder; a short one, neither."""
    from quick_plan import CONTINUUM_PACKINGS, command_of, continuum_packing_commands

    def command(target, cores):
        returncode, out = continuum_packing_commands(cores)  # one dry run for these packings
        assert returncode == 0, out[-3000:]
        return command_of(out, target, "granwave prepare-packing")

    tall, short = CONTINUUM_PACKINGS[:2]
    ck = "results/checkpoints/continuum2d_p4/p0.0001/h512/s0.h5"
    line = command(tall, 16)
    assert line.startswith("Shell command: mkdir -p results/checkpoints/continuum2d_p4/p0.0001/h512 && ")
    assert "--grains 12800" in line and "--threads 3 " in line and f"--checkpoint {ck} " in line, line
    assert "--threads 2 " in command(tall, 2)
    short = command(short, 16)
    assert "--threads 1 " in short and "--checkpoint" not in short and "mkdir" not in short, short


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 threads")
def test_a_run_stopped_on_one_thread_resumes_on_two_to_the_same_bytes(monkeypatch, tmp_path):
    """The thread count is not part of a checkpoint's key: stopped on the one-thread loop and
    resumed on two threads of the block engine (threshold lowered), the bytes are the same."""
    params = PrepareParams(grains=90, seed=11, tol=1e-9)
    straight = api.prepare_packing(params, threads=1)
    path = tmp_path / "run.ckpt.h5"
    monkeypatch.setattr(protocol, "CALL_SECONDS", 1e-9)
    keep = numba.get_num_threads()
    try:
        step = _stopped_run(monkeypatch, params, path, lambda run, saves: saves == 6)
        monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
        resumed = api.prepare_packing(params, checkpoint=path, threads=2)
    finally:
        numba.set_num_threads(keep)
    assert 0 < step < straight.attrs["steps"]
    assert _bytes(resumed) == _bytes(straight)
