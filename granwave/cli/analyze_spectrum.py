"""``granwave analyze spectrum``: eigen-spectrum statistics and mode contributions."""

from __future__ import annotations

import dataclasses

import click

from ..params import SpectrumParams
from .common import echo_json, echo_table, options_from, params_from, stage


@click.command()
@click.argument("modes_file", metavar="MODES", type=click.Path(dir_okay=False))
@click.option("--linear", "linear_file", type=click.Path(dir_okay=False), default=None,
              help="The linear file the modes were computed from: its dof map makes the "
                   "participation ratio run over grains (translations only). Without it "
                   "every dof counts as one site.")
@options_from(SpectrumParams, json=True)
@stage
def spectrum(modes_file, linear_file, as_json, **options):
    """Spectrum and each mode's part in the signal (docs/method.md §7).

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
    from .. import api
    from ..io import files as F
    from ..io import schema as S

    params = params_from(SpectrumParams, options)
    params = dataclasses.replace(params, arrays=params.arrays and as_json)
    with F.open_checked(modes_file, S.MODES) as f:
        has_vectors = "vectors" in f
    modes = F.read_modes(modes_file, vectors=has_vectors)
    system = F.read_linear(linear_file) if linear_file is not None else None
    res = api.spectrum(modes, params, system=system)
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
