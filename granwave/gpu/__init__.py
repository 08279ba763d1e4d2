"""The compute device of a stage: ``cpu`` (the numba CPU kernels) or ``gpu`` (one NVIDIA GPU).

The stages pick their kernels through :func:`granwave.devices.backend`, which loads this
package by name only when ``device="gpu"`` is asked for and takes its kernels from
:func:`kernels`; the rest of granwave imports nothing from here. This module imports nothing
beyond the standard library: the GPU modules (``granwave.gpu.dem``,
``granwave.gpu.linear``, ``granwave.gpu.pulse``, which import ``numba.cuda``) are loaded only
when ``device="gpu"`` is asked for, so the CPU path never loads a GPU package (tests/test_gpu_device.py checks it).

The GPU path needs the ``gpu`` extra (``pip install -e '.[gpu]'``: numba-cuda with the CUDA 12
libraries) and a CUDA device. Tests run the same kernels in numba's CUDA simulator
(``NUMBA_ENABLE_CUDASIM=1``), which executes them as Python on the CPU (docs/gpu.md).
"""

from __future__ import annotations

import os
from types import SimpleNamespace

from ..devices import DEVICES, backend, check_device  # noqa: F401  (re-exported for callers of granwave.gpu)
from ..errors import InputError

INSTALL_HINT = "install the GPU extra: pip install 'granwave[gpu]' (docs/gpu.md)"


def simulated() -> bool:
    """True when numba's CUDA simulator is on (kernels run as Python, for tests only)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0")


def load_cuda():
    """numba's CUDA module, loaded after putting back ``numpy.row_stack`` where numpy lacks it,
    and set to compile without fused multiply-adds (:func:`_compile_without_contraction`).

    numba-cuda 0.30 registers ``np.row_stack`` when it first compiles a kernel, and numpy 2.5
    removed that name (an alias of ``np.vstack``); without it every kernel fails to compile on
    a machine whose numpy is 2.5 (found on a real H100: benchmarks/results/gpu_history.md). The
    alias is only added where missing, so other numpy versions are untouched.
    """
    import numpy

    if not hasattr(numpy, "row_stack"):
        numpy.row_stack = numpy.vstack
    from numba import cuda

    if not simulated():
        _compile_without_contraction()
    return cuda


def _compile_without_contraction() -> None:
    """Make numba's CUDA compiler round ``a * b + c`` as the CPU does: a product, then a sum.

    libNVVM fuses such pairs into one fused multiply-add (``-fma=1``, its default, also without
    fastmath), which rounds once instead of twice: a kernel then differs from the CPU's in the
    last bits, and a DEM run, being chaotic, ends in other step counts and other packings.
    numba-cuda 0.30's ``cuda.jit`` has no option for it (NVIDIA/numba-cuda issue 118), so
    its ``nvvm.compile_ir`` is wrapped to pass ``fma=False`` unless the caller gives ``fma``
    or ``fastmath`` (whose own ``fma=True`` then wins). The wrapper applies to every kernel
    compiled in the process; granwave's cached kernels carry its source's stamp
    (granwave.kernel_cache), so none compiled before this rule is loaded.
    """
    from numba.cuda.cudadrv import nvvm

    compile_ir = nvvm.compile_ir
    if getattr(compile_ir, "granwave_without_fma", False):
        return

    def compile_ir_without_fma(llvmir, **options):
        options.setdefault("fma", False)
        return compile_ir(llvmir, **options)

    compile_ir_without_fma.granwave_without_fma = True
    nvvm.compile_ir = compile_ir_without_fma


def require_gpu() -> None:
    """Raise InputError (one line) unless numba's CUDA target and a CUDA device are usable."""
    try:
        cuda = load_cuda()
    except Exception as exc:  # ImportError, or a broken CUDA installation
        raise InputError(f"--device gpu: numba's CUDA target cannot be loaded ({exc}); "
                         f"{INSTALL_HINT}") from None
    try:
        ok = bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - a missing driver raises in some versions
        ok = False
    if not ok:
        raise InputError("--device gpu: no usable CUDA GPU found (no NVIDIA driver or device on "
                         "this machine); use --device cpu")


def kernels() -> SimpleNamespace:
    """The GPU's kernels for :func:`granwave.devices.backend`: ``engine`` (the DEM engine
    class), ``time_domain_signal``, ``pulse_samples`` (the nonlinear DEM pulse's stepping loop)
    and ``prepare_packings`` (many seeds advanced together). Checks first that a GPU is usable
    (:func:`require_gpu`), so a missing GPU fails before any work or output."""
    require_gpu()
    from .batch import prepare_packings
    from .dem import GpuEngine
    from .linear import time_domain_signal_gpu
    from .pulse import pulse_samples_gpu

    return SimpleNamespace(device="gpu", engine=GpuEngine, time_domain_signal=time_domain_signal_gpu,
                           pulse_samples=pulse_samples_gpu, prepare_packings=prepare_packings)
