"""The report's first page: the verdicts, what an estimator is worth (the truth-suite reader),
the affine effective medium the moduli are compared with, and SI conversions that match the
run (a packing's material; `analyze front --units si` refuses a Poisson ratio that is not the
material's)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from granwave.report import findings as FI
from granwave.report import validated as V


# ------------------------------------------------------------------ verdicts
def test_verdicts_say_how_far_and_why():
    assert FI.verdict(0.17, 0.01, 1 / 6) == "agrees within 1σ"
    assert FI.verdict(0.185, 0.01, 1 / 6) == "agrees within 2σ"
    assert FI.verdict(0.21, 0.01, 1 / 6, why="contacts added") == "differs by 4σ: contacts added"
    # no error: a relative difference, and why there is no σ
    assert FI.verdict(1.056, None, 1.0, why="the edge runs ahead") == \
        "5.6% above (deterministic: no σ): the edge runs ahead"
    assert FI.relative_verdict(2.34, 0.6667, no_sigma="two heights").startswith("3.5 × the reference (two heights)")
    assert FI.verdict(0.995, None, 1.0).startswith("agrees within 1%")
    # fewer than 5 packings: the range, and whether the reference is inside it
    assert FI.range_verdict([0.62, 0.66], 1.0, why="affine") == \
        "all 2 packings below the reference (too few for a σ): affine"
    assert FI.range_verdict([0.9, 1.1], 1.0).startswith("reference within the range")
    cell, mean, sem = FI.mean_or_range([0.62, 0.66])
    assert cell == "0.62 … 0.66" and math.isnan(sem)
    cell, mean, sem = FI.mean_or_range([1.0, 1.1, 1.2, 1.3, 1.4])
    assert cell == "1.20 ± 0.07" and sem == pytest.approx(np.std([1, 1.1, 1.2, 1.3, 1.4], ddof=1) / 5 ** 0.5)



def test_exponent_verdicts_read_the_printed_interval_and_bounds_say_which_side():
    """A fit of four pressures (2 dof): 1/6 at 2.2σ lies inside the Student interval (t = 4.3),
    where "within 2σ" would call it a difference; without an interval the σ rule stays."""
    from scipy import stats

    t = stats.t.ppf(0.975, 2)
    v, e = 1 / 6 + 0.022, 0.01
    assert FI.ci_verdict(v, e, (v - t * e, v + t * e), 1 / 6) == "agrees: inside the 95 % interval (2.2σ)"
    assert FI.ci_verdict(0.247, 0.013, (0.19, 0.30), 1 / 6, why="more contacts") == \
        "differs by 6.2σ, outside the 95 % interval: more contacts"
    assert FI.ci_verdict(0.21, 0.01, None, 1 / 6, why="x") == FI.verdict(0.21, 0.01, 1 / 6, why="x")
    assert FI.bound_verdict(0.987, 1.0) == "consistent: the bound lies 0.013 below it"
    assert FI.bound_verdict(1.01, 1.0) == "above it: the bound exceeds it by 1.0%"
    assert FI.bound_verdict(math.nan, 1.0) == "not measured"


def test_the_ratio_bound_is_c_at_the_band_bottom_over_c_l_less_t_errors():
    """c0/c_ℓ ≥ c(ω_lo)/c_ℓ − t·σ with σ from the two relative errors in quadrature."""
    from granwave.analysis.continuum_length import c0_ratio_lower_bound, low_frequency_of_result

    r = 0.19 / 0.2
    want = r - 2.5 * r * math.hypot(0.001 / 0.19, 0.002 / 0.2)
    assert c0_ratio_lower_bound(0.19, 0.001, 0.2, 0.002, 2.5) == pytest.approx(want, rel=1e-12)
    assert math.isnan(c0_ratio_lower_bound(0.19, 0.001, math.nan, 0.0, 2.0))
    att = {"omega": [0.01, 0.02, 0.03, 0.04], "reliable": [False, True, True, True],
           "c": [0.2, 0.19, 0.185, 0.18], "c_err": [0.01, 0.001, 0.001, 0.001], "c0": 0.195,
           "c0_err": 0.002, "ci95_factor": 2.5}
    out = low_frequency_of_result(att, c_ref=0.2, c_ref_err=0.002)
    assert out["c0_over_c_l_lower_bound"] == pytest.approx(want, rel=1e-12)


# ------------------------------------------------------------------ the truth suite's table
def _table(tmp_path, rows_by_key):
    path = tmp_path / "truth.json"
    path.write_text(json.dumps({"revision": "abc", "date": "2026-12-01", "estimators": rows_by_key}))
    V._load.cache_clear()
    return path


def test_validated_reads_the_truth_table_and_says_not_validated_otherwise(tmp_path):
    assert V.check_cell("heights.gamma", path=tmp_path / "missing.json") == "not validated"
    assert V.check_cell(None) == "—"  # no estimator involved
    row = {"setting": "chain A, 5 heights", "truth": 0.5, "n_seeds": 200, "bias": 0.0015,
           "bias_rel": 0.003, "bias_err": 0.001, "coverage95": 0.94, "verdict": "validated"}
    worse = {**row, "setting": "noisy", "bias_rel": -0.012, "bias_err": 0.002, "coverage95": 0.86,
             "verdict": "undercovered"}
    path = _table(tmp_path, {"heights.chi": [row, worse], "sweep.exponent": [row]})
    # the worst of its settings: the largest |relative bias| and the smallest coverage
    assert V.check_cell("heights.chi", path=path) == \
        "undercovered: bias -1.2 ± 0.4 %, 95 % coverage 0.86 (2 settings, ≥ 200 seeds; `heights.chi`)"
    # an alias: the first of the names the table holds
    assert V.check_cell(("heights.delta", "sweep.exponent"), path=path).startswith("validated: bias 0.3 ± 0.2 %")
    assert V.check_cell("front.t_peak", path=path) == "not validated"
    V._load.cache_clear()


# ------------------------------------------------------------------ the effective medium
@pytest.mark.parametrize("friction", [False, True])
def test_affine_medium_is_exact_on_the_triangular_lattice(friction):
    """For the triangular lattice (z = 6, Φ3 = π/(3√3), every contact the same force p/√3) the
    affine medium is the lattice itself: its c_ℓ and c_t are docs/method.md §12's closed forms."""
    from granwave.theory import effective_medium_moduli, lattice_shear_speed, lattice_speed

    for p in (1e-7, 1e-4):
        e = effective_medium_moduli(p, z=6.0, phi=math.pi / (3 * math.sqrt(3)), friction=friction)
        assert e["force"] == pytest.approx(p / math.sqrt(3), rel=1e-12)
        assert e["c_l"] == pytest.approx(lattice_speed(p, friction=friction), rel=1e-12)
        if friction:
            assert e["c_t"] == pytest.approx(lattice_shear_speed(p), rel=1e-12)


def test_affine_medium_averages_over_isotropic_normals():
    """The closed forms against a direct average of C_ijkl over contact normals (2D and 3D)."""
    from granwave.theory import effective_medium_moduli

    kn_kt = []
    for dim in (2, 3):
        e = effective_medium_moduli(1e-5, z=4.0, phi=0.55, dim=dim, poisson=0.2)
        kn = e["k_n"]
        kt = 2 * (1 - 0.2) / (2 - 0.2) * kn
        n_c = 4.0 * 0.55 / (2 * math.pi / 6)
        if dim == 2:
            th = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
            nn = np.stack([np.cos(th), np.sin(th)], 1)
        else:
            g = np.random.default_rng(0).standard_normal((400000, 3))
            nn = g / np.linalg.norm(g, axis=1)[:, None]
        v, h = nn[:, -1], nn[:, 0]
        M = n_c * np.mean((kn - kt) * v**4 + kt * v**2)
        G = n_c * 0.5 * (np.mean((kn - kt) * (h * v) ** 2 + kt * v**2) + np.mean((kn - kt) * (h * v) ** 2))
        tol = 1e-9 if dim == 2 else 5e-3
        assert e["M"] == pytest.approx(M, rel=tol) and e["G"] == pytest.approx(G, rel=tol)
        kn_kt.append(kn)
    with pytest.raises(Exception, match="positive"):
        effective_medium_moduli(1e-5, z=0.0, phi=0.5)


# ------------------------------------------------------------------ SI that matches the run
def test_material_presets_and_the_si_refusal(tmp_path):
    """`--material glass` prepares with glass's Poisson ratio and records the material; `analyze
    front --units si` refuses (one line, exit 2, nothing printed on stdout) a packing whose ratio
    is not the material's, unless --any-poisson; an explicit --poisson that differs is refused."""
    import h5py
    from click.testing import CliRunner

    from granwave.cli import main

    r = CliRunner()
    lat = {k: tmp_path / f"{k}.h5" for k in ("glass", "plain")}
    for k, extra in (("glass", ["--material", "glass"]), ("plain", [])):
        res = r.invoke(main, ["lattice", "--rows", "6", "--width", "6", "--pressure", "1e-4",
                              "--friction", "0.5", *extra, "-q", "-o", str(lat[k])])
        assert res.exit_code == 0, res.output
    with h5py.File(lat["glass"]) as f:
        assert json.loads(f.attrs["material"]) == {"name": "glass", "E": 63e9, "nu": 0.23, "rho": 2500.0}
        assert f.attrs["poisson"] == 0.23
    with h5py.File(lat["plain"]) as f:
        assert "material" not in f.attrs  # without a preset, the file is as before
    bad = r.invoke(main, ["lattice", "--rows", "6", "--width", "6", "--pressure", "1e-4", "--material", "glass",
                          "--poisson", "0.1", "-o", str(tmp_path / "x.h5")])
    assert bad.exit_code == 2 and "give one of them" in bad.output and not (tmp_path / "x.h5").exists()
    sig = {}
    for k, path in lat.items():
        lin, sig[k] = tmp_path / f"{k}_lin.h5", tmp_path / f"{k}_sig.h5"
        assert r.invoke(main, ["linearize", str(path), "-q", "-o", str(lin)]).exit_code == 0
        res = r.invoke(main, ["propagate", str(lin), "--t-max", "60", "--source", "shear", "-q",
                              "-o", str(sig[k])])
        assert res.exit_code == 0, res.output
    args = ["analyze", "front", "--units", "si", "--frequency", "0.02", "--json"]
    res = r.invoke(main, [*args, str(sig["plain"])])
    assert res.exit_code == 2 and "Poisson ratio 0 (eta = 1.000) but glass has 0.23 (eta = 0.870)" in res.output
    assert res.output.strip().count("\n") == 0
    res = r.invoke(main, [*args, "--any-poisson", str(sig["plain"])])
    assert res.exit_code == 0 and "warning:" in res.output
    res = r.invoke(main, [*args, str(sig["glass"])])  # the recorded material is the default
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["si"]["material"] == "glass"


# ------------------------------------------------------------------ repository basics
def test_license_and_citation_name_the_software_and_the_study():
    from pathlib import Path

    import yaml

    root = Path(__file__).resolve().parents[1]
    assert "MIT License" in (root / "LICENSE").read_text()
    assert 'license = {text = "MIT"}' in (root / "pyproject.toml").read_text()
    cff = yaml.safe_load((root / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["license"] == "MIT" and cff["type"] == "software"
    study = cff["references"][0]
    assert study["doi"] == "10.1103/PhysRevE.72.021301" and study["authors"][0]["family-names"] == "Somfai"
    for doc in ("README.md", "docs/method.md"):  # the study cited where users read
        assert study["doi"] in (root / doc).read_text(), doc
