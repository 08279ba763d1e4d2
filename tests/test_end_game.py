"""The adaptive end game (dem.end_game, PrepareParams.end_game): when it starts, the rate it
sets from the kinetic energy's decay, its samples at fixed step counts, the engine's caps, and
that sampling alone changes no bit of a preparation."""

import math

import numpy as np
import pytest

from granwave.dem import end_game as EG
from granwave.dem import kernels as K
from granwave.dem.integrator import Engine
from granwave.dem.mean_flow import M_GAMMA_L, M_GAMMA_M
from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.errors import InputError

GAMMA, TOL, EVERY, DT = 4e-3, 1e-10, 200, 0.25


class FakeEngine:
    """Steps, dt, and a measure() whose kinetic energy and accelerations are functions of the
    step count; records the caps it is given."""

    def __init__(self, kinetic, acceleration):
        self.steps, self.dt = 0, DT
        self.kinetic, self.acceleration = kinetic, acceleration
        self.caps = []  # (step, rate)

    def run(self, n):
        self.steps += n
        return 0

    def measure(self):
        return dict(max_acceleration=self.acceleration(self.steps), max_angular_acceleration=0.0,
                    piston_acceleration=0.0, kinetic_energy=self.kinetic(self.steps))

    def damping_rates(self):
        return GAMMA, np.zeros(0)

    def cap_background_damping(self, rate, base):
        assert base == (GAMMA, base[1])
        self.caps.append((self.steps, rate))


def _game(engine):
    return EG.EndGame(engine, engine.run, gamma=GAMMA, tol=TOL, every=EVERY)


def test_overdamped_decay_sets_critical_damping_of_the_slowest_mode():
    """K decaying as exp(-2 r t) with r = omega^2 / gamma: the first window gives 2 omega, then the
    next windows read the decay at the new rate (here the same K law: 2 sqrt(r gamma_c))."""
    r = 5e-5  # the velocities' decay rate (1 / time unit), 80 times below gamma
    start = 4000  # accelerations below 100 tol from this step on
    eng = FakeEngine(kinetic=lambda s: math.exp(-2.0 * r * s * DT),
                     acceleration=lambda s: 1e-7 if s < start else 5e-9)
    game = _game(eng)
    for chunk in (1, 137, 2000, 999, 50_000):  # chunking does not move the samples
        game.run(chunk)
    assert game.start_step == start
    window = EG.WINDOW * EVERY
    first = eng.caps[0]
    assert first[0] == start + window
    assert first[1] == pytest.approx(2.0 * math.sqrt(r * GAMMA), rel=1e-9)
    second = eng.caps[1]
    assert second == (start + 2 * window, pytest.approx(2.0 * math.sqrt(r * first[1]), rel=1e-9))
    # the rate only ever comes from the formula, held at the floor
    assert all(rate >= EG.FLOOR * GAMMA for _, rate in eng.caps)
    assert game.attrs()["end_game_step"] == start and game.attrs()["end_game_changes"] == len(eng.caps)


def test_underdamped_decay_keeps_the_protocols_rate():
    """K decaying at gamma (velocities at gamma / 2, an underdamped mode): 2 sqrt(gamma^2 / 2) is
    above gamma, so nothing changes."""
    eng = FakeEngine(kinetic=lambda s: math.exp(-GAMMA * s * DT), acceleration=lambda s: 0.0)
    game = _game(eng)
    game.run(20 * EG.WINDOW * EVERY)
    assert game.start_step == EVERY and eng.caps == [] and game.rate == GAMMA


def test_a_rearrangement_restores_the_protocols_rate():
    """A window whose K rose (a rearrangement) sets gamma again."""
    window = EG.WINDOW * EVERY

    def kinetic(s):  # slow decay, a burst in the third window, slow decay again
        return 1e-6 * math.exp(-1e-4 * s * DT) * (10.0 if s >= 3 * window else 1.0)

    eng = FakeEngine(kinetic=kinetic, acceleration=lambda s: 0.0)
    game = _game(eng)
    game.run(5 * window)
    rates = [rate for _, rate in eng.caps]
    assert rates[0] < GAMMA and GAMMA in rates and eng.caps[rates.index(GAMMA)][0] == 3 * window + EVERY


def test_waits_for_the_settling_switch():
    class Settling:
        done = False

    eng = FakeEngine(kinetic=lambda s: 1.0, acceleration=lambda s: 0.0)
    settling = Settling()
    game = EG.EndGame(eng, eng.run, gamma=GAMMA, tol=TOL, every=EVERY, settling=settling)
    game.run(10 * EVERY)
    assert not game.started
    settling.done = True
    game.run(EVERY)
    assert game.start_step == 11 * EVERY


def test_engine_caps_every_background_rate_and_restores_from_base():
    """cap_background_damping: grains, mean vertical and lateral flow at the least of the rate and
    their values at the start; a higher rate gives those values back."""
    rng = np.random.default_rng(0)
    pos = np.column_stack([rng.uniform(0, 10, 20), rng.uniform(0, 30, 20)])
    e = Engine(pos, np.full(20, 0.2), np.array([10.0]), 31.0, background_damping=0.01,
               mean_flow=(0.002, 4.0, 0.006))
    base = e.damping_rates()
    e.cap_background_damping(0.004, base)
    assert (e.fpar[K.F_GAMMA], e.mflow[M_GAMMA_M], e.mflow[M_GAMMA_L]) == (0.004, 0.002, 0.004)
    e.cap_background_damping(1.0, base)
    assert (e.fpar[K.F_GAMMA], e.mflow[M_GAMMA_M], e.mflow[M_GAMMA_L]) == (0.01, 0.002, 0.006)


def test_sampling_alone_changes_no_bit_and_the_rule_is_recorded():
    """A 2D packing whose slowest mode is underdamped: the adaptive end game starts, changes
    nothing, and the packing is the same bytes as without it; both record their rule."""
    base = dict(grains=120, seed=3, tol=1e-9)
    plain = prepare_packing(PrepareParams(**base))
    adaptive = prepare_packing(PrepareParams(**base, end_game="adaptive"))
    a = adaptive.attrs
    assert a["end_game"] == "adaptive" and a["end_game_rule"] == EG.END_GAME_RULES["adaptive"]
    assert a["end_game_step"] > 0 and a["end_game_changes"] == 0
    assert plain.attrs["end_game"] == "none" and "end_game_step" not in plain.attrs
    assert a["steps"] == plain.attrs["steps"]
    np.testing.assert_array_equal(adaptive.position, plain.position)
    np.testing.assert_array_equal(adaptive.contacts.force_tangential, plain.contacts.force_tangential)


def test_unknown_rule_is_refused():
    with pytest.raises(InputError, match="end_game"):
        PrepareParams(end_game="fire")
