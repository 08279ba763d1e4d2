"""``granwave report``: the study's report (results/report/index.md + index.html)."""

from __future__ import annotations

import click

from .common import output_path_option, quiet_option, stage


@click.command()
@output_path_option((".md",), help="The Markdown report; the HTML twin is written beside it (.html).")
@click.option("--config", "config", type=click.Path(dir_okay=False),
              help="Workflow config (YAML): its name, and the kind/friction of each scene.")
@click.option("--summaries", multiple=True, type=click.Path(),
              help="Per-sample summary JSON files or folders (searched recursively), e.g. "
                   "results/summary. The first folder level below a given folder is the scene.")
@click.option("--heights", multiple=True, type=click.Path(),
              help="`analyze heights --json` files or folders, e.g. results/heights "
                   "(results/heights/<scene>/p<p>.json).")
@click.option("--sweep", "sweeps", multiple=True, type=click.Path(dir_okay=False),
              help="`pressure-sweep --json` files (their scalar fits are listed).")
@click.option("--figures", multiple=True, type=click.Path(),
              help="Figure files or folders (every .png inside, linked relative to the report; "
                   "named <plot subcommand>[_suffix].png for a caption).")
@click.option("--damping", "damping_json", type=click.Path(dir_okay=False),
              help="`analyze damping --json` output: the damping-series table.")
@click.option("--continuum", multiple=True, type=click.Path(),
              help="`analyze continuum --json` and `analyze attenuation --json` files or folders "
                   "(results/continuum/<scene>/{front,attenuation}.json): the continuum section.")
@click.option("--shear", multiple=True, type=click.Path(),
              help="Shear-scene analyses (results/shear/<scene>/analysis.json, the workflow's "
                   "shear_analysis rule), files or folders: the shear section (docs/shear.md).")
@click.option("--shocks", multiple=True, type=click.Path(),
              help="Shocks-scene analyses (results/shocks/<scene>/analysis.json, `granwave analyze "
                   "shocks --json`), files or folders: the shocks section (docs/shocks.md).")
@click.option("--timings", multiple=True, type=click.Path(),
              help="The workflow's timing tables (results/timings/*.tsv), files or folders: the "
                   "run's CPU time on the first page.")
@click.option("--title", default="granwave report", show_default=True)
@quiet_option
@stage
def report(output, config, summaries, heights, sweeps, figures, damping_json, continuum, shear, shocks, timings,
           title, quiet):
    """Write the study's report: tables, fits and figures, every number computed
    from the inputs.

    \b
    Example (the workflow's last rule):
      granwave report --config config/config.yaml --summaries results/summary \\
        --heights results/heights --sweep results/sweep/frictional2d.json \\
        --figures results/figures -o results/report/index.md

    Contents: the findings first (what was run, its CPU time from --timings, one row per
    headline result against its reference with the estimator's validated bias and a verdict),
    the symbol table, then statics and moduli per scene, pressure and container height (mean ± std
    over n >= 5 packings, the range over fewer, units stated), a provenance table of diagnostics;
    c_l, c_t per height and c_tof, c_peak, c_zero per pressure (± one standard error) with fitted
    exponents kappa and c_tof/c_l; gamma and chi of every height series against the
    chain's exact values; lattice speeds against the formula of docs/method.md §12;
    the damping table; the continuum section (--continuum: speeds, c_tof/c_l and its
    approach, alpha(omega), c(omega), docs/continuum.md); the shear section (--shear: V_s,
    V_p, G_max against pressure, V_p/V_s and the effective Poisson ratio from waves and moduli, the pick
    table, docs/shear.md); the shocks section (--shocks: V/c0 against eps/delta0, the
    crossover strain against p, the strongly nonlinear exponent, docs/shocks.md); the sweep fits; every figure; the config name, the granwave
    version and git revision. Without any input it refuses (exit status 2).
    """
    from ..errors import InputError
    from ..io.files import check_name_length, check_target
    from ..report import build_report, collect_json, find_figures, load_config, write_report
    from pathlib import Path

    out = Path(output)  # its suffix is checked by stage() (output_path_option)
    cfg = load_config(config) if config else None  # recorded as an input first
    html = out.with_suffix(".html")  # the HTML twin, checked like -o before any work (the
    check_target(html)                # folder may be missing: write_report makes it)
    check_name_length(html)
    damping = []
    if damping_json:
        damping = collect_json([damping_json])[0][1]
        if not isinstance(damping, list):
            raise InputError(f"{damping_json}: expected the list printed by `analyze damping --json`")
    inputs = dict(summaries=collect_json(summaries), heights=collect_json(heights),
                  sweeps=collect_json(sweeps), figures=find_figures(figures),
                  continuum=collect_json(continuum), shear=_shear_analyses(shear),
                  shocks=_shear_analyses(shocks))
    if not (any(inputs.values()) or damping):
        refused = click.ClickException("nothing to report: give --summaries, --heights, --sweep, "
                                       "--figures or --damping (files, or folders that hold some)")
        refused.exit_code = 2  # bad usage, as click's own option errors
        raise refused
    md = build_report(**inputs,
                      out_dir=out.parent.resolve() if str(out.parent) else Path(".").resolve(),
                      config=cfg, config_path=config, title=title, damping=damping,
                      timings=_timing_tables(timings))
    for p in write_report(out, md, title=title):
        if not quiet:
            click.echo(f"wrote {p}", err=True)


def _timing_tables(paths):
    """The .tsv timing tables among ``paths`` (folders searched recursively)."""
    from pathlib import Path

    from ..errors import InputError

    files = []
    for p in map(Path, paths):
        if p.is_dir():
            files += sorted(p.rglob("*.tsv"))
        elif p.is_file():
            files.append(p)
        else:
            raise InputError(f"{p}: no such file or folder")
    return files


def _shear_analyses(paths):
    """The shear-scene analyses among ``paths`` (a folder such as results/shear also holds the
    per-packing records: only files named analysis.json are read)."""
    from pathlib import Path

    from ..report import collect_json

    files = []
    for p in paths:
        p = Path(p)
        files += sorted(p.rglob("analysis.json")) if p.is_dir() else [p]
    return collect_json([str(f) for f in files]) if files else []
