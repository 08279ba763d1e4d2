"""Critical settling of the mean flow (dem.settling, PrepareParams.mean_flow_settling): the swing
is measured as it says, at fixed step counts whatever the chunks; nothing changes before the
switch; the packings converge, record the rule and are reproducible; 'late' (the default) is
'compaction' (the rule before) until the kinetic energy has fallen."""

from __future__ import annotations

import math

import numpy as np
import pytest

from granwave.dem import kernels as K
from granwave.dem.forces import static_residual
from granwave.dem.protocol import Compression, granular_gas, prepare_packing
from granwave.dem.settling import LATE_FRACTION, SAMPLE_CHECKS, SETTLING_RULES, CriticalSettling
from granwave.geometry import lateral_size, wall_area
from granwave.params import PrepareParams

#: the mean-flow column of tests/test_relaxation.py (80 grains, 12.5 d, reference height 5 d)
MEAN_FLOW = dict(grains=80, seed=3, aspect=2.0, reference_height=5.0, compaction="mean-flow")


class ScriptedEngine:
    """Stands for an engine: steps advance, the piston's velocity is a given function of the
    step count, dt a given function too; status 1 at ``stop``."""

    def __init__(self, velocity, dt=lambda s: 0.5, stop=None, kinetic=lambda s: 1.0):
        self.velocity, self.dt_of, self.stop, self.kinetic = velocity, dt, stop, kinetic
        self.steps = 0
        self.piston = K.record(K.PISTON)
        self.mflow = np.array([1e-4, 4.0, 3e-3])  # gamma_m, slab, gamma_l
        self.calls = []

    @property
    def dt(self):
        return self.dt_of(self.steps)

    def measure(self):
        return dict(kinetic_energy=self.kinetic(self.steps))

    def run(self, n):
        self.calls.append((self.steps, n))
        end = self.steps + n if self.stop is None or self.steps >= self.stop else min(self.steps + n, self.stop)
        self.steps = end
        self.piston.v = self.velocity(self.steps)
        return 1 if end == self.stop else 0


def _swing(s):
    """Down until step 1030, up until step 1750, then down: an upward swing of 720 steps."""
    return -1e-3 if s < 1030 else (2e-4 if s < 1750 else -1e-4)


@pytest.mark.parametrize("chunk", [7, 200, 333, 5000])
def test_swing_measured_at_fixed_steps_whatever_the_chunks(chunk):
    """Samples at multiples of `every` only: the rise is seen at 1200 (first multiple of 200 after
    1030), the fall at 1800, so omega = pi / (600 steps x dt), with any chunking."""
    e = ScriptedEngine(_swing)
    rule = CriticalSettling(e, gamma=1.0, every=200)
    while e.steps < 6000:
        assert rule.run(min(chunk, 6000 - e.steps)) == 0
    assert rule.rise_step == 1200 and rule.switch_step == 1800
    assert rule.breathing_frequency == math.pi / (600 * 0.5)
    assert e.mflow[0] == e.mflow[2] == 2.0 * rule.breathing_frequency  # below the cap
    assert e.mflow[1] == 4.0
    assert e.steps == 6000
    # every call before the switch ended at or before the next multiple of 200
    for start, n in e.calls:
        if start < 1800:
            assert start + n <= (start // 200 + 1) * 200


def test_swing_time_follows_dt():
    """The swing's duration sums steps x dt of each sampled interval (dt adaptive)."""
    e = ScriptedEngine(_swing, dt=lambda s: 0.25 if s <= 1400 else 0.5)
    rule = CriticalSettling(e, gamma=1.0, every=200)
    rule.run(3000)
    # intervals ending at 1400 (dt 0.25) and at 1600, 1800 (dt 0.5)
    assert rule.breathing_frequency == math.pi / (200 * 0.25 + 400 * 0.5)


def test_damping_capped_at_the_fluctuations_rate():
    e = ScriptedEngine(_swing)
    rule = CriticalSettling(e, gamma=1e-3, every=200)
    rule.run(3000)
    assert 2.0 * rule.breathing_frequency > 1e-3 and e.mflow[0] == e.mflow[2] == 1e-3


@pytest.mark.parametrize("chunk", [7, 333, 5000])
def test_late_switch_waits_for_the_kinetic_energy(chunk):
    """Rule 'late': omega_b from the same swing (ended at the sample of step 1800), the switch at
    the first sample whose kinetic energy is below LATE_FRACTION of its value then: with the
    energy falling tenfold per 1000 steps after 1800, 10^-3.2 at step 5000 (10^-3 at 4800 is
    not below), whatever the chunks."""
    e = ScriptedEngine(_swing, kinetic=lambda s: 10.0 ** (-max(s - 1800, 0) / 1000.0))
    rule = CriticalSettling(e, gamma=1.0, every=200, late=LATE_FRACTION)
    while e.steps < 4800:
        assert rule.run(min(chunk, 4800 - e.steps)) == 0
    assert rule.swing_end_step == 1800 and not rule.done and e.mflow[0] == 1e-4
    assert rule.breathing_frequency == math.pi / (600 * 0.5)
    while e.steps < 6000:
        assert rule.run(min(chunk, 6000 - e.steps)) == 0
    assert rule.switch_step == 5000 and e.mflow[0] == e.mflow[2] == 2.0 * rule.breathing_frequency
    a = rule.attrs()
    assert a["settling_swing_end_step"] == 1800 and a["settling_step"] == 5000


def test_no_swing_no_switch():
    """A plug that never moves up (overdamped) keeps the compaction rate; the attributes say so."""
    e = ScriptedEngine(lambda s: -1e-4)
    rule = CriticalSettling(e, gamma=1.0, every=200)
    rule.run(5000)
    assert not rule.done and e.mflow[0] == 1e-4 and e.mflow[2] == 3e-3
    a = rule.attrs()
    assert a["settling_step"] == -1 and a["settling_rise_step"] == -1
    assert math.isnan(a["breathing_frequency"]) and math.isnan(a["settling_damping_rate"])


def test_engine_status_passed_on():
    """A convergence candidate (status 1) stops the run where the engine stopped."""
    e = ScriptedEngine(lambda s: -1e-4, stop=930)
    rule = CriticalSettling(e, gamma=1.0, every=200)
    assert rule.run(5000) == 1 and e.steps == 930


def _compression(settling: str):
    p = PrepareParams(**MEAN_FLOW, mean_flow_settling=settling)
    rng = np.random.default_rng(p.seed)
    radius = 0.5 * rng.uniform(1.0 - p.polydispersity, 1.0 + p.polydispersity, size=p.grains)
    lateral = np.full(1, lateral_size(radius, 2, p.aspect))
    position, height = granular_gas(radius, lateral, 0.5, rng)
    return Compression(position, radius, lateral, height, p)


@pytest.mark.parametrize("rule", ["critical", "late"])
def test_nothing_changes_before_the_switch(rule):
    """Up to the switch the critical (and the late) rule is the compaction rule bit for bit;
    after it, the mean flow and the piston are damped at the new rate."""
    crit, comp = _compression(rule), _compression("compaction")
    assert comp.settling is None and crit.settling.every == SAMPLE_CHECKS * 20
    while not crit.settling.done:  # sample by sample, so as to stop at the switch
        assert crit.settling.run(crit.settling.every) == 0
    if rule == "late":
        assert crit.settling.swing_end_step < crit.settling.switch_step
    comp.engine.run(crit.engine.steps)
    for a, b in ((crit.engine.position, comp.engine.position), (crit.engine.velocity, comp.engine.velocity),
                 (crit.engine.piston, comp.engine.piston)):
        np.testing.assert_array_equal(a, b)
    assert crit.engine.mflow[0] == crit.engine.mflow[2] == min(2.0 * crit.settling.breathing_frequency,
                                                                crit.gamma)
    assert crit.engine.mflow[0] != comp.engine.mflow[0] == crit.gamma_mean
    assert comp.engine.mflow[2] == comp.gamma  # the compaction: the lateral mean flow like the rest
    crit.settling.run(500)
    comp.engine.run(500)
    assert not np.array_equal(crit.engine.velocity, comp.engine.velocity)


@pytest.fixture(scope="module")
def critical():
    return prepare_packing(PrepareParams(**MEAN_FLOW, mean_flow_settling="critical"))


def test_critical_converges_and_records_its_rule(critical):
    a = critical.attrs
    assert PrepareParams().mean_flow_settling == "late"  # the default (docs/dem.md "Late settling")
    assert a["mean_flow_settling"] == "critical" and a["mean_flow_settling_rule"] == SETTLING_RULES["critical"]
    assert 0 < a["settling_rise_step"] < a["settling_step"] < a["steps"]
    assert a["settling_step"] % (SAMPLE_CHECKS * 20) == 0
    assert a["settling_damping_rate"] == min(2.0 * a["breathing_frequency"], a["background_damping_rate"])
    res = static_residual(critical, a["piston_mass"], 1e-4 * wall_area(critical.box[:-1]))
    assert a["converged"] and max(res) < 1e-10 and a["max_acceleration"] == max(res)


def test_critical_same_seed_same_bytes(critical):
    again = prepare_packing(PrepareParams(**MEAN_FLOW, mean_flow_settling="critical"))
    for a, b in ((critical.position, again.position), (critical.contacts.force_normal, again.contacts.force_normal)):
        np.testing.assert_array_equal(a, b)
    assert critical.attrs["steps"] == again.attrs["steps"]


def test_late_is_the_default_converges_and_records_its_rule():
    """The default rule 'late': the swing ends, the kinetic energy falls 1000-fold, then the
    switch; the residual is the convergence test's."""
    pk = prepare_packing(PrepareParams(**MEAN_FLOW))
    a = pk.attrs
    assert a["mean_flow_settling"] == "late" and a["mean_flow_settling_rule"] == SETTLING_RULES["late"]
    assert 0 < a["settling_rise_step"] < a["settling_swing_end_step"] < a["settling_step"] < a["steps"]
    assert a["settling_step"] % (SAMPLE_CHECKS * 20) == 0
    assert a["converged"] and a["max_acceleration"] < a["tol"]


def test_compaction_rule_records_no_switch():
    a = prepare_packing(PrepareParams(**MEAN_FLOW, mean_flow_settling="compaction")).attrs
    assert a["mean_flow_settling"] == "compaction" and "settling_step" not in a
    assert a["converged"]


def test_other_compaction_rules_ignore_settling():
    """'fixed' (and a mean-flow column not taller than reference_height) have no mean flow rule,
    so nothing to settle: the same packing either way."""
    for kw in (dict(MEAN_FLOW, compaction="fixed"), dict(MEAN_FLOW, reference_height=25.0)):
        x = prepare_packing(PrepareParams(**kw, mean_flow_settling="critical"))
        y = prepare_packing(PrepareParams(**kw, mean_flow_settling="compaction"))
        np.testing.assert_array_equal(x.position, y.position)
        assert "settling_step" not in x.attrs
