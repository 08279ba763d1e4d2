"""``granwave analyze heights``: speeds and scaling of the front over container heights."""

from __future__ import annotations

import math

import click

from .common import FiniteFloat, echo_json, echo_table, json_option, stage


class HeightPair(click.ParamType):
    """Two positive finite heights written ``A,B`` (d)."""

    name = "L1,L2"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        parts = str(value).split(",")
        try:
            pair = tuple(float(p) for p in parts)
        except ValueError:
            self.fail(f"{value!r} is not two numbers separated by a comma", param, ctx)
        if len(pair) != 2 or not all(math.isfinite(h) and h > 0 for h in pair) or pair[0] == pair[1]:
            self.fail(f"{value!r} must be two different positive heights, e.g. 8,25", param, ctx)
        return pair


@click.command()
@click.argument("signals", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--edge-heights", type=HeightPair(), default="8,25", show_default=True,
              help="c_tof, c_peak, c_zero are taken between the two nominal heights nearest "
                   "to these (d); the fit over all heights is reported as *_all.")
@click.option("--group-tolerance", type=FiniteFloat(min=0.0, max=1.0, max_open=True), default=0.05,
              show_default=True,
              help="Heights within this relative gap of each other form one nominal height.")
@click.option("--peak-fraction", type=FiniteFloat(min=0.0, max=1.0, min_open=True), default=None,
              help="First-pulse rule parameter of `granwave analyze front` (default: its "
                   "default); the same rule is applied to every signal.")
@json_option
@stage
def heights(signals, edge_heights, group_tolerance, peak_fraction, as_json):
    """Arrival times, speeds and exponents over a container-height series (SPEC §9).

    SIGNALS are signal files (from `granwave propagate`) of containers of
    several heights L (attribute `height`, bottom wall to top wall, in d),
    one or more packings per height, all at one pressure and one initial
    condition. Heights closer than --group-tolerance form one nominal
    height; every signal is its own point in the fits, per-height means are
    listed.

    Reported: arrival times of the 10% leading edge, the first peak and the
    first zero crossing against L; speeds c = 1/slope (sqrt(E*/rho)) with
    one-standard-error uncertainties: c_tof (10% edge), c_peak, c_zero between
    the --edge-heights, and the same over all heights (*_all); gamma and alpha
    from |A| ~ L^-gamma and W ~ L^alpha (W = t_zero - t_lead10), and the local
    exponents between consecutive heights. Uncertainties of a fit through
    exactly two points are undetermined (null).
    """
    from ..analysis.heights import height_series
    from ..errors import InputError
    from ..io.files import read_signal

    if not signals:
        raise InputError("no signal files given")
    sigs = [read_signal(p) for p in signals]
    front_kw = {} if peak_fraction is None else {"peak_fraction": peak_fraction}
    res = height_series(sigs, labels=list(signals), edge_heights=edge_heights,
                        group_rtol=group_tolerance, **front_kw)
    if as_json:
        echo_json(res)
        return
    scalars = {k: v for k, v in res.items()
               if k not in ("per_height", "samples", "heights_local", "gamma_local", "alpha_local",
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
    for h, g, a in zip(res["heights_local"], res["gamma_local"], res["alpha_local"]):
        click.echo(f"  L={h:10.4g}  gamma={g:.6g}  alpha={a:.6g}")
