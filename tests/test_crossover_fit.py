"""The crossover pressure p* of ``pressure-sweep --crossover`` (granwave.analysis.crossover;
docs/method.md §10): it recovers a known p* from synthetic c(p) series within its error, its
95 % interval covers the truth in 95 % of series, a crossover outside the sweep is not located,
and benchmarks/truth_cases/laws.py (the truth suite's case of it, key "sweep.p_star") runs the
same function and defaults the command uses.
"""

import importlib
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from granwave.analysis.crossover import crossover_fit, synthetic_series
from granwave.analysis.sweep import pressure_sweep

ROOT = Path(__file__).resolve().parents[1]
PRESSURES = np.logspace(-8, -3, 11)


def test_noise_free_series_gives_p_star_exactly():
    for p_star in (3e-7, 1.2e-5, 2e-4):
        p, c, _ = synthetic_series(p_star, pressures=PRESSURES, noise=0.0, seed=0)
        fit = crossover_fit(p, c)
        assert fit["p_star"] == pytest.approx(p_star, rel=1e-8) and fit["note"] == ""
        assert fit["c_star"] == pytest.approx(0.05, rel=1e-8) and fit["chi2"] < 1e-20


def test_recovers_a_known_p_star_within_its_error_and_covers_it():
    """1 % errors, p* = 1.2e-5, 300 seeds (5 s): the estimate of log10 p* is unbiased within 3 of its
    standard errors, its scatter is the quoted log10_p_star_err (ratio 1 +- 20 %), and the 95 %
    interval covers the truth in 95 % +- 3.5 % of the series (3 binomial standard errors at 300)."""
    p_star, n = 1.2e-5, 300
    est, err, covered = [], [], 0
    for seed in range(n):
        p, c, e = synthetic_series(p_star, pressures=PRESSURES, noise=0.01, seed=seed)
        fit = crossover_fit(p, c, e)
        est.append(fit["log10_p_star"])
        err.append(fit["log10_p_star_err"])
        covered += fit["p_star_lo95"] <= p_star <= fit["p_star_hi95"]
    est = np.array(est)
    bias = est.mean() - math.log10(p_star)
    assert abs(bias) < 3 * est.std() / math.sqrt(n)
    assert np.median(err) / est.std() == pytest.approx(1.0, rel=0.2)
    assert covered / n == pytest.approx(0.95, abs=0.035)


def test_errors_from_the_residuals_and_bad_input():
    p, c, _ = synthetic_series(1.2e-5, pressures=PRESSURES, noise=0.01, seed=4)
    fit = crossover_fit(p, c)
    assert fit["errors"] == "residuals" and fit["p_star_lo95"] < 1.2e-5 * 3 and fit["p_star_hi95"] > 1.2e-5 / 3
    # a crossover beyond the pressures measured is not located (one power law throughout)
    p, c, _ = synthetic_series(1.0, pressures=PRESSURES, noise=0.0, seed=0)
    fit = crossover_fit(p, c)
    assert math.isnan(fit["p_star"]) and "edge" in fit["note"]
    from granwave.errors import InputError

    with pytest.raises(InputError, match="at least 3 distinct pressures"):
        crossover_fit([1e-6, 1e-5], [0.1, 0.2])
    with pytest.raises(InputError, match="positive, finite"):
        crossover_fit([1e-6, 1e-5, 1e-4], [0.1, -0.2, 0.3])


def test_pressure_sweep_and_its_tables_carry_the_fit(tmp_path):
    """pressure_sweep(crossover=...) over height series gives the same fit as crossover_fit on its
    per-pressure means and errors (to the sweep's rounding of pressures to 12 digits), its scalars
    for the file and the fitted curve per pressure."""
    from granwave.analysis.sweep import write_tables

    p, c, e = synthetic_series(1.2e-5, pressures=PRESSURES, noise=0.01, seed=7)
    series = [{"pressure": float(a), "c_tof": float(b), "c_tof_err": float(s), "per_height": []}
              for a, b, s in zip(p, c, e)]
    res = pressure_sweep([], height_series=series, crossover=(0.25, 1 / 6))
    direct = crossover_fit(p, c, e)
    # the same to the sweep's rounding of pressures to 12 digits
    assert res["crossover_tof"]["p_star"] == pytest.approx(direct["p_star"], rel=1e-9)
    assert res["p_star_tof"] == res["crossover_tof"]["p_star"]
    assert res["p_star_tof_lo95"] == pytest.approx(direct["p_star_lo95"], rel=1e-9)
    assert any("crossover of c_l" in n for n in res["fit_notes"])  # no moduli in height series
    curve = [r["c_tof_crossover"] for r in res["per_pressure"]]
    assert np.all(np.isfinite(curve)) and np.max(np.abs(np.log(np.array(curve) / c))) < 0.05
    written = write_tables(res, tmp_path, prefix="s")
    assert "p* of c_tof = " in (tmp_path / "s_speeds.md").read_text() and written


# ---------------------------------------------------------------- the truth case
def test_the_truth_case_runs_the_sweep_s_estimator():
    """benchmarks/truth_cases/laws.py: key sweep.p_star, the truth its series were made with, and
    run(seed) = pressure_sweep(crossover=SweepParams' defaults) on them: (estimate, lo95, hi95),
    covering the truth for most seeds (20 here; python benchmarks/truth.py takes 100 or more)."""
    if str(ROOT) not in sys.path:  # the repository's benchmarks package
        sys.path.insert(0, str(ROOT))
    laws = importlib.import_module("benchmarks.truth_cases.laws")
    assert {c.key for c in laws.CASES} == {"sweep.p_star"} and any(c.fast for c in laws.CASES)
    case = next(c for c in laws.CASES if c.fast)
    hits = 0
    for seed in range(20):
        est, lo, hi = case.run(seed)
        assert lo < est < hi
        p, c, e = synthetic_series(case.truth, pressures=laws.PRESSURES, noise=0.01, seed=seed)
        assert est == pytest.approx(crossover_fit(p, c, e)["p_star"], rel=1e-9)
        hits += lo <= case.truth <= hi
    assert hits >= 16
