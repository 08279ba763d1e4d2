"""``granwave analyze spectrum``: eigen-spectrum statistics and mode contributions."""

from __future__ import annotations

import click

from .common import echo_json, echo_table, json_option, stage


@click.command()
@click.argument("modes_file", metavar="MODES", type=click.Path(dir_okay=False))
@click.option("--ic", type=click.Choice(["A", "B"], case_sensitive=False), default="A",
              show_default=True, help="Initial condition whose weights a_n b_n are analysed.")
@click.option("--linear", "linear_file", type=click.Path(dir_okay=False), default=None,
              help="The linear file the modes were computed from: its dof map makes the "
                   "participation ratio run over grains (translations only). Without it "
                   "every dof counts as one site.")
@click.option("--arrays/--no-arrays", default=False, show_default=True,
              help="With --json, also print omega^2, a_n b_n and PR of every mode.")
@json_option
@stage
def spectrum(modes_file, ic, linear_file, arrays, as_json):
    """Spectrum and each mode's part in the signal (SPEC §7).

    MODES is a modes file from `granwave eigensolve`. Reports the number of
    modes and of zero modes (|omega^2| <= the eigensolve threshold x
    omega^2_max), the lowest nonzero omega^2 (E*/(rho d^2)), the weights
    w_n = a_n b_n (E* d^2; F_sig = sum w_n sin(omega_n t) for A, cos for B),
    and the share of the signal carried by the 1%, 10% and 50% strongest
    nonzero modes (ranked by |w_n|): carried_power = share of sum w_n^2 (the
    time-averaged power), carried_abs = share of sum |w_n|.

    The participation ratio PR = (sum_i |phi_i|^2)^2 / (N sum_i |phi_i|^4)
    per mode needs eigenvectors (`granwave eigensolve --vectors`); without
    them everything else is still reported.
    """
    from ..errors import InputError
    from ..io import files as F
    from ..io import schema as S

    with F.open_checked(modes_file, S.MODES) as f:
        has_vectors = "vectors" in f
    modes = F.read_modes(modes_file, vectors=has_vectors)
    dof_grain = dof_axis = None
    if linear_file is not None:
        system = F.read_linear(linear_file)
        if modes.vectors is not None and system.n_dof != modes.vectors.shape[0]:
            raise InputError(f"{linear_file} has {system.n_dof} dofs, the eigenvectors of "
                             f"{modes_file} {modes.vectors.shape[0]}: not the same system")
        dof_grain, dof_axis = system.dof_grain, system.dof_axis

    from ..analysis.spectrum import spectrum_summary

    res = spectrum_summary(modes, ic=ic, dof_grain=dof_grain, dof_axis=dof_axis,
                           arrays=arrays and as_json)
    res["source"] = str(modes_file)
    if as_json:
        echo_json(res)
        return
    rows = {}
    for key, value in res.items():
        if isinstance(value, dict):
            for sub, v in value.items():
                rows[f"{key}[{sub}]"] = v
        else:
            rows[key] = value
    echo_table(rows, title=f"spectrum of {modes_file} (IC {res['ic']})")
