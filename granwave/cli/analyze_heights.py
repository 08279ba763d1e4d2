"""``granwave analyze heights``: speeds and scaling of the front over container heights."""

from __future__ import annotations

import click

from ..params import HeightsParams
from .common import echo_json, echo_table, options_from, params_from, stage


@click.command()
@click.argument("signals", nargs=-1, type=click.Path(dir_okay=False))
@options_from(HeightsParams, json=True)
@stage
def heights(signals, as_json, **options):
    """Arrival times, speeds and exponents over a container-height series (docs/method.md §9).

    SIGNALS are signal files (from `granwave propagate`) of containers of
    several heights L (attribute `height`, bottom wall to top wall, in d),
    one or more packings per height, all at one pressure and one initial
    condition. Heights closer than --group-tolerance form one nominal
    height; every signal is its own point in the fits, per-height means are
    listed.

    Reported: arrival times of the 10% leading edge, the first peak and the
    first zero crossing against L; speeds c = 1/slope (sqrt(E*/rho)) with
    one-standard-error uncertainties: c_tof (10% edge), c_peak, c_zero between
    the --edge-heights, and the same over all heights (*_all); gamma and chi
    from |A| ~ L^-gamma and W ~ L^chi (W = t_zero - t_lead10), and the local
    exponents between consecutive heights. Uncertainties of a fit through
    exactly two points are undetermined (null).
    """
    from .. import api
    from ..errors import InputError
    from ..io.files import read_signal

    params = params_from(HeightsParams, options)
    if not signals:
        raise InputError("no signal files given")
    res = api.heights([read_signal(p) for p in signals], params, labels=list(signals))
    if as_json:
        echo_json(res)
        return
    scalars = {k: v for k, v in res.items()
               if k not in ("per_height", "samples", "heights_local", "gamma_local", "chi_local",
                            "front_options")}
    echo_table(scalars, title=f"height series: {res['n_signals']} signals, {res['n_heights']} heights")
    ph = res["per_height"]
    click.echo("  per nominal height (means):")
    click.echo(f"  {'L':>10} {'n':>4} {'t_lead10':>12} {'t_peak':>12} {'t_zero':>12} "
               f"{'|A|':>12} {'W':>12}")
    for i in range(len(ph["height"])):
        click.echo(f"  {ph['height'][i]:10.4g} {int(ph['count'][i]):4d} {ph['t_lead10'][i]:12.6g} "
                   f"{ph['t_peak'][i]:12.6g} {ph['t_zero'][i]:12.6g} {ph['amplitude'][i]:12.6g} "
                   f"{ph['width'][i]:12.6g}")
    click.echo("  local exponents between consecutive heights:")
    for h, g, a in zip(res["heights_local"], res["gamma_local"], res["chi_local"]):
        click.echo(f"  L={h:10.4g}  gamma={g:.6g}  chi={a:.6g}")
