"""Exact pieces of the continuum analysis of the front: the scatter model, the arrival times of a
sine pulse, the candidate table, the report's section. The chain from signals to L*, β, r∞
against known answers (front picks included) is the truth suite's
(benchmarks/truth_cases/continuum.py; fast version in tests/test_truth_suite.py).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from granwave.analysis.continuum import continuum, scatter_model

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

CL, A, BETA, K = 0.2, 1.5, 0.6, 0.3
HEIGHTS = (10.0, 20.0, 40.0, 80.0, 160.0, 320.0)


def arrivals(L):
    return 5.0 + L / CL - A * L ** (1 - BETA) / (CL * (1 - BETA))


def test_scatter_model_is_exact_on_a_power_law_and_leaves_too_few_heights_alone():
    L = np.array([10.0, 20.0, 40.0, 80.0, 640.0])
    std = 0.3 * L**0.5
    np.testing.assert_allclose(scatter_model(L, std, [10, 10, 10, 10, 1]), std, rtol=1e-12)
    np.testing.assert_array_equal(scatter_model(L[:3], std[:3], [10, 10, 1]), std[:3])


def test_report_section_says_the_packing_rule_the_bootstrap_interval_and_the_cutoff():
    import json
    import re

    from benchmarks.truth_cases._ensembles import Design, Fronts, ensemble, fronts
    from granwave.analysis.attenuation import attenuation
    from granwave.report.continuum import continuum_section

    sigs, c_l = fronts(Fronts(heights=(8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0),
                              packings=(10, 10, 10, 10, 10, 10, 1)), 1)
    front = continuum(sigs, c_l, bootstrap=50, candidates=False)
    asig, ac_l = ensemble(Design(heights=(16.0, 32.0, 64.0, 128.0), packings=(3, 3, 3, 3)), 3)
    att = attenuation(asig, bootstrap=20, omega_cutoff=0.015, c_l=ac_l)
    tojson = lambda d: json.loads(json.dumps(d, default=lambda x: x.tolist()))  # noqa: E731
    md = "\n".join(continuum_section({"sc": {"front": tojson(front), "attenuation": tojson(att)}}))
    assert "Bootstrap over the packings within each height through the whole chain" in md
    assert "**Not quotable: 1 of 7 heights have fewer than 10 packings" in md
    assert "**Not quotable: 4 of 4 heights have fewer than 10 packings" in md
    assert "First lateral shear cutoff 2π c_t/L1 = 0.015 " in md and "the waveguide's" in md
    assert "Q = ω/(2 α c_g)" in md and "| c_g(ω) |" in md and "(above the cutoff)" in md
    assert "Continuum length in frequency (|c/c_ref − 1| ≤ 0.02 and Q⁻¹ ≤ 0.05, c_ref c_ℓ of the " \
           "contributing heights' packings" in md
    assert "what the band itself says: c0 ≥" in md and "not a measurement: it moves by" in md
    # the extrapolation without a ± (its interval undercovers: docs/truth.md, attenuation.c0)
    assert re.search(r"low-frequency extrapolation c0 = [0-9.]+ √", md), md


def test_arrival_times_of_a_sine_pulse_are_exact():
    from granwave.analysis.continuum import arrival_times

    t = np.arange(0, 60, 0.001)
    ta, T = 10.0, 8.0
    f = np.where((t > ta) & (t < ta + 2 * T), np.sin(np.pi * (t - ta) / T), 0.0)
    a = arrival_times(t, f)
    for lev in (0.02, 0.05, 0.1, 0.2, 0.5):
        assert a[f"edge_{lev:g}"] == pytest.approx(ta + T / np.pi * np.arcsin(lev), abs=2e-3)
    assert a["peak"] == pytest.approx(ta + T / 2, abs=1e-6)
    assert a["energy"] == pytest.approx(ta + T / 2, abs=2e-3)  # the lobe is symmetric


def test_candidate_lengths_table_moves_with_rule_tolerance_and_reference():
    from granwave.analysis.continuum import candidate_lengths

    H = np.repeat([10.0, 20.0, 40.0, 80.0, 160.0], 3)
    times = {"edge_0.1": arrivals(H), "peak": 7.0 + H / (1.01 * CL)}
    jitter = np.tile([-0.01, 0.0, 0.01], 5)
    times = {k: v + jitter for k, v in times.items()}
    r = candidate_lengths(H, times, np.full(H.size, CL), draws=200)
    np.testing.assert_allclose(r["speeds"]["peak"]["ratio"], 1.01, rtol=1e-9)
    assert len(r["table"]) == 2 * 3 * 3
    row = {(x["rule"], x["tolerance"], x["c_l_scale"]): x for x in r["table"]}
    # the edge's L* grows as the tolerance tightens and as the reference c_l is lowered
    e = [row[("edge_0.1", tol, 1.0)]["L_star"] for tol in (0.10, 0.05, 0.03)]
    assert e[0] < e[1] < e[2]
    assert row[("edge_0.1", 0.05, 0.99)]["L_star"] > row[("edge_0.1", 0.05, 1.01)]["L_star"]
