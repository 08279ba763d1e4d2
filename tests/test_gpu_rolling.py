"""Rolling resistance (``rolling sds``) on the GPU engine, against the CPU engine, in numba's CUDA
simulator: the pair kernel's couple (the CPU's own code, granwave.gpu.compile), the history's
extra columns through the device rebuild, the host rebuild and the enlarged arrays, and the
batched engine (granwave.gpu.batch) against each packing alone.

As tests/test_gpu_sim.py, the checks run in one subprocess (the simulator is chosen when
numba.cuda is first imported; the rest of the suite must not see it):
``python tests/gpu_rolling_checks.py``, about a minute on a 2-core machine.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def results():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    script = Path(__file__).with_name("gpu_rolling_checks.py")
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize("dim", [2, 3])
def test_gpu_rolling_engine_equals_cpu_bitwise(results, dim):
    """A dense frictional gas with rolling resistance between fixed walls, run on both engines
    (gpu_rolling_checks.rolling): state, pair list, every history column (F_t, then the rolling
    displacement) of pairs and walls, steps, rebuilds and pair count are the CPU's bytes; in 2D
    also with the device asking for room and with the host rebuild.
    The couple takes part: rolling displacements on pairs and walls, the slider's cap reached (3D,
    no rolling dashpot), a spin field other than without rolling."""
    r = results["rolling"]
    d = f"{dim}d"
    assert r[f"history_width_{d}"] == 2 * dim
    assert r[f"rebuilds_{d}"] >= 2 and r[f"pair_contact_steps_{d}"] >= 20 and r[f"wall_contact_steps_{d}"] >= 10
    assert r[f"rolling_pair_max_{d}"] > 0.0 and r[f"rolling_wall_max_{d}"] > 0.0
    assert r[f"moved_{d}"] > 1e-6
    if dim == 3:
        assert r["at_cap_3d"] > 0
    tags = ("", "_room", "_host") if dim == 2 else ("",)
    for tag in tags:
        key = f"{d}{tag}"
        for what in ("pairs", "history", "walls", "state", "counters"):
            assert r[f"same_{what}_{key}"], (key, what, r[f"state_abs_{key}"])
    if dim == 2:
        assert r["room_made_2d_room"] >= 1 and r["room_made_2d"] == 0


@pytest.mark.slow
def test_gpu_rolling_batch_equals_each_packing_alone(results):
    """Two rolling gases advanced together (gpu_rolling_checks.rolling_batch: the batched
    one-block rebuild for one, the multi-kernel rebuild with its pair arrays enlarged mid-batch for
    the other): each one's state, pair list, every history column, walls, piston, slabs and
    counters are the bytes of its runs alone on the GPU engine; its state equals the CPU's to
    rounding (the piston force is reduced in another order on the device)."""
    r = results["rolling_batch"]
    for s in (0, 2):
        assert r[f"history_width_seed{s}"] == 4
        assert r[f"extra_history_max_seed{s}"] > 0.0, s  # rolling displacements at the end
        assert r[f"same_seed{s}"], s
        assert r[f"rebuilds_seed{s}"] >= 1, s
        assert r[f"steps_seed{s}"] == r[f"cpu_steps_seed{s}"]
        assert r[f"cpu_abs_seed{s}"] < 1e-12, s
    assert r["room_made_seed2"] >= 1 and r["small_rebuild_launches"] > 0
