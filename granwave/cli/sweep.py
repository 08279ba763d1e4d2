"""``granwave pressure-sweep``: per-pressure statistics and speed exponents from summaries."""

from __future__ import annotations

import click

from ..params import SweepParams
from .common import echo_json, echo_table, options_from, output_option, params_from, stage


#: The tables pressure-sweep writes beside its output, as <stem>_<name> (analysis.sweep.write_tables).
TABLE_FILES = tuple(f"{t}.{ext}" for t in ("statics", "moduli", "speeds") for ext in ("md", "csv"))


@click.command("pressure-sweep")
@click.argument("summaries", nargs=-1, type=click.Path(dir_okay=False))
@output_option
@click.option("--heights", "heights_files", multiple=True, type=click.Path(dir_okay=False),
              help="A height-series JSON (`granwave analyze heights --json`) giving c_tof, "
                   "c_peak, c_zero at its pressure; repeatable. Such files are also recognised "
                   "among SUMMARIES.")
@click.option("--tables", "tables_dir", type=click.Path(file_okay=False), default=None,
              help="Folder for the Markdown and CSV tables (created if missing; default: "
                   "beside the output).")
@options_from(SweepParams, json=True)
@stage
def pressure_sweep(summaries, heights_files, output, tables_dir, as_json, **options):
    """Pressure dependence of the speeds and of the statics (docs/method.md §10).

    SUMMARIES are per-sample summary JSON files (layout: docs/summaries.md;
    a file may also hold a list of summaries); height-series JSON files
    (--heights) supply c_tof, c_peak, c_zero at their pressure, replacing
    any `tof` section of the summaries there. Samples are grouped by
    pressure; every numeric quantity gets mean, std, standard error and
    count per pressure. c_tof (analyze heights), c_l and c_t (analyze
    moduli), in sqrt(E*/rho), are fitted as c ~ p^kappa through the
    per-pressure means (kappa_tof, kappa_l, kappa_t, one standard error),
    beside the expected 1/6, the triangular-lattice formulas (frictionless
    and frictional) and c_tof/c_l. Pressures in E*.

    Writes OUTPUT (schema granwave.sweep) and, into --tables (default: the
    output's folder), <stem>_statics, <stem>_moduli and <stem>_speeds as
    .md and .csv.
    """
    from pathlib import Path

    from .. import api
    from ..analysis.sweep import load_inputs, write_sweep, write_tables
    from ..errors import InputError
    from ..io.files import check_writable

    params = params_from(SweepParams, options)
    if not summaries and not heights_files:
        raise InputError("no summary files given")
    out = check_writable(output)
    folder = Path(tables_dir) if tables_dir is not None else (out.parent if str(out.parent) else Path("."))
    if not folder.is_dir() and not folder.parent.is_dir():
        raise InputError(f"tables folder {folder}: its parent folder does not exist")
    if folder.is_dir():  # every table checked before any work (all are written, or none)
        for name in TABLE_FILES:
            check_writable(folder / f"{out.stem}_{name}")
    sums, series = load_inputs([*summaries, *heights_files])
    res = api.pressure_sweep(sums, params, height_series=series)
    folder.mkdir(exist_ok=True)  # only now that the inputs are known to be good
    written = write_tables(res, folder, prefix=out.stem)
    write_sweep(out, res, params.record({"sources": "\n".join([*summaries, *heights_files]),
                                         "poisson": params.poisson}))
    res["output"], res["tables"] = str(out), written
    if as_json:
        echo_json(res)
        return
    head = {k: v for k, v in res.items()
            if k not in ("per_pressure", "quantities", "pressures", "fit_notes", "tables")}
    echo_table(head, title=f"pressure sweep: {res['n_summaries']} summaries, "
                           f"{res['n_height_series']} height series, "
                           f"{len(res['pressures'])} pressures -> {out}")
    for note in res["fit_notes"]:
        click.echo(f"  note: {note}")
    click.echo(f"  {'p':>10} {'n':>4} {'c_tof':>11} {'c_l':>11} {'c_t':>11} {'tof/l':>8} "
               f"{'lat μ=0':>10} {'lat μ>0':>10}")
    for r in res["per_pressure"]:
        click.echo(f"  {r['pressure']:10.4g} {r['count']:4d} {r['c_tof']:11.5g} {r['c_l']:11.5g} "
                   f"{r['c_t']:11.5g} {r['c_tof_over_c_l']:8.4g} {r['lattice_frictionless']:10.5g} "
                   f"{r['lattice_frictional']:10.5g}")
    click.echo("  tables: " + ", ".join(written))
