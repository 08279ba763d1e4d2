"""The crossover pressure p* of a speed c(p) between two power laws (docs/method.md §10).

An asperity contact gives c ~ p^(1/4), Hertz's c ~ p^(1/6) (docs/method.md §2, "Low-pressure
laws"); a c(p) series that turns from one to the other is fitted with the two power laws meeting
at p*:

    ln c = ln c* + low (ln p - ln p*)   for p <= p*,
    ln c = ln c* + high (ln p - ln p*)  for p >  p*,

the exponents fixed (``low`` = 1/4, ``high`` = 1/6 by default), c* and p* free. The fit is
weighted least squares in ln c (weights 1/sigma^2, sigma = err / c, where every point has an
error; else equal weights and sigma estimated from the residuals). For each p* the best ln c* is
a weighted mean, so the fit is a one-dimensional profile chi^2(ln p*), minimized over the sweep's
own range of ln p (a grid of 4001 points, then Brent's method about the best): a crossover
outside the pressures measured cannot be located, and is reported as not determined.

The interval of p* is the profile likelihood's: the ln p* where chi^2 - chi^2_min <= q, q =
3.84 (95 %) and 1 (68 %) with known errors, q = s^2 t^2_{n-2} with s^2 = chi^2_min / (n - 2)
(and t the Student quantile) where the errors come from the residuals. An interval that reaches
the sweep's range is open on that side (NaN). ``log10_p_star_err``: half the 68 % interval's width
in log10 p. This is the estimator of ``pressure-sweep --crossover`` (granwave.analysis.sweep);
benchmarks/truth_cases/laws.py runs it on synthetic series of known p* (its bias, and the
coverage of its 95 % interval, in the truth suite's table).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

#: the exponents of the asperity (cone) and Hertz regimes (docs/method.md §2)
LOW, HIGH = 0.25, 1.0 / 6.0


def _profile(x, y, w, low, high):
    """chi^2(x*) and the best intercept b(x*) = ln c* of the broken line at x* = ln p* (x* a
    number or an array: then arrays)."""
    def fit(xs):
        xs = np.asarray(xs, float)
        g = xs.reshape(-1, 1)
        resid0 = y - np.where(x <= g, low, high) * (x - g)
        b = (resid0 @ w) / np.sum(w)
        r = resid0 - b[:, None]
        chi = (r * r) @ w
        return (float(chi[0]), float(b[0])) if xs.ndim == 0 else (chi, b)
    return fit


def crossover_fit(pressure, speed, speed_err=None, *, low: float = LOW, high: float = HIGH,
                  what: str = "speed against pressure") -> dict:
    """Fit p* (module docstring) to the speeds ``speed`` at ``pressure`` (both > 0; ``speed_err``
    one standard error each, or None). Returns a JSON-ready dict: ``p_star`` (E*),
    ``log10_p_star`` with ``log10_p_star_err``, ``p_star_lo95`` / ``p_star_hi95`` (NaN where the
    interval is open), ``c_star`` (the speed at p*), ``low``, ``high``, ``n``, ``chi2``, ``dof``,
    ``errors`` ("given" or "residuals") and ``note`` (empty, or why p* is not determined: then
    the numbers are NaN). InputError for fewer than 3 pressures or bad values."""
    from scipy import optimize, stats

    p = np.asarray(pressure, float).ravel()
    c = np.asarray(speed, float).ravel()
    if p.shape != c.shape:
        raise InputError(f"{what}: pressures and speeds differ in length ({p.size} vs {c.size})")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(c)) and np.all(p > 0) and np.all(c > 0)):
        raise InputError(f"{what}: the crossover fit needs positive, finite pressures and speeds")
    if np.unique(p).size < 3:
        raise InputError(f"{what}: the crossover fit needs at least 3 distinct pressures, got {np.unique(p).size}")
    if not (math.isfinite(low) and math.isfinite(high) and low != high):
        raise InputError(f"{what}: the two exponents must differ, got {low} and {high}")
    x, y = np.log(p), np.log(c)
    order = np.argsort(x)
    x, y = x[order], y[order]
    given = speed_err is not None
    if given:
        e = np.asarray(speed_err, float).ravel()[order]
        given = e.shape == c.shape and bool(np.all(np.isfinite(e)) and np.all(e > 0))
    w = (c[order] / e) ** 2 if given else np.ones_like(x)
    n = x.size
    chi2 = _profile(x, y, w, low, high)
    out = dict(low=float(low), high=float(high), n=int(n), dof=int(n - 2), errors="given" if given else "residuals")
    grid = np.linspace(x[0], x[-1], 4001)
    values = chi2(grid)[0]
    k = int(np.argmin(values))
    lo_b, hi_b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    best = optimize.minimize_scalar(lambda s: chi2(s)[0], bounds=(lo_b, hi_b), method="bounded",
                                    options=dict(xatol=1e-12 * max(1.0, abs(lo_b))))
    xs, cmin = (best.x, best.fun) if best.fun <= values[k] else (grid[k], values[k])
    edge = 1e-9 * (x[-1] - x[0])
    if xs - x[0] < edge or x[-1] - xs < edge:
        return {**out, **_nan(), "chi2": float(cmin),
                "note": "p* at the edge of the pressures measured: no crossover inside the sweep"}
    if given:
        q95, q68 = stats.chi2.ppf(0.95, 1), 1.0
    else:
        s2 = cmin / max(n - 2, 1)
        if n < 4 or not s2 > 0:
            q95 = q68 = math.nan
        else:
            q95 = s2 * stats.t.ppf(0.975, n - 2) ** 2
            q68 = s2 * stats.t.ppf(0.5 + 0.6826894921370859 / 2, n - 2) ** 2

    def bound(q, side):
        """The end of {chi2 - cmin <= q} on ``side`` (-1: below xs), NaN where it reaches the range."""
        if not math.isfinite(q):
            return math.nan
        end = x[0] if side < 0 else x[-1]
        if chi2(end)[0] - cmin <= q:
            return math.nan
        # the first grid point out from xs past q, then brentq between it and its neighbour inwards
        mask = (grid < xs) if side < 0 else (grid > xs)
        pts, vals = grid[mask], values[mask]
        if side < 0:
            pts, vals = pts[::-1], vals[::-1]
        past = np.flatnonzero(vals - cmin > q)
        if past.size == 0:
            return math.nan
        j = int(past[0])
        inner = xs if j == 0 else pts[j - 1]
        return optimize.brentq(lambda s: chi2(s)[0] - cmin - q, min(inner, pts[j]), max(inner, pts[j]), xtol=1e-13)

    lo95, hi95 = bound(q95, -1), bound(q95, 1)
    lo68, hi68 = bound(q68, -1), bound(q68, 1)
    ln10 = math.log(10.0)
    half = 0.5 * (hi68 - lo68) / ln10 if math.isfinite(lo68) and math.isfinite(hi68) else math.nan
    return {**out, "p_star": math.exp(xs), "log10_p_star": xs / ln10, "log10_p_star_err": half,
            "p_star_lo95": math.exp(lo95) if math.isfinite(lo95) else math.nan,
            "p_star_hi95": math.exp(hi95) if math.isfinite(hi95) else math.nan,
            "c_star": math.exp(chi2(xs)[1]), "chi2": float(cmin), "note": ""}


def _nan() -> dict:
    return {k: math.nan for k in ("p_star", "log10_p_star", "log10_p_star_err", "p_star_lo95", "p_star_hi95",
                                  "c_star")}


def synthetic_series(p_star: float, *, pressures, noise: float, seed: int, low: float = LOW,
                     high: float = HIGH, c_star: float = 0.05):
    """A c(p) series of known crossover (the truth cases and tests): the two power laws meeting at
    ``p_star`` (c* = ``c_star``), each speed times exp(noise x a standard normal) (seeded);
    returns (pressures, speeds, errors = noise x speeds)."""
    p = np.asarray(pressures, float)
    rng = np.random.default_rng(int(seed))
    x = np.log(p / p_star)
    c = c_star * np.exp(np.where(x <= 0.0, low, high) * x) * np.exp(noise * rng.standard_normal(p.size))
    return p, c, noise * c
