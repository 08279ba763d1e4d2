"""The constant-stiffness tangential spring (``--tangential linear_history``;
granwave.contact_models.linear_history, LAMMPS's ``tangential linear_history``): exact checks.

- its formulas through the dispatchers: k_t = kt between grains and 2 kt at the wall, no
  unloading rescale, spring and Coulomb slider, the time step's ratio;
- a grain hitting the rigid wall obliquely (harmonic normal law, no damping, no spin at first):
  the wall is the second body and the contact normal stays fixed, so the collision has a closed
  form. The contact point's slip s = v_x + a w obeys m_t s' = F_t with m_t = m / (1 + m a^2 / I)
  = m / 3.5 (a = R); the normal motion is the wall spring's, omega_n^2 = k_w / m, for pi / omega_n.
  (a) k_t = k_w / 3.5 (omega_t = omega_n): F_t / F_n = (k_t / k_w)(s0 / v_n0) stays constant, so
  with mu above it the contact sticks throughout and the grain leaves with its slip reversed,
  s = -s0: v_x = v_x0 - 2 s0 / 3.5, w = -5 s0 / (3.5 R); (b) s0 > 7 mu v_n0: it slides throughout,
  F_t = -mu F_n, so the tangential impulse is mu times the normal one, 2 m v_n0: v_x = v_x0 -
  2 mu v_n0, w = -5 mu v_n0 / R;
- LAMMPS: the words ``export lammps`` writes, and an oblique collision of two grains and one of a
  grain on the wall run in LAMMPS with them, leave with granwave's velocities and spins;
- a DEM-prepared packing: its file records the law, its k_t are kt and 2 kt, and the linearization
  equals the finite-difference Jacobian of the engine's frozen-history forces.
"""

import math

import numpy as np
import pytest

from granwave import contact as C
from granwave import contact_models as CM
from granwave.contact_models import options as CO
from granwave.dem.integrator import Engine
from granwave.params import PrepareParams
from lammps_collisions import granwave_collision, lammps_collision

MASS = math.pi / 6  # a unit grain (rho = 1)
LAW = dict(tangential="linear_history")


def _model(mu, kt):
    return CM.model_of("tangential", CO.resolve(dict(friction=mu, poisson=0.0, linear_history_stiffness=kt, **LAW)))


def test_formulas_through_the_dispatchers():
    m = _model(0.4, 0.03)
    e_pair, e_wall = C.effective_young(False), C.effective_young(True)
    assert m.code == CO.SUBMODELS["linear_history"]["code"] and CM.own_constants("tangential", m) == (0.4, 0.03)
    # constant k_t, whatever the normal law's (kt_law) and the overlap; twice at a rigid wall
    for kt_law, n in ((0.7, 1e-3), (1e-5, 2e-2)):
        assert CM.tangential_spring(m, kt_law, n, e_pair) == 0.03
        assert CM.tangential_spring(m, kt_law, n, e_wall) == 0.06
    assert not CM.tangential_unloads(m, 2e-3, 1e-3, True)  # nothing to rescale
    # spring, then the Coulomb cap mu F_n
    assert CM.tangential_increment(m, 1e-5, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.03, 1.0) == (1e-5 + 3e-5, 0.0, 0.0, False)
    fx, fy, fz, slid = CM.tangential_increment(m, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.03, 0.01)
    assert slid and math.hypot(fx, fy) == pytest.approx(0.4 * 0.01, rel=1e-15)
    assert CM.tangential_at_limit(m, fx, fy, fz, 0.01, 1e-9)
    assert CM.friction_acts(m) and not CM.friction_acts(_model(0.0, 0.03))
    # the time step: a wall's 2 kt counted twice, over the normal law's step stiffness
    assert CM.tangential_step_ratio(m, 0.2, MASS, 0.0) == pytest.approx(4 * 0.03 / 0.2, rel=1e-15)


def _wall_collision(mu, kn, kt, v_n, v_t, steps_per_contact=2000):
    """A grain (R = 1/2) falling at v_n with a sideways v_t onto the bottom wall, harmonic normal
    law (k_w = 2 kn at the wall), linear_history kt, no damping: (velocity, spin, largest overlap)
    after it left."""
    k_w = 2.0 * kn
    t_c = math.pi * math.sqrt(MASS / k_w)
    dt = t_c / steps_per_contact
    gap = 20.5 * v_n * dt
    e = Engine([[5.0, 0.5 + gap]], [0.5], [10.0], 10.0, friction=mu, damping=0.0, dt=dt, skin=0.2, check_every=0,
               velocity=[[v_t, -v_n]], contact_law="harmonic", harmonic_stiffness=kn, linear_history_stiffness=kt,
               **LAW)
    deepest = 0.0
    for _ in range(steps_per_contact + 100):
        e.run(1)
        deepest = max(deepest, 0.5 - e.position[0, 1])
    assert 0.5 - e.position[0, 1] < 0.0  # it left
    return e.velocity[0], e.angular_velocity[0, 0], deepest


def test_oblique_wall_collision_sticks_and_reverses_the_slip():
    """(a) of the module docstring. Tolerance from the lever arm a = R - n (the contact point on the
    wall plane): m_t and so omega_t move by ~ 2.5/3.5 x 2 n / R during the contact, a phase error
    of that order in the slip; measured |s/s0 + 1| = 0.9 n_max / R. Normal restitution 1 to 1e-8."""
    kn, v_n, v_t, mu = 0.05, 1e-5, 1e-5, 0.5
    kt = kn / 3.5  # k_t at the wall 2 kt = k_w / 3.5
    assert mu > (2 * kt / (2 * kn)) * v_t / v_n  # sticks throughout
    v, w, deepest = _wall_collision(mu, kn, kt, v_n, v_t)
    R = 0.5
    assert v[1] == pytest.approx(v_n, rel=1e-8)
    slip = v[0] + R * w
    tol = 3.0 * deepest / R
    assert deepest / R < 1e-4
    assert slip / v_t == pytest.approx(-1.0, abs=tol)
    assert v[0] == pytest.approx(v_t - 2.0 * v_t / 3.5, abs=tol * v_t)
    assert R * w == pytest.approx(-5.0 * v_t / 3.5, abs=tol * v_t)


def test_oblique_wall_collision_slides_throughout():
    """(b) of the module docstring: the slider's force is mu F_n at every step, so the tangential
    impulse is mu times the normal one to rounding (1e-9 asked; the contact's first step, which
    may stick, is one of ~2000); the spin's arm R - n changes it by ~ n / R (asked: 3 n_max / R)."""
    kn, v_n, v_t, mu = 0.05, 1e-5, 1e-5, 0.1
    kt = kn / 3.5
    assert v_t > 7 * mu * v_n and (2 * kt) * v_t > mu * (2 * kn) * v_n  # slides from the start to the end
    v, w, deepest = _wall_collision(mu, kn, kt, v_n, v_t)
    R = 0.5
    assert v[1] == pytest.approx(v_n, rel=1e-8)
    assert v[0] == pytest.approx(v_t - 2.0 * mu * v_n, rel=1e-6)
    assert R * w == pytest.approx(-5.0 * mu * v_n, rel=3.0 * deepest / R)


def _collisions(speed: float):
    """The two collisions of the LAMMPS check at ``speed`` times the base speeds (the gaps and spins
    scaled alike, the run long enough): {name: (initial state, steps)}."""
    f = speed
    return {
        "pair": (dict(position=[[4.5, 5.0, 5.0], [5.45 + 0.04 * f, 5.2, 5.1]], radius=[0.5, 0.45],
                      velocity=(f * np.array([[1e-3, 2e-4, 0.0], [-1e-3, -3e-4, 1e-4]])).tolist(),
                      spin=(f * np.array([[0.0, 1e-3, 2e-3], [0.0, 0.0, -1e-3]])).tolist()), round(6000 / f)),
        "wall": (dict(position=[[5.0, 5.0, 0.5 + 0.02 * f]], radius=[0.5],
                      velocity=(f * np.array([[4e-4, 1e-4, -1e-3]])).tolist(), spin=[[0.0, 0.0, 0.0]]),
                 round(3000 / f)),
    }


def test_lammps_export_and_a_lammps_run_of_the_same_collisions_agree():
    """The words: ``tangential linear_history kt xgammat mu`` for pairs, 2 kt for the wall. Two grains
    (d = 1 and 0.9) colliding obliquely with spins, and a grain hitting the wall obliquely, run in
    LAMMPS with those words (fix nve/sphere, the same dt) and in granwave's engine, leave with the
    same velocities and spins up to one difference of convention: LAMMPS's lever arms are the radii,
    granwave's the distances to the contact point (R - n/2 between grains, R - n at a wall), so the
    slip and the torque differ at order n / R. Measured: 3.5e-4 (pair) and 1.6e-3 (wall) of the
    speeds at the base speeds (n_max / R ~ 4e-3), ten times less at a tenth of the speeds (n ~ speed):
    asked, the difference falls in proportion (ratio 10 +- 10 %), under 2e-3 of the speeds at the
    lower one, and the collisions changed the motion (the tangential force acted)."""
    from granwave.interop import lammps as LM

    mu, kn, kt = 0.3, 0.05, 0.02
    contact = dict(contact_law="harmonic", harmonic_stiffness=kn, linear_history_stiffness=kt, **LAW)
    pair = LM.granular_model(mu, 0.0, 0.0, wall=False, **contact)
    wall = LM.granular_model(mu, 0.0, 0.0, wall=True, **contact)
    for words, k_n, k_t in ((pair, kn, kt), (wall, 2 * kn, 2 * kt)):
        w = words.split()
        assert w[0] == "hooke" and float(w[1]) == k_n and "mindlin_rescale" not in w
        at = w.index("linear_history")
        assert w[at - 1] == "tangential" and float(w[at + 1]) == k_t and float(w[at + 3]) == mu
    lmp = LM.lammps_module()
    if lmp is None:
        pytest.skip("the lammps Python module is not installed")
    dt = 0.02
    diff = {}
    for speed in (1.0, 0.1):
        for name, (state, steps) in _collisions(speed).items():
            v_g, w_g = granwave_collision(**state, dt=dt, steps=steps, friction=mu, **contact)
            v_l, w_l = lammps_collision(lmp, **state, dt=dt, steps=steps, pair_words=pair, wall_words=wall)
            scale = np.abs(state["velocity"]).max()
            assert np.abs(v_g - np.asarray(state["velocity"])).max() > 0.5 * scale  # they collided
            assert np.abs(w_g - np.asarray(state["spin"])).max() > 0.05 * scale  # and F_t acted
            diff[speed, name] = (np.abs(v_g - v_l).max() / scale, 0.5 * np.abs(w_g - w_l).max() / scale)
    for name in ("pair", "wall"):
        for k in (0, 1):
            fast, slow = diff[1.0, name][k], diff[0.1, name][k]
            assert slow < 2e-3 and fast / slow == pytest.approx(10.0, rel=0.1), (name, k, fast, slow)


@pytest.fixture(scope="module")
def packing():
    from granwave.dem.protocol import prepare_packing

    return prepare_packing(PrepareParams(dim=2, grains=30, pressure=1e-4, friction=0.5, seed=2,
                                         linear_history_stiffness=0.01, **LAW))


def test_prepared_packing_records_the_law_and_linearizes(packing):
    """The file records the law and its k_t (options.attrs_of); the contact table's k_t are kt and
    2 kt; linearize(prestress=True) = -Jacobian of the frozen-history forces (central differences,
    eps = 1e-7 d) to 1e-6 relative, as tests/test_linearize.py asks for Hertz-Mindlin."""
    from granwave.dem.forces import frozen_history_forces
    from granwave.linear.assemble import linearize
    from granwave.linear.check import finite_difference_stiffness

    p = packing
    assert p.attrs["tangential"] == "linear_history" and p.attrs["linear_history_stiffness"] == 0.01
    c = p.contacts
    np.testing.assert_array_equal(c.stiffness_tangential, np.where(c.j < 0, 0.02, 0.01))
    assert np.abs(c.force_tangential).max() > 0.05 * c.force_normal.mean()
    s = linearize(p, prestress=True)
    fd = finite_difference_stiffness(s, lambda u, t: frozen_history_forces(p, u, t), p.n_grains, eps=1e-7)
    assert np.abs(s.stiffness.toarray() - fd).max() / np.abs(fd).max() < 1e-6
