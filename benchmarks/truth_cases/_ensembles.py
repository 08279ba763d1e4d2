"""Synthetic ensembles of signals with a known coherent answer, for the attenuation and
continuum cases (docs/truth.md, "Inputs").

A *medium* is a dispersive, attenuating, non-dispersive-at-zero-frequency column: the kick's
response at distance L, in frequency (``numpy.fft.rfft`` sign, S(ω) = Σ F(t) e^{−iωt} Δt), is

    S(ω, L) = iω G(ω) exp(−α(ω) L − i k(ω) L),   k(ω) = ω / c(ω),

iω the wall-force detector's response to the kick's impulse (F ∝ δ′(t − L/c) for a
non-dispersive column, docs/method.md §8 "What the detector sees"), G(ω) = exp(−(ω/ω_s)²/2)
the kick's grain-scale low-pass delayed by t_s (the model is not causal: its Gaussian low-pass
and its ω² loss spread a pulse both ways in time; the delay keeps every record quiet at its
start, as a real record is), c(ω) = c0 (1 − f (1 − e^{−(ω/ω1)²})) (normal dispersion that
levels off, as the scenes' c(ω) does: no polynomial in ω², so the extrapolation
c0 + c2 ω² from the band's bottom misses c0) and α(ω) = α2 ω² + α4 ω⁴.

Each packing of a height adds its own arrival jitter τ ~ N(0, s L) (random-walk dephasing: the
coherent mean then decays by the extra e^{−s ω² L / 2}), an amplitude factor e^{ε}
(ε ~ N(0, a²), the same law at every height, so it leaves α alone) and an incoherent remainder:
a zero-mean random wave with the height's own spectrum, starting at the front's arrival and
decaying over two front widths, ``incoherent`` times the coherent peak. The coherent answer is
c(ω), α(ω) + s ω²/2, c_g = dω/dk and Q = ω / (2 α_coh c_g).

Units are those of the 2D continuum scene at p = 1e-4 (c0 ≈ 0.19 √(E*/ρ), heights 8 … 512 d̄,
records of 5 crossings at the lattice speed, docs/continuum.md), so that bands, windows and
noise floors fall where the scene's do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from granwave.model import Signal

#: the perfect frictional lattice's speed at p = 1e-4: the workflow's records last
#: t_max_factor crossings at it (workflow/rules/common.smk t_max)
LATTICE_SPEED = 0.283
RECORD_CROSSINGS = 5.0  # config/continuum.yaml t_max_factor


@dataclass(frozen=True)
class Medium:
    """The coherent answer of a synthetic column (module docstring); units d̄, √(E*/ρ)."""

    c0: float = 0.19
    fall: float = 0.025        # c(ω) = c0 (1 − fall (1 − e^{−(ω/ω1)²})): falls by ``fall`` in all,
    omega1: float = 0.012      # 1.5 % at ω = 0.0117 (the band's bottom), 2 % at ω = 0.0152
    alpha2: float = 4.0        # α = alpha2 ω² + alpha4 ω⁴ (1/d̄)
    alpha4: float = 0.0
    omega_s: float = 0.15      # the kick's low-pass
    t_source: float = 100.0    # the source's delay (keeps every record quiet at its start)
    jitter: float = 0.1        # arrival-time variance per unit height (time²/d̄)
    amp_jitter: float = 0.05   # rms of ln(amplitude) per packing
    incoherent: float = 0.3    # the remainder's peak, relative to the coherent peak
    coda: float = 2.0          # the remainder's decay time, in front widths
    coda_flat: bool = False    # its spectrum without the iω of the kick (a coda rich in low frequencies)
    c_l_scatter: float = 0.006  # relative scatter of each packing's c_ℓ about c0

    def c(self, w):
        u = (np.asarray(w, float) / self.omega1) ** 2
        return self.c0 * (1.0 - self.fall * (1.0 - np.exp(-u)))

    def k(self, w):
        return np.asarray(w, float) / self.c(w)

    def c_group(self, w):
        """dω/dk = c² / (c − ω dc/dω)."""
        w = np.asarray(w, float)
        u = (w / self.omega1) ** 2
        dc = -self.c0 * self.fall * 2.0 * w / self.omega1**2 * np.exp(-u)
        c = self.c(w)
        return c * c / (c - w * dc)

    def alpha(self, w):
        w = np.asarray(w, float)
        return self.alpha2 * w**2 + self.alpha4 * w**4

    def alpha_coherent(self, w):
        return self.alpha(w) + 0.5 * self.jitter * np.asarray(w, float) ** 2

    def Q(self, w):
        w = np.asarray(w, float)
        return w / (2.0 * self.alpha_coherent(w) * self.c_group(w))

    def q_inverse(self, w):
        return 1.0 / self.Q(w)

    def spread(self, L) -> float:
        """The pulse's time scale at L: the low-pass and the loss's Gaussian, in quadrature."""
        return math.sqrt(1.0 / self.omega_s**2 + 2.0 * self.alpha2 * L)

    def causal_start(self, L) -> float:
        """Before this time the coherent signal is set to zero (a half-cosine ramp over two
        spreads up to it): the model is not causal, and its dispersion sends a precursor of a
        few 10⁻³ of the peak hundreds of time units ahead of L/c0, which no column has. The cut
        changes the phase by less than 10⁻² rad, c(ω) by less than 10⁻⁴ of itself."""
        return self.t_source + L / self.c0 - 3.5 * self.spread(L)

    def spectrum(self, w, L):
        """The coherent (jitter-free) response at distance L, before the causal cut."""
        w = np.asarray(w, float)
        return (1j * w * np.exp(-0.5 * (w / self.omega_s) ** 2 - 1j * w * self.t_source)
                * np.exp(-self.alpha(w) * L - 1j * self.k(w) * L))

    def omega_star(self, *, c_tol: float = 0.02, q_tol: float = 0.05, c_ref: float | None = None,
                   lo: float = 1e-5) -> tuple[float, str]:
        """The exact ω* (first frequency from 0 up where |c/c_ref − 1| > c_tol or Q⁻¹ > q_tol)
        and which threshold sets it ("dispersion" or "loss"); c_ref = c0 by default."""
        from scipy import optimize

        ref = self.c0 if c_ref is None else c_ref

        def disp(w):
            return abs(float(self.c(w)) / ref - 1.0) - c_tol

        def loss(w):
            return float(self.q_inverse(w)) - q_tol

        out = []
        grid = np.linspace(lo, 0.2, 4000)
        for name, f in (("dispersion", disp), ("loss", loss)):
            vals = np.array([f(x) for x in grid])
            above = np.flatnonzero(vals > 0)
            if above.size and above[0] > 0:
                out.append((optimize.brentq(f, grid[above[0] - 1], grid[above[0]], xtol=1e-13), name))
        return min(out) if out else (math.nan, "none")

    def lambda_star(self, **kw) -> float:
        w, _ = self.omega_star(**kw)
        return float(2.0 * math.pi * self.c(w) / w)


@dataclass(frozen=True)
class Design:
    """Heights and packings of a synthetic scene (default: continuum2d_p4's 8 … 512 d̄, 30
    packings per height below 50 d̄ and 10 above) and its sampling."""

    heights: tuple = (8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0)
    packings: tuple = (30, 30, 30, 10, 10, 10, 10)
    dt: float = 1.0
    medium: Medium = field(default_factory=Medium)

    def with_medium(self, **kw) -> "Design":
        return replace(self, medium=replace(self.medium, **kw))


def record_length(L: float, t_source: float = 0.0) -> float:
    """The workflow's record of a column of height L (its signal delayed by ``t_source``)."""
    return t_source + RECORD_CROSSINGS * L / LATTICE_SPEED


def ensemble(design: Design, seed: int) -> tuple[list[Signal], np.ndarray]:
    """(signals, c_l per signal) of one synthetic scene: every packing of every height."""
    rng = np.random.default_rng(seed)
    m = design.medium
    dt = design.dt
    t_long = 2.0 * record_length(max(design.heights), m.t_source)
    n = 1 << int(math.ceil(math.log2(t_long / dt)))
    w = 2.0 * np.pi * np.fft.rfftfreq(n, dt)
    t = np.arange(n) * dt
    signals, c_l = [], []
    for L, count in zip(design.heights, design.packings):
        coherent = np.fft.irfft(m.spectrum(w, L) / dt, n)
        start = m.causal_start(L)
        ramp = 2.0 * m.spread(L)
        cut = np.where(t < start - ramp, 0.0, np.where(t < start, 0.5 * (1 - np.cos(np.pi * (t - start + ramp) / ramp)), 1.0))
        coherent *= cut
        coh = np.fft.rfft(coherent) * dt
        peak = float(np.abs(coherent).max())
        t_arr = m.t_source + L / m.c0
        keep = t <= record_length(L, m.t_source)
        # the remainder's decay: two front widths (the first lobe's duration, measured)
        width = _lobe_width(t, coherent)
        env = np.where(t > t_arr, np.exp(-(t - t_arr) / (m.coda * width)), 0.0)
        shape = np.abs(coh) / np.maximum(w, w[1]) if m.coda_flat else np.abs(coh)
        for _ in range(count):
            tau = math.sqrt(m.jitter * L) * rng.standard_normal()
            amp = math.exp(m.amp_jitter * rng.standard_normal())
            f = np.fft.irfft(coh * np.exp(-1j * w * tau) * amp / dt, n)
            if m.incoherent:
                white = rng.standard_normal(w.size) + 1j * rng.standard_normal(w.size)
                wave = np.fft.irfft(shape * white, n) * env
                f = f + m.incoherent * peak * wave / np.abs(wave).max()
            signals.append(Signal(time=t[keep].copy(), force=f[keep],
                                  attrs={"height": float(L), "pressure": 1e-4, "ic": "A",
                                         "method": "synthetic"}))
            c_l.append(m.c0 * (1.0 + m.c_l_scatter * rng.standard_normal()))
    return signals, np.array(c_l)


def _lobe_width(t, f) -> float:
    """Duration of the largest lobe of f (a scale for the remainder's decay)."""
    i = int(np.argmax(np.abs(f)))
    s = np.sign(f[i])
    a = i
    while a > 0 and np.sign(f[a - 1]) == s:
        a -= 1
    b = i
    while b < f.size - 1 and np.sign(f[b + 1]) == s:
        b += 1
    return float(max(t[b] - t[a], t[1] - t[0]))


# ---------------------------------------------------------------- fronts against distance
@dataclass(frozen=True)
class Fronts:
    """Packings' signals whose front features are known at every height: F = A g_σ′(t − a), the
    non-dispersive column's δ′ response (docs/method.md §8) broadened by a Gaussian of width
    σ(L) = sigma1 (L / L1)^width_exponent (what dispersion and scattering do to the front), with
    amplitude A(L) = amp1 (L / L1)^−gamma. Per packing: arrival jitter τ ~ N(0, jitter L), the
    width and the amplitude times e^{ε}, ε ~ N(0, width_jitter²) and N(0, amp_jitter²).

    The 10 % edge lies at t₁₀ = a − x₁₀ σ (x₁₀ = 2.7: :func:`benchmarks.truth_cases.edge_x`),
    the peak at a − σ, the zero crossing at a, the width W = x₁₀ σ; the expectation over packings
    of every time is exact (E e^{ε} = e^{s²/2}). ``arrival(L)``: a(L) = L / c unless ``edge``
    gives the mean 10 % edge time instead (then a = edge(L) + x₁₀ σ(L) e^{s²/2})."""

    heights: tuple
    packings: tuple
    c: float = 0.19
    sigma1: float = 5.9        # W(8.4 d̄) ≈ 16, as the 2D frictional columns at p = 1e-4
    L1: float = 8.0
    width_exponent: float = 0.75
    amp1: float = 0.022
    gamma: float = 1.3
    jitter: float = 0.1
    width_jitter: float = 0.05
    amp_jitter: float = 0.12
    c_l_scatter: float = 0.006
    crossings: float = 2.5     # record: this many crossings at the lattice speed, 2001 samples
    t_offset: float = 0.0
    edge: object = None        # None or a callable L -> the mean 10 % edge time

    def sigma(self, L):
        return self.sigma1 * (np.asarray(L, float) / self.L1) ** self.width_exponent

    def amplitude(self, L):
        return self.amp1 * (np.asarray(L, float) / self.L1) ** (-self.gamma)

    def x10(self) -> float:
        from . import edge_x

        return edge_x(0.1)

    def arrival(self, L):
        grow = math.exp(0.5 * self.width_jitter**2)
        if self.edge is not None:
            return self.edge(L) + self.x10() * self.sigma(L) * grow
        return self.t_offset + np.asarray(L, float) / self.c

    def mean_time(self, L, point: str):
        """E over packings of t_lead10, t_peak or t_zero at height L."""
        grow = math.exp(0.5 * self.width_jitter**2)
        x = {"t_lead10": self.x10(), "t_peak": 1.0, "t_zero": 0.0}[point]
        return self.arrival(L) - x * self.sigma(L) * grow


def fronts(design: Fronts, seed: int) -> tuple[list[Signal], np.ndarray]:
    """(signals, c_l per signal): every packing of every height of ``design``."""
    rng = np.random.default_rng(seed)
    signals, c_l = [], []
    for L, count in zip(design.heights, design.packings):
        t_max = design.crossings * L / LATTICE_SPEED + design.arrival(L) - L / design.c
        t_max = max(t_max, design.arrival(L) + 8 * float(design.sigma(L)))
        t = np.linspace(0.0, t_max, 2001)
        for _ in range(count):
            a = design.arrival(L) + math.sqrt(design.jitter * L) * rng.standard_normal()
            s = design.sigma(L) * math.exp(design.width_jitter * rng.standard_normal())
            amp = design.amplitude(L) * math.exp(design.amp_jitter * rng.standard_normal())
            u = (t - a) / s
            f = -amp * math.exp(0.5) * u * np.exp(-0.5 * u * u)  # peak value amp at u = −1
            signals.append(Signal(time=t, force=f, attrs={"height": float(L), "pressure": 1e-4,
                                                          "ic": "A", "method": "synthetic"}))
            c_l.append(design.c * (1.0 + design.c_l_scatter * rng.standard_normal()))
    return signals, np.array(c_l)
