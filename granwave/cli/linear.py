"""``granwave linearize`` and ``granwave eigensolve`` (SPEC §5, §7)."""

from __future__ import annotations

import warnings

import click

from .common import echo_json, echo_table, json_option, output_option, stage


def _summary(attrs: dict, keys) -> dict:
    return {k: attrs[k] for k in keys if k in attrs}


@click.command()
@click.argument("packing", type=click.Path(dir_okay=False))
@output_option
@click.option("--prestress", is_flag=True,
              help="Add the geometric (prestress) terms: D becomes the Jacobian of the "
                   "frozen-history contact forces (off by default).")
@click.option("--force", "force_unconverged", is_flag=True,
              help="Linearize even a packing whose preparation did not converge.")
@click.option("--check/--no-check", default=True, show_default=True,
              help="Check symmetry and positive semi-definiteness and count zero modes (dense "
                   "eigenvalues up to 3000 dofs, else the 12 lowest by shift-invert Lanczos).")
@json_option
@stage
def linearize(packing, output, prestress, force_unconverged, check, as_json):
    """Build the stiffness matrix D and mass matrix M of PACKING (SPEC §5).

    Dofs per non-rattler grain: translations, plus rotations when the packing
    has friction. D is in E* d per dof pair, M in rho d^3 (translations) and
    rho d^5 (rotations). Writes a granwave.linear file with the dof map,
    the source vectors of initial conditions A/B and the detector vector, and
    reports symmetry, positive semi-definiteness and the zero-mode count.
    """
    from ..io import files
    from ..linear.assemble import linearize as build

    files.check_writable(output)
    pk = files.read_packing(packing)
    pk.attrs["source_file"] = str(packing)
    system = build(pk, prestress=prestress, force=force_unconverged, check=check)
    files.write_linear(output, system)
    rows = _summary(system.attrs, ("n_dof", "n_rattlers", "n_contacts", "prestress", "asymmetry",
                                   "n_zero_modes", "expected_zero_modes", "n_negative_modes",
                                   "omega2_max", "psd_check"))
    if system.attrs.get("n_negative_modes", 0):
        click.echo(f"warning: D has {system.attrs['n_negative_modes']} negative eigenvalue(s)", err=True)
    echo_json(rows) if as_json else echo_table(rows, title=f"wrote {output}")


@click.command()
@click.argument("linear", type=click.Path(dir_okay=False))
@output_option
@click.option("--vectors", is_flag=True,
              help="Also store the M-orthonormal eigenvectors (n x n doubles; needed only "
                   "for mode shapes and modal snapshots).")
@click.option("--lowest", "lowest", type=click.IntRange(min=1), default=None,
              help="Compute only the K lowest modes (sparse shift-invert Lanczos) instead of "
                   "the full dense spectrum; the modal signal is then a low-pass truncation.")
@json_option
@stage
def eigensolve(linear, output, vectors, lowest, as_json):
    """Eigenmodes of D phi = omega^2 M phi for LINEAR (SPEC §7).

    Stores omega^2 (1/t^2, ascending), the projections a_n of initial
    conditions A and B and the detector couplings b_n; zero modes are those
    with |omega^2| <= 1e-10 omega^2_max. Dense LAPACK (syevd) by default.
    """
    from ..io import files
    from ..linear.eigen import NegativeModesWarning, eigensolve as solve

    files.check_writable(output)
    system = files.read_linear(linear)
    system.attrs["linear_source"] = str(linear)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NegativeModesWarning)
        modes = solve(system, vectors=vectors, k=lowest)
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    files.write_modes(output, modes)
    rows = _summary(modes.attrs, ("n_dof", "n_modes", "n_zero_modes", "n_negative_modes",
                                  "omega2_max", "stiffness_asymmetry", "solver"))
    echo_json(rows) if as_json else echo_table(rows, title=f"wrote {output}")
