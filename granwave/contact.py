"""The Hertz–Mindlin contact law with Coulomb friction and viscous damping (docs/method.md §2).

This is the one place the law is written: the DEM engine and the
linearization both call these functions. All are scalar ``numba`` kernels
(plus two tiny in-place vector helpers) so that the engine's loops inline them.

Units (docs/method.md §1): lengths in mean diameters, E* = E/(1-nu^2) = 1 per grain,
density 1. A wall is rigid and flat: pass ``inv_radius = 0`` and
``wall = True`` so that R12 = R_grain, E*12 = E*_grain, G*12 = G*_grain.

Unloading rule (docs/method.md §2)
-----------------------------------
The tangential force F_t is contact history, updated incrementally:

1. when the overlap *decreases* from n_old to n_new, F_t is first scaled by
   k_t(n_new)/k_t(n_old) = sqrt(n_new/n_old) (as LAMMPS' ``mindlin/rescale``);
   when it increases, F_t is left as it is;
2. then ΔF_t = k_t(n_new) Δs is added;
3. then F_t is put back on the Coulomb cone |F_t| <= mu F_n if it left it.

Why this creates no energy: take W_t = |F_t|^2 / (2 k_t) as the energy stored
in the tangential spring. Step 2 changes W_t by exactly the work F_t·Δs done
on the contact (to second order in the step). Step 1 on unloading multiplies
W_t by sqrt(n_new/n_old) < 1; on loading k_t grows with F_t fixed, so W_t
falls. Step 3 only lowers |F_t|. Hence over any path the work done on the
tangential spring is >= W_t(end) - W_t(start) >= -W_t(start): a closed loop of
loading and unloading can dissipate but never deliver more energy than the
spring held (tested in tests/test_contact.py). Without step 1, the classic
loop "shear at small n, load, shear back, unload" ends with a nonzero force
at zero displacement and can pump energy out (Elata & Berryman 1996).

Two unloading rules: ``rescale_on_unloading``
----------------------------------------------
Step 1 is an option of :func:`update_tangential` (engine option ``unloading``:
``"rescale"`` or ``"incremental"``).

- ``rescale`` (True, the default; used to **prepare** packings): as above, energy-safe
  for loops of any size.
- ``incremental`` (False; the default of the **nonlinear pulses**,
  :func:`granwave.dem.pulse.propagate_dem`): the plain incremental Mindlin law, steps
  2 and 3 only. Why: for a prestressed contact (stored F_t != 0) the rescale is a
  *first-order*, one-sided term ΔF_t = -F_t dn / (2 n) on unloading only, i.e. a
  stiffness of size up to (mu/3) k_n that the linearization around equilibrium
  (docs/method.md §5, frozen history: ``granwave.dem.forces.frozen_history_forces``, ``linearize``)
  does not have and cannot have (it is not differentiable). docs/method.md §11 requires the
  ζ = 0, small-amplitude DEM pulse to agree with the linear model; with the rescale
  a frictional packing's pulse was 16-96 % off at any amplitude (docs/damping.md),
  with the incremental law it converges to ``linearize(prestress=True)``.
  Energy: without step 1 a closed loop of amplitude a in (n, s) can deliver energy,
  but only at third order: the loop above delivers (k_t(n1) - k_t(n0)) s1^2 / 2
  ~ k_t' Δn Δs² / 2, i.e. C a^3 k_t n^2 for a loop of relative size a (measured
  0.25 a^3 from a prestressed contact, halving a divides it by 8; tests/test_contact.py)
  and leaves F_t shifted by k_t' Δn Δs (second order). For a pulse at EPS ~ 1e-3 of
  the overlap this is ~1e-10 of k_t n^2 per cycle: negligible, and far smaller than
  the first-order error the rescale makes. Preparation, where contacts load and
  unload by whole overlaps many times, keeps the energy-safe rescale.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from . import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

FOUR_THIRDS = 4.0 / 3.0

# Grain material: E* = 1 for every grain (docs/method.md §1).
YOUNG_STAR = 1.0


@numba.njit(cache=True, inline="always")
def shear_modulus_star(poisson: float) -> float:
    """Per-grain G* = E*(1-nu)/(4-2nu) in units of E* (docs/method.md §2)."""
    return YOUNG_STAR * (1.0 - poisson) / (4.0 - 2.0 * poisson)


@numba.njit(cache=True, inline="always")
def stiffness_ratio(poisson: float) -> float:
    """eta = k_t/k_n = 2(1-nu)/(2-nu): 1 for nu = 0, 2/3 for nu = 0.5."""
    return 2.0 * (1.0 - poisson) / (2.0 - poisson)


@numba.njit(cache=True, inline="always")
def effective_radius(inv_radius_i: float, inv_radius_j: float) -> float:
    """R12 = (1/R_i + 1/R_j)^-1; a wall has inv_radius 0."""
    return 1.0 / (inv_radius_i + inv_radius_j)


@numba.njit(cache=True, inline="always")
def effective_young(wall: bool) -> float:
    """E*12: 1/2 between two grains of the same material, E* against a rigid wall."""
    return YOUNG_STAR if wall else 0.5 * YOUNG_STAR


@numba.njit(cache=True, inline="always")
def effective_shear(poisson: float, wall: bool) -> float:
    """G*12: half the per-grain G* between grains, the full G* against a rigid wall."""
    g = shear_modulus_star(poisson)
    return g if wall else 0.5 * g


@numba.njit(cache=True, inline="always")
def normal_force(overlap: float, r12: float, e12: float) -> float:
    """Hertz force F_n = (4/3) sqrt(R12) E*12 n^(3/2); zero without overlap."""
    return normal_force_root(overlap, math.sqrt(r12), e12)


@numba.njit(cache=True, inline="always")
def normal_force_root(overlap: float, root_r12: float, e12: float) -> float:
    """:func:`normal_force` given sqrt(R12) (``root_r12``; the engines keep it per pair)."""
    if overlap <= 0.0:
        return 0.0
    return FOUR_THIRDS * root_r12 * e12 * overlap * math.sqrt(overlap)


@numba.njit(cache=True, inline="always")
def normal_energy(overlap: float, r12: float, e12: float) -> float:
    """Hertz elastic energy (8/15) sqrt(R12) E*12 n^(5/2), whose derivative is F_n."""
    if overlap <= 0.0:
        return 0.0
    return 0.5333333333333333 * math.sqrt(r12) * e12 * overlap * overlap * math.sqrt(overlap)


@numba.njit(cache=True, inline="always")
def normal_stiffness(overlap: float, r12: float, e12: float) -> float:
    """k_n = dF_n/dn = 2 sqrt(R12) E*12 n^(1/2)."""
    return normal_stiffness_root(overlap, math.sqrt(r12), e12)


@numba.njit(cache=True, inline="always")
def normal_stiffness_root(overlap: float, root_r12: float, e12: float) -> float:
    """:func:`normal_stiffness` given sqrt(R12)."""
    if overlap <= 0.0:
        return 0.0
    return 2.0 * root_r12 * e12 * math.sqrt(overlap)


@numba.njit(cache=True, inline="always")
def tangential_stiffness(overlap: float, r12: float, g12: float) -> float:
    """Mindlin k_t = 8 G*12 sqrt(R12 n)."""
    if overlap <= 0.0:
        return 0.0
    return 8.0 * g12 * math.sqrt(r12 * overlap)


@numba.njit(cache=True, inline="always")
def damping_coefficient(zeta: float, reduced_mass: float, stiffness: float) -> float:
    """Viscous coefficient c = 2 zeta sqrt(m_eff k): a fraction zeta of critical."""
    return 2.0 * zeta * math.sqrt(reduced_mass * stiffness)


@numba.njit(cache=True, inline="always")
def reduced_mass(mass_i: float, mass_j: float, wall: bool) -> float:
    """m_eff = m_i m_j / (m_i + m_j); the grain's own mass against a wall."""
    if wall:
        return mass_i
    return mass_i * mass_j / (mass_i + mass_j)


@numba.njit(cache=True, inline="always")
def total_normal_force(elastic: float, viscous: float) -> float:
    """Elastic plus viscous normal force (repulsive positive), never attractive."""
    f = elastic + viscous
    return f if f > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def project_tangential3(fx: float, fy: float, fz: float, nx: float, ny: float, nz: float):
    """Carry F_t = (fx, fy, fz) into the tangent plane of the unit normal n; returns it.

    The normal component is removed and the magnitude restored, so the frame
    rotation neither creates nor destroys tangential force. Scalar form (the DEM
    force loop keeps everything in registers); 2D passes fz = nz = 0, which leaves
    the 2D arithmetic unchanged.
    """
    fx, fy, fz, old2, new2 = tangential_part3(fx, fy, fz, nx, ny, nz)
    if new2 > 0.0:
        scale = math.sqrt(old2 / new2)
        fx *= scale
        fy *= scale
        fz *= scale
    return fx, fy, fz


@numba.njit(cache=True, inline="always")
def tangential_part3(fx: float, fy: float, fz: float, nx: float, ny: float, nz: float):
    """F_t without its component along the unit normal n, and |F_t|^2 before and after:
    (fx, fy, fz, old2, new2); :func:`project_tangential3` then restores the magnitude
    (the tile law of granwave.dem.pair_tile takes the root of old2 / new2 in a vector loop)."""
    dot = fx * nx + fy * ny + fz * nz
    old2 = fx * fx + fy * fy + fz * fz
    fx -= dot * nx
    fy -= dot * ny
    fz -= dot * nz
    return fx, fy, fz, old2, fx * fx + fy * fy + fz * fz


@numba.njit(cache=True, inline="always")
def update_tangential3(fx: float, fy: float, fz: float, sx: float, sy: float, sz: float,
                       overlap_old: float, overlap_new: float, kt_new: float, fn: float,
                       friction: float, rescale_on_unloading: bool):
    """Incremental Mindlin update of the tangential force (fx, fy, fz); returns (fx, fy, fz, slid).

    (sx, sy, sz) is the increment Δs of relative tangential displacement of the
    surfaces at the contact point (of j relative to i, so that the force on i
    grows along it), ``fn`` the elastic normal force magnitude. Applies the
    unloading rescale (only with ``rescale_on_unloading``: the preparation law;
    False is the plain incremental law of the pulses), the increment k_t Δs and
    the Coulomb cap (module docstring). ``slid`` is True when the contact slides.
    """
    if unloads(overlap_old, overlap_new, rescale_on_unloading):
        scale = unloading_scale(overlap_old, overlap_new)
        fx *= scale
        fy *= scale
        fz *= scale
    return increment_and_cap3(fx, fy, fz, sx, sy, sz, kt_new, fn, friction)


@numba.njit(cache=True, inline="always")
def unloads(overlap_old: float, overlap_new: float, rescale_on_unloading: bool) -> bool:
    """Whether step 1 of the update applies (module docstring): the rescale rule is on and
    the overlap fell."""
    return rescale_on_unloading and overlap_new < overlap_old and overlap_old > 0.0


@numba.njit(cache=True, inline="always")
def unloading_scale(overlap_old: float, overlap_new: float) -> float:
    """Step 1's factor k_t(n_new) / k_t(n_old) = sqrt(n_new / n_old); 0 once the contact opened."""
    return math.sqrt(overlap_new / overlap_old) if overlap_new > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def increment_and_cap3(fx: float, fy: float, fz: float, sx: float, sy: float, sz: float, kt_new: float,
                       fn: float, friction: float):
    """Steps 2 and 3 of the update (module docstring): F_t + k_t Δs, put back on the Coulomb
    cone |F_t| <= friction fn; returns (fx, fy, fz, slid)."""
    fx += kt_new * sx
    fy += kt_new * sy
    fz += kt_new * sz
    f2 = fx * fx + fy * fy + fz * fz
    cap = friction * fn
    if f2 > cap * cap:
        scale = cap / math.sqrt(f2) if f2 > 0.0 else 0.0
        return fx * scale, fy * scale, fz * scale, True
    return fx, fy, fz, False


@numba.njit(cache=True)
def project_tangential(ft: np.ndarray, normal: np.ndarray) -> None:
    """Array form of :func:`project_tangential3` (d = 2 or 3), in place."""
    three = ft.shape[0] == 3
    fx, fy, fz = project_tangential3(ft[0], ft[1], ft[2] if three else 0.0,
                                     normal[0], normal[1], normal[2] if three else 0.0)
    ft[0] = fx
    ft[1] = fy
    if three:
        ft[2] = fz


@numba.njit(cache=True)
def update_tangential(ft: np.ndarray, slip: np.ndarray, overlap_old: float, overlap_new: float,
                      kt_new: float, fn: float, friction: float, rescale_on_unloading: bool = True) -> bool:
    """Array form of :func:`update_tangential3` (d = 2 or 3): ``ft`` updated in place;
    returns True when the contact slides. ``rescale_on_unloading`` defaults to the
    preparation law."""
    three = ft.shape[0] == 3
    fx, fy, fz, slid = update_tangential3(ft[0], ft[1], ft[2] if three else 0.0,
                                          slip[0], slip[1], slip[2] if three else 0.0,
                                          overlap_old, overlap_new, kt_new, fn, friction,
                                          rescale_on_unloading)
    ft[0] = fx
    ft[1] = fy
    if three:
        ft[2] = fz
    return slid
