"""Hertz normal law with Mindlin's tangential stiffness (docs/method.md §2): the default.

F_n = (4/3) sqrt(R12) E*12 n^(3/2), k_n = 2 sqrt(R12) E*12 n^(1/2),
energy (8/15) sqrt(R12) E*12 n^(5/2), k_t = 8 G*12 sqrt(R12 n); units of docs/units.md
(lengths in d, forces in E* d^2). The formulas themselves live in :mod:`granwave.contact`
(its callers predate the seam); this module binds them to the seam's signature
(``(overlap, root_r12 or r12, e12 or g12)``: the law has no constants of its own).
"""

from __future__ import annotations

import math

import numba

from .. import contact as C
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .kinds import NORMAL

KIND = NORMAL
NAME = "hertz"
#: one line for the option's help (``--contact-law``)
SUMMARY = "F_n ~ n^(3/2), Mindlin k_t"
#: what a pulse's signal file records of the law it ran (attribute ``contact_law``)
DESCRIPTION = "Hertz-Mindlin with Coulomb friction (granwave.contact), tangential history from the packing"
#: parameters of the law beyond the grain material (none: E* = 1 and nu set it)
PARAMETERS = ()
#: its kernels' constants (none)
CONSTANTS = ()
#: LAMMPS ``pair_style granular`` normal sub-model (granwave.interop.lammps)
LAMMPS_NORMAL = "hertz"
#: LAMMPS' coeff_restitution damping: x(e) = zeta times this (F_n / n = (2/3) k_n for Hertz)
LAMMPS_RESTITUTION_SCALE = math.sqrt(6.0 / 5.0)
#: (1/2) m v^2 = IMPACT_WORK x F delta: the work of the force up to delta, over F delta
IMPACT_WORK = 0.4
#: its numba functions in the order the GPU compiles them (each after those it calls)
DEVICE_FUNCTIONS = ("force", "stiffness", "energy", "tangential_stiffness", "unloading_scale", "step_stiffness")


def kernel_constants(values: dict) -> tuple:
    """The kernels' constants: none."""
    return ()


def lammps_words(values: dict, e12_pair: float, e12_wall: float, g12_pair: float, g12_wall: float) -> dict:
    """``pair_style granular``'s normal and tangential sub-models and stiffnesses (granwave units):
    ``hertz`` k_n = (4/3) E*12, ``mindlin_rescale`` k_t = 8 G*12."""
    return dict(kn_pair=4.0 / 3.0 * e12_pair, kn_wall=4.0 / 3.0 * e12_wall, kt_pair=8.0 * g12_pair,
                kt_wall=8.0 * g12_wall, normal=LAMMPS_NORMAL, tangential="mindlin_rescale")


@numba.njit(cache=True, inline="always")
def force(overlap, root_r12, e12):
    """F_n (E* d^2) at ``overlap`` (d) given sqrt(R12) (d^1/2) and E*12 (E*)."""
    return C.normal_force_root(overlap, root_r12, e12)


@numba.njit(cache=True, inline="always")
def stiffness(overlap, root_r12, e12):
    """k_n = dF_n/dn (E* d)."""
    return C.normal_stiffness_root(overlap, root_r12, e12)


@numba.njit(cache=True, inline="always")
def energy(overlap, r12, e12):
    """Elastic energy (E* d^3), whose derivative is F_n."""
    return C.normal_energy(overlap, r12, e12)


@numba.njit(cache=True, inline="always")
def tangential_stiffness(overlap, r12, g12):
    """Mindlin k_t = 8 G*12 sqrt(R12 n) (E* d)."""
    return C.tangential_stiffness(overlap, r12, g12)


@numba.njit(cache=True, inline="always")
def unloading_scale(overlap_old, overlap_new):
    """k_t(n_new) / k_t(n_old) = sqrt(n_new / n_old): the rescale of F_t on unloading."""
    return C.unloading_scale(overlap_old, overlap_new)


@numba.njit(cache=True, inline="always")
def step_stiffness(overlap, root_r12, e12):
    """The stiffness the time-step estimate takes (granwave.dem.time_step.stable_dt): k_n itself
    (one contact: the estimate takes the stiffness at the largest overlap of the packing, above
    that of most contacts)."""
    return stiffness(overlap, root_r12, e12)


def overlap_at_force(f: float, r12: float, e12: float) -> float:
    """The overlap (d) at which the contact carries the normal force ``f`` (E* d^2)."""
    return (f / C.normal_force(1.0, r12, e12)) ** (2.0 / 3.0)
