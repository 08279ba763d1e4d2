"""Harmonic (linear spring) normal law, the standard model of the jamming literature.

F_n = k_n n, energy k_n n^2 / 2, k_n = k E*12 with the law's stiffness k (units E* d per
unit E*12, i.e. d). Between two grains of the same material E*12 = 1/2, so k_n = k / 2
(the ``harmonic_stiffness`` of :class:`granwave.params.PrepareParams` is that pair value,
k_n^pair, and the law's ``k`` is 2 k_n^pair); a rigid flat wall (E*12 = E*) gives
k_n = 2 k_n^pair, as a wall doubles E*12 for Hertz. Tangential: a constant
k_t = 4 G*12 k = eta k_n, eta = 2(1-nu)/(2-nu) the ratio k_t/k_n of Hertz-Mindlin
(1 for nu = 0), so friction and the linearization's tangential blocks mean the same
thing for both laws (LAMMPS: ``tangential linear_history`` with that k_t).
Constant k_t: the unloading rescale k_t(n_new)/k_t(n_old) is 1, and the incremental law
F_t += k_t ds is energy safe as it stands. Damping: c = 2 zeta sqrt(m_eff k_n), as for
Hertz (docs/method.md §2), here a constant coefficient.
"""

from __future__ import annotations

import numba

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

NAME = "harmonic"
CODE = 1
#: the law's parameter: k_n of a grain pair, in E* d (params.PrepareParams.harmonic_stiffness)
PARAMETERS = ("harmonic_stiffness",)
LAMMPS_NORMAL = "hooke"
IMPACT_WORK = 0.5
#: contacts of a grain acting together in the time-step estimate (kernels.stable_dt): every
#: harmonic contact has the full k_n, where Hertz's estimate takes the stiffness at the largest
#: overlap, above that of most contacts. With one, a 100-grain 2D frictional packing (zeta 0.5,
#: seed 3) stalled at safety 0.05 (its rotations chattered) and converged at 0.04 and 0.03;
#: two step it as 0.035 would (docs/decisions/0013-contact-law-seam.md)
STEP_CONTACTS = 2


@numba.njit(cache=True, inline="always")
def force(overlap, root_r12, e12, k):
    """F_n = k E*12 n (E* d^2); zero without overlap."""
    if overlap <= 0.0:
        return 0.0
    return k * e12 * overlap


@numba.njit(cache=True, inline="always")
def stiffness(overlap, root_r12, e12, k):
    """k_n = k E*12 (E* d); zero without overlap."""
    if overlap <= 0.0:
        return 0.0
    return k * e12


@numba.njit(cache=True, inline="always")
def energy(overlap, r12, e12, k):
    """k_n n^2 / 2 (E* d^3)."""
    if overlap <= 0.0:
        return 0.0
    return 0.5 * k * e12 * overlap * overlap


@numba.njit(cache=True, inline="always")
def tangential_stiffness(overlap, r12, g12, k):
    """k_t = 4 G*12 k = eta k_n (E* d), constant while the contact lasts."""
    if overlap <= 0.0:
        return 0.0
    return 4.0 * g12 * k


@numba.njit(cache=True, inline="always")
def unloading_scale(overlap_old, overlap_new):
    """k_t(n_new) / k_t(n_old) = 1 while touching; 0 once the contact opened."""
    return 1.0 if overlap_new > 0.0 else 0.0


def overlap_at_force(f: float, r12: float, e12: float, k: float) -> float:
    """The overlap (d) at which the contact carries the normal force ``f`` (E* d^2)."""
    return f / (k * e12)
