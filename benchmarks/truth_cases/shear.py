"""shear.*: the bender-element picks of a shear signal (granwave.analysis.shear.shear_picks, its
defaults, as the shear scene calls it) on impulse responses whose travel time is known exactly:

* the non-dispersive column's wall-force response ±F_A = ±2Z δ′(t − L/c) (docs/method.md §8,
  "What the detector sees"; + compression first, − the opposite sign convention), picked with
  the default matched template w′ (``response="derivative"``);
* a pure delay F_A = δ(t − L/c), picked with the template w (``response="delay"``);

each δ a unit Gaussian of σ = 1.5 samples (far narrower than any pulse), the first echo at 3L/c
included (the top wall's image), L = 100 d, c = 1, source pulses ``ricker`` and ``sine`` at
λ = c/f = 8, 16 and 32 d. Each seed samples the signal as the workflow does (2001 samples over
3 crossings plus 3 pulse periods, the record length drawn within ± 2 % so the arrival falls
anywhere between samples), draws the sign of the response, and the "noisy" settings add an
incoherent band-limited remainder whose part in the received signal F_A * w is 10⁻³ of its
maximum (the time domain's accuracy, docs/tradeoffs.md). The estimate is the pick's speed L/T over
c; truth 1. No interval is quoted for one signal's pick: tolerance 1 %.
"""

from __future__ import annotations

import math

import numpy as np

from granwave.analysis.shear import received, shear_picks, source_pulse

from . import Case

L, C = 100.0, 1.0
SAMPLES = 2001
SIGMA_SAMPLES = 1.5
NOISE = 1e-3
WAVELENGTHS = (8.0, 16.0, 32.0)
PULSES = ("ricker", "sine")
PICKS = ("first_deflection", "edge10", "peak_to_peak", "cross_correlation", "phase")
TOLERANCE = 0.01
RESPONSES = {"derivative": "±δ′(t − L/c) (the wall-force detector), template w′",
             "delay": "±δ(t − L/c) (a pure delay), template w"}


def _noise(rng, n, sigma_samples) -> np.ndarray:
    from scipy.ndimage import gaussian_filter1d

    x = gaussian_filter1d(rng.standard_normal(n + 200), sigma_samples)[100:-100]
    return x / np.abs(x).max()


def signal(seed: int, response: str, pulse: str, lam: float, noisy: bool):
    """(time, F_A, sign) of one seed: the response, its echo at 3L/c, the drawn sign."""
    rng = np.random.default_rng(seed)
    f = C / lam
    t_max = (3.0 * L / C + 3.0 / f) * (1.0 + 0.02 * (2.0 * rng.random() - 1.0))
    t = np.linspace(0.0, t_max, SAMPLES)
    sigma = SIGMA_SAMPLES * (t[1] - t[0])
    out = np.zeros_like(t)
    for t0 in (L / C, 3.0 * L / C):
        u = t - t0
        g = np.exp(-0.5 * (u / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))
        out += g if response == "delay" else -u / sigma**2 * g  # g′: its first lobe positive
    sign = 1.0 if rng.random() < 0.5 else -1.0
    out *= sign
    if noisy:
        # scaled so that its received part is NOISE of the received signal's maximum
        w = source_pulse(t, C / lam, pulse)
        x = _noise(rng, t.size, SIGMA_SAMPLES)
        out = out + NOISE * np.abs(received(t, out, w)).max() / np.abs(received(t, x, w)).max() * x
    return t, out, sign


def _shared(response, pulse, lam, noisy):
    cache = {}

    def measured(seed):
        if seed not in cache:
            t, fa, _ = signal(seed, response, pulse, lam, noisy)
            cache[seed] = shear_picks(t, fa, height=L, frequency=C / lam, pulse=pulse, c_t=C,
                                      response=response)["picks"]
        return cache[seed]
    return measured


def cases() -> list[Case]:
    out = []
    for response, words in RESPONSES.items():
        for pulse in PULSES:
            for lam in WAVELENGTHS:
                for noisy in (False, True):
                    measured = _shared(response, pulse, lam, noisy)
                    setting = (f"{words}, {pulse}, λ = {lam:g} d, L = {L:g} d, echo at 3L/c, "
                               + ("remainder 10⁻³ of the received maximum" if noisy else "exact samples"))
                    for pick in PICKS:
                        def run(seed, pick=pick, measured=measured):
                            return measured(seed)[pick]["ratio"], None, None
                        out.append(Case(f"shear.{pick}", setting, 1.0, run,
                                        fast=(lam == 16.0 and pulse == "ricker" and not noisy),
                                        tolerance=TOLERANCE))
    return out


CASES = cases()
