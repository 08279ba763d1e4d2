"""Every contact sub-model beside the defaults runs on the GPU engine with the CPU's bits: the GPU
compiles the same dispatchers from their source (granwave.gpu.compile), and asks the kinds' hooks
what the CPU asks. In numba's CUDA simulator, in one subprocess (``python
tests/gpu_submodel_checks.py``, ~10 CPU-s), as tests/test_gpu_sim.py: a two-grain frictional
collision with damping and spins, the contact engaged and its tangential force built, the same
bytes after 30 steps."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from granwave.contact_models import options as CO


def test_every_sub_model_gives_the_cpu_s_bytes_on_the_gpu():
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    script = Path(__file__).with_name("gpu_submodel_checks.py")
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    results = json.loads(r.stdout.strip().splitlines()[-1])
    assert set(results) == {n for n, s in CO.SUBMODELS.items() if s["code"] != 0 and "gpu" in s["devices"]}
    for name, res in results.items():
        assert res["overlap"] > 1e-2 and res["tangential_force"] > 1e-4, name  # contact and friction engaged
        assert res["same_bytes"] and res["max_abs"] == 0.0, (name, res)
