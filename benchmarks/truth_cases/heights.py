"""heights.*: `analyze heights` (granwave.analysis.heights.height_series with its defaults: c_tof,
c_peak, c_zero between the heights nearest 8 and 25 d̄, γ and the width exponent over every
sample) on height series of synthetic signals whose front features are known at every height
(benchmarks/truth_cases/_ensembles.py, Fronts: the δ′ response of a non-dispersive column delayed
by L/c and broadened by σ ∝ L^0.75, amplitude ∝ L^−1.3, per-packing jitter of the arrival,
the width and the amplitude). The signals go through the front picks (no arrival times are
given): the truths are c_tof = (L2 − L1)/(E t₁₀(L2) − E t₁₀(L1)) from the closed forms (faster
than c: the edge runs ahead as the pulse broadens), c_zero = c, γ and the width exponent.
"""

from __future__ import annotations

from functools import lru_cache

from granwave.analysis.heights import height_series
from granwave.params import HeightsParams

from . import Case, interval
from ._ensembles import Fronts, fronts

P = HeightsParams
SETTINGS = {
    "paper": (Fronts(heights=(5.0, 8.0, 12.0, 17.0, 25.0, 35.0, 50.0, 75.0), packings=(30,) * 8),
              "paper design: 5 … 75 d̄, 30 packings per height"),
    "quick": (Fronts(heights=(5.0, 8.0, 12.0, 17.0, 25.0), packings=(2,) * 5),
              "quick config: 5 … 25 d̄, 2 packings per height"),
}


@lru_cache(maxsize=None)
def analysed(name: str, seed: int) -> dict:
    signals, _ = fronts(SETTINGS[name][0], seed)
    return height_series(signals, edge_heights=P.edge_heights, group_rtol=P.group_tolerance)


def speed_truth(design: Fronts, point: str) -> float:
    lo, hi = P.edge_heights
    return (hi - lo) / (design.mean_time(hi, point) - design.mean_time(lo, point))


def quantity(name: str, key: str):
    def run(seed):
        r = analysed(name, seed)
        if key + "_ci95" in r:
            lo, hi = r[key + "_ci95"]
            return r[key], lo, hi
        return interval(r[key], r[key + "_err"])
    return run


def cases() -> list[Case]:
    out = []
    for name, (design, words) in SETTINGS.items():
        fast = name == "paper"
        s = f"{words}; σ ∝ L^{design.width_exponent:g}, |A| ∝ L^−{design.gamma:g}, c = {design.c:g}"
        out += [Case("heights.c_tof", s + " (10 % edge, 8 → 25 d̄)", speed_truth(design, "t_lead10"),
                     quantity(name, "c_tof"), fast),
                Case("heights.c_peak", s + " (peak, 8 → 25 d̄)", speed_truth(design, "t_peak"),
                     quantity(name, "c_peak"), fast),
                Case("heights.c_zero", s + " (zero crossing, 8 → 25 d̄)", design.c,
                     quantity(name, "c_zero"), fast),
                Case("heights.gamma", s, design.gamma, quantity(name, "gamma"), fast),
                Case("heights.chi", s, design.width_exponent, quantity(name, "chi"), fast)]
    return out


CASES = cases()
