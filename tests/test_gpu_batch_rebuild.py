"""The segmented rebuild of a batch's large packings (granwave.gpu.batch_rebuild), in numba's CUDA
simulator: one launch sequence for all of them, each packing's list the bytes of its rebuild alone.

As tests/test_gpu_sim.py, the checks run in a subprocess (the simulator is chosen when numba.cuda
is first imported; the rest of the suite must not see it): ``python tests/gpu_batch_rebuild_checks.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).with_name("gpu_batch_rebuild_checks.py")


def _checks(name: str) -> dict:
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    r = subprocess.run([sys.executable, str(SCRIPT), name], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])[name]


def test_segmented_rebuild_launches_do_not_grow_with_the_batch():
    """B = 1 and B = 3 large packings, each list due at the first step: one rebuild of twelve
    launches for the whole batch (the per-packing rebuild took twelve per packing)."""
    r = _checks("launches")
    assert r["per_rebuild"] == 12  # granwave.gpu.batch_rebuild.LAUNCHES (read in the subprocess)
    for b in (1, 3):
        got = r[f"B{b}"]
        assert got["rebuilds"] == [1] * b  # every packing rebuilt, in the one step
        assert got["launches_per_rebuild"] == {"12": 1}, got


def test_segmented_rebuild_equals_each_packing_rebuilt_alone():
    """Three large packings of 8, 10 and 12 grains run together for 1, 2 and 3 steps, one with its
    pair arrays cut (its second rebuild runs out of room on the device, room is made, the step
    redone), one with the rebuild test every 3rd step (masked while another rebuilds, though its
    fast grain would make it due), checks every 2 steps: state, reference positions, pair list,
    histories, time step, measures, steps, rebuilds and rooms made are the bytes of each run alone
    with the per-packing rebuild."""
    r = _checks("same_as_alone")
    for seed in (0, 7, 2):
        assert r[f"same_seed{seed}"], seed
        assert r[f"rebuilds_seed{seed}"] >= 1
    assert len({r[f"grains_seed{s}"] for s in (0, 7, 2)}) == 3
    assert r["room_made_seed7"] == 1  # the capacity test of the segmented fill, and room made
    assert r["rebuilds_seed2"] == 1 and r["steps_seed2"] == 3  # masked at steps 2 and 3
    assert r["launches_per_rebuild"].get("12", 0) >= 2 and r["small_rebuild_launches"] == 0
    assert r["measures"] >= 1  # the checks at step 2 of two packings: one batched measure
