"""The GPU kernels against the CPU kernels, run in numba's CUDA simulator on tiny systems.

The simulator executes the kernels (threads, blocks, shared memory, barriers) as Python on
the CPU, so these tests need no GPU; they cannot tell whether a kernel compiles for a real one
(tests/test_gpu_ptx.py does). They run in a subprocess: the simulator is chosen when
numba.cuda is first imported, and the rest of the suite must not see it. All checks run in
one subprocess (granwave.gpu.checks: 10 min wall on a 2-core machine under load 8).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest


@pytest.fixture(scope="module")
def results():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    r = subprocess.run([sys.executable, "-m", "granwave.gpu.checks"], capture_output=True, text=True,
                       env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_gpu_time_domain_signal_equals_cpu(results):
    r = results["time_domain"]
    for ic in "AB":
        assert r[f"steps_{ic}"] > 20
        assert r[f"signal_rel_{ic}"] < 1e-10
        assert r[f"snapshot_rel_{ic}"] < 1e-10
        # the energies reduced on the device agree with the CPU ones (both ~1e-15)
        assert abs(r[f"energy_dev_gpu_{ic}"] - r[f"energy_dev_cpu_{ic}"]) < 1e-13


@pytest.mark.slow
def test_gpu_two_body_frictional_collision_equals_cpu(results):
    r = results["two_body"]
    assert r["tangential_force"] > 1e-4 and r["overlap"] > 1e-3  # friction and contact engaged
    assert r["state_abs"] < 1e-12


@pytest.mark.slow
def test_gpu_repeated_runs_give_identical_bytes(results):
    assert results["two_body"]["identical"]
    assert results["time_domain"]["identical"]


@pytest.mark.slow
def test_gpu_prepared_tiny_packing_equals_cpu(results):
    r = results["prepare"]
    assert r["device_attr"] == "gpu"
    assert r["rebuilds"] > 5  # the device rebuild is exercised (one cell: a 10-grain box is narrow)
    assert r["steps_gpu"] == r["steps_cpu"]
    assert r["contacts_gpu"] == r["contacts_cpu"]
    assert r["position_abs"] < 1e-9 and r["height_abs"] < 1e-9


@pytest.mark.slow
def test_gpu_dem_pulse_equals_cpu(results):
    r = results["pulse"]
    for k in ("n_opened", "n_formed", "n_sliding"):
        assert r[f"{k}_cpu"] > 0 and r[f"{k}_gpu"] == r[f"{k}_cpu"], k
    assert r["neighbour_rebuilds_gpu"] == r["neighbour_rebuilds_cpu"] > 5
    assert r["n_contacts_initial_gpu"] == r["n_contacts_initial_cpu"]
    assert r["signal_rel"] < 1e-10 and r["max_displacement_rel"] < 1e-12


@pytest.mark.slow
def test_gpu_device_rebuild_equals_cpu_rebuild(results):
    """granwave.gpu.neighbours against granwave.dem.neighbours: a dense gas rebuilt mid-run
    (cell lists of 5-6 cells per axis), in 2D and 3D, by the one-block and the multi-kernel
    rebuild, and in 2D once more with the pair arrays cut to the first list's pairs (a later
    rebuild runs out of room on the device, the host makes room and the run goes on): the same
    pairs in the same order, the same histories and the same state, bit for bit, and the same
    number of rebuilds."""
    r = results["rebuild"]
    for key in ("2d", "2d_multi", "3d", "3d_multi", "2d_room", "2d_room_multi"):
        dim = key[:2]
        assert r[f"rebuilds_{key}"] == r[f"rebuilds_cpu_{dim}"] >= 2, key  # rebuilt mid-run
        assert r[f"pairs_{key}"] == r[f"pairs_cpu_{dim}"] > 0, key
        assert r[f"same_pairs_{key}"] and r[f"same_history_{key}"] and r[f"same_state_{key}"], key
    assert r["room_made_2d_room"] >= 1 and r["room_made_2d_room_multi"] >= 1 and r["room_made_2d"] == 0
    # the test every third step looks three steps ahead: rebuilds at other steps, the same bits
    assert r["same_state_2d_every3"] and r["rebuilds_2d_every3"] >= r["rebuilds_cpu_2d"]


@pytest.mark.slow
def test_gpu_mean_flow_rule_equals_cpu_bitwise(results):
    """granwave.gpu.mean_flow against granwave.dem.mean_flow: a dense gas with the slabs' mean
    flows damped at rates of their own, 2D frictionless (lateral rate the background one: no
    lateral sums) and 3D frictional (lateral rate apart: both lateral means), with rebuilds
    mid-run; the state and the slab means of the last step bit for bit, and the rule moves the
    state."""
    r = results["mean_flow"]
    for dim in ("2d", "3d"):
        assert r[f"same_state_{dim}"] and r[f"same_slabs_{dim}"], (dim, r[f"state_abs_{dim}"])
        assert r[f"moved_{dim}"] > 1e-2, dim  # without the rule the velocities differ this much
        assert r[f"rebuilds_{dim}"] >= 1 and r[f"occupied_slabs_{dim}"] >= 3, dim
    assert r["lateral_sums_2d"] == 0.0 and r["lateral_sums_3d"] > 0.0


@pytest.mark.slow
def test_gpu_rules_between_runs_equal_cpu(results):
    """The settling switch and the end game's cap, made on the host between runs, reach the
    device: a gas under a loaded piston (damped at the mean-flow rate in 2D) on both engines.
    The piston force is reduced in another order on the device: the state agrees to rounding
    (1e-12 over 18 steps), not necessarily bit for bit."""
    r = results["rules"]
    for dim in ("2d", "3d"):
        assert r[f"steps_{dim}"] == 18
        assert r[f"piston_force_{dim}"] > 0.0 and r[f"piston_moved_{dim}"] > 1e-3, dim
        assert r[f"state_abs_{dim}"] < 1e-12, dim
