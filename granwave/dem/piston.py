"""The piston (top wall) of the DEM engine: its acceleration, kicks and the grains' force on it."""

from __future__ import annotations

import numba
import numpy as np

from .blocks import G_NTOP, block_bounds
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


@numba.njit(cache=True)
def piston_acceleration(piston, gamma):
    """(contact force up - p A down - gamma M v) / M; zero for a fixed wall (mass inf)."""
    m = piston.mass
    if not (m < np.inf):
        return 0.0
    return (piston.f_con - piston.f_ext) / m - gamma * piston.v


@numba.njit(cache=True, inline="always")
def piston_half_kick(piston, dt):
    """Velocity Verlet's half kick of a moving piston (none for a fixed wall, mass inf)."""
    if piston.mass < np.inf:
        piston.v += 0.5 * dt * piston.a


@numba.njit(cache=True, inline="always")
def piston_kick_drift(piston, dt):
    """The first half kick and the drift of a moving piston (none for a fixed wall)."""
    if piston.mass < np.inf:
        piston.v += 0.5 * dt * piston.a
        piston.h += dt * piston.v


@numba.njit(cache=True, inline="always")
def piston_contact_force(blk_g, top_f, n, nblk):
    """The grains' force on the piston from the blocks' top-wall forces (``top_f`` from each
    block's first grain, ``blk_g[:, G_NTOP]`` of them), summed in grain order: the one-thread
    loop's sum."""
    f = 0.0
    for b in range(nblk):
        b0 = block_bounds(b, n, nblk)[0]
        for c in range(int(blk_g[b, G_NTOP])):
            f -= top_f[b0 + c]
    return f


@numba.njit(cache=True, inline="always")
def copy_piston(dst, src):
    """Every field of the piston record ``src`` into the record ``dst`` (layout.PISTON)."""
    dst.h = src.h
    dst.v = src.v
    dst.a = src.a
    dst.mass = src.mass
    dst.f_ext = src.f_ext
    dst.f_con = src.f_con
