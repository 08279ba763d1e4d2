"""The adaptive end game (dem.end_game, PrepareParams.end_game): when it starts, the rate it
sets from the decay of the largest speed, its samples at fixed step counts, the engine's caps,
and that sampling alone changes no bit of a preparation."""

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
    """Steps, dt, and a measure() whose largest speed and accelerations are functions of the
    step count; records the caps it is given and the samples it is measured at."""

    def __init__(self, speed, acceleration):
        self.steps, self.dt = 0, DT
        self.radius = np.array([0.6, 0.5])  # |w| R / R_min = 2 |w| R for the rotations
        self.speed, self.acceleration = speed, acceleration
        self.caps = []  # (step, rate)
        self.measured = []  # steps

    def run(self, n):
        self.steps += n
        return 0

    def measure(self):
        self.measured.append(self.steps)
        s = self.steps
        return dict(max_acceleration=self.acceleration(s), max_angular_acceleration=0.0,
                    piston_acceleration=0.0, max_speed=0.5 * self.speed(s), max_rotation_speed=self.speed(s),
                    piston_speed=0.0)

    def damping_rates(self):
        return GAMMA, np.zeros(0)

    def cap_background_damping(self, rate, base):
        assert base == (GAMMA, base[1])
        self.caps.append((self.steps, rate))


def _game(engine):
    return EG.EndGame(engine, engine.run, gamma=GAMMA, tol=TOL, every=EVERY)


def test_decay_rate_is_the_least_squares_slope_of_the_log():
    t = np.linspace(0.0, 500.0, 20)
    assert EG.decay_rate(t + 7.0, 3e-6 * np.exp(-4e-5 * t)) == pytest.approx(4e-5, rel=1e-9)
    wiggle = 1.0 + 0.005 * np.sin(np.arange(20))  # noise about the same decay: a quarter of its drop
    assert EG.decay_rate(t, 3e-6 * np.exp(-4e-5 * t) * wiggle) == pytest.approx(4e-5, rel=0.3)


def test_overdamped_decay_sets_critical_damping_of_the_slowest_mode():
    """Speeds decaying as exp(-r t), r = omega^2 / gamma: after one window of samples the rate is
    2 omega = 2 sqrt(r gamma); the next window reads the decay at that rate (here the same law:
    2 sqrt(r gamma_c))."""
    r = 5e-5  # 80 times below gamma
    start = 4000  # accelerations below 100 tol from this step on
    eng = FakeEngine(speed=lambda s: 1e-6 * math.exp(-r * s * DT),
                     acceleration=lambda s: 1e-7 if s < start else 5e-9)
    game = _game(eng)
    for chunk in (1, 137, 2000, 999, 30_000):  # chunking does not move the samples
        game.run(chunk)
    assert game.start_step == start
    window = EG.WINDOW * EVERY
    first = eng.caps[0]
    assert first == (start + window, pytest.approx(2.0 * math.sqrt(r * GAMMA), rel=1e-9))
    assert eng.caps[1] == (start + 2 * window, pytest.approx(2.0 * math.sqrt(r * first[1]), rel=1e-9))
    assert all(rate >= EG.FLOOR * GAMMA for _, rate in eng.caps)
    assert set(eng.measured) == set(range(EVERY, eng.steps + 1, EVERY))  # at multiples of EVERY only
    a = game.attrs()
    assert a["end_game_step"] == start and a["end_game_changes"] == len(eng.caps)
    assert a["end_game_lowest_rate"] == min(rate for _, rate in eng.caps)
    assert a["end_game_final_rate"] == game.rate == eng.caps[-1][1]


@pytest.mark.parametrize("decay", [1e-9, -1e-5])
def test_a_very_slow_decay_or_a_creep_is_held_at_the_floor(decay):
    """Speeds that hardly fall (critical damping below the floor) or rise while every acceleration
    stays small (a creep, whose speed is its force over the damping): the floor."""
    eng = FakeEngine(speed=lambda s: math.exp(-decay * s * DT), acceleration=lambda s: 0.0)
    game = _game(eng)
    game.run(EG.WINDOW * EVERY + EVERY)
    assert eng.caps == [(EVERY + EG.WINDOW * EVERY, EG.FLOOR * GAMMA)]


@pytest.mark.parametrize("decay", [GAMMA / 2, GAMMA / 4 * 1.01])
def test_underdamped_decay_keeps_the_protocols_rate(decay):
    """Speeds decaying at gamma / 2 (an underdamped mode) or just faster than gamma / 4 (critical
    damping at gamma): 2 sqrt(r gamma) is not below gamma, nothing changes."""
    eng = FakeEngine(speed=lambda s: math.exp(-decay * s * DT), acceleration=lambda s: 0.0)
    game = _game(eng)
    game.run(10 * EG.WINDOW * EVERY)
    assert game.start_step == EVERY and eng.caps == [] and game.rate == GAMMA


def test_a_lowered_rate_climbs_back_when_the_decay_is_underdamped():
    """At a lowered rate c, speeds decaying at c / 2 give 2 sqrt(c^2 / 2) = 1.41 c: the rate climbs
    back, window by window, to gamma and stays."""
    eng = FakeEngine(speed=lambda s: 1.0, acceleration=lambda s: 0.0)  # first a creep: the floor
    game = _game(eng)
    window = EG.WINDOW * EVERY
    game.run(window + EVERY)
    assert game.rate == EG.FLOOR * GAMMA
    eng.speed = lambda s: math.exp(-game.rate / 2 * s * DT)  # decays at half the present rate
    game.run(12 * window)
    rates = [rate for _, rate in eng.caps]
    assert rates[-1] == GAMMA and all(b > a for a, b in zip(rates[1:], rates[2:]))
    assert rates[2] == pytest.approx(math.sqrt(2.0) * rates[1], rel=1e-6)


def test_a_rearrangement_restores_the_protocols_rate_and_the_fit_starts_over():
    """An acceleration at or above the threshold sets gamma at once; the decay is read again from
    the samples after it, at gamma."""
    window = EG.WINDOW * EVERY
    burst = window + 600  # a sample with a large acceleration, inside the second window

    def acceleration(s):
        return 1e-6 if s == burst else 0.0

    eng = FakeEngine(speed=lambda s: 1e-6 * math.exp(-1e-4 * s * DT), acceleration=acceleration)
    game = _game(eng)
    game.run(burst + window)
    low = pytest.approx(2.0 * math.sqrt(1e-4 * GAMMA), rel=1e-9)
    assert eng.caps == [(EVERY + window, low), (burst, GAMMA), (burst + window, low)]


def test_the_rules_own_change_is_not_a_rearrangement():
    """Lowering the damping frees the force a creeping grain moves against: accelerations up to
    gamma |w| (|w| = |w| R / R_min) above the threshold keep the low rate; one beyond restores gamma."""
    def creep(s):  # rising speeds
        return 1e-6 * (1.0 + 1e-5 * s)

    def share(s):  # gamma max(|v|, |w|): |w| R = creep, R_min = 0.5
        return GAMMA * creep(s) / 0.5

    window = EG.WINDOW * EVERY
    eng = FakeEngine(speed=creep, acceleration=lambda s: 0.0)
    game = _game(eng)
    game.run(window + EVERY)
    assert eng.caps == [(window + EVERY, EG.FLOOR * GAMMA)]
    eng.acceleration = lambda s: 0.99 * (100 * TOL + share(s))
    game.run(3 * window)
    assert eng.caps == [(window + EVERY, EG.FLOOR * GAMMA)]
    eng.acceleration = lambda s: 1.01 * (100 * TOL + share(s))
    game.run(EVERY)
    assert eng.caps[-1] == (eng.steps, GAMMA)


def test_waits_for_the_settling_switch():
    class Settling:
        done = False

    eng = FakeEngine(speed=lambda s: 1.0, acceleration=lambda s: 0.0)
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
    e = Engine(pos, np.full(20, 0.2), np.array([10.0]), 31.0, damping=0.0, background_damping=0.01,
               mean_flow=(0.002, 4.0, 0.006))
    base = e.damping_rates()
    e.cap_background_damping(0.004, base)
    assert (e.fpar.gamma, e.mflow[M_GAMMA_M], e.mflow[M_GAMMA_L]) == (0.004, 0.002, 0.004)
    e.cap_background_damping(1.0, base)
    assert (e.fpar.gamma, e.mflow[M_GAMMA_M], e.mflow[M_GAMMA_L]) == (0.01, 0.002, 0.006)


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
