"""``granwave analyze damping``: coherent amplitude and tail rms against ζ (docs/method.md §11)."""

import click

from ..params import DampingParams
from .common import echo_json, options_from, params_from, stage


@click.command()
@click.argument("signals", nargs=-1, required=True, type=click.Path(dir_okay=False))
@options_from(DampingParams, json=True)
@stage
def damping(signals, as_json, **options):
    """Damping series: for SIGNALS of one packing (`propagate --method dem --damping ZETA`),
    the first-pulse amplitude and width and the tail rms, by contact damping ζ.

    The tail window is the same for every ζ, so that a broader damped pulse does not
    move it. Signals need the attribute `damping`.
    """
    from .. import api
    from ..io.files import read_signal

    params = params_from(DampingParams, options)
    rows = api.damping([read_signal(path) for path in signals], params, labels=list(signals))
    if as_json:
        echo_json(rows)
        return
    click.echo(f"{'zeta':>8} {'amplitude':>12} {'width':>10} {'tail rms':>12} {'tail/A':>10}")
    for r in rows:
        click.echo(f"{r['damping']:8.3g} {r['amplitude']:12.5g} {r['width']:10.4g} "
                   f"{r['tail_rms']:12.5g} {r.get('tail_rms_over_amplitude', float('nan')):10.4g}")
