"""``granwave analyze moduli``: global and scale-dependent elastic moduli (docs/method.md §6)."""

from __future__ import annotations

from pathlib import Path

import click

from ..params import ModuliParams
from .common import echo_result, options_from, params_from, stage, threads_option


@click.command()
@click.argument("source", metavar="LINEAR|PACKING", type=click.Path(dir_okay=False))
@click.option("--packing", "packing_path", type=click.Path(dir_okay=False), default=None,
              help="The packing file; required when the argument is a linear file "
                   "(which has no contact geometry).")
@options_from(ModuliParams, json=True)
@threads_option
@stage
def moduli(source, packing_path, threads, as_json, **options):
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
    from (C44+C55)/2.

    Bulk slab (the slab --layer <= y <= H - --layer, given as slab): C22_slab
    and C33_slab (3D: C33_slab, C44_slab, C55_slab) from the slab's own strain
    under the same loadings (the stress is uniform along the column),
    phi3_star_slab over the same slab and the same grains (those of the
    linear model), c_l_slab = sqrt(C22_slab/phi3_star_slab) and c_t_slab: the
    bulk medium's speeds, without the wall layers (`analyze continuum` uses
    them). NaN when the slab is thinner than 1 d. Units E* and sqrt(E*/rho).
    See docs/moduli.md.
    """
    from .. import api
    from ..errors import InputError
    from ..io.files import file_schema, read_linear, read_packing
    from ..io.schema import LINEAR, PACKING

    params = params_from(ModuliParams, options)
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
        packing = read_packing(packing_path)
        from ..io.validate import same_packing

        same_packing(source, system, packing_path, packing)
    else:
        raise InputError(f"{source}: expected a granwave.packing or granwave.linear file, "
                         f"found schema {kind!r}")
    res = api.moduli(packing, params, system=system, threads=threads)
    if not as_json:  # the table leaves out the arrays and the solver notes
        res = {k: float(v) if hasattr(v, "dtype") else v for k, v in res.items()
               if k not in ("voigt", "static_stress", "solver")}
    echo_result(res, as_json, title=f"elastic moduli of {source}")
