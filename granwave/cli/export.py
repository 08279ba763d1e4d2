"""``granwave export``: a packing for LAMMPS, packings and snapshots for ParaView."""

from __future__ import annotations

import functools
from pathlib import Path

import click

from .common import FiniteFloat, check_suffix, output_path_option, quiet_option, stage

NON_NEGATIVE = FiniteFloat(min=0.0)


def bad_input_exits_2(func):
    """:func:`common.stage`, with user errors (bad input, no convergence) ending with
    exit status 2: one line on stderr, no traceback, no output file."""
    wrapped = stage(func)

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return wrapped(*args, **kwargs)
        except click.ClickException as exc:
            exc.exit_code = 2
            raise

    return wrapper


@click.group("export")
def export():
    """Write granwave files in other programs' formats (LAMMPS, ParaView)."""


@export.command("lammps")
@click.argument("packing", type=click.Path(dir_okay=False))
@output_path_option(folder=True, help="Folder for packing.data and in.granwave (made if missing, "
                                      "else its two files are replaced; its parent must exist).")
@click.option("--steps", type=click.IntRange(min=0), default=0, show_default=True,
              help="Length of the deck's run (0: set up, evaluate forces, write continued.data).")
@click.option("--damping", type=NON_NEGATIVE, default=None,
              help="Contact damping zeta for the deck  [default: the packing's protocol value, else 0].")
@quiet_option
@bad_input_exits_2
def export_lammps_cmd(packing, output, steps, damping, quiet):
    """Write a LAMMPS data file (atom_style sphere) and an input deck in.granwave.

    The deck reads packing.data in units lj (= granwave's reduced units) and sets up
    the same physics: pair_style granular with the packing's contact sub-models' LAMMPS words
    (Hertz: hertz, mindlin_rescale with friction, damping matched to granwave's zeta; every
    sub-model's in docs/interop.md; one without an equivalent is refused), a granular bottom wall and a force-driven
    piston (see granwave.interop.lammps). Run it with `lmp -in in.granwave` inside
    the folder; it ends with `write_data continued.data`, which `granwave import
    lammps` reads back. LAMMPS starts every contact without tangential force (a data
    file cannot carry contact history): frictional packings re-settle slightly.
    """
    from ..interop.lammps import export_lammps
    from ..io.files import read_packing

    info = export_lammps(read_packing(packing), Path(output), steps=steps, damping=damping)
    pk_grains = info["grains"]
    if not quiet:
        click.echo(f"wrote {info['data']} and {info['deck']}: {pk_grains} grains, piston mass "
                   f"{info['piston_mass']:.6g}", err=True)


@export.command("vtk")
@click.argument("source", type=click.Path(dir_okay=False))
@output_path_option((".vtu", ".pvd"),
                    help="OUT.vtu for a packing; OUT.pvd (plus OUT_<k>.vtu beside it) for a signal's "
                         "snapshots.")
@click.option("--packing", "packing_path", type=click.Path(dir_okay=False), default=None,
              help="The packing a signal's snapshots belong to (their equilibrium positions and radii).")
@quiet_option
@bad_input_exits_2
def export_vtk_cmd(source, output, packing_path, quiet):
    """Write a packing or a signal's snapshots for ParaView (VTK XML, via meshio).

    A packing: grains as points (radius, mass, rattler flag), force-carrying contacts
    as lines (normal and tangential force). A signal file with snapshots: a .pvd time
    series of the displacement (and rotation) field on the grains.
    """
    from ..errors import InputError
    from ..interop import vtk
    from ..io import schema as S
    from ..io import validate as V
    from ..io.files import check_writable, file_schema, read_packing, read_signal

    check_writable(output)
    kind = file_schema(source)
    if kind in (S.PACKING, S.SIGNAL):
        check_suffix(output, (".vtu",) if kind == S.PACKING else (".pvd",),
                     "a packing's export" if kind == S.PACKING else "a signal's snapshot series")
    if kind == S.PACKING:
        written = [vtk.write_packing_vtu(output, read_packing(source))]
    elif kind == S.SIGNAL:
        sig = read_signal(source)
        radius = None
        if packing_path is not None:
            pk = read_packing(packing_path)
            V.same_packing(source, sig, packing_path, pk)  # never another packing's grains
            position, radius = pk.position, pk.radius
        elif sig.position is not None:
            position = sig.position
        else:
            raise InputError(f"{source}: the snapshots need the grains' positions: give --packing")
        written = vtk.write_snapshot_series(output, sig, position, radius)
    else:
        raise InputError(f"{source}: export vtk takes a packing or a signal file, found schema {kind!r}")
    if not quiet:
        click.echo(f"wrote {len(written)} file{'s' if len(written) != 1 else ''}: "
                   + ", ".join(str(w) for w in written), err=True)
