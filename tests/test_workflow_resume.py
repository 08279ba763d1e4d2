"""A workflow batch that is cut keeps the samples it finished (granwave.finished_store).

Unit level: run_batch with a fake per-sample run that writes files whose bytes name the call
that made them and fails (as a kill) on the 3rd sample; the outputs are then removed, as
Snakemake removes an incomplete job's, and the batch runs again. End to end: a batch of
three chain samples cut through snakemake after its first sample (the test hook of
finished_store.STOP_AFTER_ENV) and rerun with --rerun-incomplete, against an uninterrupted run.
"""

import csv
import errno
import hashlib
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from granwave import finished_store
from granwave.errors import InputError
from granwave.io.files import atomic_text
from granwave.workflow_support import run_batch

ROOT = Path(__file__).resolve().parents[1]
FIELDS = ["scene", "pressure", "size", "seed", "stage", "cpu_s", "wall_s"]
STAGES = ("packing", "linear", "summary")


def _samples(results: Path, n=5, height=10):
    out = []
    for seed in range(n):
        tail = f"sc/p0.0001/h{height}/s{seed}"
        out.append({"kind": "disordered", "scene": "sc", "pressure": "0.0001", "size": f"h{height}",
                    "seed": seed, "make": {"grains": 40, "seed": seed},
                    "out": {stage: str(results / stage / f"{tail}{'.json' if stage == 'summary' else '.h5'}")
                            for stage in STAGES}})
    return out


class FakeRun:
    """Writes every file of a sample with bytes naming this call (a sample computed again has
    other bytes) and times each stage by the call number; ``fail_on``: the call (1-based) that
    is cut (KeyboardInterrupt, as SIGTERM makes it in a batch) or refused (``error``)."""

    def __init__(self, fail_on=None, error=KeyboardInterrupt):
        self.calls, self.fail_on, self.error = [], fail_on, error

    def __call__(self, sample, log):
        self.calls.append(sample["seed"])
        if len(self.calls) == self.fail_on:
            raise self.error("cut")
        for stage, path in sample["out"].items():
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            atomic_text(path, f"{stage} of seed {sample['seed']}, call {len(self.calls)}\n")
        log(f"{sample['out']['summary']}: computed")
        return [{"stage": stage, "cpu_s": float(len(self.calls)) + k / 8, "wall_s": 0.5} for k, stage in
                enumerate(STAGES)]


def _batch(tmp_path, samples, run):
    run_batch(run, samples, log_path=tmp_path / "batch.log", timings_path=tmp_path / "timings.tsv",
              fields=FIELDS, failed_key="summary", store=tmp_path / "results" / "finished" / "batch_sc_0")


def _bytes(samples):
    return {path: Path(path).read_bytes() for s in samples for path in s["out"].values()}


def _remove_outputs(samples):
    """What Snakemake does to an incomplete job before running it again."""
    for s in samples:
        for path in s["out"].values():
            Path(path).unlink(missing_ok=True)


def _timings(tmp_path):
    with open(tmp_path / "timings.tsv") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def test_a_cut_batch_restores_its_finished_samples_instead_of_computing_them(tmp_path):
    samples = _samples(tmp_path / "results")
    store = tmp_path / "results" / "finished" / "batch_sc_0"
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, FakeRun(fail_on=3))
    first = _bytes(samples[:2])
    entry = finished_store.entry_of(store, samples[0], ("scene", "pressure", "size", "seed"))
    assert entry == store / "sc" / "0.0001" / "h10" / "0"
    # hard links: the entry is the output, no second copy on disk
    assert os.path.samefile(entry / "packing.h5", samples[0]["out"]["packing"])
    assert not (tmp_path / "timings.tsv").exists()
    _remove_outputs(samples)

    again = FakeRun()
    _batch(tmp_path, samples, again)
    assert again.calls == [2, 3, 4]  # seeds 0 and 1 were not run again
    assert _bytes(samples[:2]) == first  # the bytes of the first run's calls 1 and 2
    assert Path(samples[2]["out"]["summary"]).read_text() == "summary of seed 2, call 1\n"
    log = (tmp_path / "batch.log").read_text().splitlines()
    assert sum("restored from" in line for line in log) == 2 and sum("computed" == line[-8:] for line in log) == 3
    assert log[0].startswith(samples[0]["out"]["summary"] + ": restored from " + str(entry))
    assert not [line for line in log if "copies" in line]  # hard links here
    rows = _timings(tmp_path)
    assert [(int(r["seed"]), r["stage"]) for r in rows] == [(s, st) for s in range(5) for st in STAGES]
    # the restored samples' rows are those of the run that computed them (calls 1 and 2)
    assert [float(r["cpu_s"]) for r in rows[:6]] == [1.0, 1.125, 1.25, 2.0, 2.125, 2.25]
    assert [float(r["cpu_s"]) for r in rows[6:9]] == [1.0, 1.125, 1.25]
    assert not store.exists()  # the batch wrote all its outputs: no duplicates left


def test_a_changed_recipe_is_computed_again_and_its_stale_entry_replaced(tmp_path):
    samples = _samples(tmp_path / "results")
    store = tmp_path / "results" / "finished" / "batch_sc_0"
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, FakeRun(fail_on=3))
    _remove_outputs(samples)
    samples[0]["make"]["grains"] = 41  # the config changed between the runs
    again = FakeRun(fail_on=4)  # cut again, after seeds 0, 2 and 3
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, again)
    assert again.calls == [0, 2, 3, 4]
    log = (tmp_path / "batch.log").read_text()
    assert "of another recipe: computed again" in log and log.count("restored from") == 1
    stamp = json.loads((store / "sc" / "0.0001" / "h10" / "0" / "stamp.json").read_text())
    assert stamp["recipe"] == finished_store.recipe_digest(samples[0])  # replaced by the new one
    assert stamp["timings"][0]["cpu_s"] == 1.0  # of this run's first call
    _remove_outputs(samples)
    last = FakeRun()
    _batch(tmp_path, samples, last)
    assert last.calls == [4]
    assert Path(samples[0]["out"]["linear"]).read_text() == "linear of seed 0, call 1\n"


def test_an_entry_without_its_stamp_or_with_a_changed_file_is_not_used(tmp_path):
    samples = _samples(tmp_path / "results", n=3)
    store = tmp_path / "results" / "finished" / "batch_sc_0"
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, FakeRun(fail_on=3))
    keys = ("scene", "pressure", "size", "seed")
    (finished_store.entry_of(store, samples[0], keys) / "stamp.json").unlink()  # cut while being kept
    _remove_outputs(samples)  # the entry of seed 1 now holds the only name of its files
    (finished_store.entry_of(store, samples[1], keys) / "linear.h5").write_text("edited")
    again = FakeRun()
    _batch(tmp_path, samples, again)
    assert again.calls == [0, 1, 2]


def test_without_hard_links_the_store_copies(tmp_path, monkeypatch):
    def no_link(src, dst):
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_link)
    samples = _samples(tmp_path / "results", n=3)
    store = tmp_path / "results" / "finished" / "batch_sc_0"
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, FakeRun(fail_on=2))
    entry = finished_store.entry_of(store, samples[0], ("scene", "pressure", "size", "seed"))
    assert not os.path.samefile(entry / "packing.h5", samples[0]["out"]["packing"])
    first = _bytes(samples[:1])
    assert "kept as copies (no hard links on this file system)" in (tmp_path / "batch.log").read_text()
    _remove_outputs(samples)
    again = FakeRun()
    _batch(tmp_path, samples, again)
    assert again.calls == [1, 2] and _bytes(samples[:1]) == first and not store.exists()


def test_a_sample_that_cannot_be_kept_is_a_log_line_not_the_batchs_end(tmp_path, monkeypatch):
    def no_link(src, dst):
        raise OSError(errno.EXDEV, "Invalid cross-device link")

    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "link", no_link)
    monkeypatch.setattr(finished_store.shutil, "copyfile", full)
    samples = _samples(tmp_path / "results", n=2)
    run = FakeRun()
    _batch(tmp_path, samples, run)
    assert run.calls == [0, 1] and len(_timings(tmp_path)) == 6
    log = (tmp_path / "batch.log").read_text()
    assert log.count("not kept (cannot write") == 2, log


def test_a_refused_sample_ends_the_batch_and_keeps_the_ones_before(tmp_path):
    samples = _samples(tmp_path / "results", n=3)
    with pytest.raises(SystemExit):
        _batch(tmp_path, samples, FakeRun(fail_on=2, error=InputError))
    assert "s1.json: cut" in (tmp_path / "batch.log").read_text()
    _remove_outputs(samples)
    again = FakeRun()
    _batch(tmp_path, samples, again)
    assert again.calls == [1, 2]


def test_a_given_packing_is_neither_kept_nor_restored(tmp_path):
    """device gpu: the packing is the batch's input (made by its height's GPU job), not its output."""
    samples = _samples(tmp_path / "results", n=2)
    for s in samples:
        s["packing_given"] = True
    assert "packing" not in finished_store.sample_files(samples[0])
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, FakeRun(fail_on=2))
    entry = finished_store.entry_of(tmp_path / "results" / "finished" / "batch_sc_0", samples[0],
                                    ("scene", "pressure", "size", "seed"))
    assert sorted(p.name for p in entry.iterdir()) == ["linear.h5", "stamp.json", "summary.json"]


# ---- what the kept files record (a store from another config, a config edited mid-run)

class H5Run(FakeRun):
    """Writes HDF5 files that record what real stages record: the packing its ``make`` options
    and a packing digest (``digest``, default from the options), the linear file that digest."""

    def __init__(self, digest=None, **kw):
        super().__init__(**kw)
        self.digest = digest

    def __call__(self, sample, log):
        import h5py

        self.calls.append(sample["seed"])
        if len(self.calls) == self.fail_on:
            raise self.error("cut")
        digest = self.digest or hashlib.md5(json.dumps(sample["make"], sort_keys=True).encode()).hexdigest()
        for stage, path in finished_store.sample_files(sample).items():
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            if stage == "summary":
                atomic_text(path, json.dumps({"packing_digest": digest, "call": len(self.calls)}) + "\n")
                continue
            with h5py.File(path, "w") as f:
                f.attrs["packing_digest"] = digest
                if stage == "packing":
                    for key, value in sample["make"].items():
                        f.attrs[key] = value
        return [{"stage": stage, "cpu_s": 1.0, "wall_s": 0.5} for stage in STAGES]


def test_an_entry_whose_files_record_other_parameters_is_computed_again(tmp_path):
    """A store copied from another config's results (or a stamp that says this recipe over
    files of another): the packing records another pressure; not put back, computed again."""
    import h5py

    samples = _samples(tmp_path / "results", n=3)
    for s in samples:
        s["make"]["pressure"] = 1e-4
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, H5Run(fail_on=3))
    _remove_outputs(samples)
    store = tmp_path / "results" / "finished" / "batch_sc_0"
    entry = finished_store.entry_of(store, samples[1], ("scene", "pressure", "size", "seed"))
    packing = entry / "packing.h5"
    data = packing.read_bytes()  # the other config's file (same size: h5py rewrites in place)
    packing.unlink()
    packing.write_bytes(data)
    with h5py.File(packing, "a") as f:
        f.attrs["pressure"] = 1e-3
    assert packing.stat().st_size == len(data)
    again = H5Run()
    _batch(tmp_path, samples, again)
    assert again.calls == [1, 2]  # seed 0 restored, seed 1 computed again
    log = (tmp_path / "batch.log").read_text()
    assert "made with other parameters (packing pressure 0.001, this run 0.0001): computed again" in log
    with h5py.File(samples[1]["out"]["packing"]) as f:
        assert f.attrs["pressure"] == 1e-4


def test_a_given_packing_made_again_voids_the_files_of_the_old_one(tmp_path):
    """device gpu: the packing is the GPU job's output; remade (another config, then this one
    again, or other code), the kept linear file and summary belong to the old packing."""
    import h5py

    samples = _samples(tmp_path / "results", n=2)
    for s in samples:
        s["packing_given"] = True
        Path(s["out"]["packing"]).parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(s["out"]["packing"], "w") as f:
            f.attrs["packing_digest"] = "old"
            f.attrs["seed"] = s["seed"]
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, H5Run(digest="old", fail_on=2))
    for s in samples:  # what the batch made, not the given packing
        Path(s["out"]["linear"]).unlink(missing_ok=True)
        Path(s["out"]["summary"]).unlink(missing_ok=True)
    with h5py.File(samples[0]["out"]["packing"], "a") as f:
        f.attrs["packing_digest"] = "new"
    again = H5Run(digest="new")
    _batch(tmp_path, samples, again)
    assert again.calls == [0, 1]
    assert "linear.h5 is of another packing (digest old, the packing's new)" in (tmp_path / "batch.log").read_text()


def test_an_entry_whose_files_agree_is_restored(tmp_path):
    samples = _samples(tmp_path / "results", n=2)
    with pytest.raises(KeyboardInterrupt):
        _batch(tmp_path, samples, H5Run(fail_on=2))
    _remove_outputs(samples)
    again = H5Run()
    _batch(tmp_path, samples, again)
    assert again.calls == [1] and "restored from" in (tmp_path / "batch.log").read_text()


# ---- end to end, through snakemake

CHAINS = """\
name: resume
results: results
ic: A
samples: 800
t_max_factor: 2.5
chains:
  chain_A:
    balls: [20, 40, 80]
damping:
  enabled: false
"""
BATCH = "results/timings/batch_reference_0.tsv"


def _snakemake(cwd, *args, env=None):
    return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
                           BATCH, "--cores", "2", *args, "--configfile", "chains.yaml"],
                          cwd=cwd, capture_output=True, text=True, timeout=600,
                          env={**os.environ, **(env or {})})


def _digests(results: Path) -> dict:
    return {str(p.relative_to(results)): hashlib.sha256(p.read_bytes()).hexdigest()
            for stage in ("packing", "linear", "signal", "front", "summary")
            for p in sorted((results / stage).rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_a_batch_cut_under_snakemake_restores_its_first_sample_on_rerun(tmp_path):
    straight, cut = tmp_path / "straight", tmp_path / "cut"
    for folder in (straight, cut):
        folder.mkdir()
        (folder / "chains.yaml").write_text(CHAINS)
    run = _snakemake(straight)
    assert run.returncode == 0, (run.stdout + run.stderr)[-3000:]
    expected = _digests(straight / "results")
    assert len(expected) == 15  # 3 samples x 5 files

    stopped = _snakemake(cut, env={finished_store.STOP_AFTER_ENV: "1"})
    assert stopped.returncode != 0, (stopped.stdout + stopped.stderr)[-3000:]
    first = "chain_A/p0.0001/n20/s0"
    entry = cut / "results" / "finished" / "batch_reference_0" / "chain_A" / "0.0001" / "n20" / "0"
    assert (entry / "stamp.json").is_file()
    kept = {stage: os.stat(entry / f"{stage}.h5").st_ino for stage in ("packing", "linear", "signal")}
    assert not (cut / "results" / "packing" / f"{first}.h5").exists()  # snakemake removed the job's outputs

    rerun = _snakemake(cut, "--rerun-incomplete")
    assert rerun.returncode == 0, (rerun.stdout + rerun.stderr)[-3000:]
    log = (cut / "results" / "logs" / "batch" / "batch_reference_0.log").read_text().splitlines()
    assert log[0].startswith(f"results/summary/{first}.json: restored from results/finished/"), log
    assert sum("restored from" in line for line in log) == 1, log
    for stage, inode in kept.items():  # the very files the cut run made
        assert os.stat(cut / "results" / stage / f"{first}.h5").st_ino == inode, stage
    assert _digests(cut / "results") == expected
    assert not (cut / "results" / "finished" / "batch_reference_0").exists()
    again = _snakemake(cut)  # the restored files are up to date for snakemake
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr

    spec = importlib.util.spec_from_file_location("workflow_runtime", ROOT / "benchmarks" / "workflow_runtime.py")
    runtime = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(runtime)
    rows = runtime.sample_rows(cut / "results")
    assert sorted(r["size"] for r in rows) == ["n20", "n40", "n80"]
    assert all(r["packing"] > 0 and "signal" in r and "front" in r for r in rows)
