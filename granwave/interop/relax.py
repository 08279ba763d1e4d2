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

import numpy as np

from ..dem.params import PrepareParams
from ..dem.protocol import Compression
from ..errors import InputError
from ..geometry import wrap
from ..model import Packing


def relax_grains(position, radius, lateral, params: PrepareParams, *, piston_height: float | None = None,
                 velocity=None, angular_velocity=None, progress=None, attrs: dict | None = None) -> Packing:
    """Relax grains to mechanical equilibrium under the pressure ``params.pressure``.

    ``position`` (N, dim) with the bottom wall at 0 along the last axis; ``radius`` (N,);
    ``lateral`` the periodic lengths (dim-1,). ``piston_height``: where the piston starts
    (default: resting on the highest grain). ``velocity`` (N, dim) and
    ``angular_velocity`` (N, 1 in 2D / 3 in 3D) optional initial state. Raises
    ConvergenceError when the step budget (``params.max_steps``, by default scaled with the
    expected height: :func:`granwave.dem.protocol.step_budget`) does not converge, InputError for
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
    run = Compression(wrap(position, lateral), radius, lateral, height, p, velocity=velocity,
                      angular_velocity=angular_velocity)
    a = dict(attrs or {})
    a.update(kind="relaxed", grains=n,
             relaxation="granwave.interop.relax: the given grains relaxed under the piston, "
                        "tangential history from zero")
    return run.relax(a, progress=progress,
                     blow_up_hint=("are the grains overlapping far more than the pressure explains? "
                                   "Try a smaller --safety"),
                     failure="did not relax the grains")
