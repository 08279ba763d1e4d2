"""The pulse inside the packing: row-averaged energy and low-pass displacement against (y, t).

The kick of initial condition A puts most of its energy into localized
high-frequency modes near the source; the coherent front that reaches the
detector carries a small part of it. :func:`row_fields` makes both visible
from the modal solution (docs/method.md §7–§9), exactly at every time:

* u(t) = Σ_n a_n φ_n sin ω_n t,  v(t) = Σ_n a_n ω_n φ_n cos ω_n t  (A);
  u = Σ a_n φ_n cos ω_n t, v = −Σ a_n ω_n φ_n sin ω_n t (B); zero modes are
  left out as in the modal signal.
* Energy of grain i: ½ Σ_{d∈i} m_d v_d² + ½ Σ_{d∈i} u_d (D u)_d (kinetic, and
  the potential energy ½ uᵀDu split between the dofs of each grain; the split
  of one grain can be slightly negative where a neighbour carries the energy).
  The total is the energy of the nonzero modes, ½ Σ_n (a_n ω_n)²; it is conserved.
* Rows: grain centres binned along the vertical axis in slabs of thickness
  ``row_width`` (d̄) from the bottom wall to the top wall. ``energy`` is the
  energy of a row's grains divided by the total energy and by ``row_width``:
  an energy per unit height in 1/d̄ that sums (× row_width) to 1 at every time.
* Low-pass displacement: the same modal sum restricted to ω_n < ω_c, with
  ω_c = ``cutoff_factor`` × π / W and W the front width of the detector
  signal (t_zero − t_lead10: half a period of the front), i.e. every mode below
  ``cutoff_factor`` times the front's own frequency. Its vertical component is
  averaged over the grains of each row with dofs (rattlers have none).
* The detector signal's front features (docs/method.md §9) give the arrival
  lines: y = L t / t_lead10 and y = L t / t_peak (source at t = 0, detector at L).

Units: times d̄/sqrt(E*/ρ), lengths d̄, displacement in the units of the kick
(the linear model's amplitude is arbitrary).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from .front import front_features

if TYPE_CHECKING:
    from ..model import LinearSystem, Modes


@dataclass
class RowFields:
    """Row-averaged fields of the pulse on a (row, time) grid."""

    time: np.ndarray  # (T,) d̄/sqrt(E*/ρ)
    row_y: np.ndarray  # (R,) centre of each row, d̄ above the bottom wall
    energy: np.ndarray  # (R, T) energy per unit height / total energy, 1/d̄
    displacement_low: np.ndarray  # (R, T) row-mean vertical low-pass displacement (kick units)
    attrs: dict = field(default_factory=dict)  # height, omega_cut, front features, ...


def _modal_state(modes: "Modes", ic: str, times: np.ndarray, keep: np.ndarray):
    """(u, v) of shape (T, n_dof) from the modes in ``keep`` (mask over modes)."""
    omega = np.sqrt(np.maximum(modes.omega2[keep], 0.0))
    amp = (modes.amplitude_A if ic == "A" else modes.amplitude_B)[keep]
    V = np.asarray(modes.vectors)[:, keep]
    wt = np.outer(times, omega)
    if ic == "A":
        u = (np.sin(wt) * amp) @ V.T
        v = (np.cos(wt) * (amp * omega)) @ V.T
    else:
        u = (np.cos(wt) * amp) @ V.T
        v = (-np.sin(wt) * (amp * omega)) @ V.T
    return u, v


def row_fields(system: "LinearSystem", modes: "Modes", position, *, ic: str = "A",
               times=None, t_max: float | None = None, n_times: int = 400,
               row_width: float = 1.0, cutoff_factor: float = 2.0,
               zero_tol: float = 1e-9) -> RowFields:
    """Row-averaged energy E(y, t) and low-pass vertical displacement (rules: module docstring).

    ``modes`` must hold the eigenvectors (``eigensolve --vectors``) of ``system``;
    ``position`` (N, dim) are the packing's grain centres. ``times`` default to
    ``n_times`` points from 0 to ``t_max`` (default 2 × the first peak's time).
    """
    ic = str(ic).upper()
    if ic not in ("A", "B"):
        raise InputError(f"initial condition must be A or B (got {ic!r})")
    if modes.vectors is None:
        raise InputError("the modes hold no eigenvectors: rerun eigensolve with --vectors")
    if modes.vectors.shape[0] != system.n_dof:
        raise InputError(f"modes ({modes.vectors.shape[0]} dofs) and linear system "
                         f"({system.n_dof} dofs) differ")
    if not row_width > 0 or not cutoff_factor > 0:
        raise InputError("row_width and cutoff_factor must be positive")
    if np.any(modes.omega2 < -zero_tol * max(float(modes.omega2.max()), 1e-300)):
        raise InputError("the modes include negative eigenvalues: no oscillatory modal solution")
    position = np.asarray(position, float)
    dim = position.shape[1]
    height = float(system.height)
    nonzero = modes.omega2 > zero_tol * max(float(modes.omega2.max()), 1e-300)
    omega = np.sqrt(np.maximum(modes.omega2, 0.0))
    # The detector signal, exactly as the modal sum gives it, for the front features.
    weight = (modes.amplitude_A if ic == "A" else modes.amplitude_B) * modes.coupling
    trig = np.sin if ic == "A" else np.cos
    # A record of one period of the lowest nonzero mode holds the first arrival.
    t_probe = np.linspace(0.0, 2 * math.pi / float(omega[nonzero].min()), 4000)
    sig = trig(np.outer(t_probe, omega[nonzero])) @ weight[nonzero]
    try:
        feats = front_features(t_probe, sig)
    except InputError as exc:
        raise InputError(f"the detector signal: {exc}") from None
    if times is None:
        t_max = 2.0 * feats.t_peak if t_max is None else float(t_max)
        if not t_max > 0:
            raise InputError("t_max must be positive")
        times = np.linspace(0.0, t_max, int(n_times))
    times = np.asarray(times, float)
    omega_cut = cutoff_factor * math.pi / feats.width
    u, v = _modal_state(modes, ic, times, nonzero)
    u_low, _ = _modal_state(modes, ic, times, nonzero & (omega < omega_cut))

    grain = np.asarray(system.dof_grain, int)
    axis = np.asarray(system.dof_axis, int)
    per_dof = 0.5 * system.mass * v ** 2 + 0.5 * u * (system.stiffness @ u.T).T  # (T, n)
    n_rows = max(1, int(math.ceil(height / row_width - 1e-9)))
    row_of_grain = np.clip((position[:, dim - 1] / row_width).astype(int), 0, n_rows - 1)
    row_of_dof = row_of_grain[grain]
    energy = np.zeros((n_rows, times.size))
    np.add.at(energy, row_of_dof, per_dof.T)
    # Energy in the nonzero modes (M-orthonormal vectors): ½ Σ (a_n ω_n)², conserved.
    amp = modes.amplitude_A if ic == "A" else modes.amplitude_B
    total = float(0.5 * np.sum((amp[nonzero] * omega[nonzero]) ** 2))
    if not total > 0:
        raise InputError("the kick carries no energy")
    energy /= total * row_width
    vert = axis == dim - 1
    disp = np.zeros((n_rows, times.size))
    count = np.bincount(row_of_dof[vert], minlength=n_rows).astype(float)
    np.add.at(disp, row_of_dof[vert], u_low[:, vert].T)
    with np.errstate(invalid="ignore", divide="ignore"):
        disp = np.where(count[:, None] > 0, disp / count[:, None], np.nan)
    attrs = {"height": height, "ic": ic, "row_width": float(row_width),
             "cutoff_factor": float(cutoff_factor), "omega_cut": float(omega_cut),
             "modes_below_cut": int(np.sum(nonzero & (omega < omega_cut))),
             "modes_nonzero": int(nonzero.sum()), "energy_total": total,
             **{k: float(getattr(feats, k)) for k in ("t_lead10", "t_peak", "t_zero", "width",
                                                     "amplitude")}}
    return RowFields(time=times, row_y=(np.arange(n_rows) + 0.5) * row_width, energy=energy,
                     displacement_low=disp, attrs=attrs)

