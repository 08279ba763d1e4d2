"""The DEM engine: state of a run and velocity-Verlet time stepping.

:class:`Engine` holds the arrays (positions, velocities, angular velocities,
pair list with tangential history, wall-contact history, piston) and calls
the numba kernels of :mod:`granwave.dem.kernels` in chunks of steps, so
progress reporting stays in Python while the time stepping runs compiled.

Time integration: velocity Verlet (symplectic for the conservative part),
translations and rotations alike (spheres: orientation never enters the
forces, only angular velocities are kept). Velocity-dependent forces
(contact damping, background damping) and the slip increment use the
half-step velocity v(t + dt/2), whose product with dt is exactly the step's
displacement. Time step (:func:`kernels.stable_dt`): dt = (safety / 0.1) x the
estimated stability limit of this scheme, the smaller of 2 (sqrt(1 + z^2) - z) / w
over two modes of the stiffest contact (a wall contact of the largest grain on
the lightest grain, at the larger of the current largest overlap and an overlap
floor): the normal one (w_n^2 = k_n / m_min, z = zeta) and, with friction, the
grain turning about its contact (w_t^2 = 3.5 k_t / m_min, z = zeta sqrt(3.5)).
Recomputed every ``check_every`` steps when no ``dt`` is given.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from .. import contact_models as CM
from ..contact_models import options as CO
from .. import team
from ..errors import InputError
from ..geometry import grain_inertia, grain_mass, n_rotations
from ..params import PrepareParams
from ..threads import at_most
from . import kernels as K
from . import serial
from .mean_flow import M_GAMMA_L, M_GAMMA_M, M_SLAB, N_MFLOW, slab_count
from .neighbours import rebuild

#: Neighbours per grain the lists start with (2D, 3D); grown when a grain has more.
NEIGHBOUR_WIDTH = {2: 16, 3: 40}
#: Run the plain steps on more than one thread in a team of threads (kernels._team_steps: the
#: same bits as a parallel region per pass); False for the regions alone (benchmarks, tests)
PLAIN_STEPS_IN_TEAM = True

#: Tangential unloading rules (contact.update_tangential's ``rescale_on_unloading`` True / False).
UNLOADING_RULES = ("rescale", "incremental")


def one_thread(n_grains: int) -> bool:
    """Whether the engine's kernels run on one thread for ``n_grains`` (one thread set, or a
    system below K.MIN_PARALLEL_GRAINS, as :func:`granwave.threads.at_most` makes it): then the
    one-loop kernels of :mod:`granwave.dem.serial` run (the same bits)."""
    return numba.get_num_threads() == 1 or n_grains < K.MIN_PARALLEL_GRAINS


class Engine:
    """A DEM system: grains between a bottom wall and a top wall (piston).

    Parameters (units of docs/method.md §1): ``position`` (N, dim) centres, ``radius``
    (N,), ``lateral`` periodic lengths (dim-1,), ``height`` initial top-wall
    position; ``friction`` mu (0: no rotational dof at all), ``poisson`` nu,
    ``damping`` zeta (fraction of critical, per contact), ``background_damping``
    gamma (a rate, 1/time: force -gamma m v and torque -gamma I w),
    ``piston_mass`` (``inf``: the top wall is fixed), ``piston_force`` the
    constant downward force on the piston (p A). ``dt`` fixes the time step;
    otherwise it follows :func:`kernels.stable_dt` with ``safety`` and
    ``overlap_floor``. ``skin``: Verlet-list skin in d; with ``skin_min`` (< skin) the
    skin adapts at each rebuild within [skin_min, skin] to the grains' speed
    (:func:`kernels.next_skin`; the bits of a run are the same for any skin), from ``first_skin``
    (default ``skin``: a gas starts fast; a pulse from rest starts at ``skin_min``). ``tol_acceleration``,
    ``tol_velocity`` and ``check_every`` drive the convergence candidate test
    of :meth:`run`. ``unloading``: the tangential unloading rule of
    contact.update_tangential, ``"rescale"`` (default, preparation: F_t scaled by
    sqrt(n_new/n_old) when the overlap falls) or ``"incremental"`` (plain incremental
    Mindlin law, the pulses'; contact.py docstring). ``mean_flow``: None, or (gamma_m, slab)
    or (gamma_m, slab, gamma_l) for the compaction rule 'mean-flow'
    (:mod:`granwave.dem.mean_flow`: the mean vertical flow of slabs of thickness ``slab`` and
    the piston damped at gamma_m, the slabs' mean lateral flow at gamma_l (default
    ``background_damping``), the rest at ``background_damping``; ``mflow[M_GAMMA_M]`` and
    ``mflow[M_GAMMA_L]`` may be changed between runs); the GPU engine has it too
    (:mod:`granwave.gpu.mean_flow`). ``**contact``: the contact sub-models, by the names of their
    ``PrepareParams`` fields (each kind's option, e.g. ``contact_law``, and the sub-models'
    parameters; granwave.contact_models.options): the selected ones run, a history sub-model's
    columns in ``pair_ft`` and ``wall_ft`` after the tangential ones; an unknown name is a
    TypeError.

    Defaults: friction, poisson, damping, safety, skin, check_every and the contact sub-models
    are the preparation's, read from
    :class:`granwave.params.PrepareParams` (their one home; the pulses pass theirs,
    :func:`granwave.dem.pulse.engine_from_packing`). The others switch a feature off (no
    background damping, a fixed top wall, no convergence test, a fixed skin, no mean-flow rule),
    take dt from the stability rule, or start at rest; ``overlap_floor`` (d) is the protocol's
    overlap under its pressure, which it passes.
    """

    def __init__(self, position, radius, lateral, height, *, friction=PrepareParams.friction,
                 poisson=PrepareParams.poisson, damping=PrepareParams.damping, background_damping=0.0,
                 piston_mass=math.inf, piston_force=0.0, dt=None, safety=PrepareParams.safety,
                 overlap_floor=1e-3, skin=PrepareParams.skin, skin_min=None, first_skin=None, velocity=None,
                 angular_velocity=None, tol_acceleration=0.0, tol_velocity=0.0,
                 check_every=PrepareParams.check_every, unloading="rescale", mean_flow=None, **contact):
        self.position = np.array(position, dtype=np.float64, order="C")
        n, d = self.position.shape
        if d not in (2, 3):
            raise InputError(f"positions must be 2D or 3D, got {d} columns")
        self.radius = np.ascontiguousarray(radius, dtype=np.float64)
        self.lateral = np.ascontiguousarray(np.atleast_1d(lateral), dtype=np.float64)
        if self.lateral.shape != (d - 1,):
            raise InputError(f"need {d - 1} lateral lengths, got {self.lateral.shape}")
        reach = 2.0 * (2.0 * self.radius.max() + skin)
        if np.any(self.lateral <= reach):
            raise InputError(f"periodic length {self.lateral.min():g} too small: must exceed {reach:g} "
                             "(twice the largest diameter plus skin) for unique nearest images")
        self.mass, self.inertia = grain_mass(self.radius), grain_inertia(self.radius)
        self.dim = d
        self.friction = float(friction)
        n_rot = n_rotations(d, self.friction)
        self.velocity = np.zeros((n, d)) if velocity is None else np.array(velocity, dtype=np.float64)
        self.angular_velocity = (np.zeros((n, n_rot)) if angular_velocity is None or n_rot == 0
                                 else np.array(angular_velocity, dtype=np.float64).reshape(n, n_rot))
        self.acceleration = np.zeros((n, d))
        self.angular_acceleration = np.zeros((n, n_rot))
        self.pos0 = self.position.copy()
        # room for listed pairs (grown by half when a rebuild needs more, the same bits): dense
        # frictional packings list 2.4 (2D) and 4.6 (3D) pairs per grain, and every slot costs
        # 64 (2D) / 72 (3D) bytes with the per-pair constants (it was 12 and 24 per grain)
        cap = max(64, (4 if d == 2 else 8) * n)
        self.pair_i = np.zeros(cap, np.int64)
        self.pair_j = np.zeros(cap, np.int64)
        #: the contact sub-models' selection (granwave.contact_models.options: options and parameters)
        self.contact = CO.resolve({**contact, "friction": self.friction, "poisson": float(poisson),
                                   "damping": float(damping)}, "Engine")
        try:
            CO.check(self.contact, friction=1.0 if n_rot > 0 else 0.0)
        except ValueError as e:
            raise InputError(str(e)) from None
        #: history columns per contact: the tangential force's, then those of the sub-models
        hist = CM.history_columns(d, self.contact)
        self.pair_ft = np.zeros((cap, hist))
        self.pair_ov = np.zeros(cap)
        #: compaction 'mean-flow': [gamma_m, slab, gamma_l] (empty: off) and the slabs' work array
        self.mflow = np.zeros(0)
        self.slabs = np.zeros((2, 1))
        if mean_flow is not None:
            values = [float(x) for x in mean_flow]
            if len(values) == N_MFLOW - 1:
                values.append(float(background_damping))  # the lateral mean flow like the rest
            self.mflow = np.array(values)
            if (self.mflow.shape != (N_MFLOW,)
                    or not (self.mflow[M_GAMMA_M] >= 0.0 and self.mflow[M_SLAB] > 0.0 and self.mflow[M_GAMMA_L] >= 0.0)):
                raise InputError(f"mean_flow must be (gamma_m >= 0, slab > 0[, gamma_l >= 0]), got {mean_flow!r}")
            self.slabs = np.zeros((d + 1, slab_count(float(height), self.mflow[M_SLAB])))
            self._cpu_only()
        #: arrays of the parallel kernels (kernels.workspace): neighbour and incoming lists,
        #: per-block statistics, the mean-flow rule's arrays
        self.ws = K.workspace(n, d, n_rot, cap, NEIGHBOUR_WIDTH[d], mflow=self.mflow, slabs=self.slabs)
        self.wall_ft = np.zeros((2 * n, hist))
        self.wall_ov = np.zeros(2 * n)
        self.piston = K.record(K.PISTON)  # records: named fields (granwave.dem.layout)
        self.piston.h = height
        self.piston.mass = piston_mass if piston_mass is not None else math.inf
        self.piston.f_ext = piston_force
        self.fpar = K.record(K.PARAMS)
        self.fpar.poisson = poisson
        self.fpar.gamma = background_damping
        if skin_min is not None and not 0.0 < skin_min <= skin:
            raise InputError(f"skin_min must be in (0, skin = {skin:g}], got {skin_min:g}")
        self.fpar.skin_max = skin
        self.fpar.skin_min = skin if skin_min is None else skin_min
        if first_skin is not None and not self.fpar.skin_min <= first_skin <= skin:
            raise InputError(f"first_skin must be in [skin_min, skin] = [{self.fpar.skin_min:g}, {skin:g}], "
                             f"got {first_skin:g}")
        self.fpar.skin = skin if first_skin is None else first_skin
        self.fpar.safety = safety
        self.fpar.overlap_floor = overlap_floor
        self.fpar.tol_a = tol_acceleration
        self.fpar.tol_v = tol_velocity
        self.fpar.r_max = self.radius.max()
        self.fpar.m_min = self.mass.min()
        self.fpar.dt = 0.0
        if unloading not in UNLOADING_RULES:
            raise InputError(f"unloading must be one of {UNLOADING_RULES}, got {unloading!r}")
        self.unloading = unloading
        self.fpar.rescale = 1 if unloading == "rescale" else 0
        CM.fill_params(self.fpar, self.contact)
        self.ipar = K.record(K.COUNTERS)
        self.ipar.adaptive = dt is None
        self.ipar.check = check_every
        self.out = K.record(K.OUT)
        self._rebuild()
        # initial forces: dt = 0 so that no history is created by the evaluation itself
        self._forces()
        self.fpar.dt = dt if dt is not None else K.stable_dt_at(self.fpar, self.out.d_max)

    # ------------------------------------------------------------------ internals
    def grow(self, needed: int, width: int = 0) -> None:
        """Room for ``needed`` pairs, ``width`` neighbours per grain and the incoming pairs the
        workspace asked for (``ws.need[2]``); contents kept. With a new width the neighbour
        and gather lists are rebuilt by the next rebuild; otherwise they are carried over."""
        cap = max(int(needed * 1.5) + 64, len(self.pair_i))
        d = self.dim
        same_pairs = cap == len(self.pair_i)
        if cap > len(self.pair_i):
            for name, shape, dtype in (("pair_i", (cap,), np.int64), ("pair_j", (cap,), np.int64),
                                       ("pair_ft", (cap, self.pair_ft.shape[1]), np.float64),
                                       ("pair_ov", (cap,), np.float64)):
                old = getattr(self, name)
                new = np.zeros(shape, dtype)
                new[: len(old)] = old
                setattr(self, name, new)
        ws = self.ws
        old_width = ws.nbr.shape[1]
        width = old_width if width <= old_width else int(width * 1.5) + 2
        boundary = int(ws.need[2])
        room = len(ws.slot_pair)
        # the lists are carried over when only the incoming pairs asked for room (a rebuild that
        # ran out of room follows again otherwise)
        self.ws = K.grown_workspace(ws, cap, width, int(boundary * 1.5) + 64 if boundary > room else room,
                                    keep_lists=width == old_width and same_pairs)

    def _rebuild(self) -> None:
        while True:
            w = self.ws
            m = rebuild(self.position, self.radius, self.lateral, self.piston.h, self.fpar.skin,
                        self.pair_i, self.pair_j, self.pair_ft, self.pair_ov, self.ipar.npairs,
                        w.nbr, w.ncount, w.nlo, w.row, w.gather, w.need)
            if m >= 0:
                break
            self.grow(int(w.need[0]), int(w.need[1]))
        self.ipar.npairs = m
        self.ipar.built = self.ipar.steps
        K.pair_constants(self.pair_i, self.pair_j, m, self.radius, self.mass, self.ws.pair_c)
        self.pos0[:] = self.position

    def _cpu_only(self) -> None:
        """Refuse the compaction rule 'mean-flow' on an engine whose own stepping lacks it (a
        subclass with its own ``run`` that does not override this; the GPU engine does)."""
        if type(self).run is not Engine.run:
            raise InputError("mean-flow compaction runs on the CPU only for now (use --device cpu)")

    def _forces(self) -> None:
        compute_forces = serial.compute_forces if one_thread(len(self.radius)) else K.compute_forces
        compute_forces(self.position, self.velocity, self.angular_velocity, self.radius, self.mass,
                       self.inertia, self.lateral, self.pair_i, self.pair_j, self.pair_ft, self.pair_ov,
                       self.wall_ft, self.wall_ov, self.piston, self.fpar, self.ipar, self.acceleration,
                       self.angular_acceleration, self.out, self.ws)
        K.to_accelerations(self.acceleration, self.angular_acceleration, self.mass, self.inertia)
        self.piston.a = K.piston_acceleration(
            self.piston, self.mflow[0] if self.mflow.shape[0] > 0 else self.fpar.gamma)

    # ------------------------------------------------------------------ public
    def run(self, n_steps: int) -> int:
        """Advance up to ``n_steps`` steps; return 1 if the convergence candidate
        test passed, 3 if the state blew up (unstable time step; see
        :func:`kernels.run_chunk`), else 0."""
        target = self.steps + int(n_steps)
        with at_most(len(self.radius), K.MIN_PARALLEL_GRAINS):
            # one thread: the single pair loop (same bits, a third faster; dem/serial.py); more:
            # the block engine with blocks for this many threads (same bits for any partition)
            threads = numba.get_num_threads()
            run_chunk = serial.run_chunk if threads == 1 else K.run_chunk
            if threads > 1:
                self.ws = K.with_blocks(self.ws, K.block_count(len(self.radius), threads))
            self.ipar.team = int(threads > 1 and PLAIN_STEPS_IN_TEAM and team.usable())
            while self.steps < target:
                self.ipar.nsteps = target - self.steps
                self.ws.claims[0] = threads  # the force passes' share per thread (kernels.visit_block)
                status = run_chunk(self.position, self.velocity, self.acceleration, self.angular_velocity,
                                     self.angular_acceleration, self.radius, self.mass, self.inertia,
                                     self.lateral, self.pos0, self.pair_i, self.pair_j, self.pair_ft,
                                     self.pair_ov, self.wall_ft, self.wall_ov, self.piston, self.fpar,
                                     self.ipar, self.out, self.ws)
                if self.ipar.team < 0:  # its threads did not all start: regions from now on
                    team.give_up("DEM engine")
                if status == 2:
                    self.grow(int(self.ipar.needed), int(self.ipar.width))
                    continue
                if status in (1, 3):
                    return status
        return 0

    #: the arrays that hold a run's state between two calls of :meth:`run` (the rest are fixed
    #: by the constructor's arguments); ``mflow`` and ``slabs`` are shared with the workspace
    STATE_ARRAYS = ("position", "velocity", "angular_velocity", "acceleration", "angular_acceleration",
                    "pos0", "pair_i", "pair_j", "pair_ft", "pair_ov", "wall_ft", "wall_ov", "mflow", "slabs")
    #: the records of the state (granwave.dem.layout), kept as one-element structured arrays
    STATE_RECORDS = ("piston", "fpar", "ipar", "out")
    #: workspace entries a call of :meth:`run` goes on from (the lists of the last rebuild, the
    #: pair constants, the wall list, the incoming pairs' room); the others are rebuilt from them
    #: at every call, are sized by the thread count (blocks, per-thread scratch) or are timings
    STATE_WORKSPACE = ("nbr", "gather", "ncount", "nlo", "row", "need", "top", "pair_c", "walls", "slot_pair",
                       "out_slot", "bnd_f", "inv_m", "inv_i")

    def state(self) -> dict:
        """Copies of every array a later :meth:`run` goes on from ({name: array}; workspace
        fields as ``ws_<name>``): with :meth:`restore` on an engine built with the same
        arguments, the run continues with the same bits (granwave.dem.checkpoint)."""
        out = {name: getattr(self, name).copy() for name in self.STATE_ARRAYS}
        out.update({name: K.as_array(getattr(self, name)) for name in self.STATE_RECORDS})
        out.update({f"ws_{w}": getattr(self.ws, w).copy() for w in self.STATE_WORKSPACE})
        return out

    def restore(self, state: dict) -> None:
        """Take back a :meth:`state` of an engine built with the same arguments (the grains,
        the rules' parameters); arrays whose length grew during that run come back at their
        size. ``mflow`` and ``slabs`` are written in place (the workspace holds them)."""
        for name in self.STATE_ARRAYS:
            old, new = getattr(self, name), np.asarray(state[name])
            if new.dtype != old.dtype or new.shape[1:] != old.shape[1:]:
                raise InputError(f"engine state {name!r}: {new.dtype}{new.shape} does not fit "
                                 f"{old.dtype}{old.shape}")
            if name in ("mflow", "slabs"):
                if new.shape != old.shape:
                    raise InputError(f"engine state {name!r}: shape {new.shape}, expected {old.shape}")
                old[...] = new
            else:
                setattr(self, name, np.array(new, order="C"))
        for name in self.STATE_RECORDS:
            old, new = getattr(self, name), np.asarray(state[name])
            if new.dtype.names != old.dtype.names or new.shape != (1,):
                raise InputError(f"engine state {name!r}: {new.dtype}{new.shape} is not a record of "
                                 f"{old.dtype.names}")
            K.copy_record(old, new)
        self.ws = self.ws._replace(**{w: np.array(state[f"ws_{w}"], dtype=getattr(self.ws, w).dtype, order="C")
                                      for w in self.STATE_WORKSPACE})

    def damping_rates(self) -> tuple:
        """The background damping rates now (1 / time unit): (gamma, a copy of ``mflow``), the
        argument ``base`` of :meth:`cap_background_damping`."""
        return float(self.fpar.gamma), self.mflow.copy()

    def cap_background_damping(self, rate: float, base: tuple) -> None:
        """Set every background damping rate (grains; with 'mean-flow', the mean flows and the
        piston) to the least of ``rate`` (1 / time unit) and its value in ``base``
        (:meth:`damping_rates`), from the next step on (the end game of
        :mod:`granwave.dem.end_game`; the GPU engine uploads the parameters at every run)."""
        gamma, mflow = base
        self.fpar.gamma = min(gamma, rate)
        if self.mflow.shape[0] > 0:
            self.mflow[M_GAMMA_M] = min(mflow[M_GAMMA_M], rate)
            self.mflow[M_GAMMA_L] = min(mflow[M_GAMMA_L], rate)

    def measure(self) -> dict:
        """Largest accelerations and speeds, kinetic energy (piston included)."""
        K.measure(self.velocity, self.acceleration, self.angular_velocity, self.angular_acceleration,
                  self.mass, self.inertia, self.radius, self.piston, self.fpar.gamma, self.out)
        o = self.out
        return dict(max_acceleration=o.a_max, max_angular_acceleration=o.alpha_max,
                    piston_acceleration=o.a_piston, max_speed=o.v_max,
                    max_rotation_speed=o.w_max, piston_speed=abs(float(self.piston.v)),
                    kinetic_energy=o.kin,
                    top_contacts=int(o.ntop), max_overlap=o.d_max, contacts=int(o.ncontact))

    def elastic_energy(self) -> float:
        """Hertz energy of all contacts plus |F_t|^2 / (2 k_t) of the tangential springs."""
        return elastic_energy_kernel(self)

    def total_energy(self) -> float:
        """Kinetic + elastic + piston potential (p A h) energy."""
        kin = self.measure()["kinetic_energy"]
        pot = self.piston.f_ext * self.piston.h if self.piston.mass < math.inf else 0.0
        return kin + self.elastic_energy() + pot

    @property
    def dt(self) -> float:
        return float(self.fpar.dt)

    @property
    def steps(self) -> int:
        return int(self.ipar.steps)

    @property
    def rebuilds(self) -> int:
        return int(self.ipar.rebuilds)

    @property
    def skin(self) -> float:
        """The skin of the current pair list (d)."""
        return float(self.fpar.skin)

    @property
    def height(self) -> float:
        return float(self.piston.h)

    @property
    def n_pairs(self) -> int:
        return int(self.ipar.npairs)


def elastic_energy_kernel(engine: Engine) -> float:
    """Elastic energy stored in the contacts of ``engine`` (Python loop over contacts)."""
    from .forces import contacts_of_engine  # local: forces imports this module

    c = contacts_of_engine(engine)
    wall = c.j < 0
    ri = engine.radius[c.i]
    rj = np.where(wall, np.inf, engine.radius[np.maximum(c.j, 0)])
    law = K.law_of(engine.fpar)
    e = 0.0
    for k in range(len(c)):
        r12 = C.effective_radius(1.0 / ri[k], 1.0 / rj[k])
        e += CM.law_energy(law, c.overlap[k], r12, C.effective_young(bool(wall[k])))
        kt = c.stiffness_tangential[k]  # the tangential law's (contact_table)
        if engine.friction > 0.0 and kt > 0.0:
            e += float(np.dot(c.force_tangential[k], c.force_tangential[k])) / (2.0 * kt)
    return e


def steps_to_tol(history, tol: float, window: int = 60) -> float | None:
    """Steps until a decaying quantity reaches ``tol``, from its history (steps, value) after
    each chunk (about one a second): 0 when its last value is below tol; else the steps at the
    decay rate of its envelope, the least-squares slope of the log of its running minimum
    (the lowest value so far: such quantities fall in bursts) against steps over the last
    ``window`` chunks; inf when that envelope did not fall over the window or is already below
    tol (the quantity dipped below and rose again: no rate to extrapolate); None with fewer
    than 3 chunks."""
    pts = [(s, a) for s, a in history if a > 0 and math.isfinite(a)]
    if history and 0 <= history[-1][1] < tol:
        return 0.0
    if len(pts) < 3:
        return None
    envelope = np.minimum.accumulate(np.log([p[1] for p in pts]))[-window:]
    s = np.array([p[0] for p in pts[-window:]], float)
    s -= s.mean()
    if not np.any(s):
        return None
    slope = float(np.dot(s, envelope - envelope.mean()) / np.dot(s, s))
    if not tol > 0.0 or envelope[-1] <= math.log(tol) or not slope < 0:
        return math.inf  # (a threshold so small it underflowed to 0 is never reached)
    return (math.log(tol) - float(envelope[-1])) / slope  # logs: tol / lowest may underflow


def eta_seconds(quantities, steps_per_second: float, window: int = 60,
                steps_left: float = math.inf) -> float | None:
    """Seconds until every quantity of the convergence test is below its threshold, or None.

    ``quantities``: (history, tol) pairs, a history being (steps, value) after each chunk
    (the preparation passes max |a| against tol and the largest speed, |v|, |w| R or the
    piston's, against the velocity threshold); the time is that of the slowest at the decay
    rate of its envelope (:func:`steps_to_tol`). None (unknown) when one still above its
    threshold has no falling envelope, with fewer than 3 chunks, with no rate yet, when all
    are below (the run then waits for the next check and the static residual), or when the
    slowest would pass the step limit ``steps_left`` (a 51 200-grain column still compressing
    showed an ETA of 5e31 s).
    Checked on the progress log of a 21 000-grain column (1.2 million steps, max |a| alone):
    within a factor 2 of the steps left over the second half of the run, where the slope of
    the last 8 chunks of max |a| itself said seconds for minutes, or nothing; max |a| alone
    said 30 s 9 minutes before the end of a 3D run that then waited for the speeds
    (docs/dem.md; benchmarks/investigations/eta_check.py compares the two rules).
    """
    if not steps_per_second > 0:
        return None
    steps = [steps_to_tol(h, tol, window) for h, tol in quantities]
    if not steps or any(k is None for k in steps):
        return None
    slowest = max(steps)
    if slowest == 0.0 or math.isinf(slowest) or slowest > steps_left:
        return None
    return slowest / steps_per_second
