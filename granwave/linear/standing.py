"""The lowest longitudinal standing modes of a column and the speed they imply.

A column between two walls that the linear model holds fixed (docs/method.md §5: wall contacts
tie a grain to a fixed wall) has, in the continuum, the longitudinal standing modes
``u_y = sin(k_n y)``, ``k_n = n pi / H_eff``, ``omega_n = c_l k_n`` (fixed-fixed string).
The wall layers differ from the bulk: softer and less dense. Their extra compliance acts as
a spring in series at each end, which to first order lengthens the column to
``H_eff = H C22_slab / C22`` (the whole-cell C22 is the bulk's and the two wall springs in
series: H / C22 = H / C22_slab + 2 b, and the end spring b shifts each node by b C22_slab;
exact for a chain of rows with its own wall springs). Their mass sits where the mode
hardly moves (u ~ k y), a correction of order (k l)^2 l / H.

:func:`longitudinal_modes` finds those modes among the eigenmodes of ``D phi = omega^2 M phi``
by their projection on the profile ``sin(n pi y_i / H)`` along the vertical (mass-weighted,
every grain alike, nothing lateral); :func:`mode_speeds` turns them into speeds.

Units: lengths d, omega sqrt(E*/rho)/d, speeds sqrt(E*/rho).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..model import LinearSystem, Packing

#: Up to this many dofs every mode is computed (dense); above, the lowest ``LOWEST`` only.
DENSE_DOF = 2500
LOWEST = 200


def longitudinal_modes(system: LinearSystem, packing: Packing, *, n_max: int = 3) -> dict:
    """Where the standing profiles n = 1 .. ``n_max`` lie in the spectrum.

    Weight of an M-orthonormal mode phi in the profile s_n (vertical dofs
    ``sin(n pi y_i / H)``, the others 0): ``P = (phi^T M s_n)^2 / (s_n^T M s_n)``, between 0
    and 1, summing to 1 over all modes. On a perfect lattice one mode carries all of it; in
    a disordered packing the profile spreads over the modes near its frequency (scattering,
    and mixing with the other standing waves there), and its frequency is the weighted
    median of omega: half the profile's weight lies below it (``omega``; ``omega_q1``,
    ``omega_q3``: the quartiles). ``omega_top``, ``overlap``: the mode with the largest
    weight. ``overlap_total``: the weight of the modes computed (below 1 when only the lowest
    are; the median is NaN unless it reaches 1/2).
    """
    from .eigen import eigensolve

    if packing.dim not in (2, 3):
        raise InputError(f"standing modes need a 2D or 3D column (got dim = {packing.dim})")
    vertical = packing.dim - 1
    H = float(packing.box[vertical])
    n_dof = system.n_dof
    k = None if n_dof <= DENSE_DOF else min(LOWEST, n_dof - 2)
    modes = eigensolve(system, vectors=True, k=k)
    phi = modes.vectors  # M-orthonormal displacements
    omega = np.sqrt(np.maximum(modes.omega2, 0.0))
    order = np.argsort(omega)
    y = packing.position[system.dof_grain, vertical]
    along = system.dof_axis == vertical
    out = {key: [] for key in ("n", "omega", "omega_q1", "omega_q3", "omega_top", "overlap",
                               "overlap_total")}
    out["height"] = H
    for n in range(1, n_max + 1):
        s = np.where(along, np.sin(n * np.pi * y / H), 0.0)
        P = (phi.T @ (system.mass * s)) ** 2 / float(s @ (system.mass * s))
        cum = np.cumsum(P[order])
        m = int(np.argmax(P))
        out["n"].append(n)
        for key, q in (("omega", 0.5), ("omega_q1", 0.25), ("omega_q3", 0.75)):
            out[key].append(float(omega[order][np.searchsorted(cum, q)]) if cum[-1] >= q else math.nan)
        out["omega_top"].append(float(omega[m]))
        out["overlap"].append(float(P[m]))
        out["overlap_total"].append(float(cum[-1]))
    return out


def mode_speeds(modes: dict, C22: float, C22_slab: float, key: str = "omega") -> np.ndarray:
    """c_n = omega_n H_eff / (n pi), H_eff = H C22_slab / C22 (module docstring; 3D: C33),
    omega_n = ``modes[key]`` (the weighted median; ``omega_q1`` ... for its spread)."""
    H_eff = modes["height"] * C22_slab / C22
    n = np.asarray(modes["n"], float)
    return np.asarray(modes[key], float) * H_eff / (n * np.pi)
