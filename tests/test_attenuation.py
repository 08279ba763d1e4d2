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
    # Q with the group velocity c_g = dω/dk = 1/(1 + 0.03 ω²) (k = ω (1 + 0.01 ω²))
    c_g = 1.0 / (1.0 + 0.03 * w**2)
    np.testing.assert_allclose(r["c_group"][m], c_g, rtol=1e-6)
    np.testing.assert_allclose(r["Q"][m], w / (2 * alpha_true(w) * c_g), rtol=1e-6)
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


# --- which heights and frequencies are reliable (rule 8) ---

from scipy import stats  # noqa: E402

from granwave.analysis.attenuation import fit_p_value, noise_floor, reliable_band, usable  # noqa: E402

N2 = 16000
T2 = np.arange(N2) * DT
W2 = 2 * np.pi * np.fft.rfftfreq(N2, DT)


def broad(L, record=None):
    """A broad pulse (W0 = 0.5, T0 = 20) with the known alpha and c, its record cut at ``record``."""
    S = 1j * W2 * np.exp(-0.5 * (W2 / 0.5) ** 2) * np.exp(-alpha_true(W2) * L - 1j * W2 * L / c_true(W2)
                                                           - 1j * W2 * 20.0)
    f = np.fft.irfft(S / DT, N2)
    n = N2 if record is None else int(record / DT)
    return Signal(time=T2[:n], force=f[:n], attrs={"height": float(L), "pressure": 1e-4, "ic": "A",
                                                   "method": "synthetic"})


def test_short_records_are_left_out_below_one_period():
    # the three short columns' records end 8 time units after the source's arrival time + L
    sigs = [broad(L, 20.0 + L + 8.0 if L < 50 else None) for L in (10, 20, 40, 80, 160)]
    r = attenuation(sigs, window_widths=30, bootstrap=0)
    D = r["duration"]
    assert D[:3].max() < 15 and D[3:].min() > 200
    # below 2 pi / D (one period in the window) only the two long columns are usable: < 3 heights
    step = np.diff(r["omega"][:2])[0]
    assert 2 * np.pi / D[2] <= r["band"][0] < 2 * np.pi / D[2] + 2 * step
    m = r["reliable"]
    w = r["omega"][m]
    np.testing.assert_array_equal(r["used"][:3, m], r["omega"][None, m] * D[:3, None] >= 2 * np.pi)
    np.testing.assert_allclose(r["c"][m], c_true(w), rtol=2e-3)
    np.testing.assert_allclose(r["alpha"][m], alpha_true(w), rtol=0, atol=1e-3)
    assert abs(r["c0"] - 1.0) < 2e-3
    # where the third short column enters: with half a period in its window (the former default)
    # α there is off by more than its own size (-210 %), with a full period by less than half (-36 %)
    half = attenuation(sigs, window_widths=30, bootstrap=0, min_periods=0.5)
    assert np.pi / D[2] <= half["band"][0] < np.pi / D[2] + 2 * step
    i_half, i_one = (np.flatnonzero(x["reliable"])[0] for x in (half, r))
    assert abs(half["alpha"][i_half] / alpha_true(half["omega"][i_half]) - 1) > 1.0
    assert abs(r["alpha"][i_one] / alpha_true(r["omega"][i_one]) - 1) < 0.5
    # every height at every frequency (the old rule): the truncated records bias c by > 10 %
    old = attenuation(sigs, window_widths=30, bootstrap=0, min_periods=0.0, min_snr=0.0)
    mo = old["reliable"]
    assert old["band"][0] < 0.1
    assert np.max(np.abs(old["c"][mo] / c_true(old["omega"][mo]) - 1)) > 0.1 and abs(old["c0"] - 1) > 0.1


def test_noise_floor_usable_and_fit_p_exact():
    S = np.array([[1 + 1j, 2.0], [3 + 1j, 2.0], [2 + 4j, 5.0]])
    n = noise_floor(S)  # sqrt(sum |S_i - mean|^2 / (n (n - 1)))
    m = S.mean(axis=0)
    np.testing.assert_allclose(n, np.sqrt((np.abs(S - m) ** 2).sum(axis=0) / 6), rtol=1e-14)
    np.testing.assert_allclose(noise_floor(S[:2]), np.abs(S[0] - S[1]) / 2, rtol=1e-14)
    assert np.all(np.isnan(noise_floor(S[:1])))
    omega = np.array([0.0, 0.1, 0.2, 0.3])
    amp = np.array([[1.0, 1.0, 1.0, 1.0], [1.0, 0.5, 3.0, 3.0]])
    noise = np.array([[0.1] * 4, [1.0, 1.0, 1.0, np.nan]])
    u = usable(omega, amp, noise, [40.0, 20.0], min_periods=0.5, min_snr=2.0)
    # height 0: omega * 40 >= pi from 0.1; height 1: omega * 20 >= pi from 0.2, |S| >= 2 noise
    np.testing.assert_array_equal(u, [[False, True, True, True], [False, False, True, True]])
    resid = np.array([[0.1, 0.0], [-0.2, 0.0], [0.1, 0.0]])
    Sa = np.ones((3, 2))
    nz = np.full((3, 2), 0.1)
    p = fit_p_value(resid, Sa, nz, np.ones((3, 2), bool))
    assert p[0] == pytest.approx(stats.chi2.sf(1 + 4 + 1, 1), rel=1e-12) and p[1] == pytest.approx(1.0)
    assert np.isnan(fit_p_value(resid, Sa, nz, np.array([[1, 1], [1, 1], [0, 0]], bool))).all()
    # the band: the χ² test, the number of heights and the contiguity around the reference
    Sb = np.ones((3, 6))
    ok = reliable_band(np.arange(6.0), Sb, 0.05, 2, n_used=np.array([3, 3, 3, 3, 2, 3]),
                       fit_p=np.array([0.5, 0.001, 0.5, 0.5, 0.5, 0.5]))
    np.testing.assert_array_equal(ok, [False, False, True, True, False, False])
