"""``granwave analyze statics``: static characterization of a packing (docs/method.md §4)."""

from __future__ import annotations

import click

from ..params import StaticsParams
from .common import echo_result, options_from, params_from, stage


@click.command()
@click.argument("packing", type=click.Path(dir_okay=False))
@options_from(StaticsParams, json=True)
@stage
def statics(packing, as_json, **options):
    """Solid fractions, coordination, force statistics, fabric and stress of a packing.

    Bulk quantities use the slab l <= y <= H - l (grains cut exactly by its
    planes for the solid fractions; contacts of bulk non-rattler grains for
    the statistics). Keys: phi2 (disk area fraction, 2D), phi3, phi3_star
    (sphere volume fraction of a one-diameter layer, without rattlers),
    z_star, rattler_fraction, mean_force_over_p (<N>/p, d^2), Z2, Z3
    (<N^a>/<N>^a), F2, F2_strong (<n_y^2> over all / strong contacts),
    stress (whole cell, walls included, compression positive, units E*),
    stress_ratio (sigma11/sigma22), max_force_residual (worst grain force or
    torque / p d^2), piston_balance (top-wall force / (p x wall area) - 1).
    Rattler rule and other choices: granwave.analysis.statics docstring.
    """
    from .. import api
    from ..io.files import read_packing

    params = params_from(StaticsParams, options)
    result = api.statics(read_packing(packing), params)
    echo_result(result, as_json, title=f"statics of {packing} (layer {params.layer:g})")
