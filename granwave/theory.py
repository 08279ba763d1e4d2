"""Exact references of docs/method.md §12: the 1D chain and the triangular lattice.

The chain
---------
N identical balls (mass m) on a line, neighbours and both end walls joined by
N + 1 linear springs of stiffness K, equilibrium spacing ℓ. With u_0 = u_{N+1}
= 0 (walls), m ü_j = K (u_{j+1} - 2 u_j + u_{j-1}). The modes are

    φ_n(j) = sqrt(2/(N+1)) sin(j θ_n),   θ_n = k_n ℓ = nπ/(N+1),
    ω_n = 2 ω_0 sin(θ_n/2),   ω_0 = sqrt(K/m),   c = ℓ ω_0,

(Euclidean-orthonormal). The force on the far wall is F = K u_N. Because
φ_n(1) φ_n(N) = (2/(N+1)) (-1)^{n+1} sin²θ_n,

    (A) u̇_1(0) = c:  F_A(t) = K c (2/(N+1)) Σ_n (-1)^{n+1} sin²θ_n sin(ω_n t)/ω_n,
    (B) u_1(0) = ℓ:  F_B(t) = K ℓ (2/(N+1)) Σ_n (-1)^{n+1} sin²θ_n cos(ω_n t)
                            = (ℓ/c) dF_A/dt.

Airy asymptotics (derivation)
-----------------------------
The front is carried by the long waves, where the group velocity ω'(θ) =
ω_0 cos(θ/2) is largest; ω(θ) = ω_0 (θ - θ³/24 + O(θ⁵)) has its inflection
at θ = 0, so stationary phase degenerates there and gives an Airy function.
For θ → 0: sin²θ ≈ θ², sin²θ/ω ≈ θ/ω_0. Poisson summation of the
alternating sum (g even, g(0) = g(π) = 0, so Σ_{n=1}^{N} is half the sum
over a period) keeps the two slowest images e^{±i(N+1)θ}:
Σ_n (-1)^n g(θ_n) ≈ (2(N+1)/π) ∫_0^π g(θ) cos((N+1)θ) dθ; the other images
carry phases e^{±i(2m+1)(N+1)θ} that are stationary only at the echoes
t ≈ (2m+1) t0. So (2/(N+1)) Σ_n (-1)^{n+1} → -(4/π) ∫_0^∞ dθ cos((N+1)θ). Writing M = ω_0 t and keeping the slowly
varying part of -cos((N+1)θ) sin(Mθ - Mθ³/24), i.e.
-½ sin((M - N - 1)θ - Mθ³/24):

    F_A/(Kℓ) ≈ -(2/π) ∫_0^∞ θ sin((M - N - 1)θ - Mθ³/24) dθ.

With θ = λ s, λ = (8/M)^{1/3} = 2 M^{-1/3} (so that Mθ³/24 = s³/3), and
Ai'(x) = -(1/π) ∫_0^∞ s sin(s³/3 + x s) ds:

    F_A(t) ≈ -8 K ℓ M^{-2/3} Ai'(x),     x = (N + 1 - M) λ = -2 (cτ/ℓ) M^{-1/3},

with τ = t - t0, t0 = (N+1) ℓ/c (wall to wall) and M = ω_0 t = N + 1 + cτ/ℓ.
The same steps with sin²θ ≈ θ², cos instead of sin, and
Ai''(x) = -(1/π) ∫_0^∞ s² cos(s³/3 + x s) ds give

    F_B(t) ≈ 16 K ℓ M^{-1} Ai''(x).

The factors 8 and 16 contain the doubling of the force by the reflection at
the far wall. The neglected terms (θ⁵ in ω, θ² corrections of the amplitude,
the fast phases) are of relative order M^{-2/3} in the front region. At
τ = 0: F_A ≈ -8 Ai'(0) K ℓ (N+1)^{-2/3} = 2.07 K ℓ (N+1)^{-2/3} and the front width grows as
M^{1/3}; for (B) the amplitude falls as 1/N; Ai'' = x Ai(x) gives a small
positive precursor (x > 0, ahead of the front) and a larger negative main lobe.

The triangular lattice (docs/method.md §12)
---------------------------------
Identical Hertzian balls (diameter 1, E* = 1, ρ = 1), rows parallel to the
walls, under vertical stress p. Rows map to a chain with spacing √3/2, mass
π/6 per ball and per-ball row stiffness (3/2) k_n (1 + η/3) at the contact
force p/√3, which gives c = 3^{19/12} / (2^{3/2} π^{1/2}) p^{1/6}
(× sqrt(1 + η/3) with friction), to leading order in p (the overlaps shorten
the spacing by a relative O(p^{2/3})).

Transverse waves of the frictional lattice (docs/method.md §12, "Shear")
-----------------------------------------------------------------------
Rows moving along x (u_j) with rotations θ_j, uniform along each row. Per
ball (arm a = 1/2, row spacing h = √3/2, s = sin 60° = √3/2) the energy is

    E = ½ k_t (2aθ_j)²                                 (in-row contact: the two
                                                         contact points slide by 2aθ)
      + 2 × ½ k_n (δu/2)²                              (two inclined contacts, normal part)
      + 2 × ½ k_t (s δu + a(θ_j + θ_j+1))²            (their tangential part)

with δu = u_{j+1} − u_j. A plane wave (U, Θ) e^{i j q}, q = k h, gives the
2×2 dynamical matrix per ball

    D_uu = (k_n + 3 k_t)(1 − cos q),   D_θθ = 4 k_t a² (2 + cos q),
    D_uθ = −4 i k_t s a sin q,          det(D − ω² diag(m, I)) = 0.

The rotations do not follow the translations for free: at long wavelength
(q → 0) the rotation is slaved, Θ = −(2 s/3a) · (iq U/2)… i.e. minimizing E over a
uniform θ at uniform strain gives 2aθ = −(2s/3) δu, and the effective row
stiffness per ball drops from (k_n + 3k_t)/2 (rotations held) to

    K_T = (k_n + k_t)/2,   c_t = h sqrt(K_T/m) = c_ℓ0 sqrt((1 + η)/3),

c_ℓ0 the frictionless longitudinal speed above (c_t/c_ℓ = sqrt((1+η)/(3+η))
with friction: 1/√2 at η = 1). The acoustic branch is *anomalous*: as q grows
the rotations lag and the branch stiffens towards the rotations-held value,
so its group velocity exceeds c_t at finite q (up to ≈ 1.3 c_t for η = 1):
an impulsive shear kick sends a dispersive precursor ahead of the
long-wavelength front, which only a band-limited pulse (docs/shear.md)
resolves.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from . import contact
from .errors import InputError

# Memory bound of the modal sums: at most this many (time x mode) elements at once.
_CHUNK_ELEMENTS = 1 << 21


def _check_chain(n_balls: int, stiffness: float, mass: float, spacing: float) -> None:
    if int(n_balls) != n_balls or n_balls < 1:
        raise InputError(f"n_balls must be a positive integer, got {n_balls}")
    for name, v in (("stiffness", stiffness), ("mass", mass), ("spacing", spacing)):
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"{name} must be a positive finite number, got {v}")


def chain_speed(*, stiffness: float = 1.0, mass: float = 1.0, spacing: float = 1.0) -> float:
    """Long-wavelength sound speed c = ℓ sqrt(K/m) (spacing / time)."""
    return spacing * np.sqrt(stiffness / mass)


def chain_travel_time(n_balls: int, *, stiffness: float = 1.0, mass: float = 1.0,
                      spacing: float = 1.0) -> float:
    """Wall-to-wall travel time t0 = (N+1) ℓ / c (not N ℓ / c, docs/method.md §12)."""
    return (n_balls + 1) * spacing / chain_speed(stiffness=stiffness, mass=mass, spacing=spacing)


def chain_modes(n_balls: int, *, stiffness: float = 1.0, mass: float = 1.0,
                spacing: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Wavenumbers k_n = nπ/((N+1)ℓ) (1/length) and frequencies ω_n = 2 sqrt(K/m) sin(k_n ℓ/2)
    (1/time), n = 1..N, of the chain tied to two walls."""
    _check_chain(n_balls, stiffness, mass, spacing)
    n = np.arange(1, int(n_balls) + 1)
    k = n * np.pi / ((n_balls + 1) * spacing)
    return k, 2.0 * np.sqrt(stiffness / mass) * np.sin(k * spacing / 2.0)


def chain_wall_force(t, n_balls: int, *, ic: str = "A", stiffness: float = 1.0,
                     mass: float = 1.0, spacing: float = 1.0) -> np.ndarray:
    """Exact force on the far wall, F(t) = K u_N(t), from the modal sum (module docstring).

    ``ic="A"``: the first ball starts with velocity c = ℓ sqrt(K/m); ``ic="B"``:
    it starts displaced by ℓ at rest. ``t`` is any array of times (units of
    ℓ / c × ...: those of sqrt(m/K)); the result (units K ℓ) has its shape.
    Evaluated in chunks of times and modes, so memory stays bounded for long
    records and N up to 10^4 and more; the cost is O(len(t) × N).
    """
    ic = str(ic).upper()
    if ic not in ("A", "B"):
        raise InputError(f"initial condition must be 'A' or 'B', got {ic!r}")
    _check_chain(n_balls, stiffness, mass, spacing)
    t = np.asarray(t, dtype=float)
    flat = t.ravel()
    k, omega = chain_modes(n_balls, stiffness=stiffness, mass=mass, spacing=spacing)
    n = np.arange(1, int(n_balls) + 1)
    theta = k * spacing
    sign = np.where(n % 2 == 1, 1.0, -1.0)  # (-1)^{n+1}
    weight = sign * np.sin(theta) ** 2 * (2.0 / (n_balls + 1))
    if ic == "A":
        weight = weight * stiffness * chain_speed(stiffness=stiffness, mass=mass, spacing=spacing) / omega
        phase = np.sin
    else:
        weight = weight * stiffness * spacing
        phase = np.cos
    out = np.zeros(flat.size)
    mode_chunk = max(1, min(omega.size, _CHUNK_ELEMENTS // max(1, min(flat.size, 4096))))
    time_chunk = max(1, _CHUNK_ELEMENTS // mode_chunk)
    for a in range(0, flat.size, time_chunk):
        tt = flat[a:a + time_chunk]
        acc = np.zeros(tt.size)
        for b in range(0, omega.size, mode_chunk):
            acc += phase(np.outer(tt, omega[b:b + mode_chunk])) @ weight[b:b + mode_chunk]
        out[a:a + time_chunk] = acc
    return out.reshape(t.shape)


def chain_wall_force_airy(t, n_balls: int, *, ic: str = "A", stiffness: float = 1.0,
                          mass: float = 1.0, spacing: float = 1.0) -> np.ndarray:
    """Large-N Airy form of :func:`chain_wall_force` near the front (derivation: module docstring).

    (A): F ≈ -8 K ℓ M^{-2/3} Ai'(x);  (B): F ≈ 16 K ℓ M^{-1} Ai''(x),
    with M = ω_0 t = N + 1 + cτ/ℓ, x = -2 (cτ/ℓ) M^{-1/3}, τ = t - (N+1)ℓ/c.
    Valid for t > 0 near the arrival (|cτ/ℓ| ≲ a few M^{1/3}); relative error O(M^{-2/3}).
    """
    ic = str(ic).upper()
    if ic not in ("A", "B"):
        raise InputError(f"initial condition must be 'A' or 'B', got {ic!r}")
    _check_chain(n_balls, stiffness, mass, spacing)
    t = np.asarray(t, dtype=float)
    if np.any(t <= 0):
        raise InputError("the Airy form needs times t > 0")
    w0 = np.sqrt(stiffness / mass)
    big_m = w0 * t
    x = -2.0 * (big_m - (n_balls + 1)) * big_m ** (-1.0 / 3.0)
    # far ahead of the front Ai underflows to 0; scipy returns NaN beyond x ~ 1e6, so clip
    ai, aip, _, _ = special.airy(np.minimum(x, 200.0))
    if ic == "A":
        return -8.0 * stiffness * spacing * big_m ** (-2.0 / 3.0) * aip
    return 16.0 * stiffness * spacing * x * ai / big_m  # Ai''(x) = x Ai(x)


# ---------------------------------------------------------------- triangular lattice
LATTICE_PREFACTOR = 3.0 ** (19.0 / 12.0) / (2.0 ** 1.5 * np.sqrt(np.pi))


def lattice_speed(pressure, *, friction: bool = False, poisson: float = 0.0):
    """Longitudinal speed across the rows of a triangular lattice (docs/method.md §12), units sqrt(E*/ρ).

    c = 3^{19/12} / (2^{3/2} π^{1/2}) (p/E*)^{1/6}, times sqrt(1 + η/3) with
    friction, η = k_t/k_n = :func:`granwave.contact.stiffness_ratio` (ν).
    ``pressure`` in E* (scalar or array). Leading order in p.
    """
    p = np.asarray(pressure, dtype=float)
    if np.any(~np.isfinite(p)) or np.any(p <= 0):
        raise InputError("pressure must be positive and finite")
    if not 0.0 <= poisson < 1.0:
        raise InputError(f"poisson must be in [0, 1), got {poisson}")
    c = LATTICE_PREFACTOR * p ** (1.0 / 6.0)
    if friction:
        c = c * np.sqrt(1.0 + contact.stiffness_ratio(poisson) / 3.0)
    return c if c.ndim else float(c)


def law_lattice_speed(pressure: float, submodels: dict | None = None, *, friction: bool = False,
                      poisson: float = 0.0) -> float:
    """:func:`lattice_speed` of a lattice whose contacts follow the normal law (and, with
    friction, the tangential law) of the selection ``submodels`` (granwave.contact_models.options;
    None: Hertz-Mindlin, for which this is :func:`lattice_speed`), units sqrt(E*/rho).

    The row chain of docs/method.md §12 at leading order in p: c = h sqrt(K_row / m), h = sqrt(3)/2,
    m = pi/6, K_row = (3/2) (k_n + k_t/3) (k_t = 0 without friction), k_n and k_t those of two unit
    balls (R12 = 1/4, E*12 = 1/2) carrying the contact force p / sqrt(3).
    """
    from . import contact_models as CM
    from .contact_models import options as CO

    p = float(pressure)
    if not (math.isfinite(p) and p > 0):
        raise InputError("pressure must be positive and finite")
    values = CO.resolve({**(submodels or {}), "friction": 1.0 if friction else 0.0, "poisson": float(poisson)})
    _, law = CM.normal_law(values)
    r12, e12 = 0.25, contact.effective_young(False)
    n = CM.overlap_at_force(values, p / math.sqrt(3.0), r12, e12)
    kn = CM.law_stiffness(law, n, math.sqrt(r12), e12)
    kt = 0.0
    if friction:
        kt = CM.tangential_spring(CM.model_of("tangential", values),
                                  CM.law_tangential_stiffness(law, n, r12, contact.effective_shear(poisson, False)),
                                  n, e12)
    return math.sqrt(3.0) / 2.0 * math.sqrt(1.5 * (kn + kt / 3.0) / (math.pi / 6.0))


def lattice_shear_speed(pressure, *, poisson: float = 0.0):
    """Long-wavelength transverse speed across the rows of the frictional triangular lattice
    (polarization along the rows, rotations relaxed; module docstring), units sqrt(E*/ρ).

    c_t = 3^{19/12} / (2^{3/2} π^{1/2}) (p/E*)^{1/6} sqrt((1 + η)/3), η = k_t/k_n
    (:func:`granwave.contact.stiffness_ratio`). Leading order in p. A frictionless
    lattice has no shear stiffness across its rows beyond k_n's (η = 0 here) and no
    tangential wall coupling at all.
    """
    c = lattice_speed(pressure, friction=False, poisson=poisson)
    return c * np.sqrt((1.0 + contact.stiffness_ratio(poisson)) / 3.0)


def lattice_transverse_branches(q, *, kn: float, kt: float, mass: float = np.pi / 6,
                                inertia: float = np.pi / 60, arm: float = 0.5):
    """(ω_acoustic, ω_optical) of x-polarized, row-uniform waves across the lattice rows at the
    reduced wavenumbers ``q`` = k h (module docstring: the 2×2 dynamical matrix per ball)."""
    q = np.asarray(q, float)
    s = np.sqrt(3.0) / 2.0
    duu = (kn + 3.0 * kt) * (1.0 - np.cos(q))
    dtt = 4.0 * kt * arm**2 * (2.0 + np.cos(q))
    duq2 = (4.0 * kt * s * arm * np.sin(q)) ** 2
    # det = (duu - m w2)(dtt - I w2) - |duq|^2 = 0
    a = mass * inertia
    b = -(duu * inertia + dtt * mass)
    c = duu * dtt - duq2
    root = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    low = 2.0 * c / (-b + root)  # the small root without cancellation
    high = (-b + root) / (2.0 * a)
    return np.sqrt(np.maximum(low, 0.0)), np.sqrt(high)


# ---------------------------------------------------------------- effective medium (affine)
def effective_medium_moduli(pressure: float, *, z: float, phi: float, dim: int = 2,
                            friction: bool = True, poisson: float = 0.0, mean_d3: float = 1.0,
                            stress_ratio: float = 1.0) -> dict:
    """Affine effective-medium moduli of a random, isotropic packing of Hertz–Mindlin spheres of
    mean diameter d̄ = 1 fed the measured coordination ``z`` (z*, per non-rattler grain), solid
    fraction ``phi`` (Φ3*) and pressure p (E*); units E* and √(E*/ρ).

    Every contact (branch length d̄, the same force) follows the affine strain: with
    n_c = z Φ / (2 ⟨v⟩) contacts per volume (⟨v⟩ = π ⟨d³⟩/6; 2D: per layer one d̄ thick) and
    isotropic averages of the contact normals, C_ijkl = n_c d̄² ⟨(k_n − k_t) n_i n_j n_k n_l +
    k_t δ_ik n_j n_l⟩. The mean stress p̄ = n_c ⟨F_n⟩ d̄ / dim gives the contact force, Hertz
    (docs/method.md §2, R12 = d̄/4, E*12 = 1/2) its stiffness k_n = (3 F_n)^{1/3} / 2, and
    k_t = η k_n (0 without friction). Then

    * 2D (in-plane isotropy): M = C22 = n_c (3 k_n + k_t)/8, G = C33 = n_c (k_n + k_t)/8;
    * 3D: M = C33 = n_c (3 k_n + 2 k_t)/15, G = n_c (2 k_n + 3 k_t)/30.

    ``stress_ratio`` σ1/σ2 (horizontal over vertical, = p) sets p̄ = p (1 + σ1/σ2)/2 in 2D and
    p (1 + 2 σ1/σ2)/3 in 3D. The affine field ignores the grains' relaxation, so both are upper
    bounds of the relaxed packing's moduli (Voigt), G far above it near jamming.
    Returns ``M`` (longitudinal modulus), ``G``, ``c_l`` = √(M/Φ), ``c_t`` = √(G/Φ),
    ``force`` ⟨F_n⟩ and ``k_n``.
    """
    if dim not in (2, 3):
        raise InputError(f"dim must be 2 or 3, got {dim}")
    if not (pressure > 0 and z > 0 and phi > 0 and mean_d3 > 0 and stress_ratio > 0):
        raise InputError("the effective medium needs positive pressure, z, phi, mean_d3 and stress ratio")
    n_c = z * phi / (2.0 * np.pi * mean_d3 / 6.0)
    p_mean = pressure * (1.0 + (dim - 1) * stress_ratio) / dim
    force = dim * p_mean / n_c
    kn = 0.5 * (3.0 * force) ** (1.0 / 3.0)
    kt = contact.stiffness_ratio(poisson) * kn if friction else 0.0
    if dim == 2:
        m, g = n_c * (3 * kn + kt) / 8.0, n_c * (kn + kt) / 8.0
    else:
        m, g = n_c * (3 * kn + 2 * kt) / 15.0, n_c * (2 * kn + 3 * kt) / 30.0
    return {"M": float(m), "G": float(g), "c_l": float(np.sqrt(m / phi)),
            "c_t": float(np.sqrt(g / phi)), "force": float(force), "k_n": float(kn)}


# ---------------------------------------------------------------- solitary waves (docs/method.md §12)
def solitary_wave_speed(force_max: float, force_0: float, *, energy, mass: float, spacing: float) -> float:
    """Speed of the long-wave solitary wave of a chain of balls of mass ``mass`` and centre
    spacing ``spacing`` whose contacts carry ``force_0`` at rest and ``force_max`` at the wave's
    crest (docs/method.md §12, Nesterenko's closed form written for any law):

        V² = (2 a² / m) [W(δ_m) − W(δ_0) − F_0 (δ_m − δ_0)] / (δ_m − δ_0)²,

    ``energy``: a callable (force_max, force_0) -> (W(δ_m) − W(δ_0), δ_m − δ_0), the law's
    contact energy between the two overlaps and their difference. For Hertz
    (:func:`hertz_solitary_speed`) this is Nesterenko's formula; for a linear spring it is the
    sound speed a sqrt(k/m) at any amplitude. The bracket is a difference of nearly equal terms as
    F_m → F_0: a few digits are lost below F_m / F_0 − 1 ~ 1e-4 (use the sound speed there)."""
    if not (force_max > force_0 >= 0.0):
        raise ValueError(f"need force_max > force_0 >= 0 (got {force_max}, {force_0})")
    dw, dd = energy(force_max, force_0)
    return float(math.sqrt(2.0 * spacing**2 / mass * (dw - force_0 * dd) / dd**2))


def hertz_solitary_speed(force_max: float, force_0: float, *, kappa: float, mass: float,
                         spacing: float) -> float:
    """:func:`solitary_wave_speed` for Hertz contacts F = κ δ^{3/2} (W = (2/5) κ δ^{5/2}): with
    f_r = F_m / F_0 and the sound speed c_0 = a sqrt(k_0 / m), k_0 = (3/2) κ δ_0^{1/2},

        V = c_0 / (f_r^{2/3} − 1) · sqrt{(4/15) [3 + 2 f_r^{5/3} − 5 f_r^{2/3}]},

    and without precompression (F_0 = 0) V = sqrt(4/5) a sqrt(κ / m) δ_m^{1/4}."""
    def energy(fm, f0):
        dm, d0 = (fm / kappa) ** (2.0 / 3.0), (f0 / kappa) ** (2.0 / 3.0)
        return 0.4 * kappa * (dm**2.5 - d0**2.5), dm - d0
    return solitary_wave_speed(force_max, force_0, energy=energy, mass=mass, spacing=spacing)


#: Full width (in a, the spacing) of the uncompressed Hertz chain's long-wave solitary wave: its
#: strain ∝ cos⁴(√10 x / (5 a)) on |x| < 5π a / (2√10) (docs/method.md §12).
HERTZ_SOLITARY_SUPPORT = 5.0 * math.pi / math.sqrt(10.0)
#: Its full width at half maximum (in a): cos⁴(√10 x / (5 a)) = 1/2.
HERTZ_SOLITARY_FWHM = 2.0 * math.acos(2.0 ** -0.25) * 5.0 / math.sqrt(10.0)


# ---------------------------------------------------------------- the discrete chain's solitary wave
def hertz_chain_solitary_wave(speed: float, force_0: float, *, kappa: float, mass: float, spacing: float,
                              points_per_grain: int = 32, tol: float = 1e-12) -> dict:
    """The exact solitary wave of the discrete Hertzian chain travelling at ``speed`` (docs/method.md
    §12, "The discrete chain's wave"): the overlap δ_n(t) = δ_0 + y(n − V t / a) between balls n − 1 and
    n solves m (V/a)² y″(ξ) = F(δ_0 + y(ξ+1)) − 2 F(δ_0 + y(ξ)) + F(δ_0 + y(ξ−1)), F = κ δ^{3/2}. With
    F(δ_0 + y) = F_0 + k_0 y + N(y) its Fourier transform is

        ŷ(q) = s(q) N̂(q) / [m (V/a)² q² − k_0 s(q)],   s = 4 sin²(q/2),

    a positive operator for V above the sound speed c_0 = a sqrt(k_0/m), solved by Petviashvili's
    iteration (y ← M^γ G N(y), M = ⟨y, y⟩ / ⟨y, G N(y)⟩, γ = 3 without precompression, 2 with it) on
    a periodic grid of ``points_per_grain`` points per spacing, long enough for the tails to vanish
    (their decay length, 1 / sqrt(V/c_0 − 1) grains near the linear limit). Returns xi (grains), y
    (the overlap beyond δ_0), velocity (of the ball at ξ, along the wave), force_max = F(δ_0 + max y)
    and iterations."""
    if force_0 < 0.0 or not (kappa > 0.0 and mass > 0.0 and spacing > 0.0):
        raise ValueError("need force_0 >= 0 and positive kappa, mass and spacing")
    d0 = (force_0 / kappa) ** (2.0 / 3.0)
    k0 = 1.5 * kappa * math.sqrt(d0)
    c0 = spacing * math.sqrt(k0 / mass)
    if not speed > c0:
        raise ValueError(f"a solitary wave travels faster than the sound speed c_0 = {c0:.6g} (got {speed})")
    length = 32.0 if force_0 == 0.0 else max(32.0, 30.0 / math.sqrt(speed / c0 - 1.0))
    length = float(2 ** math.ceil(math.log2(length)))  # grains
    n = int(length) * int(points_per_grain)
    h = 1.0 / int(points_per_grain)
    xi = (np.arange(n) - n // 2) * h
    q = 2.0 * np.pi * np.fft.rfftfreq(n, d=h)
    s = 4.0 * np.sin(0.5 * q) ** 2
    w2 = mass * (speed / spacing) ** 2
    g = np.empty_like(q)
    g[1:] = s[1:] / (w2 * q[1:] ** 2 - k0 * s[1:])
    g[0] = 1.0 / (w2 - k0)  # s / q² -> 1
    gamma = 3.0 if force_0 == 0.0 else 2.0

    def nonlinear(y):
        y = np.maximum(y, -d0)  # an open contact carries no force
        return kappa * ((d0 + y) ** 1.5 - d0**1.5) - k0 * y

    scale = d0 if force_0 > 0.0 else (w2 / kappa) ** 2  # the overlap's size: its ξ⁰ balance
    y = scale * np.exp(-(xi / 2.0) ** 2)
    for it in range(1, 5001):
        gn = np.fft.irfft(g * np.fft.rfft(nonlinear(y)), n)
        m = float(np.dot(y, y) / np.dot(y, gn))
        new = m**gamma * gn
        err = float(np.max(np.abs(new - y)) / np.max(np.abs(new)))
        y = new
        if err < tol and abs(m - 1.0) < 1e-10:
            break
    else:
        raise ValueError(f"the solitary wave at V = {speed} did not converge (last change {err:.2g})")
    # the balls' velocity: y(ξ+1) = U(ξ) − U(ξ+1) for the displacement u_n = U(ξ), so U(ξ) = Σ_{k≥1} y(ξ+k)
    # and u̇ = −(V/a) U′(ξ) (the grid holds a whole number of points per grain)
    dy = np.fft.irfft(1j * q * np.fft.rfft(y), n)
    rows = dy.reshape(int(length), int(points_per_grain))  # row k: ξ in [k, k + 1) grains from the left end
    ahead = np.cumsum(rows[::-1], axis=0)[::-1] - rows  # Σ over the rows after each (no wrap past the end)
    velocity = -speed / spacing * ahead.ravel()
    return dict(xi=xi, y=y, velocity=velocity, force_max=float(kappa * (d0 + y.max()) ** 1.5), iterations=it)


def hertz_chain_solitary_speed(force_max: float, force_0: float, *, kappa: float, mass: float,
                               spacing: float) -> float:
    """The speed of the discrete Hertzian chain's exact solitary wave of crest force ``force_max``
    (:func:`hertz_chain_solitary_wave`, its crest force solved for by the secant method from the
    long-wave speed, :func:`hertz_solitary_speed`). Without precompression the chain has no force
    scale and V ∝ F_m^{1/6} exactly: one wave at the long-wave speed, rescaled."""
    if not force_max > force_0 >= 0.0:
        raise ValueError(f"need force_max > force_0 >= 0 (got {force_max}, {force_0})")
    kw = dict(kappa=kappa, mass=mass, spacing=spacing)
    v = hertz_solitary_speed(force_max, force_0, **kw)
    if force_0 == 0.0:
        return v * (force_max / hertz_chain_solitary_wave(v, 0.0, **kw)["force_max"]) ** (1.0 / 6.0)
    # ln F_m against ln(V − c_0): nearly straight from the linear limit to the uncompressed law
    c0 = spacing * math.sqrt(1.5 * kappa * (force_0 / kappa) ** (1.0 / 3.0) / mass)
    x_of = lambda speed: math.log(speed - c0)  # noqa: E731
    f = lambda x: math.log(hertz_chain_solitary_wave(c0 + math.exp(x), force_0, **kw)["force_max"]  # noqa: E731
                           - force_0) - math.log(force_max - force_0)
    x0, x1 = x_of(v), x_of(v) + 0.01
    f0, f1 = f(x0), f(x1)
    for _ in range(50):
        if f1 == f0:
            break
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        f1 = f(x1)
        if abs(x1 - x0) < 1e-12:
            break
    return c0 + math.exp(x1)
