"""Shared fitting helpers: straight lines, power laws, local exponents.

All fits are ordinary least squares (``scipy.stats.linregress``); a power law
``y = a x^b`` is fitted as a straight line in log-log coordinates, so every
point carries the same *relative* weight. Uncertainties are one standard
error of the fitted parameter from the scatter of the points about the line;
with exactly two points the line passes through both and the uncertainty is
undetermined: it is reported as NaN (``null`` in JSON), never as 0.

The 95 % interval of the slope (``slope_ci95``, ``exponent_ci95``) is ± t(0.975, n − 2) standard
errors: with few points the Student factor is far above 2 (4.30 for four points), and the
report's "± 2 errors" would hold the truth in only ~82 % of the cases (docs/truth.md).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class LinearFit:
    """y = intercept + slope x, with one-standard-error uncertainties."""

    slope: float
    slope_err: float
    intercept: float
    intercept_err: float
    n: int
    slope_ci95: tuple = (math.nan, math.nan)

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class PowerLawFit:
    """y = prefactor x^exponent, fitted in log-log coordinates."""

    exponent: float
    exponent_err: float
    prefactor: float
    prefactor_err: float
    n: int
    exponent_ci95: tuple = (math.nan, math.nan)

    def as_dict(self) -> dict:
        return asdict(self)


def _clean(x, y, what: str, *, positive: bool = False) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise InputError(f"{what}: x and y differ in length ({x.size} vs {y.size})")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise InputError(f"{what}: NaN or infinite values")
    if positive and (np.any(x <= 0) or np.any(y <= 0)):
        raise InputError(f"{what}: a power-law fit needs positive values")
    if x.size < 2 or np.unique(x).size < 2:
        raise InputError(f"{what}: need at least two distinct abscissae")
    return x, y


def linear_fit(x, y, *, what: str = "linear fit") -> LinearFit:
    """Least-squares straight line through (x, y); needs two distinct x."""
    from scipy import stats  # here: importing scipy.stats costs ~0.8 CPU-s, and the sample batches
    # (which import this module through analysis.sweep) never fit
    x, y = _clean(x, y, what)
    r = stats.linregress(x, y)
    undetermined = x.size <= 2
    err = math.nan if undetermined else float(r.stderr)
    t = math.nan if undetermined else float(stats.t.ppf(0.975, x.size - 2))
    return LinearFit(
        slope=float(r.slope),
        slope_err=err,
        intercept=float(r.intercept),
        intercept_err=math.nan if undetermined else float(r.intercept_stderr),
        n=int(x.size),
        slope_ci95=(float(r.slope) - t * err, float(r.slope) + t * err),
    )


def power_law_fit(x, y, *, what: str = "power-law fit") -> PowerLawFit:
    """Fit y = a x^b by a straight line through (log x, log y); x, y > 0.

    ``prefactor_err`` is propagated from the intercept's error (a e^i δi).
    """
    x, y = _clean(x, y, what, positive=True)
    lf = linear_fit(np.log(x), np.log(y), what=what)
    a = math.exp(lf.intercept)
    return PowerLawFit(exponent=lf.slope, exponent_err=lf.slope_err, prefactor=a,
                       prefactor_err=a * lf.intercept_err, n=lf.n, exponent_ci95=lf.slope_ci95)


def inverse_slope(fit: LinearFit) -> tuple[float, float]:
    """A speed from an arrival-time-versus-distance slope: c = 1/s, δc = δs/s²."""
    s = fit.slope
    if s == 0:
        return math.inf, math.nan
    return 1.0 / s, fit.slope_err / s**2


def inverse_ci(fit: LinearFit) -> tuple[float, float]:
    """The 95 % interval of c = 1/s from the slope's: [1/s_hi, 1/s_lo] (∞ where s_lo ≤ 0)."""
    lo, hi = fit.slope_ci95
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= 0:
        return math.nan, math.nan
    return 1.0 / hi, (1.0 / lo if lo > 0 else math.inf)


def local_exponents(x, y) -> tuple[np.ndarray, np.ndarray]:
    """Effective exponents d log y / d log x between consecutive points.

    ``x`` must be strictly increasing and x, y > 0 (use |y| for signed data).
    Returns (x_mid, exponent), x_mid the geometric mean of each pair; both have
    length len(x) - 1.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if np.any(np.diff(x) <= 0):
        raise InputError("local exponents need strictly increasing abscissae")
    if np.any(x <= 0) or np.any(y <= 0):
        raise InputError("local exponents need positive values")
    lx, ly = np.log(x), np.log(y)
    return np.sqrt(x[1:] * x[:-1]), np.diff(ly) / np.diff(lx)
