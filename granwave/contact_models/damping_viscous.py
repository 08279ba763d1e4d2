"""Viscous contact damping with a constant coefficient: LAMMPS's ``damping velocity``.

A touching contact gets the dashpot c = ``viscous_damping`` (force per velocity, d^2 sqrt(rho E*)),
whatever its masses and stiffness: on the normal velocity (the total normal force never
attractive) and on the tangential velocity while the contact sticks (not added to the tangential
history), as the default law's dashpots act. For a linear spring k on a mass m that is the
damping ratio c / (2 sqrt(m k)); for Hertz the ratio falls as the contact stiffens. 0: no dashpot.
The kind's ``damping`` (zeta) is not used.
"""

from __future__ import annotations

import math

import numba

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .declare import Parameter
from .kinds import DAMPING

KIND = DAMPING
NAME = "constant_viscous"
SUMMARY = "constant c = --viscous-damping on the normal and (sticking) tangential velocity (LAMMPS velocity)"
DESCRIPTION = "contact damping with a constant viscous coefficient"
PARAMETERS = (Parameter("viscous_damping", 0.05, "d^2 sqrt(rho E*)", "c of --damping-law constant_viscous: the dashpot's "
                        "force per velocity, normal and tangential.", lo=0.0),)
#: its kernels' constant: c
CONSTANTS = ("c",)
DEVICE_FUNCTIONS = ("acts", "coefficient", "step_ratio")


def kernel_constants(values: dict) -> tuple:
    """The kernels' constant c."""
    return (float(values["viscous_damping"]),)


@numba.njit(cache=True, inline="always")
def acts(c):
    """Whether there is a dashpot: c > 0."""
    return c > 0.0


@numba.njit(cache=True, inline="always")
def coefficient(meff, k, overlap, c):
    """c itself (d^2 sqrt(rho E*))."""
    return c


@numba.njit(cache=True, inline="always")
def step_ratio(k, m, c):
    """The damping ratio c / (2 sqrt(m k)) of a spring ``k`` on a mass ``m``."""
    return c / (2.0 * math.sqrt(m * k))


def lammps_words(values: dict, scale: float, normal: str, kt_over_kn) -> dict:
    """``damping velocity``: the normal model's damping number is c itself; the tangential dashpot is
    the same c (xgammat 1); ``limit_damping``: never attractive, as granwave."""
    return dict(normal_damping=float(values["viscous_damping"]), xgammat=1.0,
                damping_words="velocity limit_damping")
