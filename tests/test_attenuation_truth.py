"""Exact pieces of the attenuation analysis: the debiased coherent power, the weighted slopes,
the cutoff and thin-height flags, λ* on noise-free signals. The analysis against known answers
with the production defaults (window 5 widths, bootstrap 200, a band that starts where c has
already fallen) is the truth suite's (benchmarks/truth_cases/attenuation.py; its fast version:
tests/test_truth_suite.py).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from granwave.analysis.attenuation import attenuation

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.truth_cases._ensembles import Design, ensemble  # noqa: E402

#: a small version of the truth suite's scene: three heights of 3 packings and a lone one
SMALL = Design(heights=(16.0, 32.0, 64.0, 128.0), packings=(3, 3, 3, 1))


def test_debiased_coherent_power_and_the_variances_of_ln_S():
    # 20000 ensembles of n = 5 packings: a coherent S = 1 plus complex noise of variance
    # σ² = 0.25 per packing: E|S̄|² = 1 + σ²/n = 1.05 (|S̄| biased up by ≈ σ²/(2n) = 2.5 %),
    # |S̄|² − noise² is unbiased for 1
    from granwave.analysis.attenuation import coherent_spectra

    rng = np.random.default_rng(7)
    n, trials, var = 5, 20000, 0.25
    P = 1.0 + np.sqrt(var / 2) * (rng.standard_normal((n, trials)) + 1j * rng.standard_normal((n, trials)))
    d = coherent_spectra(P)
    raw = np.abs(d["S"]) ** 2
    deb = raw - d["noise"] ** 2
    assert raw.mean() == pytest.approx(1 + var / n, abs=4 * raw.std() / np.sqrt(trials))
    assert deb.mean() == pytest.approx(1.0, abs=4 * deb.std() / np.sqrt(trials))
    assert raw.mean() - 1 > 10 * deb.std() / np.sqrt(trials)  # the bias is resolved
    np.testing.assert_allclose(d["lnA"], np.where(deb > 0, 0.5 * np.log(np.abs(deb)), np.nan))
    # var of ln|S̄| and of the phase: first order in the noise, σ²/(2n) = 0.025 each
    assert np.mean(d["var_lnA"]) == pytest.approx(np.var(np.log(np.abs(d["S"]))), rel=0.1)
    assert np.mean(d["var_phi"]) == pytest.approx(np.var(np.angle(d["S"])), rel=0.1)


def test_weighted_slopes_match_numpy_polyfit():
    from granwave.analysis.attenuation import _slopes

    rng = np.random.default_rng(2)
    L = np.array([10.0, 20.0, 40.0, 80.0, 160.0])
    sig = np.array([0.01, 0.02, 0.05, 0.1, 0.3])
    Y = (1.0 - 0.01 * L + sig * rng.standard_normal(L.size))[:, None]
    slope, err, resid, n, chi2 = _slopes(L, Y, None, (sig**2)[:, None])
    coef, cov = np.polyfit(L, Y[:, 0], 1, w=1 / sig, cov="unscaled")
    assert slope[0] == pytest.approx(coef[0], rel=1e-12)
    # the absolute error, widened by sqrt(χ²/(n − 2)) only where that exceeds 1
    assert chi2[0] == pytest.approx(np.sum(((Y[:, 0] - np.polyval(coef, L)) / sig) ** 2), rel=1e-10)
    assert err[0] == pytest.approx(np.sqrt(cov[0, 0]) * max(1.0, np.sqrt(chi2[0] / 3)), rel=1e-10)


def test_lateral_cutoff_is_marked_and_thin_heights_are_flagged():
    from granwave.analysis.attenuation import lateral_cutoff
    from granwave.errors import InputError

    assert lateral_cutoff(0.1, 25.0) == pytest.approx(2 * np.pi * 0.1 / 25.0)
    with pytest.raises(InputError, match="c_t > 0"):
        lateral_cutoff(0.0, 25.0)
    sigs, c_l = ensemble(SMALL, 4)
    r = attenuation(sigs, bootstrap=30, omega_cutoff=0.02, c_l=c_l)
    assert r["omega_cutoff"] == 0.02 and r["band_above_cutoff"]
    np.testing.assert_array_equal(r["above_cutoff"], r["omega"] > 0.02)
    assert list(r["error_model"]) == ["sample", "sample", "sample", "pooled"]
    assert not r["packings"]["quotable"] and r["packings"]["thin_counts"] == [3, 3, 3, 1]
    assert "fewer than 10 packings" in r["packings"]["warning"]
    # the lone height is resampled about its value with the pooled variance: errors are finite
    m = r["reliable"]
    assert m.sum() > 10 and r["bootstrap"] == 30
    assert np.all(np.isfinite(r["alpha_boot_err"][m]) & (r["alpha_boot_err"][m] > 0))
    # λ*'s reference: the c_ℓ of the packings of the heights used up to ω*, named
    lam = r["continuum_length"]
    assert lam["reference"] == "c_l" and set(lam["contributing_heights"]) <= {16.0, 32.0, 64.0, 128.0}
    used = [h for h, ok in zip(r["heights"], np.asarray(r["used"])[:, m].any(axis=1)) if ok]
    assert set(lam["contributing_heights"]) <= set(used)
    with pytest.raises(InputError, match="positive frequency"):
        attenuation(sigs, omega_cutoff=-1.0)
    with pytest.raises(InputError, match="one c_l per signal"):
        attenuation(sigs, c_l=c_l[:-1])


def test_continuum_wavelength_exact_on_noise_free_signals():
    from test_attenuation import c_true, synthetic

    # noise-free: |c/c0 − 1| = 0.02 at ω* = sqrt(2.04) (c0 = 1), λ* = 2π c(ω*)/ω* = 4.310, the
    # crossing interpolated between frequencies; with 1/Q ≤ 0.002 instead the loss binds first:
    # 0.004 ω/(1 + 0.03 ω²) = 0.002 at ω = 0.5008
    exact = [synthetic(L) for L in (10, 20, 40, 80)]
    r = attenuation(exact, window_widths=30, bootstrap=0, c_l=1.0)
    cl = r["continuum_length"]
    w = np.sqrt(2.04)
    assert cl["status"] == "within" and cl["binding"] == "dispersion" and cl["reference"] == "c_l (given)"
    assert cl["lambda_star"] == pytest.approx(2 * np.pi * c_true(w) / w, rel=1e-3)
    r2 = attenuation(exact, window_widths=30, bootstrap=0, c_l=1.0, q_tol=0.002)["continuum_length"]
    assert r2["binding"] == "loss"
    assert r2["lambda_star"] == pytest.approx(2 * np.pi * c_true(0.5008) / 0.5008, rel=2e-2)
    # the spectral centroid falls with L; ω* is reached between two heights (or beyond)
    assert np.all(np.diff(cl["centroid_frequency"]) < 0)
    # without a c_ℓ the reference is c0, and c0's error includes its model spread
    r3 = attenuation(exact, window_widths=30, bootstrap=0)
    assert r3["continuum_length"]["reference"] == "c0" and r3["c0_err"] >= r3["c0_stat_err"]
