"""``granwave lattice`` and ``granwave chain``: exact reference states (docs/method.md §3, §12)."""

from __future__ import annotations

import click

from ..params import ChainParams, LatticeParams
from .common import options_from, output_option, params_from, quiet_option, stage
from .prepare import material_option, record_material, with_material



def _write(output, build, params):
    """Check the output, build the state with ``build(params)``, write it; returns the packing."""
    from ..io.files import check_writable, write_packing

    check_writable(output)
    packing = build(params)
    write_packing(output, packing)
    return packing


@click.command()
@options_from(LatticeParams)
@material_option
@output_option
@quiet_option
@stage
def lattice(output, material, quiet, **options):
    """Perfect triangular lattice of unit balls under pressure (no preparation run).

    Rows are parallel to the walls; all contacts carry f = p a/sqrt(3) (a the
    centre spacing, solved with the Hertz overlap), wall contacts p a, so the
    vertical stress is exactly p. Overlaps, k_n and k_t follow from the
    Hertz-Mindlin law. Lengths in mean diameters, forces in E* d^2.
    """
    from .. import api

    params = params_from(LatticeParams, with_material(options, material))
    packing = _write(output, lambda p: record_material(api.lattice(p), material), params)
    if not quiet:
        click.echo(f"lattice {params.rows} x {params.width}, p = {params.pressure:g}: spacing "
                   f"{packing.attrs['spacing']:.12g}, height {packing.height:.8g} -> {output}", err=True)


@click.command()
@options_from(ChainParams)
@output_option
@quiet_option
@stage
def chain(output, quiet, **options):
    """1D chain of balls between two walls, linear springs of equal stiffness.

    Every contact (walls included) carries the force p; springs have one
    stiffness K and overlap p/K; positions follow. Lengths in mean diameters,
    stiffness in E* d, forces in E* d^2.
    """
    from .. import api

    params = params_from(ChainParams, options)
    packing = _write(output, api.chain, params)
    if not quiet:
        click.echo(f"chain of {params.balls} balls, p = {params.pressure:g}, K = {packing.attrs['stiffness']}: "
                   f"height {packing.height:.8g} -> {output}", err=True)
