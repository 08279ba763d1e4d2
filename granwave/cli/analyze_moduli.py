"""``granwave analyze moduli``: global and scale-dependent elastic moduli (SPEC §6)."""

from __future__ import annotations

import click

from .common import NON_NEGATIVE, POSITIVE, echo_json, echo_table, json_option, stage


@click.command(context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("source", metavar="LINEAR|PACKING", type=click.Path(dir_okay=False))
@click.option("--packing", "packing_path", type=click.Path(dir_okay=False), default=None,
              help="The packing file; required when the argument is a linear file "
                   "(which has no contact geometry).")
@click.option("--local", is_flag=True,
              help="Also the body-force (n = 1, 2) and line (n = 1, 3) moduli, as ratios "
                   "to the global ones.")
@click.option("--prestress", is_flag=True,
              help="Include the prestress (geometric) terms (a linear file brings its own).")
@click.option("--amplitude", type=POSITIVE, default=1e-6, show_default=True,
              help="Strain amplitude (the linear model makes the result independent of it).")
@click.option("--grip/--no-grip", default=None,
              help="Hold the lateral motion of wall-touching grains in the shear loadings "
                   "[default: only for frictionless packings, whose walls cannot drag].")
@click.option("--layer", type=NON_NEGATIVE, default=3.0, show_default=True,
              help="Layer next to each wall left out of the bulk phi3_star (SPEC §4).")
@click.option("--force", is_flag=True, help="Accept a packing marked as not converged.")
@json_option
@stage
def moduli(source, packing_path, local, prestress, amplitude, grip, layer, force, as_json):
    """Elastic moduli of a packing by imposed strain and linear relaxation.

    LINEAR|PACKING is a granwave.packing file (linearized here) or a
    granwave.linear file together with --packing (the linear file must have
    been built from that packing; its prestress setting is used).

    Global moduli (2D): C11, C12, C22, C33 with sigma11 = C11 e11 + C12 e22,
    sigma22 = C12 e11 + C22 e22, sigma12 = 2 C33 e12 (compression and
    shrinking positive; 2 = vertical), c_l = sqrt(C22/phi3_star),
    c_t = sqrt(C33/phi3_star), phi3_star the bulk value of `analyze statics`
    (whole cell, phi3_star_cell, when there is no bulk). 3D: Voigt
    C11 C22 C33 C12 C13 C23 C44 C55 C66 with z vertical, c_l from C33, c_t
    from (C44+C55)/2. Units E* and sqrt(E*/rho). See docs/moduli.md.
    """
    from ..errors import InputError
    from ..io.files import file_schema, read_linear, read_packing
    from ..io.schema import LINEAR, PACKING
    from ..linear.moduli import moduli as compute

    from pathlib import Path

    if not Path(source).is_file():
        raise InputError(f"{source}: no such file")
    kind = file_schema(source)
    system = None
    if kind == PACKING:
        if packing_path is not None:
            raise InputError("--packing is only for a linear-file argument")
        packing = read_packing(source)
    elif kind == LINEAR:
        if packing_path is None:
            raise InputError(f"{source} is a linear file: pass its packing with --packing FILE")
        system = read_linear(source)
        if prestress and not bool(system.attrs.get("prestress", False)):
            raise InputError("--prestress conflicts with the linear file (built without prestress)")
        packing = read_packing(packing_path)
    else:
        raise InputError(f"{source}: expected a granwave.packing or granwave.linear file, "
                         f"found schema {kind!r}")
    res = compute(packing, local=local, prestress=prestress, amplitude=amplitude, grip=grip,
                  system=system, force=force, layer=layer)
    if as_json:
        echo_json(res)
    else:
        rows = {k: v for k, v in res.items() if k not in ("voigt", "static_stress", "solver")}
        echo_table({k: float(v) if hasattr(v, "dtype") else v for k, v in rows.items()},
                   title=f"elastic moduli of {source}")
