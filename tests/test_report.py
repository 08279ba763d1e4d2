"""`granwave report`: from small synthetic inputs the report holds every table,
every figure link and the numbers of the inputs (none typed in)."""

from __future__ import annotations

import json
import math

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from click.testing import CliRunner  # noqa: E402

from granwave import io as _io  # noqa: E402,F401  (import io before model: import cycle)
from granwave import report as R  # noqa: E402
from granwave.cli import main  # noqa: E402
from granwave.theory import lattice_speed  # noqa: E402

PRESSURES = (1e-6, 1e-4)


def summary(p, seed):
    """A per-sample summary (docs/summaries.md) with seed-dependent numbers."""
    x = 0.001 * seed
    c_l = 2.0 * p ** (1 / 6) * (1 + x)
    return {"pressure": p, "seed": seed, "kind": "disordered", "height": 25.0, "friction": 0.5,
            "statics": {"phi2": 0.80 + x, "phi3": 0.54 + x, "phi3_star": 0.53 + x, "z_star": 3.4 + x,
                        "rattler_fraction": 0.1, "mean_force_over_p": 1.0 + x, "Z2": 1.5, "Z3": 3.1,
                        "F2": 0.51, "F2_strong": 0.55, "stress_ratio": 0.9 + x},
            "moduli": {"C11": 0.01 + x, "C12": 0.005, "C22": 0.011, "C33": 0.003, "c_l": c_l,
                       "c_t": 0.5 * c_l, "phi3_star": 0.53 + x},
            "front": {"t_lead10": 100.0, "t_peak": 110.0, "amplitude": 0.02, "t_zero": 120.0,
                      "width": 20.0}}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("results")
    for p in PRESSURES:
        for seed in range(3):
            d = root / "summary" / "frictional2d" / f"p{p:g}" / "h25"
            d.mkdir(parents=True, exist_ok=True)
            (d / f"s{seed}.json").write_text(json.dumps(summary(p, seed)))
    hd = root / "heights"
    heights = {
        ("frictional2d", 1e-6): {"c_tof": 0.2345, "c_tof_err": 0.0012, "c_peak": 0.2222,
                                  "c_zero": 0.2111, "gamma": 0.8123, "gamma_err": 0.021,
                                  "alpha": 0.4567, "alpha_err": 0.034},
        ("frictional2d", 1e-4): {"c_tof": 0.4811, "c_tof_err": 0.002, "c_peak": 0.4711,
                                  "c_zero": 0.4611, "gamma": 0.7911, "gamma_err": 0.02,
                                  "alpha": 0.4412, "alpha_err": 0.03},
        ("lattice_frictional", 1e-5): {"c_tof": 0.4321, "c_tof_err": 0.001, "c_peak": 0.4012,
                                        "c_zero": 0.3999},
        ("chain_B", 1.0): {"ic": "B", "gamma": 0.9712, "gamma_err": 0.005, "alpha": 0.3401,
                           "alpha_err": 0.002},
    }
    for (scene, p), obj in heights.items():
        (hd / scene).mkdir(parents=True, exist_ok=True)
        L = [8.0, 8.0, 25.0, 25.0]
        obj = {"pressure": p, "ic": obj.get("ic", "A"), **obj,
               "samples": [{"height": h, "t_lead10": h / 0.2, "t_peak": h / 0.19, "t_zero": h / 0.18,
                            "amplitude": h ** -0.8, "width": h ** 0.45} for h in L]}
        (hd / scene / f"p{p:g}.json").write_text(json.dumps(obj))
    sweep = root / "sweep" / "frictional2d.json"
    sweep.parent.mkdir()
    from granwave.analysis.sweep import pressure_sweep
    from granwave.cli.common import _jsonable

    sums = [summary(p, s) for p in PRESSURES for s in range(3)]
    for s in sums:  # a height series per pressure, copied into its samples' summaries
        s["tof"] = {"c_tof": 0.2345 if s["pressure"] < 1e-5 else 0.4811}
    res = pressure_sweep(sums)
    res["alpha_tof"], res["alpha_tof_err"] = 0.2468, 0.0135  # stands out in the report
    sweep.write_text(json.dumps(_jsonable(res)))
    figs = root / "figures"
    figs.mkdir()
    from granwave import plots
    plots.chain_airy(figs / "airy_A.png", n_balls=(10, 20), pdf=True)
    plots.amplitude_width({"x": {"height": [8, 25], "amplitude": [1, 0.5], "width": [1, 2]}},
                          figs / "exponents.png")
    cfg = root / "config.yaml"
    cfg.write_text("name: synthetic-test\ndisordered:\n  frictional2d:\n    friction: 0.5\n"
                   "lattices:\n  lattice_frictional:\n    friction: 0.5\nchains:\n  chain_B:\n"
                   "    ic: B\n")
    return root


def run_report(root, out):
    args = ["report", "--config", str(root / "config.yaml"), "--summaries", str(root / "summary"),
            "--heights", str(root / "heights"), "--sweep", str(root / "sweep" / "frictional2d.json"),
            "--figures", str(root / "figures"), "-o", str(out)]
    return CliRunner().invoke(main, args)


def test_report_contents(inputs, tmp_path):
    out = tmp_path / "report" / "index.md"
    res = run_report(inputs, out)
    assert res.exit_code == 0, res.output
    md = out.read_text()
    html = out.with_suffix(".html").read_text()
    # provenance
    assert "synthetic-test" in md and "git revision" in md
    # every table
    for heading in ("## Statics per pressure", "## Elastic moduli per pressure",
                    "## Sound speeds against pressure", "## Front scaling with distance",
                    "## Triangular lattices against the formula", "## Pressure-sweep fits",
                    "## Figures"):
        assert heading in md
    # statics: mean ± std over the 3 packings of each pressure, with their number
    phi2 = [0.80, 0.801, 0.802]
    assert R.fmt(np.mean(phi2), np.std(phi2, ddof=1)) in md
    assert "| packings | 3 | 3 |" in md
    # moduli and speeds: c_l per pressure, c_tof from the height series, ratio, exponents
    for p in PRESSURES:
        cl = [2.0 * p ** (1 / 6) * (1 + 0.001 * s) for s in range(3)]
        assert R.fmt(np.mean(cl), np.std(cl, ddof=1)) in md
    assert "0.2345 ± 0.0012" in md and "0.4811 ± 0.002" in md
    assert "c_tof/c_ℓ" in md
    assert R.fmt(0.2345 / np.mean([2.0 * 1e-6 ** (1 / 6) * (1 + 0.001 * s) for s in range(3)]),
                 None)[:5] in md
    alpha_tof = math.log(0.4811 / 0.2345) / math.log(100)
    assert R.fmt(alpha_tof) in md
    assert "α = 0.1667" in md  # the Hertz exponent from the lattice formula
    # gamma and alpha with uncertainties, against the chain's exact values
    assert "0.8123 ± 0.021" in md and "0.4567 ± 0.034" in md and "0.9712 ± 0.005" in md
    assert "| initial condition A | 0.6667 | 0.3333 |" in md
    assert "| initial condition B | 1 | 0.3333 |" in md
    # the lattice against the formula (frictional, from the config)
    c = lattice_speed(1e-5, friction=True)
    assert R.fmt(c) in md and R.fmt(0.4321 / c) in md
    # the sweep's numbers as given
    assert "### frictional2d\n\n| exponent | value | pressures |\n|---|---|---|\n" \
           "| alpha_tof | 0.2468 ± 0.013 | 2 |" in md
    # figures: relative links, captions, PDF twin
    assert "![Chain signals against the Airy shape" in md
    assert "](../" in md and "figures/airy_A.png)" in md and "figures/exponents.png)" in md
    assert "airy_A.pdf" in md
    # HTML twin
    n_tables = sum(line.startswith("|---") for line in md.splitlines())
    assert n_tables >= 8 and html.count("<table>") == n_tables and "<img src=" in html
    assert "0.8123 ± 0.021" in html


def test_sweep_speeds_reads_pressure_sweep(inputs):
    d = R.sweep_speeds(json.loads((inputs / "sweep" / "frictional2d.json").read_text()))
    assert np.allclose(d["pressure"], PRESSURES) and np.allclose(d["c_tof"], [0.2345, 0.4811])
    assert np.all(d["c_l"] > 0) and np.all(d["c_t"] > 0)


def test_report_bad_input(inputs, tmp_path):
    out = tmp_path / "index.md"
    res = CliRunner().invoke(main, ["report", "--summaries", str(tmp_path / "missing"), "-o", str(out)])
    assert res.exit_code != 0 and "no such file" in res.output
    assert not out.exists()
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    res = CliRunner().invoke(main, ["report", "--heights", str(bad), "-o", str(out)])
    assert res.exit_code != 0 and "not a JSON file" in res.output and not out.exists()
    res = CliRunner().invoke(main, ["report", "-o", str(tmp_path / "index.txt")])
    assert res.exit_code != 0 and ".md" in res.output


def test_markdown_to_html():
    h = R.markdown_to_html("# T\n\n- a **b**\n\n| x | y |\n|---|---|\n| 1 < 2 | `c` |\n\n"
                           "![cap](f.png)\n")
    assert "<h1>T</h1>" in h and "<li>a <strong>b</strong></li>" in h
    assert "<td>1 &lt; 2</td>" in h and "<code>c</code>" in h and '<img src="f.png" alt="cap">' in h


def test_report_from_single_files(inputs, tmp_path):
    """As the workflow calls it: one flag per file; scenes from the path layout."""
    args = ["report", "--config", str(inputs / "config.yaml")]
    for f in sorted((inputs / "summary").rglob("*.json")):
        args += ["--summaries", str(f)]
    for f in sorted((inputs / "heights").rglob("*.json")):
        args += ["--heights", str(f)]
    for f in sorted((inputs / "figures").glob("*.png")):
        args += ["--figures", str(f)]
    out = tmp_path / "index.md"
    res = CliRunner().invoke(main, args + ["-o", str(out)])
    assert res.exit_code == 0, res.output
    md = out.read_text()
    assert "### frictional2d" in md and "| lattice_frictional | 0.5 | 1e-05 |" in md
    assert "| packings | 3 | 3 |" in md and "figures/exponents.png)" in md
