"""``granwave analyze ensemble``: average signal and rms deviation over packings."""

from __future__ import annotations

import click

from ..params import EnsembleParams
from .common import echo_json, echo_table, options_from, output_option, params_from, stage


@click.command()
@click.argument("signals", nargs=-1, type=click.Path(dir_okay=False))
@output_option
@options_from(EnsembleParams, json=True)
@stage
def ensemble(signals, output, as_json, **options):
    """Average signal and rms deviation over independent packings (docs/method.md §9).

    SIGNALS are signal files (from `granwave propagate`) of one pressure, one
    initial condition, one kind of system and one container height (within
    5 %); a mix is refused. Writes OUTPUT (schema granwave.ensemble):
    ensemble/time, ensemble/mean = (1/n) sum F_i and ensemble/rms =
    sqrt((1/n) sum (F_i - mean)^2), forces in E* d^2, times in
    d/sqrt(E*/rho). Signals with identical sample times are averaged as they
    are; otherwise all are linearly interpolated onto a uniform grid over the
    overlap of their time ranges with the finest step among them.

    Prints the mean, std, standard error and count of every front feature
    over the signals, and the front features of the mean signal.
    """
    from .. import api
    from ..analysis.ensemble import write_ensemble
    from ..errors import InputError
    from ..io.files import check_writable, read_signal

    params = params_from(EnsembleParams, options)
    if not signals:
        raise InputError("no signal files given")
    check_writable(output)
    ens, summary = api.ensemble([read_signal(p) for p in signals], params, labels=list(signals))
    write_ensemble(output, ens, summary.pop("attrs"))
    summary["output"] = str(output)
    if as_json:
        echo_json(summary)
        return
    head = {k: v for k, v in summary.items() if k not in ("front_stats", "front_of_mean", "front_options")}
    echo_table(head, title=f"ensemble of {summary['n_signals']} signals -> {output}")
    click.echo(f"  {'feature':<12} {'mean':>12} {'std':>12} {'sem':>12} {'n':>5} {'of mean':>12}")
    for key, st in summary["front_stats"].items():
        om = summary["front_of_mean"].get(key, float("nan"))
        click.echo(f"  {key:<12} {st['mean']:12.6g} {st['std']:12.6g} {st['sem']:12.6g} "
                   f"{st['count']:5d} {float(om):12.6g}")
