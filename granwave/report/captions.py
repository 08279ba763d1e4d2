"""Figure names (the ``granwave plot`` subcommands) and the report's captions."""

from __future__ import annotations

import os
from pathlib import Path

FIGURES: dict[str, str] = {
    "network": "Force network (width ∝ normal force) beside the stiffness network (width ∝ k_n), "
               "with the force and stiffness histograms",
    "roses": "Contact-direction roses for all, strong and weak contacts",
    "snapshot": "The pulse: displacement snapshots on one scale, the row-averaged energy E(y, t) "
                "(log scale) and the low-pass displacement with the detector's arrival times",
    "signals": "Signals of several packings and the ensemble average ± rms",
    "compare": "Signals of the frictional 2D, frictionless 2D and 3D systems against t/L (heights L "
               "in the legend), cut to a common range",
    "coherent": "Coherent part of the signal at several heights",
    "arrivals": "Arrival times of the 10% edge, the peak and the zero crossing against distance",
    "exponents": "Amplitude A(L) and width W(L): ensemble means ± standard error, fits, and local "
                 "exponents between distinct heights",
    "exponents_chains": "Amplitude A(L) and width W(L) of the chains (L ≈ N), with local exponents "
                        "(apart from the packings' figure: their L differ a hundredfold)",
    "speeds": "Sound speeds c_tof, c_ℓ and c_t against pressure with the lattice theory and p^(1/6), "
              "p^(1/4) guides",
    "spectrum": "Eigen-spectrum and the modes' weights a_n b_n in the signal",
    "modes": "Selected mode shapes",
    "damping": "Nonlinear DEM signals for several contact dampings ζ at one kick amplitude, the linear "
               "model dashed",
    "airy": "Chain signals against the Airy shape in the co-moving frame",
    "continuum": "Continuum scene: local speeds and c_ℓ against L, c_tof/c_ℓ with the fit "
                 "1 + a L^−β, amplitude and width with local exponents, attenuation α(ω) and phase "
                 "velocity c(ω) of the coherent signal in its reliable band",
    "shear": "Shear scene: V_s, V_p (waves) and c_t, c_ℓ (moduli) against pressure with fits, "
             "G_max against p^(1/3) and the measured exponent κ_G, V_p/V_s and the effective Poisson "
             "ratio ν_eff from waves and moduli, every arrival pick's V/c_t against distance",
    "shocks": "Shocks scene: piston pushes of growing strain on the same packings; V/c0 against "
              "ε/δ0 with the mean-field column's curve, V against ε, the crossover strain ε× against "
              "p with the p^(2/3) line, and the fractions of contacts that opened and slid",
}
"""Figure name (the ``granwave plot`` subcommand) -> caption used by the report."""


def caption_for(filename: str | os.PathLike) -> str:
    """The caption of a figure file named after its ``granwave plot`` subcommand."""
    stem = Path(filename).stem
    for name in sorted(FIGURES, key=len, reverse=True):
        if stem == name or stem.startswith(name + "_") or stem.startswith(name + "-"):
            rest = stem[len(name) + 1:]
            return FIGURES[name] + (f" ({rest.replace('_', ' ')})" if rest else "")
    return stem.replace("_", " ")
