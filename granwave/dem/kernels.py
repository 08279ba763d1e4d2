"""Numba kernels of the DEM engine: per-contact law application and force loops.

Pure functions over float64 arrays (int64 indices); one code path for 2D and
3D (the dimension is read from array shapes) and for frictionless runs (the
rotation arrays then have zero columns), so each kernel compiles once.

Every piece of the contact law is called from :mod:`granwave.contact`; the
geometry follows docs/conventions.md. :func:`contact_force3` is the single
per-contact routine (scalars in and out): the engine's pair loops call it with
velocities and the real Coulomb law; :func:`granwave.dem.forces.frozen_history_forces`
calls its array form :func:`contact_force` with displacements (``dt = 1``), no
unloading rescale and no Coulomb cap.

Parallel and deterministic (docs/dem.md, "Parallel engine"): the grains are split into
contiguous index blocks (:func:`block_count`, of N and the thread count) and a step is two
parallel passes over the blocks. :func:`_incoming_pass` computes, for each block, its
incoming pairs (k, g): g in the block, k below it, whose row belongs to an earlier block;
:func:`_row_pass` then runs the one-thread pair loop (dem/serial.py) over each block's own
rows, taking the forces of its rows' boundary pairs from the first pass, followed by walls,
damping and kicks. The pair list is lexicographic, so a grain's terms in the one-thread loop
are its incoming pairs (increasing k), then its pairs inside the block, then its row's pairs
beyond the block, then its walls: both passes add them in that order and every grain's force
is bit for bit the one-thread loop's, for any thread count. Maxima and sums over grains are
taken per block. No two threads write the same memory, apart from the blocks' taken flags
(:func:`take_block`, integer atomics that only decide which thread computes a block); no
floating-point atomics.

Layout of the small parameter arrays (indices below):
``fpar``: dt, zeta, mu, poisson, background damping rate, skin, dt safety,
overlap floor for the time step, acceleration tol, velocity tol, largest
radius, smallest mass, last max speed, unloading rule (1: rescale F_t on
unloading, 0: plain incremental; contact.update_tangential), piston height when the wall
list was made (:func:`wall_list`), smallest and largest skin (an adaptive skin when they
differ: :func:`next_skin`), the normal law's code and stiffness k (granwave.contact_models,
:func:`law_of`); ``ipar``: pairs listed, steps asked, steps done, steps between
checks, adaptive dt, rebuilds, sizes a rebuild needs (pairs, width), step of the last
rebuild, whether plain steps run in a team of threads (1: yes, 0: no, -1: a team did not
start; :func:`_team_steps`), steps run so far in teams; ``piston``: height, velocity,
acceleration, mass (inf = fixed wall), downward force p*A, contact force.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .. import contact as C
from .. import contact_models as CM
from .. import team
from .. import threads as _threads  # noqa: F401  (selects the threading layer first)
from ..geometry import fold_into_box, nearest_image, periodic_distance2
from . import neighbours
from . import pair_tile as PT
from .mean_flow import M_GAMMA_M, add_slab_damping, slab_means
from .. import kernel_cache  # noqa: F401  (cached kernels stamped with the whole package's source)


# fpar indices
F_DT, F_ZETA, F_MU, F_POISSON, F_GAMMA, F_SKIN, F_SAFETY, F_DFLOOR, F_TOLA, F_TOLV, F_RMAX, F_MMIN, \
    F_VMAX, F_RESCALE, F_WALLH, F_SKIN_MIN, F_SKIN_MAX, F_LAW, F_KLAW = range(19)
N_FPAR = 19
# piston indices
P_H, P_V, P_A, P_MASS, P_FEXT, P_FCON = range(6)
N_PISTON = 6
# ipar indices
I_NPAIRS, I_NSTEPS, I_STEPS, I_CHECK, I_ADAPTIVE, I_REBUILDS, I_NEEDED, I_WIDTH, I_BUILT, I_TEAM, \
    I_TEAMSTEPS = range(11)
N_IPAR = 11
# out (statistics) indices
O_AMAX, O_ALPHAMAX, O_APISTON, O_VMAX, O_WMAX, O_KIN, O_NTOP, O_DMAX, O_NCONTACT = range(9)
N_OUT = 9


@numba.njit(cache=True, inline="always")
def rotation_velocity(vrel, n, omega, i, j, ai, aj):
    """Subtract (a_i w_i + a_j w_j) x n from ``vrel`` (j < 0: a wall, no rotation).

    The contact-point velocity of j relative to i (conventions) is
    v_j - v_i + w_j x (-a_j n) - w_i x (a_i n) = v_j - v_i - (a_i w_i + a_j w_j) x n.
    ``omega`` rows hold w (2D: one column, the z component; 3D: three).
    """
    r = omega.shape[1]
    if r == 1:
        w = ai * omega[i, 0]
        if j >= 0:
            w += aj * omega[j, 0]
        # w e_z x n = w (-n_y, n_x)
        vrel[0] += w * n[1]
        vrel[1] -= w * n[0]
    elif r == 3:
        w0 = ai * omega[i, 0]
        w1 = ai * omega[i, 1]
        w2 = ai * omega[i, 2]
        if j >= 0:
            w0 += aj * omega[j, 0]
            w1 += aj * omega[j, 1]
            w2 += aj * omega[j, 2]
        vrel[0] -= w1 * n[2] - w2 * n[1]
        vrel[1] -= w2 * n[0] - w0 * n[2]
        vrel[2] -= w0 * n[1] - w1 * n[0]


@numba.njit(cache=True, inline="always")
def add_torque(torque, k, arm, n, f):
    """torque[k] += (arm n) x f (only the tangential part of f contributes)."""
    r = torque.shape[1]
    if r == 1:
        torque[k, 0] += arm * (n[0] * f[1] - n[1] * f[0])
    elif r == 3:
        torque[k, 0] += arm * (n[1] * f[2] - n[2] * f[1])
        torque[k, 1] += arm * (n[2] * f[0] - n[0] * f[2])
        torque[k, 2] += arm * (n[0] * f[1] - n[1] * f[0])


@numba.njit(cache=True, inline="always")
def contact_force3(nx, ny, nz, delta, r12, root_r12, e12, g12, meff, vx, vy, vz, hx, hy, hz, overlap_old, dt,
                   zeta, mu, rescale, law):
    """Force (fx, fy, fz) on i from one contact (the normal law of ``law``, Mindlin-type tangential
    spring with Coulomb friction, damping; docs/method.md §2); returns it and the elastic normal
    force. The single per-contact routine (scalar form).

    Three components always (2D: the third is 0, and adding zeros leaves the 2D
    arithmetic unchanged). (nx, ny, nz) unit normal i -> j, ``delta`` > 0 the overlap,
    (vx, vy, vz) the contact-point velocity of j relative to i, (hx, hy, hz) the
    tangential history F_t, ``overlap_old`` the overlap when it was last updated, ``root_r12``
    sqrt(R12) (kept per pair by the engines: a square root less per contact and step).
    Returns (fx, fy, fz, elastic normal force, new history hx, hy, hz). Normal: the law's F_n plus viscous c_n = 2 zeta sqrt(m_eff k_n) on
    the normal velocity, total never attractive. Tangential (mu > 0): ``ft`` carried into
    the new tangent plane (contact.project_tangential), then contact.update_tangential
    with slip = tangential velocity * dt and its unloading rescale when ``rescale``
    (contact.py docstring: preparation True, pulses False); a viscous part c_t v_t is added to the force
    (not to the history) while the contact sticks. ``law``: the contact model
    (:class:`granwave.contact_models.ContactModel`) whose normal law gives F_n, k_n, k_t and
    the unloading factor.
    """
    fel = CM.law_force(law, delta, root_r12, e12)
    vn = vx * nx + vy * ny + vz * nz
    fn = fel
    if zeta > 0.0:
        kn = CM.law_stiffness(law, delta, root_r12, e12)
        # approaching (vn < 0) gives a repulsive viscous force
        fn = C.total_normal_force(fel, -C.damping_coefficient(zeta, meff, kn) * vn)
    if mu > 0.0:
        tx = vx - vn * nx
        ty = vy - vn * ny
        tz = vz - vn * nz
        # Scalar forms of the law (contact.py): the history stays in registers.
        gx, gy, gz = C.project_tangential3(hx, hy, hz, nx, ny, nz)
        kt = CM.law_tangential_stiffness(law, delta, r12, g12)
        # contact.update_tangential3's steps, with the law's unloading factor
        if C.unloads(overlap_old, delta, rescale):
            scale = CM.law_unloading_scale(law, overlap_old, delta)
            gx *= scale
            gy *= scale
            gz *= scale
        gx, gy, gz, slid = C.increment_and_cap3(gx, gy, gz, tx * dt, ty * dt, tz * dt, kt, fel, mu)
        ct = 0.0
        if zeta > 0.0 and not slid:
            ct = C.damping_coefficient(zeta, meff, kt)
        return (-fn * nx + gx + ct * tx, -fn * ny + gy + ct * ty, -fn * nz + gz + ct * tz, fel,
                gx, gy, gz)
    return -fn * nx, -fn * ny, -fn * nz, fel, hx, hy, hz


@numba.njit(cache=True)
def contact_force(n, delta, r12, e12, g12, meff, vrel, ft, overlap_old, dt, zeta, mu, fvec,
                  rescale=True, law=CM.ContactModel(CM.HERTZ, 0.0)):
    """Array form of :func:`contact_force3` (tests, frozen-history forces).

    ``n``, ``vrel``, ``ft``, ``fvec`` have length d = 2 or 3; ``ft`` is updated
    in place, the force on i is written into ``fvec``, the elastic normal force returned.
    """
    d = n.shape[0]
    three = d == 3
    fx, fy, fz, fel, hx, hy, hz = contact_force3(
        n[0], n[1], n[2] if three else 0.0, delta, r12, math.sqrt(r12), e12, g12, meff,
        vrel[0], vrel[1], vrel[2] if three else 0.0, ft[0], ft[1], ft[2] if three else 0.0,
        overlap_old, dt, zeta, mu, rescale, law)
    ft[0] = hx
    ft[1] = hy
    if three:
        ft[2] = hz
    fvec[0] = fx
    fvec[1] = fy
    if d == 3:
        fvec[2] = fz
    return fel


#: The parallel engine splits the grains into contiguous index blocks (docs/dem.md, "Parallel
#: engine"): ``block_count(N, threads)`` blocks of about BLOCK_GRAINS grains, their number a
#: multiple of BLOCK_MULTIPLE so that 2 or 4 threads get equal shares of the blocks; with more
#: threads, at least BLOCKS_PER_THREAD blocks per thread (a multiple of the thread count, none
#: smaller than MIN_BLOCK_GRAINS grains), so that 16 threads on 10^4 grains have work (8 blocks
#: would cap them at 8x; more blocks per thread add incoming pairs faster than they balance
#: the work, docs/decisions/0004-parallel-passes.md). The partition decides only which thread
#: computes which grains: every grain adds its terms in the one-thread loop's order whatever
#: the blocks, so the bits do not
#: depend on it (tests/test_parallel.py runs several partitions); the blocks (not the threads)
#: hold the partial maxima.
BLOCK_GRAINS = 1024
BLOCK_MULTIPLE = 4
BLOCKS_PER_THREAD = 2
MIN_BLOCK_GRAINS = 64
# columns of the per-block statistics (``blk_g``)
G_DMAX, G_NC, G_NTOP, G_AMAX, G_ALMAX, G_VMAX, G_WMAX, G_KIN, G_DVMAX, G_DISP = range(10)
N_GCOL = 10


def block_count(n: int, threads: int = 1) -> int:
    """Number of grain blocks for ``n`` grains on ``threads`` threads: the multiple of
    BLOCK_MULTIPLE nearest n / BLOCK_GRAINS, at least BLOCK_MULTIPLE; above BLOCK_MULTIPLE
    threads, raised to BLOCKS_PER_THREAD per thread and rounded up to a multiple of the
    threads, but no block under MIN_BLOCK_GRAINS grains (at most n blocks, at least 1)."""
    k = int(n / (BLOCK_MULTIPLE * BLOCK_GRAINS) + 0.5)
    nb = BLOCK_MULTIPLE * max(1, k)
    if threads > BLOCK_MULTIPLE:
        nb = max(nb, threads * BLOCKS_PER_THREAD)
        nb = -(-nb // threads) * threads
        nb = min(nb, max(BLOCK_MULTIPLE, n // MIN_BLOCK_GRAINS))
    return max(1, min(n, nb))


@numba.njit(cache=True, inline="always")
def block_bounds(b, n, nblk):
    """Grains [b0, b1) of block b of ``nblk`` over ``n`` grains."""
    return b * n // nblk, (b + 1) * n // nblk


@numba.njit(cache=True, inline="always")
def grains(lo, hi):
    """range(lo, hi) counted unsigned, for the per-grain loops of a block. With a signed index
    whose start is not a constant, numba checks every access for a negative (wraparound)
    index, and that branch keeps the loop scalar: zeroing a block's forces took 14 us instead
    of 3 for 10^4 grains, and the block engine's grain loops were slower than the
    one-thread loop's over range(n)."""
    return range(np.uint64(lo), np.uint64(hi))


@numba.njit(cache=True, inline="always")
def take_block(claims, b, phase):
    """Mark block b taken in pass ``phase``: ``claims[1 + b]`` exchanged with ``phase`` atomically
    (an LLVM ``atomicrmw xchg``, :func:`granwave.team.atomic_swap`). True when this caller took
    the block, False when someone had. The flags start below every phase (:func:`open_claims`
    zeroes them for the regions' passes, which are all phase 1; the team's passes count up,
    :func:`_team_steps`)."""
    return team.atomic_swap(claims, b + 1, phase) != phase


@numba.njit(cache=True, inline="always")
def block_taken(claims, b, phase):
    """Whether block b is taken in pass ``phase`` (``claims[1 + b]`` read atomically)."""
    return team.atomic_load(claims, b + 1) == phase


@numba.njit(cache=True)
def visit_order(t, threads, nblk, order):
    """The blocks that thread t of ``threads`` offers to take in a force pass, in its order, into
    ``order[:nblk]``: first its own share (numba's static split, ascending), then the other
    threads' shares (t + 1, t + 2, ... cyclically), each from its far end. Where the threads keep
    pace each takes its own share, as the static split did (same memory, same cache); a thread
    done early takes the others' last blocks (:func:`take_block`). Into ``order[nblk + j]`` the
    first block of the share of block ``order[j]``, -1 for t's own. Made once per pass (a team:
    once per run) so that :func:`claim_block` looks blocks up: computing each from the thread
    count takes several integer divisions per block, on the path of the last thread to the
    barrier (benchmarks/investigations/claim_scan.py times both)."""
    j = 0
    for b in range(t * nblk // threads, (t + 1) * nblk // threads):
        order[j] = b
        order[nblk + j] = -1
        j += 1
    u = t
    for _ in range(1, threads):
        u = u + 1 if u + 1 < threads else 0
        c0 = u * nblk // threads
        for b in range((u + 1) * nblk // threads - 1, c0 - 1, -1):
            order[j] = b
            order[nblk + j] = c0
            j += 1


@numba.njit(cache=True, inline="always")
def claim_block(claims, order, nblk, j, phase):
    """The j-th block of a thread's ``order`` (:func:`visit_order`) if the thread should try it
    and took it (:func:`take_block`) in pass ``phase``; else -1. It tries every block of its own
    share, one of another's only while its owner has not reached the block before it. The owner
    then keeps the block it would start next, which it computes from its own cache: taking it
    over a little earlier made the balanced 10 200-grain square slower (threads 1 -> 2 down to
    1.60 in one of three runs, CPU time per step x1.25). A force pass runs, per thread, the blocks
    that ``claim_block(claims, order, nblk, j, phase)`` gives for j < nblk."""
    b = order[j]
    first = order[nblk + j]
    if (first < 0 or (b > first and not block_taken(claims, b - 1, phase))) and take_block(claims, b, phase):
        return b
    return -1


@numba.njit(cache=True, inline="always")
def open_claims(claims, nblk, rows):
    """Clear the taken flags before a pass; the thread count (``claims[0]``, set by the engines),
    at most ``rows``, the tile scratches (one per thread: a pass's iteration t uses row t)."""
    for b in range(nblk):
        claims[1 + b] = 0
    return max(1, min(claims[0], rows))


# Geometry pieces of one contact, shared with the GPU kernels (granwave.gpu.compile compiles
# these same functions for the device).
@numba.njit(cache=True, inline="always")
def _pair_geometry(pos, lateral, i, j):
    """(dx, dy, dz): nearest-image separation r_j - r_i (dz = 0 in 2D)."""
    d = pos.shape[1]
    dx = nearest_image(pos[j, 0] - pos[i, 0], lateral[0])
    if d == 2:
        return dx, pos[j, 1] - pos[i, 1], 0.0
    return dx, nearest_image(pos[j, 1] - pos[i, 1], lateral[1]), pos[j, 2] - pos[i, 2]


@numba.njit(cache=True, inline="always")
def _spin(omega, k, arm):
    """arm * w_k as (wx, wy, wz) (2D: only wz; frictionless: zeros)."""
    r = omega.shape[1]
    if r == 1:
        return 0.0, 0.0, arm * omega[k, 0]
    if r == 3:
        return arm * omega[k, 0], arm * omega[k, 1], arm * omega[k, 2]
    return 0.0, 0.0, 0.0


@numba.njit(cache=True, inline="always")
def _contact_velocity(vel, omega, i, j, ai, aj, nx, ny, nz):
    """(vx, vy, vz): velocity of j's surface relative to i's at their contact point, lever arms
    a_i, a_j along the unit normal n (i -> j): v_j - v_i - (a_i w_i + a_j w_j) x n
    (docs/conventions.md; vz = 0 in 2D)."""
    d = vel.shape[1]
    vx = vel[j, 0] - vel[i, 0]
    vy = vel[j, 1] - vel[i, 1]
    vz = vel[j, 2] - vel[i, 2] if d == 3 else 0.0
    if omega.shape[1] > 0:
        wx, wy, wz = _spin(omega, i, ai)
        ux, uy, uz = _spin(omega, j, aj)
        wx += ux
        wy += uy
        wz += uz
        vx -= wy * nz - wz * ny
        vy -= wz * nx - wx * nz
        vz -= wx * ny - wy * nx
    return vx, vy, vz


@numba.njit(cache=True, inline="always")
def _add_torque3(torque, k, arm, nx, ny, nz, fx, fy, fz):
    """torque[k] += (arm n) x f (only the tangential part of f contributes)."""
    r = torque.shape[1]
    if r == 1:
        torque[k, 0] += arm * (nx * fy - ny * fx)
    elif r == 3:
        torque[k, 0] += arm * (ny * fz - nz * fy)
        torque[k, 1] += arm * (nz * fx - nx * fz)
        torque[k, 2] += arm * (nx * fy - ny * fx)

@numba.njit(cache=True, inline="always")
def wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov, i, k, h, vp, e_wall, g_wall, dt, zeta,
                 mu, rescale, law):
    """Grain i against wall k (0 bottom: normal -e_z at 0; 1 top: +e_z at h, moving at vp):
    the pair law (:func:`contact_force3`) on the wall's own history slots (``wall_ft``,
    ``wall_ov``, updated here) with R12 = R_i, the wall moduli and the grain's mass.

    Returns (delta, arm, nx, ny, nz, fx, fy, fz): the force on the grain; delta <= 0 when
    they do not touch (the history is then cleared and the force is zero). One copy for
    the one-thread loop, the parallel row pass and the GPU kernel.
    """
    d = pos.shape[1]
    r = omega.shape[1]
    y = pos[i, d - 1]
    R = rad[i]
    delta = R - y if k == 0 else R - (h - y)
    w = 2 * i + k
    if delta <= 0.0:
        if wall_ov[w] != 0.0:
            wall_ov[w] = 0.0
            for a in range(d):
                wall_ft[w, a] = 0.0
        return delta, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    sgn = -1.0 if k == 0 else 1.0
    vx = -vel[i, 0]
    if d == 2:
        nx, ny, nz = 0.0, sgn, 0.0
        vy = -vel[i, 1] + (vp if k == 1 else 0.0)
        vz = 0.0
    else:
        nx, ny, nz = 0.0, 0.0, sgn
        vy = -vel[i, 1]
        vz = -vel[i, 2] + (vp if k == 1 else 0.0)
    ai = R - delta
    if r > 0:
        wx, wy, wz = _spin(omega, i, ai)
        vx -= wy * nz - wz * ny
        vy -= wz * nx - wx * nz
        vz -= wx * ny - wy * nx
    hx = hy = hz = 0.0
    if mu > 0.0:
        hx = wall_ft[w, 0]
        hy = wall_ft[w, 1]
        if d == 3:
            hz = wall_ft[w, 2]
    fx, fy, fz, fel, hx, hy, hz = contact_force3(nx, ny, nz, delta, R, math.sqrt(R), e_wall, g_wall, mass[i],
                                                 vx, vy, vz, hx, hy, hz, wall_ov[w], dt, zeta, mu, rescale,
                                                 law)
    if mu > 0.0:
        wall_ft[w, 0] = hx
        wall_ft[w, 1] = hy
        if d == 3:
            wall_ft[w, 2] = hz
    wall_ov[w] = delta
    return delta, ai, nx, ny, nz, fx, fy, fz





@numba.njit(cache=True)
def wall_list(pos, rad, h, skin, wall_ov, walls):
    """The grains that may touch a wall until the list is made again, increasing, into
    ``walls[1:walls[0] + 1]``: those whose position in ``pos`` (the engines pass the positions
    of the last rebuild) is within ``skin`` of the bottom or of the piston at height ``h``, and
    any with a wall history still to clear. It stays complete while every grain is less than
    skin / 2 from that position (the pair list's own rule; it is made again at every rebuild)
    and the piston less than skin / 2 from h (:func:`refresh_wall_list`). The wall loops run
    over it instead of over every grain, in the same grain order: the same bits."""
    n, d = pos.shape
    c = 0
    for i in range(n):
        y = pos[i, d - 1]
        R = rad[i]
        if y - R < skin or (h - y) - R < skin or wall_ov[2 * i] != 0.0 or wall_ov[2 * i + 1] != 0.0:
            c += 1
            walls[c] = i
    walls[0] = c


@numba.njit(cache=True)
def refresh_wall_list(pos_ref, rad, piston, fpar, wall_ov, walls, force):
    """Make the wall list (:func:`wall_list`, from the positions ``pos_ref``) again when
    ``force`` or when the piston has moved more than skin / 2 since it was made (its height
    then is kept in ``fpar[F_WALLH]``)."""
    h = piston[P_H]
    if force or abs(h - fpar[F_WALLH]) > 0.5 * fpar[F_SKIN]:
        wall_list(pos_ref, rad, h, fpar[F_SKIN], wall_ov, walls)
        fpar[F_WALLH] = h


@numba.njit(cache=True, inline="always")
def first_wall_entry(walls, b0):
    """Position in the wall list of its first grain >= b0 (binary search)."""
    lo = 1
    hi = walls[0] + 1
    while lo < hi:
        mid = (lo + hi) // 2
        if walls[mid] < b0:
            lo = mid + 1
        else:
            hi = mid
    return lo


def boundary_room(n_grains: int) -> int:
    """Incoming pairs a new workspace has room for (it grows when a rebuild needs more)."""
    return max(64, n_grains // 2)


def workspace(n_grains: int, dim: int, n_rot: int, cap: int, width: int, boundary: int = 0, mflow=None,
              slabs=None, blocks: int | None = None) -> tuple:
    """Arrays of the parallel kernels for ``n_grains`` grains, ``width`` neighbours per grain and
    room for ``boundary`` incoming pairs (at least :func:`boundary_room`); indexed by the W_* constants:
    the neighbour and gather lists, counts and pair-list offsets of
    :func:`granwave.dem.neighbours.rebuild` and its size request (pairs, width, incoming pairs),
    each block's incoming pairs (their slots) and the place of each in its owner's row order
    (:func:`incoming_lists`), the per-block statistics, the top-wall forces,
    the constants of each of ``cap`` listed pairs (:func:`pair_constants`), the wall list
    (:func:`wall_list`), per incoming pair
    the force and torque its block hands to the owner row (d + r columns), 1/m and 1/I per
    grain, the compaction rule 'mean-flow''s parameters (:mod:`granwave.dem.mean_flow`;
    empty: off) and slab work array, and one pair tile's scratch per thread that numba can
    start (:func:`granwave.dem.pair_tile.scratch`), the thread count, the blocks' taken flags
    (:func:`take_block`) and the state of the slab means (:func:`_slab_job`), the cycles of
    each thread of a team in its passes and at its barriers (T_* columns), and each thread's
    order of the blocks (:func:`visit_order`). ``blocks``: the
    number of grain blocks (None: :func:`block_count` for one thread; :func:`with_blocks`
    changes it)."""
    n = n_grains
    nblk = block_count(n) if blocks is None else int(blocks)
    cap_b = max(boundary_room(n), int(boundary))
    rows = max(1, numba.config.NUMBA_NUM_THREADS)  # one per thread numba can start
    return (np.zeros((n, width), np.int64), np.zeros((n, width), np.int64),
            np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n + 1, np.int64),
            np.zeros(3, np.int64), np.zeros((nblk, N_GCOL)), np.zeros(max(1, n)), np.zeros((cap, N_PCOL)),
            np.zeros(n + 1, np.int64),
            np.zeros(nblk + 1, np.int64), np.zeros(nblk + 1, np.int64), np.zeros(cap_b, np.int64),
            np.zeros(cap_b, np.int64), np.zeros((cap_b, dim + n_rot)), np.zeros(n), np.zeros(n),
            np.zeros(0) if mflow is None else mflow, np.zeros((2, 1)) if slabs is None else slabs,
            *PT.scratch(rows), np.zeros(nblk + 2, np.int64), np.zeros((rows, N_TEAM_TIMES), np.int64),
            np.zeros((rows, 2 * nblk), np.int64))


# workspace entries
W_NBR, W_GL, W_NCNT, W_NLO, W_ROW, W_NEED, W_BLK, W_TOP, W_PAIRC, W_WALLS, W_SLOT, W_OUT, W_SPAIR, W_OSLOT, \
    W_BF, W_INVM, W_INVI, W_MFLOW, W_SLABS, W_TILE, W_TILEP, W_CLAIM, W_TEAMTIME, W_VISIT = range(24)
#: per thread of a team, cycles (team.cycle_counter) spent in its blocks of the first pass (with
#: the step's own tests), waiting at the barrier after it, in its blocks of the second pass,
#: waiting at the barrier after that, and after it in the step's end (the piston, the blocks'
#: maxima); summed over the engine's team steps (``ws[W_TEAMTIME]``; read by
#: benchmarks/dem_team_times.py)
T_PASS1, T_WAIT1, T_PASS2, T_WAIT2, T_END = range(5)
N_TEAM_TIMES = 5


def with_blocks(ws: tuple, nblk: int) -> tuple:
    """The workspace ``ws`` with its per-block arrays sized for ``nblk`` blocks (the rest
    shared); the incoming lists are rebuilt at the next :func:`run_chunk`."""
    if ws[W_BLK].shape[0] == nblk:
        return ws
    new = list(ws)
    for w in (W_SLOT, W_OUT):
        new[w] = np.zeros(nblk + 1, np.int64)
    new[W_BLK] = np.zeros((nblk, N_GCOL))
    new[W_CLAIM] = np.zeros(nblk + 2, np.int64)
    new[W_CLAIM][0] = ws[W_CLAIM][0]
    new[W_VISIT] = np.zeros((ws[W_VISIT].shape[0], 2 * nblk), np.int64)
    return tuple(new)


def grown_workspace(ws: tuple, cap: int, width: int, boundary: int, keep_lists: bool) -> tuple:
    """The workspace ``ws`` with room for ``cap`` pairs, ``width`` neighbours per grain and
    ``boundary`` incoming pairs: only the arrays whose size changes are new (the pair constants
    carried over); the others are the same arrays. The neighbour and gather lists, counts and
    offsets keep their contents with ``keep_lists`` and are cleared otherwise (the next rebuild
    makes them); every other entry is recomputed from the lists by the next
    :func:`run_chunk`. Making the whole workspace again at every growth (its arrays take about
    1 KB per grain in 3D) would leave the freed arrays in the allocator's heap: a step in the
    resident memory of a large preparation."""
    new = list(ws)
    n = ws[W_NCNT].shape[0]
    if width != ws[W_NBR].shape[1]:
        new[W_NBR] = np.zeros((n, width), np.int64)
        new[W_GL] = np.zeros((n, width), np.int64)
    if cap != ws[W_PAIRC].shape[0]:
        old_c = ws[W_PAIRC]
        new[W_PAIRC] = np.zeros((cap, N_PCOL))
        new[W_PAIRC][: old_c.shape[0]] = old_c
    if boundary != ws[W_SPAIR].shape[0]:
        cols = ws[W_BF].shape[1]
        new[W_SPAIR] = np.zeros(boundary, np.int64)
        new[W_OSLOT] = np.zeros(boundary, np.int64)
        new[W_BF] = np.zeros((boundary, cols))
    if not keep_lists:
        for w in (W_NBR, W_GL, W_NCNT, W_NLO):
            new[w][:] = 0
    return tuple(new)


@numba.njit(cache=True)
def incoming_lists(nbr, nlo, gl, row, nblk, slot_start, out_start, slot_pair, out_slot):
    """The incoming pairs of each of ``nblk`` blocks: pairs (k, g) with g in the block and k below
    it (row k belongs to an earlier block). Block b's incoming pairs, in the order of its grains
    g and then of k (each grain's order of the one-thread loop), get the slots
    ``slot_start[b]:slot_start[b + 1]`` (``slot_pair``: their pair indices). ``out_slot`` lists
    the slots in increasing pair index, i.e. in the order the owner rows meet them, block b's
    rows from ``out_start[b]``. From the sorted neighbour rows of the last rebuild; serial
    (O(N) plus a sort of the incoming pairs). Returns the number of incoming pairs; when it
    exceeds the room of ``slot_pair`` only that count is valid."""
    n = nlo.shape[0]
    cap = slot_pair.shape[0]
    s = 0
    for b in range(nblk):
        slot_start[b] = s
        b0, b1 = block_bounds(b, n, nblk)
        for g in range(b0, b1):
            for t in range(nlo[g]):
                if nbr[g, t] >= b0:
                    break
                if s < cap:
                    slot_pair[s] = gl[g, t]
                s += 1
    slot_start[nblk] = s
    if s > cap:
        return s
    order = np.argsort(slot_pair[:s])
    for k in range(s):
        out_slot[k] = order[k]
    k = 0
    for b in range(nblk):
        first = row[block_bounds(b, n, nblk)[0]]
        while k < s and slot_pair[order[k]] < first:
            k += 1
        out_start[b] = k
    out_start[nblk] = s
    return s


@numba.njit(cache=True)
def prepare_blocks(rad, mass, inertia, ws, nblk):
    """1/m and 1/I per grain (the one-thread loop's divisions, once per chunk) and the
    incoming lists (:func:`incoming_lists`) of ``nblk`` blocks into the workspace; returns
    the number of incoming pairs (also into ``ws[W_NEED][2]``): above the room of the
    workspace, the lists are not usable."""
    inv_m = ws[W_INVM]
    inv_i = ws[W_INVI]
    for i in range(rad.shape[0]):
        inv_m[i] = 1.0 / mass[i]
        inv_i[i] = 1.0 / inertia[i]
    return _lists(ws, nblk)


@numba.njit(cache=True)
def _lists(ws, nblk):
    s = incoming_lists(ws[W_NBR], ws[W_NLO], ws[W_GL], ws[W_ROW], nblk, ws[W_SLOT], ws[W_OUT], ws[W_SPAIR],
                       ws[W_OSLOT])
    ws[W_NEED][2] = s
    return s


def boundary_fraction(ws, n_pairs: int) -> float:
    """Incoming pairs (those computed in phase 1, by the block of their grain j) over all pairs
    of the list, for the lists last built in ``ws``."""
    return float(ws[W_SLOT][-1]) / max(1, n_pairs)


@numba.njit(cache=True, inline="always")
def law_of(fpar):
    """The contact model (:class:`granwave.contact_models.ContactModel`) of the engine's
    parameters: the normal law's code ``fpar[F_LAW]`` and its stiffness ``fpar[F_KLAW]``."""
    return CM.ContactModel(int(fpar[F_LAW]), fpar[F_KLAW])


@numba.njit(cache=True, inline="always")
def pair_constants3(inv_rad_i, inv_rad_j, mass_i, mass_j):
    """(R12, sqrt(R12), m_eff) of two grains from their 1/R and masses: what the contact law
    needs of a pair that does not change while it is listed."""
    r12 = C.effective_radius(inv_rad_i, inv_rad_j)
    return r12, math.sqrt(r12), C.reduced_mass(mass_i, mass_j, False)


#: columns of the per-pair constants (``ws[W_PAIRC]``)
PC_R12, PC_ROOT, PC_MEFF = range(3)
N_PCOL = 3


@numba.njit(cache=True)
def pair_constants(pair_i, pair_j, npairs, rad, mass, pair_c):
    """R12, sqrt(R12) and m_eff of the first ``npairs`` listed pairs into ``pair_c``
    (:func:`pair_constants3`), after each rebuild of the pair list: per step that saves each
    contact two divisions and a square root, which share one execution unit with the
    contact's other seven to ten; the values are the ones the loop computed per step, so the
    bits are the same."""
    for p in range(npairs):
        i = pair_i[p]
        j = pair_j[p]
        pair_c[p, PC_R12], pair_c[p, PC_ROOT], pair_c[p, PC_MEFF] = pair_constants3(
            1.0 / rad[i], 1.0 / rad[j], mass[i], mass[j])


@numba.njit(cache=True, inline="always")
def _pair_law(pos, vel, omega, rad, lateral, pair_ft, pair_ov, p, i, j, dt, zeta, mu, rescale, e_pair, g_pair,
              r12, root_r12, meff, law):
    """Pair p = (i, j) with constants R12, sqrt(R12), m_eff (:func:`pair_constants3`):
    (touching, delta, a_i, a_j, n, force on i, new tangential history), with the arithmetic
    of the one-thread loop (dem/serial.py) so that the bits are its own. Reads the history,
    writes nothing."""
    d = pos.shape[1]
    dx, dy, dz = _pair_geometry(pos, lateral, i, j)
    r2 = dx * dx + dy * dy + dz * dz
    ri = rad[i]
    rj = rad[j]
    rs = ri + rj
    if r2 >= rs * rs:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    dist = math.sqrt(r2)
    delta = rs - dist
    nx = dx / dist
    ny = dy / dist
    nz = dz / dist if d == 3 else 0.0
    ai = ri - 0.5 * delta
    aj = rj - 0.5 * delta
    vx, vy, vz = _contact_velocity(vel, omega, i, j, ai, aj, nx, ny, nz)
    hx = hy = hz = 0.0
    if mu > 0.0:
        hx = pair_ft[p, 0]
        hy = pair_ft[p, 1]
        if d == 3:
            hz = pair_ft[p, 2]
    fx, fy, fz, fel, hx, hy, hz = contact_force3(nx, ny, nz, delta, r12, root_r12, e_pair, g_pair, meff,
                                                 vx, vy, vz, hx, hy, hz, pair_ov[p], dt, zeta,
                                                 mu, rescale, law)
    return True, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz


@numba.njit(cache=True, parallel=True)
def _incoming_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j, pair_ft, pair_ov, fpar,
                   nblk, slot_start, slot_pair, bnd_f, blk_g, tile, tile_p, claims, visit):
    """Phase 1 of a step, in parallel over blocks: each block sets its grains' force and torque
    (``acc``, ``alpha``) to zero, then computes each of its incoming pairs (k, g) once (with
    the tangential history update: no one else touches that pair in this step), subtracts the
    force from g and adds a_g (n x f) to its torque, in g's order of the one-thread loop
    (increasing k), and leaves the force on k and a_k (n x f) in the pair's slot of
    ``bnd_f`` (zeros when the grains do not touch: adding them later changes no bit of a sum
    that starts from +0) for the owner row k in phase 2. Largest overlap and contacts of
    these pairs into ``blk_g``."""
    threads = open_claims(claims, nblk, tile.shape[0])
    for t in numba.prange(threads):  # one iteration per thread; blocks taken as in _row_pass
        visit_order(t, threads, nblk, visit[t])
        for j in range(nblk):
            b = claim_block(claims, visit[t], nblk, j, 1)
            if b >= 0:
                _incoming_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j,
                                pair_ft, pair_ov, fpar, nblk, slot_start, slot_pair, bnd_f, blk_g, tile[t],
                                tile_p[t])


@numba.njit(cache=True, _nrt=False)  # no reference counting of the arrays of the inlined helpers
def _incoming_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j, pair_ft, pair_ov,
                    fpar, nblk, slot_start, slot_pair, bnd_f, blk_g, t, tp):
    """Block b of :func:`_incoming_pass` (a plain function: the parallel one stays small, which
    keeps its compilation short); its incoming pairs go through the staged law a tile at a time
    (:func:`granwave.dem.pair_tile.law_tile_incoming`, the bits of :func:`_pair_law`), in the
    calling thread's tile scratch ``t``, ``tp`` (one row of the workspace's W_TILE, W_TILEP)."""
    n, d = pos.shape
    r = omega.shape[1]
    b0, b1 = block_bounds(b, n, nblk)
    flat = acc.reshape(n * d)  # contiguous rows: one flat loop (a memset; unsigned: see grains)
    for q in grains(b0 * d, b1 * d):
        flat[q] = 0.0
    flat = alpha.reshape(n * r)
    for q in grains(b0 * r, b1 * r):
        flat[q] = 0.0
    dt = fpar[F_DT]
    zeta = fpar[F_ZETA]
    mu = fpar[F_MU]
    rescale = fpar[F_RESCALE] != 0.0
    e_pair = C.effective_young(False)
    g_pair = C.effective_shear(fpar[F_POISSON], False)
    law = law_of(fpar)
    dmax = 0.0
    ncontact = 0
    # the block's slots are in the order of its grains g and then of k (incoming_lists): one
    # sequential walk, not the neighbour rows (two cache lines per grain, read for a pair or two).
    # Staged, not pair at a time (_pair_law): the tile's roots and divisions run as vector loops
    # (docs/decisions/0005-pair-law-in-tiles.md)
    s = slot_start[b]
    while s < slot_start[b + 1]:
        s, dmax, ncontact = PT.law_tile_incoming(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft,
                                                 pair_ov, slot_pair, s, slot_start[b + 1], dt, zeta, mu, rescale,
                                                 e_pair, g_pair, law, t, tp, acc, alpha, bnd_f, dmax, ncontact)
    blk_g[b, G_DMAX] = dmax
    blk_g[b, G_NC] = ncontact


@numba.njit(cache=True, inline="always")
def drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt):
    """First half kick (``half`` = dt / 2) and drift of grain i, its lateral coordinates
    folded back into the box at once (geometry.fold_into_box: the bits of a run do not
    depend on when the pair list is rebuilt). Returns |v|^2 and the squared displacement
    since ``pos0``: geometry.periodic_distance2's sum, taken in the same loop from the new
    coordinates (the same operations in the same order), so that they are not read twice."""
    d = pos.shape[1]
    v2 = 0.0
    s = 0.0
    for a in range(d):
        vel[i, a] += half * acc[i, a]
        v = vel[i, a]
        x = pos[i, a] + dt * v
        if a < d - 1:
            x = fold_into_box(x, lateral[a])
            dx = nearest_image(x - pos0[i, a], lateral[a])
        else:
            dx = x - pos0[i, a]
        pos[i, a] = x
        v2 += v * v
        s += dx * dx
    for a in range(omega.shape[1]):
        omega[i, a] += half * alpha[i, a]
    return v2, s


@numba.njit(cache=True)
def _finish(lo, hi, pos, vel, acc, omega, alpha, rad, mass, inertia, inv_m, inv_i, lateral, pos0, dt, stats,
            drift):
    """Grains lo..hi-1 after their forces and torques: accelerations and the second half kick;
    with ``stats`` the largest |a|^2, |alpha|^2, |v|^2, |w|^2 R^2 and the summed kinetic
    energy, after the kick; with ``drift`` the next step's first half kick and drift, the
    largest |v|^2 and squared displacement since ``pos0``. Returned in that order. Separate
    short loops (they vectorize); the same operations per grain as one loop."""
    d = pos.shape[1]
    r = omega.shape[1]
    half = 0.5 * dt
    for i in grains(lo, hi):
        inv = inv_m[i]
        for a in range(d):
            acc[i, a] *= inv
            vel[i, a] += half * acc[i, a]
        inv = inv_i[i]
        for a in range(r):
            alpha[i, a] *= inv
            omega[i, a] += half * alpha[i, a]
    amax = almax = vmax = wmax = kin = dvmax = disp = 0.0
    if stats:
        for i in grains(lo, hi):
            a2 = 0.0
            v2 = 0.0
            for a in range(d):
                a2 += acc[i, a] * acc[i, a]
                v2 += vel[i, a] * vel[i, a]
            al2 = 0.0
            w2 = 0.0
            for a in range(r):
                al2 += alpha[i, a] * alpha[i, a]
                w2 += omega[i, a] * omega[i, a]
            amax = max(amax, a2)
            almax = max(almax, al2)
            vmax = max(vmax, v2)
            wmax = max(wmax, w2 * rad[i] * rad[i])
            kin += 0.5 * (mass[i] * v2 + inertia[i] * w2)
    if drift:
        for i in grains(lo, hi):
            v2, s = drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt)
            dvmax = max(dvmax, v2)
            disp = max(disp, s)
    return amax, almax, vmax, wmax, kin, dvmax, disp


@numba.njit(cache=True, parallel=True)
def _row_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral, pos0, pair_i,
              pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, row, nblk, out_start, out_slot,
              slot_pair, bnd_f, blk_g, top_f, kick, stats, drift, mflow, slabs, tile, tile_p, claims, visit):
    """Phase 2 of a step, in parallel over blocks, after phase 1: each block runs the
    one-thread pair loop over its own rows (pairs (i, j), i in the block), updating their
    tangential histories and adding each force to i and j; a pair whose j lies beyond the
    block was computed by j's block in phase 1, and its force and torque on i are taken from
    its slot once the block's rows are done (a row's such pairs are its last). Then, per grain
    of the block, its bottom and top wall contacts and the background damping -gamma m v,
    -gamma I w (with the compaction rule 'mean-flow', ``mflow`` non-empty, the slabs' mean
    vertical and lateral flows at their own rates from the slab means in ``slabs``, which
    thread 0 takes first, :func:`_slab_job`): for every grain the terms
    of the one-thread loop in its order (phase 1 gave the first ones), so its force is bit for
    bit that loop's. Only the block's own grains are read or written, apart from the slots.

    ``kick`` 0: forces and torques stay in ``acc``, ``alpha``; 1: accelerations, the second
    half kick and (``stats``, ``drift``) what :func:`_finish` does. Per block into ``blk_g``:
    largest overlap and contacts (with phase 1's), top-wall contacts (their forces on the
    piston, grain order, into ``top_f`` from the block's first grain), the block's measures.
    """
    # Each thread takes its own share of the blocks (numba's static split) and then, when done
    # early, the other's last blocks still untaken (an atomic flag per block) while their owner
    # has not come near them (:func:`worth_taking`): with the gas numbered from the bottom up,
    # the static split alone gave one thread a compacting column's dilute bottom and the other
    # its dense top, and the first thread waited at the barrier for half of the compaction
    # (docs/decisions/0004-parallel-passes.md). Which thread computes a block never changes a bit.
    threads = open_claims(claims, nblk, tile.shape[0])
    slab_job = mflow.shape[0] > 0 and fpar[F_GAMMA] > 0.0
    claims[nblk + 1] = SLABS_TODO if slab_job else SLABS_READY
    for t in numba.prange(threads):
        if t == 0 and slab_job:
            _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, 0)
        visit_order(t, threads, nblk, visit[t])
        for j in range(nblk):
            b = claim_block(claims, visit[t], nblk, j, 1)
            if b >= 0:
                _row_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral,
                           pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, row, nblk,
                           out_start, out_slot, slot_pair, bnd_f, blk_g, top_f, kick, stats, drift, mflow, slabs,
                           tile[t], tile_p[t], claims, 0)


#: states of the slab means in ``claims[nblk + 1]`` during phase 2 of round 0 (:func:`_slab_job`);
#: round r adds 2 r, so that one round's SLABS_READY is the next one's SLABS_TODO
SLABS_TODO, SLABS_RUNNING, SLABS_READY = 0, 1, 2


@numba.njit(cache=True, _nrt=False)
def _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd):
    """The slabs' means (:func:`granwave.dem.mean_flow.slab_means`: serial, in grain order, the
    bits of the one-thread loop) into ``slabs``, by the first thread to ask for them: thread 0
    at the start of phase 2, while the others compute their blocks' pairs (which take longer)
    and take over its blocks, or the first block to need them if thread 0 has not started.
    (In phase 1, whose blocks are short, the other threads had waited for thread 0 at the end
    of the pass: on a 10 500-grain column the rule cost 10 % of the rate at two threads against
    4 % at one.) ``claims[nblk + 1]``: SLABS_TODO -> SLABS_RUNNING (compare-and-swap: one
    thread computes them) -> SLABS_READY (release), each plus 2 ``rnd`` (the regions' pass is
    round 0, its flag set to SLABS_TODO before; a team's step s is round s, its flag left at
    the last round's SLABS_READY, which is this round's SLABS_TODO). The job waits for nothing,
    so no schedule of the pass's iterations onto threads can deadlock on it."""
    todo = SLABS_TODO + 2 * rnd
    if team.atomic_cas(claims, nblk + 1, todo, todo + 1) == todo:
        slab_means(pos, vel, mass, fpar[F_GAMMA], mflow, slabs)
        team.atomic_store(claims, nblk + 1, todo + 2)


@numba.njit(cache=True, inline="always")
def _await_slab_means(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd):
    """The slab means of round ``rnd`` ready (acquire): taken here if nobody has
    (:func:`_slab_job`), else waited for while the thread that took them runs (yielding the
    core after a while, :func:`granwave.team.relax`). They read every grain's velocity and
    position, so no block may add its slab term, kick or drift before."""
    _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd)
    ready = SLABS_READY + 2 * rnd
    spins = 0
    while team.atomic_load(claims, nblk + 1) != ready:
        team.relax(spins)
        spins += 1


@numba.njit(cache=True, _nrt=False)  # no reference counting of the arrays passed to wall_contact
def _row_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral, pos0, pair_i,
               pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, row, nblk, out_start, out_slot,
               slot_pair, bnd_f, blk_g, top_f, kick, stats, drift, mflow, slabs, t, tp, claims, rnd):
    """Block b of :func:`_row_pass` (``t``, ``tp``: the calling thread's tile scratch, as in
    :func:`_incoming_block`; ``claims``, ``rnd``: where the slab means' state is and which round
    this pass is, :func:`_slab_job`)."""
    n, d = pos.shape
    r = omega.shape[1]
    b0, b1 = block_bounds(b, n, nblk)
    dt = fpar[F_DT]
    zeta = fpar[F_ZETA]
    mu = fpar[F_MU]
    gamma = fpar[F_GAMMA]
    rescale = fpar[F_RESCALE] != 0.0
    e_pair = C.effective_young(False)
    g_pair = C.effective_shear(fpar[F_POISSON], False)
    e_wall = C.effective_young(True)
    g_wall = C.effective_shear(fpar[F_POISSON], True)
    law = law_of(fpar)
    dmax = blk_g[b, G_DMAX]
    ncontact = int(blk_g[b, G_NC])
    # the block's rows a tile at a time (pair_tile: the pair law with its roots and quotients in
    # vector loops, the bits of _pair_law), skipping the pairs beyond the block (computed by
    # their j's block in phase 1)
    p = row[b0]
    while p < row[b1]:
        p, dmax, ncontact = PT.law_tile(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov,
                                        p, row[b1], b1, dt, zeta, mu, rescale, e_pair, g_pair, law, t, tp,
                                        acc, alpha, dmax, ncontact)
    # then those pairs' forces on their rows' grains, from the slots, in increasing pair index
    # (a row's are its last pairs, sorted by j). Nothing but row k adds to grain k once row k
    # is done (pairs have k < j) until the walls below, so each grain's order is the one-thread
    # loop's (adding them row by row as the tiles finished rows cost a test per row, 4 % of
    # the pass for 10^4 grains)
    for c in range(out_start[b], out_start[b + 1]):
        s = out_slot[c]
        k = pair_i[slot_pair[s]]
        acc[k, 0] += bnd_f[s, 0]
        acc[k, 1] += bnd_f[s, 1]
        if d == 3:
            acc[k, 2] += bnd_f[s, 2]
        for a in range(r):
            alpha[k, a] += bnd_f[s, d + a]
    # walls: k = 0 bottom (normal -e_z, at 0), k = 1 top (normal +e_z, at h, velocity vp), for
    # the block's grains in the wall list (no other can touch one)
    h = piston[P_H]
    vp = piston[P_V]
    ntop = 0
    q = first_wall_entry(walls, b0)
    while q <= walls[0] and walls[q] < b1:
        i = walls[q]
        q += 1
        for k in range(2):
            delta, ai, nx, ny, nz, fx, fy, fz = wall_contact(pos, vel, omega, rad, mass, wall_ft, wall_ov,
                                                             i, k, h, vp, e_wall, g_wall, dt, zeta, mu,
                                                             rescale, law)
            if delta <= 0.0:
                continue
            acc[i, 0] += fx
            acc[i, 1] += fy
            if d == 3:
                acc[i, 2] += fz
            if r > 0:
                _add_torque3(alpha, i, ai, nx, ny, nz, fx, fy, fz)
            if k == 1:
                top_f[b0 + ntop] = fz if d == 3 else fy
                ntop += 1
            if delta > dmax:
                dmax = delta
            ncontact += 1
    if gamma > 0.0:
        for i in grains(b0, b1):
            for a in range(d):
                acc[i, a] -= gamma * mass[i] * vel[i, a]
            for a in range(r):
                alpha[i, a] -= gamma * inertia[i] * omega[i, a]
        if mflow.shape[0] > 0:  # after every grain's damping, as the one-thread loop
            _await_slab_means(pos, vel, mass, fpar, mflow, slabs, claims, nblk, rnd)
            add_slab_damping(b0, b1, pos, mass, gamma, mflow, slabs, acc)
    m = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if kick:
        m = _finish(b0, b1, pos, vel, acc, omega, alpha, rad, mass, inertia, inv_m, inv_i, lateral, pos0, dt,
                    stats, drift)
    blk_g[b, G_DMAX] = dmax
    blk_g[b, G_NC] = ncontact
    blk_g[b, G_NTOP] = ntop
    blk_g[b, G_AMAX] = m[0]
    blk_g[b, G_ALMAX] = m[1]
    blk_g[b, G_VMAX] = m[2]
    blk_g[b, G_WMAX] = m[3]
    blk_g[b, G_KIN] = m[4]
    blk_g[b, G_DVMAX] = m[5]
    blk_g[b, G_DISP] = m[6]


@numba.njit(cache=True, parallel=True)
def _drift_pass(pos, vel, acc, omega, alpha, lateral, pos0, dt, blk_g):
    """First half kick and drift of velocity Verlet; block maxima of |v|^2 and of the squared
    displacement since ``pos0`` into ``blk_g`` (columns G_DVMAX, G_DISP)."""
    n = pos.shape[0]
    nblk = blk_g.shape[0]
    half = 0.5 * dt
    for b in numba.prange(nblk):
        dvmax = 0.0
        disp = 0.0
        b0, b1 = block_bounds(np.int64(b), n, nblk)
        for i in grains(b0, b1):
            v2, s = drift_grain(pos, vel, acc, omega, alpha, pos0, lateral, i, half, dt)
            dvmax = max(dvmax, v2)
            disp = max(disp, s)
        blk_g[b, G_DVMAX] = dvmax
        blk_g[b, G_DISP] = disp


@numba.njit(cache=True, parallel=True)
def _displacement_pass(pos, lateral, pos0, blk_g):
    """Block maxima of the squared displacement since ``pos0`` (nearest image) into
    ``blk_g[:, G_DISP]``."""
    n = pos.shape[0]
    nblk = blk_g.shape[0]
    for b in numba.prange(nblk):
        disp = 0.0
        b0, b1 = block_bounds(np.int64(b), n, nblk)
        for i in grains(b0, b1):
            disp = max(disp, periodic_distance2(pos, i, pos0, i, lateral))
        blk_g[b, G_DISP] = disp


@numba.njit(cache=True)
def _block_max(blk, col):
    m = 0.0
    for b in range(blk.shape[0]):
        m = max(m, blk[b, col])
    return m


@numba.njit(cache=True)
def _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, kick, stats, drift):
    """Phases 1 and 2 of a step over ``nblk`` blocks (see each); reduce the blocks into ``out``
    and the piston's contact force (its grains' forces summed in grain order) and
    acceleration; with ``stats`` the convergence measures as :func:`measure` (the kinetic
    energy summed by blocks: only its finiteness is used). The incoming lists
    (:func:`prepare_blocks`) must be those of the current pair list and ``nblk``."""
    blk_g = ws[W_BLK]
    top_f = ws[W_TOP]
    pair_c = ws[W_PAIRC]
    mflow = ws[W_MFLOW]
    _incoming_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j, pair_ft, pair_ov,
                   fpar, nblk, ws[W_SLOT], ws[W_SPAIR], ws[W_BF], blk_g, ws[W_TILE], ws[W_TILEP], ws[W_CLAIM],
                   ws[W_VISIT])
    # the wall list must cover this piston height (made again if the piston moved)
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws[W_WALLS], False)
    # (with the rule 'mean-flow' also the slabs' mean flow, from this step's velocities)
    _row_pass(pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, ws[W_INVM], ws[W_INVI], lateral, pos0,
              pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, ws[W_WALLS], piston, fpar, ws[W_ROW], nblk,
              ws[W_OUT], ws[W_OSLOT], ws[W_SPAIR], ws[W_BF], blk_g, top_f, kick, stats, drift, mflow, ws[W_SLABS],
              ws[W_TILE], ws[W_TILEP], ws[W_CLAIM], ws[W_VISIT])
    n = pos.shape[0]
    dmax = 0.0
    ncontact = 0
    ntop = 0
    kin = 0.0
    amax = almax = vmax = wmax = 0.0
    for b in range(nblk):
        dmax = max(dmax, blk_g[b, G_DMAX])
        ncontact += int(blk_g[b, G_NC])
        ntop += int(blk_g[b, G_NTOP])
        kin += blk_g[b, G_KIN]
        amax = max(amax, blk_g[b, G_AMAX])
        almax = max(almax, blk_g[b, G_ALMAX])
        vmax = max(vmax, blk_g[b, G_VMAX])
        wmax = max(wmax, blk_g[b, G_WMAX])
    piston[P_FCON] = piston_contact_force(blk_g, top_f, n, nblk)
    piston[P_A] = piston_acceleration(piston, mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar[F_GAMMA])
    out[O_DMAX] = dmax
    out[O_NTOP] = ntop
    out[O_NCONTACT] = ncontact
    if stats:
        out[O_AMAX] = math.sqrt(amax)
        out[O_ALPHAMAX] = math.sqrt(almax)
        out[O_VMAX] = math.sqrt(vmax)
        out[O_WMAX] = math.sqrt(wmax)
        if piston[P_MASS] < np.inf:
            out[O_APISTON] = abs(piston[P_A])
            kin += 0.5 * piston[P_MASS] * piston[P_V] * piston[P_V]
        else:
            out[O_APISTON] = 0.0
        out[O_KIN] = kin


@numba.njit(cache=True)
def compute_forces(pos, vel, omega, rad, mass, inertia, lateral, pair_i, pair_j, pair_ft, pair_ov, wall_ft,
                   wall_ov, piston, fpar, ipar, force, torque, out, ws):
    """Total force and torque on every grain (into ``force``, ``torque``), the contact force on
    the piston (``piston[P_FCON]``), largest overlap, top-wall and total contact counts (``out``).

    Also adds the background damping -gamma m v, -gamma I w. Contacts update their
    tangential history with slip = v_rel * fpar[F_DT] (0: evaluated, not advanced). When the
    workspace has no room for the incoming pairs, one block (the same bits).
    """
    nblk = ws[W_BLK].shape[0]
    if prepare_blocks(rad, mass, inertia, ws, nblk) > ws[W_SPAIR].shape[0]:
        nblk = 1
        _lists(ws, nblk)
    refresh_wall_list(pos, rad, piston, fpar, wall_ov, ws[W_WALLS], True)  # for these positions
    _forces(pos, vel, force, omega, torque, rad, mass, inertia, lateral, pos, pair_i, pair_j, pair_ft,
            pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, False, False, False)


@numba.njit(cache=True)
def piston_acceleration(piston, gamma):
    """(contact force up - p A down - gamma M v) / M; zero for a fixed wall (mass inf)."""
    m = piston[P_MASS]
    if not (m < np.inf):
        return 0.0
    return (piston[P_FCON] - piston[P_FEXT]) / m - gamma * piston[P_V]


@numba.njit(cache=True, inline="always")
def piston_half_kick(piston, dt):
    """Velocity Verlet's half kick of a moving piston (none for a fixed wall, mass inf)."""
    if piston[P_MASS] < np.inf:
        piston[P_V] += 0.5 * dt * piston[P_A]


@numba.njit(cache=True, inline="always")
def piston_kick_drift(piston, dt):
    """The first half kick and the drift of a moving piston (none for a fixed wall)."""
    if piston[P_MASS] < np.inf:
        piston[P_V] += 0.5 * dt * piston[P_A]
        piston[P_H] += dt * piston[P_V]


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


@numba.njit(cache=True)
def to_accelerations(force, torque, mass, inertia):
    """Divide forces by masses and torques by moments of inertia, in place."""
    n, d = force.shape
    r = torque.shape[1]
    for i in range(n):
        inv = 1.0 / mass[i]
        for a in range(d):
            force[i, a] *= inv
        inv = 1.0 / inertia[i]
        for a in range(r):
            torque[i, a] *= inv


#: ``safety`` at which :func:`stable_dt` would step exactly at the estimated stability limit:
#: dt = (safety / SAFETY_AT_LIMIT) x dt_limit (default safety 0.05: half the limit).
SAFETY_AT_LIMIT = 0.1
#: 1 + m a^2 / I for a sphere turning about its contact point (arm a <= R, I = m (2R)^2 / 10):
#: the tangential spring acts on a mode of mass m / 3.5 (translation plus rotation).
ROTATION_FACTOR = 3.5


@numba.njit(cache=True, inline="always")
def verlet_limit(omega, zeta):
    """Largest stable dt of the engine's velocity Verlet for one damped oscillator
    x'' = -omega^2 x - 2 zeta omega v with the damping on the half-step velocity:
    omega dt < 2 (sqrt(1 + zeta^2) - zeta) (2 at zeta = 0, 0.83 at zeta = 1; the
    amplification matrix of the scheme, tests/test_dem.py)."""
    return 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta) / omega


@numba.njit(cache=True)
def stable_dt(fpar):
    """dt = (safety / SAFETY_AT_LIMIT) x the estimated stability limit of the explicit step.

    The stiffest spring is a wall contact of the largest grain (R12 = R_max, E*12 = 1)
    at the larger of the largest current overlap and the overlap floor (that of a
    contact carrying p d^2), acting on the lightest grain: k_n, omega_n^2 = k_n / m_min.
    Two modes of that contact bound the step (:func:`verlet_limit`):
    - normal: omega_n, damping ratio zeta;
    - tangential (mu > 0): the grain turning about its contact, mode mass m / 3.5
      (m a^2 / I <= 2.5), so omega_t^2 = 3.5 eta omega_n^2 (eta = k_t / k_n) and, since
      c_t = 2 zeta sqrt(m k_t) uses the translational mass (docs/method.md §2), damping ratio
      zeta sqrt(3.5).
    A grain has several contacts, so the true limit is 0.7-1.0 of this estimate for zeta in
    [0, 1], with and without friction; hence ``safety`` <= 0.06 (params;
    docs/decisions/0009-time-step-rule.md). k_n is the engine's normal law's
    (contact_models.law_step_stiffness: a harmonic k_n, the same for every contact, counts twice,
    for a grain's contacts acting together; eta is the same for both laws).
    """
    k = CM.law_step_stiffness(law_of(fpar), fpar[F_DFLOOR], math.sqrt(fpar[F_RMAX]), C.effective_young(True))
    omega = math.sqrt(k / fpar[F_MMIN])
    zeta = fpar[F_ZETA]
    limit = verlet_limit(omega, zeta)
    if fpar[F_MU] > 0.0:
        omega_t = omega * math.sqrt(ROTATION_FACTOR * C.stiffness_ratio(fpar[F_POISSON]))
        limit = min(limit, verlet_limit(omega_t, zeta * math.sqrt(ROTATION_FACTOR)))
    return fpar[F_SAFETY] / SAFETY_AT_LIMIT * limit


@numba.njit(cache=True)
def measure(vel, acc, omega, alpha, mass, inertia, rad, piston, gamma, out):
    """Largest accelerations and speeds, kinetic energy (grains + piston) into ``out``."""
    n, d = vel.shape
    r = omega.shape[1]
    amax = 0.0
    almax = 0.0
    vmax = 0.0
    wmax = 0.0
    kin = 0.0
    for i in range(n):
        a2 = 0.0
        v2 = 0.0
        for a in range(d):
            a2 += acc[i, a] * acc[i, a]
            v2 += vel[i, a] * vel[i, a]
        al2 = 0.0
        w2 = 0.0
        for a in range(r):
            al2 += alpha[i, a] * alpha[i, a]
            w2 += omega[i, a] * omega[i, a]
        amax = max(amax, a2)
        almax = max(almax, al2)
        vmax = max(vmax, v2)
        wmax = max(wmax, w2 * rad[i] * rad[i])
        kin += 0.5 * (mass[i] * v2 + inertia[i] * w2)
    out[O_AMAX] = math.sqrt(amax)
    out[O_ALPHAMAX] = math.sqrt(almax)
    out[O_VMAX] = math.sqrt(vmax)
    out[O_WMAX] = math.sqrt(wmax)
    if piston[P_MASS] < np.inf:
        out[O_APISTON] = abs(piston[P_A])
        kin += 0.5 * piston[P_MASS] * piston[P_V] * piston[P_V]
    else:
        out[O_APISTON] = 0.0
    out[O_KIN] = kin


# --------------------------------------------------------------------------- team of threads
# Plain steps (no rebuild, no check, no wall list to remake) in one parallel
# region, the two passes of each separated by granwave.team's spin barrier. numba opens a region
# (an OpenMP fork and join) per pass, and each region ends in a wait for its slowest thread; a
# team saves the forks and joins of the plain steps (on many threads a region costs several
# microseconds: docs/decisions/0004-parallel-passes.md). Every block runs the same code as in
# the regions' passes and every thread takes the same decisions from the same numbers, so the
# bits are those of the regions' path (tests/test_parallel.py).


@numba.njit(cache=True)
def _team_thread(t, threads, sync, claims, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m,
                 inv_i, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar,
                 row, nblk, out_start, out_slot, slot_start, slot_pair, bnd_f, blk_g, top_f, mflow, slabs, scr,
                 scr_p, gamma_p, check, built, steps, step, n_steps, disp2, vmax, state, times, order):
    """Thread t's part of :func:`_team_steps`: from step ``step`` of ``n_steps`` (``steps`` done in
    all, the list made at ``built``), with its own copy ``piston`` of the piston, as long as the
    next step is one that :func:`run_chunk` would run as a plain drifted step. Its count of steps,
    ``disp2`` and the largest |v| into ``state`` (every thread the same); its cycles in the passes
    and at the barriers added to row t of ``times`` (T_* columns; a few counter reads per step).
    ``scr``, ``scr_p``: its tile scratch; ``order``: its row for :func:`visit_order`."""
    n = pos.shape[0]
    dt = fpar[F_DT]
    half_skin = 0.5 * fpar[F_SKIN]
    slab_job = mflow.shape[0] > 0 and fpar[F_GAMMA] > 0.0
    gen = 0
    done = 0
    visit_order(t, threads, nblk, order)
    c0 = team.cycle_counter()
    while True:
        # run_chunk's tests for this step, from the same numbers on every thread
        is_check = check > 0 and (steps + 1) % check == 0
        reach = math.sqrt(disp2) + 2.0 * vmax * dt
        if (is_check or step + 1 >= n_steps or not math.isfinite(reach)
                or rebuild_due(fpar, steps + 1 - built, reach)
                or abs(piston[P_H] - fpar[F_WALLH]) > half_skin):
            break
        phase = 2 * done + 1
        for j in range(nblk):
            b = claim_block(claims, order, nblk, j, phase)
            if b >= 0:
                _incoming_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, lateral, pair_i, pair_j,
                                pair_ft, pair_ov, fpar, nblk, slot_start, slot_pair, bnd_f, blk_g, scr, scr_p)
        c1 = team.cycle_counter()
        gen = team.barrier(sync, threads, gen)
        c2 = team.cycle_counter()
        if t == 0 and slab_job:  # as in _row_pass: thread 0 first, the others take its blocks
            _slab_job(pos, vel, mass, fpar, mflow, slabs, claims, nblk, done)
        for j in range(nblk):
            b = claim_block(claims, order, nblk, j, phase + 1)
            if b >= 0:
                _row_block(b, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral,
                           pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, piston, fpar, row,
                           nblk, out_start, out_slot, slot_pair, bnd_f, blk_g, top_f, True, False, True, mflow,
                           slabs, scr, scr_p, claims, done)
        c3 = team.cycle_counter()
        gen = team.barrier(sync, threads, gen)
        c4 = team.cycle_counter()
        times[t, T_PASS1] += c1 - c0
        times[t, T_WAIT1] += c2 - c1
        times[t, T_PASS2] += c3 - c2
        times[t, T_WAIT2] += c4 - c3
        # what _forces and run_chunk do after the passes, read before this thread arrives at the
        # next barrier: the next phase 1 writes no column read here, the next phase 2 all of them
        piston[P_FCON] = piston_contact_force(blk_g, top_f, n, nblk)
        piston[P_A] = piston_acceleration(piston, gamma_p)
        piston_half_kick(piston, dt)
        steps += 1
        step += 1
        done += 1
        vmax = math.sqrt(_block_max(blk_g, G_DVMAX))
        disp2 = _block_max(blk_g, G_DISP)
        piston_kick_drift(piston, dt)
        c0 = team.cycle_counter()
        times[t, T_END] += c0 - c4
    state[t, 0] = done
    state[t, 1] = disp2
    state[t, 2] = vmax


@numba.njit(cache=True, parallel=True)
def _team_region(pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia, inv_m, inv_i, lateral, pos0, pair_i,
                 pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls, pistons, fpar, row, nblk, out_start, out_slot,
                 slot_start, slot_pair, bnd_f, blk_g, top_f, mflow, slabs, tile, tile_p, gamma_p, check,
                 built, steps, step, n_steps, disp2, vmax, sync, claims, state, times, visit):
    threads = team.team_size(sync)
    for t in numba.prange(threads):  # one iteration per thread (granwave.team)
        if team.enter(sync, threads):
            _team_thread(t, threads, sync, claims, pos, vel, acc, omega, alpha, rad, pair_c, mass, inertia,
                         inv_m, inv_i, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, walls,
                         pistons[t], fpar, row, nblk, out_start, out_slot, slot_start, slot_pair, bnd_f, blk_g,
                         top_f, mflow, slabs, tile[t], tile_p[t], gamma_p, check, built, steps, step,
                         n_steps, disp2, vmax, state, times, visit[t])


@numba.njit(cache=True)
def _team_steps(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft, pair_ov,
                wall_ft, wall_ov, piston, fpar, ipar, ws, nblk, step, n_steps, disp2, sync):
    """Run the plain steps from step ``step`` of :func:`run_chunk` (whose drift is done) in a team
    of threads: each step the passes of :func:`_forces` with the drift of the next, and the
    piston and the rebuild test as run_chunk, until a step is a check, needs a new pair list or
    wall list, or is the last. Returns (steps run, disp2); updates the piston, ``fpar[F_VMAX]``
    and the step counts. Returns (0, disp2) with ``ipar[I_TEAM]`` = -1 when the team did not
    start (:func:`granwave.team.enter`; then nothing was done), or when it has more threads than
    the workspace has tile scratches (more than numba can start: it would not start either)."""
    threads = max(1, ws[W_CLAIM][0])
    team.reset_team(sync, threads)
    if threads > ws[W_TILE].shape[0]:
        ipar[I_TEAM] = -1
        return 0, disp2
    pistons = np.empty((threads, piston.shape[0]))
    for t in range(threads):
        for k in range(piston.shape[0]):
            pistons[t, k] = piston[k]
    claims = np.zeros(nblk + 2, np.int64)
    state = np.zeros((threads, 3))
    times = ws[W_TEAMTIME]
    if times.shape[0] < threads:  # a team larger than numba's threads (it will not start): no row to miss
        times = np.zeros((threads, N_TEAM_TIMES), np.int64)
    mflow = ws[W_MFLOW]
    gamma_p = mflow[M_GAMMA_M] if mflow.shape[0] > 0 else fpar[F_GAMMA]
    _team_region(pos, vel, acc, omega, alpha, rad, ws[W_PAIRC], mass, inertia, ws[W_INVM], ws[W_INVI], lateral,
                 pos0, pair_i, pair_j, pair_ft, pair_ov, wall_ft, wall_ov, ws[W_WALLS], pistons, fpar, ws[W_ROW],
                 nblk, ws[W_OUT], ws[W_OSLOT], ws[W_SLOT], ws[W_SPAIR], ws[W_BF], ws[W_BLK], ws[W_TOP], mflow,
                 ws[W_SLABS], ws[W_TILE], ws[W_TILEP], gamma_p, ipar[I_CHECK], ipar[I_BUILT],
                 ipar[I_STEPS], step, n_steps, disp2, fpar[F_VMAX], sync, claims, state, times, ws[W_VISIT])
    if sync[team.S_ENTRY] < threads:
        ipar[I_TEAM] = -1
        return 0, disp2
    done = int(state[0, 0])
    if done > 0:
        for k in range(piston.shape[0]):
            piston[k] = pistons[0, k]
        fpar[F_VMAX] = state[0, 2]
        ipar[I_STEPS] += done
        ipar[I_TEAMSTEPS] += done
    return done, state[0, 1]


#: Below this many grains the engine runs on one thread (the same results): two parallel
#: regions per step cost more than they save on a small system (applied by the callers,
#: :func:`granwave.threads.at_most`: numba.set_num_threads inside a kernel stops caching).
MIN_PARALLEL_GRAINS = 1000


@numba.njit(cache=True)
def run_chunk(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
              pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws):
    """Advance ``ipar[I_NSTEPS]`` velocity-Verlet steps (or stop early).

    State on entry and exit: positions, velocities and accelerations at the same
    time (``acc``/``alpha`` valid). Returns 0 when all steps ran, 1 when the
    convergence candidate test passed at a check (every ``ipar[I_CHECK]``
    steps: piston touching grains, every |a|, |alpha| and |a_piston| below
    F_TOLA, every |v|, |w| R and |v_piston| below F_TOLV), 2 when the pair list
    needs more room (``ipar[I_NEEDED]`` pairs, ``ipar[I_WIDTH]`` neighbours per grain,
    ``ws[W_NEED][2]`` incoming pairs; the state is one that a new call goes on from with
    the same bits), 3 when the
    state blew up (an overlap larger than the largest radius or non-finite motion at a
    check, or non-finite positions before a rebuild): the time step is unstable.
    With ``ipar[I_ADAPTIVE]`` the time step is reset at every check from
    :func:`stable_dt`.

    Two parallel passes per step over the grain blocks (:func:`_incoming_pass`,
    :func:`_row_pass`); the first half kick and drift of the next step ride on the second
    unless that step rebuilds the pair list or follows a check (then :func:`_drift_pass`).
    With ``ipar[I_TEAM]`` > 0 the runs of plain steps between go in a team of threads instead
    (:func:`_team_steps`: one parallel region for the run, the same bits).
    """
    n, d = pos.shape
    blk_g = ws[W_BLK]
    nblk = blk_g.shape[0]
    room = ws[W_SPAIR].shape[0]
    if prepare_blocks(rad, mass, inertia, ws, nblk) > room:  # lists built elsewhere, more than room
        ipar[I_NEEDED] = ipar[I_NPAIRS]
        ipar[I_WIDTH] = 0
        return 2
    refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws[W_WALLS], True)  # from the last rebuild's positions
    check = ipar[I_CHECK]
    n_steps = ipar[I_NSTEPS]
    # largest squared displacement since the last build (then kept by the drift)
    _displacement_pass(pos, lateral, pos0, blk_g)
    disp2 = _block_max(blk_g, G_DISP)
    drifted = False
    # plain steps in a team of threads (_team_steps) when asked for and on more than one thread
    use_team = ipar[I_TEAM] > 0 and ws[W_CLAIM][0] > 1
    sync = np.zeros(team.SYNC_LENGTH, np.int64)
    step = 0
    while step < n_steps:
        if drifted and use_team:
            done, disp2 = _team_steps(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i,
                                      pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, ws, nblk,
                                      step, n_steps, disp2, sync)
            step += done
            use_team = ipar[I_TEAM] > 0
        dt = fpar[F_DT]
        if not drifted:
            # rebuild when a grain may come within reach of a pair not in the list
            # before the next rebuild check (factor 2: the speed may grow in a step)
            reach = math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt
            if not math.isfinite(reach):  # the state blew up (unstable step): stop before the rebuild
                return 3
            if needs_rebuild(fpar, ipar, reach, 0):
                skin = next_skin(fpar, ipar, reach)  # kept only once the list is made with it
                np_new = neighbours.rebuild(pos, rad, lateral, piston[P_H], skin, pair_i, pair_j,
                                            pair_ft, pair_ov, ipar[I_NPAIRS], ws[0], ws[2], ws[3],
                                            ws[4], ws[1], ws[5])
                if np_new < 0:
                    ipar[I_NEEDED] = ws[5][0]
                    ipar[I_WIDTH] = ws[5][1]
                    return 2
                fpar[F_SKIN] = skin
                ipar[I_NPAIRS] = np_new
                ipar[I_REBUILDS] += 1
                ipar[I_BUILT] = ipar[I_STEPS]
                pair_constants(pair_i, pair_j, np_new, rad, mass, ws[W_PAIRC])
                for i in range(n):  # explicit loops: slice assignment compiles shape-check machinery
                    for a in range(d):
                        pos0[i, a] = pos[i, a]
                refresh_wall_list(pos0, rad, piston, fpar, wall_ov, ws[W_WALLS], True)  # new positions
                disp2 = 0.0
                if _lists(ws, nblk) > room:  # grow (Engine.grow), then go on from here: the same bits
                    ipar[I_NEEDED] = np_new
                    ipar[I_WIDTH] = 0
                    return 2
            _drift_pass(pos, vel, acc, omega, alpha, lateral, pos0, dt, blk_g)
            fpar[F_VMAX] = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            piston_kick_drift(piston, dt)
        is_check = check > 0 and (ipar[I_STEPS] + 1) % check == 0
        # the next step's rebuild test is known now unless dt may change (a check)
        reach = math.sqrt(disp2) + 2.0 * fpar[F_VMAX] * dt
        drifted = (not is_check and step + 1 < n_steps and math.isfinite(reach)
                   and not needs_rebuild(fpar, ipar, reach, 1))
        _forces(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pair_i, pair_j, pair_ft,
                pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, nblk, True, is_check, drifted)
        piston_half_kick(piston, dt)
        ipar[I_STEPS] += 1
        if drifted:
            fpar[F_VMAX] = math.sqrt(_block_max(blk_g, G_DVMAX))
            disp2 = _block_max(blk_g, G_DISP)
            piston_kick_drift(piston, dt)
        if is_check:
            if not (out[O_DMAX] < fpar[F_RMAX] and math.isfinite(out[O_KIN])):
                return 3  # an overlap beyond a radius, or non-finite motion: the step is unstable
            if ipar[I_ADAPTIVE]:
                fpar[F_DT] = stable_dt_at(fpar, out[O_DMAX])
            tol_a = fpar[F_TOLA]
            tol_v = fpar[F_TOLV]
            if (out[O_NTOP] > 0 and out[O_AMAX] < tol_a and out[O_ALPHAMAX] < tol_a
                    and out[O_APISTON] < tol_a and out[O_VMAX] < tol_v and out[O_WMAX] < tol_v
                    and abs(piston[P_V]) < tol_v):
                return 1
        step += 1
    return 0


#: Adaptive skin: steps a pair list is meant to last (:func:`next_skin`). A rebuild of a
#: dense column costs about five steps, so at this length rebuilds take ~2 % of a run.
SKIN_STEPS = 200


@numba.njit(cache=True)
def needs_rebuild(fpar, ipar, reach, ahead):
    """Whether the pair list is made again before the step ``ahead`` steps from now.

    Must when a grain may have come within ``reach`` of half the skin (the list's
    guarantee). With an adaptive skin also when the list has lasted twice
    :data:`SKIN_STEPS` and the grains' speed since it was made asks for a skin below half
    the current one: they have slowed down, and a list with a smaller skin makes each
    step cheaper (:func:`next_skin`).
    """
    return rebuild_due(fpar, ipar[I_STEPS] + ahead - ipar[I_BUILT], reach)


@numba.njit(cache=True, inline="always")
def rebuild_due(fpar, lasted, reach):
    """:func:`needs_rebuild` for a list that will have lasted ``lasted`` steps."""
    skin = fpar[F_SKIN]
    if reach > 0.5 * skin:
        return True
    return (fpar[F_SKIN_MIN] < skin and lasted >= 2 * SKIN_STEPS
            and 2.0 * SKIN_STEPS * reach < 0.5 * skin * lasted)


@numba.njit(cache=True)
def next_skin(fpar, ipar, reach):
    """Skin of the pair list about to be made (d).

    Fixed unless ``fpar[F_SKIN_MIN] < fpar[F_SKIN_MAX]``; then the skin that the grains'
    speed of the list now ending (``reach`` over the steps it lasted) would take
    :data:`SKIN_STEPS` steps to use up, within [F_SKIN_MIN, F_SKIN_MAX] and within a
    factor of two of the current skin. A skin changes no bit of a run: positions are folded
    into the box at every drift, never at a rebuild, and pairs not in contact add nothing.
    """
    skin = fpar[F_SKIN]
    lo = fpar[F_SKIN_MIN]
    hi = fpar[F_SKIN_MAX]
    if not lo < hi:
        return skin
    lasted = max(ipar[I_STEPS] - ipar[I_BUILT], 1)
    want = 2.0 * SKIN_STEPS * reach / lasted
    return min(max(want, lo, 0.5 * skin), hi, 2.0 * skin)


@numba.njit(cache=True)
def stable_dt_at(fpar, dmax):
    """:func:`stable_dt` with the overlap floor raised to the current largest overlap."""
    floor = fpar[F_DFLOOR]
    fpar[F_DFLOOR] = max(floor, dmax)
    dt = stable_dt(fpar)
    fpar[F_DFLOOR] = floor
    return dt
