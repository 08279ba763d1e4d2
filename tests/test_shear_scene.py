"""The workflow's shear scene (docs/shear.md, "The shear scene"): its jobs in the quick
config's dry run, the config checks, the exponent / ratio / Poisson analysis on synthetic
records with a known answer, and the report section and figure on small made inputs."""

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from granwave.analysis.shear import PICKS
from granwave.analysis.shear_scene import (HERTZ_EXPONENT, poisson_from_ratio, poisson_from_tensor,
                                           sample_record, shear_scene)

from quick_plan import dry_run

ROOT = Path(__file__).resolve().parents[1]
PRESSURES = (1e-7, 1e-6, 1e-5, 1e-4)
NU_S, NU_P = 0.25, 0.2          # the synthetic speeds' pressure exponents
A_S, A_P, PHI = 0.8, 1.6, 0.8   # their prefactors and Phi3*
#: every pick's V/c_t in the synthetic records (first_deflection within 5 %, the others not)
RATIOS = {"first_deflection": 1.03, "edge10": 0.9, "peak_to_peak": 0.93, "cross_correlation": 1.0,
          "phase": 1.08, "impulse_edge10": 1.5, "impulse_peak": 1.3}


def _picks(height, c, lam, scale):
    """A shear_picks-like result whose speeds are RATIOS × c × scale."""
    picks = {}
    for name in PICKS:
        v = RATIOS[name] * c * scale
        picks[name] = {"time": height / v, "speed": v, "ratio": v / c}
    return {"picks": picks, "errors": {}, "height": height, "frequency": c / lam, "pulse": "ricker",
            "c_t": c, "wavelength": lam}


def _records(dim=2, seeds=3):
    rng = np.random.default_rng(1)
    out = []
    for p in PRESSURES:
        for h in (8, 25):
            for s in range(seeds):
                jitter = 1 + 0.01 * rng.standard_normal()
                ct, cl = A_S * p**NU_S * jitter, A_P * p**NU_P * jitter
                moduli = {"dim": dim, "c_t_slab": ct, "c_l_slab": cl, "phi3_star": PHI,
                          "phi3_star_cell": PHI, "phi3_star_slab": PHI}
                if dim == 2:  # an isotropic medium: C12 = C22 - 2 C33
                    moduli.update(C11=PHI * cl**2, C22=PHI * cl**2, C33=PHI * ct**2,
                                  C12=PHI * (cl**2 - 2 * ct**2))
                else:
                    moduli.update(C33=PHI * cl**2, C44=PHI * ct**2, C55=PHI * ct**2,
                                  C13=PHI * (cl**2 - 2 * ct**2))
                L = h * 0.97
                out.append(sample_record(scene="shear2d", source_scene="frictional2d", pressure=p,
                                         size=f"h{h}", seed=s, moduli=moduli,
                                         shear=[_picks(L, ct, lam, 1.0) for lam in (8.0, 16.0)],
                                         normal=[_picks(L, cl, lam, 1.0) for lam in (8.0, 16.0)],
                                         wavelengths=(8.0, 16.0), pulse="ricker"))
    return out


def test_reference_speeds_bulk_slab_whole_cell_and_the_in_plane_shear_block():
    from granwave.analysis.shear_scene import reference_speeds

    m = {"dim": 2, "c_t_slab": 0.1, "c_l_slab": 0.2, "C22": 0.03, "C33": 0.008, "phi3_star_cell": 0.8}
    r = reference_speeds(m)
    assert (r["c_t"], r["c_l"], r["speed_reference"]) == (0.1, 0.2, "bulk slab")
    assert r["c_t_cell"] == pytest.approx(math.sqrt(0.008 / 0.8)) and r["c_l_cell"] == pytest.approx(math.sqrt(0.03 / 0.8))
    r = reference_speeds({**m, "c_t_slab": float("nan")})  # no slab: the whole cell's, said so
    assert r["speed_reference"] == "whole cell" and r["c_t"] == r["c_t_cell"]
    # 3D: the block [[C55, C45], [C45, C44]] of a packing anisotropic in plane (C45 = 10 % of C44)
    c44, c55, c45, phi = 0.010, 0.012, 0.0011, 0.6
    v = np.zeros((6, 6))
    v[3, 3], v[4, 4], v[3, 4], v[4, 3] = c44, c55, c45, c45
    r = reference_speeds({"dim": 3, "C33": 0.03, "C44": c44, "C55": c55, "voigt": v.tolist(),
                          "phi3_star_cell": phi, "c_t_slab": 0.1, "c_l_slab": 0.2})
    mean, half = 0.5 * (c44 + c55), math.hypot(0.5 * (c55 - c44), c45)
    assert r["c_t_polarisations"] == pytest.approx([math.sqrt((mean - half) / phi), math.sqrt((mean + half) / phi)])
    assert r["c_t_x_cell"] == pytest.approx(math.sqrt((mean + half) / phi))  # C55 > C44: x is the fast one
    assert r["polarisation_deg"] == pytest.approx(math.degrees(0.5 * math.atan2(2 * c45, c55 - c44)))
    assert r["C45_ratio"] == pytest.approx(c45 / math.sqrt(c44 * c55))


def test_poisson_from_speeds_and_from_the_tensor_agree_for_an_isotropic_medium():
    lam, mu = 0.7, 0.3
    # 2D: C22 = lambda + 2 mu, C33 = mu, C12 = lambda; nu = lambda / (lambda + 2 mu)
    r = math.sqrt((lam + 2 * mu) / mu)
    assert poisson_from_ratio(r, 2) == pytest.approx(lam / (lam + 2 * mu), rel=1e-12)
    assert poisson_from_tensor({"C12": lam, "C22": lam + 2 * mu}, 2) == pytest.approx(lam / (lam + 2 * mu))
    # 3D: nu = lambda / (2 (lambda + mu))
    assert poisson_from_ratio(r, 3) == pytest.approx(lam / (2 * (lam + mu)), rel=1e-12)
    assert poisson_from_tensor({"C13": lam, "C33": lam + 2 * mu}, 3) == pytest.approx(lam / (2 * (lam + mu)))
    assert poisson_from_ratio(math.sqrt(2.0), 2) == pytest.approx(0.0)  # r^2 = 2: nu = 0


@pytest.mark.parametrize("dim", [2, 3])
def test_scene_analysis_recovers_known_exponents_ratios_and_picks(dim):
    a = shear_scene(_records(dim), pick="cross_correlation")
    assert a["dim"] == dim and a["fit_height"] == 25 and a["n_records"] == 4 * 2 * 3
    f = a["fits"]
    assert f["V_s"]["exponent"] == pytest.approx(NU_S, abs=0.01)
    assert f["V_p"]["exponent"] == pytest.approx(NU_P, abs=0.01)
    assert f["c_t"]["exponent"] == pytest.approx(NU_S, abs=0.01)
    assert f["G_max"]["exponent"] == pytest.approx(2 * NU_S, abs=0.02)  # Phi3* constant
    assert math.isfinite(f["G_max"]["exponent_err"])
    g = a["G_max"]
    assert g["hertz"]["exponent"] == HERTZ_EXPONENT
    assert g["free"]["rms_log_residual"] < g["hertz"]["rms_log_residual"]  # 1/2 is not 1/3
    assert g["deviation_from_hertz"] > 3
    for row in a["pressures"]:
        p = row["pressure"]
        assert row["n"] == 3 and row["height_nominal"] == 25
        r = (A_P * p**NU_P) / (A_S * p**NU_S)  # the same jitter on both speeds
        assert row["ratio_waves"]["mean"] == pytest.approx(r, rel=1e-9)
        assert row["ratio_moduli"]["mean"] == pytest.approx(r, rel=1e-9)
        nu = poisson_from_ratio(r, dim)
        assert row["poisson_waves"]["mean"] == pytest.approx(nu, rel=1e-9)
        assert row["poisson_tensor"]["mean"] == pytest.approx(nu, rel=1e-9)  # isotropic records
        assert row["V_s_over_c_t"]["mean"] == pytest.approx(1.0)
        assert row["G_max"]["mean"] == pytest.approx(row["G_moduli"]["mean"], rel=0.01)
    # the pick table: 4 pressures x 2 wavelengths x 2 heights, the picks within 5 % of c_t
    assert len(a["pick_table"]) == 16
    for row in a["pick_table"]:
        assert row["n"] == 3
        assert row["first_deflection"] == pytest.approx(1.03)
        assert row["within_5pct"] == ["first_deflection", "cross_correlation"]


def test_scene_analysis_refuses_bad_input():
    from granwave.errors import InputError

    with pytest.raises(InputError, match="pick"):
        shear_scene(_records(), pick="nonsense")
    with pytest.raises(InputError, match="no shear scene records"):
        shear_scene([])
    with pytest.raises(InputError, match="dimensions"):
        shear_scene(_records(2)[:3] + _records(3)[:3])


def test_report_section_and_figure_from_a_made_analysis(tmp_path, monkeypatch):
    from figure_rules import capture, check

    from granwave.figures import caption_for, shear_panels
    from granwave.report import build_report
    from granwave.report.shear import shear_section

    a = {**shear_scene(_records(), pick="cross_correlation", material="quartz", diameter_mm=0.5),
         "scene": "shear2d", "source_scene": "frictional2d"}
    md = "\n".join(shear_section({"shear2d": a}))
    from granwave.units import material_scales

    sc = material_scales("quartz", 0.5e-3)  # V_s in m/s = reduced V_s x sqrt(E*/rho)
    row = a["si"]["rows"][-1]
    assert row["V_s_m_s"]["mean"] == pytest.approx(a["pressures"][-1]["V_s"]["mean"] * sc["speed"])
    assert row["G_max_MPa"]["mean"] == pytest.approx(a["pressures"][-1]["G_max"]["mean"] * sc["E_star"] / 1e6)
    assert row["f_shear_kHz"] == pytest.approx(a["pressures"][-1]["c_t"]["mean"] * sc["speed"] / (8 * 0.5e-3) / 1e3)
    assert "In SI units for quartz grains" in md and "| p (kPa) | V_s (m/s)" in md
    assert "## Shear waves" in md and "### shear2d (2D, packings of frictional2d)" in md
    assert "κ_s = 0.25" in md                      # exponent ± error, error to 1-2 digits
    from granwave.report.symbols import undefined_symbols

    assert not undefined_symbols(md), sorted(undefined_symbols(md))
    assert "Not quartz beads" not in md  # no Poisson ratio given: nothing to compare
    # packings that ran with another Poisson ratio than the material's: the SI table says so
    b = shear_scene(_records(), pick="cross_correlation", material="quartz", diameter_mm=0.5, poisson=0.0)
    assert b["si"]["poisson_mismatch"].startswith("the packing ran with Poisson ratio 0 (eta = 1.000)")
    md_b = "\n".join(shear_section({"shear2d": {**b, "scene": "shear2d", "source_scene": "frictional2d"}}))
    assert "**Not quartz beads:** the packing ran with Poisson ratio 0" in md_b
    assert "per unit length of wall" in md_b  # 2D moduli: per d̄-thick layer
    assert "| 1e-07 | 3 |" in md                   # counts as integers
    assert "`first_deflection`, `cross_correlation`" in md  # within 5 %
    assert "in no row: `edge10`, `peak_to_peak`, `phase`, `impulse_edge10`, `impulse_peak`" in md
    # the compressional precursor's speed beside the picks: c_l/c_t of the moduli per pressure
    from granwave.report.shear import compressional_ratio

    for p, r in compressional_ratio(a).items():
        assert r["mean"] == pytest.approx(A_P / A_S * p ** (NU_P - NU_S), rel=1e-12)
    assert "| c_ℓ/c_t (P) |" in md
    page = build_report(shear=[(tmp_path / "shear2d" / "analysis.json", a, None)], out_dir=tmp_path)
    assert "## Shear waves" in page
    figs = capture(monkeypatch)
    files = shear_panels(a, tmp_path / "shear_shear2d.png")
    assert files[0].stat().st_size > 10_000
    check(figs[0], scene="shear2d", pressure=False)  # several pressures: p on the axes
    assert caption_for(files[0]).startswith("Shear scene:") and caption_for(files[0]).endswith("(shear2d)")


def _config():
    import jsonschema  # noqa: F401  (the schema's defaults are filled in as the workflow does)
    from snakemake.utils import validate

    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    validate(cfg, str(ROOT / "workflow" / "schemas" / "config.schema.yaml"))
    return cfg


@pytest.mark.parametrize("change, text", [
    (lambda c: c["shear"]["shear2d"].update(scene="frictionless2d"), "shear.shear2d.scene = 'frictionless2d' is frictionless"),
    (lambda c: c["shear"]["shear2d"].update(scene="nothere"), "is not a disordered scene"),
    (lambda c: c["shear"]["shear2d"].update(pressures=[3e-5]), "shear.shear2d.pressures[0] = 3e-05 is not a pressure"),
    (lambda c: c["shear"]["shear2d"].update(heights=[9]), "shear.shear2d.heights[0] = 9 is not a height"),
    (lambda c: c["shear"]["shear2d"].update(samples=1), "shear.shear2d.samples"),
    (lambda c: c["shear"].update(frictional2d=c["shear"]["shear2d"]), "defined twice"),
])
def test_shear_config_errors_name_the_key(change, text):
    from granwave.workflow_config import shear_error

    cfg = _config()
    assert shear_error(cfg) is None
    bad = copy.deepcopy(cfg)
    change(bad)
    message = shear_error(bad)
    assert message and text in message and "\n" not in message


def test_quick_config_dry_run_includes_the_shear_scene():
    returncode, out = dry_run("config/config.yaml")
    assert returncode == 0, out[-3000:]
    # the analysis draws the figure in the same job (rule shear_scene_outputs)
    for rule in ("shear_batch_shear2d_0", "shear_scene_outputs"):
        assert rule in out, rule


def test_docs_scene_pick_table_is_the_generated_one():
    """docs/shear.md's scene tables are what benchmarks/results/summarize.py writes from the newest
    shear_scene.jsonl record of each scene (rerun it after recording a run)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("summarize", ROOT / "benchmarks" / "results" / "summarize.py")
    summarize = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(summarize)
    doc = (ROOT / "docs" / "shear.md").read_text()
    begin, end = summarize.SHEAR_TABLE
    block = doc[doc.index(begin) + len(begin):doc.index(end)]
    assert block.strip() == summarize.shear_scene_table().strip()


def test_report_flags_a_compressional_pick_faster_than_c_l():
    """A V_p above 1.1 c_l (a cross-correlation that skipped a cycle) is named in the report, the
    rows within it are not."""
    from granwave.report.shear import shear_section

    a = {**shear_scene(_records(), pick="cross_correlation"), "scene": "shear2d", "source_scene": "frictional2d"}
    assert "V_p above" not in "\n".join(shear_section({"shear2d": a}))
    rows = [dict(r) for r in a["pressures"]]
    rows[0] = {**rows[0], "V_p_over_c_l": {"mean": 1.43, "sem": 0.01}}
    md = "\n".join(shear_section({"shear2d": {**a, "pressures": rows}}))
    assert f"V_p above 1.1 c_ℓ at p = {rows[0]['pressure']:g}**" in md
