"""Coherent-front features (docs/method.md §9) on analytic pulses and on the exact chain."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy import optimize

from granwave import theory
from granwave.analysis.front import front_features
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files
from granwave.model import Signal

SIGMA = 1.3
T0 = 10.0137  # not on the sample grid


def gauss_derivative(t, t0=T0):
    """x exp(-x^2/2), x = (t - t0)/SIGMA: a negative lobe then a positive one of equal size."""
    x = (t - t0) / SIGMA
    return x * np.exp(-x * x / 2)


def exact_points():
    """Closed-form points of the first (negative) lobe: peak at x = -1, zero at x = 0."""
    amp = np.exp(-0.5)
    x_lead = optimize.brentq(lambda x: x * np.exp(-x * x / 2) + 0.1 * amp, -10.0, -1.0, xtol=1e-14)
    return dict(t_peak=T0 - SIGMA, amplitude=amp, t_zero=T0, t_lead10=T0 + SIGMA * x_lead)


def test_gaussian_derivative_points_in_closed_form():
    # dt = sigma/20: linear interpolation and the parabola err by O(dt^2) ~ 1e-3 sigma.
    t = np.arange(0.0, 25.0, SIGMA / 20)
    f = front_features(t, gauss_derivative(t))
    ex = exact_points()
    assert f.polarity == -1
    assert f.t_peak == pytest.approx(ex["t_peak"], abs=1e-3 * SIGMA)
    assert f.amplitude == pytest.approx(ex["amplitude"], rel=1e-4)
    assert f.t_zero == pytest.approx(ex["t_zero"], abs=1e-3 * SIGMA)
    assert f.t_lead10 == pytest.approx(ex["t_lead10"], abs=1e-3 * SIGMA)
    assert f.width == pytest.approx(f.t_zero - f.t_lead10, rel=1e-15)
    assert f.width == pytest.approx(ex["t_zero"] - ex["t_lead10"], abs=2e-3 * SIGMA)
    # Linear interpolation misplaces a crossing by at most dt^2/8 |F''|max / |F'| (derived bound),
    # for any sampling; check it for several dt and grid offsets.
    x = np.linspace(-4, 0, 4001)
    f2max = np.max(np.abs((x**3 - 3 * x) * np.exp(-x * x / 2))) / SIGMA**2
    xl = (ex["t_lead10"] - T0) / SIGMA
    f1_lead = abs((1 - xl * xl) * np.exp(-xl * xl / 2)) / SIGMA
    for dt in (SIGMA / 10, SIGMA / 20, SIGMA / 40):
        for offset in (0.0, 0.3, 0.7):
            ts = np.arange(offset * dt, 25.0, dt)
            fs = front_features(ts, gauss_derivative(ts))
            assert abs(fs.t_lead10 - ex["t_lead10"]) <= dt**2 / 8 * f2max / f1_lead
            assert abs(fs.t_zero - ex["t_zero"]) <= dt**2 / 8 * f2max / (1 / SIGMA)


def test_precursor_and_ripples_are_skipped():
    t0 = 30.0
    t = np.arange(0.0, 45.0, SIGMA / 20)
    clean = -gauss_derivative(t, t0)  # positive lobe first
    precursor = -0.2 * np.exp(-0.5) * np.exp(-(((t - (t0 - 8 * SIGMA)) / (0.7 * SIGMA)) ** 2))
    ripples = 1e-7 * np.sin(37.0 * t) * (t < t0 - 11 * SIGMA)
    f_clean = front_features(t, clean)
    f = front_features(t, clean + precursor + ripples)
    assert f.polarity == 1
    for key in ("t_lead10", "t_peak", "amplitude", "t_zero", "width"):
        assert getattr(f, key) == pytest.approx(getattr(f_clean, key), rel=1e-9, abs=1e-9)
    # The rule is a stated parameter: a low enough fraction takes the precursor.
    low = front_features(t, clean + precursor + ripples, peak_fraction=0.1)
    assert low.polarity == -1 and low.t_peak == pytest.approx(t0 - 8 * SIGMA, abs=1e-3)


@pytest.mark.parametrize("n", [10, 30, 100, 1000])
def test_chain_B_picks_main_lobe_after_precursor(n):
    t0 = theory.chain_travel_time(n)
    w = n ** (1 / 3)
    t = np.linspace(0.0, t0 + 8 * w + 5, 6001)
    dt = t[1] - t[0]
    fa = front_features(t, theory.chain_wall_force(t, n, ic="A"))
    sig_b = theory.chain_wall_force(t, n, ic="B")
    fb = front_features(t, sig_b)
    # B = (l/c) dF_A/dt: a positive precursor (the rise of A) then the negative main lobe,
    # which crosses zero exactly where A peaks.
    assert fb.polarity == -1
    assert fa.polarity == 1
    before = t < fb.t_lead10
    assert sig_b[before].max() > 0.1 * fb.amplitude  # there is a real precursor ...
    assert sig_b[before].max() < 0.3 * fb.amplitude  # ... and it is smaller than the main lobe
    # B's main lobe starts where A peaks and ends where A has its trough.
    k = np.flatnonzero((t < fb.t_lead10) & (sig_b > 0))[-1]  # last precursor sample
    start_b = t[k] + sig_b[k] * dt / (sig_b[k] - sig_b[k + 1])
    sig_a = theory.chain_wall_force(t, n, ic="A")
    j = np.flatnonzero((t > fa.t_zero)[:-1] & (np.diff(sig_a) > 0))[0]  # first local minimum
    trough_a = t[j] + 0.5 * dt * (sig_a[j - 1] - sig_a[j + 1]) / (sig_a[j - 1] - 2 * sig_a[j] + sig_a[j + 1])
    tol = 0.02 * dt + 1e-3 * fa.width  # O(dt^2) interpolation errors, dt = w/700 ... w/20
    assert start_b == pytest.approx(fa.t_peak, abs=tol)
    assert fb.t_zero == pytest.approx(trough_a, abs=tol)
    # the A peak sits at the arrival time t0 = (N+1) l/c up to O(N^{1/3} N^{-2/3}) shifts
    assert abs(fa.t_peak - t0) < 0.25 * w
    assert fa.t_lead10 < t0 < fa.t_zero


def test_chain_A_front_scalings_match_airy():
    # Large-N limits from theory.py: A peak amplitude -> -8 Ai'(0) (N+1)^{-2/3};
    # B main lobe -> 16 * 0.69638 / (N+1) (checked in test_theory); width ~ N^{1/3}.
    widths = []
    for n in (300, 3000):
        t0 = theory.chain_travel_time(n)
        w = n ** (1 / 3)
        t = np.linspace(t0 - 6 * w, t0 + 6 * w, 3001)
        t[0] = 0.0  # quiet start: F_A is exponentially small there
        fa = front_features(t, theory.chain_wall_force(t, n, ic="A"))
        widths.append(fa.width)
        assert fa.amplitude * (n + 1) ** (2 / 3) == pytest.approx(2.0705552, rel=8 * n ** (-2 / 3))
    assert np.log(widths[1] / widths[0]) / np.log(10) == pytest.approx(1 / 3, abs=0.03)


def test_incomplete_first_pulse_is_refused():
    t = np.arange(0.0, 25.0, SIGMA / 20)
    f = gauss_derivative(t)
    rising = t < T0 - 1.5 * SIGMA
    with pytest.raises(InputError, match="never reaches its peak"):
        front_features(t[rising], f[rising])
    no_zero = t < T0 - 0.5 * SIGMA
    with pytest.raises(InputError, match="never crosses zero"):
        front_features(t[no_zero], f[no_zero])
    late = t > T0 - 2.0 * SIGMA  # starts above 10% of the peak
    with pytest.raises(InputError, match="leading edge is not in the record"):
        front_features(t[late], f[late])
    with pytest.raises(InputError, match="identically zero"):
        front_features(t, np.zeros_like(t))
    with pytest.raises(InputError, match="strictly increasing"):
        front_features(t[::-1], f)
    with pytest.raises(InputError, match="NaN"):
        front_features(t, np.where(t > 5, np.nan, f))


def write_signal(path, t, f, height=12.5):
    files.write_signal(path, Signal(time=t, force=f, attrs=dict(ic="A", method="test", height=height)))


def test_cli_front_json_and_table(tmp_path):
    t = np.arange(0.0, 25.0, SIGMA / 20)
    write_signal(tmp_path / "s.h5", t, gauss_derivative(t))
    runner = CliRunner()
    res = runner.invoke(main, ["analyze", "front", str(tmp_path / "s.h5"), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    lib = front_features(t, gauss_derivative(t)).as_dict()
    for key in ("t_lead10", "t_peak", "amplitude", "t_zero", "width"):
        assert out[key] == pytest.approx(lib[key], rel=1e-12)
    assert out["height"] == 12.5
    res = runner.invoke(main, ["analyze", "front", str(tmp_path / "s.h5")])
    assert res.exit_code == 0 and "t_lead10" in res.output and "width" in res.output
    res = runner.invoke(main, ["analyze", "front", "--help"])
    assert "width = t_zero - t_lead10" in res.output


def test_cli_front_bad_input(tmp_path):
    t = np.arange(0.0, 25.0, SIGMA / 20)
    f = gauss_derivative(t)
    keep = t < T0 - 1.5 * SIGMA
    write_signal(tmp_path / "cut.h5", t[keep], f[keep])
    runner = CliRunner()
    res = runner.invoke(main, ["analyze", "front", str(tmp_path / "cut.h5")])
    assert res.exit_code != 0
    assert "never reaches its peak" in res.output and "Traceback" not in res.output
    assert len(res.output.strip().splitlines()) == 1
    (tmp_path / "foreign.h5").write_text("not a granwave file")
    res = runner.invoke(main, ["analyze", "front", str(tmp_path / "foreign.h5")])
    assert res.exit_code != 0 and "not an HDF5 file" in res.output
    res = runner.invoke(main, ["analyze", "front", str(tmp_path / "cut.h5"), "--peak-fraction", "nan"])
    assert res.exit_code != 0
