"""Rolling resistance: LAMMPS' spring-dashpot-slider model (``pair_style granular ... rolling sds``).

A contact carries a rolling displacement xi (length d, in the tangent plane; its history,
``HISTORY_WIDTH(dim)`` columns per contact after the tangential history). Per step, with the
unit normal n from grain i to j, the effective radius R12 (a wall contact: R_i) and the spins
w_i, w_j (docs/method.md, "Rolling resistance"):

- rolling velocity v_r = R12 (w_i - w_j) x n_L, n_L = -n (LAMMPS' normal, j -> i);
- xi carried into the new tangent plane (projected and rescaled to its length, when its normal
  part is not negligible: |xi.n| k_r > 1e-10 F_rcrit, as LAMMPS), then xi += v_r dt;
- the rolling force f_r = -k_r xi - gamma_r v_r, capped at F_rcrit = mu_r F_n (F_n the contact's
  elastic normal force, granwave's Coulomb limit for the tangential force too); at the cap xi is
  reset to -(F_rcrit f_r / |f_r| + gamma_r v_r) / k_r (the slider);
- the couple R12 n_L x f_r on i and its opposite on j (no force).

2D: spins about z, n in the plane: xi and f_r lie in the plane, the couple along z. The
parameters are ``PrepareParams.rolling_stiffness`` k_r (E* d), ``rolling_damping`` gamma_r
(d^2 sqrt(rho E*), force per velocity) and ``rolling_friction`` mu_r (dimensionless, a length
of mu_r R12 for the couple's cap). Off ('none') by default: the engines then skip it entirely.
Registered in :mod:`granwave.contact_models.registry` (kind :data:`granwave.contact_models.kinds.ROLLING`).
"""

from __future__ import annotations

import math

import numba

from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)
from .declare import Parameter
from .kinds import ROLLING

KIND = ROLLING
NAME = "sds"
SUMMARY = ("LAMMPS' spring-dashpot-slider: a couple from the relative rotation, spring k_r, dashpot gamma_r, "
           "capped at mu_r F_n R12; docs/method.md 'Rolling resistance'")
DESCRIPTION = "rolling resistance"
#: its parameters in PrepareParams and in the files' attributes
PARAMETERS = (
    Parameter("rolling_stiffness", 0.01, "E* d", "k_r of --rolling sds (a wall contact: the same).",
              lo=0.0, lo_open=True),
    Parameter("rolling_damping", 0.0, "d^2 sqrt(rho E*)", "gamma_r of --rolling sds (force per rolling velocity).",
              lo=0.0),
    Parameter("rolling_friction", 0.1, None, "mu_r of --rolling sds: the rolling force is capped at mu_r F_n.",
              lo=0.0),
)
#: its kernels' constants: k_r, gamma_r, mu_r
CONSTANTS = ("k", "gamma", "mu")
#: a couple needs the grains' rotations: refused without friction
NEEDS_FRICTION = True
#: LAMMPS' name of the model (``pair_coeff ... rolling sds k_r gamma_r mu_r``)
LAMMPS_ROLLING = "sds"
#: LAMMPS' threshold for carrying the history into a new tangent plane (GRAN_KERNEL_EPSILON)
FRAME_EPSILON = 1e-10
#: I / (m R^2) of a solid sphere (I = m d^2 / 10, in 2D too): the mode of :func:`step_mode`
SPHERE_INERTIA = 0.4
#: its numba functions in the order the GPU compiles them (each after those it calls)
DEVICE_FUNCTIONS = ("rolling_velocity", "in_plane", "couple", "spring_couple", "step_mode")


def history_width(dim: int) -> int:
    """History columns per contact (the rolling displacement, one per axis)."""
    return int(dim)


def kernel_constants(values: dict) -> tuple:
    """The kernels' constants (k_r, gamma_r, mu_r)."""
    return tuple(float(values[p.name]) for p in PARAMETERS)


def lammps_fragment(values: dict) -> str:
    """``rolling sds k_r gamma_r mu_r``: LAMMPS' own model, the same coefficients for pairs and walls
    (granwave's F_rcrit is mu_r times the elastic normal force, LAMMPS' the total one: the same at
    rest)."""
    k, gamma, mu = kernel_constants(values)
    return f"rolling {LAMMPS_ROLLING} {k:.17g} {gamma:.17g} {mu:.17g}"


def linear_blocks(blocks, values: dict, n, wall, r_i, r_j, dim: int, p: int) -> None:
    """Add the rolling spring's stiffness to the contacts' blocks (granwave.linear.assemble): couple
    R12^2 k_r P (theta_j - theta_i) on i and its opposite on j, P = I - n n on the rotations (2D:
    P_zz = 1), R12 = R_i R_j / (R_i + R_j) (a wall: R_i); ``p`` dofs per grain, its rotations after
    its ``dim`` translations. Its stored displacement's turning with the contact (a prestress term)
    is not included."""
    import numpy as np

    if p == dim:  # no rotations (frictionless): no couple
        return
    k_roll = float(values["rolling_stiffness"])
    m = len(n)
    n3 = np.zeros((m, 3))
    n3[:, :dim] = n
    proj3 = np.eye(3)[None] - n3[:, :, None] * n3[:, None, :]
    rot = proj3[:, 2:, 2:] if dim == 2 else proj3
    r12 = np.where(wall, r_i, r_i * r_j / (r_i + r_j))
    kr = (r12 * r12 * k_roll)[:, None, None] * rot
    ti, tj = slice(dim, p), slice(p + dim, 2 * p)
    blocks[:, ti, ti] += kr
    inner = ~wall
    blocks[inner, ti, tj] -= kr[inner]
    blocks[inner, tj, ti] -= kr[inner]
    blocks[inner, tj, tj] += kr[inner]


@numba.njit(cache=True, inline="always")
def rolling_velocity(nx, ny, nz, rx, ry, rz, r12):
    """v_r = R12 (w_i - w_j) x n_L with n_L = -n, i.e. R12 n x (w_i - w_j); (rx, ry, rz) = w_i - w_j."""
    return r12 * (ny * rz - nz * ry), r12 * (nz * rx - nx * rz), r12 * (nx * ry - ny * rx)


@numba.njit(cache=True, inline="always")
def in_plane(hx, hy, hz, nx, ny, nz):
    """xi projected on the plane normal to n and rescaled to its former length (zero if along n)."""
    dot = hx * nx + hy * ny + hz * nz
    old = math.sqrt(hx * hx + hy * hy + hz * hz)
    hx -= dot * nx
    hy -= dot * ny
    hz -= dot * nz
    new = math.sqrt(hx * hx + hy * hy + hz * hz)
    scale = old / new if new > 0.0 else 0.0
    return hx * scale, hy * scale, hz * scale


@numba.njit(cache=True, inline="always")
def couple(k, gamma, mu, nx, ny, nz, rx, ry, rz, r12, fel, hx, hy, hz, dt):
    """The couple (cx, cy, cz) on grain i (E* d^3) and the new rolling displacement (hx, hy, hz)
    of one contact: unit normal n (i -> j), (rx, ry, rz) = w_i - w_j, effective radius ``r12``,
    elastic normal force ``fel``, displacement ``h`` before the step, step ``dt`` (0: evaluated
    without advancing the history's increment)."""
    vx, vy, vz = rolling_velocity(nx, ny, nz, rx, ry, rz, r12)
    fcrit = mu * fel
    if abs(hx * nx + hy * ny + hz * nz) * k > FRAME_EPSILON * fcrit:
        hx, hy, hz = in_plane(hx, hy, hz, nx, ny, nz)
    hx += dt * vx
    hy += dt * vy
    hz += dt * vz
    fx = -k * hx - gamma * vx
    fy = -k * hy - gamma * vy
    fz = -k * hz - gamma * vz
    mag = math.sqrt(fx * fx + fy * fy + fz * fz)
    if mag > fcrit:
        if hx != 0.0 or hy != 0.0 or hz != 0.0:
            s = fcrit / mag
            fx *= s
            fy *= s
            fz *= s
            hx = -(fx + gamma * vx) / k
            hy = -(fy + gamma * vy) / k
            hz = -(fz + gamma * vz) / k
        else:
            fx = fy = fz = 0.0
    # R12 n_L x f_r = -R12 n x f_r
    return (-r12 * (ny * fz - nz * fy), -r12 * (nz * fx - nx * fz), -r12 * (nx * fy - ny * fx),
            hx, hy, hz)


@numba.njit(cache=True, inline="always")
def spring_couple(k, gamma, mu, nx, ny, nz, rx, ry, rz, r12, hx, hy, hz):
    """The couple on grain i of the rolling spring alone with its history frozen (the linearization's
    contract, granwave.dem.forces): the stored displacement h carried into the plane normal to n,
    plus R12 n x (theta_i - theta_j) for the rotations (rx, ry, rz) = theta_i - theta_j; no
    dashpot, no cap."""
    hx, hy, hz = in_plane(hx, hy, hz, nx, ny, nz)
    vx, vy, vz = rolling_velocity(nx, ny, nz, rx, ry, rz, r12)
    fx = -k * (hx + vx)
    fy = -k * (hy + vy)
    fz = -k * (hz + vz)
    return -r12 * (ny * fz - nz * fy), -r12 * (nz * fx - nx * fz), -r12 * (nx * fy - ny * fx)


@numba.njit(cache=True, inline="always")
def step_mode(k, gamma, mu, m_min):
    """(omega_r, damping ratio) of the rolling spring's mode for the time step
    (granwave.dem.time_step.stable_dt): the lightest grain turning on a wall's rolling spring,
    I theta'' = -R^2 (k_r theta + gamma_r theta'), so omega_r^2 = k_r / (0.4 m_min) and damping ratio
    gamma_r / (2 sqrt(0.4 m_min k_r)); twice k_r (a grain's contacts acting together, as for the
    harmonic law)."""
    k2 = 2.0 * k
    m = SPHERE_INERTIA * m_min
    return math.sqrt(k2 / m), gamma / (2.0 * math.sqrt(m * k2))
