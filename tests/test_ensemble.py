"""Ensemble average (docs/method.md §9): mean and rms, common grid, front statistics, CLI and its errors."""

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from granwave.io import files, schema
from granwave.analysis.ensemble import (analyze_ensemble, ensemble_average, read_ensemble,
                                        write_ensemble)
from granwave.analysis.front import front_features
from granwave.cli.analyze_ensemble import ensemble as ensemble_cmd
from granwave.errors import InputError
from granwave.model import Signal
from granwave import theory

N = 50
DT = 0.05
T = np.arange(0.0, theory.chain_travel_time(N) + 12.0, DT)


def chain(shift=0, scale=1.0, pressure=1e-4, ic="A"):
    """Chain wall force delayed by ``shift`` samples (exact, from the modal sum)."""
    f = scale * theory.chain_wall_force(T - shift * DT, N, ic=ic)
    return Signal(T.copy(), f, attrs=dict(ic=ic, method="modal", height=N + 1.0 + 0.01 * shift,
                                          pressure=pressure, kind="chain"))


def test_identical_signals_have_zero_rms():
    ens = ensemble_average([chain(), chain(), chain()])
    np.testing.assert_array_equal(ens.time, T)
    np.testing.assert_allclose(ens.mean, chain().force, rtol=0, atol=1e-15)
    assert np.all(ens.rms <= 1e-15)
    assert ens.attrs["grid"] == "identical" and ens.n_signals == 3


def test_plus_minus_perturbations_give_known_rms():
    s = chain().force
    delta = 1e-3 * np.sin(0.7 * T)
    k = np.array([1.0, -1.0, 2.0, -2.0])  # s + k delta: mean s, rms sqrt(mean(k^2)) |delta|
    sigs = [Signal(T, s + ki * delta, attrs={"ic": "A"}) for ki in k]
    ens = ensemble_average(sigs)
    np.testing.assert_allclose(ens.mean, s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ens.rms, np.sqrt(np.mean(k**2)) * np.abs(delta), rtol=1e-10, atol=1e-16)


def test_different_grids_are_interpolated_on_the_overlap():
    # Linear signals are interpolated exactly: the mean is known at every grid point.
    t1 = np.linspace(0.0, 10.0, 101)  # step 0.1
    t2 = np.linspace(2.0, 12.0, 401)  # step 0.025
    sigs = [Signal(t1, 3.0 * t1 + 1.0, attrs={}), Signal(t2, -1.0 * t2, attrs={})]
    ens = ensemble_average(sigs)
    assert ens.attrs["grid"] == "overlap"
    assert ens.time[0] == 2.0 and ens.time[-1] == pytest.approx(10.0, abs=1e-9)
    np.testing.assert_allclose(np.diff(ens.time), 0.025, rtol=1e-9)
    np.testing.assert_allclose(ens.mean, (3.0 * ens.time + 1.0 - ens.time) / 2, rtol=1e-12)
    np.testing.assert_allclose(ens.rms, np.abs(3.0 * ens.time + 1.0 + ens.time) / 2, rtol=1e-12)
    with pytest.raises(InputError, match="do not overlap"):
        ensemble_average([Signal(t1, t1, attrs={}), Signal(t1 + 20.0, t1, attrs={})])


def test_front_statistics_of_shifted_and_scaled_signals():
    shifts = np.array([0, 4, 10, 3])
    scales = np.array([1.0, 2.0, 0.5, 1.5])
    sigs = [chain(int(k), float(a)) for k, a in zip(shifts, scales)]
    _, summary = analyze_ensemble(sigs)
    base = front_features(T, chain().force)
    st = summary["front_stats"]
    # Delays shift every time by k*DT; scales multiply the amplitude and keep the times.
    for key in ("t_lead10", "t_peak", "t_zero"):
        expect = getattr(base, key) + shifts * DT
        assert st[key]["mean"] == pytest.approx(expect.mean(), abs=1e-9)
        assert st[key]["std"] == pytest.approx(expect.std(ddof=1), abs=1e-9)
        assert st[key]["sem"] == pytest.approx(expect.std(ddof=1) / 2, abs=1e-9)
        assert st[key]["count"] == 4
    amp = base.amplitude * scales
    assert st["amplitude"]["mean"] == pytest.approx(amp.mean(), rel=1e-10)
    assert st["width"]["std"] == pytest.approx(0.0, abs=1e-9)
    # The mean of identical-shape signals is the same shape: its front equals theirs.
    _, same = analyze_ensemble([chain(0, a) for a in scales])
    assert same["front_of_mean"]["t_peak"] == pytest.approx(base.t_peak, abs=1e-9)
    assert same["front_of_mean"]["amplitude"] == pytest.approx(base.amplitude * scales.mean(), rel=1e-10)


def test_file_round_trip(tmp_path):
    ens = ensemble_average([chain(), chain(2)])
    write_ensemble(tmp_path / "e.h5", ens)
    back = read_ensemble(tmp_path / "e.h5")
    np.testing.assert_array_equal(back.mean, ens.mean)
    np.testing.assert_array_equal(back.rms, ens.rms)
    assert back.n_signals == 2 and back.attrs["ic"] == "A"
    with h5py.File(tmp_path / "e.h5") as f:
        assert f.attrs["schema"] == schema.ENSEMBLE
        assert f["ensemble/rms"].attrs["units"] == "E_star * d_bar**2"
    files.write_signal(tmp_path / "s.h5", chain())
    with pytest.raises(InputError, match="expected a granwave.ensemble file"):
        read_ensemble(tmp_path / "s.h5")


def write(tmp_path, name, sig):
    files.write_signal(tmp_path / name, sig)
    return str(tmp_path / name)


def test_cli_writes_file_and_json(tmp_path):
    paths = [write(tmp_path, f"s{k}.h5", chain(k)) for k in (0, 2, 6)]
    out = tmp_path / "ens.h5"
    r = CliRunner().invoke(ensemble_cmd, [*paths, "-o", str(out), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    assert res["n_signals"] == 3 and res["front_stats"]["t_peak"]["count"] == 3
    ens = read_ensemble(out)
    lib = ensemble_average([files.read_signal(p) for p in paths])
    np.testing.assert_array_equal(ens.mean, lib.mean)
    assert ens.attrs["front_t_peak_mean"] == pytest.approx(res["front_stats"]["t_peak"]["mean"])
    assert ens.attrs["pressure"] == 1e-4
    r = CliRunner().invoke(ensemble_cmd, [*paths, "-o", str(tmp_path / "ens2.h5")])
    assert r.exit_code == 0 and "t_peak" in r.output


def _fails(args, match, out):
    r = CliRunner().invoke(ensemble_cmd, [*args, "-o", str(out)])
    assert r.exit_code != 0
    assert r.exception is None or isinstance(r.exception, SystemExit)
    assert match in r.output and len(r.output.strip().splitlines()) == 1, r.output
    assert not out.exists()


def test_cli_bad_input(tmp_path):
    out = tmp_path / "ens.h5"
    good = write(tmp_path, "a.h5", chain())
    _fails([], "no signal files", out)
    _fails([good, write(tmp_path, "p.h5", chain(pressure=1e-5))], "mixed pressure", out)
    _fails([good, write(tmp_path, "b.h5", chain(ic="B"))], "mixed ic", out)
    cut = chain()
    keep = cut.time < theory.chain_travel_time(N) - 2.0  # before the first peak
    _fails([good, write(tmp_path, "cut.h5", Signal(T[keep], cut.force[keep], attrs=cut.attrs))],
           "cut.h5", out)
    (tmp_path / "x.h5").write_text("no")
    _fails([good, str(tmp_path / "x.h5")], "not an HDF5 file", out)
    _fails([good, good], "folder", tmp_path / "missing" / "e.h5")
    assert not list(tmp_path.glob(".*.tmp"))
