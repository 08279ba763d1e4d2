"""The granwave library API: one function per stage, objects in, objects out.

Every function takes the in-memory objects of :mod:`granwave.model`
(:class:`Packing`, :class:`LinearSystem`, :class:`Modes`, :class:`Signal`)
and a frozen parameter object of :mod:`granwave.params`, and returns an
object or a summary dict; nothing here reads or writes files (use
:mod:`granwave.io.files` for that). Parameters may also be given as keywords,
which build (or replace fields of) the stage's parameter object::

    from granwave import api
    packing = api.prepare_packing(grains=100, pressure=1e-4, seed=1)
    system = api.linearize(packing)
    signal = api.propagate(system, t_max=300.0, method="auto")
    front = api.front(signal)

Errors in the input raise :class:`granwave.errors.InputError`. Compute stages
take ``threads`` (:func:`granwave.threads.set_threads`; None leaves the
process's setting, by default every core); the results do not depend on it. Units: docs/method.md §1. A walk-through:
docs/api.md.
"""

from __future__ import annotations

from collections.abc import Mapping

import dataclasses
import math
import warnings
from typing import Callable, Sequence

import numpy as np

from .contact_models import options as CO
from .errors import InputError
from .io import validate as V
from .model import LinearSystem, Modes, Packing, Signal
from .params import (ChainParams, DampingParams, EigenParams, EnsembleParams, FrontParams,
                     HeightsParams, LatticeParams, LinearizeParams, ModuliParams, PrepareParams,
                     PropagateParams, SpectrumParams, StaticsParams, SweepParams)

__all__ = ["prepare_packing", "prepare_packings", "lattice", "chain", "linearize", "eigensolve", "propagate",
           "choose_method", "statics", "moduli", "front", "heights", "ensemble", "spectrum",
           "damping", "pressure_sweep", "AliasingWarning"]


class AliasingWarning(UserWarning):
    """The output sample interval is longer than pi/omega_max: the highest modes alias."""


def _params(cls, params, fields: dict):
    """``params`` (or the class defaults) with ``fields`` replaced; validated on creation."""
    if params is not None and not isinstance(params, cls):
        raise InputError(f"expected {cls.__name__}, got {type(params).__name__}")
    known = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(fields) - set(known))
    if unknown:
        raise InputError(f"unknown parameter(s) {', '.join(unknown)} (the fields of {cls.__name__}: "
                         f"{', '.join(known)})")
    if params is None:
        missing = [name for name, f in known.items() if name not in fields and f.init
                   and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
        if missing:
            raise InputError(f"missing parameter(s) {', '.join(missing)} ({cls.__name__})")
        return cls(**fields)
    return dataclasses.replace(params, **fields) if fields else params


def _need(obj, cls, name: str):
    """``obj`` if it is a ``cls`` (a class or a tuple of them); else InputError naming it.

    The library's entry points check the kinds of their objects here, so that a path, a
    dict or another stage's object is one line, not an AttributeError deep inside.
    """
    if not isinstance(obj, cls):
        want = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        hint = " (read it first: granwave.io.files.read_*)" if isinstance(obj, (str, bytes)) or hasattr(obj, "__fspath__") else ""
        raise InputError(f"{name} must be a {want}, got {type(obj).__name__}{hint}")
    return obj


def _need_all(objs, cls, name: str) -> list:
    """A list of ``cls`` objects from a sequence (not a single object, not a string)."""
    if isinstance(objs, (str, bytes, dict)) or not hasattr(objs, "__iter__") or isinstance(objs, cls):
        raise InputError(f"{name} must be a sequence of {cls.__name__} objects, got {type(objs).__name__}")
    objs = list(objs)
    for k, obj in enumerate(objs):
        _need(obj, cls, f"{name}[{k}]")
    return objs


def _labels(labels, n: int):
    if labels is None:
        return None
    if isinstance(labels, (str, bytes)) or not hasattr(labels, "__iter__"):
        raise InputError(f"labels must be a sequence of strings, got {type(labels).__name__}")
    labels = [str(x) for x in labels]
    if len(labels) != n:
        raise InputError(f"{len(labels)} labels for {n} objects")
    return labels


def _progress(progress):
    if progress is not None and not callable(progress):
        raise InputError(f"progress must be a callable taking one line of text, got {type(progress).__name__}")
    return progress


def _threads(threads: int | None) -> None:
    """Set the parallel kernels' thread count; None leaves the process's setting alone."""
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
            raise InputError(f"threads must be a positive integer, got {threads!r}")
        from .threads import set_threads

        set_threads(threads)


# ----------------------------------------------------------------- packings
def prepare_packing(params: PrepareParams | None = None, /, *, progress: Callable[[str], None] | None = None,
                    threads: int | None = None, device: str | None = None, checkpoint=None,
                    checkpoint_every: float = 600.0, keep_checkpoint: bool = False, **fields) -> Packing:
    """A disordered packing by piston compression of a granular gas (docs/method.md §3).

    ``progress`` receives one line of text about once a second. Raises
    ConvergenceError when the step budget (``max_steps``; default 2e6 per 100 d of the
    expected height, at least 2e6) does not converge. The protocol is
    recorded in ``packing.attrs`` (one attribute per parameter, and the whole
    parameter object as JSON in ``prepare_params``). ``device``: "cpu" (default)
    or "gpu" (docs/gpu.md; recorded as the attribute ``device`` when "gpu").

    ``checkpoint``: a file path. The run's state is written there atomically
    every ``checkpoint_every`` seconds (0: at every chunk of steps); when the file exists at
    the start and belongs to these parameters (seed included) and this granwave source, the
    run goes on from it, and the packing is the same, bit for bit, as an uninterrupted
    run's; another run's checkpoint, or one written on the other device, is refused
    (InputError). The file is removed once the
    packing is returned, unless ``keep_checkpoint`` (the command line removes it after
    writing the packing). docs/dem.md "Checkpoints".
    """
    from .dem.protocol import prepare_packing as run
    from .devices import backend

    p = _params(PrepareParams, params, fields)
    refused = CO.cpu_only(CO.values_of(p)) if device not in (None, "cpu") else None
    if refused:
        raise InputError(refused)
    _progress(progress)
    kernels = backend(device)
    _threads(threads)
    saved = None
    if checkpoint is not None:
        from .dem.checkpoint import Checkpoint

        saved = Checkpoint(checkpoint, p, checkpoint_every, device=kernels.device)
        saved.check()  # refuse another run's checkpoint before any work
    packing = run(p, progress=progress, engine=kernels.engine, checkpoint=saved)
    if saved is not None and not keep_checkpoint:
        saved.remove()
    p.record(packing.attrs)
    if kernels.device != "cpu":
        packing.attrs["device"] = kernels.device
    return packing


def prepare_packings(params: PrepareParams | None = None, /, *, seeds, progress: Callable[[str], None] | None = None,
                     threads: int | None = None, device: str | None = None, checkpoint: str | None = None,
                     checkpoint_every: float = 600.0, keep_checkpoint: bool = False, **fields) -> list[Packing]:
    """One packing per seed of ``seeds`` (the parameters otherwise the same; ``params.seed`` is
    not used), in the order of ``seeds``: each the packing :func:`prepare_packing` makes for that
    seed on that device, with the same attributes, bit for bit.

    ``device="gpu"`` prepares them together, advanced by the same kernel launches (docs/gpu.md
    "Ensembles per launch"); ``"cpu"`` (default) one after another. ``progress`` lines start
    with ``seed N:``. When a seed does not converge, the first such error (in the order of
    ``seeds``, its message starting with ``seed N:``) is raised once every seed has ended.

    ``checkpoint``: a file path with ``{seed}`` (one checkpoint per seed, as
    :func:`prepare_packing`'s): each seed goes on from its own file, to the same bits. The
    files are removed once every packing is returned (none when a seed fails, so that a second
    call goes on from them), unless ``keep_checkpoint``.
    """
    p = _params(PrepareParams, params, fields)
    if isinstance(seeds, (str, bytes, dict)) or not hasattr(seeds, "__iter__"):
        raise InputError(f"seeds must be a sequence of integers, got {type(seeds).__name__} {seeds!r}")
    checked = []
    for k, s in enumerate(seeds):  # each validated as PrepareParams.seed, before any work
        try:
            checked.append(dataclasses.replace(p, seed=s).seed)
        except InputError as exc:
            raise InputError(f"seeds[{k}]: {exc}") from None
    seeds = checked
    if not seeds or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise InputError(f"seeds must be distinct non-negative integers, at least one (got {seeds!r})")
    _progress(progress)
    if checkpoint is not None and "{seed}" not in str(checkpoint):
        raise InputError(f"checkpoint {str(checkpoint)!r} must contain {{seed}} (one checkpoint per seed)")
    paths = {s: None if checkpoint is None else str(checkpoint).replace("{seed}", str(s)) for s in seeds}
    if device in (None, "cpu"):
        from .dem.checkpoint import Checkpoint

        for s in seeds:  # every seed's checkpoint refused or accepted before any work
            if paths[s] is not None:
                Checkpoint(paths[s], dataclasses.replace(p, seed=s), checkpoint_every).check()

        def one(s):
            tell = None if progress is None else (lambda line: progress(f"seed {s}: {line}"))
            return prepare_packing(dataclasses.replace(p, seed=s), progress=tell, threads=threads, device=device,
                                   checkpoint=paths[s], checkpoint_every=checkpoint_every, keep_checkpoint=True)

        packings = [one(s) for s in seeds]
    else:
        packings = _prepare_on_gpu(p, seeds, paths, checkpoint_every, progress, threads, device)
    if checkpoint is not None and not keep_checkpoint:
        _remove_checkpoints(p, paths)
    return packings


def _prepare_on_gpu(p: PrepareParams, seeds: list, paths: dict, every: float, progress, threads,
                    device) -> list[Packing]:
    """:func:`prepare_packings` on the GPU: the seeds advanced together (the GPU's ``prepare_packings``), each
    from its checkpoint ``paths[seed]`` (None: none)."""
    from .dem.checkpoint import Checkpoint
    from .devices import backend

    refused = CO.cpu_only(CO.values_of(p))
    if refused:
        raise InputError(refused)
    kernels = backend(device)  # a missing GPU fails here, before any work
    _threads(threads)
    saved = [None if paths[s] is None else Checkpoint(paths[s], dataclasses.replace(p, seed=s), every,
                                                      device=kernels.device) for s in seeds]
    for c in saved:
        if c is not None:
            c.check()  # refuse another run's checkpoint before any work
    packings = kernels.prepare_packings(p, seeds, progress=progress, checkpoints=saved)
    for s, packing in zip(seeds, packings):
        dataclasses.replace(p, seed=s).record(packing.attrs)
        packing.attrs["device"] = kernels.device
    return packings


def _remove_checkpoints(p: PrepareParams, paths: dict) -> None:
    """Delete the seeds' checkpoints (every packing is returned)."""
    from .dem.checkpoint import Checkpoint

    for s, path in paths.items():
        Checkpoint(path, dataclasses.replace(p, seed=s)).remove()


def _contact_fields(p) -> dict:
    """The contact sub-models' fields a stage's parameters hold (granwave.contact_models.options),
    by name: what systems.triangular_lattice and systems.chain take."""
    names = set(CO.options())
    return {f.name: getattr(p, f.name) for f in dataclasses.fields(p) if f.name in names}


def lattice(params: LatticeParams | None = None, /, **fields) -> Packing:
    """Perfect triangular lattice under pressure (docs/method.md §3, §12; granwave.systems)."""
    from .systems import triangular_lattice

    p = _params(LatticeParams, params, fields)
    packing = triangular_lattice(rows=p.rows, width=p.width, pressure=p.pressure,
                                 friction=p.friction, poisson=p.poisson, **_contact_fields(p))
    p.record(packing.attrs)
    return packing


def chain(params: ChainParams | None = None, /, **fields) -> Packing:
    """1D chain of balls between two walls (docs/method.md §3, §12; granwave.systems)."""
    from .systems import chain as make_chain

    p = _params(ChainParams, params, fields)
    law = p.law()
    contact = {k: v for k, v in _contact_fields(p).items() if k != "contact_law"}
    if law is not None:
        contact["contact_law"] = law
    packing = make_chain(n_balls=p.balls, pressure=p.pressure, polydispersity=p.polydispersity,
                         seed=p.seed, stiffness=p.stiffness,
                         stiffness_model="equal" if law is None else "law", **contact)
    p.record(packing.attrs)
    return packing


# ----------------------------------------------------------------- linear model
def linearize(packing: Packing, params: LinearizeParams | None = None, /, *,
              threads: int | None = None, progress=None, **fields) -> LinearSystem:
    """Stiffness matrix D and mass matrix M around equilibrium (docs/method.md §5).

    ``progress``: a callable taking one line of text (assembly and check times of
    large systems, the check's iterations).
    """
    from .linear.assemble import linearize as build

    _need(packing, Packing, "packing")
    V.contact_indices("packing", len(packing.radius), packing.contacts.i, packing.contacts.j)
    _progress(progress)
    p = _params(LinearizeParams, params, fields)
    _threads(threads)
    system = build(packing, prestress=p.prestress, force=p.force, check=p.check, progress=progress,
                   remove_spins=not p.keep_spins)
    p.record(system.attrs)
    return system


def eigensolve(system: LinearSystem, params: EigenParams | None = None, /, *,
               threads: int | None = None, **fields) -> Modes:
    """Spectrum and signal projections of D phi = omega^2 M phi (docs/method.md §7).

    Emits granwave.linear.eigen.NegativeModesWarning when D is not positive
    semi-definite.
    """
    from .linear.eigen import eigensolve as solve

    _need(system, LinearSystem, "system")
    V.linear_system(system)  # a negative mass gave NaN modes
    p = _params(EigenParams, params, fields)
    _threads(threads)
    modes = solve(system, vectors=p.vectors, k=p.lowest)
    p.record(modes.attrs)
    return modes


# ----------------------------------------------------------------- propagation
#: Cost model of method="auto", from the measurements of docs/tradeoffs.md §3 (525 dofs):
#: dense eigensolve 0.04 s, i.e. about 2.8e-10 s x n^3; modal sum 0.004 s for 525 modes x
#: 492 samples, about 1.5e-8 s per (mode, sample); time domain at safety 0.1 (front error
#: < 1e-3 of max|F|, the publication-quality setting there) 0.03 s for 4419 steps over
#: ~7e3 nonzeros, about 1e-9 s per (nonzero, step), plus the detector and energy sums at
#: every output sample, about 8e-9 s per (dof, sample) (benchmarks/propagate_auto.py fits
#: 3.1e-9 and 2.4e-8 on a machine three times slower). Only the ratio of the two
#: predictions decides, so the machine's speed cancels.
EIGEN_SECONDS_PER_DOF3 = 2.8e-10
MODAL_SUM_SECONDS_PER_TERM = 1.5e-8
VERLET_SECONDS_PER_NNZ_STEP = 1.0e-9
TIME_SAMPLE_SECONDS_PER_DOF = 8e-9


def _time_steps(params: PropagateParams, dt: float) -> float:
    """Velocity-Verlet steps of a time-domain run: ceil(h/dt) per output interval h."""
    h = params.t_max / (params.samples - 1)
    return float(params.samples - 1) * (1.0 if dt >= h else math.ceil(h / dt))


def _time_seconds(system: LinearSystem, params: PropagateParams, dt: float) -> float:
    """Predicted seconds of one time-domain run at step dt (the constants above)."""
    return (VERLET_SECONDS_PER_NNZ_STEP * system.stiffness.nnz * _time_steps(params, dt)
            + TIME_SAMPLE_SECONDS_PER_DOF * system.n_dof * params.samples)


def _modal_seconds(system: LinearSystem, params: PropagateParams) -> float:
    """Predicted seconds of the dense eigensolve and the modal sum (the constants above)."""
    n = system.n_dof
    return EIGEN_SECONDS_PER_DOF3 * n**3 + MODAL_SUM_SECONDS_PER_TERM * n * params.samples


def _omega_max_bound(system: LinearSystem) -> float:
    """Gershgorin bound on omega_max of M^-1/2 D M^-1/2 (instant; at most ~40% high)."""
    import scipy.sparse as sp

    from .linear.assemble import gershgorin_bound

    s = sp.diags(1.0 / np.sqrt(system.mass))
    return math.sqrt(gershgorin_bound(s @ system.stiffness @ s))


def choose_method(system: LinearSystem, params: PropagateParams) -> tuple[str, str]:
    """("modal" | "time", why): the cheaper method by predicted cost (constants above).

    Modal: dense eigensolve (n^3) plus the modal sum (n x samples); refused above
    the dense limit of :func:`granwave.linear.eigen.eigensolve`. Time domain:
    t_max / dt velocity-Verlet steps over the nonzeros of D, dt = safety x
    2/omega_max (omega_max bounded by Gershgorin, so the prediction errs towards
    the modal sum), never coarser than the output interval.
    """
    from .linear.eigen import DENSE_MAX_DOF

    n = system.n_dof
    nnz = system.stiffness.nnz
    dt = params.dt if params.dt is not None else params.safety * 2.0 / max(_omega_max_bound(system), 1e-300)
    steps = _time_steps(params, dt)
    t_time = _time_seconds(system, params, dt)
    if n > DENSE_MAX_DOF:
        return "time", (f"time domain: {n} dofs exceed the dense eigensolve limit {DENSE_MAX_DOF} "
                        f"(predicted {t_time:.3g} s)")
    t_modal = _modal_seconds(system, params)
    method = "modal" if t_modal <= t_time else "time"
    return method, (f"{'modal sum' if method == 'modal' else 'time domain'}: predicted "
                    f"{min(t_modal, t_time):.3g} s against {max(t_modal, t_time):.3g} s for the "
                    f"{'time domain' if method == 'modal' else 'modal sum'} ({n} dofs, {nnz} "
                    f"nonzeros, {steps:.3g} steps at safety {params.safety:g})")


def _rerun_or_modal(system: LinearSystem, params: PropagateParams):
    """For method "auto" in the time domain: (rerun_ok(dt), why(signal)). rerun_ok says whether
    a repeated run at the shorter step dt that the tolerance asks for is predicted cheaper than
    the modal sum (always, above the dense limit); why gives the reason of the switch."""
    from .linear.eigen import DENSE_MAX_DOF

    t_modal = _modal_seconds(system, params)

    def rerun_ok(dt: float) -> bool:
        return system.n_dof > DENSE_MAX_DOF or _time_seconds(system, params, dt) < t_modal

    def why(sig: Signal) -> str:
        dt = float(sig.attrs["step_declined_dt"])
        return (f"modal sum: the time domain's first run (dt = {sig.attrs['dt']:.3g}) was "
                f"{sig.attrs['step_error_estimate']:.3g} of max|F| off, above the tolerance "
                f"{params.tolerance:g}; the run at dt = {dt:.3g} it needs was predicted "
                f"{_time_seconds(system, params, dt):.3g} s against {t_modal:.3g} s for the modal sum")
    return rerun_ok, why


def _dem_omega_max(packing: Packing) -> float:
    """Gershgorin bound on the highest DEM frequency: max_i 2 sum_j k_n,ij / m_i."""
    c = packing.contacts
    rows = np.zeros(packing.n_grains)
    np.add.at(rows, c.i, c.stiffness_normal)
    pair = c.j >= 0
    np.add.at(rows, c.j[pair], c.stiffness_normal[pair])
    return math.sqrt(float(np.max(2.0 * rows / packing.mass, initial=0.0)))


def _check_band(signal: Signal, omega_max: float) -> None:
    """Record the Nyquist ratio h omega_max / pi; warn (AliasingWarning) when it exceeds 1.

    A warning and not a refusal: the samples are the exact signal at the sample
    times, and a coherent front far slower than the highest mode (a long chain)
    is still well sampled; but a spectrum of such a record folds the modes above
    pi/h back onto lower frequencies.
    """
    h = float(signal.time[1] - signal.time[0])
    ratio = h * omega_max / math.pi
    signal.attrs["omega_max_band"] = float(omega_max)
    signal.attrs["nyquist_ratio"] = float(ratio)
    signal.attrs["aliased"] = bool(ratio > 1.0)
    if ratio > 1.0:
        warnings.warn(AliasingWarning(
            f"the sample interval {h:.3g} is {ratio:.3g} x the Nyquist interval pi/omega_max = "
            f"{math.pi / omega_max:.3g}: modes above omega = {math.pi / h:.3g} alias in this record "
            f"(use at least {signal.attrs['t_max'] * omega_max / math.pi + 1:.3g} samples or a "
            "shorter --t-max)"), stacklevel=3)


def propagate(source: LinearSystem | Modes | Packing, params: PropagateParams | None = None, /, *,
              system: LinearSystem | None = None, progress: Callable[[str], None] | None = None,
              threads: int | None = None, device: str | None = None, **fields) -> Signal:
    """The signal on the top wall after a kick at the bottom (docs/method.md §8).

    ``source``: a Modes (modal sum), a LinearSystem (``method`` "time", "modal"
    with an eigensolve on the fly, or "auto", which picks the cheaper of the two
    by :func:`choose_method`) or a Packing (``method`` "dem": the nonlinear
    DEM pulse). The default method follows the source: modal, time, dem.
    ``system``: the linear system a Modes came from, needed only for snapshots
    (its dof map). The signal's attrs record the method, for "auto" also
    ``method_requested`` and ``method_reason``, and the sampling check
    (``nyquist_ratio``, ``aliased``; an AliasingWarning when aliased).
    ``device``: "cpu" (default) or "gpu" (``method`` "time" or "dem"; docs/gpu.md).
    """
    from .devices import check_device
    from .linear.propagate import modal_propagate

    kind = ("modes" if isinstance(source, Modes) else "linear" if isinstance(source, LinearSystem)
            else "packing" if isinstance(source, Packing) else None)
    if kind is None:
        raise InputError(f"propagate needs a Modes, LinearSystem or Packing, got {type(source).__name__}")
    if kind == "linear":
        V.linear_system(source)  # a negative mass ended in an ArpackError
    _progress(progress)
    p = _params(PropagateParams, params, fields)
    method = p.method or {"modes": "modal", "linear": "time", "packing": "dem"}[kind]
    allowed = {"modes": ("modal", "auto"), "linear": ("modal", "time", "auto"), "packing": ("dem",)}[kind]
    if method not in allowed:
        what = {"modes": "a modes file (granwave.modes): the time domain needs the linear file "
                         "(granwave linearize output)",
                "linear": "a linear file (granwave.linear): the DEM pulse needs the packing file",
                "packing": "a packing file (granwave.packing): linearize it first, or use --method dem"}
        raise InputError(f"cannot run --method {method} on {what[kind]}")
    p.check_method(method)
    if p.source_kind != "normal":  # the kick's source and detector in the places of the normal ones
        if kind == "packing":
            if source.friction == 0.0:
                from .model import no_shear_message

                raise InputError(no_shear_message(source.attrs))
        else:
            source = source.for_source(p.source_kind)
    device = check_device(device)
    if device != "cpu" and method not in ("time", "dem"):
        raise InputError(f"--device {device}: --method {method} runs on the CPU only; use --device "
                         "cpu, or --method time (linear file) or dem (packing file)")
    from .devices import backend

    time_domain_signal = backend(device).time_domain_signal
    _threads(threads)
    reason = None
    if kind == "modes":
        if method == "auto":
            reason = "modal sum: the modes are already computed"
        method = "modal"
        if p.snapshots is not None and system is None:
            raise InputError("snapshots from a modes file need the dof map of the linear system it "
                             "came from (system=...)")
        if system is not None:
            from .io.validate import modes_match_linear

            _need(system, LinearSystem, "system")
            why = modes_match_linear(source, system)
            if why is not None:
                raise InputError(f"system= is not the linear system of these modes: it {why}")
        sig = modal_propagate(source, ic=p.ic, t_max=p.t_max, samples=p.samples, snapshots=p.snapshots,
                              dof_grain=None if system is None else system.dof_grain,
                              dof_axis=None if system is None else system.dof_axis)
        omega_max = math.sqrt(max(float(np.max(source.omega2, initial=0.0)), 0.0))
    elif kind == "linear":
        rerun_ok = None
        if method == "auto":
            method, reason = choose_method(source, p)
            rerun_ok, switch = _rerun_or_modal(source, p)
        if method == "time":
            from .linear.step_rule import accurate_signal

            sig = accurate_signal(time_domain_signal, source, tolerance=p.tolerance, ic=p.ic,
                                  t_max=p.t_max, dt=p.dt, samples=p.samples, safety=p.safety,
                                  snapshots=p.snapshots, progress=progress, rerun_ok=rerun_ok)
            omega_max = float(sig.attrs["omega_max"])
            if sig.attrs.get("step_rerun_declined"):
                method, reason = "modal", switch(sig)
        if method == "modal":
            from .linear.eigen import eigensolve as solve

            modes = solve(source, vectors=p.snapshots is not None)
            sig = modal_propagate(modes, ic=p.ic, t_max=p.t_max, samples=p.samples,
                                  snapshots=p.snapshots, dof_grain=source.dof_grain,
                                  dof_axis=source.dof_axis)
            omega_max = math.sqrt(max(float(np.max(modes.omega2, initial=0.0)), 0.0))
    else:
        from .dem.pulse import DEFAULT_BIN, DEFAULT_DAMPING, propagate_dem

        sig = propagate_dem(source, ic=p.ic, t_max=p.t_max, samples=p.samples, dt=p.dt,
                            amplitude=p.amplitude, strain=p.strain, velocity=p.velocity,
                            drive=p.drive or "impulse",
                            bin_width=DEFAULT_BIN if p.bin_width is None else p.bin_width,
                            damping=DEFAULT_DAMPING if p.damping is None else p.damping,
                            progress=progress, device=device,
                            source_kind=p.source_kind)
        omega_max = _dem_omega_max(source)
    if reason is not None:
        sig.attrs.update(method_requested="auto", method_reason=reason)
    if device != "cpu":
        sig.attrs["device"] = device
    sig.attrs["source_kind"] = p.source_kind
    p.record(sig.attrs)
    if omega_max > 0:
        _check_band(sig, omega_max)
    return sig


# ----------------------------------------------------------------- analyses
def statics(packing: Packing, params: StaticsParams | None = None, /, **fields) -> dict:
    """Solid fractions, coordination, force statistics, fabric and stress (docs/method.md §4)."""
    from .analysis.statics import statics as compute

    _need(packing, Packing, "packing")
    p = _params(StaticsParams, params, fields)
    return compute(packing, layer=p.layer, min_contacts=p.min_contacts)


def moduli(packing: Packing, params: ModuliParams | None = None, /, *,
           system: LinearSystem | None = None, threads: int | None = None, **fields) -> dict:
    """Global (and local) elastic moduli by imposed strain (docs/method.md §6).

    ``system``: a linear system built from ``packing`` (its prestress setting is
    used; ``prestress=True`` with a system built without it is refused).
    """
    from .linear.moduli import moduli as compute

    _need(packing, Packing, "packing")
    if system is not None:
        from .io.validate import belongs_to_packing

        _need(system, LinearSystem, "system")
        why = belongs_to_packing(system, packing)
        if why is not None:
            raise InputError(f"the linear system is not that of the packing: it {why}")
    p = _params(ModuliParams, params, fields)
    if system is not None and p.prestress and not bool(system.attrs.get("prestress", False)):
        raise InputError("--prestress conflicts with the linear file (built without prestress)")
    _threads(threads)
    res = compute(packing, local=p.local, prestress=p.prestress, amplitude=p.amplitude, grip=p.grip,
                  system=system, force=p.force, layer=p.layer)
    # the packing's identity: the analyses that pair moduli with a signal check it belongs
    # (granwave.cli.moduli_files.moduli_mismatch)
    a = packing.attrs
    res.update({k: a[k] for k in ("packing_digest", "pressure", "friction", "seed") if k in a})
    res["height"] = float(packing.box[-1])
    return res


def _signal_height(signal: Signal) -> float:
    """The signal's container height (attribute ``height``, wall to wall): a finite number > 0,
    else InputError (a signal file always carries one; a Signal built in memory may not)."""
    if "height" not in signal.attrs:
        raise InputError("signal has no height attribute (the container height, wall to wall): "
                         "set signal.attrs['height']")
    V.material_attrs("signal", {"height": signal.attrs["height"]})
    return float(signal.attrs["height"])


def front(signal: Signal, params: FrontParams | None = None, /, **fields) -> dict:
    """Leading edge, first peak, zero crossing and width of the first pulse (docs/method.md §9).

    Returns t_lead10, t_peak, amplitude, polarity, t_zero, width, height, the
    signal's ic/method/pressure where known, rise and the rule's parameters.
    """
    from .analysis.front import front_features

    _need(signal, Signal, "signal")
    p = _params(FrontParams, params, fields)
    d = front_features(signal.time, signal.force, **p.as_dict()).as_dict()
    out = {k: d[k] for k in ("t_lead10", "t_peak", "amplitude", "polarity", "t_zero", "width")}
    out["height"] = _signal_height(signal)
    for key in ("ic", "method", "pressure"):
        if key in signal.attrs:
            out[key] = signal.attrs[key]
    out.update(rise=d["rise"], **p.as_dict())
    return out


def shear_front(signal: Signal, *, moduli: dict | None = None, frequency: float | None = None,
                wavelength: float = 8.0, pulse: str = "sine", band=(0.5, 1.5), response: str = "derivative",
                deflection_fraction: float = 0.02, units: str = "reduced", material: str = "glass",
                diameter: float = 1e-3) -> dict:
    """Arrival picks of a shear signal (granwave.analysis.shear; docs/shear.md).

    ``moduli``: ``analyze moduli`` output of the same packing (gives c_t, the bulk slab's where
    the column has one, else the whole cell's: granwave.analysis.shear_scene.reference_speeds,
    whose values are returned under ``reference``; Phi3* and the shear modulus); ``frequency`` of the source pulse (1/time), default c_t / ``wavelength``
    (d); ``response``: the matched template's response, "derivative" (w′) or "delay" (w). ``units`` "si": V_s (m/s) of every pick, G_max = Phi3* rho V_s^2 (MPa) and the
    moduli's G (MPa), travel times (us) and the frequency (kHz) for ``material`` and the
    mean grain ``diameter`` (m) (granwave.units.MATERIALS).
    """
    from .analysis.shear import shear_picks
    from .units import material_scales

    c_t = phi = g_mod = None
    if moduli is not None and not isinstance(moduli, Mapping):
        raise InputError(f"moduli must be a mapping (the JSON object of analyze moduli), got "
                         f"{type(moduli).__name__}")
    if moduli is not None:
        from .analysis.shear_scene import reference_speeds

        ref = reference_speeds(moduli)  # the bulk slab's c_t (the whole cell's without a slab)
        c_t = ref["c_t"]
        phi = moduli.get("phi3_star")
        dim = int(moduli.get("dim", 2))
        g_mod = moduli.get("C33") if dim == 2 else (0.5 * (moduli["C44"] + moduli["C55"])
                                                    if "C44" in moduli and "C55" in moduli else None)
        if c_t is None or not math.isfinite(float(c_t)):
            raise InputError("the moduli give no finite c_t")
        c_t = float(c_t)
    if frequency is None:
        if c_t is None:
            raise InputError("give the source pulse's --frequency, or --moduli (then f = c_t / --wavelength)")
        if not wavelength > 0:
            raise InputError(f"wavelength must be positive (got {wavelength})")
        frequency = c_t / wavelength
    out = shear_picks(signal.time, signal.force, height=float(signal.attrs["height"]), frequency=frequency,
                      pulse=pulse, c_t=c_t, deflection_fraction=deflection_fraction, band=band,
                      response=response)
    out["phi3_star"] = float(phi) if phi is not None else math.nan
    out["G"] = float(g_mod) if g_mod is not None else math.nan
    if moduli is not None:
        out["reference"] = ref
        if math.isfinite(ref.get("c_t_x_cell", math.nan)):
            out["ratio_x_cell"] = {k: v["speed"] / ref["c_t_x_cell"] for k, v in out["picks"].items()}
    for key in ("ic", "method", "pressure", "source_kind"):
        if key in signal.attrs:
            out[key] = signal.attrs[key]
    if units == "si":
        sc = material_scales(material, diameter)
        si = {"material": material, "diameter_mm": diameter * 1e3, "E_star_GPa": sc["E_star"] / 1e9,
              "density": sc["rho"], "frequency_kHz": frequency / sc["time"] / 1e3,
              "c_t_m_s": (c_t * sc["speed"]) if c_t else math.nan,
              "G_moduli_MPa": out["G"] * sc["E_star"] / 1e6}
        for name, pk in out["picks"].items():
            vs = pk["speed"] * sc["speed"]
            si[f"{name}_Vs_m_s"] = vs
            si[f"{name}_time_us"] = pk["time"] * sc["time"] * 1e6
            si[f"{name}_Gmax_MPa"] = out["phi3_star"] * sc["rho"] * vs * vs / 1e6
        out["si"] = si
    elif units != "reduced":
        raise InputError(f"units must be reduced or si (got {units!r})")
    return out


def heights(signals: Sequence[Signal], params: HeightsParams | None = None, /, *,
            labels: Sequence[str] | None = None, **fields) -> dict:
    """Arrival times, speeds and exponents over a container-height series (docs/method.md §9)."""
    from .analysis.heights import height_series

    signals = _need_all(signals, Signal, "signals")
    labels = _labels(labels, len(signals))
    p = _params(HeightsParams, params, fields)
    return height_series(signals, labels=labels, edge_heights=p.edge_heights,
                         group_rtol=p.group_tolerance, **p.front_kw())


def ensemble(signals: Sequence[Signal], params: EnsembleParams | None = None, /, *,
             labels: Sequence[str] | None = None, **fields):
    """(Ensemble, summary): average signal and rms deviation over packings (docs/method.md §9).

    The summary's ``attrs`` entry holds the flat attributes to store with the
    ensemble (front statistics, front of the mean, the parameters).
    """
    import json

    from .analysis.ensemble import analyze_ensemble

    signals = _need_all(signals, Signal, "signals")
    labels = _labels(labels, len(signals))
    p = _params(EnsembleParams, params, fields)
    if not signals:
        raise InputError("no signal files given")
    front_kw = p.front_kw()
    ens, summary = analyze_ensemble(list(signals), labels=labels, **front_kw)
    attrs = {"front_options": json.dumps(front_kw)}
    if labels is not None:
        attrs["sources"] = json.dumps(list(labels))
    for key, st in summary["front_stats"].items():
        attrs[f"front_{key}_mean"] = st["mean"]
        attrs[f"front_{key}_std"] = st["std"]
    for key, value in summary["front_of_mean"].items():
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            attrs[f"front_of_mean_{key}"] = value
    p.record(attrs)
    summary["attrs"] = attrs
    return ens, summary


def spectrum(modes: Modes, params: SpectrumParams | None = None, /, *,
             system: LinearSystem | None = None, **fields) -> dict:
    """Spectrum statistics and each mode's part in the signal (docs/method.md §7).

    ``system`` (the linear system of the modes) makes the participation ratio
    run over grains.
    """
    from .analysis.spectrum import spectrum_summary

    _need(modes, Modes, "modes")
    p = _params(SpectrumParams, params, fields)
    dof_grain = dof_axis = None
    if system is not None:
        from .io.validate import modes_match_linear

        _need(system, LinearSystem, "system")
        why = modes_match_linear(modes, system)
        if why is not None:
            raise InputError(f"the linear system is not the same system as the modes: it {why}")
        dof_grain, dof_axis = system.dof_grain, system.dof_axis
    return spectrum_summary(modes, ic=p.ic, dof_grain=dof_grain, dof_axis=dof_axis, arrays=p.arrays)


def damping(signals: Sequence[Signal], params: DampingParams | None = None, /, *,
            labels: Sequence[str] | None = None, **fields) -> list[dict]:
    """Coherent amplitude, width and tail rms against contact damping (docs/method.md §11).

    ``labels`` name the signals in error messages (the CLI passes the file names).
    """
    from .dem.pulse import damping_table

    signals = _need_all(signals, Signal, "signals")
    labels = _labels(labels, len(signals))
    p = _params(DampingParams, params, fields)
    return damping_table(signals, tail_start=p.tail_start, labels=labels)


def pressure_sweep(summaries: Sequence[dict], params: SweepParams | None = None, /, *,
                   height_series: Sequence[dict] = (), **fields) -> dict:
    """Per-pressure statistics and speed exponents from per-sample summaries (docs/method.md §10)."""
    from .analysis.sweep import pressure_sweep as run

    for name, value in (("summaries", summaries), ("height_series", height_series)):
        if isinstance(value, (str, bytes, dict)) or not hasattr(value, "__iter__"):
            raise InputError(f"{name} must be a sequence of summary dicts, got {type(value).__name__}")
    p = _params(SweepParams, params, fields)
    if not summaries and not height_series:
        raise InputError("no summary files given")
    return run(list(summaries), height_series=list(height_series), poisson=p.poisson,
               crossover=(p.crossover_low, p.crossover_high) if p.crossover else None)
