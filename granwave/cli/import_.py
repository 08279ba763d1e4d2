"""``granwave import``: packings prepared by other programs (LAMMPS)."""

from __future__ import annotations

import click

from .common import POSITIVE, FiniteFloat, output_option, progress_printer, quiet_option, threads_option
from .export import NON_NEGATIVE
from .export import bad_input_exits_2


@click.group("import")
def import_group():
    """Read packings written by other programs into granwave files."""


@import_group.command("lammps")
@click.argument("source", type=click.Path(dir_okay=False))
@output_option
@click.option("--pressure", type=POSITIVE, required=True,
              help="Piston pressure p in units of E* (as for prepare-packing).")
@click.option("--friction", type=NON_NEGATIVE, default=0.5, show_default=True, help="Coulomb friction mu.")
@click.option("--poisson", type=FiniteFloat(min=0.0, max=0.5, max_open=True), default=0.0,
              show_default=True, help="Poisson ratio nu.")
@click.option("--damping", type=FiniteFloat(min=0.0, max=1.0), default=0.5, show_default=True,
              help="Contact damping zeta during the relaxation.")
@click.option("--background-damping", type=NON_NEGATIVE, default=0.3, show_default=True,
              help="Background damping rate in units of 1/t_i, t_i = sqrt(m/(p d)).")
@click.option("--piston-mass", type=POSITIVE, default=None,
              help="Piston mass in rho d^3  [default: the file's piston atom's (files from "
                   "`granwave export lammps`), else one layer of grains].")
@click.option("--tol", type=POSITIVE, default=1e-10, show_default=True,
              help="Convergence threshold on every acceleration (as prepare-packing).")
@click.option("--max-steps", type=click.IntRange(min=1), default=None,
              help="Step budget of the relaxation  [default: as prepare-packing, 2e6 per 100 d of "
                   "the expected height, at least 2e6]; not relaxed by then: error, no output file.")
@click.option("--safety", type=FiniteFloat(min=0.0, min_open=True), default=0.05, show_default=True,
              help="Time-step factor (as prepare-packing; at most 0.06).")
@click.option("--dim", type=click.Choice(["auto", "2", "3"]), default="auto", show_default=True,
              help="2: centres in the x-y plane, y vertical; 3: z vertical; auto: 2 when every z is equal.")
@click.option("--length-scale", type=POSITIVE, default=1.0, show_default=True,
              help="Multiply the file's lengths by this to measure them in mean diameters "
                   "(velocities are then ignored).")
@threads_option
@quiet_option
@bad_input_exits_2
def import_lammps_cmd(source, output, pressure, friction, poisson, damping, background_damping, piston_mass,
                      tol, max_steps, safety, dim, length_scale, threads, quiet):
    """Relax grains from a LAMMPS data file or text dump with granwave's engine.

    Reads positions, radii (data file: atom_style sphere; dump: a radius or diameter
    column) and velocities when present; x (and y in 3D) periodic, the bottom wall at
    the box's lower bound along the vertical, the piston where the file's piston atom
    is (files from `granwave export lammps`) or on the highest grain. The grains are
    relaxed under --pressure to --tol with the preparation's physics (tangential
    history from zero, so it is granwave's own) and written as a granwave.packing
    file recording the source file.
    """
    from ..dem.params import PrepareParams
    from ..interop.lammps import grains_of_state, read_lammps
    from ..interop.relax import relax_grains
    from ..io.files import check_writable, write_packing
    from ..threads import set_threads

    set_threads(threads)
    check_writable(output)
    state = read_lammps(source)
    g = grains_of_state(state, None if dim == "auto" else int(dim), length_scale=length_scale)
    params = PrepareParams(dim=g["dim"], grains=len(g["radius"]), pressure=pressure, friction=friction,
                           poisson=poisson, damping=damping, background_damping=background_damping,
                           piston_mass=piston_mass if piston_mass is not None else state.piston_mass,
                           tol=tol, max_steps=max_steps, safety=safety)
    attrs = {**state.source, "source_length_scale": length_scale,
             "source_velocities": g["velocity"] is not None}
    packing = relax_grains(g["position"], g["radius"], g["lateral"], params, piston_height=g["piston_height"],
                           velocity=g["velocity"], angular_velocity=g["angular_velocity"],
                           progress=progress_printer(not quiet), attrs=attrs)
    write_packing(output, packing)
    if not quiet:
        click.echo(f"wrote {output}: {packing.n_grains} grains, {len(packing.contacts)} contacts, "
                   f"{packing.attrs['steps']} steps, residual {packing.attrs['max_acceleration']:.3g}", err=True)
