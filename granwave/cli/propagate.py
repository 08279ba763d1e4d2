"""``granwave propagate``: the signal on the top wall after a kick at the bottom (SPEC §8).

Dispatch on the input file kind and the method: a modes file -> modal sum;
a linear file -> time domain (or, with ``--method modal``, an eigensolve on
the fly). A nonlinear ``dem`` method from a packing file can be added to
``RUNNERS`` (key: (schema, method)) without touching the others.
"""

from __future__ import annotations

import click

from .common import POSITIVE, FiniteFloat, echo_json, echo_table, json_option, output_option, \
    progress_printer, stage

METHODS = ("modal", "time", "dem")


def _parse_times(text: str | None):
    if not text:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r} is not a comma-separated list of times",
                                 param_hint="--snapshots") from None


def _modal_from_modes(path, opts):
    from ..io import files
    from ..linear.propagate import modal_propagate

    from ..errors import InputError

    want = opts["snapshots"] is not None
    modes = files.read_modes(path, vectors=want)
    modes.attrs["modes_source"] = str(path)
    dof_grain = dof_axis = None
    if want:
        # The modes file has no dof map: take it from the linear file it was made from.
        linear = modes.attrs.get("linear_source")
        if not linear or not _exists(linear):
            raise InputError(f"{path}: snapshots need the dof map of the linear file it came from "
                             f"({linear or 'unknown'}, not found); run propagate on the linear file "
                             "instead (--method modal or time)")
        system = files.read_linear(linear)
        dof_grain, dof_axis = system.dof_grain, system.dof_axis
    return modal_propagate(modes, ic=opts["ic"], t_max=opts["t_max"], samples=opts["samples"],
                           snapshots=opts["snapshots"], dof_grain=dof_grain, dof_axis=dof_axis)


def _modal_from_linear(path, opts):
    from ..io import files
    from ..linear.eigen import eigensolve
    from ..linear.propagate import modal_propagate

    system = files.read_linear(path)
    system.attrs["linear_source"] = str(path)
    modes = eigensolve(system, vectors=opts["snapshots"] is not None)
    return modal_propagate(modes, ic=opts["ic"], t_max=opts["t_max"], samples=opts["samples"],
                           snapshots=opts["snapshots"], dof_grain=system.dof_grain,
                           dof_axis=system.dof_axis)


def _time_from_linear(path, opts):
    from ..io import files
    from ..linear.propagate import time_domain_signal

    system = files.read_linear(path)
    system.attrs["linear_source"] = str(path)
    return time_domain_signal(system, ic=opts["ic"], t_max=opts["t_max"], dt=opts["dt"],
                              samples=opts["samples"], safety=opts["safety"],
                              snapshots=opts["snapshots"], progress=progress_printer(opts["progress"]))


def _time_from_modes(path, opts):
    from ..errors import InputError

    raise InputError(f"{path} is a modes file: the time domain needs the linear file "
                     "(granwave linearize output)")


def _dem_from_packing(path, opts):
    """Nonlinear DEM pulse from a packing file (granwave.dem.pulse, docs/damping.md)."""
    from ..dem.pulse import DEFAULT_AMPLITUDE, propagate_dem
    from ..errors import InputError
    from ..io import files

    if opts["snapshots"] is not None:
        raise InputError("--snapshots is not available with --method dem")
    packing = files.read_packing(path)
    amplitude = DEFAULT_AMPLITUDE if opts["amplitude"] is None else opts["amplitude"]
    return propagate_dem(packing, ic=opts["ic"], amplitude=amplitude, damping=opts["damping"] or 0.0,
                         t_max=opts["t_max"], samples=opts["samples"], dt=opts["dt"],
                         progress=progress_printer(opts["progress"]))


RUNNERS = {
    ("granwave.modes", "modal"): _modal_from_modes,
    ("granwave.linear", "modal"): _modal_from_linear,
    ("granwave.linear", "time"): _time_from_linear,
    ("granwave.modes", "time"): _time_from_modes,
    ("granwave.packing", "dem"): _dem_from_packing,
}


@click.command()
@click.argument("source", metavar="(MODES | LINEAR | PACKING)", type=click.Path(dir_okay=False))
@output_option
@click.option("--ic", type=click.Choice(["A", "B"], case_sensitive=False), default="A", show_default=True,
              help="Initial condition: A = impulse on the grains touching the bottom wall, "
                   "B = their displacement (docs/conventions.md).")
@click.option("--t-max", "t_max", type=POSITIVE, required=True,
              help="Length of the signal, in d/sqrt(E*/rho) (the crossing time is height / c).")
@click.option("--method", type=click.Choice(METHODS), default=None,
              help="modal (needs a modes file, or eigensolves a linear file on the fly) or time "
                   "(velocity Verlet on a linear file) or dem (nonlinear Hertz-Mindlin DEM on a "
                   "packing file). Default: modal for a modes file, time for a linear file, dem for "
                   "a packing file.")
@click.option("--dt", type=POSITIVE, default=None,
              help="Time step of the time-domain method (default: safety x 2/omega_max, shortened "
                   "to fit an integer number of steps per sample); with dem, default 0.01 x the "
                   "shortest contact period 2 pi sqrt(m_min/k_max).")
@click.option("--safety", type=FiniteFloat(min=0.0, max=1.0, min_open=True, max_open=True),
              default=0.1, show_default=True,
              help="Default time step as a fraction of the stability limit 2/omega_max.")
@click.option("--samples", type=click.IntRange(min=2), default=2001, show_default=True,
              help="Number of equally spaced output times from 0 to t_max.")
@click.option("--snapshots", default=None, metavar="T1,T2,...",
              help="Store the displacement field at these times (modal needs a modes file made "
                   "with --vectors).")
@click.option("--amplitude", type=POSITIVE, default=None,
              help="dem only: EPS, kick size such that the largest single-contact displacement "
                   "estimate of a kicked grain is EPS x the mean overlap of the packing's contacts "
                   "(A: v_i sqrt(m_i/k_wall,i); B: the imposed displacement). Default 1e-3 "
                   "(linear regime). The signal is divided by the kick's scale (docs/damping.md).")
@click.option("--damping", type=FiniteFloat(min=0.0, max=1.0), default=None,
              help="dem only: contact damping zeta, fraction of critical, normal and tangential "
                   "(SPEC §2). Default 0.")
@click.option("--quiet", is_flag=True, help="No progress lines on stderr.")
@json_option
@stage
def propagate(source, output, ic, t_max, method, dt, safety, samples, snapshots, amplitude, damping,
              quiet, as_json):
    """Signal F_sig(t) on the top wall, in E* d^2, after a kick at the bottom (SPEC §8).

    Reads a granwave.modes file (modal sum), a granwave.linear file (time
    domain, no eigendecomposition needed) or a granwave.packing file (--method
    dem: nonlinear DEM pulse, fixed walls, contact damping). Writes a granwave.signal file with
    signal/time and signal/force and the run's parameters as attributes.
    """
    from ..errors import InputError
    from ..io import files

    files.check_writable(output)
    kind = files.file_schema(source) if _exists(source) else None
    if kind is None:
        raise InputError(f"{source}: no such file")
    if method is None:
        method = {"granwave.modes": "modal", "granwave.packing": "dem"}.get(kind, "time")
    runner = RUNNERS.get((kind, method))
    if runner is None:
        raise InputError(f"{source}: cannot run --method {method} on a {kind or 'non-granwave'} file "
                         "(expected a granwave.modes or granwave.linear file, or a "
                         "granwave.packing file with --method dem)")
    if method != "dem" and (amplitude is not None or damping is not None):
        raise InputError("--amplitude and --damping apply to --method dem only")
    opts = dict(ic=ic.upper(), t_max=t_max, dt=dt, safety=safety, samples=samples,
                snapshots=_parse_times(snapshots), progress=not quiet, amplitude=amplitude,
                damping=damping)
    signal = runner(source, opts)
    signal.attrs["source_file"] = str(source)
    files.write_signal(output, signal)
    rows = {k: signal.attrs[k] for k in ("ic", "method", "height", "t_max", "samples", "dt",
                                         "omega_max_dt", "modified_energy_max_rel_deviation",
                                         "amplitude", "damping", "n_opened", "n_formed", "n_sliding",
                                         "max_displacement_over_overlap")
            if k in signal.attrs}
    echo_json(rows) if as_json else echo_table(rows, title=f"wrote {output}")


def _exists(path) -> bool:
    from pathlib import Path

    return Path(path).is_file()
