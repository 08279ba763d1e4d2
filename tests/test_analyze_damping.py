"""`granwave analyze damping` and the report's damping table, on synthetic signals."""

import json

import numpy as np
from click.testing import CliRunner

from granwave.cli import main
from granwave.io.files import write_signal
from granwave.model import Signal
from granwave.report import build_report


def pulse(t, zeta):
    """A Gaussian-derivative front at t = 20 (amplitude falling with zeta) plus a tail at t > 60."""
    front = -(t - 20.0) / 3.0 * np.exp(-((t - 20.0) / 3.0) ** 2) / (1.0 + zeta)
    tail = 0.1 * np.sin(t) * (t > 60.0) * np.exp(-zeta * 5.0)
    return front + tail


def test_table_orders_by_zeta_and_amplitude_and_tail_fall(tmp_path):
    t = np.linspace(0.0, 120.0, 6001)
    paths = []
    for zeta in (0.5, 0.0, 0.1):
        path = tmp_path / f"z{zeta}.h5"
        write_signal(path, Signal(time=t, force=pulse(t, zeta),
                                  attrs=dict(ic="A", method="dem", height=10.0, damping=zeta)))
        paths.append(str(path))
    run = CliRunner().invoke(main, ["analyze", "damping", *paths, "--json"])
    assert run.exit_code == 0, run.output
    rows = json.loads(run.output)
    assert [r["damping"] for r in rows] == [0.0, 0.1, 0.5]
    amps = [r["amplitude"] for r in rows]
    # The front's peak is (1/(1+zeta)) * max|x e^{-x^2}| = e^{-1/2}/sqrt(2)/(1+zeta).
    np.testing.assert_allclose(amps, [np.exp(-0.5) / np.sqrt(2) / (1 + z) for z in (0, 0.1, 0.5)],
                               rtol=1e-4)
    tails = [r["tail_rms"] for r in rows]
    assert tails[0] > tails[1] > tails[2] > 0
    report = build_report(damping=rows)
    assert "## Damping series" in report and report.count("\n| 0.1") == 1


def test_signals_without_damping_attribute_are_refused(tmp_path):
    t = np.linspace(0.0, 120.0, 601)
    path = tmp_path / "s.h5"
    write_signal(path, Signal(time=t, force=pulse(t, 0.0), attrs=dict(ic="A", method="modal", height=1.0)))
    run = CliRunner().invoke(main, ["analyze", "damping", str(path)])
    assert run.exit_code != 0
    assert "damping" in run.output and "Traceback" not in run.output


def test_signal_without_damping_is_named(tmp_path):
    t = np.linspace(0.0, 120.0, 601)
    good, bad = tmp_path / "z0.h5", tmp_path / "linear.h5"
    write_signal(good, Signal(time=t, force=pulse(t, 0.0), attrs=dict(ic="A", method="dem",
                                                                       height=10.0, damping=0.0)))
    write_signal(bad, Signal(time=t, force=pulse(t, 0.0), attrs=dict(ic="A", method="modal",
                                                                      height=10.0)))
    run = CliRunner().invoke(main, ["analyze", "damping", str(good), str(bad), "--json"])
    assert run.exit_code != 0 and f"{bad}: no 'damping' attribute" in run.output
    assert "Traceback" not in run.output
