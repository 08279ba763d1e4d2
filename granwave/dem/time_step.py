"""The DEM engine's time step (stability estimate) and its pair-list rebuild and skin rules."""

from __future__ import annotations

import math

import numba

from .. import contact as C
from ..contact_models import _dispatch as CD
from .contact_law import couple_of, dashpot_of, friction_of, law_of
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


#: ``safety`` at which :func:`stable_dt` would step exactly at the estimated stability limit:
#: dt = (safety / SAFETY_AT_LIMIT) x dt_limit (default safety 0.05: half the limit).
SAFETY_AT_LIMIT = 0.1
#: 1 + m a^2 / I for a sphere turning about its contact point (arm a <= R, I = m (2R)^2 / 10):
#: the tangential spring acts on a mode of mass m / 3.5 (translation plus rotation).
ROTATION_FACTOR = 3.5


@numba.njit(cache=True, inline="always")
def verlet_limit(omega, zeta):
    """Largest stable dt of the engine's velocity Verlet for one damped oscillator
    x'' = -omega^2 x - 2 zeta omega v with the damping on the half-step velocity:
    omega dt < 2 (sqrt(1 + zeta^2) - zeta) (2 at zeta = 0, 0.83 at zeta = 1; the
    amplification matrix of the scheme, tests/test_dem.py)."""
    return 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta) / omega


@numba.njit(cache=True)
def stable_dt(fpar):
    """dt = (safety / SAFETY_AT_LIMIT) x the estimated stability limit of the explicit step.

    The stiffest spring is a wall contact of the largest grain (R12 = R_max, E*12 = 1)
    at the larger of the largest current overlap and the overlap floor (that of a
    contact carrying p d^2), acting on the lightest grain: k_n, omega_n^2 = k_n / m_min.
    Two modes of that contact bound the step (:func:`verlet_limit`):
    - normal: omega_n, the damping law's ratio zeta of k_n on m_min (its step_ratio: the default
      law's zeta itself);
    - tangential (where the tangential law acts): the grain turning about its contact, mode mass
      m / 3.5 (m a^2 / I <= 2.5), so omega_t^2 = 3.5 eta omega_n^2 (eta = k_t / k_n, the
      tangential law's step_ratio given k_n and m_min: Mindlin's 2(1-nu)/(2-nu)) and, since the
      dashpot's ratio is that of k_t on the translational mass (docs/method.md §2: c_t = 2 zeta
      sqrt(m k_t) for the default law), damping ratio zeta_t sqrt(3.5).
    A grain has several contacts, so the true limit is 0.7-1.0 of this estimate for zeta in
    [0, 1], with and without friction; hence ``safety`` <= 0.06 (params;
    docs/decisions/0009-time-step-rule.md). k_n is the engine's normal law's
    (contact_models.law_step_stiffness: a harmonic k_n, the same for every contact, counts twice,
    for a grain's contacts acting together; eta is the same for both laws).
    """
    k = CD.law_step_stiffness(law_of(fpar), fpar.overlap_floor, math.sqrt(fpar.r_max), C.effective_young(True))
    omega = math.sqrt(k / fpar.m_min)
    dashpot = dashpot_of(fpar)
    zeta = CD.dashpot_step_ratio(dashpot, k, fpar.m_min)
    limit = verlet_limit(omega, zeta)
    tangential = friction_of(fpar)
    if CD.friction_acts(tangential):
        eta = CD.tangential_step_ratio(tangential, k, fpar.m_min, fpar.poisson)
        omega_t = omega * math.sqrt(ROTATION_FACTOR * eta)
        zeta_t = CD.dashpot_step_ratio(dashpot, eta * k, fpar.m_min)
        limit = min(limit, verlet_limit(omega_t, zeta_t * math.sqrt(ROTATION_FACTOR)))
    couple = couple_of(fpar)
    if couple.code != 0:  # the couple sub-model's own mode (granwave.contact_models, kind rolling)
        omega_c, zeta_c = CD.couple_step_mode(couple, fpar.m_min)
        limit = min(limit, verlet_limit(omega_c, zeta_c))
    return fpar.safety / SAFETY_AT_LIMIT * limit


#: Adaptive skin: steps a pair list is meant to last (:func:`next_skin`). A rebuild of a
#: dense column costs about five steps, so at this length rebuilds take ~2 % of a run.
SKIN_STEPS = 200


@numba.njit(cache=True)
def needs_rebuild(fpar, ipar, reach, ahead):
    """Whether the pair list is made again before the step ``ahead`` steps from now.

    Must when a grain may have come within ``reach`` of half the skin (the list's
    guarantee). With an adaptive skin also when the list has lasted twice
    :data:`SKIN_STEPS` and the grains' speed since it was made asks for a skin below half
    the current one: they have slowed down, and a list with a smaller skin makes each
    step cheaper (:func:`next_skin`).
    """
    return rebuild_due(fpar, ipar.steps + ahead - ipar.built, reach)


@numba.njit(cache=True, inline="always")
def rebuild_due(fpar, lasted, reach):
    """:func:`needs_rebuild` for a list that will have lasted ``lasted`` steps."""
    skin = fpar.skin
    if reach > 0.5 * skin:
        return True
    return (fpar.skin_min < skin and lasted >= 2 * SKIN_STEPS
            and 2.0 * SKIN_STEPS * reach < 0.5 * skin * lasted)


@numba.njit(cache=True)
def next_skin(fpar, ipar, reach):
    """Skin of the pair list about to be made (d).

    Fixed unless ``fpar.skin_min < fpar.skin_max``; then the skin that the grains'
    speed of the list now ending (``reach`` over the steps it lasted) would take
    :data:`SKIN_STEPS` steps to use up, within [F_SKIN_MIN, F_SKIN_MAX] and within a
    factor of two of the current skin. A skin changes no bit of a run: positions are folded
    into the box at every drift, never at a rebuild, and pairs not in contact add nothing.
    """
    skin = fpar.skin
    lo = fpar.skin_min
    hi = fpar.skin_max
    if not lo < hi:
        return skin
    lasted = max(ipar.steps - ipar.built, 1)
    want = 2.0 * SKIN_STEPS * reach / lasted
    return min(max(want, lo, 0.5 * skin), hi, 2.0 * skin)


@numba.njit(cache=True)
def stable_dt_at(fpar, dmax):
    """:func:`stable_dt` with the overlap floor raised to the current largest overlap."""
    floor = fpar.overlap_floor
    fpar.overlap_floor = max(floor, dmax)
    dt = stable_dt(fpar)
    fpar.overlap_floor = floor
    return dt


@numba.njit(cache=True)
def check_outcome(out, fpar, ipar, piston):
    """What a convergence check decides from the step's statistics ``out`` (the engines'
    run loops share it): 3 when the state blew up (an overlap beyond the largest radius or
    non-finite motion: the step is unstable), 1 when the convergence candidate test passes
    (piston touching grains, every |a|, |alpha|, |a_piston| below tol_a, every |v|, |w| R,
    |v_piston| below tol_v), else 0. With an adaptive step it first resets ``fpar.dt``."""
    if not (out.d_max < fpar.r_max and math.isfinite(out.kin)):
        return 3
    if ipar.adaptive:
        fpar.dt = stable_dt_at(fpar, out.d_max)
    tol_a = fpar.tol_a
    tol_v = fpar.tol_v
    if (out.ntop > 0 and out.a_max < tol_a and out.alpha_max < tol_a
            and out.a_piston < tol_a and out.v_max < tol_v and out.w_max < tol_v
            and abs(piston.v) < tol_v):
        return 1
    return 0
