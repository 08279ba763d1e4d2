"""`granwave report`: from small synthetic inputs the report holds every table,
every figure link and the numbers of the inputs (none typed in), one row per
scene, pressure and container height, units and ensemble sizes stated,
diagnostics apart, and no empty table."""

from __future__ import annotations

import json
import math
import re

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
TALL, SHORT, TINY = 25.0, 8.1, 5.0  # container heights of the frictional scene
N_TALL = 5  # packings at the tall height (5: mean ± error); 2 at the short one (a range)


def c_l_of(p, seed, height):
    return 2.0 * p ** (1 / 6) * (1 + 0.001 * seed) * (1 + 0.01 * (height == SHORT))


def summary(p, seed, height=TALL, statics=True):
    """A per-sample summary (docs/summaries.md) with seed- and height-dependent numbers."""
    x = 0.001 * seed + (0.05 if height == SHORT else 0.0)
    c_l = c_l_of(p, seed, height)
    out = {"pressure": p, "seed": seed, "kind": "disordered", "height": height + 0.01 * seed,
           "friction": 0.5,
           "moduli": {"C11": 0.01 + x, "C12": 0.005, "C22": 0.011, "C33": 0.003, "c_l": c_l,
                      "c_t": 0.5 * c_l, "phi3_star": 0.53 + x, "dim": 2, "n_dof": 1800 + seed},
           "front": {"t_lead10": 100.0, "t_peak": 110.0, "amplitude": 0.02, "t_zero": 120.0,
                     "width": 20.0}}
    if statics:
        out["statics"] = {"phi2": 0.80 + x, "phi3": 0.54 + x, "phi3_star": 0.53 + x,
                          "z_star": 3.4 + x, "rattler_fraction": 0.1, "mean_force_over_p": 1.0 + x,
                          "Z2": 1.5, "Z3": 3.1, "F2": 0.51, "F2_strong": 0.55,
                          "stress_ratio": 0.9 + x, "layer": 3.0, "min_contacts": 2,
                          "max_force_residual": 1e-7 * (1 + seed), "piston_balance": -1e-8}
    return out


def lattice_summary(p, rows):
    h = rows * math.sqrt(3) / 2
    return {"pressure": p, "seed": None, "kind": "lattice", "height": h, "friction": 0.5,
            "statics": {"phi2": 0.9069, "z_star": 6.0, "rattler_fraction": 0.0, "layer": 3.0},
            "moduli": {"C11": 0.016 + 1e-4 * rows, "C12": 3e-35 * rows, "C22": 0.0166,
                       "C33": 0.0056, "c_l": 0.163, "c_t": 0.095}}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("results")

    def put(scene, p, size, seed, obj):
        d = root / "summary" / scene / f"p{p:g}" / size
        d.mkdir(parents=True, exist_ok=True)
        (d / f"s{seed}.json").write_text(json.dumps(obj))

    for p in PRESSURES:
        for seed in range(N_TALL):
            put("frictional2d", p, "h25", seed, summary(p, seed))
        for seed in range(2):
            put("frictional2d", p, "h8", seed, summary(p, seed, SHORT))
        put("frictional2d", p, "h5", 0, summary(p, 0, TINY, statics=False))
    for seed in range(2):
        put("frictionless2d", 1e-4, "h25", seed, {**summary(1e-4, seed), "friction": 0.0})
    for rows in (10, 29):
        put("lattice_frictional", 1e-5, f"r{rows}", 0, lattice_summary(1e-5, rows))
    hd = root / "heights"
    heights = {
        ("frictional2d", 1e-6): {"c_tof": 0.2345, "c_tof_err": 0.0012, "c_peak": 0.2222,
                                  "c_zero": 0.2111, "gamma": 0.8123, "gamma_err": 0.021,
                                  "chi": 0.4567, "chi_err": 0.034, "edge_heights": [SHORT, TALL]},
        ("frictional2d", 1e-4): {"c_tof": 0.4811, "c_tof_err": 0.002, "c_peak": 0.4711,
                                  "c_zero": 0.4611, "gamma": 0.7911, "gamma_err": 0.02,
                                  "chi": 0.4412, "chi_err": 0.03, "edge_heights": [SHORT, TALL]},
        ("lattice_frictional", 1e-5): {"c_tof": 0.4321, "c_tof_err": None, "c_peak": 0.4012,
                                        "c_zero": 0.3999, "edge_heights": [8.66, 25.1]},
        ("chain_B", 1.0): {"ic": "B", "gamma": 0.9712, "gamma_err": 0.005, "alpha": 0.3401,
                           "alpha_err": 0.002, "n_aliased": 2},  # a file of before the rename: alpha = χ
        # two heights only: its slope's ± (the scatter of two packings per height) is not shown
        ("frictionless3d", 1e-4): {"c_tof": 0.31, "c_peak": 0.29, "c_zero": 0.28, "gamma": 1.5123, "gamma_err": 0.0101, "chi": 0.7012, "chi_err": 0.021,
                                   "n_heights": 2, "n_signals": 4},
    }
    for (scene, p), obj in heights.items():
        (hd / scene).mkdir(parents=True, exist_ok=True)
        L = [8.0, 8.0, 16.0, 16.0, 25.0, 25.0]
        obj = {"pressure": p, "ic": obj.get("ic", "A"), "n_signals": 6, "n_heights": 3, **obj,
               "samples": [{"height": h, "t_lead10": h / 0.2, "t_peak": h / 0.19, "t_zero": h / 0.18,
                            "amplitude": h ** -0.8, "width": h ** 0.45} for h in L]}
        (hd / scene / f"p{p:g}.json").write_text(json.dumps(obj))
    sweep = root / "sweep" / "frictional2d.json"
    sweep.parent.mkdir()
    from granwave.analysis.sweep import pressure_sweep
    from granwave.io.files import jsonable

    sums = [summary(p, s) for p in PRESSURES for s in range(N_TALL)]
    for s in sums:  # a height series per pressure, copied into its samples' summaries
        s["tof"] = {"c_tof": 0.2345 if s["pressure"] < 1e-5 else 0.4811}
    res = pressure_sweep(sums)
    res["kappa_tof"], res["kappa_tof_err"] = 0.2468, 0.0135  # stands out in the report
    sweep.write_text(json.dumps(jsonable(res)))
    figs = root / "figures"
    figs.mkdir()
    from granwave import figures

    figures.chain_airy(figs / "airy_A.png", n_balls=(10, 20), pdf=True)
    figures.amplitude_width({"x": {"height": [8, 25], "amplitude": [1, 0.5], "width": [1, 2]}},
                            figs / "exponents.png")
    cfg = root / "config.yaml"
    cfg.write_text("name: synthetic-test\ndisordered:\n  frictional2d:\n    friction: 0.5\n"
                   "  frictionless2d:\n    friction: 0.0\n"
                   "lattices:\n  lattice_frictional:\n    friction: 0.5\nchains:\n  chain_B:\n"
                   "    ic: B\n")
    return root


def run_report(root, out):
    args = ["report", "--config", str(root / "config.yaml"), "--summaries", str(root / "summary"),
            "--heights", str(root / "heights"), "--sweep", str(root / "sweep" / "frictional2d.json"),
            "--figures", str(root / "figures"), "-o", str(out)]
    return CliRunner().invoke(main, args)


@pytest.fixture(scope="module")
def page(inputs, tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "report" / "index.md"
    res = run_report(inputs, out)
    assert res.exit_code == 0, res.output
    return out.read_text(), out.with_suffix(".html").read_text()


def section(md: str, heading: str) -> str:
    start = md.index(heading)
    nxt = md.find("\n## ", start + 1)
    return md[start:nxt if nxt > 0 else None]


def rows_of(text: str, first: str) -> list[list[str]]:
    """Cells of the table rows of ``text`` whose first cell is ``first``."""
    return [[c.strip() for c in line.strip().strip("|").split("|")] for line in text.splitlines()
            if line.startswith(f"| {first} |")]


def test_report_contents(page):
    md, html = page
    assert "synthetic-test" in md and "git revision" in md
    for heading in ("## Statics per pressure and container height",
                    "## Elastic moduli per pressure and container height",
                    "## Sound speeds against pressure", "## Front scaling with distance",
                    "## Triangular lattices against the formula", "## Pressure-sweep fits",
                    "## Provenance and numerical checks", "## Figures"):
        assert heading in md
    # the findings come first, then the symbols, then the tables (each one under its anchor)
    assert md.index("## Findings") < md.index("## Symbols") < md.index("## Statics per pressure")
    assert '<a id="exponents"></a>' in md and "[table](#exponents)" in md
    # gamma and chi with uncertainties, against the chain's exact values
    assert "0.81 ± 0.02" in md and "0.46 ± 0.03" in md and "0.971 ± 0.005" in md
    assert "| initial condition A | 0.6667 | 0.3333 |" in md
    assert "| initial condition B | 1 | 0.3333 |" in md
    # aliased signals are marked, and the page says what that means
    assert "| chain_B | chains | 1 | B | 6 at 3 (2 aliased) | 8 … 25 |" in md  # its old `alpha` read as χ
    assert "| frictionless3d | disordered | 0.0001 | A | 4 at 2 | 8 … 25 | 1.512 | 0.7012 |" in md
    assert "| 0.971 ± 0.005 | 0.340 ± 0.002 |" in md
    assert 'Rows marked "aliased": 2 signals in 1 height series were sampled' in md
    # the lattice against the formula (frictional, from the config)
    c = lattice_speed(1e-5, friction=True)
    assert R.fmt(c) in md and R.fmt(0.4321 / c) in md
    # the sweep's numbers as given
    assert "### frictional2d\n\n| exponent | value [95 %] | pressures |\n|---|---|---|\n" \
           "| κ of c_tof (`kappa_tof`) | 0.247 ± 0.013 | 2 |" in md
    # figures: relative links, captions, PDF twin
    assert "![Chain signals against the Airy shape" in md
    assert "](../" in md and "figures/airy_A.png)" in md and "figures/exponents.png)" in md
    assert "airy_A.pdf" in md
    # HTML twin, rendered by the markdown package: every table, the images
    n_tables = sum(line.startswith("|---") for line in md.splitlines())
    assert n_tables >= 12 and html.count("<table>") == n_tables and "<img " in html
    assert "0.81 ± 0.02" in html


def test_statics_one_row_per_pressure_and_height(page):
    md, _ = page
    statics = section(md, "## Statics per pressure and container height")
    for p in PRESSURES:
        # five packings: mean ± sample standard deviation; two: their range, not a ± of two
        phi2 = [summary(p, s, TALL)["statics"]["phi2"] for s in range(N_TALL)]
        L = np.mean([TALL + 0.01 * s for s in range(N_TALL)])
        row = f"| {p:.3g} | {L:.3g} | {N_TALL} | {R.fmt(np.mean(phi2), np.std(phi2, ddof=1))} |"
        assert row in statics, row
        phi2 = [summary(p, s, SHORT)["statics"]["phi2"] for s in range(2)]
        L = np.mean([SHORT + 0.01 * s for s in range(2)])
        row = f"| {p:.3g} | {L:.3g} | 2 | {R.fmt_range(min(phi2), max(phi2))} |"
        assert row in statics, row
        pooled = [summary(p, s, h)["statics"]["phi2"] for h, n in ((TALL, N_TALL), (SHORT, 2))
                  for s in range(n)]
        assert R.fmt(np.mean(pooled), np.std(pooled, ddof=1)) not in md  # heights never pooled
    # the rattler fraction is the same in every packing: no "± 0"
    assert f"0.1 (all {N_TALL} equal)" in statics and "± 0 " not in md and "± 0 |" not in md
    # the short containers have no bulk: they are not in the table, and the page says why
    assert f"| {PRESSURES[0]:.3g} | {TINY:.3g} |" not in statics.split("Packings not in")[0]
    assert "no statics: the container has no bulk (L ≤ 2 l + 1 with wall layers l = 3 d̄)" in statics
    # units and what n counts
    assert "p [E*]" in statics and "L [d̄]" in statics and "n: the packings in the row" in statics


def test_diagnostics_apart_and_fixed_values_not_statistics(page):
    md, _ = page
    for name in ("## Statics per pressure", "## Elastic moduli per pressure"):
        header = rows_of(section(md, name), "p")[0]
        for diag in ("layer", "min_contacts", "max_force_residual", "piston_balance", "dim", "n_dof"):
            assert not any(diag in h for h in header), (name, diag)
    prov = section(md, "## Provenance and numerical checks")
    prov = prov[prov.index("### frictional2d"):]
    header = rows_of(prov, "diagnostic (section)")[0]  # one row per diagnostic, a column per pressure
    col = header.index(f"p = {1e-4:.3g} (n = {N_TALL + 3})")
    assert rows_of(prov, "`layer` (statics)")[0][col] == "3"
    assert rows_of(prov, "`dim` (moduli)")[0][col] == "2"
    assert rows_of(prov, "`max_force_residual` (statics)")[0][col] == "1e-07 … 5e-07"  # a range
    assert "±" not in prov


def test_lattice_rows_per_size_and_zero_within_precision(page):
    md, _ = page
    moduli = section(md, "## Elastic moduli per pressure")
    lat = moduli[moduli.index("### lattice_frictional"):]
    rows = rows_of(lat.split("Local")[0].split("###")[1], f"{1e-5:.3g}")
    assert [r[1] for r in rows] == [f"{10 * math.sqrt(3) / 2:.3g}", f"{29 * math.sqrt(3) / 2:.3g}"]
    assert all(r[2] == "1" and "±" not in " ".join(r) for r in rows)
    assert all(r[4] == "0 (< 1e-12 × max Cij)" for r in rows)  # C12 = 3e-35, 9e-34
    assert R.fmt(0.016 + 1e-4 * 29) in rows[1]


def test_speeds_one_kind_of_error_bar(page):
    md, _ = page
    speeds = section(md, "## Sound speeds against pressure")
    assert "Every ± is one standard error" in speeds and "± sample standard deviation" not in speeds
    for p in PRESSURES:
        cl = [c_l_of(p, s, TALL) for s in range(N_TALL)]
        sem = np.std(cl, ddof=1) / np.sqrt(N_TALL)
        assert R.fmt(np.mean(cl), sem) in speeds
    # c_tof from the height series, against c_ℓ of the taller edge height
    assert "0.2345 ± 0.0012" in speeds and "0.481 ± 0.002" in speeds
    cl = np.mean([c_l_of(1e-6, s, TALL) for s in range(N_TALL)])
    row = rows_of(speeds, f"{1e-6:.3g}")
    tof_row = [r for r in row if r[3] == "0.2345 ± 0.0012"][0]
    assert tof_row[1] == f"{SHORT:.3g}–{TALL:.3g}" and tof_row[7].startswith(R.fmt(0.2345 / cl)[:5])
    alpha_tof = math.log(0.4811 / 0.2345) / math.log(100)
    assert R.fmt(alpha_tof) in speeds
    assert "κ = 0.1667" in speeds  # the Hertz exponent from the lattice formula


def test_no_empty_tables(page):
    md, _ = page
    # a scene with one height: no time-of-flight table and no exponents row, one line why
    fl = section(md, "## Sound speeds against pressure")
    fl = fl[fl.index("### frictionless2d"):]
    assert "No time-of-flight speeds: the scene has 1 container height" in fl
    assert "c_tof" not in fl.split("No time-of-flight")[0]
    assert "No γ or χ for frictionless2d: no height series of theirs" in md
    # no table row whose numbers are all missing
    for line in md.splitlines():
        if line.startswith("| ") and not line.startswith("|---"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            assert any(c not in ("—", "") for c in cells[3:]) or len(cells) <= 3, line


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
    res = CliRunner().invoke(main, ["report", "--summaries", str(bad), "-o", str(tmp_path / "i.txt")])
    assert res.exit_code != 0 and ".md" in res.output


@pytest.mark.parametrize("args", [[], ["--config", "CFG"], ["--summaries", "EMPTY"]])
def test_report_refuses_nothing_to_report(inputs, tmp_path, args):
    empty = tmp_path / "empty"
    empty.mkdir()
    args = [str(inputs / "config.yaml") if a == "CFG" else str(empty) if a == "EMPTY" else a
            for a in args]
    out = tmp_path / "index.md"
    res = CliRunner().invoke(main, ["report", *args, "-o", str(out)])
    assert res.exit_code == 2, res.output
    assert res.output.strip().count("\n") == 0 and "nothing to report" in res.output
    assert not out.exists() and not out.with_suffix(".html").exists()
    with pytest.raises(R.build_report.__globals__["InputError"], match="nothing to report"):
        R.build_report()


def test_markdown_to_html():
    h = R.markdown_to_html("# T\n\n- a **b**\n\n| x | y |\n|---|---|\n| 1 < 2 | `c` |\n\n"
                           "![cap](f.png)\n", title="a <title>")
    assert "<h1>T</h1>" in h and re.search(r"<li>a <strong>b</strong></li>", h)
    assert "<td>1 &lt; 2</td>" in h and "<code>c</code>" in h and '<img alt="cap" src="f.png"' in h
    assert "<title>a &lt;title&gt;</title>" in h and h.count("<table>") == 1


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
    assert f"| {1e-4:.3g} | {TALL:.3g} | {N_TALL} |" in md and "figures/exponents.png)" in md


def test_sweep_without_fits_is_one_line():
    from granwave.report.tables import sweep_table

    obj = {"kappa_tof": None, "kappa_tof_err": None, "kappa_tof_n": 0, "kappa_l": None,
           "fit_notes": ["kappa_tof: c_tof known at 1 pressure(s), need 2"]}
    assert sweep_table(obj) == ["No exponent fitted: kappa_tof: c_tof known at 1 pressure(s), "
                                "need 2.", ""]
    rows = sweep_table({"kappa_tof": 0.2, "kappa_tof_err": 0.01, "kappa_tof_n": 4, "kappa_l": None})
    assert rows[2] == "| κ of c_tof (`kappa_tof`) | 0.200 ± 0.010 | 4 |" and len(rows) == 4  # no "—" row for kappa_l
    # a file of before the rename (alpha_*) reads the same
    old = sweep_table({"alpha_tof": 0.2, "alpha_tof_err": 0.01, "alpha_tof_n": 4, "alpha_l": None})
    assert old[2] == rows[2] and len(old) == 4


def test_findings_first_with_references_and_verdicts(page):
    md, _ = page
    find = section(md, "## Findings")
    assert "What was run" in find and "frictional2d" in find
    # the sweep's κ_tof (0.247 ± 0.013 in the fixture) against 1/6: 6σ off, and why
    row = [r for r in rows_of(find, "pressure exponent κ_tof of c_tof (c ∝ p^κ), frictional2d")][0]
    assert row[1] == "0.247 ± 0.013" and row[3].startswith("1/6 = 0.1667")
    assert row[5].startswith("differs by 6σ: a fixed network gives 1/6") and row[6] == "[table](#sweeps)"
    # the estimator's worth: "not validated" without a truth-suite record (never a typed number)
    assert row[4] in ("not validated",) or row[4].startswith(("validated:", "biased:", "undercovered:"))
    # moduli against the affine effective medium: five packings at the tall height, a ±
    em = [r for r in find.splitlines() if r.startswith("| longitudinal modulus") and "frictional2d" in r]
    assert em and "±" in em[0].split("|")[2]
    # a two-height series: no ± and no σ
    two = [r for r in find.splitlines() if r.startswith("| amplitude exponent γ, frictionless3d")][0]
    assert "| 1.51 |" in two and "two heights, few packings: no σ" in two


def test_every_symbol_defined_once(page):
    """The generated page uses no symbol its symbol table lacks, and the table defines each
    once (the figures' labels: tests/figure_rules.py)."""
    from granwave.report.symbols import duplicates, undefined_symbols

    md, _ = page
    assert not duplicates()
    assert not undefined_symbols(md), sorted(undefined_symbols(md))
    table = section(md, "## Symbols")
    spellings = [f.strip() for line in table.splitlines() if line.startswith("| ") and "---" not in line
                 for f in line.strip("|").split("|")[0].replace("\\|", "|").split(", ")][1:]
    assert len(spellings) == len(set(spellings)) and "κ" in spellings and "χ" in spellings
    # the checker does fail: a symbol nobody defined, and the old width exponent δ
    assert undefined_symbols("with ν_x = 3 and W ∝ L^δ") == {"ν_x", "δ"}


def test_timings_give_the_run_s_cpu_time(inputs, tmp_path):
    """--timings: the CPU time of the first page is the sum of the timing tables' cpu_s."""
    t = tmp_path / "timings"
    (t / "analyses").mkdir(parents=True)
    (t / "batch_0.tsv").write_text("scene\tstage\tcpu_s\twall_s\nx\tpacking\t1.25\t2.5\nx\tlinear\t0.5\t1.0\n")
    (t / "analyses" / "a.tsv").write_text("stage\tcpu_s\twall_s\nheights\t2.0\t3.0\n")
    out = tmp_path / "index.md"
    res = CliRunner().invoke(main, ["report", "--summaries", str(inputs / "summary"), "--timings", str(t),
                                    "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "- CPU time: 4 CPU-s over 3 stages (6 s wall)" in out.read_text()
    res = CliRunner().invoke(main, ["report", "--summaries", str(inputs / "summary"), "--timings",
                                    str(tmp_path / "none"), "-o", str(tmp_path / "j.md")])
    assert res.exit_code == 2 and "no such file or folder" in res.output


def test_every_number_on_the_page_follows_the_rule(page):
    """Every "value ± error" of the page as the number rule writes it (tests/figure_rules.py
    reads them back: the error to 1–2 significant digits, the value to the same decimals);
    the checker fails on the legends issue 62 found."""
    from figure_rules import number_problems

    md, _ = page
    assert not number_problems(md), number_problems(md)[:5]
    assert len(number_problems("p^0.164 ± 0.0058, δ = 0.600 ± 0.086")) == 2


def test_no_markup_from_file_names_or_text_reaches_the_html(tmp_path):
    """A figure whose file name is markup, a link with a script URL and raw HTML in the page:
    the HTML twin keeps the report's own tags (tables, links, images, anchors) and nothing else."""
    from granwave.report import build_report, write_report

    fig = tmp_path / "<img src=x onerror=alert(1)>.png"
    fig.write_bytes(b"")
    md = build_report(figures=[fig], out_dir=tmp_path)
    md += "\n[run](javascript:alert(2)) <script>alert(3)</script>\n\n| a | b |\n|---|--:|\n| 1 | 2 |\n"
    _, html_path = write_report(tmp_path / "r.md", md)
    page = html_path.read_text()
    from html.parser import HTMLParser

    seen = []

    class Elements(HTMLParser):
        def handle_starttag(self, tag, attrs):
            seen.append((tag, dict(attrs)))

    Elements().feed(page)
    assert not [t for t, a in seen if t == "script" or any(k.startswith("on") for k in a)]
    assert not [a for _, a in seen if any("javascript" in (v or "") for v in a.values())]
    assert ("a", {"id": "figures"}) in seen and ("td", {"align": "right"}) in seen
    assert [a for t, a in seen if t == "img" and a.get("src", "").endswith("onerror=alert(1)>.png")]


def test_shocks_cells_print_the_student_interval_and_ranges_under_five():
    # the shocks tables: mean [95 % interval] (Student, n − 1) over ≥ 5 packings, recomputed for a
    # record written before stat() gave ci95; the range (min … max) under 5 packings
    from scipy import stats as st

    from granwave.analysis.shocks_scene import stat
    from granwave.report.shocks import cell

    s = stat([1.0, 1.2, 1.4, 1.1, 1.3, 1.25, 1.15, 1.05, 1.35, 1.2])
    half = st.t.ppf(0.975, 9) * s["error"]
    text = f"{s['mean']:.2f} [{s['mean'] - half:.2f}, {s['mean'] + half:.2f}]"
    assert cell(s) == text
    old = {k: v for k, v in s.items() if k != "ci95"}
    assert cell(old) == text
    assert cell(stat([1.0, 1.3, 1.1, 1.2])) == "1 … 1.3"
    assert cell(stat([2.5])) == "2.5"
