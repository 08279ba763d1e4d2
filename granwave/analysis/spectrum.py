"""Eigen-spectrum statistics and each mode's part in the signal (docs/method.md §7).

Choices (also in ``docs/summaries.md`` and the CLI help)
--------------------------------------------------------
* **Zero modes**: the modes with |omega²| <= ``zero_mode_threshold`` ×
  omega²_max (the threshold recorded by eigensolve, 1e-10 if absent);
  eigensolve has already clipped them to 0. "Nonzero" modes are the others.
* **Weights** w_n = a_n b_n for the chosen initial condition, so that
  F_sig(t) = Σ w_n sin(ω_n t) (A) or Σ w_n cos(ω_n t) (B).
* **"Carried" by the strongest modes**: the modes are ranked by |w_n|; the
  top fraction q (1 %, 10 %, 50 %) is the ceil(q × n_nonzero) strongest
  nonzero modes (at least one). ``carried_power`` is their share of Σ w_n²
  — the time-averaged signal power, since <F²>_t = ½ Σ w_n² for distinct
  frequencies (Parseval) — and ``carried_abs`` their share of Σ |w_n| (the
  bound max|F| <= Σ |w_n|). Also reported: how many strongest modes carry
  50 %, 90 % and 99 % of the power.
* **Participation ratio** per mode, over grains:
  PR = (Σ_i |φ_i|²)² / (N Σ_i |φ_i|⁴), |φ_i|² the squared *translational*
  displacement of grain i (rotations left out; they are not displacements)
  and N the number of grains in the modes (rattlers are not). PR ~ 1 for an
  extended mode, ~ 1/N for a mode on one grain. Needs the eigenvectors
  (``eigensolve --vectors``) and the dof map of the linear system; without
  the map each dof counts as one site (exact for one dof per grain).

Units: omega² in E*/(rho d²), weights in E* d² (force).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:
    from ..model import Modes

DEFAULT_FRACTIONS = (0.01, 0.1, 0.5)
POWER_LEVELS = (0.5, 0.9, 0.99)
DEFAULT_ZERO_THRESHOLD = 1e-10


def participation_ratio(vectors, *, dof_grain=None, dof_axis=None, dim: int | None = None) -> np.ndarray:
    """PR of every column of ``vectors`` (n_dof, n_modes); definition in the module docstring.

    With ``dof_grain`` (n_dof,) the sites are grains and only translational
    dofs (``dof_axis < dim``) enter; without it every dof is a site.
    """
    V = np.asarray(vectors, dtype=float)
    if V.ndim != 2:
        raise InputError(f"eigenvectors must be a 2D array (n_dof, n_modes), got shape {V.shape}")
    sq = V**2
    if dof_grain is not None:
        dof_grain = np.asarray(dof_grain, dtype=np.int64)
        if dof_grain.shape != (V.shape[0],):
            raise InputError(f"the dof map has {dof_grain.size} dofs, the eigenvectors {V.shape[0]}")
        keep = np.ones(V.shape[0], bool)
        if dof_axis is not None:
            if dim is None:
                raise InputError("dim is needed to tell translations from rotations")
            keep = np.asarray(dof_axis) < dim
        grains, site = np.unique(dof_grain[keep], return_inverse=True)
        per_site = np.zeros((grains.size, V.shape[1]))
        np.add.at(per_site, site, sq[keep])
        sq = per_site
    n_sites = sq.shape[0]
    num = sq.sum(axis=0) ** 2
    den = n_sites * (sq**2).sum(axis=0)
    return np.divide(num, den, out=np.full(V.shape[1], np.nan), where=den > 0)


def carried_fractions(weights, fractions=DEFAULT_FRACTIONS, levels=POWER_LEVELS) -> dict:
    """Share of Σ w² and Σ |w| carried by the strongest fractions of the modes given.

    Returns ``{"carried_power": {q: share}, "carried_abs": {q: share},
    "n_strongest": {q: count}, "modes_for_power": {level: count}}``; keys are
    the fractions/levels formatted as strings ("0.01", ...).
    """
    w = np.abs(np.asarray(weights, dtype=float))
    n = w.size
    if n == 0:
        raise InputError("no nonzero modes")
    ranked = np.sort(w)[::-1]
    power = np.cumsum(ranked**2)
    absum = np.cumsum(ranked)
    out = {"carried_power": {}, "carried_abs": {}, "n_strongest": {}, "modes_for_power": {}}
    for q in fractions:
        if not 0 < q <= 1:
            raise InputError(f"fractions must be in (0, 1], got {q}")
        k = max(1, math.ceil(q * n - 1e-9))
        key = f"{q:g}"
        out["n_strongest"][key] = k
        out["carried_power"][key] = float(power[k - 1] / power[-1]) if power[-1] > 0 else math.nan
        out["carried_abs"][key] = float(absum[k - 1] / absum[-1]) if absum[-1] > 0 else math.nan
    for level in levels:
        k = int(np.searchsorted(power, level * power[-1] * (1 - 1e-12))) + 1 if power[-1] > 0 else 0
        out["modes_for_power"][f"{level:g}"] = min(k, n)
    return out


def spectrum_summary(modes: "Modes", *, ic: str = "A", dof_grain=None, dof_axis=None,
                     fractions=DEFAULT_FRACTIONS, arrays: bool = True) -> dict:
    """Spectrum statistics of a modes object (docs/method.md §7); choices in the module docstring.

    ``dof_grain``/``dof_axis`` (from the linear system) make the participation
    ratio run over grains; ``arrays`` adds omega2, weights and PR per mode.
    """
    ic = str(ic).upper()
    if ic not in ("A", "B"):
        raise InputError(f"initial condition must be A or B, got {ic!r}")
    omega2 = np.asarray(modes.omega2, dtype=float)
    if omega2.size == 0:
        raise InputError("the modes file holds no modes")
    amp = modes.amplitude_A if ic == "A" else modes.amplitude_B
    weights = np.asarray(amp, dtype=float) * np.asarray(modes.coupling, dtype=float)
    threshold = float(modes.attrs.get("zero_mode_threshold", DEFAULT_ZERO_THRESHOLD))
    w2max = float(np.max(np.abs(omega2)))
    zero = np.abs(omega2) <= threshold * w2max
    nonzero = ~zero
    if not nonzero.any():
        raise InputError("every mode is a zero mode")
    lowest = float(omega2[nonzero].min())
    out = {
        "ic": ic,
        "n_modes": int(omega2.size),
        "n_zero_modes": int(zero.sum()),
        "n_negative_modes": int((omega2 < 0)[nonzero].sum()),
        "zero_mode_threshold": threshold,
        "lowest_nonzero_omega2": lowest,
        "lowest_nonzero_omega": math.sqrt(lowest) if lowest > 0 else math.nan,
        "highest_omega2": float(omega2.max()),
        "sum_weights": float(weights.sum()),
        "sum_abs_weights": float(np.abs(weights).sum()),
        "sum_weights_squared": float((weights**2).sum()),
        "strongest_mode": int(np.argmax(np.abs(weights))),
    }
    out["strongest_mode_omega2"] = float(omega2[out["strongest_mode"]])
    out.update(carried_fractions(weights[nonzero], fractions))
    if "n_zero_modes" in modes.attrs:
        out["n_zero_modes_eigensolve"] = int(modes.attrs["n_zero_modes"])
    if modes.vectors is not None:
        dim = modes.attrs.get("dim")
        pr = participation_ratio(modes.vectors, dof_grain=dof_grain, dof_axis=dof_axis,
                                 dim=None if dim is None else int(dim))
        if pr.size != omega2.size:
            raise InputError(f"{pr.size} eigenvectors for {omega2.size} eigenvalues")
        pr_nz = pr[nonzero]
        out.update(pr_sites="grains" if dof_grain is not None else "dofs",
                   pr_mean=float(np.nanmean(pr_nz)), pr_min=float(np.nanmin(pr_nz)),
                   pr_max=float(np.nanmax(pr_nz)),
                   most_localized_mode=int(np.flatnonzero(nonzero)[np.nanargmin(pr_nz)]))
        if arrays:
            out["participation_ratio"] = pr
    else:
        out["participation_ratio_note"] = ("needs eigenvectors: rerun `granwave eigensolve "
                                           "--vectors`")
    if arrays:
        out["omega2"] = omega2
        out["weights"] = weights
    return out
