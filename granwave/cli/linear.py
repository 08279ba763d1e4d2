"""``granwave linearize`` and ``granwave eigensolve`` (docs/method.md §5, §7)."""

from __future__ import annotations

import warnings

import click

from ..params import EigenParams, LinearizeParams
from .common import (echo_result, echo_warnings, json_option, options_from, output_option, params_from,
                     progress_printer, stage, threads_option)

LINEARIZE_ROWS = ("n_dof", "n_rattlers", "n_free_spins", "n_spins_removed", "n_contacts", "prestress", "asymmetry",
                  "n_zero_modes", "expected_zero_modes", "n_negative_modes", "omega2_max", "psd_check")
EIGENSOLVE_ROWS = ("n_dof", "n_modes", "n_zero_modes", "n_negative_modes", "omega2_max",
                   "stiffness_asymmetry", "solver")


def _echo_summary(attrs: dict, keys, output, as_json: bool) -> None:
    echo_result({k: attrs[k] for k in keys if k in attrs}, as_json, title=f"wrote {output}")


@click.command()
@click.argument("packing", type=click.Path(dir_okay=False))
@output_option
@options_from(LinearizeParams)
@click.option("-q", "--quiet", is_flag=True, help="No progress lines on stderr (printed above "
              "3000 dofs: assembly time, the check's method, iterations and time).")
@threads_option
@json_option
@stage
def linearize(packing, output, threads, as_json, quiet, **options):
    """Build the stiffness matrix D and mass matrix M of PACKING (docs/method.md §5).

    Dofs per non-rattler grain: translations, plus rotations when the packing
    has friction. D is in E* d per dof pair, M in rho d^3 (translations) and
    rho d^5 (rotations). Writes a granwave.linear file with the dof map,
    the source vectors of initial conditions A/B and the detector vector, and
    reports symmetry, positive semi-definiteness and the zero-mode count.
    """
    from .. import api
    from ..io import files

    params = params_from(LinearizeParams, options)
    files.check_writable(output)
    pk = files.read_packing(packing)
    pk.attrs["source_file"] = str(packing)
    system = api.linearize(pk, params, threads=threads, progress=progress_printer(not quiet))
    files.write_linear(output, system)
    if system.attrs.get("n_negative_modes", 0):
        kept = int(system.attrs.get("n_free_spins", 0)) - int(system.attrs.get("n_spins_removed", 0))
        why = (f" (with prestress each of the {kept} free spins kept is a zero or slightly negative "
               "mode, docs/linear.md; --remove-spins constrains them)"
               if kept and system.attrs.get("prestress") else "")
        click.echo(f"warning: D has {system.attrs['n_negative_modes']} negative eigenvalue(s){why}", err=True)
    _echo_summary(system.attrs, LINEARIZE_ROWS, output, as_json)


@click.command()
@click.argument("linear", type=click.Path(dir_okay=False))
@output_option
@options_from(EigenParams)
@threads_option
@json_option
@stage
def eigensolve(linear, output, threads, as_json, **options):
    """Eigenmodes of D phi = omega^2 M phi for LINEAR (docs/method.md §7).

    Stores omega^2 (1/t^2, ascending), the projections a_n of initial
    conditions A and B and the detector couplings b_n; zero modes are those
    with |omega^2| <= 1e-10 omega^2_max. Dense LAPACK (syevd) by default.
    """
    from .. import api
    from ..io import files

    params = params_from(EigenParams, options)
    files.check_writable(output)
    system = files.read_linear(linear)
    system.attrs["linear_source"] = files.source_reference(linear, output)  # beside the modes file
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        modes = api.eigensolve(system, params, threads=threads)
    echo_warnings(caught)
    files.write_modes(output, modes)
    _echo_summary(modes.attrs, EIGENSOLVE_ROWS, output, as_json)
