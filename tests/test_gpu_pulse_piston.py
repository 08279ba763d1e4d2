"""The DEM pulse's piston drive on the GPU (``propagate --method dem --drive piston --device gpu``)
against the CPU, in numba's CUDA simulator on a 9-grain column (granwave.gpu.checks.pulse_piston).

The simulator runs the kernels as Python on the CPU, in a subprocess (it is chosen when
numba.cuda is first imported; the rest of the suite must not see it). That the kernels compile
for a real GPU is tests/test_gpu_ptx.py's check (the piston drive adds no kernel: it is the
pulse's kernels with the source grains made heavy, and the CPU's readings on the state brought
back at every sample).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest


@pytest.fixture(scope="module")
def piston():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    r = subprocess.run([sys.executable, "-m", "granwave.gpu.checks", "pulse_piston"], capture_output=True,
                       text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])["pulse_piston"]


def test_gpu_piston_pulse_equals_cpu(piston):
    r = piston
    # a strong push: the contacts' force grows several times over, the field moves
    assert r["force_grew"] > 2.0 and r["field_max"] > 0.5 * r["piston_velocity"]
    assert r["n_steps_gpu"] == r["n_steps_cpu"] >= 40
    for k in ("n_opened", "n_formed", "n_sliding", "neighbour_rebuilds", "n_contacts_initial"):
        assert r[f"{k}_gpu"] == r[f"{k}_cpu"], k
    assert r["neighbour_rebuilds_cpu"] > 0  # the host rebuild and its carried flags are exercised
    # the counts at every sample, from the flags brought to the host, and the incoming front's (NaN
    # on both: the 3-row column's four samples fit no front)
    for k in ("opened", "formed", "sliding_new"):
        assert r[f"{k}_gpu"] == r[f"{k}_cpu"], k
    assert r["opened_cpu"][-1] == r["n_opened_cpu"] > r["opened_cpu"][0]  # they change within the record
    for k in ("front_far_wall_time", "n_opened_incoming", "n_formed_incoming", "n_sliding_new_incoming"):
        assert r[f"{k}_gpu"] == r[f"{k}_cpu"] or (math.isnan(r[f"{k}_gpu"]) and math.isnan(r[f"{k}_cpu"])), k
    # the same arithmetic in another order only in the device's reductions (docs/gpu.md)
    assert r["signal_rel"] < 1e-10 and r["field_rel"] < 1e-10 and r["force_max_rel"] < 1e-10
    assert r["max_displacement_rel"] < 1e-12

