"""The kick of the nonlinear DEM pulse (docs/shocks.md): its source grains, its size in the
units users give (EPS in mean overlaps, strain, velocity) and the overlap it presses into a
contact, which sets the time step of a strong kick (:mod:`granwave.dem.pulse` runs it)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..model import Packing
from .. import contact_models as CM
from ..contact_models import options as CO

#: Default amplitude EPS (linear regime; docs/damping.md).
DEFAULT_AMPLITUDE = 1e-3
#: The drives of the source (docs/shocks.md): the impulse of initial condition A or B, or the source
#: grains pushed at a constant velocity v_p (a piston, Gomez et al. 2012).
DRIVES = ("impulse", "piston")


def packing_law(packing: Packing) -> tuple[str, dict]:
    """(normal law's name, the contact sub-models' selection) of a packing (its attributes: the
    defaults where absent; granwave.contact_models.options); InputError for an unknown law, a
    parameter out of range or a sub-model the pulse does not run (only the normal law)."""
    # the material's laws from the packing; the dashpot is the pulse's own (its damping zeta, a
    # fraction of critical: the damping series of docs/method.md §11), not the preparation's
    values = {**CO.values_of_attrs(packing.attrs), CO.KINDS["damping"]["option"]: CO.KINDS["damping"]["default"]}
    try:
        chosen = CO.check(values)
    except ValueError as e:
        raise InputError(str(e)) from None
    for option, name in CO.off_kinds_on(values):
        raise InputError(f"the DEM pulse does not run {CO.SUBMODELS[name]['description']} yet (the packing was "
                         f"made with --{option.replace('_', '-')} {name})")
    return chosen["normal"], values


def _check_ic(ic: str) -> str:
    ic = str(ic).upper()
    if ic not in ("A", "B"):
        raise InputError(f"initial condition must be A or B (got {ic!r})")
    return ic


def source(packing: Packing, kind: str = "normal") -> tuple[np.ndarray, np.ndarray]:
    """(grain indices, k_wall) of the force-carrying bottom-wall contacts (the source);
    k_wall is k_n for the normal kick, k_t for the shear kick."""
    c = packing.contacts
    on = c.is_bottom & (c.force_normal > 0.0)
    if not np.any(on):
        raise InputError("the packing has no force-carrying bottom-wall contact: no source")
    if not np.any(c.is_top & (c.force_normal > 0.0)):
        raise InputError("the packing has no force-carrying top-wall contact: no detector")
    k = c.stiffness_tangential if kind == "shear" else c.stiffness_normal
    return c.i[on].astype(np.int64), k[on].astype(float)


def shear_kick(packing: Packing) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(grains, velocities (m, dim), angular velocities (m, n_rot)) of the shear kick per unit
    scale: the generalized force of the bottom wall moved along x
    (:func:`granwave.linear.assemble.wall_push`: k_t on x and the torque of the dragged
    contact point) divided by the mass and the moment of inertia, the linear model's IC A."""
    from ..geometry import n_rotations
    from ..linear.assemble import shear_direction, wall_push

    c = packing.contacts
    on = np.flatnonzero(c.is_bottom & (c.force_normal > 0.0))
    n_rot = n_rotations(packing.dim, packing.friction)
    grains, force, torque = wall_push(packing, on, shear_direction(packing.dim), n_rot)
    return (grains.astype(np.int64), force / packing.mass[grains, None],
            torque / packing.inertia[grains, None])


def mean_overlap(packing: Packing) -> float:
    """δ̄: mean overlap of the force-carrying contacts (grain–grain and wall)."""
    c = packing.contacts
    carrying = c.force_normal > 0.0
    if not np.any(carrying):
        raise InputError("the packing has no force-carrying contact")
    return float(np.mean(c.overlap[carrying]))


def amplitude_scale(packing: Packing, ic: str, amplitude: float, kind: str = "normal") -> float:
    """The global scale s of the source for amplitude EPS (module docstring; for the shear kick
    k_wall = k_t)."""
    ic = _check_ic(ic)
    grains, kw = source(packing, kind)
    dbar = mean_overlap(packing)
    if ic == "A":
        return amplitude * dbar / float(np.max(np.sqrt(kw / packing.mass[grains])))
    return amplitude * dbar / float(np.max(kw / kw.mean()))


def _check_drive(drive: str, ic: str) -> str:
    drive = str(drive).lower()
    if drive not in DRIVES:
        raise InputError(f"drive must be one of {', '.join(DRIVES)} (got {drive!r})")
    if drive == "piston" and ic != "A":
        raise InputError("the piston drive is a velocity: initial condition A only")
    return drive


def _unit_speed(packing: Packing, ic: str, kind: str, drive: str) -> float:
    """The largest source velocity per unit scale s: max_i k_wall,i / m_i (impulse A, normal), the
    largest |velocity| of :func:`shear_kick` (impulse A, shear), 1 (piston: s = v_p); NaN for B."""
    if drive == "piston":
        return 1.0
    if ic == "B":
        return float("nan")
    if kind == "shear":
        return float(np.max(np.linalg.norm(shear_kick(packing)[1], axis=1)))
    grains, kw = source(packing, kind)
    return float(np.max(kw / packing.mass[grains]))


def kick_size(packing: Packing, *, ic: str = "A", kind: str = "normal", drive: str = "impulse",
              amplitude: float | None = None, strain: float | None = None,
              velocity: float | None = None) -> dict:
    """The kick's size from exactly one of ``amplitude`` (EPS, in mean overlaps), ``strain`` (EPS
    δ̄ / d̄, d̄ the mean diameter) or ``velocity`` (the largest source velocity: of a kicked grain
    for the impulse, v_p for the piston; in sqrt(E*/rho)), with the other two: a dict
    amplitude, strain, velocity (NaN for initial condition B) and scale s (module docstring;
    the piston's s is v_p and its EPS the single-contact excursion of a source grain at v_p)."""
    ic = _check_ic(ic)
    drive = _check_drive(drive, ic)
    given = {k: v for k, v in (("amplitude", amplitude), ("strain", strain), ("velocity", velocity)) if v is not None}
    if len(given) > 1:
        raise InputError(f"give one kick size, not {' and '.join('--' + k for k in given)}")
    for k, v in given.items():
        if not (v > 0.0 and math.isfinite(v)):
            raise InputError(f"{k} must be a positive number (got {v})")
    grains, kw = source(packing, kind)
    dbar = mean_overlap(packing)
    dmean = float(np.mean(2.0 * packing.radius))
    unit = _unit_speed(packing, ic, kind, drive)
    if drive == "piston":
        excursion = float(np.max(np.sqrt(packing.mass[grains] / kw)))  # per unit v_p
        eps_per_scale = excursion / dbar
    else:
        eps_per_scale = amplitude_scale(packing, ic, 1.0, kind) ** -1.0
    if "velocity" in given:
        if not math.isfinite(unit):
            raise InputError("initial condition B is a displacement: give --amplitude or --strain, not --velocity")
        scale = velocity / unit
    elif "strain" in given:
        scale = strain * dmean / dbar / eps_per_scale
    else:
        scale = (DEFAULT_AMPLITUDE if amplitude is None else amplitude) / eps_per_scale
    eps = scale * eps_per_scale
    if not given or "amplitude" in given:  # EPS given: exactly it, and the impulse's scale bit for bit
        eps = DEFAULT_AMPLITUDE if amplitude is None else float(amplitude)
        if drive == "impulse":
            scale = amplitude_scale(packing, ic, eps, kind)
    return dict(amplitude=float(eps), strain=float(eps * dbar / dmean), velocity=float(scale * unit),
                scale=float(scale))


def peak_overlap(packing: Packing, *, ic: str, velocity: float, displacement: float, drive: str) -> tuple[float, float]:
    """(Δ, k(Δ)): the overlap Δ that the kick itself presses into a contact and the normal law's
    stiffness there. A velocity (impulse A, piston): two of the lightest grains closing at
    v_rel (the largest kick velocity; 2 v_p for the piston, the speed of a grain bounced off it)
    until their law's energy equals the kinetic energy of the relative motion, m_min v_rel^2 / 4;
    a displacement (B): Δ = the largest imposed displacement. k(Δ) is the stiffness of the
    grain-wall contact (the stiffer one) of the smallest grain at Δ."""
    from .. import contact as C

    _, values = packing_law(packing)
    _, law = CM.normal_law(values)
    r = float(np.min(packing.radius))
    e_wall = C.effective_young(True)
    stiff = lambda x: float(CM.law_stiffness(law, x, math.sqrt(r), e_wall))  # noqa: E731
    if ic == "B" and drive == "impulse":
        return float(displacement), stiff(float(displacement))
    v_rel = (2.0 if drive == "piston" else 1.0) * float(velocity)
    target = 0.25 * float(packing.mass.min()) * v_rel**2
    r12, e12 = C.effective_radius(1.0 / r, 1.0 / r), C.effective_young(False)
    energy = lambda x: float(CM.law_energy(law, x, r12, e12)) - target  # noqa: E731
    hi = 1e-12
    while energy(hi) < 0.0 and hi < r:
        hi *= 2.0
    if energy(hi) < 0.0:
        return r, stiff(r)  # beyond a radius: the run's own check stops it
    from scipy.optimize import brentq

    delta = float(brentq(energy, 0.0, hi, xtol=1e-15 * hi, rtol=1e-12))
    return delta, stiff(delta)


#: The default record of the DEM pulse, in crossings of the column at :func:`front_speed_bound`: the
#: bound is the perfect lattice's (or a chain's exact speed), and a disordered packing's front travels
#: at about half of it (the workflow's t_max_factor, 2.5 crossings, for the same reason).
RECORD_CROSSINGS = 2.5
#: c of a triangular lattice across its rows over d sqrt(k/m) (docs/method.md §12: (√3/2) sqrt(3/2)):
#: the densest 2D arrangement's, above a chain's (1) and a disordered packing's.
LATTICE_SPEED_FACTOR = math.sqrt(9.0 / 8.0)


def front_speed_bound(packing: Packing, *, peak: float) -> dict:
    """An upper estimate of the kick's front speed from the closed forms (docs/shocks.md): the larger
    of the linear speed c = sqrt(9/8) d̄ sqrt((k̄_n + k̄_t/3) / m̄) (the triangular lattice's with the
    packing's mean stored stiffnesses of force-carrying grain contacts) and the long-wave solitary
    wave's speed (:func:`granwave.theory.solitary_wave_speed`, the packing's law) of crest overlap
    δ̄_0 + ``peak`` (:func:`peak_overlap`, an overestimate of the wave's crest: two grains colliding at
    the full kick velocity), on the mean precompression δ̄_0. A dict linear, nonlinear, speed."""
    from .. import contact as C
    from ..theory import solitary_wave_speed

    c = packing.contacts
    on = (c.j >= 0) & (c.force_normal > 0.0)
    if not np.any(on):
        raise InputError("the packing has no force-carrying grain contact: no front speed")
    mass = float(np.mean(packing.mass))
    spacing = float(np.mean(2.0 * packing.radius))
    kn, kt = float(np.mean(c.stiffness_normal[on])), float(np.mean(c.stiffness_tangential[on]))
    linear = LATTICE_SPEED_FACTOR * spacing * math.sqrt((kn + kt / 3.0) / mass)
    _, values = packing_law(packing)
    _, law = CM.normal_law(values)
    r = 0.5 * spacing
    r12, e12 = C.effective_radius(1.0 / r, 1.0 / r), C.effective_young(False)
    d0 = float(np.mean(c.overlap[on]))
    dm = d0 + float(peak)
    f0 = float(CM.law_force(law, d0, math.sqrt(r12), e12))
    fm = float(CM.law_force(law, dm, math.sqrt(r12), e12))
    nonlinear = 0.0
    if fm > f0:
        energy = lambda *_: (float(CM.law_energy(law, dm, r12, e12) - CM.law_energy(law, d0, r12, e12)),  # noqa: E731
                             dm - d0)
        nonlinear = solitary_wave_speed(fm, f0, energy=energy, mass=mass, spacing=spacing)
    return dict(linear=float(linear), nonlinear=float(nonlinear), speed=float(max(linear, nonlinear)))
