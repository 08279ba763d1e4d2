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
Hertz (docs/method.md §2), here a constant coefficient. Registered in
:mod:`granwave.contact_models.registry`.
"""

from __future__ import annotations

import numba

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .declare import Parameter
from .kinds import NORMAL

KIND = NORMAL
NAME = "harmonic"
SUMMARY = "linear spring F_n = k_n n, constant k_t = eta k_n; docs/method.md"
DESCRIPTION = ("harmonic: F_n = k_n n, k_n = harmonic_stiffness between two grains (twice that at a "
               "wall), constant k_t = eta k_n, with Coulomb friction (granwave.contact_models.harmonic), "
               "tangential history from the packing")
#: the law's parameter: k_n of a grain pair (the kernels' k is twice it)
PARAMETERS = (Parameter("harmonic_stiffness", 1.0, "E* d", "k_n of two grains under --contact-law harmonic "
                        "(a wall contact: twice it).", lo=0.0, lo_open=True),)
#: its kernels' constant: k = k_n / E*12
CONSTANTS = ("k",)
LAMMPS_NORMAL = "hooke"
#: LAMMPS' coeff_restitution damping of ``hooke``: c_n = 2 x(e) sqrt(m_eff k_n), so x(e) = zeta
LAMMPS_RESTITUTION_SCALE = 1.0
IMPACT_WORK = 0.5
#: contacts of a grain acting together in the time-step estimate (kernels.stable_dt): every
#: harmonic contact has the full k_n, where Hertz's estimate takes the stiffness at the largest
#: overlap, above that of most contacts. With one, a 100-grain 2D frictional packing (zeta 0.5,
#: seed 3) stalled at safety 0.05 (its rotations chattered) and converged at 0.04 and 0.03;
#: two step it as 0.035 would (docs/decisions/0013-contact-law-seam.md)
STEP_CONTACTS = 2
DEVICE_FUNCTIONS = ("force", "stiffness", "energy", "tangential_stiffness", "unloading_scale", "step_stiffness")


def kernel_constants(values: dict) -> tuple:
    """The kernels' k = k_n^pair / E*12^pair = 2 k_n^pair."""
    return (2.0 * float(values["harmonic_stiffness"]),)


def lammps_words(values: dict, e12_pair: float, e12_wall: float, g12_pair: float, g12_wall: float) -> dict:
    """``hooke`` k_n = k E*12 and ``tangential linear_history`` k_t = 4 G*12 k (granwave units)."""
    k = kernel_constants(values)[0]
    return dict(kn_pair=k * e12_pair, kn_wall=k * e12_wall, kt_pair=4.0 * g12_pair * k,
                kt_wall=4.0 * g12_wall * k, normal=LAMMPS_NORMAL, tangential="linear_history")


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
def unloading_scale(overlap_old, overlap_new, k):
    """k_t(n_new) / k_t(n_old) = 1 while touching; 0 once the contact opened."""
    return 1.0 if overlap_new > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def step_stiffness(overlap, root_r12, e12, k):
    """The stiffness the time-step estimate takes (granwave.dem.time_step.stable_dt): k_n times
    STEP_CONTACTS."""
    return STEP_CONTACTS * stiffness(overlap, root_r12, e12, k)


def overlap_at_force(f: float, r12: float, e12: float, k: float) -> float:
    """The overlap (d) at which the contact carries the normal force ``f`` (E* d^2)."""
    return f / (k * e12)
