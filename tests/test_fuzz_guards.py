"""Guards against requests that would be killed (memory) or run for days (issue #66): each is
refused before it allocates or starts, in one line with its estimate, exit 2, no output; the
same request within bounds (or with --allow-long-run) runs. Each case takes well under a second."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from granwave import resources as R
from granwave.cli import main


def run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


def one_line_refusal(r, *words):
    assert r.exit_code == 2, r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), r.output
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


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
