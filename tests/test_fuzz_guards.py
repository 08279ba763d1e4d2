"""Guards against requests that would be killed (memory) or run for days (issue #66): each is
refused before it allocates or starts, in one line with its estimate, exit 2, no output; the
same request within bounds (or with --allow-long-run) runs. Each case takes well under a second."""

from __future__ import annotations

import pytest

from granwave import resources as R


from cli_refusals import one_line_refusal, run  # noqa: E402


@pytest.mark.parametrize("n", [10**9, 10**12])
def test_plot_airy_of_a_huge_chain_is_refused_before_it_allocates(tmp_path, n):
    """`plot airy --n 1000000000` died for memory (80 GB of modal arrays): refused with the
    estimate, whatever the machine's memory (the estimate is proportional to N)."""
    out = tmp_path / "airy.png"
    need = R.CHAIN_FORCE_BYTES_PER_BALL * n
    if need <= R.HEADROOM * R.available_memory():  # a machine that holds it: the run-time guard
        line = one_line_refusal(run(["plot", "airy", "--n", n, "-o", out]), "--allow-long-run")
    else:
        line = one_line_refusal(run(["plot", "airy", "--n", n, "-o", out]), "of memory", str(n))
        assert R.format_bytes(need + 3 * R.DOUBLE * (1 << 21)) in line
    assert not out.exists()


def test_chain_force_estimate_grows_with_the_chain():
    """The run-time estimate is O(samples x N) and the memory one O(N) (property)."""
    t1 = R.predicted_seconds("chain-modal-sum", 1e3, 800, threads=1)
    assert R.predicted_seconds("chain-modal-sum", 1e6, 800, threads=1) == pytest.approx(1e3 * t1)
    assert R.check_chain_force(100, 800) == pytest.approx(t1 / 10)


@pytest.mark.parametrize("spec, count", [("0-100000000", 100000001), ("0-5,10-99999999", 99999996)])
def test_a_huge_seed_range_is_refused_with_its_estimate(tmp_path, spec, count):
    """`--seeds 0-100000000` started preparing seed after seed: refused with the predicted time
    (without listing 10^8 seeds or checking 10^8 names)."""
    line = one_line_refusal(run(["prepare-packing", "--seeds", spec, "-o", tmp_path / "p_{seed}.h5"]),
                            f"{count} preparations", "--allow-long-run", "predicted to take")
    assert "days" in line or "years" in line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("spec", ["0-3,2", "5,5", "0-9,9-12", "3-1"])
def test_overlapping_or_reversed_seed_ranges_are_refused(tmp_path, spec):
    one_line_refusal(run(["prepare-packing", "--seeds", spec, "--grains", 5, "-o", tmp_path / "p_{seed}.h5"]),
                     "--seeds")
    assert not list(tmp_path.iterdir())


def test_seed_ranges_count_what_parse_seeds_lists():
    from granwave.cli.prepare import parse_seeds, seed_ranges

    for spec in ("0-9", "1,4-6", "7", "3-3,10-12,5"):
        seeds = parse_seeds(spec)
        assert len(seeds) == sum(b - a + 1 for a, b in seed_ranges(spec)) == len(set(seeds))


# ---------------------------------------------------------------- checkpoints
CK_RUN = ["prepare-packing", "--grains", 12, "--seed", 3, "--checkpoint-every", 0]


@pytest.fixture(scope="module")
def budget_checkpoint(tmp_path_factory):
    """A checkpoint kept after a step-budget failure (1000 steps), and the bytes of the same
    preparation run whole."""
    import h5py

    folder = tmp_path_factory.mktemp("ck")
    ck, out = folder / "ck.h5", folder / "p.h5"
    r = run([*CK_RUN, "--max-steps", 1000, "--checkpoint", ck, "-o", out, "-q"])
    assert r.exit_code == 1 and "1000 steps did not converge" in r.output, r.output
    assert "kept at step 1000" in r.output and "larger --max-steps" in r.output
    assert ck.exists() and not out.exists()
    whole = folder / "whole.h5"
    assert run([*CK_RUN[:5], "-o", whole, "-q"]).exit_code == 0
    with h5py.File(whole) as f:
        position = f["grains/position"][()]
    return ck, position


def test_a_checkpoint_kept_after_a_budget_failure_resumes_with_a_larger_budget(budget_checkpoint, tmp_path):
    """It could only be resumed with the same budget (the budget was in its digest), which
    failed again: a larger one goes on from it to the bytes of a run made whole."""
    import shutil

    import h5py
    import numpy as np

    ck, position = budget_checkpoint
    mine = shutil.copy(ck, tmp_path / "ck.h5")
    out = tmp_path / "p.h5"
    r = run([*CK_RUN, "--max-steps", 100000, "--checkpoint", mine, "-o", out, "-q"])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert np.array_equal(f["grains/position"][()], position)
        assert f.attrs["max_steps"] == 100000
    assert not (tmp_path / "ck.h5").exists()


def test_a_checkpoint_damaged_anywhere_is_refused_in_one_line(budget_checkpoint, tmp_path):
    """Bytes overwritten in the middle of a checkpoint ended in an h5py RuntimeError (a
    truncated one was refused cleanly): wherever the damage falls, the run is refused in one
    line naming the checkpoint (its state digest catches damage inside a dataset) or, where the
    bytes were unused, resumes."""
    import numpy as np

    ck, _ = budget_checkpoint
    data = ck.read_bytes()
    rng = np.random.default_rng(66)
    outcomes = set()
    for k, offset in enumerate(sorted(rng.integers(0, len(data) - 64, size=10))):
        damaged = tmp_path / f"ck{k}.h5"
        damaged.write_bytes(data[:offset] + bytes(rng.integers(0, 256, 64, dtype=np.uint8)) + data[offset + 64:])
        out = tmp_path / f"p{k}.h5"
        r = run([*CK_RUN, "--max-steps", 1001, "--checkpoint", damaged, "-o", out, "-q"])
        if r.exit_code == 1:  # resumed: one more step, the budget again
            assert "1001 steps did not converge" in r.output, r.output
            outcomes.add("resumed")
            continue
        one_line_refusal(r, str(damaged))
        assert not out.exists()
        outcomes.add("refused")
    assert "refused" in outcomes
    truncated = tmp_path / "short.h5"
    truncated.write_bytes(data[: len(data) // 2])
    one_line_refusal(run([*CK_RUN, "--checkpoint", truncated, "-o", tmp_path / "t.h5"]), "short.h5")


def test_another_runs_checkpoint_names_the_differences(budget_checkpoint, tmp_path):
    """The refusal printed the whole parameter dictionary on one line: it names what differs."""
    ck, _ = budget_checkpoint
    line = one_line_refusal(run(["prepare-packing", "--grains", 12, "--seed", 4, "--pressure", 1e-3,
                                 "--checkpoint", ck, "-o", tmp_path / "p.h5"]), "belongs to another")
    assert "seed 3 (this run: 4)" in line and "pressure 0.0001 (this run: 0.001)" in line
    assert "polydispersity" not in line and len(line) < 300


def test_a_gpu_checkpoint_kept_after_a_budget_failure_takes_a_larger_budget(budget_checkpoint, tmp_path):
    """The GPU batch path (granwave/gpu/batch.py) runs the same protocol and Checkpoint: its
    budget failure saves the run so far and its resume checks the same digest, without the
    budget. The GPU run itself takes minutes in numba's CUDA simulator (a 10-grain preparation
    of 200 steps did not end in 5 minutes on a loaded CI core): here the check of a checkpoint
    written on the GPU, under a larger and a smaller budget, and another seed refused."""
    import shutil

    import h5py

    from granwave.dem import checkpoint as CK
    from granwave.dem.params import PrepareParams
    from granwave.errors import InputError

    ck, _ = budget_checkpoint
    mine = shutil.copy(ck, tmp_path / "gpu_ck.h5")
    with h5py.File(mine, "a") as f:
        f.attrs["device"] = "gpu"
        steps = int(f.attrs["step"])
    for budget in (100000, steps + 1, 10 * steps):
        CK.Checkpoint(mine, PrepareParams(grains=12, seed=3, max_steps=budget), device="gpu").check()
    with pytest.raises(InputError, match="belongs to another preparation.*seed 3 \\(this run: 4\\)"):
        CK.Checkpoint(mine, PrepareParams(grains=12, seed=4, max_steps=100000), device="gpu").check()
    with pytest.raises(InputError, match="written on the GPU"):
        CK.Checkpoint(mine, PrepareParams(grains=12, seed=3, max_steps=100000), device="cpu").check()
