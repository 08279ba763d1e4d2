"""Asperity-to-Hertz crossover normal law: a cone's F_n ~ n^2 below the overlap n*, Hertz above.

Goddard's picture of the low-pressure exponent (Proc. R. Soc. A 430, 105 (1990); docs/method.md
§2): at small loads a contact is carried by an asperity (:mod:`.cone`: contact radius ~ n, so
c ~ p^(1/4)); once it is flattened the grains' bodies touch as Hertz's spheres (c ~ p^(1/6)). With
n* = ``crossover_overlap`` (d) and s = n*/4:

    n <= n*:  F_n = B sqrt(R12) E*12 n^2,                 k_n = 2 B sqrt(R12) E*12 n,
    n >  n*:  F_n = (4/3) sqrt(R12) E*12 (n - s)^(3/2),   k_n = 2 sqrt(R12) E*12 (n - s)^(1/2),

B = (sqrt(3)/2) / sqrt(n*). The offset s and B are what make force and stiffness both
continuous at n* (two conditions on the two power laws): Hertz's body contact starts once the
asperity has taken up s. The contact radius a = k_n / (2 E*12) (B sqrt(R12) n below, sqrt(R12
(n - s)) above) is continuous too, and Mindlin's k_t = 8 G*12 a = eta k_n, with the unloading
rescale k_t(n_new) / k_t(n_old) of either branch. Below n* the asperity is a cone of slope
tan(beta) = (2/pi) / (B sqrt(R12)) (:mod:`.cone`'s law, its slope set by n* and the radius).
The crossover force F* = (sqrt(3)/2) sqrt(R12) E*12 n*^(3/2): a triangular lattice of unit balls
(contact force p / sqrt(3), R12 = 1/4, E*12 = 1/2) crosses over at p* = (3/8) n*^(3/2) (1.19e-5
at the default n* = 1e-3). Walls: E*12 = E*, R12 = R. Units of docs/units.md.
"""

from __future__ import annotations

import math

import numba

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .declare import Parameter
from .kinds import NORMAL

KIND = NORMAL
NAME = "cone_hertz"
SUMMARY = ("asperity (cone, F_n ~ n^2) below n* = --crossover-overlap, Hertz (n - n*/4)^(3/2) above, force and "
           "stiffness continuous; c ~ p^(1/4) then p^(1/6); docs/method.md")
DESCRIPTION = ("cone_hertz: conical asperity F_n ~ n^2 below crossover_overlap n*, Hertz F_n = (4/3) sqrt(R12) E*12 "
               "(n - n*/4)^(3/2) above, Mindlin k_t = 8 G*12 a, with Coulomb friction (granwave.contact_models."
               "cone_hertz), tangential history from the packing")
PARAMETERS = (Parameter("crossover_overlap", 1e-3, "d", "Overlap n* where --contact-law cone_hertz turns from the "
                        "asperity's F_n ~ n^2 to Hertz's (n - n*/4)^(3/2).", lo=0.0, lo_open=True, hi=0.1),)
#: its kernels' constants: n*, the offset s = n*/4 and B = (sqrt(3)/2) / sqrt(n*)
CONSTANTS = ("n_star", "shift", "b")
NO_LAMMPS = ("LAMMPS's granular normal models (hooke, hertz, hertz/material, dmt, jkr) have no asperity law "
             "turning into Hertz")
#: the work of the force up to n over F n in the asperity branch (where the preparation's impact
#: speed, set by forces of mass x tol, falls): that of F ~ n^2
IMPACT_WORK = 1.0 / 3.0
DEVICE_FUNCTIONS = ("radius_factor", "force", "stiffness", "energy", "tangential_stiffness", "unloading_scale",
                    "step_stiffness")


def kernel_constants(values: dict) -> tuple:
    """The kernels' (n*, s = n*/4, B = (sqrt(3)/2) / sqrt(n*))."""
    n = float(values["crossover_overlap"])
    return (n, 0.25 * n, 0.5 * math.sqrt(3.0) / math.sqrt(n))


@numba.njit(cache=True, inline="always")
def radius_factor(overlap, n_star, shift, b):
    """a / sqrt(R12): the contact radius per square root of the effective radius (d^1/2);
    zero without overlap."""
    if overlap <= 0.0:
        return 0.0
    if overlap <= n_star:
        return b * overlap
    return math.sqrt(overlap - shift)


@numba.njit(cache=True, inline="always")
def force(overlap, root_r12, e12, n_star, shift, b):
    """F_n (E* d^2): B sqrt(R12) E*12 n^2 up to n*, (4/3) sqrt(R12) E*12 (n - s)^(3/2) beyond."""
    if overlap <= 0.0:
        return 0.0
    if overlap <= n_star:
        return b * root_r12 * e12 * overlap * overlap
    u = overlap - shift
    return 4.0 / 3.0 * root_r12 * e12 * u * math.sqrt(u)


@numba.njit(cache=True, inline="always")
def stiffness(overlap, root_r12, e12, n_star, shift, b):
    """k_n = dF_n/dn = 2 sqrt(R12) E*12 a / sqrt(R12) (E* d)."""
    return 2.0 * root_r12 * e12 * radius_factor(overlap, n_star, shift, b)


@numba.njit(cache=True, inline="always")
def energy(overlap, r12, e12, n_star, shift, b):
    """Elastic energy (E* d^3), whose derivative is F_n: B sqrt(R12) E*12 n^3 / 3 up to n*, then
    that at n* plus (8/15) sqrt(R12) E*12 ((n - s)^(5/2) - (n* - s)^(5/2))."""
    if overlap <= 0.0:
        return 0.0
    root = math.sqrt(r12)
    if overlap <= n_star:
        return b * root * e12 * overlap ** 3 / 3.0
    return root * e12 * (b * n_star ** 3 / 3.0 + 8.0 / 15.0 * ((overlap - shift) ** 2.5 - (n_star - shift) ** 2.5))


@numba.njit(cache=True, inline="always")
def tangential_stiffness(overlap, r12, g12, n_star, shift, b):
    """Mindlin k_t = 8 G*12 a (E* d)."""
    return 8.0 * g12 * math.sqrt(r12) * radius_factor(overlap, n_star, shift, b)


@numba.njit(cache=True, inline="always")
def unloading_scale(overlap_old, overlap_new, n_star, shift, b):
    """k_t(n_new) / k_t(n_old) = a(n_new) / a(n_old) (the radius cancels); 0 once the contact opened."""
    old = radius_factor(overlap_old, n_star, shift, b)
    if overlap_new <= 0.0 or old <= 0.0:
        return 0.0
    return radius_factor(overlap_new, n_star, shift, b) / old


@numba.njit(cache=True, inline="always")
def step_stiffness(overlap, root_r12, e12, n_star, shift, b):
    """The stiffness the time-step estimate takes: k_n itself (it grows with the overlap in both
    branches, as Hertz's)."""
    return stiffness(overlap, root_r12, e12, n_star, shift, b)


def overlap_at_force(f: float, r12: float, e12: float, n_star: float, shift: float, b: float) -> float:
    """The overlap (d) at which the contact carries the normal force ``f`` (E* d^2)."""
    root = math.sqrt(r12)
    if f <= b * root * e12 * n_star * n_star:
        return math.sqrt(f / (b * root * e12))
    return shift + (f / (4.0 / 3.0 * root * e12)) ** (2.0 / 3.0)
