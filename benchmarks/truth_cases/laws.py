"""Truth cases of the low-pressure laws' estimator: the crossover pressure p* that
``granwave pressure-sweep --crossover`` fits to a c(p) series (granwave.analysis.crossover),
run through the very function and defaults the command and the report use
(granwave.analysis.sweep.pressure_sweep with crossover = the defaults of SweepParams), on
synthetic series of known p*: the two power laws c ~ p^(1/4) and p^(1/6) meeting at p*, each
speed with a log-normal error of known size, given to the fit as the height series' c_tof_err.
"""

from __future__ import annotations

import math

import numpy as np

from benchmarks.truth_cases import Case

#: the laws scene's pressures (config/laws.yaml): 1e-8 ... 1e-3, two per decade
PRESSURES = tuple(float(p) for p in np.logspace(-8, -3, 11))


def _estimate(p_star: float, noise: float, seed: int) -> tuple[float, float, float]:
    """(p*, lo95, hi95) of pressure-sweep --crossover on a synthetic c_tof(p) series: an interval
    open on one side (it reaches the sweep's range) as an infinite end; p* not located (the fit's
    note) as NaN throughout, a miss (the truth lies inside the sweep)."""
    from granwave.analysis.crossover import synthetic_series
    from granwave.analysis.sweep import pressure_sweep
    from granwave.params import SweepParams

    p, c, e = synthetic_series(p_star, pressures=PRESSURES, noise=noise, seed=seed)
    series = [{"pressure": float(a), "c_tof": float(b), "c_tof_err": float(s), "per_height": []}
              for a, b, s in zip(p, c, e)]
    d = SweepParams()
    fit = pressure_sweep([], height_series=series, crossover=(d.crossover_low, d.crossover_high))["crossover_tof"]
    if fit["note"]:
        return math.nan, math.nan, math.nan
    lo, hi = fit["p_star_lo95"], fit["p_star_hi95"]
    return fit["p_star"], (lo if math.isfinite(lo) else 0.0), (hi if math.isfinite(hi) else math.inf)


def _case(p_star: float, noise: float, fast: bool) -> Case:
    return Case(key="sweep.p_star",
                setting=f"c_tof ~ p^(1/4) | p^(1/6) meeting at p* = {p_star:g}, {len(PRESSURES)} pressures "
                        f"1e-8 ... 1e-3, {noise:.0%} log-normal error per speed (given)",
                truth=p_star, run=lambda seed: _estimate(p_star, noise, seed), fast=fast)


CASES = [
    _case(1.2e-5, 0.01, True),   # the crossover law's p* at its default n* = 1e-3 (lattice), 1 % errors
    _case(1.2e-5, 0.03, False),  # noisier speeds, as a few disordered packings per pressure give
    _case(3e-7, 0.01, False),    # a crossover near the low end of the sweep
]
