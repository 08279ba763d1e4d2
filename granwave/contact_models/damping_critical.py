"""Contact damping as a fraction of critical: the default damping law (docs/method.md §2).

A contact of stiffness k between masses of reduced mass m_eff gets the dashpot
c = 2 zeta sqrt(m_eff k): on the normal velocity with k = k_n (the total normal force never
attractive), on the tangential velocity with k = k_t while the contact sticks (not added to
the tangential history). ``damping`` = zeta in [0, 1]; 0: no dashpot (the engines skip its
terms). The formula itself is :func:`granwave.contact.damping_coefficient` (its callers predate
the parts); registered in :mod:`granwave.contact_models.registry`.
"""

from __future__ import annotations

import math

import numba

from .. import contact as C
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .kinds import DAMPING

KIND = DAMPING
NAME = "critical_fraction"
SUMMARY = "c = 2 zeta sqrt(m_eff k) on the normal and (sticking) tangential velocity, zeta = --damping"
DESCRIPTION = "contact damping, a fraction zeta of critical"
#: its own parameters beyond the kind's (damping: zeta here)
PARAMETERS = ()
#: its kernels' constant: the kind's damping (zeta), under its parameter's name
CONSTANTS = ("damping",)
#: its numba functions in the order the GPU compiles them (each after those it calls)
DEVICE_FUNCTIONS = ("acts", "coefficient", "step_ratio")


def kernel_constants(values: dict) -> tuple:
    """The kernels' constant: the damping zeta."""
    return (float(values["damping"]),)


@numba.njit(cache=True, inline="always")
def acts(damping):
    """Whether there is a dashpot: damping > 0."""
    return damping > 0.0


@numba.njit(cache=True, inline="always")
def coefficient(meff, k, overlap, damping):
    """c = 2 damping sqrt(m_eff k) (force per velocity, d^2 sqrt(rho E*)); ``overlap`` unused."""
    return C.damping_coefficient(damping, meff, k)


@numba.njit(cache=True, inline="always")
def step_ratio(k, m, damping):
    """The damping ratio of a spring ``k`` on a mass ``m`` with this dashpot: damping itself."""
    return damping


#: LAMMPS's damping sub-model with granwave's "never attractive" (``pair_style granular``)
LAMMPS_DAMPING = "coeff_restitution limit_damping"


def lammps_words(values: dict, scale: float, normal: str, kt_over_kn: float) -> dict:
    """LAMMPS's equivalent of c = 2 zeta sqrt(m_eff k): ``damping coeff_restitution`` with the
    restitution e whose x(e) = zeta ``scale`` (the normal law's ``LAMMPS_RESTITUTION_SCALE``;
    x(e) = -ln e / sqrt(pi^2 + ln^2 e)) and the tangential ratio xgammat = c_t / c_n =
    sqrt(k_t / k_n) (``kt_over_kn`` None: not constant, which only zeta = 0 can express); ValueError
    where no e < 1 gives it (``normal``: the normal law's LAMMPS name, for the message). The
    restitution is the normal model's damping number (``normal_damping``)."""
    damping = float(values["damping"])
    x = damping * scale
    if not (0.0 <= damping and x < 1.0):
        raise ValueError(f"contact damping {damping:g} cannot be expressed by LAMMPS' coeff_restitution "
                         f"damping of a {normal} contact (needs 0 <= zeta < {1.0 / scale:.4f})")
    if kt_over_kn is None and damping > 0.0:
        raise ValueError(f"contact damping {damping:g} cannot be expressed by LAMMPS' coeff_restitution damping "
                         "where k_t / k_n changes with the overlap (its tangential dashpot is a fixed fraction "
                         "of the normal one): only damping 0")
    e = math.exp(-math.pi * x / math.sqrt(1.0 - x * x))
    return dict(restitution=e, normal_damping=e, xgammat=math.sqrt(kt_over_kn) if kt_over_kn is not None else 0.0,
                damping_words=LAMMPS_DAMPING)
