"""The truth suite's cases: every estimator granwave quotes, run through the functions and
defaults the scenes use on inputs with a known answer (docs/truth.md).

Each topic module of this package (``front.py``, ``heights.py``, ...; a name starting with
``_`` is a helper, not a topic) exposes ``CASES: list[Case]``; ``python benchmarks/truth.py``
collects them, runs each over many seeds and reports, per estimator key and setting, the bias
and the coverage of the quoted 95 % interval.

A case's ``run(seed)`` returns ``(estimate, lo95, hi95)``: the estimator's value on the
seed's input, and the 95 % interval the output quotes (None, None where it quotes none on that
input, e.g. a frequency outside the band; NaN bounds where it quotes an estimate without its
interval, a miss; an infinite end where it quotes a one-sided bound; a NaN estimate where it
quotes only a bound). Where an output quotes its own 95 % interval (``*_ci95``,
``*_ci``), that interval is checked; where it quotes one standard error only, the interval
checked is value ± 2 errors (:func:`interval`), which is how the report reads an error
(``granwave.report.numbers.interval95``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

#: The interval a case returns: (estimate, lo95, hi95).
Result = tuple[float, "float | None", "float | None"]


@dataclass
class Case:
    """One estimator on one kind of input with a known answer.

    ``key``: "<topic>.<quantity>" (e.g. "front.t_lead10"); ``setting``: the input in words
    (shape, response, sizes); ``truth``: the exact answer; ``run``: seed -> (estimate, lo95,
    hi95); ``fast``: in the quick subset the tests run; ``tolerance``: the allowed |relative
    bias| where no interval is quoted.
    """

    key: str
    setting: str
    truth: float
    run: Callable[[int], tuple[float, float | None, float | None]]
    fast: bool = False
    tolerance: float | None = None


def edge_x(level: float) -> float:
    """x > 1 with x e^{(1 − x²)/2} = level: where g′ (g a Gaussian of width σ) reaches ``level``
    of its peak on its leading side, in σ ahead of its centre."""
    from scipy import optimize

    return float(optimize.brentq(lambda x: x * math.exp(0.5 * (1 - x * x)) - level, 1.0, 10.0))


def t95(dof: float) -> float:
    """The two-sided 95 % Student-t factor t(0.975, dof); 1.96 for dof = inf or None."""
    if dof is None or not math.isfinite(dof):
        return 1.959963984540054
    if dof < 1:
        return math.nan
    from scipy import stats

    return float(stats.t.ppf(0.975, dof))


def interval(value, error, factor: float = 2.0) -> tuple[float, float | None, float | None]:
    """(value, value − factor·error, value + factor·error): the report's 95 % reading of a
    standard error (factor 2); NaN bounds where the error is unknown (an estimate without an
    interval on this seed: a miss)."""
    v = _float(value)
    e = _float(error)
    if not (math.isfinite(v) and math.isfinite(e)):
        return v, math.nan, math.nan
    return v, v - factor * e, v + factor * e


def at(omega, values, w: float) -> float:
    """``values`` (one per frequency of ``omega``) interpolated linearly at ``w``; NaN outside."""
    import numpy as np

    om = np.asarray(omega, float)
    v = np.asarray(values, float)
    if not om[0] <= w <= om[-1]:
        return math.nan
    return float(np.interp(w, om, v))


def _float(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan
