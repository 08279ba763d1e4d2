"""``granwave analyze damping``: coherent amplitude and tail rms against ζ (SPEC §11)."""

import click

from .common import FiniteFloat, echo_json, json_option, stage


@click.command()
@click.argument("signals", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--tail-start", type=FiniteFloat(min=0.0), default=None,
              help="Start of the tail window (time units d/sqrt(E*/rho)); default: the least "
                   "damped signal's first zero crossing plus one pulse width.")
@json_option
@stage
def damping(signals, tail_start, as_json):
    """Damping series: for SIGNALS of one packing (`propagate --method dem --damping ZETA`),
    the first-pulse amplitude and width and the tail rms, by contact damping ζ.

    The tail window is the same for every ζ, so that a broader damped pulse does not
    move it. Signals need the attribute `damping`.
    """
    from ..dem.pulse import damping_table
    from ..io.files import read_signal

    rows = damping_table([read_signal(path) for path in signals], tail_start=tail_start,
                         labels=list(signals))
    if as_json:
        echo_json(rows)
        return
    click.echo(f"{'zeta':>8} {'amplitude':>12} {'width':>10} {'tail rms':>12} {'tail/A':>10}")
    for r in rows:
        click.echo(f"{r['damping']:8.3g} {r['amplitude']:12.5g} {r['width']:10.4g} "
                   f"{r['tail_rms']:12.5g} {r.get('tail_rms_over_amplitude', float('nan')):10.4g}")
