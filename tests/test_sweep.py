"""Pressure sweep (docs/method.md §10): summaries, per-pressure statistics, exponents, tables, CLI."""

import csv
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.io import files
from granwave import theory
from granwave.analysis.sweep import (flatten, load_summaries, merge_summary, pressure_sweep,
                                     read_sweep, update_summary_file, write_summary)
from granwave.cli.sweep import pressure_sweep as sweep_cmd
from granwave.errors import InputError
from granwave.model import Signal

PRESSURES = (1e-7, 1e-6, 1e-5, 1e-4)
EPS = (-0.01, 0.0, 0.01)  # per-seed relative scatter, symmetric: the mean is the power law


def synthetic(rng=None):
    """Summaries with c ∝ p^(1/6) exactly on average, scattered statics."""
    rng = rng or np.random.default_rng(7)
    out = []
    for p in PRESSURES:
        for seed, eps in enumerate(EPS):
            out.append({
                "pressure": p, "seed": seed, "kind": "disordered", "height": 25.0 + 0.1 * seed,
                "statics": {"phi2": float(rng.uniform(0.8, 0.85)), "phi3": float(rng.uniform(0.55, 0.6)),
                            "z_star": float(rng.uniform(3, 4)), "stress_ratio": float(rng.uniform(0.8, 1)),
                            "stress": [[1.0 * p, 0.0], [0.0, p]], "converged": True},
                "moduli": {"C11": 100 * p ** (1 / 3) * (1 + eps), "C22": 90 * p ** (1 / 3),
                           "c_l": 2.0 * p ** (1 / 6) * (1 + eps), "c_t": 1.1 * p ** (1 / 6) * (1 + eps)},
                "tof": {"c_tof": 2.1 * p ** (1 / 6), "c_tof_err": 0.01, "gamma": 0.5,
                        "samples": [{"height": 8.0}]},
            })
    return out


def test_flatten_rule():
    flat = flatten(synthetic()[0])
    assert "statics.phi3" in flat and flat["statics.stress.1.1"] == 1e-7
    assert "statics.converged" not in flat and not any(k.startswith("tof.samples") for k in flat)


def test_exponents_and_per_pressure_statistics():
    sums = synthetic()
    res = pressure_sweep(sums)
    assert res["pressures"] == list(PRESSURES)
    for key in ("kappa_tof", "kappa_l", "kappa_t"):
        assert res[key] == pytest.approx(1 / 6, abs=1e-10)
        assert res[key + "_err"] < 1e-7  # exact power law: only rounding scatter
    for row, p in zip(res["per_pressure"], PRESSURES):
        mine = [s for s in sums if s["pressure"] == p]
        phi3 = np.array([s["statics"]["phi3"] for s in mine])
        st = row["stats"]["statics.phi3"]
        assert st["mean"] == pytest.approx(phi3.mean(), rel=1e-14)
        assert st["std"] == pytest.approx(phi3.std(ddof=1), rel=1e-12)
        assert st["sem"] == pytest.approx(phi3.std(ddof=1) / math.sqrt(3), rel=1e-12)
        assert st["count"] == 3 and row["count"] == 3
        cl = np.array([s["moduli"]["c_l"] for s in mine])
        assert row["c_l"] == pytest.approx(cl.mean(), rel=1e-14)
        assert row["c_l_err"] == pytest.approx(cl.std(ddof=1) / math.sqrt(3), rel=1e-12)
        # c_tof is the same in every summary of a pressure: its error is the one carried.
        assert row["c_tof_err"] == pytest.approx(0.01)
        assert row["c_tof_over_c_l"] == pytest.approx(2.1 / 2.0, rel=1e-12)
        assert row["lattice_frictionless"] == pytest.approx(theory.lattice_speed(p), rel=1e-15)
        assert row["lattice_frictional"] == pytest.approx(theory.lattice_speed(p, friction=True), rel=1e-15)
        assert row["c_l_p16"] == pytest.approx(row["c_l"], rel=1e-12)


def test_fit_uses_per_pressure_means_with_uncertainty():
    # Means off the power law by known factors: the exponent is the log-log slope through them.
    sums = []
    factors = (1.02, 0.99, 1.01, 0.98)
    for p, f in zip(PRESSURES, factors):
        for seed in range(2):
            sums.append({"pressure": p, "seed": seed, "kind": "k", "height": 10.0,
                         "moduli": {"c_l": f * p ** 0.2, "c_t": p ** 0.2}})
    res = pressure_sweep(sums)
    x, y = np.log(PRESSURES), np.log(np.array(factors) * np.array(PRESSURES) ** 0.2)
    slope, intercept = np.polyfit(x, y, 1)
    resid = y - (slope * x + intercept)
    se = math.sqrt(np.sum(resid**2) / 2 / np.sum((x - x.mean()) ** 2))
    assert res["kappa_l"] == pytest.approx(slope, rel=1e-12)
    assert res["kappa_l_err"] == pytest.approx(se, rel=1e-6)
    assert math.isnan(res["kappa_tof"]) and any("kappa_tof" in n for n in res["fit_notes"])


def test_merge_summary_from_attrs_and_sections(tmp_path):
    attrs = dict(pressure=1e-5, seed=4, kind="disordered", height=24.9, ic="A", method="modal",
                 schema="granwave.signal", friction="none")
    (tmp_path / "front.json").write_text(json.dumps({"t_peak": 80.0, "amplitude": 0.1}))
    s = merge_summary(attrs=attrs, scene="main", statics={"phi2": 0.84}, front=tmp_path / "front.json")
    assert s["pressure"] == 1e-5 and s["seed"] == 4 and s["scene"] == "main" and s["ic"] == "A"
    assert s["friction"] is None and "schema" not in s  # HDF5's "none" is null; file keys stay out
    assert s["front"] == {"t_peak": 80.0, "amplitude": 0.1} and s["statics"]["phi2"] == 0.84
    with pytest.raises(InputError, match="missing seed"):
        merge_summary(attrs={"pressure": 1e-5, "kind": "k", "height": 3.0})


def test_update_summary_file_in_any_order(tmp_path):
    target = tmp_path / "s.json"
    (tmp_path / "statics.json").write_text(json.dumps({"phi2": 0.84, "z_star": 3.7}))
    update_summary_file(target, section="statics", data=tmp_path / "statics.json")  # incomplete: fine
    update_summary_file(target, pressure=1e-5, seed=2, kind="disordered", height=24.9)
    update_summary_file(target, section="moduli", data={"c_l": 0.3, "C22": 0.05})
    update_summary_file(target, section="statics", data={"phi2": 0.85})
    (s,) = load_summaries([target])
    assert s["statics"] == {"phi2": 0.85, "z_star": 3.7} and s["moduli"]["c_l"] == 0.3
    assert s["pressure"] == 1e-5 and s["seed"] == 2
    with pytest.raises(InputError, match="pressure"):
        update_summary_file(target, pressure=-1.0)
    with pytest.raises(InputError, match="section"):
        update_summary_file(target, section="nonsense", data={})
    assert load_summaries([target])[0]["pressure"] == 1e-5  # the refused update left the file alone


def test_height_series_define_tof_at_their_pressure():
    sums = synthetic()
    series = [{"pressure": p, "c_tof": 3.0 * p ** 0.2, "c_tof_err": 0.02, "c_peak": 2.0 * p ** 0.2,
               "per_height": {"height": [8.0, 25.0]}, "gamma": 0.6} for p in PRESSURES]
    res = pressure_sweep(sums, height_series=series)
    assert res["kappa_tof"] == pytest.approx(0.2, abs=1e-10)  # the summaries' tof (1/6) is replaced
    assert res["kappa_peak"] == pytest.approx(0.2, abs=1e-10)
    assert res["kappa_l"] == pytest.approx(1 / 6, abs=1e-10)
    row = res["per_pressure"][0]
    assert row["c_tof_err"] == 0.02 and row["n_height_series"] == 1 and row["count"] == 3
    assert row["stats"]["tof.gamma"]["count"] == 1
    with pytest.raises(InputError, match="pressure"):
        pressure_sweep(sums, height_series=[{**series[0], "pressure": None}])


def write_all(tmp_path, sums):
    paths = []
    for i, s in enumerate(sums):
        paths.append(str(tmp_path / f"s{i}.json"))
        write_summary(paths[-1], s)
    return paths


def test_cli_writes_sweep_and_tables(tmp_path):
    sums = synthetic()
    paths = write_all(tmp_path, sums[:6])
    (tmp_path / "rest.json").write_text(json.dumps(sums[6:]))  # a list of summaries in one file
    (tmp_path / "tables").mkdir()
    out = tmp_path / "sweep.h5"
    r = CliRunner().invoke(sweep_cmd, [*paths, str(tmp_path / "rest.json"), "-o", str(out),
                                       "--tables", str(tmp_path / "tables"), "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    assert res["kappa_l"] == pytest.approx(1 / 6, abs=1e-10) and res["n_summaries"] == 12
    lib = pressure_sweep(sums)
    back = read_sweep(out)
    np.testing.assert_array_equal(back["pressure"], PRESSURES)
    j = back["quantity"].index("statics.phi3")
    np.testing.assert_array_equal(back["mean"][:, j], [r["stats"]["statics.phi3"]["mean"]
                                                       for r in lib["per_pressure"]])
    np.testing.assert_allclose(back["c_tof"], [2.1 * p ** (1 / 6) for p in PRESSURES], rtol=1e-14)
    assert back["attrs"]["kappa_tof"] == pytest.approx(1 / 6, abs=1e-10)
    # tables: CSV numbers are the per-pressure means and stds, exactly
    with open(tmp_path / "tables" / "sweep_statics.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["pressure"]) for r in rows] == list(PRESSURES)
    for row, lrow in zip(rows, lib["per_pressure"]):
        assert float(row["phi3"]) == lrow["stats"]["statics.phi3"]["mean"]
        assert float(row["phi3_err"]) == lrow["stats"]["statics.phi3"]["std"]
        assert row["Z2"] == ""  # absent from the summaries
    with open(tmp_path / "tables" / "sweep_moduli.csv") as fh:
        mod = list(csv.DictReader(fh))
    assert float(mod[3]["C11"]) == pytest.approx(100 * 1e-4 ** (1 / 3), rel=1e-12)
    md = (tmp_path / "tables" / "sweep_speeds.md").read_text()
    assert f"{theory.lattice_speed(1e-4):.6g}" in md and "kappa_tof" in md
    # default table folder: beside the output
    r = CliRunner().invoke(sweep_cmd, [*paths, "-o", str(tmp_path / "two.h5")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "two_moduli.md").exists() and "kappa_l" in r.output
    # height-series files, by option or among the summaries; a new tables folder is created
    for i, p in enumerate(PRESSURES[:2]):
        (tmp_path / f"h{i}.json").write_text(json.dumps(
            {"pressure": p, "c_tof": 3.0 * p ** 0.2, "c_tof_err": 0.02, "per_height": {}}))
    r = CliRunner().invoke(sweep_cmd, [*paths, "--heights", str(tmp_path / "h0.json"), str(tmp_path / "h1.json"),
                                       "-o", str(tmp_path / "three.h5"), "--tables", str(tmp_path / "new"),
                                       "--json"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    assert res["n_height_series"] == 2 and res["kappa_tof"] == pytest.approx(0.2, abs=1e-10)
    assert (tmp_path / "new" / "three_speeds.csv").exists()


def _fails(tmp_path, args, match):
    before = set(tmp_path.rglob("*"))
    r = CliRunner().invoke(sweep_cmd, [*args, "-o", str(tmp_path / "bad.h5")])
    assert r.exit_code != 0
    assert r.exception is None or isinstance(r.exception, SystemExit)
    assert match in r.output and len(r.output.strip().splitlines()) == 1, r.output
    assert set(tmp_path.rglob("*")) == before  # no output, no tables, no temporary files


def test_cli_bad_input(tmp_path):
    good = write_all(tmp_path, synthetic()[:2])
    _fails(tmp_path, [], "no summary files")
    (tmp_path / "x.json").write_text("{not json")
    _fails(tmp_path, [good[0], str(tmp_path / "x.json")], "not a JSON file")
    files.write_signal(tmp_path / "sig.h5", Signal(np.arange(3.0), np.zeros(3),
                                                   attrs=dict(ic="A", method="m", height=1.0)))
    _fails(tmp_path, [good[0], str(tmp_path / "sig.h5")], "not a JSON file")
    (tmp_path / "nokeys.json").write_text(json.dumps({"pressure": 1e-4}))
    _fails(tmp_path, [good[0], str(tmp_path / "nokeys.json")], "not a granwave summary")
    (tmp_path / "empty.json").write_text("[]")
    _fails(tmp_path, [str(tmp_path / "empty.json")], "empty list")
    _fails(tmp_path, [*good, "--tables", str(tmp_path / "no" / "where")], "parent folder does not exist")

