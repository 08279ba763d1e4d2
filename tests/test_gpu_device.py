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


@pytest.mark.parametrize("stage", ["prepare-packing", "prepare-packing-rolling", "propagate"])
def test_gpu_without_a_gpu_exits_2_with_one_line_and_no_output(tmp_path, stage):
    """(With rolling resistance too: the GPU runs it, so the line is the missing GPU's.)"""
    out = tmp_path / "out.h5"
    args = ["prepare-packing", "--grains", "20"] if stage.startswith("prepare-packing") else []
    if stage == "prepare-packing-rolling":
        args += ["--rolling", "sds"]
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


def test_gpu_engine_takes_rolling_resistance():
    """The device's pair kernel computes the rolling couple (tests/test_gpu_rolling.py checks it
    against the CPU, bit for bit, in the simulator): a GPU engine with the rolling sub-model has
    the CPU engine's history columns (F_t, then the rolling displacement) and is not refused, nor
    is ``device="gpu"`` with ``rolling="sds"`` before the device is looked for."""
    import numpy as np

    pytest.importorskip("numba.cuda")
    from granwave.contact_models import options as CO
    from granwave.gpu.dem import GpuEngine
    from granwave.params import PrepareParams

    pos = np.array([[1.0, 0.6], [3.0, 0.6], [2.0, 1.5]])
    e = GpuEngine(pos, np.full(3, 0.5), [6.0], 3.0, friction=0.5, rolling="sds", rolling_stiffness=1.0,
                  rolling_friction=0.1)
    assert e.pair_ft.shape[1] == e.wall_ft.shape[1] == 4
    assert CO.cpu_only(CO.values_of(PrepareParams(rolling="sds"))) is None


def test_gpu_dem_pulse_refuses_a_rolling_packing_in_one_line():
    """The DEM pulse does not run rolling resistance on either device: with ``device="gpu"`` a
    rolling packing is refused in one line before any device work (no GPU needed)."""
    from granwave.dem.pulse import propagate_dem

    packing = api.prepare_packing(grains=10, seed=1, tol=1e-2, pressure=1e-2, rolling="sds")
    for device in ("gpu", "cpu"):
        with pytest.raises(InputError) as exc:
            propagate_dem(packing, t_max=1.0, samples=3, device=device)
        message = str(exc.value)
        assert "does not run rolling resistance" in message and "\n" not in message, message
