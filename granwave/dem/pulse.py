"""Nonlinear pulse propagation with contact damping in the DEM engine (docs/method.md §8, §11).

The stored packing is kicked at the bottom wall and integrated with the full
nonlinear contact law of the packing (its ``contact_law`` attribute, Hertz–Mindlin
when absent, or harmonic: :mod:`granwave.contact_models`, through the engine's own
kernels): the signal is the extra force on the fixed top wall. At zero damping and
small amplitude it must equal the linear signal (``granwave.linear``) of the
same packing; docs/damping.md records the agreement measured.

Set-up
------
- State at t = 0⁻: the stored positions, zero velocities, the stored contact
  list **with its tangential forces as history** (``contacts.force_tangential``,
  keyed by (i, j); walls by grain). The engine (:class:`~granwave.dem.integrator.Engine`)
  has no argument for an initial history, so it is written into its history
  arrays after construction (:func:`engine_from_packing`).
- Walls: bottom wall and top wall (piston) both fixed; no piston dynamics,
  no background damping. Contact damping ζ (docs/method.md §2: c = 2 ζ sqrt(m_eff k)
  with the current k_n and k_t, normal and tangential, the total normal force
  never attractive) acts during the pulse when ``damping`` > 0.
- Source (docs/conventions.md), times a global scale s:
  (A) v_i = s k_wall,i / m_i (vertical, upward) for every grain with a
  force-carrying bottom-wall contact; (B) u_i = s k_wall,i / ⟨k_wall⟩,
  imposed as one kinematic increment (so the tangential springs of the
  displaced grains load by k_t Δs exactly as in the linear model), zero
  velocity.
- Amplitude EPS (``amplitude``): s is chosen so that the *single-contact
  estimate* of the largest grain displacement equals EPS × δ̄, with δ̄ the
  mean overlap of the packing's force-carrying contacts (grain–grain and
  wall). For (A) the estimate for grain i is its velocity times its wall
  contact's time scale, v_i sqrt(m_i / k_wall,i) (the largest excursion of a
  grain of mass m_i launched at v_i against a spring k_wall,i), so
  s = EPS δ̄ / max_i sqrt(k_wall,i / m_i). For (B) it is the imposed
  displacement itself, s = EPS δ̄ / max_i (k_wall,i / ⟨k_wall⟩). The largest
  displacement actually reached, over grains and the whole record, is
  measured and written as ``max_displacement_over_overlap`` (it is smaller:
  the grain is held by its neighbours too).
- Signal: F_sig(t) = [F_top(t) − F_top(0⁻)] / s, F_top the total normal force
  (elastic plus viscous) of the top-wall contacts and F_top(0⁻) the sum of the
  stored top-wall normal forces. Dividing by s makes it directly comparable
  with — in the linear limit equal to — the linear signal of the same packing
  with the docs/conventions.md normalization (E* d²).
- Time step: velocity Verlet (the engine's) with dt = ``dt_safety`` × 2π
  sqrt(m_min / k_max), k_max the largest stored k_n (the period of the
  stiffest single contact on the lightest grain), shortened so that an
  integer number of steps fits between two output samples (uniform grid of
  ``samples`` times from 0 to t_max, as the linear signals).

Counted during the run (after every step; :mod:`granwave.dem.pulse_kernels`):
``n_opened`` contacts of t = 0 that lose their overlap at some step;
``n_formed`` contacts absent at t = 0 that gain an overlap at some step;
``n_sliding`` contacts whose tangential force is on the Coulomb cone after
some step (``n_sliding_new`` of them were not on the cone at t = 0;
``n_at_cone_initial`` were fully mobilized in the stored state). Walls
count like grains. With the pulse field, the same counts at every sample, and from them
``n_opened_incoming``, ``n_formed_incoming``, ``n_sliding_new_incoming``: the counts when the
fitted front reaches the far wall (``front_far_wall_time``), before its reflection
(:func:`incoming_counts`).
"""

from __future__ import annotations

import math
import time as _time
from typing import Callable, Sequence

import numba
import numpy as np

from ..errors import ConvergenceError, InputError
from ..model import Packing, Signal
from ..params import PropagateParams
from ..resources import check_propagate, check_run_time, predicted_seconds
from ..threads import at_most
from ..provenance import SAMPLE_ATTRS, carried
from .. import contact_models as CM
from ..contact_models import options as CO
from . import kernels as K
from . import pulse_kernels as PK
from .integrator import Engine, one_thread
from . import serial
from .kick import (DEFAULT_AMPLITUDE, DRIVES, RECORD_CROSSINGS, _check_drive, _check_ic,  # noqa: F401
                   amplitude_scale, front_speed_bound, kick_size, mean_overlap, packing_law, peak_overlap,
                   shear_kick, source)

#: Default time step as a fraction of the shortest single-contact period 2π sqrt(m_min/k_max).
DEFAULT_DT_SAFETY = 0.01
#: Default tangential unloading rule of the pulses: the plain incremental Mindlin law, the one
#: the linear model (frozen history) linearizes (granwave/contact.py docstring, docs/damping.md).
DEFAULT_UNLOADING = "incremental"
#: Default contact damping zeta of the pulses (fraction of critical): none, the linear model's.
DEFAULT_DAMPING = 0.0
#: Verlet skin of the pulses' pair list (d): the smallest and first one of the adapting list, and
#: the GPU list's fixed skin.
DEFAULT_SKIN = 0.2
#: Largest skin of the pulses' adapting list (d): a strong push moves the grains behind its front
#: together, and a longer-lived list saves rebuilds, each 5-20 steps' work (docs/decisions/0058).
SKIN_MAX = 0.6
#: Seconds of stepping per kernel call (progress and the blow-up test between calls; every sample's
#: readings are taken inside the call).
CALL_SECONDS = 0.2
#: Default number of output samples: propagate's.
DEFAULT_SAMPLES = PropagateParams.samples

#: The piston's grains: mass and moment of inertia times this factor, so that the contact forces change
#: their velocity by at most F t / (1e15 m) over a record: a constant velocity to round-off.
PISTON_MASS_FACTOR = 1e15
#: Default height bin of the pulse field (d).
DEFAULT_BIN = 1.0

AMPLITUDE_DEFINITION = {
    "A": "s = EPS * mean_overlap / max_i sqrt(k_wall_i / m_i): the largest single-contact "
         "excursion v_i sqrt(m_i / k_wall_i) of a kicked grain is EPS mean overlaps",
    "B": "s = EPS * mean_overlap / max_i (k_wall_i / <k_wall>): the largest imposed "
         "displacement is EPS mean overlaps",
    "piston": "s = v_p, the piston's velocity; EPS = v_p * max_i sqrt(m_i / k_wall_i) / mean_overlap, "
              "the single-contact excursion of a source grain launched at v_p in mean overlaps",
}
STRAIN_DEFINITION = "strain = EPS * mean_overlap / mean diameter"


#: Attributes carried from the packing into the signal.
CARRIED_ATTRS = (*SAMPLE_ATTRS, "grains", "polydispersity", "contact_law", "packing_digest")


# ---------------------------------------------------------------- set-up

def default_time_step(packing: Packing, dt_safety: float = DEFAULT_DT_SAFETY,
                      peak_stiffness: float = 0.0) -> float:
    """dt_safety × 2π sqrt(m_min / k_max), k_max the largest stored normal stiffness or, when larger,
    ``peak_stiffness`` (the law's stiffness at the overlap the kick presses in, :func:`peak_overlap`:
    a strong kick, or a chain without precompression, collides on a stiffer contact than any stored;
    for a concave law such as Hertz k(δ0 + Δ) <= k(δ0) + k(Δ), at most twice the larger)."""
    if not 0.0 < dt_safety <= 0.2:
        raise InputError(f"dt_safety must be in (0, 0.2], got {dt_safety:g}")
    kmax = max(float(np.max(packing.contacts.stiffness_normal, initial=0.0)), float(peak_stiffness))
    if not kmax > 0.0:
        raise InputError("the packing has no contact stiffness: no time scale")
    return dt_safety * 2.0 * math.pi * math.sqrt(float(packing.mass.min()) / kmax)


def _forces_now(engine: Engine, dt: float = 0.0) -> None:
    """Forces and accelerations of the current state with step ``dt`` for the slip
    (0: the history is evaluated, not advanced), as the engine does at construction."""
    keep = engine.fpar.dt
    engine.fpar.dt = dt
    compute_forces = serial.compute_forces if one_thread(len(engine.radius)) else K.compute_forces
    compute_forces(engine.position, engine.velocity, engine.angular_velocity, engine.radius,
                   engine.mass, engine.inertia, engine.lateral, engine.pair_i, engine.pair_j,
                   engine.pair_ft, engine.pair_ov, engine.wall_ft, engine.wall_ov, engine.piston,
                   engine.fpar, engine.ipar, engine.acceleration, engine.angular_acceleration,
                   engine.out, engine.ws)
    K.to_accelerations(engine.acceleration, engine.angular_acceleration, engine.mass, engine.inertia)
    engine.fpar.dt = keep




def engine_from_packing(packing: Packing, *, damping: float = DEFAULT_DAMPING, dt: float,
                        skin: float | None = None, unloading: str = DEFAULT_UNLOADING) -> Engine:
    """A DEM engine in the stored state: fixed walls, the stored tangential forces as history.

    The engine builds its pair list from the positions; every stored contact
    must be found there overlapping (else InputError). Stored F_t is the
    force on i from j, so a pair stored with i > j enters the engine's (i < j)
    slot with the opposite sign. Forces and accelerations are then evaluated
    (slip 0) so that the state is ready for velocity Verlet. ``unloading``: the
    tangential unloading rule (:data:`DEFAULT_UNLOADING`; contact.py docstring). The engine
    runs the packing's normal law (:func:`packing_law`). ``skin``: the pair list's fixed skin (d);
    None: a skin adapting to the grains' speed from :data:`DEFAULT_SKIN` up to :data:`SKIN_MAX`, or
    less where the box is narrow (the same bits: a skin changes none).
    """
    if packing.dim not in (2, 3):
        raise InputError(f"the DEM pulse needs a 2D or 3D packing (got dim = {packing.dim})")
    _, contact = packing_law(packing)
    radius = np.asarray(packing.radius, float)
    if skin is not None:
        skins = dict(skin=skin)
    else:
        # up to the largest skin that keeps nearest images unique (Engine: L > 2 (2 R_max + skin))
        widest = 0.999 * (0.5 * float(np.min(packing.box[:-1])) - 2.0 * float(radius.max()))
        skin_max = min(SKIN_MAX, widest)
        skins = (dict(skin=skin_max, skin_min=DEFAULT_SKIN, first_skin=DEFAULT_SKIN) if skin_max > DEFAULT_SKIN
                 else dict(skin=DEFAULT_SKIN))
    engine = Engine(packing.position, radius, packing.box[:-1], float(packing.box[-1]),
                    friction=packing.friction, poisson=float(packing.attrs.get("poisson", 0.0)),
                    damping=float(damping), background_damping=0.0, piston_mass=math.inf,
                    piston_force=0.0, dt=dt, check_every=0,  # fixed dt, no convergence test
                    **skins,
                    unloading=unloading, **contact)
    if not np.allclose(engine.mass, packing.mass, rtol=1e-12, atol=0.0):
        raise InputError("the packing's grain masses are not rho pi d^3 / 6 (docs/method.md §1): "
                         "the DEM engine cannot represent them")
    c = packing.contacts
    n = packing.n_grains
    m = engine.n_pairs
    keys = engine.pair_i[:m] * n + engine.pair_j[:m]
    carrying = c.overlap > 0.0
    pair = (c.j >= 0) & carrying
    ci, cj = c.i[pair], c.j[pair]
    want = np.minimum(ci, cj) * n + np.maximum(ci, cj)
    slot = np.searchsorted(keys, want)
    slot_ok = slot < m
    found = np.zeros(len(want), bool)
    found[slot_ok] = keys[slot[slot_ok]] == want[slot_ok]
    found[slot_ok] &= engine.pair_ov[slot[slot_ok]] > 0.0
    if not np.all(found):
        k = int(np.flatnonzero(~found)[0])
        raise InputError(f"stored contact ({ci[k]}, {cj[k]}) has no overlap at the stored positions: "
                         "the packing's contact list does not match its geometry")
    if packing.friction > 0.0:
        sign = np.where(ci < cj, 1.0, -1.0)
        engine.pair_ft[slot] = sign[:, None] * c.force_tangential[pair]
        for jw, k in ((-1, 0), (-2, 1)):
            on = (c.j == jw) & carrying
            slots = 2 * c.i[on] + k
            if np.any(engine.wall_ov[slots] <= 0.0):
                raise InputError("a stored wall contact has no overlap at the stored positions")
            engine.wall_ft[slots] = c.force_tangential[on]
    _forces_now(engine)
    return engine


# ---------------------------------------------------------------- the run
def propagate_dem(packing: Packing, *, ic: str = "A", amplitude: float | None = None,
                  damping: float = DEFAULT_DAMPING, t_max: float | None = None, samples: int = DEFAULT_SAMPLES,
                  dt_safety: float = DEFAULT_DT_SAFETY, dt: float | None = None, skin: float | None = None,
                  baseline: bool = True, progress: Callable[[str], None] | None = None,
                  progress_interval: float = 10.0, unloading: str = DEFAULT_UNLOADING,
                  device: str = "cpu", source_kind: str = "normal", drive: str = "impulse",
                  strain: float | None = None, velocity: float | None = None,
                  bin_width: float = DEFAULT_BIN) -> Signal:
    """Kick the packing at the bottom wall in the nonlinear DEM; the top-wall signal.

    Parameters
    ----------
    packing : a converged packing (2D or 3D) with its contact list and F_t.
    ic : "A" (impulse) or "B" (displacement) on the bottom-wall grains.
    amplitude : EPS > 0, the largest single-contact displacement estimate in
        units of the mean overlap (module docstring); default 1e-3 (linear
        regime: docs/damping.md).
    damping : contact damping ζ in [0, 1], fraction of critical (docs/method.md §2).
    t_max, samples : output grid of ``samples`` times from 0 to t_max (d/sqrt(E*/rho)). Default
        t_max: :data:`RECORD_CROSSINGS` crossings of the column at the kick's front speed bound
        (:func:`front_speed_bound`: a strong kick's faster front gets a shorter record).
    dt_safety : dt = dt_safety × 2π sqrt(m_min/k_max) (default 0.01); ``dt``
        overrides it. Either is shortened to divide the sample interval.
    skin : a fixed Verlet skin of the engine's pair list (d); default: on the CPU one that adapts to
        the grains' speed between :data:`DEFAULT_SKIN` and :data:`SKIN_MAX`, on the GPU
        :data:`DEFAULT_SKIN`. The skin changes no bit of the run, only its speed.
    baseline : subtract the top-wall force of the same run without the kick
        (default) instead of the constant stored static force. A packing
        converged to a residual acceleration a_r drifts by ~ a_r t^2 / 2,
        which at EPS ~ 1e-3 is a percent of the pulse's displacements; the
        baseline run removes that drift (and doubles the cost).
    progress : called with a one-line message about every ``progress_interval`` s.
    unloading : tangential unloading rule, "incremental" (default: plain incremental
        Mindlin law, which the linear model linearizes, so that at ζ = 0 and small
        amplitude the signal converges to ``linearize(prestress=True)``) or "rescale"
        (F_t scaled by sqrt(n_new/n_old) on unloading, as in preparation: a first-order
        one-sided term for prestressed contacts; granwave/contact.py docstring).
    device : "cpu" or "gpu" (the steps on one GPU: granwave.gpu.pulse; docs/gpu.md).
    source_kind : "normal" (default) or "shear": the bottom wall kicked along x (IC A only,
        friction needed, CPU only): the source grains get the velocities and angular
        velocities of :func:`shear_kick` times s, and the signal is the top wall's force
        along x (:func:`granwave.dem.pulse_kernels.top_shear_force`), minus that of the
        unkicked run, over s (docs/method.md §8, "Shear source").
    drive : "impulse" (default: initial condition A or B as above) or "piston": the source grains
        pushed at the constant velocity v_p = s (vertical, or along x for the shear source) for
        the whole record, their mass and moment of inertia times :data:`PISTON_MASS_FACTOR`
        (docs/shocks.md); the signal is then divided by v_p.
    strain, velocity : the kick's size instead of ``amplitude`` (one of the three;
        :func:`kick_size`): the strain EPS δ̄ / d̄, or the largest source velocity (v_p for the
        piston). The time step's stiffness follows from the size (:func:`peak_overlap`).
    bin_width : height bins (d) of the pulse field (either device): per bin, the mean velocity of its
        grains along the kick at every sample, the largest contact normal force reached over the
        record and at t = 0, and the front's arrival (:mod:`granwave.analysis.shocks`). A 1D
        chain (``granwave chain``, with a contact law) is run as a 2D column
        (:func:`granwave.systems.chain_column`).

    Returns
    -------
    Signal with ``force`` = [F_top(t) − F_top,unkicked(t)] / s in E* d² (the
    linear normalization) and attrs: ic, method="dem", height, amplitude,
    damping, scale s, mean_overlap, amplitude_definition, dt, n_steps, the
    counts n_opened, n_formed, n_sliding (n_sliding_new, n_at_cone_initial), with the field
    also those of the incoming front (module docstring), max_displacement_over_overlap,
    contact_law (a description of the packing's law that the run used; with the law's
    parameters when it is not the default) and the packing's attributes.
    The engine runs the packing's normal law (``contact_law`` attribute, Hertz when absent);
    ``device="gpu"`` takes Hertz packings only.
    """
    ic = _check_ic(ic)
    drive = _check_drive(drive, ic)
    from ..model import check_source_kind, no_shear_message

    if packing.dim == 1:
        from ..systems import chain_column

        packing = chain_column(packing)
    if not (bin_width > 0.0 and math.isfinite(bin_width)):
        raise InputError(f"bin width must be a positive number (got {bin_width})")

    source_kind = check_source_kind(source_kind)
    shear = source_kind == "shear"
    if shear:
        if packing.friction == 0.0:
            raise InputError(no_shear_message(packing.attrs))
        if ic != "A":
            raise InputError("the shear kick has initial condition A only")
        if device != "cpu":
            raise InputError("the DEM shear pulse runs on the CPU only (--device cpu)")
    law_name, contact = packing_law(packing)
    if device != "cpu" and law_name != CO.KINDS["normal"]["default"]:  # granwave.gpu.pulse's contact flags are Hertz's
        raise InputError(f"the DEM pulse of a {law_name} packing runs on the CPU only (--device cpu)")
    if unloading not in ("incremental", "rescale"):
        raise InputError(f"unloading must be 'incremental' or 'rescale' (got {unloading!r})")
    if not 0.0 <= damping <= 1.0:
        raise InputError(f"damping zeta must be in [0, 1] (got {damping})")
    if t_max is not None and not (t_max > 0.0 and math.isfinite(t_max)):
        raise InputError(f"t_max must be a positive finite time (got {t_max})")
    if int(samples) != samples or samples < 2:
        raise InputError(f"need at least 2 samples (got {samples})")
    samples = int(samples)
    check_propagate(packing.n_grains * packing.dim, samples)  # refuse a signal that cannot fit
    if str(packing.attrs.get("converged", True)) in ("False", "false", "0"):
        raise InputError("the packing is not converged (attrs converged = False)")
    size = kick_size(packing, ic=ic, kind=source_kind, drive=drive, amplitude=amplitude, strain=strain,
                     velocity=velocity)
    amplitude = size["amplitude"]
    delta_peak, k_peak = peak_overlap(packing, ic=ic, velocity=size["velocity"], drive=drive,
                                      displacement=amplitude * mean_overlap(packing))
    bound = front_speed_bound(packing, peak=delta_peak)
    record_rule = "given"
    if t_max is None:
        t_max = RECORD_CROSSINGS * packing.height / bound["speed"]
        record_rule = f"{RECORD_CROSSINGS:g} crossings at the front speed bound"
    times = np.linspace(0.0, float(t_max), samples)
    h = float(times[1] - times[0])
    step = default_time_step(packing, dt_safety, k_peak) if dt is None else float(dt)
    if not (step > 0.0 and math.isfinite(step)):
        raise InputError(f"time step must be positive (got {dt})")
    ratio = h / step * (1.0 - 1e-12)
    sub = max(1, int(math.ceil(ratio))) if ratio < 2.0**62 else None
    n_steps = None if sub is None else sub * (samples - 1) * (2 if baseline else 1)
    if n_steps is None or n_steps > 2**62:
        n_steps = ratio * (samples - 1) * (2 if baseline else 1)
        raise InputError(f"t_max {t_max:g} needs {n_steps:.3g} time steps of {step:.3g}, more than "
                         "the engine can count: use a shorter --t-max or a longer --dt")
    check_run_time(predicted_seconds("dem-pulse", packing.n_grains, n_steps),
                   f"the DEM pulse ({n_steps:.3g} steps of {packing.n_grains} grains"
                   f"{', kicked run and baseline' if baseline else ''})", progress)
    step = h / sub

    grains, kw = source(packing, source_kind)
    dbar = mean_overlap(packing)
    scale = size["scale"]
    c = packing.contacts
    # the static force on the top wall: vertical, or along x (minus the stored F_t on the grains)
    f_static = (float(-np.sum(c.force_tangential[c.is_top, 0])) if shear
                else float(np.sum(c.force_normal[c.is_top])))
    run = dict(damping=damping, step=step, sub=sub, samples=samples, skin=skin, times=times,
               progress=progress, progress_interval=progress_interval, unloading=unloading,
               device=device, shear=shear, drive=drive)
    t_wall0 = _time.perf_counter()
    # A: initial velocities v_i; B: imposed displacements u_i (vertical, on the source grains);
    # shear: (velocities, angular velocities) of the source grains
    if drive == "piston":
        values = np.full(len(grains), scale)
    elif shear:
        grains, v_kick, w_kick = shear_kick(packing)
        values = (scale * v_kick, scale * w_kick)
    else:
        values = scale * kw / packing.mass[grains] if ic == "A" else scale * kw / kw.mean()
    kicked = _run(packing, ic=ic, kick=(grains, values), field=bin_width, **run)
    base = None
    if baseline:
        base = _run(packing, ic=ic, kick=None, **run)
    wall_time = _time.perf_counter() - t_wall0
    reference = base["top"] if base is not None else np.full(samples, f_static)
    force = (kicked["top"] - reference) / scale
    attrs = carried(packing.attrs, CARRIED_ATTRS)
    attrs.update(
        ic=ic, source_kind=source_kind, method="dem", height=packing.height, lateral_width=float(packing.box[0]),
        amplitude=float(amplitude),
        damping=float(damping),
        scale=float(scale), mean_overlap=dbar, amplitude_definition=AMPLITUDE_DEFINITION[ic],
        t_max=float(t_max), samples=samples, dt=float(step),
        dt_safety=float(dt_safety) if dt is None else float("nan"), n_steps=int(sub * (samples - 1)),
        integrator="velocity Verlet (DEM engine)",
        contact_law=CO.SUBMODELS[law_name]["description"],
        unloading=unloading,
        top_wall="fixed", bottom_wall="fixed", background_damping=0.0,
        baseline_subtracted=bool(baseline),
        signal_definition=("(F_top(t) - F_top_unkicked(t)) / scale, F_top_unkicked from the same run "
                           "without the kick" if baseline else "(F_top(t) - F_top(0-)) / scale"),
        static_top_force=f_static, static_top_force_engine=kicked["f_static_engine"],
        static_residual_acceleration=kicked["residual"],
        baseline_drift_over_signal=(float(np.max(np.abs(base["top"] - f_static)) / scale
                                          / max(np.max(np.abs(force)), 1e-300))
                                    if base is not None else float("nan")),
        n_source_grains=int(len(grains)), n_contacts_initial=kicked["n_contacts_initial"],
        n_opened=kicked["n_opened"], n_formed=kicked["n_formed"], n_sliding=kicked["n_sliding"],
        n_sliding_new=kicked["n_sliding_new"], **{"n_at_cone_initial": kicked["n_at_cone_initial"]},
        max_displacement=kicked["max_displacement"],
        max_displacement_over_overlap=kicked["max_displacement"] / dbar,
        baseline_max_displacement_over_overlap=(base["max_displacement"] / dbar if base is not None
                                                else float("nan")),
        energy_input=kicked["energy_input"], neighbour_rebuilds=kicked["rebuilds"],
        energy_drift=kicked["energy_drift"],
        wall_time=float(wall_time),
    )
    # the law's parameters where it is not the default (signals of the default as before)
    attrs.update({k: v for k, v in CO.attrs_of(contact).items() if k in CO.PARAMETERS})
    # the drive and the kick's size in the other units (docs/shocks.md)
    attrs.update(drive=drive, strain=size["strain"], kick_velocity=size["velocity"],
                 strain_definition=STRAIN_DEFINITION, peak_overlap_estimate=float(delta_peak),
                 peak_stiffness_estimate=float(k_peak), front_speed_bound=bound["speed"],
                 front_speed_bound_linear=bound["linear"], front_speed_bound_nonlinear=bound["nonlinear"],
                 t_max_rule=record_rule)
    if drive == "piston":
        attrs.update(amplitude_definition=AMPLITUDE_DEFINITION["piston"], piston_velocity=float(scale),
                     signal_definition=attrs["signal_definition"].replace("/ scale", "/ v_p"),
                     piston_mass_factor=PISTON_MASS_FACTOR)
    if packing.attrs.get("kind") == "chain":
        attrs["column_width"] = float(packing.attrs["column_width"])
    sig = Signal(time=times, force=force, attrs=attrs)
    if kicked["field"] is not None:
        from ..analysis.shocks import front_picks

        sig.pulse = kicked["field"]
        picks = front_picks(times, sig.pulse["height"], sig.pulse["velocity"],
                            pick="crossing" if drive == "piston" else "peak", column=packing.height)
        sig.pulse["arrival"] = picks["arrival"]
        attrs.update(field_bin_width=float(bin_width), front_pick=picks["pick"],
                     front_speed=picks["speed"], front_speed_error=picks["speed_error"],
                     front_fit_range=picks["fit_range"], front_width=picks["width"])
        attrs.update(incoming_counts(times, np.stack([sig.pulse[name] for name in PK.CONTACT_COUNTS], axis=1),
                                     t0=picks["t0"], speed=picks["speed"], column=packing.height))
    return sig


def incoming_counts(times: np.ndarray, contacts: np.ndarray, *, t0: float, speed: float, column: float) -> dict:
    """The contact counts of the incoming front alone: the run's counts so far (``contacts``,
    (samples, 3), pulse_kernels.CONTACT_COUNTS) at the last sample before the fitted front
    (arrival t0 + z / speed at height z) reaches the far wall at z = ``column``, before any
    reflection; the whole record's where the front does not reach it within the record. The
    arrival time ``front_far_wall_time`` with them; NaN (and NaN counts) without a fitted front."""
    t_far = t0 + column / speed if speed > 0.0 and math.isfinite(speed) and math.isfinite(t0) else math.nan
    out = {"front_far_wall_time": float(t_far)}
    k = int(np.searchsorted(times, t_far, side="right")) - 1 if math.isfinite(t_far) else -1
    for c, name in enumerate(PK.CONTACT_COUNTS):
        out[f"n_{name}_incoming"] = float(contacts[k, c]) if k >= 0 else math.nan
    return out


def _run(packing: Packing, *, ic: str, kick, damping: float, step: float, sub: int, samples: int,
         skin: float | None, times: np.ndarray, progress, progress_interval: float, unloading: str,
         device: str = "cpu", shear: bool = False, drive: str = "impulse", field: float | None = None) -> dict:
    """One DEM run from the stored state: ``kick`` = (grains, values) or None (baseline):
    values are the initial velocities (A) or imposed displacements (B), vertical, or with
    ``shear`` a pair (velocities, angular velocities); ``shear`` records the top wall's force
    along x instead of the vertical one.

    Returns the top-wall force at the output times, the contact counts, the
    largest displacement, the kick's energy and the static checks. ``drive`` "piston": the kick's
    values are the source grains' constant velocity (their masses made
    :data:`PISTON_MASS_FACTOR` times larger). ``field``: the height bin (d) of the pulse field,
    recorded at every sample, or None. Each kernel call runs many samples (about
    :data:`CALL_SECONDS` of stepping), the readings of every sample inside it
    (:class:`granwave.dem.pulse_kernels.Readings`).
    """
    if skin is None and device != "cpu":  # the GPU's rebuild test keeps the first skin (granwave.gpu.dem)
        skin = DEFAULT_SKIN
    engine = engine_from_packing(packing, damping=damping, dt=step, skin=skin, unloading=unloading)
    d = packing.dim
    residual = float(np.max(np.linalg.norm(engine.acceleration, axis=1), initial=0.0))
    f_static_engine = float(engine.piston.f_con)
    pos_ref = engine.position.copy()
    pair_state = np.zeros(engine.pair_i.shape[0], np.int8)
    wall_state = np.zeros(engine.wall_ov.shape[0], np.int8)
    archive = PK.flag_archive()  # the flags of contacts the list dropped (PK.carry_flags)
    PK.classify(d, engine.radius, engine.pair_i, engine.pair_j, engine.n_pairs, engine.pair_ft,
                engine.pair_ov, engine.wall_ft, engine.wall_ov, K.friction_of(engine.fpar), pair_state, wall_state,
                True, K.law_of(engine.fpar))
    energy_input = 0.0
    axis = 0 if shear else d - 1
    if kick is not None:
        grains, values = kick
        if drive == "piston":
            engine.mass[grains] *= PISTON_MASS_FACTOR
            engine.inertia[grains] *= PISTON_MASS_FACTOR
            K.pair_constants(engine.pair_i, engine.pair_j, engine.n_pairs, engine.radius, engine.mass,
                             engine.ws.pair_c)
            engine.velocity[grains, axis] = values
            energy_input = float("nan")  # the piston works all along
            _forces_now(engine)
        elif shear:
            v_kick, w_kick = values
            engine.velocity[grains] += v_kick
            engine.angular_velocity[grains] += w_kick
            energy_input = float(0.5 * np.sum(packing.mass[grains, None] * v_kick**2)
                                 + 0.5 * np.sum(packing.inertia[grains, None] * w_kick**2))
            _forces_now(engine)
        elif ic == "A":
            engine.velocity[grains, d - 1] += values
            energy_input = float(0.5 * np.sum(packing.mass[grains] * values**2))
            _forces_now(engine)
        else:
            e0 = engine.elastic_energy()
            u0 = np.zeros_like(engine.position)
            u0[grains, d - 1] = values
            with CM.without_dashpot(engine.fpar):
                engine.position += u0
                engine.velocity[:] = u0  # one kinematic increment: slip = tangential u_rel (dt = 1)
                _forces_now(engine, dt=1.0)
                engine.velocity[:] = 0.0
            _forces_now(engine)
            energy_input = float(engine.elastic_energy() - e0)

    energy_start = _energy(engine) if kick is not None and drive != "piston" else float("nan")
    top = np.empty(samples)
    top[0] = engine.piston.f_con
    n_bins = 0
    grain_bin = None
    if field is not None:
        n_bins = max(1, int(math.ceil(packing.height / field)))
        grain_bin = np.clip((pos_ref[:, d - 1] / field).astype(np.int64), 0, n_bins - 1)
    # the per-sample readings besides the top-wall force, taken inside the kernel (PK.Readings)
    rd = PK.readings(packing.n_grains, samples, axis=axis, bin_width=field or 1.0, grain_bin=grain_bin,
                     n_bins=n_bins, shear=shear)
    PK.read_sample(0, engine.position, engine.velocity, engine.angular_velocity, engine.radius, engine.mass,
                   engine.pair_i, engine.pair_j, engine.n_pairs, engine.pair_ov, engine.ws.pair_c, engine.wall_ft,
                   engine.wall_ov, engine.piston, engine.fpar, rd)
    force_initial = rd.force_max.copy()
    stats = np.zeros(2)
    stats[0] = PK.max_displacement(engine.position, pos_ref, engine.lateral)
    k = 1
    # many samples per call (the readings are the kernel's), sized to about CALL_SECONDS a call
    chunk = max(1, min(samples - 1, 20_000 // sub))
    from ..devices import backend

    samples_kernel = backend(device).pulse_samples  # PK.pulse_samples on the CPU
    t_wall0 = t_last = _time.perf_counter()
    n_total = sub * (samples - 1)
    while k < samples:
        k_stop = min(samples, k + chunk)
        t0 = _time.perf_counter()
        with at_most(packing.n_grains, K.MIN_PARALLEL_GRAINS):
            engine.ws.claims[0] = numba.get_num_threads()  # the force passes' share per thread
            # one thread: the one-loop engine (same bits; its kernels compile several times faster)
            kernel = PK.pulse_samples_serial if device == "cpu" and numba.get_num_threads() == 1 else samples_kernel
            r = kernel(engine.position, engine.velocity, engine.acceleration, engine.angular_velocity,
                       engine.angular_acceleration, engine.radius, engine.mass, engine.inertia,
                       engine.lateral, engine.pos0, pos_ref, engine.pair_i, engine.pair_j,
                       engine.pair_ft, engine.pair_ov, engine.wall_ft, engine.wall_ov, engine.piston,
                       engine.fpar, engine.ipar, engine.out, engine.ws, pair_state, wall_state, archive, k,
                       k_stop, sub, top, stats, rd)
        if r < 0:  # the pair list needs room: grow the arrays (and the flags) and resume
            k = -r
            engine.grow(int(engine.ipar.needed), int(engine.ipar.width))
            grown = np.zeros(engine.pair_i.shape[0], np.int8)
            grown[: len(pair_state)] = pair_state
            pair_state = grown
            continue
        _check_sound(engine, top, k, r, stats, step, times, device)
        k = r
        elapsed = _time.perf_counter() - t0
        if elapsed > 0:  # about 0.2 s per call: Ctrl-C and SIGTERM wait for the call to return
            chunk = int(max(1, min(samples, chunk * min(4.0, CALL_SECONDS / max(elapsed, 1e-3)))))
        now = _time.perf_counter()
        if progress is not None and now - t_last >= progress_interval:
            t_last = now
            rate = engine.steps / (now - t_wall0)
            what = "dem pulse" if kick is not None else "dem baseline (no kick)"
            progress(f"{what}: t = {times[k - 1]:.4g} / {times[-1]:.4g}, step {engine.steps}/{n_total}, "
                     f"{rate:.0f} steps/s, ~{(n_total - engine.steps) / rate:.0f} s left")
    m = engine.n_pairs
    energy_drift = (_energy(engine) - energy_start) / energy_input if energy_input > 0 else float("nan")
    pulse = None
    if field is not None:
        pulse = dict(height=(np.arange(n_bins) + 0.5) * field, count=rd.count, velocity=rd.velocity,
                     force_max=rd.force_max, force_initial=force_initial,
                     **{name: np.ascontiguousarray(rd.contacts[:, c]) for c, name in enumerate(PK.CONTACT_COUNTS)})
    states = np.concatenate([pair_state[:m], wall_state, PK.archived_flags(archive)])
    count = lambda flag: int(np.count_nonzero(states & flag))  # noqa: E731
    tally = dict(zip(PK.CONTACT_COUNTS, (int(c) for c in PK.tally_states(states))))  # as every sample's
    return dict(top=rd.shear if shear else top, residual=residual, f_static_engine=f_static_engine,
                energy_input=energy_input,
                n_contacts_initial=count(PK.INITIAL), n_opened=tally["opened"], n_formed=tally["formed"],
                n_sliding=count(PK.SLID), n_sliding_new=tally["sliding_new"],
                **{"n_at_cone_initial": count(PK.LIMIT0)}, max_displacement=float(stats[0]),
                rebuilds=int(engine.rebuilds), energy_drift=float(energy_drift), field=pulse)


def _energy(engine: Engine) -> float:
    """Kinetic plus elastic energy of the engine's state (fixed walls: no work on them)."""
    kinetic = 0.5 * float(np.sum(engine.mass[:, None] * engine.velocity**2)
                          + np.sum(engine.inertia[:, None] * engine.angular_velocity**2))
    return kinetic + float(engine.elastic_energy())


def _check_sound(engine: Engine, top: np.ndarray, k0: int, k1: int, stats: np.ndarray, step: float,
                 times: np.ndarray, device: str) -> None:
    """Stop a pulse whose state blew up (the time step too long for the contacts), as the
    preparation does: a top-wall force or displacement that is not finite, or (CPU engine)
    an overlap beyond the largest grain radius after the samples ``k0 .. k1 - 1``."""
    bad = not (np.all(np.isfinite(top[k0:k1])) and math.isfinite(float(stats[0])))
    if not bad and device == "cpu":
        bad = not float(engine.out.d_max) < float(engine.fpar.r_max)
    if bad:
        raise ConvergenceError(
            f"the DEM pulse blew up by t = {times[k1 - 1]:.4g} (non-finite motion or an overlap beyond "
            f"a grain radius) at dt {step:.3g}: the step is unstable; use a smaller --dt "
            "(default: 0.01 x the shortest contact period); no output written")


# ---------------------------------------------------------------- damping series
def damping_table(signals: Sequence[Signal], *, tail_start: float | None = None,
                  labels: Sequence[str] | None = None) -> list[dict]:
    """Coherent amplitude and tail rms of each signal of a damping series, by ζ.

    For every signal (sorted by ``attrs['damping']``): the front features of
    :func:`granwave.analysis.front.front_features` (``amplitude``, ``t_peak``,
    ``t_zero``, ``width``; NaN and ``front_error`` when the rule finds no
    complete first pulse) and ``tail_rms``, the root mean square of the
    signal over t >= ``tail_start`` to the end of the record. By default
    ``tail_start`` = the latest end of a first pulse over the series,
    max over ζ of t_zero + width (a pulse's zero crossing plus one pulse
    width): one window for every ζ, which starts after every coherent pulse,
    the broadest damped one included, so no pulse counts as tail.
    ``tail_in_pulse`` says whether a row's own pulse ends after the window
    starts (possible only with ``tail_start`` given). Also
    ``tail_rms_over_amplitude`` and the counts of the DEM run. ``labels`` name
    the signals (file names) in error messages.
    """
    from ..analysis.front import front_features

    if not len(signals):
        raise InputError("no signals")
    labels = list(labels) if labels is not None else [f"signal {k}" for k in range(len(signals))]
    missing = [lab for lab, s in zip(labels, signals) if "damping" not in s.attrs]
    if missing:
        raise InputError(f"{', '.join(missing)}: no 'damping' attribute (not a "
                         "`propagate --method dem` signal)")
    order = sorted(signals, key=lambda s: float(s.attrs["damping"]))
    feats = []
    for s in order:
        try:
            feats.append(front_features(s.time, s.force))
        except InputError as exc:
            feats.append(exc)
    if tail_start is None:
        f0 = feats[0]
        if isinstance(f0, InputError):
            raise InputError(f"the least damped signal has no complete first pulse ({f0}); "
                             "give tail_start")
        tail_start = max(f.t_zero + f.width for f in feats if not isinstance(f, InputError))
    rows = []
    for s, f in zip(order, feats):
        tail = s.force[s.time >= tail_start]
        rms = float(np.sqrt(np.mean(tail**2))) if tail.size else float("nan")
        row = dict(damping=float(s.attrs["damping"]), amplitude=float("nan"), t_peak=float("nan"),
                   t_zero=float("nan"), width=float("nan"), tail_start=float(tail_start),
                   tail_rms=rms)
        if isinstance(f, InputError):
            row["front_error"] = str(f)
        else:
            row.update(amplitude=f.amplitude, t_peak=f.t_peak, t_zero=f.t_zero, width=f.width)
        row["tail_in_pulse"] = bool(not isinstance(f, InputError) and f.t_zero + f.width > tail_start)
        row["tail_rms_over_amplitude"] = rms / row["amplitude"] if row["amplitude"] > 0 else float("nan")
        for key in ("n_opened", "n_formed", "n_sliding", "max_displacement_over_overlap", "amplitude"):
            if key in s.attrs:
                row[f"run_{key}" if key == "amplitude" else key] = s.attrs[key]
        rows.append(row)
    return rows
