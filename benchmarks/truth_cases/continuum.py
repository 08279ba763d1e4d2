"""continuum.* of the front against distance: `analyze continuum` (granwave.analysis.continuum.
continuum with its defaults: tolerance 5 %, bootstrap 200, each packing's own c_ℓ) on synthetic
columns whose 10 % edge approaches c_ℓ by a known law (benchmarks/truth_cases/_ensembles.py, Fronts
with the mean edge time built height by height so that the local speed between consecutive
heights is exactly c_ℓ (1 + a L_mid^−β), L_mid their geometric mean: a = 2.7, β = 0.71, the
fit of continuum2d_p4). The signals go through the front picks; the truths are β, r∞ = 1 (the
free-limit fit), L* = (a / 0.05)^{1/β} and the local c_tof/c_ℓ at the tallest pair.
(λ* and L_λ of the frequency analysis: benchmarks/truth_cases/attenuation.py.)
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from granwave.analysis.continuum import continuum
from granwave.params import ContinuumParams

from . import Case
from ._ensembles import Fronts, fronts

P = ContinuumParams
A, BETA = 2.7, 0.71


def approach_edges(heights, c_l: float, t_first: float):
    """The mean 10 % edge times at ``heights`` whose local speeds are c_ℓ (1 + A L_mid^−β)."""
    h = np.asarray(heights, float)
    t = [t_first]
    for lo, hi in zip(h[:-1], h[1:]):
        mid = math.sqrt(lo * hi)
        t.append(t[-1] + (hi - lo) / (c_l * (1.0 + A * mid ** (-BETA))))
    table = dict(zip(h.tolist(), t))
    return lambda L: table[float(L)]


HEIGHTS = (8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0)
PACKINGS = (30, 30, 30, 10, 10, 10, 10)
DESIGN = Fronts(heights=HEIGHTS, packings=PACKINGS, width_exponent=0.6, gamma=1.0,
                edge=approach_edges(HEIGHTS, 0.19, 25.0), crossings=5.0)
WORDS = ("2D scene design (8 … 512 d̄, 30/10 packings), local c_tof/c_ℓ = 1 + 2.7 L^−0.71, "
         "σ ∝ L^0.6, jitter 0.1 L, c_ℓ scatter 0.6 %")


@lru_cache(maxsize=None)
def analysed(seed: int) -> dict:
    signals, c_l = fronts(DESIGN, seed)
    r = continuum(signals, c_l, tolerance=P.tolerance, group_rtol=P.group_tolerance,
                  bootstrap=P.bootstrap, seed=seed, candidates=False)
    return {"approach": r["approach"], "local": {k: np.asarray(v) for k, v in r["local"].items()}}


def l_star_fit(seed):
    app = analysed(seed)["approach"]
    lo, hi = app.get("L_star_ci", (math.nan, math.nan))
    return app.get("L_star", math.nan), lo, hi


def l_star_boot(seed):
    app = analysed(seed)["approach"]
    lo, hi = app.get("L_star_boot_ci", (math.nan, math.nan))
    return app.get("L_star", math.nan), lo, hi


def beta(seed):
    app = analysed(seed)["approach"]
    lo, hi = app.get("beta_ci", (math.nan, math.nan))
    return app.get("beta", math.nan), lo, hi


def r_inf(seed):
    free = analysed(seed)["approach"].get("free_limit") or {}
    lo, hi = free.get("r_inf_ci", (math.nan, math.nan))
    return free.get("r_inf", math.nan), lo, hi


def ratio_tallest(seed):
    loc = analysed(seed)["local"]
    r, e = float(loc["ratio"][-1]), float(loc["ratio_err"][-1])
    return r, r - 2 * e, r + 2 * e


def peak_ratio_tallest(seed):
    """The peak's local speed over c_ℓ at the tallest pair, errors propagated as for c_tof/c_ℓ."""
    loc = analysed(seed)["local"]
    c, ce = float(loc["c_peak"][-1]), float(loc["c_peak_err"][-1])
    cl, cle = float(loc["c_l"][-1]), float(loc["c_l_err"][-1])
    r = c / cl
    e = abs(r) * math.hypot(ce / c, cle / cl)
    return r, r - 2 * e, r + 2 * e


def _peak_truth() -> float:
    lo, hi = HEIGHTS[-2], HEIGHTS[-1]
    return (hi - lo) / (DESIGN.mean_time(hi, "t_peak") - DESIGN.mean_time(lo, "t_peak")) / DESIGN.c


MID = math.sqrt(HEIGHTS[-1] * HEIGHTS[-2])
CASES = [
    Case("continuum.L_star", WORDS + "; 95 % interval: the fit's covariance",
         (A / P.tolerance) ** (1 / BETA), l_star_fit, fast=True),
    Case("continuum.L_star", WORDS + "; 95 % interval: the bootstrap through the chain",
         (A / P.tolerance) ** (1 / BETA), l_star_boot, fast=True),
    Case("continuum.beta", WORDS, BETA, beta, fast=True),
    Case("continuum.r_inf", WORDS + " (limit free)", 1.0, r_inf, fast=True),
    Case("continuum.ratio", WORDS + f"; local c_tof/c_ℓ at the tallest pair (L = {MID:.0f} d̄)",
         1.0 + A * MID ** (-BETA), ratio_tallest, fast=True),
    Case("continuum.ratio", WORDS + f"; local c_peak/c_ℓ at the tallest pair (L = {MID:.0f} d̄)",
         _peak_truth(), peak_ratio_tallest),
]
