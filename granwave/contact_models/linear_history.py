"""Constant-stiffness tangential spring with a Coulomb slider: LAMMPS's ``tangential linear_history``.

The tangential force F_t is contact history, F_t += k_t Δs each step with a constant k_t (it does
not follow the overlap, unlike Mindlin's), then put back on the Coulomb cone |F_t| <= mu F_n (F_n
elastic). With k_t constant there is nothing to rescale on unloading. ``linear_history_stiffness``
is k_t of two grains (E* d); a rigid wall doubles it, as a wall doubles E*12 (k_t = 2 E*12 k).
``friction`` mu = 0: no tangential force (and no rotations). LAMMPS stores the tangential
displacement xi with F_t = -k_t xi: with k_t constant the same history.
"""

from __future__ import annotations

import numba

from .. import contact as C
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .declare import Parameter
from .kinds import TANGENTIAL

KIND = TANGENTIAL
NAME = "linear_history"
SUMMARY = "constant k_t = --linear-history-stiffness (a wall: twice it), no unloading rescale, Coulomb cap mu F_n"
DESCRIPTION = "constant-stiffness tangential spring with Coulomb friction (LAMMPS linear_history)"
PARAMETERS = (Parameter("linear_history_stiffness", 0.05, "E* d", "k_t of two grains under --tangential "
                        "linear_history (a wall contact: twice it).", lo=0.0, lo_open=True),)
#: its kernels' constants: friction, then k_t of a grain pair
CONSTANTS = ("friction", "kt")
DEVICE_FUNCTIONS = ("acts", "stiffness", "unloads", "increment", "step_ratio", "at_limit")


def kernel_constants(values: dict) -> tuple:
    """The kernels' (friction, k_t of a pair)."""
    return (float(values["friction"]), float(values["linear_history_stiffness"]))


@numba.njit(cache=True, inline="always")
def acts(friction, kt):
    """Whether there is a tangential force: friction > 0."""
    return friction > 0.0


@numba.njit(cache=True, inline="always")
def stiffness(kt_law, overlap, e12, friction, kt):
    """k_t = 2 E*12 kt (E* d): kt between grains (E*12 = 1/2), 2 kt at a rigid wall."""
    return 2.0 * e12 * kt


@numba.njit(cache=True, inline="always")
def unloads(overlap_old, overlap_new, rescale, friction, kt):
    """Never: a constant k_t has no unloading rescale."""
    return False


@numba.njit(cache=True, inline="always")
def increment(fx, fy, fz, sx, sy, sz, k, fel, friction, kt):
    """F_t + k Δs put back on the cone |F_t| <= friction ``fel``: (fx, fy, fz, slid)."""
    return C.increment_and_cap3(fx, fy, fz, sx, sy, sz, k, fel, friction)


@numba.njit(cache=True, inline="always")
def step_ratio(kn, m, poisson, friction, kt):
    """k_t / k_n of the contact that bounds the time step (``kn``: the normal law's step
    stiffness): a wall's k_t, 2 kt, counted twice (every contact of a grain has the full k_t,
    as the harmonic law counts its k_n)."""
    return 4.0 * kt / kn


@numba.njit(cache=True, inline="always")
def at_limit(fx, fy, fz, fel, tol, friction, kt):
    """Whether F_t sits on the slider's limit, |F_t| >= (1 - ``tol``) friction ``fel`` with ``fel`` > 0."""
    cap = friction * fel * (1.0 - tol)
    return fel > 0.0 and fx * fx + fy * fy + fz * fz >= cap * cap


def lammps_tangential(values: dict, words: dict, side: str, xgammat: float) -> str:
    """``tangential linear_history k_t xgammat mu`` (k_t of the ``side``: "pair" or "wall"), or
    ``tangential linear_nohistory 0 0`` without friction."""
    friction = float(values["friction"])
    if not friction > 0:
        return "tangential linear_nohistory 0 0"
    kt = float(values["linear_history_stiffness"]) * (2.0 if side == "wall" else 1.0)
    return f"tangential linear_history {kt:.17g} {xgammat:.17g} {friction:.17g}"


def lammps_stiffness_ratio(values: dict, words: dict) -> float | None:
    """k_t / k_n, the same for pairs and walls where the normal law's k_n is constant (LAMMPS's
    ``hooke``), else None (it changes with the overlap)."""
    if words["normal"] != "hooke":
        return None
    return float(values["linear_history_stiffness"]) / words["kn_pair"]
