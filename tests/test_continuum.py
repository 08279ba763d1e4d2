"""The front against distance: local speeds, exponents and the approach fit (exact cases)."""

import numpy as np
import pytest

from granwave.analysis.continuum import approach_fit, continuum_from_features
from granwave.errors import InputError


def test_approach_fit_recovers_known_beta_and_L_star():
    L = np.geomspace(8, 1000, 8)
    r = approach_fit(L, 1 + 2.0 * L**-0.5, np.full(L.size, 1e-3))
    assert r["beta"] == pytest.approx(0.5, abs=1e-9)
    assert r["a"] == pytest.approx(2.0, abs=1e-9)
    assert r["L_star"] == pytest.approx(1600.0, rel=1e-8)  # (2 / 0.05)^2
    assert r["status"] == "beyond" and r["L_star_lower_bound"] == pytest.approx(1000.0)
    assert r["L_star_ci"][0] < 1600 < r["L_star_ci"][1]
    assert r["free_limit"]["r_inf"] == pytest.approx(1.0, abs=1e-8)


def test_approach_fit_noisy_ci_covers_beta_and_reached_status():
    rng = np.random.default_rng(0)
    L = np.geomspace(8, 4000, 9)
    e = np.full(L.size, 5e-3)
    r = approach_fit(L, 1 + 0.5 * L**-0.7 + e * rng.standard_normal(L.size), e)
    assert r["beta_ci"][0] < 0.7 < r["beta_ci"][1]
    assert r["status"] == "reached"  # 0.5 * 4000^-0.7 = 0.0015 < 0.05
    assert r["L_star"] == pytest.approx((0.5 / 0.05) ** (1 / 0.7), rel=0.3)
    with pytest.raises(InputError, match="at least 3"):
        approach_fit([8, 16], [1.2, 1.1])


def test_local_speeds_ratio_and_exponents_exact():
    # arrivals t = L / c(L_mid) on a line of speed 2 after an offset, c_l = 1.6, A ~ L^-0.5, W ~ L^0.25
    heights = np.repeat([8.0, 16.0, 32.0, 64.0], 3)
    feats = [{"t_lead10": 1.0 + h / 2.0, "t_peak": 2.0 + h / 1.8, "t_zero": 3.0 + h / 1.5,
              "amplitude": h**-0.5, "width": h**0.25} for h in heights]
    r = continuum_from_features(heights, feats, np.full(heights.size, 1.6))
    loc = r["local"]
    np.testing.assert_allclose(loc["height"], [8 * 2**0.5, 16 * 2**0.5, 32 * 2**0.5])
    np.testing.assert_allclose(loc["c_tof"], 2.0)
    np.testing.assert_allclose(loc["c_peak"], 1.8)
    np.testing.assert_allclose(loc["c_zero"], 1.5)
    np.testing.assert_allclose(loc["ratio"], 1.25)
    np.testing.assert_allclose(loc["gamma_eff"], 0.5)
    np.testing.assert_allclose(loc["chi_eff"], 0.25)
    np.testing.assert_allclose(r["per_height"]["c_tof_apparent"], [8 / 5, 16 / 9, 32 / 17, 64 / 33])
    assert r["global"]["c_tof_all"] == pytest.approx(2.0)


def test_a_height_with_one_packing_borrows_the_pooled_relative_scatter():
    # two heights with 3 packings each whose arrival times scatter by exactly +-2 % and +-4 %
    # (sample std = 2 % and 4 % of the mean), and a tallest height with a single packing
    heights = np.array([8.0] * 3 + [16.0] * 3 + [32.0])
    t_mean = {8.0: 5.0, 16.0: 9.0, 32.0: 17.0}
    rel = {8.0: np.array([-0.02, 0.0, 0.02]), 16.0: np.array([-0.04, 0.0, 0.04]), 32.0: np.array([0.0])}
    feats = []
    for h in (8.0, 16.0, 32.0):
        for r in rel[h]:
            t = t_mean[h] * (1 + r)
            feats.append({"t_lead10": t, "t_peak": t + 1, "t_zero": t + 2, "amplitude": 1.0, "width": 1.0})
    out = continuum_from_features(heights, feats, np.full(heights.size, 1.6))
    per = out["per_height"]
    assert list(per["error_model"]) == ["sample", "sample", "pooled"]
    # pooled coefficient of variation, weights n - 1 = 2 and 2: sqrt((0.02^2 + 0.04^2) / 2)
    cv = np.sqrt((0.02**2 + 0.04**2) / 2)
    assert per["t_lead10_std"][2] == pytest.approx(17.0 * cv, rel=1e-12)
    assert per["t_lead10_sem"][2] == pytest.approx(17.0 * cv, rel=1e-12)  # n = 1
    assert per["t_lead10_sem"][0] == pytest.approx(5.0 * 0.02 / np.sqrt(3), rel=1e-12)
    # the local speed that uses the lone height has a finite error, larger than from its partner alone
    err = out["local"]["c_tof_err"]
    assert np.all(np.isfinite(err)) and err[1] > 0
    c = 16.0 / 8.0
    assert err[1] > c * per["t_lead10_sem"][1] / 8.0


# ------------------------------------------------------------ CLI, figure and report section
def _signal_files(tmp_path):
    """Signals of a front of speed 1.25 c_l (c_l = 0.8) at four heights, two packings each."""
    import json

    from granwave.io.files import write_signal
    from test_attenuation import synthetic

    paths, moduli = [], []
    for L in (10, 20, 40, 80):
        for s in range(2):
            sig = synthetic(L)
            sig.force = sig.force * (1 + 0.01 * s)
            p = tmp_path / f"h{L}_s{s}.h5"
            write_signal(p, sig)
            m = tmp_path / f"h{L}_s{s}.json"
            m.write_text(json.dumps({"c_l": 0.8, "c_t": 0.5, "c_l_slab": 0.8, "c_t_slab": 0.5}))
            paths.append(str(p))
            moduli.append(str(m))
    return paths, moduli


def test_cli_figure_and_report_section(tmp_path, monkeypatch):
    import json

    from click.testing import CliRunner
    from figure_rules import capture, check

    from granwave.cli import main
    from granwave.report.continuum import continuum_inputs, continuum_section
    from granwave.report.symbols import undefined_symbols

    paths, moduli = _signal_files(tmp_path)
    runner = CliRunner()
    args = ["analyze", "continuum", *paths]
    for m in moduli:
        args += ["--moduli", m]
    front = runner.invoke(main, args + ["--json"])
    assert front.exit_code == 0, front.output
    res = json.loads(front.stdout)
    # the synthetic front moves at the speed of its lowest frequencies, c = 1 = 1.25 c_l
    assert res["c_l"]["mean"] == pytest.approx(0.8)
    assert res["local"]["ratio"][-1] == pytest.approx(1.25, rel=0.02)
    att = runner.invoke(main, ["analyze", "attenuation", *paths, "--bootstrap", "5", "--json"])
    assert att.exit_code == 0, att.output
    bad = runner.invoke(main, ["analyze", "continuum", *paths, "--moduli", moduli[0]])
    assert bad.exit_code == 2 and "one --moduli file per signal" in bad.output
    (tmp_path / "sc").mkdir()
    (tmp_path / "sc" / "front.json").write_text(front.stdout)
    (tmp_path / "sc" / "attenuation.json").write_text(att.stdout)
    figs = capture(monkeypatch)
    fig = runner.invoke(main, ["plot", "continuum", str(tmp_path / "sc" / "front.json"),
                               "--attenuation", str(tmp_path / "sc" / "attenuation.json"),
                               "--scene", "sc", "-o", str(tmp_path / "continuum_sc.png")])
    assert fig.exit_code == 0, fig.output
    assert (tmp_path / "continuum_sc.png").stat().st_size > 10000
    check(figs[0], scene="sc", pressure=False)  # the synthetic signals carry no pressure
    items = [(tmp_path / "sc" / n, json.loads((tmp_path / "sc" / n).read_text()), None)
             for n in ("front.json", "attenuation.json")]
    md = "\n".join(continuum_section(continuum_inputs(items)))
    assert "### sc" in md and "c0/c_ℓ" in md and "L*" in md
    assert not undefined_symbols(md)


def test_a_failed_moduli_solve_costs_the_packing_its_c_l_not_the_batch(tmp_path, monkeypatch):
    import json

    import granwave.linear.moduli as M
    from granwave.workflow_support import run_sample

    def floppy(*args, **kw):
        raise InputError("the linear system D u = f could not be solved accurately")

    monkeypatch.setattr(M, "moduli", floppy)

    def sample(folder, **extra):
        out = {k: str(tmp_path / folder / f"{k}.h5") for k in ("packing", "linear", "signal")}
        out.update({k: str(tmp_path / folder / f"{k}.json") for k in ("moduli", "front", "summary")})
        return {"kind": "lattices", "scene": "lat", "make": dict(rows=6, width=4, pressure=1e-4),
                "signal": {"method": "time", "ic": "A", "t_max": 40.0, "samples": 400, "safety": 0.1},
                "out": out, "local_moduli": False, **extra}

    with pytest.raises(InputError, match="could not be solved"):
        run_sample(sample("a"), log=lambda line: None)
    lines = []
    run_sample(sample("b", moduli_may_fail=True), log=lines.append)
    m = json.loads((tmp_path / "b" / "moduli.json").read_text())
    assert m["c_l"] is None and "could not be solved" in m["error"]
    assert any("no moduli" in line for line in lines)


def test_bulk_speed_from_wall_layers_in_series_exact():
    from granwave.analysis.continuum import bulk_speed

    # 1 / c^2 = 1 / 0.2^2 + 30 / L: the wall compliance in series with a bulk of speed 0.2
    L = np.repeat([8.0, 16.0, 32.0, 64.0, 100.0], 2)
    c = (1 / 0.2**2 + 30.0 / L) ** -0.5
    r = bulk_speed(L, c)
    assert r["c_l_inf"] == pytest.approx(0.2, rel=1e-12) and r["b"] == pytest.approx(30.0, rel=1e-9)
    assert r["c_l_inf_err"] < 1e-12
    assert np.isnan(bulk_speed([8.0, 8.0, 8.0], [0.2, 0.2, 0.2])["c_l_inf"])  # one height
    heights = np.repeat([8.0, 16.0, 32.0, 64.0], 3)
    cl = (1 / 0.2**2 + 30.0 / heights) ** -0.5
    feats = [{"t_lead10": 1.0 + h / 0.25, "t_peak": 2.0 + h / 0.22, "t_zero": 3.0 + h / 0.2,
              "amplitude": h**-0.5, "width": h**0.25} for h in heights]
    out = continuum_from_features(heights, feats, cl)
    np.testing.assert_allclose(out["local"]["ratio_bulk"], 0.25 / 0.2, rtol=1e-9)
    assert out["c_l_bulk"]["c_l_inf"] == pytest.approx(0.2, rel=1e-12)


def test_low_frequency_of_a_result_without_c0_is_nan_not_an_error():
    """A continuum result whose band held too few heights stores c0 and its errors as null (the
    tiny workflow's report failed on it): the low-frequency summary is NaN, not a TypeError."""
    import math

    from granwave.analysis.continuum_length import low_frequency_of_result

    att = {"omega": [0.01, 0.02, 0.03], "reliable": [False, True, True], "c": [0.2, 0.19, 0.18],
           "c_err": [0.01, 0.01, 0.01], "c0": None, "c0_err": None, "c0_stat_err": None}
    out = low_frequency_of_result(att, c_ref=0.19, c_ref_err=0.01)
    assert math.isnan(out["c0"]) and math.isnan(out["c0_stat_err"])
    assert out["c0_lower_bound"] < 0.19
