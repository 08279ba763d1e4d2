"""front.*: the characteristic points of one signal's first pulse (granwave.analysis.front.
front_features, the candidate table's granwave.analysis.continuum.arrival_times), with their
defaults, on signals whose exact features are known:

* the non-dispersive column's response to the kick, F_A = 2Z δ′(t − L/c) (docs/method.md §8,
  "What the detector sees"), seen through a Gaussian low-pass of width σ: F = g_σ′(t − t0),
  whose points are closed forms (zero crossing at t0, peak at t0 − σ, the edge at level q at
  t0 − x_q σ with x e^{(1−x²)/2} = q, energy centroid t0 − 2σ/√π); σ = 20 samples, the
  coarsest sampling of the scenes (the continuum scene's tallest columns);
* the exact chain (granwave.theory.chain_wall_force), initial conditions A (an Airy front whose
  tail lobes grow) and B (a precursor before the main lobe), at N = 25 and 100 balls;
* the exact modal sum of a triangular lattice (granwave.lattice → linearize → eigensolve →
  propagate, the workflow's stages), 25 rows.

Each seed samples the signal as the workflow does (2001 samples over 2.5 crossings, the record
length drawn within ± 2 % so the front falls anywhere between samples); "noisy" settings add a
band-limited error of 10⁻³ max|F| (the time domain's accuracy, docs/tradeoffs.md). The truth of
the chain and the lattice is the same rule applied to the exact signal evaluated 200 times more
finely (its interpolation error is then 4 × 10⁻⁴ of the production grid's). No interval is quoted
for a single signal's point, so each case has a tolerance: 10⁻³ of the time, 3 × 10⁻³ of a
width or an amplitude — below the smallest standard error a scene quotes for a mean over
packings (1.1 × 10⁻³ of t₁₀ at 515 d̄, 1.2 × 10⁻² of W, 3 × 10⁻² of |A|: docs/continuum.md).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from granwave.analysis.continuum import EDGE_LEVELS, arrival_times
from granwave.analysis.front import front_features

from . import Case, edge_x

SAMPLES = 2001   # granwave.params.PropagateParams.samples
CROSSINGS = 2.5  # config/config.yaml t_max_factor
FINE = 50
NOISE = 1e-3
TIME_TOL, SHAPE_TOL = 1e-3, 3e-3


def features(t, f) -> dict:
    """Every point the cases check, by the production functions and their defaults."""
    ff = front_features(t, f)
    arr = arrival_times(t, f)
    out = {"t_lead10": ff.t_lead10, "t_peak": ff.t_peak, "t_zero": ff.t_zero, "width": ff.width,
           "amplitude": ff.amplitude, "centroid": arr["energy"]}
    for lev in EDGE_LEVELS:
        if lev != 0.1:
            out[f"edge{lev:g}"] = arr[f"edge_{lev:g}"]
    return out


def _noise(rng, n, sigma_samples) -> np.ndarray:
    """White noise low-passed like the signal (a Gaussian of ``sigma_samples``), max |·| = 1."""
    from scipy.ndimage import gaussian_filter1d

    x = gaussian_filter1d(rng.standard_normal(n + 200), sigma_samples)[100:-100]
    return x / np.abs(x).max()


def _grid(rng, t_cross: float) -> np.ndarray:
    t_max = CROSSINGS * t_cross * (1.0 + 0.02 * (2.0 * rng.random() - 1.0))
    return np.linspace(0.0, t_max, SAMPLES)


# ------------------------------------------------------------------ the Gaussian-smoothed δ′
SIGMA_SAMPLES = 20.0


def gauss_truth(t0: float, sigma: float) -> dict:
    amp = math.exp(-0.5) / sigma  # peak of g′ for g(u) = e^{−u²/2σ²} (max of −u/σ² e^{…} = e^{−½}/σ)
    out = {"t_lead10": t0 - edge_x(0.1) * sigma, "t_peak": t0 - sigma, "t_zero": t0,
           "width": edge_x(0.1) * sigma, "amplitude": amp, "centroid": t0 - 2.0 * sigma / math.sqrt(math.pi)}
    for lev in EDGE_LEVELS:
        if lev != 0.1:
            out[f"edge{lev:g}"] = t0 - edge_x(lev) * sigma
    return out


GAUSS_T0 = 100.0
GAUSS_SIGMA = CROSSINGS * GAUSS_T0 / (SAMPLES - 1) * SIGMA_SAMPLES  # 20 samples of the grid


def gauss_signal(seed: int, noisy: bool):
    """F = g_σ′(t − t0) (the first lobe positive: compression, then tension)."""
    rng = np.random.default_rng(seed)
    t = _grid(rng, GAUSS_T0)
    u = t - GAUSS_T0
    f = -u / GAUSS_SIGMA**2 * np.exp(-0.5 * (u / GAUSS_SIGMA) ** 2)
    if noisy:
        f = f + NOISE * np.abs(f).max() * _noise(rng, t.size, SIGMA_SAMPLES / 2)
    return t, f


# ------------------------------------------------------------------ exact chain and lattice
@lru_cache(maxsize=None)
def chain_truth(n: int, ic: str) -> dict:
    from granwave.theory import chain_travel_time, chain_wall_force

    t0 = chain_travel_time(n)
    dt = CROSSINGS * t0 / (SAMPLES - 1) / FINE
    # from well before the front (the chain is quiet there: below 10⁻⁶ of its peak) past the
    # first pulse and the next lobe
    t = np.arange(0.6 * t0, 1.6 * t0 + 8 * n ** (1 / 3) + 20, dt)
    return features(t, chain_wall_force(t, n, ic=ic))


def chain_signal(n: int, ic: str):
    from granwave.theory import chain_travel_time, chain_wall_force

    def make(seed: int, noisy: bool):
        rng = np.random.default_rng(seed)
        t = _grid(rng, chain_travel_time(n))
        f = chain_wall_force(t, n, ic=ic)
        if noisy:
            f = f + NOISE * np.abs(f).max() * _noise(rng, t.size, 5.0)
        return t, f
    return make


LATTICE = {"rows": 25, "width": 6, "pressure": 1e-4}


@lru_cache(maxsize=1)
def lattice_modes():
    import granwave as gw

    packing = gw.lattice(**LATTICE)
    modes = gw.eigensolve(gw.linearize(packing))
    from granwave.theory import lattice_speed

    height = float(packing.height)
    return modes, height / lattice_speed(LATTICE["pressure"])


@lru_cache(maxsize=None)
def lattice_truth() -> dict:
    from granwave.linear.propagate import modal_signal

    modes, t_cross = lattice_modes()
    dt = CROSSINGS * t_cross / (SAMPLES - 1) / FINE
    t = np.arange(0.5 * t_cross, 1.6 * t_cross, dt)
    return features(t, modal_signal(modes, ic="A", times=t))


def lattice_signal(seed: int, noisy: bool):
    import granwave as gw

    modes, t_cross = lattice_modes()
    rng = np.random.default_rng(seed)
    t_max = CROSSINGS * t_cross * (1.0 + 0.02 * (2.0 * rng.random() - 1.0))
    sig = gw.propagate(modes, t_max=t_max, samples=SAMPLES)  # the workflow's stage, as called
    f = np.asarray(sig.force)
    if noisy:
        f = f + NOISE * np.abs(f).max() * _noise(rng, f.size, 5.0)
    return np.asarray(sig.time), f


# ------------------------------------------------------------------ the cases
POINTS = ("t_lead10", "t_peak", "t_zero", "width", "amplitude", "centroid",
          *(f"edge{lev:g}" for lev in EDGE_LEVELS if lev != 0.1))


def _shared(make, noisy):
    """One feature extraction per seed for every point of a setting."""
    cache = {}

    def measured(seed):
        if seed not in cache:
            cache[seed] = features(*make(seed, noisy))
        return cache[seed]
    return measured


def cases() -> list[Case]:
    inputs = [
        ("Gaussian-smoothed δ′ (non-dispersive column, σ = 20 samples)", gauss_signal,
         lambda: gauss_truth(GAUSS_T0, GAUSS_SIGMA), True),
        ("exact chain, N = 25, initial condition A", chain_signal(25, "A"),
         lambda: chain_truth(25, "A"), True),
        ("exact chain, N = 100, initial condition A", chain_signal(100, "A"),
         lambda: chain_truth(100, "A"), False),
        ("exact chain, N = 25, initial condition B (precursor)", chain_signal(25, "B"),
         lambda: chain_truth(25, "B"), True),
        ("exact triangular lattice, 25 rows × 6, p = 1e-4 (modal sum)", lattice_signal,
         lattice_truth, False),
    ]
    out = []
    for words, make, truth_of, fast in inputs:
        truth = truth_of()
        for noisy in (False, True):
            measured = _shared(make, noisy)
            setting = words + (", error 10⁻³ max|F|" if noisy else ", exact samples")
            for point in POINTS:
                tol = TIME_TOL if point not in ("width", "amplitude") else SHAPE_TOL
                key = "front." + point

                def run(seed, point=point, measured=measured):
                    return measured(seed)[point], None, None
                out.append(Case(key, setting, float(truth[point]), run,
                                fast=fast and not noisy, tolerance=tol))
    return out


CASES = cases()
