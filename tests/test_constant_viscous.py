"""Viscous contact damping with a constant coefficient (``--damping-law constant_viscous``;
granwave.contact_models.damping_viscous, LAMMPS's ``damping velocity``): exact checks.

A linear (harmonic) contact k with the dashpot c between masses of reduced mass m is the damped
oscillator x'' = -(k x + c x') / m with the total force never attractive: from x = 0, x' = v0,
x(t) = (v0/w_d) e^(-s t) sin(w_d t) (w^2 = k/m, zeta = c / (2 m w), s = zeta w, w_d = w sqrt(1 -
zeta^2)) until the force k x + c x' reaches 0 at t1 (before the overlap closes); from then on
no force acts and the overlap closes at the speed -x'(t1) by t_c = t1 + x(t1) / -x'(t1). So the
restitution is e = -x'(t1) / v0 and the contact time t_c, each a closed form (t1 a root, found
by brentq). With c constant, zeta depends on the pair's masses: a coefficient, not a ratio.

- two grains of different sizes colliding head on: t_c and e of the closed form;
- a grain hitting the rigid wall obliquely and sliding throughout (harmonic law, Coulomb mu
  small): the slider's force is mu times the *elastic* normal force (granwave's rule, docs/method.md
  §2), so the tangential impulse is mu k (the integral of x(t) over the contact: closed form, the
  integral of the damped sine to t1 by quad plus the closing triangle), and no tangential dashpot
  acts while sliding;
- LAMMPS: the words ``export lammps`` writes (``damping velocity limit_damping`` with c as the
  normal model's damping number) and LAMMPS runs of an oblique collision of two grains and of a
  grain on the wall with them (frictionless) give granwave's velocities;
- its formulas through the dispatchers, and the time step's ratio.
"""

import math

import numpy as np
import pytest
from scipy import integrate, optimize

from granwave import contact_models as CM
from granwave.contact_models import options as CO
from granwave.dem.integrator import Engine
from lammps_collisions import granwave_collision, lammps_collision

LAW = dict(damping_law="constant_viscous")


def _model(c):
    return CM.model_of("damping", CO.resolve(dict(damping=0.5, viscous_damping=c, **LAW)))


def test_formulas_through_the_dispatchers():
    m = _model(0.02)
    assert m.code == CO.SUBMODELS["constant_viscous"]["code"] and CM.own_constants("damping", m) == (0.02,)
    # the same c whatever the masses, the stiffness and the overlap; the kind's zeta (0.5) unused
    for meff, k, n in ((0.2, 0.05, 1e-3), (3.0, 1e-4, 0.0)):
        assert CM.dashpot_coefficient(m, meff, k, n) == 0.02
    assert CM.dashpot_acts(m) and not CM.dashpot_acts(_model(0.0))
    # the time step's ratio of a spring k on a mass m: c / (2 sqrt(m k))
    assert CM.dashpot_step_ratio(m, 0.05, 0.5) == pytest.approx(0.02 / (2 * math.sqrt(0.025)), rel=1e-15)


def closed_form(m: float, k: float, c: float, v0: float) -> dict:
    """The damped, never attractive linear collision of the module docstring: restitution e, contact
    time t_c and the elastic impulse k x dt over the contact."""
    w = math.sqrt(k / m)
    zeta = c / (2.0 * m * w)
    s, wd = zeta * w, w * math.sqrt(1.0 - zeta * zeta)

    def x(t):
        return v0 / wd * math.exp(-s * t) * math.sin(wd * t)

    def v(t):
        return v0 * math.exp(-s * t) * (math.cos(wd * t) - s / wd * math.sin(wd * t))

    t1 = optimize.brentq(lambda t: k * x(t) + c * v(t), 1e-9 / w, math.pi / wd, xtol=1e-15, rtol=1e-15)
    v1, x1 = -v(t1), x(t1)
    elastic = k * (integrate.quad(x, 0.0, t1, epsabs=0.0, epsrel=1e-13)[0] + x1 * x1 / (2.0 * v1))
    return dict(e=v1 / v0, t_c=t1 + x1 / v1, zeta=zeta, elastic_impulse=elastic)


def _head_on(kn, c, v0, r1, r2, steps_per_contact, t_c):
    """Two grains of radii r1, r2 approaching head on at v0 each (harmonic k_n, dashpot c, no
    friction): (contact time, restitution), the contact's start and end interpolated between steps."""
    dt = t_c / steps_per_contact
    gap = 40.5 * 2 * v0 * dt
    e = Engine([[4.5 - gap, 5.0], [4.5 + r1 + r2, 5.0]], [r1, r2], [10.0], 10.0, friction=0.0, dt=dt, skin=0.2,
               check_every=0, velocity=[[v0, 0.0], [-v0, 0.0]], contact_law="harmonic", harmonic_stiffness=kn,
               viscous_damping=c, **LAW)

    def overlap():
        return r1 + r2 - (e.position[1, 0] - e.position[0, 0])

    times, last, step = [], overlap(), 0
    while len(times) < 2 and step < 3 * steps_per_contact:
        e.run(1)
        step += 1
        now = overlap()
        if (last <= 0.0 < now) or (last > 0.0 >= now):
            times.append((step - 1 + last / (last - now)) * dt)
        last = now
    assert len(times) == 2
    e.run(10)
    return times[1] - times[0], (e.velocity[1, 0] - e.velocity[0, 0]) / (2 * v0)


def test_head_on_collision_of_unequal_grains_is_the_damped_oscillator():
    """Grains of d = 1 and 0.8 (m_eff = m1 m2 / (m1 + m2)), harmonic k_n = 0.05, c = 0.03 (zeta =
    0.16 for this pair): restitution and contact time of the closed form. The step's error is of
    first order here (the dashpot's force c v jumps on at the step the contact starts, and its end is
    the clamped total force), at most the dashpot's impulse over one step, c dt / m_eff (measured 0.1
    and 0.26 of it at 4000 steps per contact): asked, under c dt / m_eff there and halving with the
    step (ratio 2 +- 15 %), so that what is left is the step's, not a difference of model."""
    kn, c, v0 = 0.05, 0.03, 1e-4
    r1, r2 = 0.5, 0.4
    m1, m2 = math.pi / 6, math.pi * 0.8 ** 3 / 6
    meff = m1 * m2 / (m1 + m2)
    ref = closed_form(meff, kn, c, 2 * v0)
    assert 0.1 < ref["zeta"] < 0.5 and 0.4 < ref["e"] < 0.8
    err = {}
    for n in (2000, 4000):
        t_c, rest = _head_on(kn, c, v0, r1, r2, n, ref["t_c"])
        err[n] = (rest / ref["e"] - 1.0, t_c / ref["t_c"] - 1.0)
    bound = c * (ref["t_c"] / 4000) / meff
    for k in (0, 1):
        assert abs(err[4000][k]) < bound and err[2000][k] / err[4000][k] == pytest.approx(2.0, rel=0.15), err


def _wall_slide(kn, c, mu, v_n, v_t, steps_per_contact, t_c):
    R = 0.5
    dt = t_c / steps_per_contact
    e = Engine([[5.0, R + 20.5 * v_n * dt]], [R], [10.0], 10.0, friction=mu, dt=dt, skin=0.2, check_every=0,
               velocity=[[v_t, -v_n]], contact_law="harmonic", harmonic_stiffness=kn, viscous_damping=c,
               tangential="linear_history", linear_history_stiffness=kn / 3.5, **LAW)
    deepest = 0.0
    for _ in range(steps_per_contact + 200):
        e.run(1)
        deepest = max(deepest, R - e.position[0, 1])
    assert R - e.position[0, 1] < 0.0
    return e.velocity[0].copy(), R * e.angular_velocity[0, 0], deepest


def test_oblique_wall_collision_sliding_throughout():
    """A grain (R = 1/2) falling at v_n with a sideways v_t onto the wall (k_w = 2 k_n, c = 0.03),
    Coulomb mu = 0.05 with linear_history's k_t: it slides from the first step to the last, so it
    leaves with v_n e and v_t - mu J_el / m, J_el the elastic impulse of the closed form, and its
    spin R w = -2.5 mu J_el / m to the lever arm's O(n/R) (asked: 3 n_max / R). The step's error is of
    first order, as head on: asked under c dt / m (of v_n, of v_t; measured 0.05 of it) at 4000 steps
    per contact, halving with the step."""
    kn, c, mu, v_n, v_t = 0.05, 0.03, 0.05, 1e-5, 1e-5
    m = math.pi / 6
    ref = closed_form(m, 2 * kn, c, v_n)
    dv = mu * ref["elastic_impulse"] / m
    assert v_t - 3.5 * dv > 0.2 * v_t  # the contact point still slips forward at the end
    err = {}
    for n in (2000, 4000):
        v, spin, deepest = _wall_slide(kn, c, mu, v_n, v_t, n, ref["t_c"])
        err[n] = (v[1] / (ref["e"] * v_n) - 1.0, (v[0] - (v_t - dv)) / v_t)
    bound = c * (ref["t_c"] / 4000) / m
    for k in (0, 1):
        assert abs(err[4000][k]) < bound and err[2000][k] / err[4000][k] == pytest.approx(2.0, rel=0.15), err
    assert spin == pytest.approx(-2.5 * dv, rel=3 * deepest / 0.5)


def test_lammps_export_and_a_lammps_run_of_the_same_collisions_agree():
    """The words: ``hooke k_n c tangential ... damping velocity limit_damping`` (c the normal model's
    damping number, xgammat 1: the same c on the tangential velocity), pair and wall. An oblique
    collision of grains d = 1 and 0.9 and one of a grain on the wall, frictionless, run in LAMMPS
    with those words and in granwave: the same velocities to 1e-12 of the speeds (measured 4e-16:
    the same velocity Verlet, the same dashpot on the half-step velocity, the same never-attractive
    rule). Frictional runs differ at the order of the dashpot's force while a contact slides, by
    the rules' difference (LAMMPS caps the spring and the dashpot together at mu times the total
    normal force; granwave the spring at mu times the elastic one and adds no dashpot; docs/method.md
    §2): not compared."""
    from granwave.interop import lammps as LM

    kn, c = 0.05, 0.02
    contact = dict(contact_law="harmonic", harmonic_stiffness=kn, viscous_damping=c, **LAW)
    pair = LM.granular_model(0.0, 0.0, 0.0, wall=False, **contact)
    wall = LM.granular_model(0.0, 0.0, 0.0, wall=True, **contact)
    for words, k_n in ((pair, kn), (wall, 2 * kn)):
        w = words.split()
        assert w[0] == "hooke" and float(w[1]) == k_n and float(w[2]) == c
        assert words.endswith("damping velocity limit_damping")
    lmp = LM.lammps_module()
    if lmp is None:
        pytest.skip("the lammps Python module is not installed")
    cases = {
        "pair": (dict(position=[[4.5, 5.0, 5.0], [5.49, 5.2, 5.1]], radius=[0.5, 0.45],
                      velocity=[[1e-3, 2e-4, 0.0], [-1e-3, -3e-4, 1e-4]], spin=[[0.0, 0.0, 0.0]] * 2), 6000),
        "wall": (dict(position=[[5.0, 5.0, 0.52]], radius=[0.5], velocity=[[4e-4, 1e-4, -1e-3]],
                      spin=[[0.0, 0.0, 0.0]]), 3000),
    }
    for name, (state, steps) in cases.items():
        v_g, _ = granwave_collision(**state, dt=0.02, steps=steps, friction=0.0, **contact)
        v_l, _ = lammps_collision(lmp, **state, dt=0.02, steps=steps, pair_words=pair, wall_words=wall)
        scale = np.abs(state["velocity"]).max()
        assert np.abs(v_g - np.asarray(state["velocity"])).max() > 0.5 * scale  # they collided
        assert np.abs(v_g - v_l).max() < 1e-12 * scale, (name, v_g, v_l)
