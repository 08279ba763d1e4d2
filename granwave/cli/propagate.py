"""``granwave propagate``: the signal on the top wall after a kick at the bottom (docs/method.md §8).

Reads the source file (modes, linear or packing), builds
:class:`granwave.params.PropagateParams` from the options and calls
:func:`granwave.api.propagate`, which picks the method.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import click

from ..params import PropagateParams
from .common import (echo_result, echo_warnings, json_option, long_run_option, options_from, output_option,
                     params_from, progress_printer, quiet_option, stage, threads_option)
from .prepare import device_option

ROWS = ("ic", "method", "method_reason", "height", "t_max", "samples", "dt", "omega_max_dt",
        "nyquist_ratio", "step_error_estimate", "step_runs", "modified_energy_max_rel_deviation",
        "amplitude", "strain", "kick_velocity", "drive", "damping", "front_speed", "front_speed_error",
        "energy_drift", "n_opened",
        "n_formed", "n_sliding", "max_displacement_over_overlap")


def _read_source(path: str, kind: str, params: PropagateParams):
    """(the object propagate needs, the linear system for a modes file's snapshots or None)."""
    from ..errors import InputError
    from ..io import files
    from ..io import schema as S

    if kind == S.MODES:
        modes = files.read_modes(path, vectors=params.snapshots is not None)
        modes.attrs["modes_source"] = str(path)
        system = None
        if params.snapshots is not None:
            # The modes file has no dof map: take it from the linear file it was made from.
            system = files.linear_of_modes(path, modes)
        return modes, system
    if kind == S.LINEAR:
        system = files.read_linear(path)
        system.attrs["linear_source"] = str(path)
        return system, None
    if kind == S.PACKING:
        return files.read_packing(path), None
    raise InputError(f"{path}: cannot propagate a {kind or 'non-granwave'} file (expected a "
                     "granwave.modes or granwave.linear file, or a granwave.packing file with "
                     "--method dem)")


@click.command()
@click.argument("source", metavar="(MODES | LINEAR | PACKING)", type=click.Path(dir_okay=False))
@output_option
@options_from(PropagateParams)
@threads_option
@device_option
@quiet_option
@json_option
@long_run_option
@stage
def propagate(source, output, threads, device, quiet, as_json, **options):
    """Signal F_sig(t) on the top wall, in E* d^2, after a kick at the bottom (docs/method.md §8).

    Reads a granwave.modes file (modal sum), a granwave.linear file (time
    domain, no eigendecomposition needed; --method auto chooses the time
    domain or the modal sum by predicted cost) or a granwave.packing file
    (--method dem: nonlinear DEM pulse, fixed walls, contact damping). Writes a
    granwave.signal file with signal/time and signal/force and the run's
    parameters as attributes. A sample interval longer than pi/omega_max
    (the highest modes alias) is written with a warning, not refused.
    """
    from .. import api
    from ..errors import InputError
    from ..io import files

    params = params_from(PropagateParams, options)
    files.check_writable(output)
    if not Path(source).is_file():
        raise InputError(f"{source}: no such file")
    obj, system = _read_source(source, files.file_schema(source), params)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", api.AliasingWarning)
        signal = api.propagate(obj, params, system=system, progress=progress_printer(not quiet),
                               threads=threads, device=device)
    echo_warnings(caught)
    signal.attrs["source_file"] = str(source)
    files.write_signal(output, signal)
    if "method_reason" in signal.attrs and not as_json:  # a choice, said even with -q
        click.echo(f"method auto -> {signal.attrs['method_reason']}", err=True)
    rows = {k: signal.attrs[k] for k in ROWS if k in signal.attrs}
    echo_result(rows, as_json, title=f"wrote {output}")
