"""``granwave analyze front``: characteristic points of the coherent front (docs/method.md §9)."""

from __future__ import annotations

import click

from ..params import FrontParams
from .common import echo_result, options_from, params_from, stage


@click.command()
@click.argument("signal", type=click.Path(dir_okay=False))
@options_from(FrontParams, json=True)
@stage
def front(signal, as_json, **options):
    """Leading edge, first peak, zero crossing and width of a signal's first pulse.

    SIGNAL is a granwave.signal file (from `granwave propagate`). Printed:
    t_lead10 (first time the first pulse reaches 10% of its peak, linear
    interpolation), t_peak and amplitude (|F| at the peak, parabola through
    three samples; polarity = its sign), t_zero (first zero crossing after
    the peak), width = t_zero - t_lead10, and the height (wall-to-wall
    distance, d) from the file. Times in d/sqrt(E*/rho), forces in E* d^2.

    The first pulse is the first lobe (run of one sign) at least
    --peak-fraction of the largest lobe up to and including the next one;
    lobes under --noise-fraction of max|F| are ignored (docs/front.md).
    A signal whose first pulse does not reach its peak or does not cross
    zero inside the record is refused.
    """
    from .. import api
    from ..io.files import read_signal

    params = params_from(FrontParams, options)
    out = api.front(read_signal(signal), params)
    echo_result(out, as_json, title=f"front of {signal}")
