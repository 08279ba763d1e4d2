"""Preparation of disordered packings by piston compression (docs/method.md §3).

Protocol
--------
1. Diameters uniform in [1-W, 1+W] (seeded generator). Periodic width from
   :func:`granwave.geometry.lateral_size` so that the final packing is about
   ``aspect`` times as high as wide.
2. A granular gas at rest: grains placed at random in distinct cells of a grid
   (cells at least one largest diameter wide), each jittered inside its cell,
   in a box tall enough for the requested initial solid fraction
   ``gas_density``; the piston starts at the top of the gas.
3. A constant downward force p A on the piston (mass M), Hertz-Mindlin
   contacts with friction and contact damping zeta, and a weak background
   damping gamma = b / t_p on grains and piston (t_p = sqrt(m_mean / k_p),
   k_p = k_n of a grain pair carrying p d^2). The protocol is then invariant
   under the Hertz scaling of pressure (time ~ p^-1/6, overlaps ~ p^2/3): the
   same b gives statistically the same packing at every p.
4. Velocity Verlet with the adaptive time step of
   :mod:`granwave.dem.integrator` (safety 0.05 by default: half the estimated
   stability limit, contact damping and rotations included), until converged.
   A run that blows up (unstable step) or whose max |a| stalls far above tol
   stops with a ConvergenceError saying what was observed and what may help.

Convergence test (stated in the output attribute ``convergence_test``): every
``check_every`` steps, candidate when (a) the piston touches grains, (b) every
grain's |a| and |alpha| and the piston's |a| are below ``tol``, and (c) every
grain's |v| and |w| R and the piston's |v| are below v_tol, the speed at which
a head-on Hertz collision of two mean grains peaks at an acceleration tol
(:func:`impact_velocity`; 6.5e-9 for tol = 1e-10, independent of p). (c)
removes the two false positives of docs/method.md §3: a dilute gas (or a piston at
terminal velocity) has small accelerations but finite velocities, and a caged
rattler between collisions has zero acceleration but moves; a rattler slower
than v_tol cannot raise an acceleration above tol when it hits. A candidate is
accepted when the static residual computed from the stored contacts alone
(elastic forces, no velocities; :func:`granwave.dem.forces.static_residual`)
is also below ``tol``: that is the ``max_acceleration`` written to the file.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import contact as C
from .. import contact_models as CM
from ..contact_models import options as CO
from ..errors import ConvergenceError, InputError, StepBudgetExceeded
from ..geometry import (EXPECTED_SOLID_FRACTION_2D, EXPECTED_SOLID_FRACTION_3D, grain_inertia, grain_mass,
                        grain_measure, lateral_size, wall_area, wrap)
from ..model import Packing
from ..resources import check_prepare
from .forces import contacts_of_engine, static_residual
from .integrator import Engine, eta_seconds
from .end_game import END_GAME_RULES, EndGame, largest_acceleration, largest_speed
from .settling import LATE_FRACTION, SAMPLE_CHECKS, SETTLING_RULES, CriticalSettling
from ..params import PrepareParams, default_gas_density

#: how the initial gas numbers its grains (recorded: it fixes the bits, not the distribution)
GAS_NUMBERING = "by grid cell, layer by layer from the bottom"
DT_RULE = ("(safety/0.1) * min over the normal and (friction) rotational mode of the stiffest contact "
           "of 2(sqrt(1+z^2)-z)/w: w_n^2 = k_max/m_min, z = zeta; w_t^2 = 3.5 eta k_max/m_min, "
           "z = zeta sqrt(3.5); adaptive")
CONVERGENCE_TEST = ("piston touches grains; max |a|, |alpha| of grains and |a| of piston < tol; "
                    "max |v|, |w| R of grains and |v| of piston < velocity_tol (Hertz impact at tol); "
                    "static residual from stored contacts < tol")

COMPACTION_RULES = {
    "fixed": "background damping rate b / t_i at every height",
    "height-scaled": ("background damping rate (b / t_i) min(1, reference_height / L_e), L_e the expected "
                      "final height (grain area or volume / (expected solid fraction x lateral size))"),
    "mean-flow": ("background damping rate b / t_i on the velocities about the mean vertical flow; the "
                  "mean flow (mass-weighted mean vertical velocity of the grains in horizontal slabs of "
                  "thickness mean_flow_slab) and the piston at (b / t_i) min(1, reference_height / L_e)"),
}


#: Default step budget per 100 d of a column's expected height (and the least budget). At
#: p = 1e-7, the lowest pressure of the study, the default rule took 0.82-0.88e6 steps per 100 d
#: at 100-400 d, growing as L^0.9 (docs/dem.md "Relaxation cost"): a margin of 2.3-2.4 that
#: grows with L, where a fixed 2e6 stopped the 400 d column after 60 % of its run
STEPS_PER_100D = 2_000_000


def step_budget(max_steps: int | None, expected_height: float) -> int:
    """Steps a preparation may take: ``max_steps`` when given, else :data:`STEPS_PER_100D` per
    100 d of ``expected_height`` (d), at least :data:`STEPS_PER_100D`."""
    if max_steps is not None:
        return int(max_steps)
    return int(STEPS_PER_100D * max(1.0, expected_height / 100.0))


def expected_height(radius, lateral) -> float:
    """Expected final height of the grains ``radius`` in the periodic cell ``lateral`` (d): their
    area (2D) or volume (3D) over the expected solid fraction times the lateral size; the inverse
    of :func:`granwave.geometry.lateral_size` (aspect x width for a prepared packing)."""
    dim = len(lateral) + 1
    phi = EXPECTED_SOLID_FRACTION_2D if dim == 2 else EXPECTED_SOLID_FRACTION_3D
    return float(np.sum(grain_measure(radius, dim))) / (phi * float(np.prod(lateral)))


def damping_scale(params: PrepareParams, height: float) -> float:
    """Factor on the background damping rate b / t_i for a column of expected height ``height``.

    'fixed': 1. 'height-scaled': min(1, reference_height / height). In the overdamped
    compaction of a tall column the piston drags a growing plug of grains through the
    background damping, so with a fixed rate its speed falls as 1/L and the compaction
    takes a time ~ L^2; with the rate ~ 1/L the compaction is the same in units of L (the
    continuum problem is invariant under x -> x L, t -> t L, gamma -> gamma / L: the same
    speeds at the same relative depth) and the slowest mode (frequency ~ 1/L) keeps the same
    damping ratio, so time and steps grow as H. Columns up to ``reference_height`` keep b.
    """
    if params.compaction != "height-scaled" or height <= params.reference_height:
        return 1.0
    return params.reference_height / height


def mean_flow_scale(params: PrepareParams, height: float) -> float:
    """Factor on the damping rate of the mean vertical flow and the piston, 'mean-flow' rule only:
    min(1, reference_height / height) (1 for the other rules, whose mean flow is damped with the rest).

    The plug that the piston drags is the mean flow: damped at a rate ~ 1/L its compaction is the
    same in units of L at every height (as with 'height-scaled'), while the grain-scale agitation
    about it, whose time scale does not grow with L, keeps the rate b / t_i of a short column.
    """
    if params.compaction != "mean-flow" or height <= params.reference_height:
        return 1.0
    return params.reference_height / height


def pressure_scales(pressure: float, mean_mass: float, contact: dict | None = None) -> tuple[float, float, float]:
    """(delta_p, k_p, t_p): overlap and k_n of a grain pair (R12 = 1/4, E*12 = 1/2)
    carrying the force p d^2 under the normal law of the sub-models ``contact`` (a selection,
    granwave.contact_models.options; None: the defaults), and the contact time scale
    t_p = sqrt(m_mean / k_p)."""
    r12, e12 = 0.25, C.effective_young(False)
    values = CO.values_of(contact or {})
    _, model = CM.normal_law(values)
    delta = CM.overlap_at_force(values, pressure, r12, e12)
    k = CM.law_stiffness(model, delta, math.sqrt(r12), e12)
    return delta, k, math.sqrt(mean_mass / k)


def impact_velocity(tol: float, mass: float, contact: dict | None = None) -> float:
    """Speed at which a head-on impact of two grains of mass ``mass`` (R12 = 1/4,
    E*12 = 1/2) peaks at an acceleration ``tol``: (1/2) m_eff v^2 = W F delta with
    F = mass * tol, W F delta the work of the force up to delta (the normal law's IMPACT_WORK:
    Hertz 2/5, a linear spring 1/2)."""
    r12, e12 = 0.25, C.effective_young(False)
    force = mass * tol
    values = CO.values_of(contact or {})
    module, _ = CM.normal_law(values)
    delta = CM.overlap_at_force(values, force, r12, e12)
    m_eff = C.reduced_mass(mass, mass, False)
    return math.sqrt(2.0 * module.IMPACT_WORK * force * delta / m_eff)


def granular_gas(radius: np.ndarray, lateral: np.ndarray, gas_density: float, rng: np.random.Generator):
    """Non-overlapping grains at rest in a tall periodic box; returns (positions, height).

    Grid cells are at least one largest diameter wide; N distinct cells are
    drawn at random and each grain jittered inside its cell. The height gives
    the requested solid fraction, or more height if the grid needs it.
    """
    n = len(radius)
    dim = len(lateral) + 1
    dmax = 2.0 * radius.max()
    if np.any(np.asarray(lateral) < dmax):
        raise InputError(f"periodic length {float(np.min(lateral)):g} too small for the granular gas: "
                         f"must be at least the largest diameter {dmax:g} (use more grains or a "
                         "smaller aspect)")
    ncol = [max(1, int(length // dmax)) for length in lateral]
    per_layer = int(np.prod(ncol))
    height = float(np.sum(grain_measure(radius, dim))) / (gas_density * float(np.prod(lateral)))
    # rows: as many as fit in the density height, and never fewer than N grains need. The
    # row count is an integer computed directly, not recovered from a height by floor
    # division ((9 dmax) // dmax can be 8 in floating point, which left fewer cells than grains).
    nrow = int(height // dmax)
    if nrow * per_layer < n:
        nrow = -(-n // per_layer)
        height = max(height, nrow * dmax)
    # cells numbered layer by layer from the bottom (row-major: the vertical index first), so
    # that grains with neighbouring indices are neighbours in space and contiguous index ranges
    # are horizontal slabs (the parallel engine's blocks, docs/dem.md "Parallel engine")
    shape = (nrow, *ncol)
    cells = np.sort(rng.choice(per_layer * nrow, size=n, replace=False))
    idx = np.array(np.unravel_index(cells, shape)).T  # (n, dim): row, then the lateral cells
    idx = np.roll(idx, -1, axis=1)  # lateral cells, then the row
    size = np.array([*(lateral[a] / ncol[a] for a in range(dim - 1)), height / nrow])
    # >= 0 by construction up to rounding (a cell is >= dmax wide); clamp the last ulp
    room = np.maximum(0.5 * size[None, :] - radius[:, None], 0.0)
    jitter = rng.uniform(-1.0, 1.0, size=(n, dim)) * room
    pos = (idx + 0.5) * size[None, :] + jitter
    return pos, height


#: Target length (s) of one engine call between Python's checks: a signal waits at most about
#: this long (the progress lines still come about once a second).
CALL_SECONDS = 0.3



class Compression:
    """The engine of the piston protocol for given grains, and what it records.

    One home for the protocol's scales (pressure scales, inertial time, background
    damping rate, velocity threshold, piston mass and force) shared by the
    preparation from a gas and the relaxation of grains made elsewhere
    (:func:`granwave.interop.relax.relax_grains`). ``engine``: the engine class (CPU or GPU).
    """

    def __init__(self, position, radius, lateral, height: float, params: PrepareParams, *,
                 velocity=None, angular_velocity=None, engine=Engine):
        p = self.params = params
        self.radius, self.lateral = radius, lateral
        self.mass = grain_mass(radius)
        mean_mass = float(self.mass.mean())
        #: the contact sub-models' selection (granwave.contact_models.options)
        self.contact = CO.values_of(p)
        delta_p, _, self.time_scale = pressure_scales(p.pressure, mean_mass, self.contact)
        self.piston_mass = p.piston_mass if p.piston_mass is not None else mean_mass * float(np.prod(lateral))
        self.piston_force = p.pressure * wall_area(lateral)
        self.inertial_time = math.sqrt(mean_mass / p.pressure)  # sqrt(m / (p d))
        self.expected_height = expected_height(radius, lateral)
        self.max_steps = step_budget(p.max_steps, self.expected_height)
        self.damping_scale = damping_scale(p, self.expected_height)
        self.gamma = p.background_damping * self.damping_scale / self.inertial_time
        #: compaction 'mean-flow': the rate of the mean flow and the piston (None: the rule is off,
        #: or the column is not taller than reference_height, where it is 'fixed' to the bit)
        self.mean_flow_scale = mean_flow_scale(p, self.expected_height)
        self.gamma_mean = self.gamma * self.mean_flow_scale if self.mean_flow_scale < 1.0 else None
        extra = {} if self.gamma_mean is None else dict(mean_flow=(self.gamma_mean, p.mean_flow_slab))
        self.tol_v = impact_velocity(p.tol, mean_mass, self.contact)
        self.engine = engine(position, radius, lateral, height, friction=p.friction, poisson=p.poisson,
                             damping=p.damping, background_damping=self.gamma,
                             piston_mass=self.piston_mass, piston_force=self.piston_force,
                             safety=p.safety, overlap_floor=delta_p, skin=p.skin,
                             skin_min=min(p.skin_min, p.skin),
                             tol_acceleration=p.tol, tol_velocity=self.tol_v,
                             check_every=p.check_every, velocity=velocity,
                             angular_velocity=angular_velocity, **extra, **self.contact)
        #: compaction 'mean-flow', settling 'critical' or 'late': watches the piston and switches
        #: the mean flow to critical damping once the plug has arrived (and, 'late', the kinetic
        #: energy has fallen; None: off)
        self.settling = (CriticalSettling(self.engine, self.gamma, SAMPLE_CHECKS * p.check_every,
                                          late=LATE_FRACTION if p.mean_flow_settling == "late" else None)
                         if self.gamma_mean is not None and p.mean_flow_settling != "compaction" else None)
        #: end_game 'adaptive': matches the background damping to the slowest mode once the packing
        #: is all but static (None: 'none', the protocol without it to the bit)
        settled = self.engine.run if self.settling is None else self.settling.run
        self.end_game = (EndGame(self.engine, settled, gamma=self.gamma, tol=p.tol,
                                 every=SAMPLE_CHECKS * p.check_every, settling=self.settling)
                         if p.end_game == "adaptive" else None)
        #: what advances the run: the engine, wrapped by the rules that are on
        self.advance = settled if self.end_game is None else self.end_game.run

    def packing(self, attrs: dict) -> Packing:
        """The engine's current state as a packing, with the protocol in its attributes."""
        p, engine = self.params, self.engine
        a = dict(attrs)
        a.update(dim=p.dim, pressure=p.pressure, friction=p.friction, poisson=p.poisson, seed=p.seed,
                 damping=p.damping, background_damping=p.background_damping,
                 background_damping_rate=self.gamma, compaction=p.compaction,
                 reference_height=p.reference_height, expected_height=self.expected_height,
                 background_damping_scale=self.damping_scale, compaction_rule=COMPACTION_RULES[p.compaction],
                 piston_mass=self.piston_mass, dt=engine.dt,
                 dt_safety=p.safety, dt_rule=DT_RULE, tol=p.tol, velocity_tol=self.tol_v,
                 time_scale=self.time_scale, inertial_time=self.inertial_time, steps=engine.steps,
                 rebuilds=engine.rebuilds, skin=p.skin, skin_min=p.skin_min, check_every=p.check_every,
                 convergence_test=CONVERGENCE_TEST, max_steps=self.max_steps)
        a.update(CO.attrs_of(self.contact))
        if p.compaction == "mean-flow":
            a.update(mean_flow_slab=p.mean_flow_slab, mean_flow_damping_scale=self.mean_flow_scale,
                     mean_flow_damping_rate=self.gamma * self.mean_flow_scale,
                     mean_flow_settling=p.mean_flow_settling,
                     mean_flow_settling_rule=SETTLING_RULES[p.mean_flow_settling])
            if self.settling is not None:
                a.update(self.settling.attrs())
        if self.end_game is not None:
            a.update(self.end_game.attrs())
        a.update(end_game=p.end_game, end_game_rule=END_GAME_RULES[p.end_game])
        r = self.radius
        return Packing(position=wrap(engine.position, self.lateral), radius=r.copy(),
                       mass=self.mass.copy(), inertia=grain_inertia(r),
                       box=np.array([*self.lateral, engine.height]),
                       contacts=contacts_of_engine(engine), attrs=a)

    def relax(self, attrs: dict, *, progress=None, blow_up_hint: str,
              failure: str = "did not converge", checkpoint=None) -> Packing:
        """Run until every acceleration is below tol and the static residual agrees.

        ``attrs``: what the packing records beyond the protocol (kind, sizes, ...).
        ``progress`` is called about once a second. Raises ConvergenceError when the
        run blows up (with ``blow_up_hint``) or ``self.max_steps`` steps ``failure``.
        ``checkpoint``: None, or a :class:`granwave.dem.checkpoint.Checkpoint` the run resumes
        from (when its file exists) and writes at chunk boundaries when it is due.
        """
        p, engine = self.params, self.engine
        chunk = 2000
        history = []  # (steps, max |a|) after every chunk: tells a stalled run from a slow one
        speeds = []  # (steps, largest of |v|, |w| R and the piston's |v|): the ETA waits for them too
        resumed = None if checkpoint is None else checkpoint.resume(self)
        if resumed is not None:
            history, speeds = resumed
            if progress is not None:
                progress(f"resumed from step {engine.steps} ({checkpoint.path})")
        last = time.perf_counter()
        last_steps = engine.steps
        # a resumed run reported these before its checkpoint
        announced = self.settling is not None and self.settling.done  # the settling switch reported
        announced_end = self.end_game is not None and self.end_game.started  # the end game's start reported
        while engine.steps < self.max_steps:
            t0 = time.perf_counter()
            status = self.advance(min(chunk, self.max_steps - engine.steps))
            if status == 3:
                raise ConvergenceError(
                    f"the run blew up after {engine.steps} steps (an overlap beyond a grain radius or "
                    f"non-finite motion) at dt {engine.dt:.3g}: {blow_up_hint}")
            m = engine.measure()
            history.append((engine.steps, largest_acceleration(m)))
            speeds.append((engine.steps, largest_speed(m)))
            if progress is not None and self.settling is not None and self.settling.done and not announced:
                announced = True
                s = self.settling
                progress(f"plug arrived (piston up at step {s.rise_step}, down at {s.swing_end_step}; switch at "
                         f"{s.switch_step}): breathing "
                         f"frequency {s.breathing_frequency:.3g}, mean flow damped at {engine.mflow[0]:.3g} "
                         f"(was {self.gamma_mean:.3g})")
            if progress is not None and self.end_game is not None and self.end_game.started and not announced_end:
                announced_end = True
                progress(f"end game from step {self.end_game.start_step}: the background damping "
                         f"({self.gamma:.3g}) follows the slowest mode")
            elapsed = time.perf_counter() - t0
            # calls of about CALL_SECONDS: a signal (Ctrl-C, SIGTERM) is handled between calls,
            # and the bits do not depend on the chunking (docs/dem.md)
            if elapsed > 0:
                chunk = int(min(max(chunk * min(4.0, CALL_SECONDS / max(elapsed, 1e-3)), 200), 200_000))
            if status == 1:
                packing = self.packing({**attrs, "converged": True, "max_acceleration": 0.0})
                res = static_residual(packing, self.piston_mass, self.piston_force)
                if max(res) < p.tol:
                    packing.attrs["max_acceleration"] = max(res)
                    if progress is not None:
                        progress(f"converged after {engine.steps} steps: static residual {max(res):.3e}")
                    return packing
            now = time.perf_counter()
            if progress is not None and now - last > 1.0:
                rate = (engine.steps - last_steps) * engine.position.shape[0] / (now - last)
                eta = eta_seconds(((history, p.tol), (speeds, self.tol_v)), rate / engine.position.shape[0],
                                  steps_left=self.max_steps - engine.steps)
                progress(f"step {engine.steps:>9d}  max|a| {largest_acceleration(m):.3e}"
                         f"  max|v| {m['max_speed']:.3e}"
                         # frictional grains rotate; their spin is part of the convergence test
                         + (f"  max|wR| {m['max_rotation_speed']:.3e}" if p.friction > 0 else "")
                         + f"  KE {m['kinetic_energy']:.3e}  piston {engine.height:.4f}"
                         # the end game's background damping rate, once it follows the slowest mode
                         + (f"  damping {self.end_game.rate:.3g}"
                            if self.end_game is not None and self.end_game.started else "")
                         + f"  contacts {m['contacts']:>5d}  dt {engine.dt:.3g}  {rate:.3g} grain-steps/s"
                         f"  ETA {'?' if eta is None else f'{eta:.0f} s'}")
                last, last_steps = now, engine.steps
            if checkpoint is not None and checkpoint.due():
                checkpoint.save(self, history, speeds)  # a chunk boundary: the state the run goes on from
        m = engine.measure()
        kept = ""
        if checkpoint is not None:  # the run so far, for a larger budget to go on from
            checkpoint.save(self, history, speeds)
            kept = (f" (checkpoint {checkpoint.path} kept at step {engine.steps}: rerun with a larger "
                    "--max-steps to go on from it)")
        raise StepBudgetExceeded(f"{self.max_steps} steps {failure}: "
                                 + non_convergence_hint(history, m, p, engine.dt, self.max_steps) + kept,
                                 self.max_steps)


def prepare_packing(params: PrepareParams, progress=None, engine=Engine, checkpoint=None) -> Packing:
    """Prepare one disordered packing in mechanical equilibrium (docs/method.md §3).

    ``progress``: optional callable taking one line of text, called about once
    a second. ``engine``: the engine class (the CPU :class:`Engine`, or
    :class:`granwave.gpu.dem.GpuEngine`; granwave.devices.backend picks it). Raises :class:`granwave.errors.ConvergenceError` when
    its step budget (:func:`step_budget`) does not converge. The returned packing lists the
    force-carrying contacts at the final positions (walls: j = -1 bottom,
    -2 top) and records the protocol in ``attrs``. ``checkpoint``: None or a
    :class:`granwave.dem.checkpoint.Checkpoint` (resumed from when its file exists; see
    :meth:`Compression.relax`); the packing is the same, bit for bit.
    """
    p = params
    check_prepare(p.grains, p.dim)  # refuse a request that cannot fit, before allocating
    rng = np.random.default_rng(p.seed)
    w = p.polydispersity
    diameter = rng.uniform(1.0 - w, 1.0 + w, size=p.grains) if w > 0 else np.ones(p.grains)
    radius = 0.5 * diameter
    width = lateral_size(radius, p.dim, p.aspect)
    lateral = np.full(p.dim - 1, width)
    # a bottom wall more than twice the grains laid side by side cannot carry even one layer
    # (and a tiny aspect would ask the gas for more cells than an index can count)
    one_layer = float(np.sum(diameter ** (p.dim - 1)))
    if width ** (p.dim - 1) > 2.0 * one_layer:
        raise InputError(f"aspect {p.aspect:g} gives a container {width:.4g} d wide, more than twice "
                         f"what the {p.grains} grains cover in one layer: not a packing (use a larger "
                         "aspect or more grains)")
    gas_density = p.gas_density if p.gas_density is not None else default_gas_density(p.dim)
    position, height = granular_gas(radius, lateral, gas_density, rng)
    actual_gas_density = float(np.sum(grain_measure(radius, p.dim))) / (height * float(np.prod(lateral)))
    run = Compression(position, radius, lateral, height, p, engine=engine)
    attrs = dict(kind="disordered", grains=p.grains, polydispersity=p.polydispersity, aspect=p.aspect,
                 gas_density=actual_gas_density, gas_height=height,
                 gas_numbering=GAS_NUMBERING)
    return run.relax(attrs, progress=progress, checkpoint=checkpoint,
                     blow_up_hint=(f"the explicit step is unstable for safety {p.safety:g}, damping "
                                   f"{p.damping:g}, friction {p.friction:g}; use a smaller --safety"))


def non_convergence_hint(history, m: dict, p: PrepareParams, dt: float, budget: int) -> str:
    """What was observed at the end of a run that did not converge, and what could help.

    ``history``: (steps, max |a|) after every chunk; ``budget``: the run's steps
    (:func:`step_budget`). The run *stalled* when max |a| is still
    far above tol (> 1e3 tol) and its lowest value over the second half of the run is not
    even 10x below its lowest value over the first half: more steps will not help; an
    unstable step (safety too large for the damping) or a system that cannot come to rest
    (no damping) will not converge. Otherwise max |a| was still falling: more steps can help.
    """
    a_now = largest_acceleration(m)
    seen = f"max |a| {a_now:.3e} (tol {p.tol:g}), max |v| {m['max_speed']:.3e}"
    half = [a for s, a in history if s > budget / 2]
    first = [a for s, a in history if s <= budget / 2]
    if half and first and a_now > 1e3 * p.tol and min(half) > 0.1 * min(first):
        return (f"{seen}; max |a| stalled (lowest {min(first):.2e} in the first half of the run, "
                f"{min(half):.2e} in the second), so more steps will not help. At dt {dt:.3g} "
                f"(safety {p.safety:g}, damping {p.damping:g}, background damping "
                f"{p.background_damping:g}) the explicit step may be unstable: try a smaller "
                "--safety, or different damping (some contact or background damping is needed "
                "to come to rest)")
    if a_now < p.tol:
        # Forces balance but grains keep moving at a steady speed: a creeping configuration
        # (contacts sliding at the Coulomb limit against the background damping), e.g. a
        # layer too thin or too few grains to carry the piston. More steps do not help.
        return (f"{seen}; accelerations are below tol but the grains still move at a steady "
                "speed: the packing creeps (sliding contacts) instead of settling, so more steps "
                "will not help; try more grains or a taller container (--aspect)")
    trend = f" (from {first[0]:.2e} early on)" if first else ""
    return f"{seen}{trend}; max |a| was still falling: raise --max-steps"
