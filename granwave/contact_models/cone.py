"""Conical-asperity normal law (Goddard 1990): F_n ~ n^2, so c ~ p^(1/4) (docs/method.md §2).

Real grains touch through surface asperities. Goddard (Proc. R. Soc. A 430, 105 (1990)) takes
the contact of a grain as a conical asperity tip, its flank at an angle beta to the contact
plane, pressed into the other grain's surface. Sneddon's cone indentation gives a contact radius
growing linearly with the overlap, a = A n with A = (2/pi) / tan(beta), and

    F_n = A E*12 n^2,  k_n = dF_n/dn = 2 E*12 a = 2 A E*12 n,  energy A E*12 n^3 / 3,

independent of the grains' radii (a cone has no length scale). Since k_n ~ F_n^(1/2), a network of
such contacts has moduli ~ p^(1/2) and sound speeds ~ p^(1/4), the exponent seen in experiments at
low pressure, against Hertz's p^(1/6). Tangential: Mindlin's k_t = 8 G*12 a = eta k_n (eta =
2(1-nu)/(2-nu), as for Hertz), so friction means the same as with Hertz; on unloading F_t is scaled
by k_t(n_new) / k_t(n_old) = n_new / n_old (the same rule as Hertz's, energy safe). A rigid flat
wall: E*12 = E*, G*12 = G* (twice a grain pair's). Parameter ``cone_slope`` = tan(beta)
(dimensionless; the kernels' constant is A). Units of docs/units.md (lengths d, forces E* d^2).
"""

from __future__ import annotations

import math

import numba

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .declare import Parameter
from .kinds import NORMAL

KIND = NORMAL
NAME = "cone"
SUMMARY = ("Goddard's conical asperity: F_n = (2/pi) E*12 n^2 / cone_slope, Mindlin k_t = eta k_n; c ~ p^(1/4); "
           "docs/method.md")
DESCRIPTION = ("cone: Goddard's conical asperity, F_n = (2/pi) E*12 n^2 / cone_slope, k_t = 8 G*12 a with a the "
               "contact radius, with Coulomb friction (granwave.contact_models.cone), tangential history from the "
               "packing")
PARAMETERS = (Parameter("cone_slope", 0.05, None, "tan(beta) of the asperity's flank under --contact-law cone (beta "
                        "its angle to the contact plane): F_n = (2/pi) E*12 n^2 / cone_slope.", lo=0.0, lo_open=True),)
#: its kernels' constant: A = a / n, the contact radius per overlap
CONSTANTS = ("a",)
NO_LAMMPS = "LAMMPS's granular normal models (hooke, hertz, hertz/material, dmt, jkr) have no F ~ n^2 law"
#: the work of the force up to n over F n: (A n^3 / 3) / (A n^3)
IMPACT_WORK = 1.0 / 3.0
DEVICE_FUNCTIONS = ("force", "stiffness", "energy", "tangential_stiffness", "unloading_scale", "step_stiffness")


def kernel_constants(values: dict) -> tuple:
    """The kernels' A = (2/pi) / cone_slope."""
    return (2.0 / math.pi / float(values["cone_slope"]),)


@numba.njit(cache=True, inline="always")
def force(overlap, root_r12, e12, a):
    """F_n = A E*12 n^2 (E* d^2); zero without overlap."""
    if overlap <= 0.0:
        return 0.0
    return a * e12 * overlap * overlap


@numba.njit(cache=True, inline="always")
def stiffness(overlap, root_r12, e12, a):
    """k_n = 2 A E*12 n (E* d)."""
    if overlap <= 0.0:
        return 0.0
    return 2.0 * a * e12 * overlap


@numba.njit(cache=True, inline="always")
def energy(overlap, r12, e12, a):
    """A E*12 n^3 / 3 (E* d^3), whose derivative is F_n."""
    if overlap <= 0.0:
        return 0.0
    return a * e12 * overlap * overlap * overlap / 3.0


@numba.njit(cache=True, inline="always")
def tangential_stiffness(overlap, r12, g12, a):
    """Mindlin k_t = 8 G*12 A n (E* d): 8 G*12 times the contact radius."""
    if overlap <= 0.0:
        return 0.0
    return 8.0 * g12 * a * overlap


@numba.njit(cache=True, inline="always")
def unloading_scale(overlap_old, overlap_new, a):
    """k_t(n_new) / k_t(n_old) = n_new / n_old; 0 once the contact opened."""
    if overlap_new <= 0.0 or overlap_old <= 0.0:
        return 0.0
    return overlap_new / overlap_old


@numba.njit(cache=True, inline="always")
def step_stiffness(overlap, root_r12, e12, a):
    """The stiffness the time-step estimate takes: k_n itself (it grows with the overlap, so the
    estimate's largest overlap gives the stiffest contact, as for Hertz)."""
    return stiffness(overlap, root_r12, e12, a)


def overlap_at_force(f: float, r12: float, e12: float, a: float) -> float:
    """The overlap (d) at which the contact carries the normal force ``f`` (E* d^2)."""
    return math.sqrt(f / (a * e12))
