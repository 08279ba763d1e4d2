"""The device option: the CPU path loads no GPU package; a GPU request without a usable GPU is
refused in one line with exit status 2 and no output; methods without GPU kernels are refused."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from granwave import api
from granwave.errors import InputError
from granwave.gpu import check_device

ENV = {**os.environ, "NUMBA_DISABLE_CUDA": "1"}
ENV.pop("NUMBA_ENABLE_CUDASIM", None)


# GPU packages: numba's CUDA target (built in, or numba-cuda's numba_cuda), CUDA bindings, CuPy.
# With the gpu extra installed, its import hooks (.pth files) load the empty ``cuda`` namespace
# package at interpreter start, before any import: what was there at start is the baseline.
CPU_PATH = """
import sys
GPU = ("numba.cuda", "numba_cuda", "cuda", "cupy", "cupyx")
def gpu_modules():
    return sorted(m for m in sys.modules if m in GPU or m.startswith(tuple(g + "." for g in GPU)))
start = gpu_modules()
import numba
plain = gpu_modules()
import granwave.cli, granwave.api as api
packing = api.prepare_packing(grains=20, seed=1, tol=1e-3, pressure=1e-2, device="cpu")
system = api.linearize(api.lattice(rows=3, width=3, pressure=1e-4))
api.propagate(system, t_max=1.0, samples=3, method="time", device="cpu")
after = gpu_modules()
print("gpu modules:", start, plain, after)
assert plain == start and after == start, (start, plain, after)
assert "numba.cuda" not in sys.modules and "cupy" not in sys.modules
"""


def _run(code: str):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV,
                          timeout=300)


def test_gpu_cpu_path_imports_no_gpu_package():
    r = _run(CPU_PATH)
    assert r.returncode == 0, r.stderr
    assert "gpu modules:" in r.stdout


@pytest.mark.parametrize("stage", ["prepare-packing", "propagate"])
def test_gpu_without_a_gpu_exits_2_with_one_line_and_no_output(tmp_path, stage):
    out = tmp_path / "out.h5"
    args = ["prepare-packing", "--grains", "20"] if stage == "prepare-packing" else []
    if stage == "propagate":
        src = tmp_path / "lin.h5"
        make = ("from granwave import api; from granwave.io import files; "
                f"files.write_linear({str(src)!r}, api.linearize(api.lattice(rows=3, width=3, "
                "pressure=1e-4)))")
        assert _run(make).returncode == 0
        args = ["propagate", str(src), "--t-max", "1", "--method", "time"]
    r = subprocess.run([sys.executable, "-m", "granwave", *args, "-o", str(out), "--device", "gpu"],
                       capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "--device gpu" in lines[0] and "no usable CUDA GPU" in lines[0]
    assert not out.exists()


def test_gpu_device_names_and_methods_without_gpu_kernels_are_refused():
    assert check_device(None) == "cpu" and check_device("GPU") == "gpu"
    with pytest.raises(InputError, match="device must be one of"):
        check_device("tpu")
    packing = api.lattice(rows=3, width=3, pressure=1e-4)
    system = api.linearize(packing)
    with pytest.raises(InputError, match="modal runs on the CPU only"):
        api.propagate(system, t_max=1.0, method="modal", device="gpu")


def test_gpu_engine_takes_the_mean_flow_rule():
    """The GPU engine runs every rule of the CPU engine (granwave.gpu.mean_flow): it no longer
    refuses the compaction rule 'mean-flow'; an engine with its own stepping that lacks the
    rule still does. Needs numba's CUDA target importable (no GPU: nothing runs on a device)."""
    import numpy as np

    pytest.importorskip("numba.cuda")
    from granwave.dem.integrator import Engine
    from granwave.gpu.dem import GpuEngine

    pos = np.array([[1.0, 0.6], [3.0, 0.6], [2.0, 1.5]])
    kw = dict(mean_flow=(0.1, 1.0), background_damping=0.5)
    e = GpuEngine(pos, np.full(3, 0.5), [6.0], 3.0, **kw)
    assert e.mflow.shape == (3,) and e.slabs.shape == (3, 5)

    class Stepper(Engine):
        def run(self, n_steps):  # its own stepping, without the rule
            return 0

    with pytest.raises(InputError, match="mean-flow compaction runs on the CPU only"):
        Stepper(pos, np.full(3, 0.5), [6.0], 3.0, **kw)


def test_gpu_engine_refuses_rolling_resistance():
    """The device's pair kernel has no rolling couple: a GPU engine with the rolling sub-model is
    refused in one line rather than run without it."""
    import numpy as np

    pytest.importorskip("numba.cuda")
    from granwave.gpu.dem import GpuEngine

    pos = np.array([[1.0, 0.6], [3.0, 0.6], [2.0, 1.5]])
    with pytest.raises(InputError, match="rolling resistance runs on the CPU only"):
        GpuEngine(pos, np.full(3, 0.5), [6.0], 3.0, friction=0.5, rolling="sds", rolling_stiffness=1.0,
                  rolling_friction=0.1)
