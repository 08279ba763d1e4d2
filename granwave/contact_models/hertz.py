"""Hertz normal law with Mindlin's tangential stiffness (docs/method.md §2): the default.

F_n = (4/3) sqrt(R12) E*12 n^(3/2), k_n = 2 sqrt(R12) E*12 n^(1/2),
energy (8/15) sqrt(R12) E*12 n^(5/2), k_t = 8 G*12 sqrt(R12 n); units of docs/units.md
(lengths in d, forces in E* d^2). The formulas themselves live in :mod:`granwave.contact`
(its callers predate the seam); this module binds them to the seam's signature
(``(overlap, root_r12 or r12, e12 or g12, k)``, ``k`` unused here).
"""

from __future__ import annotations

import math

import numba

from .. import contact as C
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

NAME = "hertz"
#: the law's integer code in :class:`granwave.contact_models.ContactModel` (registry order)
CODE = 0
#: parameters of the law beyond the grain material (none: E* = 1 and nu set it)
PARAMETERS = ()
#: LAMMPS ``pair_style granular`` normal sub-model (granwave.interop.lammps)
LAMMPS_NORMAL = "hertz"
#: (1/2) m v^2 = IMPACT_WORK x F delta: the work of the force up to delta, over F delta
IMPACT_WORK = 0.4
#: contacts of a grain at the estimated stiffness that the time-step estimate assumes act together
#: (kernels.stable_dt): one, the stiffness being that at the largest overlap of the packing
STEP_CONTACTS = 1


@numba.njit(cache=True, inline="always")
def force(overlap, root_r12, e12, k):
    """F_n (E* d^2) at ``overlap`` (d) given sqrt(R12) (d^1/2) and E*12 (E*)."""
    return C.normal_force_root(overlap, root_r12, e12)


@numba.njit(cache=True, inline="always")
def stiffness(overlap, root_r12, e12, k):
    """k_n = dF_n/dn (E* d)."""
    return C.normal_stiffness_root(overlap, root_r12, e12)


@numba.njit(cache=True, inline="always")
def energy(overlap, r12, e12, k):
    """Elastic energy (E* d^3), whose derivative is F_n."""
    return C.normal_energy(overlap, r12, e12)


@numba.njit(cache=True, inline="always")
def tangential_stiffness(overlap, r12, g12, k):
    """Mindlin k_t = 8 G*12 sqrt(R12 n) (E* d)."""
    return C.tangential_stiffness(overlap, r12, g12)


@numba.njit(cache=True, inline="always")
def unloading_scale(overlap_old, overlap_new):
    """k_t(n_new) / k_t(n_old) = sqrt(n_new / n_old): the rescale of F_t on unloading."""
    return C.unloading_scale(overlap_old, overlap_new)


def overlap_at_force(f: float, r12: float, e12: float, k: float) -> float:
    """The overlap (d) at which the contact carries the normal force ``f`` (E* d^2)."""
    return (f / C.normal_force(1.0, r12, e12)) ** (2.0 / 3.0)
