"""Parameters are refused where they are given, in one line, before any work: wrong types in
the API (a bool or a string for a number, None for a required number), a seed that files cannot
store, a pressure whose forces underflow, and a workflow sample whose stage would refuse it."""

import pytest
from click.testing import CliRunner

from granwave.cli import main
from granwave.errors import InputError
from granwave.params import MAX_SEED, MIN_PRESSURE, PrepareParams, PropagateParams
from granwave.workflow_config import samples_error


@pytest.mark.parametrize("kw, message", [
    (dict(pressure=True), "pressure must be a number, got True"),
    (dict(pressure="1e-4"), "pressure must be a number, got '1e-4'"),
    (dict(tol=None), "tol must be a number, got None"),
    (dict(grains=None), "grains must be a number, got None"),
    (dict(seed=MAX_SEED + 1), "seed must be in [0, 9223372036854775807]"),
    (dict(pressure=1e-310), "pressure must be in [1e-12, 0.1] E*"),
])
def test_prepare_params_refuse(kw, message):
    with pytest.raises(InputError) as exc:
        PrepareParams(**kw)
    assert message in str(exc.value)


def test_the_limits_themselves_are_accepted():
    assert PrepareParams(seed=MAX_SEED, pressure=MIN_PRESSURE).seed == MAX_SEED
    t_max = PropagateParams(t_max=10).t_max  # an integer where a float is asked: taken as a float
    assert t_max == 10.0 and isinstance(t_max, float)


@pytest.mark.parametrize("snapshots", ["15", [True, 2.0], 3.0])
def test_snapshots_must_be_a_list_of_times(snapshots):
    with pytest.raises(InputError, match="snapshots must be a list of times"):
        PropagateParams(t_max=10.0, snapshots=snapshots)


def test_snapshot_times_are_read_as_floats():
    assert PropagateParams(t_max=10.0, snapshots=[1, "2.5"]).snapshots == (1.0, 2.5)


def test_a_seed_files_cannot_store_is_refused_before_the_run(tmp_path):
    out = tmp_path / "p.h5"
    result = CliRunner().invoke(main, ["prepare-packing", "--grains", "20", "--seed", str(2**64), "-o", str(out)])
    assert result.exit_code == 2
    assert "seed must be in [0, 9223372036854775807]" in result.output
    assert not out.exists()


def _batch(kind, make):
    signal = dict(method="auto", ic="A", t_max=100.0, samples=101, safety=0.1)
    return [("batch_x_0", "x", [dict(kind=kind, pressure="1e-4", size="n10", seed=0, make=make, signal=signal)])]


def test_workflow_samples_are_checked_by_their_stage():
    assert samples_error(_batch("chains", dict(n_balls=10, pressure=1e-4, polydispersity=0.0, seed=0))) is None
    message = samples_error(_batch("chains", dict(n_balls=10, pressure=1e-13, polydispersity=0.0, seed=0)))
    assert message.startswith("config: x, sample 1e-4/n10/s0: pressure must be in [1e-12, 0.1]")
    message = samples_error(_batch("disordered", dict(grains=100, pressure=1e-4, seed=MAX_SEED + 1)))
    assert "seed must be in" in message


def test_a_signal_that_is_not_finite_is_not_written(tmp_path):
    import numpy as np

    from granwave.errors import ConvergenceError
    from granwave.io import files
    from granwave.model import Signal

    out = tmp_path / "s.h5"
    force = np.zeros(11)
    force[7] = np.nan  # an integration that blew up
    with pytest.raises(ConvergenceError, match="signal is not finite"):
        files.write_signal(out, Signal(time=np.linspace(0.0, 1.0, 11), force=force))
    assert not out.exists() and not list(tmp_path.iterdir())
