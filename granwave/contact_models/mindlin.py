"""Mindlin's tangential spring with a Coulomb slider: the default tangential law (docs/method.md §2).

The tangential force F_t is contact history, updated incrementally each step (the steps of
:func:`granwave.contact.update_tangential3`, whose module docstring shows why they create no
energy): on unloading (the overlap fell, with the engine's unloading rule ``rescale``) F_t is
first scaled by the normal law's k_t(n_new) / k_t(n_old) (LAMMPS's ``mindlin_rescale``; for
Hertz sqrt(n_new / n_old), 1 for the harmonic law's constant k_t); then F_t += k_t Δs with the
normal law's k_t (Hertz: 8 G*12 sqrt(R12 n); harmonic: eta k_n); then F_t is put back on the
Coulomb cone |F_t| <= mu F_n (F_n elastic). ``friction`` mu = 0: no tangential force at all (and
no rotations: a frictionless packing). The formulas themselves are :mod:`granwave.contact`'s;
registered in :mod:`granwave.contact_models.registry`.
"""

from __future__ import annotations

import numba

from .. import contact as C
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .kinds import TANGENTIAL

KIND = TANGENTIAL
NAME = "mindlin"
SUMMARY = "the normal law's k_t (Hertz: Mindlin 8 G*12 sqrt(R12 n)), rescaled on unloading, Coulomb cap mu F_n"
DESCRIPTION = "Mindlin tangential spring with Coulomb friction"
#: its own parameters beyond the kind's (friction, poisson)
PARAMETERS = ()
#: its kernels' constant: the kind's friction (mu), under its parameter's name
CONSTANTS = ("friction",)
#: its numba functions in the order the GPU compiles them (each after those it calls)
DEVICE_FUNCTIONS = ("acts", "stiffness", "unloads", "increment", "step_ratio", "at_limit")


def kernel_constants(values: dict) -> tuple:
    """The kernels' constant mu."""
    return (float(values["friction"]),)


@numba.njit(cache=True, inline="always")
def acts(friction):
    """Whether there is a tangential force: friction > 0."""
    return friction > 0.0


@numba.njit(cache=True, inline="always")
def stiffness(kt_law, overlap, e12, friction):
    """k_t: the normal law's own (``kt_law``, E* d)."""
    return kt_law


@numba.njit(cache=True, inline="always")
def unloads(overlap_old, overlap_new, rescale, friction):
    """Whether F_t is rescaled first: the rescale rule is on and the overlap fell."""
    return C.unloads(overlap_old, overlap_new, rescale)


@numba.njit(cache=True, inline="always")
def increment(fx, fy, fz, sx, sy, sz, kt, fel, friction):
    """F_t + k_t Δs put back on the cone |F_t| <= friction ``fel``: (fx, fy, fz, slid)."""
    return C.increment_and_cap3(fx, fy, fz, sx, sy, sz, kt, fel, friction)


@numba.njit(cache=True, inline="always")
def step_ratio(kn, m, poisson, friction):
    """k_t / k_n = eta = 2(1-nu)/(2-nu) at any stiffness ``kn`` and mass ``m``: the normal laws'
    own ratio (Hertz: Mindlin's 8 G*12 over 2 E*12 at any overlap; harmonic: k_t = eta k_n)."""
    return C.stiffness_ratio(poisson)


@numba.njit(cache=True, inline="always")
def at_limit(fx, fy, fz, fel, tol, friction):
    """Whether F_t sits on the slider's limit, |F_t| >= (1 - ``tol``) friction ``fel`` with ``fel`` > 0
    (a sliding contact sits exactly on the Coulomb cone, a sticking one inside it; the nonlinear
    pulse's classification of sliding contacts)."""
    cap = friction * fel * (1.0 - tol)
    return fel > 0.0 and fx * fx + fy * fy + fz * fz >= cap * cap


def lammps_tangential(values: dict, words: dict, side: str, xgammat: float) -> str:
    """``tangential WORD k_t xgammat mu`` of ``pair_style granular`` with the normal law's LAMMPS
    tangential model and stiffness (``words``: its LAMMPS words, e.g. ``mindlin_rescale`` for Hertz;
    ``side``: "pair" or "wall"), or ``tangential linear_nohistory 0 0`` without friction."""
    friction = float(values["friction"])
    if not friction > 0:
        return "tangential linear_nohistory 0 0"
    return f"tangential {words['tangential']} {words['kt_' + side]:.17g} {xgammat:.17g} {friction:.17g}"


def lammps_stiffness_ratio(values: dict, words: dict) -> float:
    """k_t / k_n of every contact (the dashpots' ratio LAMMPS needs): eta = 2(1-nu)/(2-nu)."""
    return C.stiffness_ratio(float(values["poisson"]))
