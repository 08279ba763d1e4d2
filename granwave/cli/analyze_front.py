"""``granwave analyze front``: characteristic points of the coherent front (SPEC §9)."""

from __future__ import annotations

import click

from .common import FiniteFloat, echo_json, echo_table, json_option, stage


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("signal", type=click.Path(dir_okay=False))
@click.option("--peak-fraction", type=FiniteFloat(min=0.0, max=1.0, min_open=True), default=0.3,
              show_default=True,
              help="The first pulse is the first lobe at least this fraction of the largest "
                   "lobe up to and including the next one (skips precursors).")
@click.option("--lead-fraction", type=FiniteFloat(min=0.0, max=1.0, min_open=True, max_open=True),
              default=0.1, show_default=True, help="Leading-edge level, fraction of the first peak.")
@click.option("--noise-fraction", type=FiniteFloat(min=0.0, max=1.0, max_open=True), default=1e-3,
              show_default=True, help="Lobes below this fraction of max |F| are ripples and skipped.")
@json_option
@stage
def front(signal, peak_fraction, lead_fraction, noise_fraction, as_json):
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
    from ..analysis.front import front_features
    from ..io.files import read_signal

    sig = read_signal(signal)
    feats = front_features(sig.time, sig.force, peak_fraction=peak_fraction,
                           lead_fraction=lead_fraction, noise_fraction=noise_fraction)
    d = feats.as_dict()
    out = {k: d[k] for k in ("t_lead10", "t_peak", "amplitude", "polarity", "t_zero", "width")}
    out["height"] = float(sig.attrs["height"])
    for key in ("ic", "method", "pressure"):
        if key in sig.attrs:
            out[key] = sig.attrs[key]
    out.update(rise=d["rise"], peak_fraction=peak_fraction, lead_fraction=lead_fraction,
               noise_fraction=noise_fraction)
    if as_json:
        echo_json(out)
    else:
        echo_table(out, title=f"front of {signal}")
