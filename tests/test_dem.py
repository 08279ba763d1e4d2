"""The DEM engine against exact results: Hertz collisions, energy, Newton's third law, images."""

import math

import numpy as np
import pytest
from scipy.special import beta

from granwave import contact as C
from granwave.dem import kernels as K
from granwave.dem import workspace as WS
from granwave.dem.integrator import Engine
from granwave.dem.protocol import granular_gas


def hertz_collision_time(v, r12, e12, m_eff):
    """Exact Hertz contact time: m d'' = -K d^(3/2), K = (4/3) sqrt(R12) E12, approach speed v:
    t_c = 2 (d_max / v) int_0^1 (1 - x^(5/2))^(-1/2) dx, d_max = (5 m v^2 / (4 K))^(2/5)."""
    k = C.normal_force(1.0, r12, e12)
    d_max = (5.0 * m_eff * v * v / (4.0 * k)) ** 0.4
    return 2.0 * d_max / v * 0.4 * beta(0.4, 0.5)


def collide(dim, wall, zeta=0.0, v=0.01, per_contact=1000, friction=0.5):
    """Run one head-on collision step by step; return (contact time, exact time, restitution)."""
    R = 0.5
    lateral = np.full(dim - 1, 10.0)
    mid = np.full(dim, 5.0)
    m = math.pi / 6.0
    if wall:
        pos = mid[None, :].copy()
        pos[0, -1] = R + 0.002
        vel = np.zeros((1, dim))
        vel[0, -1] = -v
        r12, e12, m_eff = R, C.effective_young(True), m
    else:
        pos = np.array([mid, mid])
        pos[0, 0] -= R + 0.001
        pos[1, 0] += R + 0.001
        vel = np.zeros((2, dim))
        vel[0, 0], vel[1, 0] = 0.5 * v, -0.5 * v
        r12, e12, m_eff = R / 2, C.effective_young(False), m / 2
    tc = hertz_collision_time(v, r12, e12, m_eff)
    dt = tc / per_contact
    eng = Engine(pos, np.full(len(pos), R), lateral, 10.0, friction=friction, damping=zeta, dt=dt,
                 velocity=vel)
    in_contact = 0
    started = False
    for _ in range(10 * per_contact):
        eng.run(1)
        touching = eng.out.ncontact > 0
        in_contact += touching
        started |= touching
        if started and not touching:
            break
    if wall:
        e = eng.velocity[0, -1] / v
    else:
        e = (eng.velocity[1, 0] - eng.velocity[0, 0]) / v
    return in_contact * dt, tc, e


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("wall", [False, True])
def test_hertz_collision_time_and_restitution(dim, wall):
    # contact time resolved to 1/1000: within 1% of the Hertz formula; undamped restitution 1 within 1e-3
    t, tc, e = collide(dim, wall)
    assert t == pytest.approx(tc, rel=0.01)
    assert e == pytest.approx(1.0, abs=1e-3)


def test_restitution_decreases_with_damping():
    es = [collide(2, False, zeta=z, per_contact=300)[2] for z in (0.0, 0.05, 0.2, 0.5)]
    assert es[0] == pytest.approx(1.0, abs=1e-3)
    assert all(a > b for a, b in zip(es[:-1], es[1:])), es
    assert es[1] < 1.0 - 1e-3 and es[-1] > 0.0


def gas_engine(dt, friction=0.0, zeta=0.0, seed=1, n=40, dim=2):
    rng = np.random.default_rng(seed)
    radius = 0.5 * rng.uniform(0.8, 1.2, n)
    lateral = np.full(dim - 1, 8.0)
    pos, height = granular_gas(radius, lateral, 0.35, rng)
    vel = rng.normal(0.0, 0.01, size=pos.shape)
    return Engine(pos, radius, lateral, height, friction=friction, damping=zeta, dt=dt, velocity=vel)


def energy_drift(dt, t_end=150.0):
    eng = gas_engine(dt)
    e0 = eng.total_energy()
    worst = 0.0
    collisions = 0
    for _ in range(30):
        eng.run(int(round(t_end / 30 / dt)))
        worst = max(worst, abs(eng.total_energy() - e0) / e0)
        collisions += eng.out.ncontact > 0
    return worst, collisions


def test_energy_conserved_without_damping_and_error_shrinks_with_dt():
    """Frictionless undamped gas with collisions, walls and periodic images: the largest energy
    error over the run is below 1e-3 of the total at dt = 0.1 (about t_c / 50 for these speeds)
    and falls at least 3x when dt is halved (velocity Verlet: O(dt^2))."""
    e1, hits = energy_drift(0.1)
    e2, _ = energy_drift(0.05)
    assert hits > 5  # collisions happened during the run
    assert e1 < 1e-3
    assert e2 < e1 / 3.0


def test_newton_third_law_forces_and_torques():
    """Frictional damped cluster away from walls: total force and total angular momentum change
    (torques plus r x f, about the origin) vanish to 1e-12 of the sum of magnitudes."""
    rng = np.random.default_rng(4)
    n = 30
    radius = 0.5 * rng.uniform(0.8, 1.2, n)
    # a jammed blob in the middle of a large box, squeezed so that many contacts exist
    pos = np.column_stack([rng.uniform(17, 23, n), rng.uniform(17, 23, n)])
    vel = rng.normal(0, 0.02, size=(n, 2))
    eng = Engine(pos, radius, [40.0], 40.0, friction=0.3, damping=0.2, dt=0.02, velocity=vel,
                 angular_velocity=rng.normal(0, 0.05, size=(n, 1)))
    eng.run(200)
    assert eng.out.ncontact > 10
    f = eng.acceleration * eng.mass[:, None]
    tau = eng.angular_acceleration[:, 0] * eng.inertia
    scale = np.abs(f).sum()
    assert np.abs(f.sum(axis=0)).max() < 1e-12 * scale
    moment = tau.sum() + np.sum(eng.position[:, 0] * f[:, 1] - eng.position[:, 1] * f[:, 0])
    assert abs(moment) < 1e-12 * scale * 40.0
    assert np.abs(tau).max() > 0  # friction acted


@pytest.fixture
def use_threads(monkeypatch):
    """use_threads(n): run the engines on n threads from here to the end of the test, the block
    engine even for a few grains; skips the test on a machine with fewer threads."""
    import numba

    from granwave import threads as T

    keep = numba.get_num_threads()

    def use(n):
        if n > numba.config.NUMBA_NUM_THREADS:
            pytest.skip(f"needs {n} threads")
        monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
        T.set_threads(n)

    yield use
    numba.set_num_threads(keep)


@pytest.mark.parametrize("threads", [1, 2])
def test_pair_constants_follow_the_pair_list(threads, use_threads, monkeypatch):
    """R12, sqrt(R12) and m_eff kept per listed pair (kernels.pair_constants) stay those of the
    pair's two grains through rebuilds and growth of the lists (one-thread loop and block
    engine): a frictional gas with contacts from the first step, squeezed by the piston, run
    with lists that start too small for the neighbours and the incoming pairs gives the bytes
    of the one-thread loop with the default sizes, and its final constants equal the law's
    expressions evaluated here."""
    from granwave.dem import integrator

    use_threads(threads)
    rng = np.random.default_rng(9)
    n = 60
    radius = 0.5 * rng.uniform(0.8, 1.2, n)
    pos = np.column_stack([rng.uniform(0, 10, n), rng.uniform(0.6, 10, n)])  # 62 contacts at once
    vel = rng.normal(0, 0.05, size=(n, 2))

    def run():
        eng = Engine(pos, radius, [10.0], 11.0, friction=0.5, damping=0.3, piston_mass=5.0, piston_force=0.05,
                     velocity=vel)
        eng.run(2000)
        return eng

    use_threads(1)
    ref = run()  # the one-thread pair loop with lists of the default sizes
    use_threads(threads)
    monkeypatch.setattr(integrator, "NEIGHBOUR_WIDTH", {2: 2, 3: 2})
    monkeypatch.setattr(WS, "boundary_room", lambda n: 1)  # read by workspace() in its module
    grown = []
    grow = integrator.Engine.grow
    monkeypatch.setattr(integrator.Engine, "grow", lambda self, *a: grown.append(a) or grow(self, *a))
    eng = run()
    assert grown and eng.rebuilds > 3 and ref.out.ncontact > n
    if threads > 1:  # the room for incoming pairs grew (a request with no new width)
        assert any(a[1] == 0 for a in grown)
    assert eng.position.tobytes() == ref.position.tobytes()
    m = eng.n_pairs
    i, j = eng.pair_i[:m], eng.pair_j[:m]
    r12 = 1.0 / (1.0 / radius[i] + 1.0 / radius[j])
    want = np.column_stack([r12, np.sqrt(r12), eng.mass[i] * eng.mass[j] / (eng.mass[i] + eng.mass[j])])
    assert np.array_equal(eng.ws.pair_c[:m], want)


@pytest.mark.parametrize("threads", [1, 2])
def test_wall_list_misses_no_wall_contact(threads, use_threads):
    """The wall loops visit only the grains near a wall (kernels.wall_list, made at each rebuild
    and when the piston has moved skin / 2). A light piston driven down onto grains thrown at
    both walls: one run of many steps gives the bytes of one-step runs, each of which makes
    the list anew, while the piston travels many skins and touches grains."""
    use_threads(threads)
    rng = np.random.default_rng(3)
    n = 40
    radius = 0.5 * rng.uniform(0.8, 0.95, n)
    pos = np.column_stack([np.arange(n) % 10 + 0.5, 0.6 + 1.5 * (np.arange(n) // 10)])
    vel = np.column_stack([rng.normal(0, 0.05, n), np.where(np.arange(n) < 20, -0.03, 0.03)])

    def engine():
        return Engine(pos, radius, [10.0], 20.0, friction=0.5, damping=0.1, piston_mass=0.5, piston_force=0.01,
                      velocity=vel)

    long_run = engine()
    long_run.run(1500)
    steps = engine()
    top = 0
    for _ in range(1500):
        steps.run(1)
        top = max(top, int(steps.out.ntop))
    assert top > 0 and 20.0 - steps.piston.h > 20 * 0.2
    assert long_run.position.tobytes() == steps.position.tobytes()
    assert long_run.piston.tobytes() == steps.piston.tobytes()


def test_fold_into_box():
    """Lateral coordinates fold into [0, L) at the step they leave it: a fold down is exact, a
    fold up that rounds to L gives 0."""
    from granwave.geometry import fold_into_box

    L = 10.3
    for x in (0.0, 3.7, L - 1e-9, np.nextafter(L, 0.0)):
        assert fold_into_box(x, L) == x
    for x in (L, L + 0.25, 1.9 * L):
        assert fold_into_box(x, L) == x - L and 0.0 <= x - L < L  # exact (Sterbenz)
    assert fold_into_box(-0.25, L) == -0.25 + L
    assert fold_into_box(-1e-18, L) == 0.0  # -1e-18 + L rounds to L: the grain sits at 0


def _drifting_gas(dim, skin, skin_min=None):
    """Grains of a gas with a lateral drift (each crosses the periodic boundary about twice),
    thrown against the bottom and a falling piston."""
    rng = np.random.default_rng(5)
    n = 50
    lateral = np.full(dim - 1, 8.0)
    radius = 0.5 * rng.uniform(0.8, 1.2, n)
    pos = np.column_stack([rng.uniform(0, 8.0, (n, dim - 1)), rng.uniform(0.7, 11.0, n)])
    vel = rng.normal(0, 0.03, (n, dim))
    vel[:, 0] += 0.08
    return Engine(pos, radius, lateral, 12.0, friction=0.5, damping=0.3, piston_mass=3.0,
                  piston_force=0.02, skin=skin, skin_min=skin_min, velocity=vel)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("threads", [1, 2])
def test_bits_do_not_depend_on_skin(dim, threads, use_threads):
    """Positions are folded into the box at every drift, never at a rebuild, and pairs not in
    contact add nothing: the same run with skins 0.4, 0.1 and an adaptive skin (0.4 down to
    0.02) gives the same bytes, with different rebuild counts, while most grains cross the
    periodic boundary and grains hit both walls (the adaptive skin, shrinking, in the next
    test)."""
    use_threads(threads)
    runs = {}
    for key in ((0.4, None), (0.1, None), (0.4, 0.02)):
        eng = _drifting_gas(dim, *key)
        start = eng.position.copy()
        travelled = np.zeros(len(eng.radius))
        for _ in range(40):  # the lateral distance each grain travels (folds do not count)
            before = eng.velocity[:, 0].copy()
            eng.run(50)
            travelled += 50 * eng.dt * 0.5 * (before + eng.velocity[:, 0])
        runs[key] = eng
    fixed = runs[(0.4, None)]
    assert np.median(np.abs(travelled)) > 8.0  # most grains crossed the boundary
    assert fixed.out.ncontact > 0 and fixed.steps == 2000
    assert np.all((fixed.position[:, 0] >= 0.0) & (fixed.position[:, 0] < 8.0))
    assert not np.array_equal(fixed.position, start)
    assert runs[(0.1, None)].rebuilds > 2 * fixed.rebuilds
    for key, eng in runs.items():
        for name in ("position", "velocity", "angular_velocity", "piston", "wall_ov"):
            assert getattr(eng, name).tobytes() == getattr(fixed, name).tobytes(), (key, name)


def test_adaptive_skin_follows_the_grains_speed():
    """The adaptive skin shrinks to skin_min while a packing is at rest (a list lasting twice
    SKIN_STEPS is made again smaller) and grows back, at most by two per rebuild, when the
    grains move fast; a fixed skin never changes."""
    eng = _drifting_gas(2, 0.4, 0.02)
    fixed = _drifting_gas(2, 0.4)
    engines = (eng, fixed)
    for e in engines:
        e.run(200)
    assert eng.skin == 0.4 and fixed.skin == 0.4  # a fast gas: lists last fewer than SKIN_STEPS
    for e in engines:
        e.velocity[:] = 0.0
        e.angular_velocity[:] = 0.0
        e.piston.v = e.piston.f_ext = 0.0
        e.fpar.gamma = 1.0  # strong background damping: the grains come to rest
        e.run(20 * K.SKIN_STEPS)
    assert eng.skin == 0.02 and fixed.skin == 0.4
    skins = []
    for e in engines:
        e.fpar.gamma = 0.0
        e.velocity[:, 0] = 0.05  # a fast drift: the lists last a step or two
    for _ in range(30):  # step by step: at most one rebuild in between
        for e in engines:
            e.run(1)
        skins.append(eng.skin)
    assert skins[-1] == 0.4 and all(b <= 2.0 * a for a, b in zip([0.02] + skins, skins))
    assert fixed.skin == 0.4
    assert eng.position.tobytes() == fixed.position.tobytes()
    assert eng.velocity.tobytes() == fixed.velocity.tobytes()
    with pytest.raises(Exception, match="skin_min"):
        _drifting_gas(2, 0.1, 0.2)


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_across_periodic_boundary(dim):
    """The same overlapping, sliding pair placed across the periodic boundary and in the middle
    of the box gives the same forces and torques (relative 1e-12)."""
    L = 9.0
    radius = np.array([0.45, 0.55])
    offset = np.zeros(dim)
    offset[0] = 0.98
    offset[1] = 0.1
    vel = np.zeros((2, dim))
    vel[1, 1] = 0.01
    out = []
    for x0 in (L - 0.3, 4.0):
        a = np.full(dim, 3.0)
        a[0] = x0
        pos = np.array([a, a + offset])
        eng = Engine(pos, radius, np.full(dim - 1, L), 6.0, friction=0.5, damping=0.1, dt=0.01, velocity=vel)
        eng.run(20)
        out.append((eng.acceleration.copy(), eng.angular_acceleration.copy()))
    assert np.abs(out[0][0]).max() > 0
    np.testing.assert_allclose(out[0][0], out[1][0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(out[0][1], out[1][1], rtol=1e-12, atol=1e-14)


def test_history_survives_neighbour_rebuilds():
    """A sheared, compressed column of two grains between the walls: many list rebuilds (tiny
    skin) give the same tangential history as a skin that never rebuilds (relative 1e-12)."""
    results = []
    for skin in (0.0005, 0.6):
        pos = np.array([[3.0, 0.49], [3.0, 1.47]])
        vel = np.array([[0.0, 0.0], [0.02, 0.0]])
        eng = Engine(pos, np.array([0.5, 0.5]), [12.0], 1.96, friction=0.5, damping=0.0, dt=0.01, skin=skin,
                     velocity=vel)
        eng.run(2000)
        results.append((eng.pair_ft[: eng.n_pairs].copy(), eng.wall_ft.copy(), eng.rebuilds))
    assert results[0][2] > 3 and results[1][2] == 0
    np.testing.assert_allclose(results[0][0], results[1][0], rtol=1e-12)
    np.testing.assert_allclose(results[0][1], results[1][1], rtol=1e-12)
    assert np.abs(results[0][0]).max() > 0


@pytest.mark.parametrize("dim", [2, 3])
def test_cell_list_pairs_equal_brute_force_and_are_sorted(dim):
    """The cell-list candidate keys (emitted sorted per grain, no global sort) are exactly the
    sorted keys of an all-pairs search with the same skin and nearest images."""
    from granwave.dem.neighbours import candidate_keys
    from granwave.geometry import nearest_image

    rng = np.random.default_rng(7)
    n = 150 if dim == 2 else 200
    radius = 0.5 * rng.uniform(0.8, 1.2, n)
    lateral = np.full(dim - 1, 9.0)
    pos, height = granular_gas(radius, lateral, 0.45 if dim == 2 else 0.2, rng)
    pos[:, :-1] %= lateral
    skin = 0.3
    keys = candidate_keys(pos, radius, lateral, height, skin)
    want = []
    for i in range(n):
        for j in range(i + 1, n):
            x = pos[j] - pos[i]
            for a in range(dim - 1):
                x[a] = nearest_image(x[a], lateral[a])
            if np.dot(x, x) < (radius[i] + radius[j] + skin) ** 2:
                want.append(i * n + j)
    assert len(want) > n  # a dense enough gas
    np.testing.assert_array_equal(keys, np.array(want, np.int64))


@pytest.mark.parametrize("zeta", [0.0, 0.3, 1.0, 1.87])
def test_verlet_limit_is_the_schemes_stability_limit(zeta):
    """The engine's step on x'' = -w^2 x - 2 zeta w v (damping on the half-step velocity):
    the amplification matrix has spectral radius <= 1 just below kernels.verlet_limit and > 1
    just above it."""
    w = 1.0

    def radius(h):
        m = np.zeros((3, 3))
        for k, (x, v, a) in enumerate(np.eye(3)):
            vh = v + 0.5 * h * a
            x2 = x + h * vh
            a2 = -w * w * x2 - 2 * zeta * w * vh
            m[:, k] = [x2, vh + 0.5 * h * a2, a2]
        return np.abs(np.linalg.eigvals(m)).max()

    lim = K.verlet_limit(w, zeta)
    assert radius(0.999 * lim) <= 1.0 + 1e-9
    assert radius(1.001 * lim) > 1.0 + 1e-6


def test_time_step_includes_damping_and_rotation():
    """stable_dt: frictionless undamped 2/w_n x safety/0.1; friction adds the rotational mode
    (w_t^2 = 3.5 k_t/m) and damping shrinks both."""
    eng = gas_engine(None, friction=0.0)
    f = K.record(K.PARAMS, eng.fpar)
    k = C.normal_stiffness(f.overlap_floor, f.r_max, 1.0)
    w = math.sqrt(k / f.m_min)
    scale = f.safety / K.SAFETY_AT_LIMIT
    assert K.stable_dt(f) == pytest.approx(scale * 2.0 / w, rel=1e-14)
    f.friction = 0.5
    assert K.stable_dt(f) == pytest.approx(scale * 2.0 / (w * math.sqrt(3.5)), rel=1e-14)
    f.damping = 1.0
    z = math.sqrt(3.5)
    assert K.stable_dt(f) == pytest.approx(scale * 2.0 * (math.sqrt(1 + z * z) - z) / (w * z), rel=1e-14)


def test_blow_up_is_reported_not_a_memory_error():
    """A step far beyond the limit: run() stops with status 3 (unstable) instead of feeding
    non-finite positions to the neighbour list."""
    eng = gas_engine(5.0, friction=0.5, zeta=0.5)
    status = 0
    for _ in range(200):
        status = eng.run(100)
        if status:
            break
    assert status == 3
