"""The front inside the column: arrival per height bin, front speed and width (docs/shocks.md).

The DEM pulse stores the pulse field (granwave.dem.pulse): per height bin b (centre z_b), the
mean velocity v_b(t) of its grains along the kick, at every output sample. From it:

- **arrival** t_b, by one of two picks on the bin's own signal, scaled by its largest value
  v_max,b over the record:
  ``peak`` (a pulse: impulse kick, solitary wave): the first local maximum of v_b after it first
  reaches ``level`` × v_max,b, placed between samples by the parabola through the three samples
  around it; ``crossing`` (a step: the piston's shock): the first time v_b reaches ``level`` ×
  v_max,b, by linear interpolation between the two samples around it. NaN where the bin holds
  no grain or its velocity never becomes positive.
- **front speed** V: the least-squares line t_b = t_0 + z_b / V through the bins whose centre
  lies in ``fit`` (fractions of the column's height: the source's formation length and the top
  wall's reflection left out), V = 1 / slope, with its standard error from the fit's residuals
  (error of the slope / slope², the residuals taken as independent: arrival scatter from bin to
  bin; docs/truth.md records its coverage).
- **width** (``peak`` only): the full width at half maximum of the bin's first peak in time,
  times V, median over the fitted bins (d): the pulse's length along the column.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .front import _crossing, _parabola_vertex

PICKS = ("peak", "crossing")
#: Default threshold of the picks, a fraction of the bin's largest velocity.
DEFAULT_LEVEL = 0.5
#: Default range of the speed fit, fractions of the column's height.
DEFAULT_FIT = (0.2, 0.8)


def _first_over(v: np.ndarray, level: float) -> int:
    """Index of the first sample with v >= level (-1 if none)."""
    over = np.flatnonzero(v >= level)
    return int(over[0]) if over.size else -1


def arrival_time(time: np.ndarray, v: np.ndarray, *, pick: str = "peak", level: float = DEFAULT_LEVEL) -> float:
    """The arrival of one bin's velocity signal ``v`` sampled at ``time`` (module docstring)."""
    vmax = float(np.max(v)) if v.size else 0.0
    if not vmax > 0.0:
        return math.nan
    i = _first_over(v, level * vmax)
    if pick == "crossing":
        if i <= 0:
            return float(time[max(i, 0)])
        return _crossing(time, v, i, level * vmax)
    n = v.size
    while i + 1 < n and v[i + 1] > v[i]:
        i += 1
    if i == 0 or i + 1 >= n:
        return float(time[i])
    # the first peak refined as the compressional front's peak pick refines its own
    return _parabola_vertex(np.asarray(time[i - 1:i + 2], float), np.asarray(v[i - 1:i + 2], float))[0]


def peak_width(time: np.ndarray, v: np.ndarray, *, level: float = DEFAULT_LEVEL) -> float:
    """Full width at half maximum (in time) of the first peak of ``v`` (the ``peak`` pick's);
    NaN where it does not fall to half on both sides within the record."""
    vmax = float(np.max(v)) if v.size else 0.0
    if not vmax > 0.0:
        return math.nan
    i = _first_over(v, level * vmax)
    while i + 1 < v.size and v[i + 1] > v[i]:
        i += 1
    half = 0.5 * float(v[i])
    lo = i
    while lo > 0 and v[lo - 1] > half:
        lo -= 1
    hi = i
    while hi + 1 < v.size and v[hi + 1] > half:
        hi += 1
    if lo == 0 or hi + 1 >= v.size:
        return math.nan
    h = float(time[1] - time[0])
    t_lo = time[lo - 1] + h * (half - v[lo - 1]) / (v[lo] - v[lo - 1])
    t_hi = time[hi] + h * (v[hi] - half) / (v[hi] - v[hi + 1])
    return float(t_hi - t_lo)


def front_speed(height: np.ndarray, arrival: np.ndarray, *, fit=DEFAULT_FIT, column: float | None = None) -> dict:
    """The least-squares front speed through the bins of ``fit`` (module docstring): a dict of
    speed, speed_error, n_bins, t0 and fit_range (d)."""
    height = np.asarray(height, float)
    arrival = np.asarray(arrival, float)
    top = float(column) if column is not None else float(height[-1] + 0.5 * (height[-1] - height[-2])
                                                          if height.size > 1 else 2.0 * height[-1])
    lo, hi = fit
    if not 0.0 <= lo < hi <= 1.0:
        raise InputError(f"the fit range must be two fractions 0 <= lo < hi <= 1 (got {fit})")
    use = (height >= lo * top) & (height <= hi * top) & np.isfinite(arrival)
    out = dict(speed=math.nan, speed_error=math.nan, n_bins=int(np.count_nonzero(use)), t0=math.nan,
               fit_range=(lo * top, hi * top))
    if out["n_bins"] < 3:
        return out
    z, t = height[use], arrival[use]
    zc = z - z.mean()
    sxx = float(np.sum(zc * zc))
    slope = float(np.sum(zc * (t - t.mean())) / sxx)
    if not slope > 0.0:
        return out
    resid = t - t.mean() - slope * zc
    se = math.sqrt(float(np.sum(resid**2)) / (z.size - 2) / sxx)
    out.update(speed=1.0 / slope, speed_error=se / slope**2, t0=float(t.mean() - slope * z.mean()))
    return out


def front_picks(time: np.ndarray, height: np.ndarray, velocity: np.ndarray, *, pick: str = "peak",
                level: float = DEFAULT_LEVEL, fit=DEFAULT_FIT, column: float | None = None) -> dict:
    """Arrival per bin, front speed (and error) and, for ``peak``, the width (module docstring).
    ``velocity``: (B, T) the pulse field; ``column``: the column's height (default: the bins')."""
    if pick not in PICKS:
        raise InputError(f"pick must be one of {', '.join(PICKS)} (got {pick!r})")
    if not 0.0 < level < 1.0:
        raise InputError(f"level must be in (0, 1) (got {level})")
    time = np.asarray(time, float)
    velocity = np.asarray(velocity, float)
    arrival = np.array([arrival_time(time, v, pick=pick, level=level) for v in velocity])
    fitted = front_speed(height, arrival, fit=fit, column=column)
    width = math.nan
    if pick == "peak" and math.isfinite(fitted["speed"]):
        lo, hi = fitted["fit_range"]
        rows = [k for k, z in enumerate(height) if lo <= z <= hi]
        widths = np.array([peak_width(time, velocity[k], level=level) for k in rows])
        widths = widths[np.isfinite(widths)]
        if widths.size:
            width = float(np.median(widths)) * fitted["speed"]
    return dict(pick=pick, level=float(level), arrival=arrival, speed=fitted["speed"],
                speed_error=fitted["speed_error"], n_bins=fitted["n_bins"], t0=fitted["t0"],
                fit_range=np.array(fitted["fit_range"]), width=width)
