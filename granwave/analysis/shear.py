"""Arrival picks of a shear signal, as a bender-element experiment makes them (docs/shear.md).

The kick of ``propagate`` is an impulse (initial condition A: the wall moved for an
infinitesimal time), so its signal F_A(t) is the impulse response of the path from the
bottom wall's displacement to the top wall's force. The signal a finite wall motion w(t)
(a bender element's tip) would give is the convolution

    F_w(t) = ∫ F_A(t − τ) w(τ) dτ        (:func:`received`, on the signal's own grid).

The rule (also in docs/shear.md and ``granwave analyze front --help``)
---------------------------------------------------------------------
Source pulses w(t) (:func:`source_pulse`), frequency f (1 / time unit):
``sine`` one period sin(2π f t) on [0, 1/f] (the bender-element standard; its spectrum
falls as 1/ω² only), ``ricker`` (1 − 2u²) exp(−u²), u = π f (t − 1.5/f) (no energy
above ~3 f: no grain-scale branch is excited).

Every travel time is a pick on the received F_w minus the same pick on the **matched
template** s(t), the shape F_w would have in a non-dispersive column: the wall-force detector
responds to the top wall's strain, so the impulse response from the bottom wall's
displacement is F_A = 2Z δ′(t − L/c) (docs/method.md §8, compression first) and
s = w′ (``response="derivative"``, the default); ``response="delay"`` (a pure-delay path,
F_A = δ(t − L/c)) takes s = w. On such a column every pick below gives L/c exactly.

* ``cross_correlation``: the lag τ of the global extremum of |Σ F_w(t) s(t − τ)| over
  0 ≤ τ ≤ 2 L/c_t (past the direct arrival of any speed above c_t/2, before the first echo at
  three times the delay; without ``c_t`` twice the received first pulse's peak time, the
  first-pulse rule of docs/front.md), refined by a parabola; the
  **polarity** is that extremum's sign (never a side lobe's);
* the template's **main lobe**: its first lobe (run of one sign) with at least
  ``MAIN_LOBE_FRACTION`` of the largest lobe's area (w′ of a Ricker: the first of its two equal
  lobes; of a sine: its middle half period; w of a Ricker: its centre), at the lobe's peak t_m;
  the received main lobe: the largest (polarity × sign) × F_w within a quarter period of
  τ + t_m;
* ``peak_to_peak``: the received main lobe's peak minus t_m (parabola vertices);
* ``edge10``: the last 10 % crossing before each main lobe's peak (received minus template);
* ``first_deflection``: the first time |F| reaches ``deflection_fraction`` (default 0.02) of its
  main lobe's height (received minus template);
* ``phase``: the phase velocity of the band [``band`` × f]: the transfer function
  H(ω) = FT[F_A] on a window ending at twice the cross-correlation arrival (before the
  first reflection, which comes at three times it; a cosine taper over the last quarter),
  zero-padded 8x, over the template's transfer function (iω for ``derivative``: its π/2 is
  not a delay; 1 for ``delay``), phase unwrapped from the lowest frequency (the static sign
  removed), T(ω) = −φ/ω, c(ω) = L/T(ω) averaged over the band;
* ``impulse_peak`` / ``impulse_edge10``: the first peak and 10 % edge of F_A itself (the
  compressional kick's picks, docs/method.md §9); the kick is at t = 0.

Speeds are L/T with L the wall-to-wall distance (``height``); ratios are to c_t, the
packing's own shear speed from its global moduli (2D sqrt(C33/Φ3*), 3D
sqrt(((C44 + C55)/2)/Φ3*); ``granwave analyze moduli``). A pick that cannot be made
(no complete first pulse, an empty band) is NaN with its reason in ``errors``.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..errors import InputError
from .front import _crossing, _parabola_vertex, front_features

PULSES = ("sine", "ricker")
PICKS = ("first_deflection", "edge10", "peak_to_peak", "cross_correlation", "phase", "impulse_edge10",
         "impulse_peak")
DEFAULT_DEFLECTION_FRACTION = 0.02
DEFAULT_BAND = (0.5, 1.5)
RESPONSES = ("derivative", "delay")
DEFAULT_RESPONSE = "derivative"
#: A template lobe with at least this fraction of the largest lobe's area is a main-lobe candidate
#: (the first wins).
MAIN_LOBE_FRACTION = 0.9


#: a pulse's duration in periods 1/f: the sine's one period; the Ricker wavelet centred at
#: 1.5/f, where it has decayed to e^-(1.5 pi)^2 ~ 2e-10 at 0 and 3/f
PULSE_PERIODS = {"sine": 1.0, "ricker": 3.0}


def source_pulse(times, frequency: float, shape: str = "sine") -> np.ndarray:
    """The wall displacement w(t) of a source pulse of ``frequency`` (module docstring)."""
    if not (frequency > 0 and math.isfinite(frequency)):
        raise InputError(f"pulse frequency must be positive (got {frequency})")
    t = np.asarray(times, float)
    if shape == "sine":
        return np.where((t >= 0) & (t <= 1.0 / frequency), np.sin(2 * np.pi * frequency * t), 0.0)
    if shape == "ricker":
        u = np.pi * frequency * (t - 1.5 / frequency)
        return (1.0 - 2.0 * u * u) * np.exp(-u * u)
    raise InputError(f"pulse must be one of {', '.join(PULSES)} (got {shape!r})")


def _uniform_step(time) -> float:
    t = np.asarray(time, float)
    dt = np.diff(t)
    if t.size < 3 or abs(t[0]) > 1e-12 * max(1.0, abs(t[-1])) or np.ptp(dt) > 1e-6 * dt.mean():
        raise InputError("the shear picks need a signal sampled uniformly from t = 0 (a propagate output)")
    return float(dt.mean())


def received(time, force, pulse) -> np.ndarray:
    """F_w = F_A * w on the signal's grid (the first len(time) samples of the discrete
    convolution times the step)."""
    dt = _uniform_step(time)
    f = np.asarray(force, float)
    w = np.asarray(pulse, float)
    n = len(f)
    size = 1 << int(math.ceil(math.log2(2 * n)))
    out = np.fft.irfft(np.fft.rfft(f, size) * np.fft.rfft(w, size), size)[:n]
    return out * dt


def template(times, frequency: float, shape: str = "sine", response: str = DEFAULT_RESPONSE) -> np.ndarray:
    """The expected received shape of a source pulse w(t) (module docstring): w′(t) (in units
    of 1/time) for ``response`` "derivative", the wall-force detector's (docs/method.md §8:
    F_A = 2Z δ′(t − L/c)), w(t) itself for "delay" (a pure-delay response F_A = δ(t − L/c))."""
    if response not in RESPONSES:
        raise InputError(f"response must be one of {', '.join(RESPONSES)} (got {response!r})")
    if response == "delay":
        return source_pulse(times, frequency, shape)
    source_pulse(np.zeros(1), frequency, shape)  # validates frequency and shape
    t = np.asarray(times, float)
    if shape == "sine":
        return np.where((t >= 0) & (t <= 1.0 / frequency),
                        2 * np.pi * frequency * np.cos(2 * np.pi * frequency * t), 0.0)
    u = np.pi * frequency * (t - 1.5 / frequency)
    return np.pi * frequency * (4.0 * u ** 3 - 6.0 * u) * np.exp(-u * u)


def _main_lobe(t, s) -> tuple[float, int]:
    """(time, sign) of the template's main lobe: the first lobe (a run of one sign) whose area
    reaches MAIN_LOBE_FRACTION of the largest lobe's (the first of two equal lobes, never a side
    lobe nor a sine's quarter-period end lobe), at the peak of |s| within it."""
    sg = np.sign(s)
    nz = np.flatnonzero(sg != 0)
    if nz.size == 0:
        raise InputError("the source template is zero")
    cuts = np.flatnonzero(np.diff(sg[nz]) != 0) + 1
    lobes = np.split(nz, cuts)
    areas = np.array([abs(float(s[idx].sum())) for idx in lobes])
    idx = lobes[int(np.argmax(areas >= MAIN_LOBE_FRACTION * areas.max()))]
    sign = 1 if s[idx[0]] > 0 else -1
    k = int(idx[np.argmax(sign * s[idx])])
    if 0 < k < len(s) - 1:
        tv, _ = _parabola_vertex(t[k - 1:k + 2], sign * s[k - 1:k + 2])
        return tv, sign
    return float(t[k]), sign


def _lobe(t, y, sign, t_guess, half_width) -> tuple[float, float, int]:
    """(time, height, index) of the largest ``sign`` × y within ``half_width`` of ``t_guess``."""
    dt = t[1] - t[0]
    lo = max(0, int(math.floor((t_guess - half_width - t[0]) / dt)))
    hi = min(len(t), int(math.ceil((t_guess + half_width - t[0]) / dt)) + 1)
    if hi - lo < 3:
        raise InputError("the received main lobe lies outside the record")
    z = sign * y[lo:hi]
    k = lo + int(np.argmax(z))
    if not sign * y[k] > 0:
        raise InputError("the received signal has no lobe of the template's main-lobe sign there")
    if 0 < k < len(t) - 1:
        tv, yv = _parabola_vertex(t[k - 1:k + 2], sign * y[k - 1:k + 2])
        return tv, yv, k
    return float(t[k]), float(sign * y[k]), k


def _edge(t, y, sign, k, level) -> float:
    """Last time before sample ``k`` (the lobe's peak) where ``sign`` × y rises through ``level``."""
    z = sign * y
    j = k
    while j > 0 and z[j - 1] >= level:
        j -= 1
    if j == 0:
        raise InputError("the lobe has no leading edge in the record")
    return _crossing(t, z, j, level)


def _first_deflection(t, y, level) -> float:
    """First time |y| reaches ``level``."""
    a = np.abs(y)
    k = int(np.argmax(a >= level))
    if a[k] < level:
        raise InputError("the signal never reaches the deflection level")
    if k == 0:
        return float(t[0])
    return _crossing(t, a, k, level)


def _correlation(y, s, n_lags) -> np.ndarray:
    """C(τ_k) = Σ y(t) s(t − τ_k) for k = 0 .. n_lags − 1."""
    n = len(y)
    size = 1 << int(math.ceil(math.log2(2 * n)))
    return np.fft.irfft(np.fft.rfft(y, size) * np.conj(np.fft.rfft(s, size)), size)[:max(3, min(n, n_lags))]


def _xcorr_lag(t, y, s, t_last) -> tuple[float, int]:
    """(lag, polarity) of the correlation's global extremum over lags 0 .. ``t_last`` (before the
    first echo): polarity = its sign, the lag refined by a parabola."""
    dt = t[1] - t[0]
    xc = _correlation(y, s, int(t_last / dt) + 1)
    k = int(np.argmax(np.abs(xc)))
    polarity = 1 if xc[k] > 0 else -1
    xc = polarity * xc
    if 0 < k < len(xc) - 1:
        tv, _ = _parabola_vertex(t[k - 1:k + 2], xc[k - 1:k + 2])
        return float(tv), polarity
    return float(k * dt), polarity


def _phase_speed(t, f, height, t_arrival, frequency, band, response) -> tuple[float, float]:
    """(mean phase speed over the band, its std over the band's frequencies)."""
    dt = t[1] - t[0]
    t_end = 2.0 * t_arrival
    if t_end > t[-1] + 1e-9 * t[-1]:
        raise InputError(f"the phase pick needs the record up to twice the arrival ({t_end:.4g}; "
                         f"record ends at {t[-1]:.4g})")
    n = int(round(t_end / dt)) + 1
    win = np.ones(n)
    m = n // 4
    win[n - m:] = 0.5 * (1 + np.cos(np.pi * np.arange(1, m + 1) / m))
    y = f[:n] * win
    size = 8 * (1 << int(math.ceil(math.log2(n))))
    H = np.fft.rfft(y, size)
    omega = 2 * np.pi * np.fft.rfftfreq(size, dt)
    # the phase of H over the template's transfer function (iω for the derivative response:
    # its +π/2 is not a delay), unwrapped from the first positive frequency
    phi = np.unwrap(np.angle(H[1:])) - (0.5 * np.pi if response == "derivative" else 0.0)
    phi -= np.pi * np.round(phi[0] / np.pi)  # the static response's sign (0 or pi)
    omega = omega[1:]
    lo, hi = band[0] * frequency * 2 * np.pi, band[1] * frequency * 2 * np.pi
    sel = (omega >= lo) & (omega <= hi)
    if not np.any(sel):
        raise InputError("no frequency of the record lies in the band")
    delay = -phi[sel] / omega[sel]
    c = height / delay
    return float(np.mean(c)), float(np.std(c))


def shear_picks(time, force, *, height: float, frequency: float, pulse: str = "sine",
                c_t: float | None = None, deflection_fraction: float = DEFAULT_DEFLECTION_FRACTION,
                band: Sequence[float] = DEFAULT_BAND, response: str = DEFAULT_RESPONSE) -> dict:
    """Travel times, speeds and (with ``c_t``) speed ratios of every pick (module docstring).

    ``time``, ``force``: an impulse signal (propagate, IC A) on a uniform grid from 0;
    ``height``: source-detector distance L (d); ``frequency``: the source pulse's (1/time);
    ``response``: the path's expected impulse response, "derivative" (the wall-force
    detector's δ′, the default) or "delay" (δ), which sets the matched template.
    Returns {"picks": {name: {"time", "speed", "ratio"}}, "errors": {name: reason}, ...}.
    """
    t = np.asarray(time, float)
    f = np.asarray(force, float)
    dt = _uniform_step(t)
    if not (height > 0):
        raise InputError(f"height must be positive (got {height})")
    if not (0 < deflection_fraction < 1):
        raise InputError(f"deflection fraction must be in (0, 1) (got {deflection_fraction})")
    if not (0 < band[0] < band[1]):
        raise InputError(f"band must be two increasing positive multiples of the frequency (got {band})")
    if not (frequency > 0 and math.isfinite(frequency)):
        raise InputError(f"pulse frequency must be positive (got {frequency})")
    nyquist = 0.5 / dt
    if frequency > nyquist:  # the sampled pulse would be aliased, or no sample at all
        raise InputError(f"pulse frequency {frequency:.4g} is above the record's Nyquist frequency "
                         f"1/(2 dt) = {nyquist:.4g}: lower --frequency (a longer --wavelength), or "
                         "propagate with more --samples")
    duration = PULSE_PERIODS.get(pulse, 1.0) / frequency
    if duration > t[-1]:
        raise InputError(f"the {pulse} pulse lasts {duration:.4g} ({PULSE_PERIODS.get(pulse, 1.0):g}/f at "
                         f"f = {frequency:.4g}), longer than the record ({t[-1]:.4g}): raise --frequency "
                         "(a shorter --wavelength), or propagate with a longer --t-max")
    w = source_pulse(t, frequency, pulse)
    s = template(t, frequency, pulse, response)
    y = received(t, f, w)
    # the template's own points on a grid padded before t = 0 (a sine's w′ jumps at t = 0)
    pad = int(math.ceil(1.0 / (frequency * dt))) + 2
    tp = (np.arange(-pad, len(t))) * dt
    sp = template(tp, frequency, pulse, response)
    t_main, sign_main = _main_lobe(tp, sp)
    k_main = int(round((t_main - tp[0]) / dt))
    amp_s = abs(float(sp[k_main]))
    quarter = 0.25 / frequency
    times: dict[str, float] = {}
    errors: dict[str, str] = {}

    def attempt(name, fn):
        try:
            times[name] = float(fn())
        except InputError as exc:
            times[name] = math.nan
            errors[name] = str(exc)

    state: dict = {}

    def xc():
        # the lag window: twice the expected delay L/c_t (past the direct arrival of any speed
        # above c_t/2, before the first echo at three times it); without c_t, twice the
        # received first pulse's peak time (docs/front.md's rule), else the whole record
        if not np.abs(y).max() > 0:
            raise InputError("the received signal is zero")
        if c_t and math.isfinite(c_t) and c_t > 0:
            t_last = 2.0 * height / c_t
        else:
            try:
                t_last = 2.0 * front_features(t, y).t_peak
            except InputError:
                t_last = t[-1]
        lag, pol = _xcorr_lag(t, y, s, t_last)
        state["polarity"] = pol
        return lag

    attempt("cross_correlation", xc)

    def lobe():
        if "lobe" not in state:
            if "polarity" not in state:
                raise InputError("the main lobe is found from the cross-correlation arrival, which failed")
            sign = state["polarity"] * sign_main
            state["lobe"] = (sign, *_lobe(t, y, sign, times["cross_correlation"] + t_main, quarter))
        return state["lobe"]

    def peak():
        _, tv, _, _ = lobe()
        return tv - t_main

    def edge():
        sign, _, height_y, k = lobe()
        return _edge(t, y, sign, k, 0.1 * height_y) - _edge(tp, sp, sign_main, k_main, 0.1 * amp_s)

    def deflection():
        _, _, height_y, _ = lobe()
        return (_first_deflection(t, y, deflection_fraction * height_y)
                - _first_deflection(tp, sp, deflection_fraction * amp_s))

    attempt("first_deflection", deflection)
    attempt("edge10", edge)
    attempt("peak_to_peak", peak)
    phase_std = math.nan

    def phase():
        nonlocal phase_std
        t_arr = times.get("cross_correlation", math.nan)
        if not math.isfinite(t_arr):
            raise InputError("the phase pick needs the cross-correlation arrival for its window")
        c, phase_std = _phase_speed(t, f, height, t_arr, frequency, band, response)
        return height / c

    attempt("phase", phase)
    attempt("impulse_edge10", lambda: front_features(t, f).t_lead10)
    attempt("impulse_peak", lambda: front_features(t, f).t_peak)
    picks = {}
    for name in PICKS:
        tt = times[name]
        speed = height / tt if tt > 0 else math.nan
        picks[name] = {"time": tt, "speed": speed,
                       "ratio": speed / c_t if (c_t and math.isfinite(c_t) and c_t > 0) else math.nan}
    return {"picks": picks, "errors": errors, "height": float(height), "frequency": float(frequency),
            "pulse": pulse, "response": response, "polarity": state.get("polarity", 0),
            "wavelength": (float(c_t / frequency) if c_t else math.nan),
            "c_t": float(c_t) if c_t else math.nan, "deflection_fraction": float(deflection_fraction),
            "band": [float(band[0]), float(band[1])], "phase_speed_spread": phase_std}


def shear_series(results: Sequence[dict], *, group_rtol: float = 0.05) -> dict:
    """Ratios speed / c_t of every pick against distance, with ensemble errors.

    ``results``: :func:`shear_picks` outputs (each with its own c_t) of several packings
    and heights. Heights are grouped as in ``analyze heights``; per nominal height and
    pick the mean ratio, its standard error over the packings (``describe``) and the
    count; ``within_5pct``: the picks whose mean ratio lies within 5 % of 1.
    """
    from .ensemble import describe
    from .heights import group_heights

    if not results:
        raise InputError("no shear pick results")
    heights = np.array([r["height"] for r in results])
    groups = group_heights(heights, group_rtol)
    rows = []
    for g in range(int(groups.max()) + 1):
        members = [r for r, k in zip(results, groups) if k == g]
        row = {"height": describe([r["height"] for r in members])["mean"], "n": len(members),
               "c_t": describe([r["c_t"] for r in members])["mean"],
               "frequency": describe([r["frequency"] for r in members])["mean"]}
        for name in PICKS:
            d = describe([r["picks"][name]["ratio"] for r in members])
            row[name] = d["mean"]
            row[f"{name}_err"] = d["sem"]
        row["within_5pct"] = [name for name in PICKS if math.isfinite(row[name]) and abs(row[name] - 1) <= 0.05]
        rows.append(row)
    return {"rows": rows, "picks": list(PICKS), "n_signals": len(results)}
