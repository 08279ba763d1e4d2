"""Relax given grains (positions, radii) under the piston with granwave's own engine.

The route for packings prepared elsewhere (LAMMPS on MPI, a file of positions):
the grains are put between granwave's bottom wall and piston and relaxed with
the preparation's physics and convergence test (docs/dem.md;
:mod:`granwave.dem.protocol`), starting from the given state instead of a gas.
Every contact starts with a zero tangential force, so the contact history of
the result is granwave's own. Parameters are a
:class:`granwave.dem.params.PrepareParams` (pressure, friction, damping,
background damping, tol, max_steps, safety, ...); its gas fields are unused.

Built from the engine's public pieces (:class:`~granwave.dem.integrator.Engine`,
:func:`~granwave.dem.forces.static_residual`, the protocol's scales and hint);
the loop mirrors :func:`granwave.dem.protocol.prepare_packing`'s.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConvergenceError, InputError
from ..geometry import grain_inertia, grain_mass, wall_area, wrap
from ..model import Packing
from ..dem.forces import contacts_of_engine, static_residual
from ..dem.integrator import Engine
from ..dem.params import PrepareParams
from ..dem.protocol import CONVERGENCE_TEST, DT_RULE, impact_velocity, non_convergence_hint, pressure_scales


def _max_acceleration(m: dict) -> float:
    return max(m["max_acceleration"], m["max_angular_acceleration"], m["piston_acceleration"])


def relax_grains(position, radius, lateral, params: PrepareParams, *, piston_height: float | None = None,
                 velocity=None, angular_velocity=None, progress=None, attrs: dict | None = None) -> Packing:
    """Relax grains to mechanical equilibrium under the pressure ``params.pressure``.

    ``position`` (N, dim) with the bottom wall at 0 along the last axis; ``radius`` (N,);
    ``lateral`` the periodic lengths (dim-1,). ``piston_height``: where the piston starts
    (default: resting on the highest grain). ``velocity`` (N, dim) and
    ``angular_velocity`` (N, 1 in 2D / 3 in 3D) optional initial state. Raises
    ConvergenceError when ``params.max_steps`` steps do not converge, InputError for
    grains that do not fit between the walls.
    """
    p = params
    position = np.array(position, dtype=float)
    radius = np.asarray(radius, dtype=float)
    lateral = np.atleast_1d(np.asarray(lateral, dtype=float))
    n, dim = position.shape
    if dim != p.dim or lateral.shape != (dim - 1,):
        raise InputError(f"positions have {dim} columns; expected {p.dim} and {p.dim - 1} periodic lengths")
    y = position[:, -1]
    if np.any(y - radius < -0.5 * radius):
        k = int(np.argmin(y - radius))
        raise InputError(f"grain {k} reaches {radius[k] - y[k]:.3g} d below the bottom wall "
                         "(more than half its radius): the wall is not where the grains are")
    top = float(np.max(y + radius))
    height = top if piston_height is None else float(piston_height)
    if height < top - 0.5 * radius.min():
        raise InputError(f"the piston at {height:.6g} cuts through the grains (the highest reaches {top:.6g})")
    position = wrap(position, lateral)
    mass = grain_mass(radius)
    mean_mass = float(mass.mean())
    delta_p, _, t_p = pressure_scales(p.pressure, mean_mass)
    piston_mass = p.piston_mass if p.piston_mass is not None else mean_mass * float(np.prod(lateral))
    piston_force = p.pressure * wall_area(lateral)
    t_i = math.sqrt(mean_mass / p.pressure)
    gamma = p.background_damping / t_i
    tol_v = impact_velocity(p.tol, mean_mass)
    engine = Engine(position, radius, lateral, height, friction=p.friction, poisson=p.poisson,
                    damping=p.damping, background_damping=gamma, piston_mass=piston_mass,
                    piston_force=piston_force, safety=p.safety, overlap_floor=delta_p, skin=p.skin,
                    tol_acceleration=p.tol, tol_velocity=tol_v, check_every=p.check_every,
                    velocity=velocity, angular_velocity=angular_velocity)

    def packing_now(residual: float) -> Packing:
        a = dict(attrs or {})
        a.update(kind="relaxed", dim=dim, pressure=p.pressure, friction=p.friction, poisson=p.poisson,
                 seed=p.seed, converged=True, max_acceleration=residual, grains=n, damping=p.damping,
                 background_damping=p.background_damping, background_damping_rate=gamma,
                 piston_mass=piston_mass, dt=engine.dt, dt_safety=p.safety, dt_rule=DT_RULE, tol=p.tol,
                 velocity_tol=tol_v, time_scale=t_p, inertial_time=t_i, steps=engine.steps,
                 rebuilds=engine.rebuilds, skin=p.skin, check_every=p.check_every,
                 convergence_test=CONVERGENCE_TEST, max_steps=p.max_steps,
                 relaxation="granwave.interop.relax: the given grains relaxed under the piston, "
                            "tangential history from zero")
        return Packing(position=wrap(engine.position, lateral), radius=radius.copy(), mass=mass.copy(),
                       inertia=grain_inertia(radius), box=np.array([*lateral, engine.height]),
                       contacts=contacts_of_engine(engine), attrs=a)

    history = []
    chunk = 2000
    while engine.steps < p.max_steps:
        status = engine.run(min(chunk, p.max_steps - engine.steps))
        if status == 3:
            raise ConvergenceError(f"the relaxation blew up after {engine.steps} steps (an overlap beyond "
                                   f"a grain radius or non-finite motion) at dt {engine.dt:.3g}: are the "
                                   "grains overlapping far more than the pressure explains? Try a smaller "
                                   "--safety")
        m = engine.measure()
        history.append((engine.steps, _max_acceleration(m)))
        if progress is not None:
            progress(f"step {engine.steps:>9d}  max|a| {history[-1][1]:.3e}  max|v| {m['max_speed']:.3e}  "
                     f"piston {engine.height:.6f}  contacts {m['contacts']}")
        if status == 1:
            packing = packing_now(0.0)
            res = max(static_residual(packing, piston_mass, piston_force))
            if res < p.tol:
                packing.attrs["max_acceleration"] = res
                return packing
        chunk = min(4 * chunk, 50_000)
    raise ConvergenceError(f"{p.max_steps} steps did not relax the grains: "
                           + non_convergence_hint(history, engine.measure(), p, engine.dt))
