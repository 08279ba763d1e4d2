"""``granwave analyze shocks``: the shocks scene's front speeds against strain (docs/shocks.md)."""

from __future__ import annotations

import click

from .common import echo_json, stage


@click.command()
@click.argument("records", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--tail-from", type=float, default=10.0, show_default=True,
              help="Lower end (eps/delta0) of the strongly nonlinear window of the exponent fit.")
@click.option("--json", "as_json", is_flag=True, help="Print the analysis as one JSON object.")
@stage
def shocks(records, tail_from, as_json):
    """Front speed against the piston's strain, from the linear response to shocks.

    RECORDS are the shocks scene's packing records (results/shocks/<scene>/p<p>/<size>/s<seed>.json,
    one per packing: every piston push's front speed V, v_p and contact counts). Per scene and
    pressure: the linear speed V_0 (the weakest push), V/V_0 against eps/delta0 (eps = v_p/V the
    strain behind the front, delta0 the mean overlap over the mean diameter), the crossover strain
    eps_x (V = 1.1 V_0) and its scaling with p, the exponent of V against eps at eps/delta0 >=
    --tail-from, each against the mean-field column's value; the fractions of contacts that open
    and that slide. Means over packings with standard errors (a range under 5 packings). Units: d,
    sqrt(E*/rho). See docs/shocks.md.
    """
    import json

    from ..analysis.shocks_scene import read_record, shocks_scene
    from ..errors import InputError

    recs = []
    for path in records:
        try:
            with open(path) as f:
                obj = json.load(f)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read a JSON record ({exc.__class__.__name__})") from None
        recs.append(read_record(obj, str(path)))
    res = shocks_scene(recs, tail_from=tail_from)
    if as_json:
        echo_json(res)
        return
    for scene, a in res["scenes"].items():
        t, sc = a["tail_exponent"], a["crossover_scaling"]
        click.echo(f"{scene}: {a['contact_law']}, friction {a['friction']:g}, {a['n_packings']} packings")
        click.echo(f"  exponent at eps/delta0 >= {a['tail_from']:g}: {t['mean']:.4g} +- {t['error']:.2g} "
                   f"(n = {t['n']}; expected {a['tail_exponent_expected']:g}, mean field over the same "
                   f"window {a['tail_exponent_mean_field']:.4g})")
        click.echo(f"  eps_x ~ p^{sc['exponent']:.4g} +- {sc['error']:.2g} (expected "
                   f"{a['crossover_scaling_expected']:.4g})")
        click.echo(f"  {'p':>8} {'n':>3} {'delta0':>10} {'V_0':>9} {'eps_x/delta0':>13} {'reached':>8}")
        for q in a["pressures"]:
            click.echo(f"  {q['pressure']:8.2g} {q['n_packings']:3d} {q['static_strain']['mean']:10.4g} "
                       f"{q['c0']['mean']:9.4g} {q['crossover_over_static']['mean']:13.4g} "
                       f"{q['n_crossover_reached']:8d}")
