"""Attenuation alpha(omega) and phase velocity c(omega) recovered from synthetic signals."""

import numpy as np
import pytest

from granwave.analysis.attenuation import attenuation, window
from granwave.errors import InputError
from granwave.model import Signal

DT, N = 0.05, 8000
T = np.arange(N) * DT
W = 2 * np.pi * np.fft.rfftfreq(N, DT)
W0, T0 = 2.0, 10.0


def alpha_true(w):
    return 0.002 * w**2  # per d


def c_true(w):
    return 1.0 / (1.0 + 0.01 * w**2)  # slower at high frequency


def synthetic(L, noise=0.0, rng=None):
    """A derivative-of-Gaussian source pulse propagated over L with the known alpha and c."""
    S = 1j * W * np.exp(-0.5 * (W / W0) ** 2) * np.exp(-alpha_true(W) * L - 1j * W * L / c_true(W)
                                                      - 1j * W * T0)
    f = np.fft.irfft(S / DT, N)
    if noise:
        # packing-to-packing scatter after the arrival (the signal is quiet before it)
        f = f + noise * np.abs(f).max() * rng.standard_normal(N) * (T > T0 + L)
    return Signal(time=T, force=f, attrs={"height": float(L), "pressure": 1e-4, "ic": "A",
                                         "method": "synthetic"})


def test_known_alpha_and_c_recovered_exactly_with_a_wide_window():
    sigs = [synthetic(L) for L in (10, 20, 40, 80)]
    r = attenuation(sigs, window_widths=30, bootstrap=0)
    m = r["reliable"]
    w = r["omega"][m]
    assert m.sum() > 50 and r["band"][0] < 0.1 and r["band"][1] > 3.5
    np.testing.assert_allclose(r["alpha"][m], alpha_true(w), rtol=0, atol=1e-8)
    np.testing.assert_allclose(r["c"][m], c_true(w), rtol=1e-8)
    np.testing.assert_allclose(r["Q"][m], w / (2 * alpha_true(w) * c_true(w)), rtol=1e-6)
    # c = 1 - 0.01 w^2 + 1e-4 w^4 ...: the quadratic fit's c0 is 1 within the quartic term
    assert abs(r["c0"] - 1.0) < 5e-4


def test_noise_gives_error_bars_that_cover_the_truth():
    rng = np.random.default_rng(3)
    sigs = [synthetic(L, 0.02, rng) for L in (10, 20, 40, 80) for _ in range(6)]
    r = attenuation(sigs, window_widths=30, bootstrap=100, seed=1)
    m = r["reliable"] & (r["omega"] > 0.5) & (r["omega"] < 3.0)
    w = r["omega"][m]
    assert np.all(r["alpha_boot_err"][m] > 0) and np.all(np.isfinite(r["c_err"][m]))
    # within 4 error bars at (almost) every frequency
    z_a = np.abs(r["alpha"][m] - alpha_true(w)) / r["alpha_err"][m]
    z_c = np.abs(r["c"][m] - c_true(w)) / r["c_err"][m]
    assert np.mean(z_a < 4) > 0.95 and np.mean(z_c < 4) > 0.95


def test_window_and_refusals():
    t = np.linspace(0, 10, 11)
    w = window(t, 8.0, 2.0)
    np.testing.assert_allclose(w, [1, 1, 1, 1, 1, 1, 1, 0.5, 0, 0, 0])
    with pytest.raises(InputError, match="two or more different heights"):
        attenuation([synthetic(10), synthetic(10)])
