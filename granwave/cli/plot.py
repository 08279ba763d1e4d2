"""``granwave plot <figure> INPUTS... -o FIG.png``: the study's figures (granwave.figures).

Thin wrappers: read the inputs, call one function of :mod:`granwave.figures`.
matplotlib is imported only inside the commands, so ``granwave --help`` stays fast.
"""

from __future__ import annotations


import click

from .common import POSITIVE, is_quiet, long_run_option, output_path_option, quiet_flag, stage


def load_json(path):
    """granwave.io.files.load_json, imported on use so that `granwave --help` stays fast."""
    from ..io.files import load_json as load

    return load(path)

_fig_path = output_path_option((".png", ".pdf", ".svg"), help="Output figure, written atomically.")


_scene = click.option("--scene", default=None, metavar="NAME",
                      help="The scene's name for the figure's title (e.g. the workflow config's).")


def fig_output(func):
    """``-o FIG``, ``-q`` and ``--scene`` of every figure."""
    return _fig_path(quiet_flag(_scene(func)))
pdf_option = click.option("--pdf", is_flag=True, help="Also write a PDF beside the PNG.")


def _figures():
    import matplotlib

    matplotlib.use("Agg")
    from .. import figures

    return figures


def _done(paths) -> None:
    for p in [] if is_quiet() else paths:
        click.echo(f"wrote {p}", err=True)


def read_ensemble(path) -> dict:
    """An ``analyze ensemble`` file as a dict (time, mean, rms, n, height, attrs)."""
    from ..analysis.ensemble import read_ensemble as _read

    e = _read(path)
    return {"time": e.time, "mean": e.mean, "rms": e.rms, "n": e.attrs.get("n_signals"),
            "height": e.attrs.get("height", e.attrs.get("height_mean")), "attrs": e.attrs}


def _signal_or_ensemble(path) -> dict:
    """A coherent-signal series entry from an ensemble file or a single signal file."""
    from ..errors import InputError
    from ..io import schema as S
    from ..io.files import file_schema, read_signal

    kind = file_schema(path)
    if kind == S.ENSEMBLE:
        e = read_ensemble(path)
        if e["height"] is None:
            raise InputError(f"{path}: the ensemble file has no 'height' attribute")
        return e
    s = read_signal(path)
    return {"time": s.time, "mean": s.force, "rms": None, "n": 1, "height": s.height, "attrs": s.attrs}


@click.group()
def plot():
    """Draw the study's figures (one subcommand per figure; see docs/figures.md).

    Every subcommand writes one figure with -o FILE.png (add --pdf for a PDF
    twin). Units: d̄, E*, time d̄/sqrt(E*/ρ) (docs/method.md §1).
    """


@plot.command()
@click.argument("packing", type=click.Path(dir_okay=False))
@fig_output
@pdf_option
@click.option("--walls", is_flag=True, help="Include wall contacts in the histograms.")
@stage
def network(packing, output, pdf, scene, walls):
    """Force and stiffness networks of a packing, with their histograms."""
    figs = _figures()
    from ..io.files import read_packing

    figs.output_paths(output, pdf)
    _done(figs.force_network(read_packing(packing), output, pdf=pdf, walls=walls, scene=scene))


@plot.command()
@click.argument("packing", type=click.Path(dir_okay=False))
@fig_output
@pdf_option
@click.option("--walls", is_flag=True, help="Include wall contacts.")
@click.option("--bins", type=click.IntRange(4, 360), default=36, show_default=True)
@stage
def roses(packing, output, pdf, scene, walls, bins):
    # Every plot command has this shape (read one file, call one figure of
    # granwave.figures); they differ in the reader and the figure, not in logic.
    """Contact-direction roses: all, strong and weak contacts."""
    figs = _figures()
    from ..io.files import read_packing

    figs.output_paths(output, pdf)
    _done(figs.contact_roses(read_packing(packing), output, pdf=pdf, walls=walls, bins=bins, scene=scene))


@plot.command()
@click.argument("signal", type=click.Path(dir_okay=False))
@click.option("--packing", type=click.Path(dir_okay=False),
              help="Packing file (positions, radii) if the signal stores no positions.")
@click.option("--index", "index", type=int, multiple=True,
              help="Snapshot index (repeatable; default: up to four spread over the record).")
@click.option("--modes", type=click.Path(dir_okay=False),
              help="Modes file with eigenvectors (eigensolve --vectors) of the same packing: adds "
                   "the row-averaged energy E(y, t) and the low-pass displacement maps (needs "
                   "--linear and --packing).")
@click.option("--linear", type=click.Path(dir_okay=False), help="The linear file of --modes.")
@click.option("--cutoff-factor", type=click.FloatRange(0, min_open=True), default=None,
              help="Low-pass cut-off ω_c = factor × π / W, W the front width (docs/figures.md); "
                   "default: granwave.analysis.pulse_field.row_fields's, twice the front's "
                   "own frequency.")
@fig_output
@pdf_option
@stage
def snapshot(signal, packing, index, modes, linear, cutoff_factor, output, pdf, scene):
    """The pulse: displacement snapshots on one scale and, with --modes, the coherent front
    in space and time (energy E(y, t) on a log scale, low-pass displacement, arrival lines)."""
    figs = _figures()
    from ..errors import InputError
    from ..io.files import read_linear, read_modes, read_packing, read_signal
    from ..io.validate import same_packing, same_system

    figs.output_paths(output, pdf)
    if (modes is None) != (linear is None) or (modes and not packing):
        raise InputError("--modes needs --linear and --packing (and the other way round)")
    sig = read_signal(signal)
    pk = read_packing(packing) if packing else None
    if pk is not None:
        same_packing(signal, sig, packing, pk)
    fields = None
    if modes:
        from ..analysis.pulse_field import row_fields

        cut = {} if cutoff_factor is None else {"cutoff_factor": cutoff_factor}
        lin, mo = read_linear(linear), read_modes(modes, vectors=True)
        same_packing(linear, lin, packing, pk)
        same_system(modes, mo, linear, lin)
        fields = row_fields(lin, mo, pk.position,
                            ic=str(sig.attrs.get("ic", "A")), t_max=float(sig.time[-1]), **cut)
    _done(figs.displacement_snapshot(sig, output, packing=pk, index=list(index) or None,
                                     fields=fields, pdf=pdf, scene=scene))


@plot.command()
@click.argument("signals", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--ensemble", type=click.Path(dir_okay=False),
              help="Ensemble file (analyze ensemble) for the average ± rms panel; default: "
                   "the average of the given signals.")
@click.option("--max-traces", type=click.IntRange(1), default=30, show_default=True)
@fig_output
@pdf_option
@stage
def signals(signals, ensemble, max_traces, output, pdf, scene):
    """Signals of several packings overlaid, and the ensemble average ± rms."""
    figs = _figures()
    from ..io.files import read_signal

    figs.output_paths(output, pdf)
    sigs = [read_signal(s) for s in signals]
    ens = read_ensemble(ensemble) if ensemble else None
    _done(figs.signals_overlay(sigs, output, ensemble=ens, max_traces=max_traces, pdf=pdf, scene=scene))


@plot.command()
@click.argument("signals", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--label", "labels", multiple=True, help="Label per signal (default: from attributes).")
@click.option("--speed", "speeds", type=POSITIVE, multiple=True,
              help="Speed per signal: time axis t c/L (give one per signal, or none for raw time).")
@fig_output
@pdf_option
@stage
def compare(signals, labels, speeds, output, pdf, scene):
    """Signals of different systems (frictional 2D, frictionless 2D, 3D) in one panel."""
    figs = _figures()
    from ..errors import InputError
    from ..io.files import read_signal

    figs.output_paths(output, pdf)
    if labels and len(labels) != len(signals):
        raise InputError(f"give one --label per signal ({len(signals)}), or none")
    if speeds and len(speeds) != len(signals):
        raise InputError(f"give one --speed per signal ({len(signals)}), or none")
    sigs = [read_signal(s) for s in signals]
    _done(figs.signal_comparison(sigs, output, labels=list(labels) or None,
                                  speeds=list(speeds) or None, pdf=pdf, scene=scene))


@plot.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@fig_output
@pdf_option
@stage
def coherent(files, output, pdf, scene):
    """Coherent part at several heights (ensemble files with a height, or signal files)."""
    figs = _figures()
    figs.output_paths(output, pdf)
    _done(figs.coherent_heights([_signal_or_ensemble(f) for f in files], output, pdf=pdf, scene=scene))


@plot.command()
@click.argument("heights_json", type=click.Path(dir_okay=False))
@fig_output
@pdf_option
@stage
def arrivals(heights_json, output, pdf, scene):
    """Arrival times of the three characteristic points against L (analyze heights --json)."""
    figs = _figures()
    from ..report import heights_arrays

    figs.output_paths(output, pdf)
    data = heights_arrays(load_json(heights_json), source=heights_json)
    _done(figs.arrival_times(data, output, pdf=pdf, scene=scene))


@plot.command()
@click.argument("heights_json", nargs=-1, type=click.Path(dir_okay=False))
@click.option("--label", "labels", multiple=True, help="Label per file (default: from the path).")
@click.option("--chain", "chain", default="", metavar="N1,N2,...",
              help="Add the exact identical-ball chain (theory) at these N, e.g. 50,100,200,400.")
@click.option("--ic", type=click.Choice(["A", "B"]), default="A", show_default=True,
              help="Initial condition of the --chain series.")
@fig_output
@pdf_option
@stage
def exponents(heights_json, labels, chain, ic, output, pdf, scene):
    """A(L) and W(L) log-log: ensemble means per height ± standard error, the fits of
    `analyze heights`, and local exponents between distinct heights with error bars."""
    figs = _figures()
    from ..errors import InputError
    from ..report import chain_series, heights_means, label_from_path

    figs.output_paths(output, pdf)
    if labels and len(labels) != len(heights_json):
        raise InputError(f"give one --label per file ({len(heights_json)}), or none")
    series = {}
    for k, path in enumerate(heights_json):
        lab = labels[k] if labels else label_from_path(path)
        series[lab] = heights_means(load_json(path), source=path)
    if chain:
        try:
            ns = [int(x) for x in chain.split(",") if x.strip()]
        except ValueError:
            raise InputError(f"--chain: {chain!r} is not a list of integers") from None
        series[f"chain (exact, {ic})"] = chain_series(ns, ic=ic)
    if not series:
        raise InputError("give heights JSON files and/or --chain")
    if chain:  # the exact chain's own reference; else each series' initial condition's
        series[f"chain (exact, {ic})"]["ic"] = ic
    _done(figs.amplitude_width(series, output, pdf=pdf, scene=scene))


@plot.command()
@click.argument("sweep_json", type=click.Path(dir_okay=False))
@click.option("--lattice", "lattice", multiple=True, type=click.Path(dir_okay=False),
              help="Heights JSON of a frictionless lattice (repeatable): markers.")
@click.option("--lattice-frictional", "lattice_fr", multiple=True, type=click.Path(dir_okay=False),
              help="Heights JSON of a frictional lattice (repeatable): markers.")
@click.option("--lattice-speed", type=click.Choice(["tof", "peak", "zero"]), default="tof",
              show_default=True, help="Which lattice speed to draw.")
@click.option("--poisson", type=click.FloatRange(0, 1, max_open=True), default=0.0, show_default=True,
              help="Poisson ratio for the frictional lattice theory.")
@fig_output
@pdf_option
@stage
def speeds(sweep_json, lattice, lattice_fr, lattice_speed, poisson, output, pdf, scene):
    """Speeds against pressure (pressure-sweep --json) with the lattice theory."""
    figs = _figures()
    from ..report import sweep_speeds

    figs.output_paths(output, pdf)
    data = sweep_speeds(load_json(sweep_json), source=sweep_json)
    points = []
    key = {"tof": "c_tof", "peak": "c_peak", "zero": "c_zero"}[lattice_speed]
    for files, fr in ((lattice, 0.0), (lattice_fr, 1.0)):
        for path in files:
            h = load_json(path)
            if h.get(key) is not None and h.get("pressure") is not None:
                points.append({"pressure": h["pressure"], "speed": h[key], "friction": fr,
                               "label": f"lattice simulation ({key}), "
                                        + ("frictional" if fr else "frictionless")})
    _done(figs.speeds_vs_pressure(data, output, lattice_points=points, poisson=poisson, pdf=pdf,
                                  scene=scene))


@plot.command()
@click.argument("modes", type=click.Path(dir_okay=False))
@click.option("--ic", type=click.Choice(["A", "B"]), default="A", show_default=True)
@click.option("--bins", type=click.IntRange(5), default=60, show_default=True)
@fig_output
@pdf_option
@stage
def spectrum(modes, ic, bins, output, pdf, scene):
    """Eigen-spectrum (density of ω) and the weights a_n b_n."""
    figs = _figures()
    from ..io.files import read_modes

    figs.output_paths(output, pdf)
    _done(figs.spectrum(read_modes(modes), output, ic=ic, bins=bins, pdf=pdf, scene=scene))


@plot.command()
@click.argument("modes", type=click.Path(dir_okay=False))
@click.argument("linear", type=click.Path(dir_okay=False))
@click.argument("packing", type=click.Path(dir_okay=False))
@click.option("--mode", "mode_index", type=click.IntRange(0), multiple=True,
              help="Mode index (repeatable; default: lowest nonzero, strongest a_n b_n, most localized).")
@click.option("--ic", type=click.Choice(["A", "B"]), default="A", show_default=True)
@fig_output
@pdf_option
@stage
def modes(modes, linear, packing, mode_index, ic, output, pdf, scene):
    """Selected mode shapes as arrows (needs eigensolve --vectors)."""
    figs = _figures()
    import numpy as np

    from ..errors import InputError
    from ..io.files import read_linear, read_modes, read_packing

    figs.output_paths(output, pdf)
    m = read_modes(modes, vectors=True)
    lin = read_linear(linear)
    pk = read_packing(packing)
    if m.vectors.shape[0] != lin.n_dof:
        raise InputError(f"{modes} and {linear} differ in the number of dofs")
    if mode_index:
        n = m.vectors.shape[1]
        bad = [i for i in mode_index if i >= n]
        if bad:
            raise InputError(f"mode index {bad[0]} out of range (the file has {n} modes)")
        chosen = {f"mode {i}": i for i in mode_index}
    else:
        chosen = figs.select_modes(m, dof_grain=lin.dof_grain, dof_axis=lin.dof_axis, dim=pk.dim,
                                    ic=ic)
    idx = list(chosen.values())
    names = {"lowest nonzero": "lowest-frequency mode with ω > 0",
             "strongest |a_n b_n|": "largest weight |a_n b_n|",
             "most localized": "most localized (least participation)"}
    labels = [f"{names.get(name, name)} (file index {i})" if not name.startswith("mode") else name
              for name, i in chosen.items()]
    _done(figs.mode_shapes(m.vectors[:, idx], lin.dof_grain, lin.dof_axis, pk.position, output,
                            omega=np.sqrt(np.maximum(m.omega2[idx], 0)), labels=labels,
                            radius=pk.radius, box=pk.box, pdf=pdf, scene=scene,
                            pressure=pk.attrs.get("pressure")))


@plot.command()
@click.argument("signals", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--reference", type=click.Path(dir_okay=False),
              help="A reference signal (e.g. the linear model) drawn dashed in every panel.")
@fig_output
@pdf_option
@stage
def damping(signals, reference, output, pdf, scene):
    """Signals of one packing for several contact dampings ζ (attribute 'damping')."""
    figs = _figures()
    from ..io.files import read_signal

    figs.output_paths(output, pdf)
    ref = read_signal(reference) if reference else None
    _done(figs.damping_series([read_signal(s) for s in signals], output, reference=ref,
                               labels=list(signals), pdf=pdf, scene=scene))


@plot.command()
@click.option("--n", "n_balls", type=click.IntRange(2), multiple=True,
              help="Chain length N (repeatable; default 25 50 100 200).")
@click.option("--ic", type=click.Choice(["A", "B"]), default="A", show_default=True)
@fig_output
@pdf_option
@long_run_option
@stage
def airy(n_balls, ic, output, pdf, scene):
    """Chain wall force (exact modal sum) against the Airy asymptote, co-moving frame."""
    figs = _figures()
    figs.output_paths(output, pdf)
    _done(figs.chain_airy(output, n_balls=list(n_balls) or (25, 50, 100, 200), ic=ic, pdf=pdf, scene=scene))


@plot.command()
@click.argument("front_json", type=click.Path(dir_okay=False))
@click.option("--attenuation", "attenuation_json", type=click.Path(dir_okay=False), default=None,
              help="`analyze attenuation --json` output: adds the alpha(omega) and c(omega) panels.")
@fig_output
@pdf_option
@stage
def continuum(front_json, attenuation_json, output, pdf, scene):
    """The continuum scene from `analyze continuum --json`: local speeds and c_l against L,
    c_tof/c_l with its fit, amplitude and width with local exponents, and (with
    --attenuation) alpha(omega), c(omega) with the reliable band."""
    figs = _figures()
    figs.output_paths(output, pdf)
    att = load_json(attenuation_json) if attenuation_json else None
    _done(figs.continuum_panels(load_json(front_json), att, output, pdf=pdf, scene=scene))


@plot.command()
@click.argument("analysis_json", type=click.Path(dir_okay=False))
@fig_output
@pdf_option
@stage
def shear(analysis_json, output, pdf, scene):
    """A shear scene from its analysis (results/shear/<scene>/analysis.json): V_s, V_p and c_t,
    c_l against pressure, G_max against p^1/3, V_p/V_s and the Poisson ratio from waves and
    moduli, and every pick's V/c_t against distance (docs/shear.md)."""
    from ..errors import InputError

    figs = _figures()
    figs.output_paths(output, pdf)
    data = load_json(analysis_json)
    if not (isinstance(data, dict) and "pick_table" in data and "pressures" in data):
        raise InputError(f"{analysis_json}: not a shear-scene analysis (no pick_table / pressures)")
    _done(figs.shear_panels(data, output, pdf=pdf, scene=scene))


@plot.command()
@click.argument("analysis_json", type=click.Path(dir_okay=False))
@fig_output
@pdf_option
@stage
def shocks(analysis_json, output, pdf, scene):
    """A shocks scene from its analysis (results/shocks/<scene>/analysis.json, `granwave analyze
    shocks --json`): V/c0 against eps/delta0 with the mean-field curve, V against eps, the
    crossover strain against p and the fractions of opening and sliding contacts (docs/shocks.md)."""
    from ..errors import InputError

    figs = _figures()
    figs.output_paths(output, pdf)
    data = load_json(analysis_json)
    if not (isinstance(data, dict) and isinstance(data.get("scenes"), dict)):
        raise InputError(f"{analysis_json}: not a shocks analysis (no scenes)")
    _done(figs.shocks_panels(data, output, pdf=pdf, scene=scene))
