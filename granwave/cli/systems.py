"""``granwave lattice`` and ``granwave chain``: exact reference states (SPEC §3, §12)."""

from __future__ import annotations

import click

from .common import NON_NEGATIVE, POSITIVE, FiniteFloat, output_option, seed_option, stage

CONTEXT = {"help_option_names": ["-h", "--help"]}


@click.command(context_settings=CONTEXT)
@click.option("--rows", type=click.IntRange(min=2), required=True,
              help="Number of rows (>= 2); the first touches the bottom wall, the last the top wall.")
@click.option("--width", type=click.IntRange(min=3), required=True,
              help="Balls per row (>= 3); periodic in x, box length = width x spacing.")
@click.option("--pressure", type=POSITIVE, required=True,
              help="Vertical stress p in units of E* (force per wall length x one diameter).")
@click.option("--friction", type=NON_NEGATIVE, default=0.0, show_default=True,
              help="Friction coefficient mu (recorded; mu > 0 makes the linearization use k_t).")
@click.option("--poisson", type=FiniteFloat(min=0.0, max=1.0, max_open=True), default=0.0,
              show_default=True, help="Poisson ratio nu of the grains (sets k_t/k_n).")
@output_option
@stage
def lattice(rows, width, pressure, friction, poisson, output):
    """Perfect triangular lattice of unit balls under pressure (no preparation run).

    Rows are parallel to the walls; all contacts carry f = p a/sqrt(3) (a the
    centre spacing, solved with the Hertz overlap), wall contacts p a, so the
    vertical stress is exactly p. Overlaps, k_n and k_t follow from the
    Hertz-Mindlin law. Lengths in mean diameters, forces in E* d^2.
    """
    from ..io.files import check_writable, write_packing
    from ..systems import triangular_lattice

    check_writable(output)
    packing = triangular_lattice(rows=rows, width=width, pressure=pressure, friction=friction,
                                 poisson=poisson)
    write_packing(output, packing)
    click.echo(f"lattice {rows} x {width}, p = {pressure:g}: spacing {packing.attrs['spacing']:.12g}, "
               f"height {packing.height:.8g} -> {output}", err=True)


@click.command(context_settings=CONTEXT)
@click.option("--balls", "n_balls", type=click.IntRange(min=1), required=True, help="Number of balls N.")
@click.option("--pressure", type=POSITIVE, required=True,
              help="Force on every contact in units of E* d^2 (1D pressure: force per mean diameter squared).")
@click.option("--polydispersity", type=FiniteFloat(min=0.0, max=1.0, max_open=True), default=0.0,
              show_default=True, help="W: diameters uniform in [1-W, 1+W] (masses pi d^3/6 follow).")
@seed_option
@click.option("--stiffness", type=POSITIVE, default=None,
              help="Spring stiffness K (E* d) of every contact, walls included "
                   "[default: Hertz k_n of two unit balls at force p].")
@click.option("--hertz", "hertz", is_flag=True,
              help="Give each contact its own Hertz k_n (radius dependent) instead of one K.")
@output_option
@stage
def chain(n_balls, pressure, polydispersity, seed, stiffness, hertz, output):
    """1D chain of balls between two walls, linear springs of equal stiffness.

    Every contact (walls included) carries the force p; springs have one
    stiffness K and overlap p/K; positions follow. Lengths in mean diameters,
    stiffness in E* d, forces in E* d^2.
    """
    from ..io.files import check_writable, write_packing
    from ..systems import chain as make_chain

    check_writable(output)
    packing = make_chain(n_balls=n_balls, pressure=pressure, polydispersity=polydispersity, seed=seed,
                         stiffness=stiffness, stiffness_model="hertz" if hertz else "equal")
    write_packing(output, packing)
    click.echo(f"chain of {n_balls} balls, p = {pressure:g}, K = {packing.attrs['stiffness']}: "
               f"height {packing.height:.8g} -> {output}", err=True)
