"""The compaction rule of the piston protocol (dem.protocol.damping_scale, mean_flow_scale): the
height-scaled and mean-flow rules converge, record themselves and are reproducible; 'fixed' is the
protocol before; the mean-flow damping splits the velocities as it says."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.cli import main as cli_main
from granwave.dem.forces import static_residual
from granwave.dem import kernels as K
from granwave.dem.integrator import Engine
from granwave.dem import protocol
from granwave.dem.protocol import (COMPACTION_RULES, damping_scale, expected_height, mean_flow_scale,
                                   prepare_packing, step_budget)
from granwave.errors import ConvergenceError, InputError, StepBudgetExceeded
from granwave.geometry import lateral_size, wall_area
from granwave.io import files
from granwave.params import PrepareParams

#: 80 grains, seed 3, aspect 2 (expected height 12.5 d), prepared by the protocol before the
#: compaction rule existed (background damping b / t_i at every height: the rule 'fixed'). Both
#: other rules must reproduce it byte for byte below reference_height. The reference is made in
#: the run, not stored: the same seed gives the same bytes on one machine, and a digest stored
#: on 2026-11-24 (22 300 steps, sha256 c2308e62...) was not reproduced on 2026-11-25 on an AVX2
#: machine, with the code of that day as well (the same 22 300 steps, other last bits).
BEFORE = dict(grains=80, seed=3, aspect=2.0)
#: a reference height below the column's, so that the height-scaled rule acts
SCALED = dict(BEFORE, reference_height=5.0, compaction="height-scaled")
MEAN_FLOW = dict(BEFORE, reference_height=5.0, compaction="mean-flow")


def digest(packing) -> str:
    h = hashlib.sha256()
    c = packing.contacts
    for a in (packing.position, packing.radius, packing.box, c.i, c.j, c.normal, c.overlap, c.force_normal,
              c.force_tangential):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def before():
    return prepare_packing(PrepareParams(**BEFORE, compaction="fixed"))


@pytest.fixture(scope="module")
def scaled():
    return prepare_packing(PrepareParams(**SCALED))


def test_damping_scale_rule():
    assert PrepareParams().compaction == "fixed"  # the default: the protocol before
    assert damping_scale(PrepareParams(), 400.0) == 1.0
    scaled = PrepareParams(compaction="height-scaled")
    assert damping_scale(scaled, 25.0) == 1.0  # up to reference_height: b unscaled
    assert damping_scale(scaled, 100.0) == 0.25
    assert damping_scale(PrepareParams(compaction="height-scaled", reference_height=10.0), 40.0) == 0.25


def test_step_budget_rule():
    per = protocol.STEPS_PER_100D
    assert step_budget(None, 12.5) == per  # at least one budget
    assert step_budget(None, 100.0) == per
    assert step_budget(None, 400.0) == 4 * per
    assert step_budget(1234, 400.0) == 1234  # given: as given


def test_default_budget_follows_the_column(before, monkeypatch):
    """A run without max_steps stops after the budget of its column's expected height (a
    small budget per 100 d here, so that the runs stop early), and says so; a given max_steps
    wins. A column below 100 d records the least budget."""
    assert before.attrs["max_steps"] == protocol.STEPS_PER_100D
    monkeypatch.setattr(protocol, "STEPS_PER_100D", 1000)
    tall = dict(grains=600, aspect=40.0, seed=1)
    radius = 0.5 * np.random.default_rng(1).uniform(0.8, 1.2, 600)  # the protocol's draw for seed 1
    height = expected_height(radius, np.array([lateral_size(radius, 2, 40.0)]))
    assert height > 110.0
    budget = step_budget(None, height)
    assert budget == int(1000 * height / 100.0) > 1000
    with pytest.raises(ConvergenceError, match=rf"^{budget} steps did not converge"):
        prepare_packing(PrepareParams(**tall))
    with pytest.raises(ConvergenceError, match=r"^700 steps did not converge") as info:
        prepare_packing(PrepareParams(**tall, max_steps=700))
    assert isinstance(info.value, StepBudgetExceeded) and info.value.steps == 700  # the budget, not a blow-up
    with pytest.raises(ConvergenceError, match=r"^1000 steps did not converge"):
        prepare_packing(PrepareParams(**BEFORE))  # 12.5 d: the least budget


def test_expected_height_inverts_lateral_size():
    rng = np.random.default_rng(0)
    r = 0.5 * rng.uniform(0.8, 1.2, 500)
    w = lateral_size(r, 2, 3.0)
    assert expected_height(r, np.array([w])) == pytest.approx(3.0 * w, rel=1e-12)
    w3 = lateral_size(r, 3, 2.0)
    assert expected_height(r, np.array([w3, w3])) == pytest.approx(2.0 * w3, rel=1e-12)


def test_height_scaled_converges_and_records_its_protocol(scaled, before):
    a = scaled.attrs
    h_e = expected_height(scaled.radius, scaled.box[:-1])
    assert h_e == pytest.approx(2.0 * scaled.box[0], rel=1e-12)  # aspect 2
    assert a["compaction"] == "height-scaled" and a["compaction_rule"] == COMPACTION_RULES["height-scaled"]
    assert a["reference_height"] == 5.0 and a["expected_height"] == h_e
    assert a["background_damping_scale"] == 5.0 / h_e
    assert a["background_damping_rate"] == pytest.approx(0.3 * (5.0 / h_e) / a["inertial_time"], rel=1e-14)
    # in equilibrium: the static residual from the stored contacts alone is below tol
    res = static_residual(scaled, a["piston_mass"], 1e-4 * wall_area(scaled.box[:-1]))
    assert max(res) < 1e-10 and a["max_acceleration"] == max(res)
    assert a["converged"] and a["steps"] != before.attrs["steps"]  # another trajectory than 'fixed'
    assert digest(scaled) != digest(before)


def test_height_scaled_same_seed_same_bytes(scaled, tmp_path):
    again = prepare_packing(PrepareParams(**SCALED))
    files.write_packing(tmp_path / "a.h5", scaled)
    files.write_packing(tmp_path / "b.h5", again)
    assert (tmp_path / "a.h5").read_bytes() == (tmp_path / "b.h5").read_bytes()


@pytest.mark.parametrize("compaction", ["height-scaled", "mean-flow"])
def test_before_reproduced(compaction, before):
    """'height-scaled' and 'mean-flow' below reference_height are the protocol before ('fixed'):
    the same arrays to the byte and the same steps."""
    pk = prepare_packing(PrepareParams(**BEFORE, compaction=compaction))
    assert pk.attrs["background_damping_scale"] == 1.0
    assert pk.attrs["background_damping_rate"] == 0.3 / pk.attrs["inertial_time"]
    assert before.attrs["converged"] and before.attrs["steps"] > 1000
    assert pk.attrs["steps"] == before.attrs["steps"]
    assert digest(pk) == digest(before)


def test_fixed_ignores_height(before):
    pk = prepare_packing(PrepareParams(**{**SCALED, "compaction": "fixed"}))
    assert pk.attrs["compaction"] == "fixed" and pk.attrs["background_damping_scale"] == 1.0
    assert digest(pk) == digest(before)


def test_cli_options(tmp_path):
    out = CliRunner().invoke(cli_main, ["prepare-packing", "--help"]).output
    assert "--compaction" in out and "--reference-height" in out and "--mean-flow-slab" in out
    assert "mean-flow" in out
    target = tmp_path / "x.h5"
    bad = CliRunner().invoke(cli_main, ["prepare-packing", "--compaction", "fire", "-o", str(target)])
    assert bad.exit_code == 2 and not target.exists()


def test_mean_flow_scale_rule():
    mf = PrepareParams(compaction="mean-flow")
    assert damping_scale(mf, 100.0) == 1.0  # the fluctuations keep b / t_i
    assert mean_flow_scale(mf, 25.0) == 1.0 and mean_flow_scale(mf, 100.0) == 0.25
    assert mean_flow_scale(PrepareParams(compaction="height-scaled"), 100.0) == 1.0
    assert mean_flow_scale(PrepareParams(), 100.0) == 1.0


def _loose_grains(v_mean, fluct_sign):
    """16 equal grains without contacts, in pairs sharing a slab (4 d) with opposite fluctuation."""
    n = 16
    x = 1.5 * np.arange(n) + 0.75
    z = 2.0 + 4.0 * (np.arange(n) // 4) + 0.3 * (np.arange(n) % 4)  # four grains per slab
    u = fluct_sign * 1e-3 * np.where(np.arange(n) % 2 == 0, 1.0, -1.0) * (1 + np.arange(n) // 2)
    vel = np.zeros((n, 2))
    vel[:, 0] = 2e-3 * np.cos(np.arange(n))  # lateral: damped at gamma, not in the mean flow
    vel[:, 1] = v_mean + u
    return np.column_stack([x, z]), np.full(n, 0.5), vel, u


@pytest.mark.parametrize("v_mean, sign", [(0.0, 1.0), (-3e-3, 0.0), (-3e-3, 1.0)])
def test_mean_flow_damping_splits_mean_and_fluctuation(v_mean, sign):
    """A uniform vertical motion is damped at gamma_m, a velocity field with zero slab means at
    gamma (exactly: the slab means vanish), their sum at gamma_m and gamma; the piston at gamma_m."""
    gamma, gamma_m = 2e-3, 5e-4
    pos, rad, vel, u = _loose_grains(v_mean, sign)
    e = Engine(pos, rad, [24.0], 20.0, friction=0.0, damping=0.0, background_damping=gamma, piston_mass=3.0,
               piston_force=0.0, velocity=vel, mean_flow=(gamma_m, 4.0))
    m = e.mass
    assert e.measure()["contacts"] == 0
    # lateral: -gamma v, bit for bit as the loop computes it
    np.testing.assert_array_equal(e.acceleration[:, 0], (0.0 - gamma * m * vel[:, 0]) * (1.0 / m))
    expected = -gamma_m * v_mean - gamma * u
    if v_mean == 0.0:
        np.testing.assert_array_equal(e.acceleration[:, 1], (0.0 - gamma * m * vel[:, 1]) * (1.0 / m))
    else:
        np.testing.assert_allclose(e.acceleration[:, 1], expected, rtol=1e-13, atol=1e-18)
    e.piston.v = -1e-3
    e._forces()
    assert e.piston.a == pytest.approx(gamma_m * 1e-3, rel=1e-15)
    off = Engine(pos, rad, [24.0], 20.0, friction=0.0, damping=0.0, background_damping=gamma, piston_mass=3.0,
                 velocity=vel)  # rule off: everything at gamma
    np.testing.assert_allclose(off.acceleration[:, 1], -gamma * vel[:, 1], rtol=1e-14)


def test_lateral_mean_flow_at_its_own_rate():
    """The slabs' mean lateral flow (a shear) is damped at gamma_l, the lateral fluctuation about
    it at gamma; with gamma_l = gamma (the compaction) the term is not added: the bits of the
    rule without it."""
    gamma, gamma_m, gamma_l = 2e-3, 5e-4, 7e-4
    pos, rad, vel, _ = _loose_grains(-3e-3, 1.0)
    slab = np.arange(16) // 4
    shear = 1e-3 * (1.0 + slab)  # mean lateral velocity of each slab
    fluct = 2e-4 * np.where(np.arange(16) % 2 == 0, 1.0, -1.0)  # zero mean in every slab
    vel[:, 0] = shear + fluct
    e = Engine(pos, rad, [24.0], 20.0, friction=0.0, damping=0.0, background_damping=gamma, velocity=vel,
               mean_flow=(gamma_m, 4.0, gamma_l))
    np.testing.assert_allclose(e.acceleration[:, 0], -gamma_l * shear - gamma * fluct, rtol=1e-12, atol=1e-20)
    same = Engine(pos, rad, [24.0], 20.0, friction=0.0, damping=0.0, background_damping=gamma, velocity=vel,
                  mean_flow=(gamma_m, 4.0, gamma))
    two = Engine(pos, rad, [24.0], 20.0, friction=0.0, damping=0.0, background_damping=gamma, velocity=vel,
                 mean_flow=(gamma_m, 4.0))  # the default gamma_l: background_damping
    assert two.mflow[2] == gamma
    m = same.mass
    np.testing.assert_array_equal(same.acceleration[:, 0], (0.0 - gamma * m * vel[:, 0]) * (1.0 / m))
    np.testing.assert_array_equal(two.acceleration, same.acceleration)
    with pytest.raises(InputError, match="mean_flow must be"):
        Engine(pos, rad, [24.0], 20.0, background_damping=gamma, mean_flow=(gamma_m, 4.0, -1.0))


@pytest.mark.parametrize("dim,gamma_l", [(2, 2e-3), (2, 7e-4), (3, 7e-4)])
def test_slab_means_sum_in_grain_order(dim, gamma_l):
    """The slab pass (sums carried over runs of grains sharing a slab) gives every slab's sums in
    grain order, bit for bit: against a plain loop over the grains, with grains below the floor,
    above the last slab, runs of one grain and slabs met again after others."""
    from granwave.dem.mean_flow import slab_means

    rng = np.random.default_rng(7)
    n, gamma = 400, 2e-3
    z = np.sort(rng.uniform(-1.0, 30.0, n))  # layer by layer, then shuffled locally
    swap = rng.integers(0, n - 1, 60)
    for i in swap:
        z[[i, i + 1]] = z[[i + 1, i]]
    z[::37] = rng.uniform(-1.0, 40.0, z[::37].shape)  # strays far from their neighbours
    pos = np.column_stack([rng.uniform(0, 10, (n, dim - 1)), z])
    vel = rng.normal(0.0, 1e-3, (n, dim))
    mass = rng.uniform(0.5, 1.5, n)
    mflow = np.array([5e-4, 2.5, gamma_l])
    ns = 10  # slabs of 2.5 d: z > 22.5 d counts in the last
    slabs = np.full((dim + 1, ns), np.nan)
    slab_means(pos, vel, mass, gamma, mflow, slabs)
    lateral = gamma_l != gamma
    want = np.zeros((dim + 1, ns))
    for i in range(n):
        k = 0 if not z[i] > 0.0 else min(int(z[i] / 2.5), ns - 1)
        want[0, k] += mass[i] * vel[i, dim - 1]
        want[1, k] += mass[i]
        for a in range(dim - 1 if lateral else 0):
            want[2 + a, k] += mass[i] * vel[i, a]
    for k in range(ns):
        if want[1, k] > 0.0:
            want[0, k] /= want[1, k]
            for a in range(dim - 1 if lateral else 0):
                want[2 + a, k] /= want[1, k]
    assert np.all(want[1] > 0.0)  # every slab has grains
    n_rows = 2 + (dim - 1 if lateral else 0)
    np.testing.assert_array_equal(slabs[:n_rows], want[:n_rows])
    assert np.all(slabs[n_rows:] == 0.0)  # rows not used are zeroed, not summed


def test_mean_flow_refused_by_an_engine_without_it():
    pos, rad, vel, _ = _loose_grains(-1e-3, 1.0)

    class OtherEngine(Engine):  # steps elsewhere, without the rule (the GPU engine has it: test_gpu_device.py)
        def run(self, n_steps):
            return 0

    with pytest.raises(InputError, match="mean-flow compaction runs on the CPU only"):
        OtherEngine(pos, rad, [24.0], 20.0, background_damping=1e-3, mean_flow=(1e-4, 4.0))


@pytest.fixture(scope="module")
def mean_flow():
    return prepare_packing(PrepareParams(**MEAN_FLOW))


def test_mean_flow_converges_and_records_its_protocol(mean_flow, before):
    a = mean_flow.attrs
    h_e = expected_height(mean_flow.radius, mean_flow.box[:-1])
    assert a["compaction"] == "mean-flow" and a["compaction_rule"] == COMPACTION_RULES["mean-flow"]
    assert a["background_damping_scale"] == 1.0 and a["background_damping_rate"] == 0.3 / a["inertial_time"]
    assert a["mean_flow_damping_scale"] == 5.0 / h_e and a["mean_flow_slab"] == 4.0
    assert a["mean_flow_damping_rate"] == pytest.approx(0.3 * (5.0 / h_e) / a["inertial_time"], rel=1e-14)
    res = static_residual(mean_flow, a["piston_mass"], 1e-4 * wall_area(mean_flow.box[:-1]))
    assert a["converged"] and max(res) < 1e-10 and a["max_acceleration"] == max(res)
    assert a["steps"] != before.attrs["steps"] and digest(mean_flow) != digest(before)


def test_mean_flow_same_seed_same_bytes(mean_flow, tmp_path):
    again = prepare_packing(PrepareParams(**MEAN_FLOW))
    files.write_packing(tmp_path / "a.h5", mean_flow)
    files.write_packing(tmp_path / "b.h5", again)
    assert (tmp_path / "a.h5").read_bytes() == (tmp_path / "b.h5").read_bytes()
