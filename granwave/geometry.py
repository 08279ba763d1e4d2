"""Box geometry shared by the DEM engine and its users (docs/conventions.md).

The box is periodic along the lateral axes (lengths ``lateral``, all axes but
the last) and bounded along the last (vertical) axis by a rigid bottom wall
at 0 and a top wall (the piston) at height ``h``.

Conventions: the contact normal points from grain i towards grain j (nearest
periodic image); the bottom wall's normal is (0, ..., -1) and the top wall's
(0, ..., +1). Overlap with a wall is R_i minus the distance to its plane; the
contact point of a wall contact lies on the wall plane (arm a_i = R_i - delta),
that of a grain pair at a_i = R_i - delta/2 from the centre of i.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .model import BOTTOM_WALL, TOP_WALL  # noqa: F401  (re-exported: -1, -2)
from . import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)

# Random close packing fractions used only to size the box before a run
# (the final height is whatever the piston finds).
EXPECTED_SOLID_FRACTION_2D = 0.82  # disks, area fraction
EXPECTED_SOLID_FRACTION_3D = 0.63  # spheres, volume fraction


@numba.njit(cache=True, inline="always")
def nearest_image(x: float, length: float) -> float:
    """Lateral separation ``x`` folded to the nearest periodic image.

    Valid for |x| < 1.5 length, which holds because the engine keeps positions in
    [0, length) (:func:`fold_into_box` after every drift).
    """
    if x > 0.5 * length:
        return x - length
    if x < -0.5 * length:
        return x + length
    return x


@numba.njit(cache=True, inline="always")
def fold_into_box(x: float, length: float) -> float:
    """Lateral coordinate ``x`` in [-length, 2 length) folded into [0, length).

    The engine folds each coordinate at the step it leaves the box, never at a
    neighbour-list rebuild: so the bits of a run do not depend on when the list is
    rebuilt (hence not on the skin). A fold down (x - length, x >= length) is
    exact; a fold up may round x + length to length, which is taken as 0.
    """
    if x < 0.0:
        x += length
        if x >= length:
            x = 0.0
    elif x >= length:
        x -= length
    return x


@numba.njit(cache=True, inline="always")
def periodic_distance2(a: np.ndarray, ia: int, b: np.ndarray, ib: int, lateral: np.ndarray) -> float:
    """|a[ia] - b[ib]|^2 with every lateral component folded to its nearest periodic image."""
    d = a.shape[1]
    r2 = 0.0
    for k in range(d):
        x = a[ia, k] - b[ib, k]
        if k < d - 1:
            x = nearest_image(x, lateral[k])
        r2 += x * x
    return r2


def wrap(position: np.ndarray, lateral: np.ndarray) -> np.ndarray:
    """Positions with every lateral coordinate folded into [0, L) (a copy)."""
    out = np.array(position, dtype=float, copy=True)
    d = out.shape[1]
    for a in range(d - 1):
        out[:, a] = np.mod(out[:, a], lateral[a])
    return out


def cube(x) -> np.ndarray:
    """x^3 as two products, the same bits on every machine. numpy's power for exponents other
    than 2 (like its exp, log, cbrt) runs code chosen for the CPU: with AVX-512 it differs from
    AVX2 in the last bit of some elements, and through the masses that made every packing's bits
    depend on the machine that prepared it (docs/dem.md "The same bits on every machine").
    Products are correctly rounded on every CPU."""
    x = np.asarray(x, dtype=float)
    return x * x * x


def grain_mass(radius: np.ndarray) -> np.ndarray:
    """Mass of a sphere of density 1: m = pi d^3 / 6 (docs/method.md §1), in rho d^3."""
    return np.pi * cube(2.0 * np.asarray(radius)) / 6.0


def grain_inertia(radius: np.ndarray) -> np.ndarray:
    """Moment of inertia of a solid sphere, I = m d^2 / 10, in rho d^5."""
    d = 2.0 * np.asarray(radius)
    return grain_mass(radius) * (d * d) / 10.0


def n_rotations(dim: int, friction: float) -> int:
    """Rotational dofs per grain: none without friction or in 1D, 1 (about z) in 2D, 3 in 3D."""
    if friction <= 0.0 or dim == 1:
        return 0
    return 1 if dim == 2 else 3


def wall_area(lateral: np.ndarray) -> float:
    """Area on which the piston pressure acts: L1 x (one diameter) in 2D, L1 L2 in 3D.

    docs/method.md §1: a 2D pressure is a force per (wall length x one diameter).
    """
    lateral = np.atleast_1d(np.asarray(lateral, dtype=float))
    return float(np.prod(lateral)) if len(lateral) > 1 else float(lateral[0]) * 1.0


def grain_measure(radius: np.ndarray, dim: int) -> np.ndarray:
    """Area (2D: disk cross-section) or volume (3D) of each grain."""
    radius = np.asarray(radius, dtype=float)
    return np.pi * (radius * radius) if dim == 2 else 4.0 / 3.0 * np.pi * cube(radius)


def lateral_size(radius: np.ndarray, dim: int, aspect: float) -> float:
    """Periodic width so that the final packing has height/width about ``aspect``.

    Uses the expected random-close-packing fraction (0.82 for disks, 0.63 for
    spheres); e.g. 600 grains with diameters in [0.8, 1.2] give a width of 24.1.
    """
    phi = EXPECTED_SOLID_FRACTION_2D if dim == 2 else EXPECTED_SOLID_FRACTION_3D
    measure = float(np.sum(grain_measure(radius, dim))) / phi
    # 2D: W * H = measure, H = aspect W; 3D: W^2 H = measure.
    return math.sqrt(measure / aspect) if dim == 2 else (measure / aspect) ** (1.0 / 3.0)
