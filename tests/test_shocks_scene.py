"""The shocks scene (docs/shocks.md, "The shocks scene"): its analysis on synthetic packing
records of known answers (the mean-field curve's crossover and its p^(2/3) scaling, a known
strongly nonlinear exponent, a tanh front of known width), the refusals, the CLI, the config
checks and the config's dry run. Fast: no DEM run."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

from quick_plan import dry_run  # noqa: E402

from granwave.analysis import shocks_scene as S  # noqa: E402
from granwave.errors import InputError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DRIVES = [0.01, 0.0316, 0.1, 0.316, 1.0, 3.16, 10.0, 31.6, 100.0]


def _record(p, seed, *, speed, d0_of_p=lambda p: 0.5 * p ** (2 / 3), c0=0.2, noise=0.0, rng=None,
            law="hertz", friction=0.0, scene="synthetic"):
    """A packing record whose pushes sit at ε/δ0 = DRIVES and travel at V = c0 speed(x) (× noise)."""
    d0 = d0_of_p(p)
    rows = []
    for x in DRIVES:
        v = c0 * float(speed(x)) * (1.0 + (noise * rng.standard_normal() if noise else 0.0))
        eps = x * d0
        rows.append(dict(amplitude=x, nominal_strain=eps, piston_velocity=eps * v, front_speed=v,
                         front_speed_error=0.0, strain=eps, width=2.0, opened=min(1.0, 0.01 * x),
                         slid=0.0, formed=0.0, n_contacts=1000, energy_drift=0.0,
                         front_speed_bound_linear=1.1 * c0))
    return S.packing_record(dict(scene=scene, pressure=p, seed=seed, friction=friction, contact_law=law),
                            rows, static_strain=d0)


def test_mean_field_curve_limits():
    x = np.array([1e-8, 1e-3])
    # small x: 1 + (alpha - 2) x / 4
    assert np.allclose(S.mean_field_speed(x, 2.5), 1.0 + 0.125 * x, rtol=0, atol=1e-7)
    assert np.allclose(S.mean_field_speed(np.array([0.1, 10.0, 1e3]), 2.0), 1.0, rtol=1e-12)
    # large x: slope (alpha - 2) / 2, and the exact value at x = 3 for Hertz: sqrt((8 - 1) / 4.5)
    assert S.mean_field_slope(1e8, 1e9, 2.5) == pytest.approx(0.25, abs=1e-4)
    assert float(S.mean_field_speed(3.0, 2.5)) == pytest.approx(math.sqrt(7.0 / 4.5), rel=1e-12)
    x_c = S.mean_field_crossover(2.5)
    assert float(S.mean_field_speed(x_c, 2.5)) == pytest.approx(S.CROSSOVER_RATIO, rel=1e-10)
    assert math.isnan(S.mean_field_crossover(2.0))


def test_crossover_and_its_pressure_scaling_recovered_from_the_mean_field_curve():
    """Records on the exact mean-field curve with δ0 ∝ p^(2/3): ε×/δ0 is the curve's own x× up to
    the monotone cubic between half-decade pushes (1.3 % here, the crossing 5 % below a push;
    −0.4 % on average over the pushes' positions, 1.3 % at worst: decision 0053; tested at 2 %),
    and ε× ∝ p^(2/3) exactly."""
    recs = [_record(p, s, speed=lambda x: S.mean_field_speed(x, 2.5))
            for p in (1e-7, 1e-6, 1e-5, 1e-4) for s in range(3)]
    a = S.shocks_scene(recs)["scenes"]["synthetic"]
    x_c = S.mean_field_crossover(2.5)
    for q in a["pressures"]:
        assert q["crossover_over_static"]["mean"] == pytest.approx(x_c, rel=0.02)
        assert math.isnan(q["crossover_over_static"]["error"])  # 3 packings: a range, not a ±
        assert q["c0"]["mean"] == pytest.approx(0.2 * float(S.mean_field_speed(0.01, 2.5)), rel=1e-12)
    assert a["crossover_scaling"]["exponent"] == pytest.approx(2 / 3, abs=1e-9)
    assert a["crossover_scaling_expected"] == pytest.approx(2 / 3)
    assert a["tail_exponent_expected"] == pytest.approx(0.25)
    # the mean-field slope over the window the pushes cover is what the finite window can give
    assert a["tail_exponent"]["mean"] == pytest.approx(a["tail_exponent_mean_field"], abs=0.01)


def test_known_exponent_and_crossover_within_the_quoted_error():
    """Noisy synthetic packings (1 % speed noise, 10 packings at each of two pressures):
    (a) V = c0 (x ≥ 1: x^β), β = 0.3: β from the pushes at x ≥ 10 (exact without noise) within 3
    quoted errors in at least 9 of 10 seeds; (b) V on the mean-field Hertz curve: ε×/δ0 within
    3 quoted errors (+ 2 % for the interpolation between half-decade pushes, 1.3 % here) of
    the curve's exact x× in at least 9 of 10 seeds."""
    beta = 0.3
    power = lambda x: 1.0 if x < 1.0 else x**beta  # noqa: E731
    exact = S.shocks_scene([_record(1e-5, 0, speed=power)])["scenes"]["synthetic"]["tail_exponent"]["mean"]
    assert exact == pytest.approx(beta, abs=1e-12)
    x_cross = S.mean_field_crossover(2.5)
    hits_beta = hits_cross = 0
    for seed in range(10):
        rng = np.random.default_rng(seed)
        recs = [_record(p, s, speed=power, noise=0.01, rng=rng) for p in (1e-6, 1e-5) for s in range(10)]
        t = S.shocks_scene(recs)["scenes"]["synthetic"]["tail_exponent"]
        assert t["n"] == 20 and t["error"] > 0
        hits_beta += abs(t["mean"] - beta) < 3 * t["error"]
        recs = [_record(p, s, speed=lambda x: S.mean_field_speed(x, 2.5), noise=0.01, rng=rng)
                for p in (1e-6, 1e-5) for s in range(10)]
        q = S.shocks_scene(recs)["scenes"]["synthetic"]["pressures"][0]["crossover_over_static"]
        assert q["n"] == 10 and q["error"] > 0
        hits_cross += abs(q["mean"] - x_cross) < 3 * q["error"] + 0.02 * x_cross
    assert hits_beta >= 9 and hits_cross >= 9


def test_crossover_between_softened_pushes_and_its_propagated_error():
    """(a) Pushes below the crossing softened (V/c0 < 1, as at the lowest recorded pressures): the
    crossing lies between the two pushes around 1.1, where the cubic is monotone. (b) The error
    propagated from the pushes' speed errors (each moving ln V/c0 and ln ε = ln v_p/V) matches
    the spread of ε× over 2000 draws of 0.2 % noise on the mean-field curve, within 10 %."""
    strain = np.array([0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0])
    ratio = np.array([1.0, 0.97, 0.95, 0.96, 0.995, 1.15, 1.3])
    e = S.crossover_strain(strain, ratio)
    assert 1.0 < e < 3.0 and math.isfinite(e)
    assert math.isnan(S.crossover_strain(strain, np.minimum(ratio, 1.05)))
    rng = np.random.default_rng(3)
    v_p = strain * S.mean_field_speed(strain, 2.5)  # v_p = ε V at c0 = 1
    speed = S.mean_field_speed(strain, 2.5)
    sigma = 0.002
    quoted = S.crossover_error(strain, speed, sigma * speed)
    draws = []
    for _ in range(2000):
        v = speed * (1.0 + sigma * rng.standard_normal(speed.size))
        draws.append(S.crossover_strain(v_p / v, v / v[0]))
    assert np.std(draws) == pytest.approx(quoted, rel=0.1)
    assert math.isnan(S.crossover_error(strain, speed * 0 + 1.0, sigma * speed))  # never reached


def test_crossover_scaling_error_is_hc3():
    """κ's error: the HC3 sandwich (X'X)⁻¹ X' diag(r²/(1 − h)²) X (X'X)⁻¹ of the regression of ln ε×
    on ln p, computed here with the full matrices, on points whose scatter grows towards low p."""
    rng = np.random.default_rng(5)
    p = np.repeat([1e-7, 1e-6, 1e-5, 1e-4], 10)
    e = p ** (2 / 3) * np.exp(rng.standard_normal(p.size) * np.where(p < 1e-6, 0.5, 0.1))
    sc = S._scaling(list(zip(p, e)))
    X = np.column_stack([np.ones(p.size), np.log(p)])
    y = np.log(e)
    inv = np.linalg.inv(X.T @ X)
    coef = inv @ X.T @ y
    r = y - X @ coef
    h = np.einsum("ij,jk,ik->i", X, inv, X)
    cov = inv @ X.T @ np.diag(r**2 / (1 - h) ** 2) @ X @ inv
    assert sc["exponent"] == pytest.approx(coef[1], rel=1e-12)
    assert sc["error"] == pytest.approx(math.sqrt(cov[1, 1]), rel=1e-10)
    t = float(__import__("scipy.stats", fromlist=["t"]).t.ppf(0.975, p.size - 2))
    assert sc["ci95"] == pytest.approx([coef[1] - t * sc["error"], coef[1] + t * sc["error"]], rel=1e-12)


def test_harmonic_law_has_no_crossover_and_a_flat_curve():
    recs = [_record(p, s, speed=lambda x: 1.0, law="harmonic contact", scene="harm") for p in (1e-6, 1e-5)
            for s in range(5)]
    a = S.shocks_scene(recs)["scenes"]["harm"]
    assert a["contact_law"] == "harmonic" and a["tail_exponent_expected"] == 0.0
    assert a["tail_exponent"]["mean"] == pytest.approx(0.0, abs=1e-12)
    assert a["tail_exponent_mean_field"] == 0.0  # exactly: the report prints it as 0
    assert all(q["n_crossover_reached"] == 0 for q in a["pressures"])
    assert math.isnan(a["crossover_scaling"]["exponent"])
    # a pressure where fewer than half the packings cross is not in the scaling (a selection)
    few = [_record(p, s, speed=(lambda x: S.mean_field_speed(x, 2.5)) if (p == 1e-4 or s == 0) else (lambda x: 1.0))
           for p in (1e-6, 1e-5, 1e-4) for s in range(4)]
    b = S.shocks_scene(few)["scenes"]["synthetic"]
    assert [q["crossover_counted"] for q in b["pressures"]] == [False, False, True]
    assert b["crossover_scaling"]["n_pressures"] == 1 and math.isnan(b["crossover_scaling"]["exponent"])
    # contact fractions carried per push: opened = 0.01 x in the synthetic records
    row = a["pressures"][0]["pushes"][4]
    assert row["opened"]["mean"] == pytest.approx(0.01 * row["x"]["mean"], rel=1e-12)


def test_rise_width_of_a_tanh_front():
    """A front v_p (1 + tanh((t − z/V) V / ℓ)) / 2: the 10–90 % width is 2 atanh(0.8) ℓ."""
    V, ell, v_p = 0.3, 1.5, 1e-3
    time = np.linspace(0.0, 200.0, 4001)
    height = np.arange(0.5, 40.0, 1.0)
    field = np.array([0.5 * v_p * (1.0 + np.tanh((time - z / V - 10.0) * V / ell)) for z in height])
    w = S.rise_width(time, height, field, plateau=v_p, speed=V, fit_range=(8.0, 32.0))
    assert w == pytest.approx(2.0 * math.atanh(0.8) * ell, rel=2e-3)


def test_refusals_are_one_line():
    good = _record(1e-5, 0, speed=lambda x: 1.0)
    with pytest.raises(InputError, match="not a shocks packing record"):
        S.read_record({"pulses": 3}, "x.json")
    bad = copy.deepcopy(good)
    bad["pulses"][0].pop("strain")
    with pytest.raises(InputError, match="push 0 has no strain"):
        S.read_record(bad, "x.json")
    weak = copy.deepcopy(good)
    weak["pulses"] = weak["pulses"][3:]  # weakest push at x = 0.316: no linear speed
    with pytest.raises(InputError, match="no linear speed c0"):
        S.shocks_scene([weak])
    a = S.shocks_scene([good, weak])["scenes"]["synthetic"]  # that packing left out and named
    assert a["n_packings"] == 1 and a["n_excluded"] == 1 and "no linear speed" in a["excluded"][0]
    lost = copy.deepcopy(good)  # the weakest push's fit failed (90 % error): left out, the next is c0
    lost["pulses"][0].update(front_speed=5.0, front_speed_error=4.5)
    a = S.shocks_scene([lost])["scenes"]["synthetic"]
    assert a["n_pushes_rejected"] == 1 and a["pressures"][0]["c0"]["mean"] == pytest.approx(0.2, rel=1e-12)
    mixed = [good, {**copy.deepcopy(good), "friction": 0.5}]
    with pytest.raises(InputError, match="mix"):
        S.shocks_scene(mixed)
    # a JSON record's nulls (NaN written as null) read back as NaN
    back = S.read_record(json.loads(json.dumps({**good, "pulses": [{**good["pulses"][0], "width": None}]})))
    assert math.isnan(back["pulses"][0]["width"])


def test_cli_prints_json_and_refuses_in_one_line(tmp_path):
    paths = []
    for s in range(2):
        path = tmp_path / f"s{s}.json"
        path.write_text(json.dumps(_record(1e-5, s, speed=lambda x: S.mean_field_speed(x, 2.5))))
        paths.append(str(path))
    run = subprocess.run([sys.executable, "-m", "granwave", "analyze", "shocks", *paths, "--json"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    a = json.loads(run.stdout)["scenes"]["synthetic"]
    assert a["n_packings"] == 2
    (tmp_path / "bad.json").write_text("{}")
    run = subprocess.run([sys.executable, "-m", "granwave", "analyze", "shocks", str(tmp_path / "bad.json")],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr


def _config():
    from snakemake.utils import validate

    cfg = yaml.safe_load((ROOT / "config" / "shocks.yaml").read_text())
    validate(cfg, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    return cfg


@pytest.mark.parametrize("change, text", [
    (lambda c: c["shocks"]["hertz_frictionless"].update(drives=[0.5, 1.0]), "weakest drive"),
    (lambda c: c["shocks"]["hertz_frictionless"].update(drives=[0.01, 1.0, 1.0000001]), "one label"),
    (lambda c: c["shocks"]["hertz_frictionless"].update(contact={"contact_law": "nothere"}),
     "shocks.hertz_frictionless.contact.contact_law"),
    (lambda c: c.update(disordered={"hertz_frictional": {"pressures": [1e-4], "heights": [8]}}), "defined twice"),
])
def test_shocks_config_errors_name_the_key(change, text):
    from granwave.workflow_config import shocks_error

    cfg = _config()
    assert shocks_error(cfg) is None
    bad = copy.deepcopy(cfg)
    change(bad)
    message = shocks_error(bad)
    assert message and text in message and "\n" not in message


def test_shocks_config_dry_run_and_the_quick_default_without_it():
    returncode, out = dry_run("config/shocks.yaml")
    assert returncode == 0, out[-3000:]
    for rule in ("shocks_kernels", "shocks_batch_hertz_frictionless_0", "shocks_batch_hertz_frictional_0",
                 "shocks_batch_harmonic_frictionless_0", "shocks_batch_hertz_frictional_3d_0", "shocks_analysis",
                 "figure_shocks", "report"):
        assert rule in out, rule
    returncode, out = dry_run("config/config.yaml")
    jobs = [line.split()[0] for line in out.splitlines() if line.strip() and not line.startswith(" ")]
    assert returncode == 0 and not any("shocks" in job for job in jobs), out[-3000:]


@pytest.mark.parametrize("markers, table", [("SHOCKS_TABLE", "shocks_scene_tables"),
                                            ("PULSE_TABLE", "pulse_speed_table")])
def test_docs_tables_are_the_generated_ones(markers, table):
    """docs/shocks.md's scene tables and speed table are what benchmarks/results/summarize.py writes
    from the newest shocks_scene.jsonl record of each scene and the newest pulse.jsonl shock records
    (rerun it after recording a run)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("summarize", ROOT / "benchmarks" / "results" / "summarize.py")
    summarize = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(summarize)
    doc = (ROOT / "docs" / "shocks.md").read_text()
    begin, end = getattr(summarize, markers)
    block = doc[doc.index(begin) + len(begin):doc.index(end)]
    assert block.strip() == getattr(summarize, table)().strip()


def test_report_section_copies_the_analysis(tmp_path):
    """The report's shocks section: the scene's exponent and its distance from 1/4 as the analysis
    gives them, a range for a point under 5 packings."""
    from granwave.report.shocks import shocks_section

    recs = [_record(p, s, speed=lambda x: S.mean_field_speed(x, 2.5)) for p in (1e-6, 1e-5) for s in range(3)]
    a = S.shocks_scene(recs)["scenes"]["synthetic"]
    md = "\n".join(shocks_section({"synthetic": a}))
    assert md.startswith("## Shocks") and "| synthetic | hertz, 0 | 6 |" in md
    assert " … " in md  # 3 packings a point: ranges


def test_figure_follows_the_rules_and_report_symbols_are_defined(tmp_path, monkeypatch):
    from figure_rules import capture, check

    from granwave.figures import shocks_panels
    from granwave.report.captions import caption_for
    from granwave.report.shocks import shocks_section
    from granwave.report.symbols import undefined_symbols

    recs = [_record(p, s, speed=lambda x: S.mean_field_speed(x, 2.5), friction=0.5)
            for p in (1e-6, 1e-5) for s in range(5)]
    analysis = S.shocks_scene(recs)
    figs = capture(monkeypatch)
    files = shocks_panels(analysis, tmp_path / "shocks_synthetic.png", scene="synthetic")
    assert files[0].stat().st_size > 10_000
    check(figs[0], scene="synthetic", pressure=False, height=False)
    assert caption_for(files[0]).startswith("Shocks scene:")
    assert not undefined_symbols("\n".join(shocks_section(analysis["scenes"])))


def test_the_batch_code_runs_a_tiny_packing(tmp_path):
    """The kernels' warm-up is the batch's own code (workflow_support.run_shocks_sample) on a
    60-grain copy of a scene's sample: it ran nowhere in the tests, and a missing import there
    stopped `snakemake --configfile config/shocks.yaml` at its first job. The sample is the
    workflow's (common.smk's shocks_sample) for config/shocks.yaml's Hertz scene, whose law is
    the default (no `contact` key); the record names it and holds one row per drive."""
    from granwave.workflow_support import warm_shocks

    spec = yaml.safe_load((ROOT / "config" / "shocks.yaml").read_text())["shocks"]["hertz_frictionless"]
    assert "contact" not in spec
    sample = {"scene": "hertz_frictionless", "pressure": 1e-4, "size": "h24", "seed": 0,
              "make": dict(dim=2, grains=288, aspect=2.0, pressure=1e-4, friction=0.0, poisson=0.2,
                           polydispersity=0.2, tol=1e-4, max_steps=200000, seed=0),
              "drives": [0.01, 0.1, 1.0], "max_strain": 0.05, "damping": 0.1, "samples": 400, "bin": 1.0,
              "out": {"packing": str(tmp_path / "p.h5"), "record": str(tmp_path / "r.json")}}
    done = warm_shocks(sample, tmp_path / "kernels")
    assert done["family"] == "shocks" and done["ran"][0]["sample"] == "hertz_frictionless"
    rec = json.loads((tmp_path / "kernels" / "tiny.record.json").read_text())
    assert rec["contact_law"] == "hertz" and rec["scene"] == "hertz_frictionless", rec
    assert [p["amplitude"] for p in rec["pulses"]] == [0.01, 1.0], rec  # the warm-up's two drives
    assert rec["n_grains"] == 60 and rec["static_strain"] > 0, rec
