"""The staged pair law (granwave.dem.pair_tile) against the pair-at-a-time law, bit for bit."""

import numpy as np
import pytest

from granwave import contact as C
from granwave import contact_models as CM
from granwave.dem import kernels as K
from granwave.dem import pair_tile as PT

#: the normal law of these checks (Hertz; tests/test_harmonic.py runs them with the harmonic law)
LAW = CM.contact_model()


def dense_state(dim, n, seed):
    """Grains in a box small enough that about half the listed pairs overlap, with random
    motion, and per pair a history that covers every branch of the law: new contacts
    (no history), loading and unloading ones, histories beyond the Coulomb cap, and pairs
    apart that still carry one."""
    rng = np.random.default_rng(seed)
    side = 0.62 * n ** (1.0 / dim)
    pos = rng.uniform(0, side, (n, dim))
    rad = rng.uniform(0.4, 0.6, n)
    lateral = np.full(dim - 1, side)
    vel = rng.normal(0, 1e-2, (n, dim))
    n_rot = 1 if dim == 2 else 3
    omega = rng.normal(0, 1e-2, (n, n_rot))
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)
             if np.sum(np.square(K._pair_geometry(pos, lateral, i, j))) < (rad[i] + rad[j] + 0.3) ** 2]
    pair_i = np.array([p[0] for p in pairs], np.int64)
    pair_j = np.array([p[1] for p in pairs], np.int64)
    m = len(pairs)
    mass = rad ** dim
    pair_c = np.zeros((m, K.N_PCOL))
    K.pair_constants(pair_i, pair_j, m, rad, mass, pair_c)
    overlap = np.array([rad[i] + rad[j] - np.sqrt(np.sum(np.square(K._pair_geometry(pos, lateral, i, j))))
                        for i, j in pairs])
    kind = rng.integers(0, 4, m)
    pair_ov = np.where(kind == 0, 0.0, np.abs(overlap) * rng.uniform(0.5, 1.5, m))
    pair_ft = rng.normal(0, 1e-3, (m, dim)) * (kind != 0)[:, None]
    pair_ft[kind == 3] *= 1e3  # far beyond mu F_n: these slide
    return pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, int(np.sum(overlap > 0))


def law_and_history(state, p, i, j, dt, zeta, mu, rescale, e12, g12):
    """Pair p = (i, j) through kernels._pair_law, its history updated as the engines do:
    (touching, delta, a_i, a_j, n, force on i)."""
    pos, vel, omega, rad, lateral, _, _, pair_c, pair_ft, pair_ov, _ = state
    touch, delta, ai, aj, nx, ny, nz, fx, fy, fz, hx, hy, hz = K._pair_law(
        pos, vel, omega, rad, lateral, pair_ft, pair_ov, p, i, j, dt, CM.damping_model(zeta), CM.tangential_model(mu),
        rescale, e12, g12,
        pair_c[p, K.PC_R12], pair_c[p, K.PC_ROOT], pair_c[p, K.PC_MEFF], LAW)
    if not touch:
        if pair_ov[p] != 0.0:
            pair_ov[p] = 0.0
            pair_ft[p] = 0.0
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if mu > 0.0:
        pair_ft[p] = (hx, hy, hz)[: pos.shape[1]]
    pair_ov[p] = delta
    return True, delta, ai, aj, nx, ny, nz, fx, fy, fz


def pair_at_a_time(state, jmax, dt, zeta, mu, rescale):
    """The one-thread loop's pairs through kernels._pair_law, one at a time, in list order."""
    pos, omega, pair_i, pair_j, pair_ft, pair_ov = (state[k] for k in (0, 2, 5, 6, 8, 9))
    force = np.zeros_like(pos)
    torque = np.zeros_like(omega)
    e12, g12 = C.effective_young(False), C.effective_shear(0.2, False)
    dmax, count = 0.0, 0
    for p, (i, j) in enumerate(zip(pair_i, pair_j)):
        if j >= jmax:
            continue
        touch, delta, ai, aj, nx, ny, nz, fx, fy, fz = law_and_history(state, p, i, j, dt, zeta, mu, rescale,
                                                                       e12, g12)
        if not touch:
            continue
        f = np.array([fx, fy, fz])[: pos.shape[1]]
        force[i] += f
        force[j] -= f
        for k, arm in ((i, ai), (j, aj)):
            t = np.zeros_like(torque)
            K._add_torque3(t, k, arm, nx, ny, nz, fx, fy, fz)
            torque[k] += t[k]
        dmax = max(dmax, delta)
        count += 1
    return force, torque, pair_ft, pair_ov, dmax, count


def tiled(state, jmax, dt, zeta, mu, rescale):
    pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, _ = state
    force = np.zeros_like(pos)
    torque = np.zeros_like(omega)
    t, tp = PT.scratch()
    e12, g12 = C.effective_young(False), C.effective_shear(0.2, False)
    p, dmax, count, tiles = 0, 0.0, 0, 0
    while p < len(pair_i):
        p, dmax, count = PT.law_tile(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft, pair_ov, p,
                                     len(pair_i), jmax, dt, CM.damping_model(zeta), CM.tangential_model(mu), rescale,
                                     e12, g12, LAW, CM.NO_ROLLING, t[0], tp[0], force, torque, dmax, count)
        tiles += 1
    return (force, torque, pair_ft, pair_ov, dmax, count), tiles


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("zeta, mu, rescale", [(0.5, 0.5, True), (0.5, 0.5, False), (0.0, 0.3, True),
                                                (0.7, 0.0, True), (0.0, 0.0, True)])
def test_tiled_law_gives_the_bits_of_the_pair_at_a_time_law(dim, zeta, mu, rescale):
    """Forces, torques (summed in list order), new histories, cleared histories of pairs apart,
    the largest overlap and the contact count: the same bytes, over more than one tile, and
    pairs whose j is beyond jmax untouched."""
    state = dense_state(dim, 400 if dim == 2 else 300, seed=dim)
    n = len(state[3])
    assert state[-1] > PT.TILE  # more than one tile of contacts
    for jmax in (n, n // 2):
        ref = pair_at_a_time(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in state), jmax, 0.01,
                             zeta, mu, rescale)
        got, tiles = tiled(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in state), jmax, 0.01,
                           zeta, mu, rescale)
        assert tiles >= (2 if jmax == n else 1)
        assert ref[5] > 0 and ref[5] == got[5] and ref[4] == got[4]
        for a, b in zip(ref[:4], got[:4]):
            assert a.tobytes() == b.tobytes()
        if jmax < n:  # skipped pairs keep their history
            skipped = state[6] >= jmax
            assert np.array_equal(got[2][skipped], state[8][skipped])
            assert np.array_equal(got[3][skipped], state[9][skipped])


def incoming_at_a_time(state, slots, dt, zeta, mu, rescale):
    """A block's incoming pairs (pair indices ``slots``, in slot order) as kernels._incoming_block
    computed them before the staged law: one at a time through kernels._pair_law, the force
    subtracted from g with g's torque, the force on k and k's torque into the slot's row."""
    pos, omega, pair_i, pair_j, pair_ft, pair_ov = (state[k] for k in (0, 2, 5, 6, 8, 9))
    d, r = pos.shape[1], omega.shape[1]
    force = np.zeros_like(pos)
    torque = np.zeros_like(omega)
    bnd_f = np.full((len(slots), d + r), np.nan)
    e12, g12 = C.effective_young(False), C.effective_shear(0.2, False)
    dmax, count = 0.0, 0
    for s, p in enumerate(slots):
        k, g = pair_i[p], pair_j[p]
        touch, delta, ai, aj, nx, ny, nz, fx, fy, fz = law_and_history(state, p, k, g, dt, zeta, mu, rescale,
                                                                       e12, g12)
        if not touch:
            bnd_f[s] = 0.0
            continue
        f = np.array([fx, fy, fz])[:d]
        force[g] -= f
        t = np.zeros_like(torque)
        K._add_torque3(t, g, aj, nx, ny, nz, fx, fy, fz)
        torque[g] += t[g]
        arm = {0: [], 1: [ai * (nx * fy - ny * fx)],  # k's torque, for k's row to add (from +0)
               3: [ai * (ny * fz - nz * fy), ai * (nz * fx - nx * fz), ai * (nx * fy - ny * fx)]}[r]
        bnd_f[s] = np.concatenate([f, arm])
        dmax = max(dmax, delta)
        count += 1
    return force, torque, pair_ft, pair_ov, bnd_f, dmax, count


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("zeta, mu, rescale", [(0.5, 0.5, True), (0.0, 0.3, False), (0.7, 0.0, True),
                                                (0.0, 0.0, True)])
def test_tiled_incoming_pairs_give_the_bits_of_the_pair_at_a_time_law(dim, zeta, mu, rescale):
    """The incoming pairs of a block (pair_tile.law_tile_incoming, tile by tile): forces and
    torques on g, the slots' forces and torques for k (zeros for pairs apart), histories, the
    largest overlap and the contact count, the same bytes as one pair at a time."""
    state = dense_state(dim, 400 if dim == 2 else 300, seed=10 + dim)
    pair_i, pair_j = state[5], state[6]
    g0 = len(state[3]) // 3  # a block [g0, n): its incoming pairs (k, g), k < g0 <= g, by g then k
    slots = np.array(sorted((p for p in range(len(pair_i)) if pair_i[p] < g0 <= pair_j[p]),
                            key=lambda p: (pair_j[p], pair_i[p])), np.int64)
    ref = incoming_at_a_time(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in state), slots, 0.01,
                             zeta, mu, rescale)
    pos, vel, omega, rad, lateral, _, _, pair_c, pair_ft, pair_ov, _ = (
        a.copy() if isinstance(a, np.ndarray) else a for a in state)
    force, torque = np.zeros_like(pos), np.zeros_like(omega)
    bnd_f = np.full_like(ref[4], np.nan)
    t, tp = PT.scratch()
    e12, g12 = C.effective_young(False), C.effective_shear(0.2, False)
    s, dmax, count, tiles = 0, 0.0, 0, 0
    while s < len(slots):
        s, dmax, count = PT.law_tile_incoming(pos, vel, omega, rad, lateral, pair_i, pair_j, pair_c, pair_ft,
                                              pair_ov, slots, s, len(slots), 0.01, CM.damping_model(zeta),
                                              CM.tangential_model(mu), rescale, e12, g12, LAW, CM.NO_ROLLING, t[0],
                                              tp[0], force, torque, bnd_f, dmax, count)
        tiles += 1
    assert tiles >= 2 and ref[6] > PT.TILE  # more than one tile of contacts
    assert ref[6] == count and ref[5] == dmax
    for a, b in zip(ref[:5], (force, torque, pair_ft, pair_ov, bnd_f)):
        assert a.tobytes() == b.tobytes()
