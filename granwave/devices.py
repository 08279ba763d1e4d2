"""The compute device of a stage: ``cpu`` (the numba CPU kernels) or ``gpu`` (one NVIDIA GPU).

This module is the one place where a stage's kernels are picked (:func:`backend`); the
stages (granwave.api, the DEM pulse) ask it and never import a device's modules themselves.
The GPU's kernels are a plug-in: the package named in :data:`PLUGINS` is imported by name,
only when its device is asked for, and gives its kernels through its ``kernels()`` (for the
GPU: :func:`granwave.gpu.kernels`, which checks the device first). So the CPU path never
loads a GPU package (tests/test_gpu_device.py checks it).
"""

from __future__ import annotations

import importlib
from types import SimpleNamespace

from .errors import InputError

DEVICES = ("cpu", "gpu")

#: device -> the package whose ``kernels()`` gives that device's kernels.
PLUGINS = {"gpu": "granwave.gpu"}


def check_device(device: str | None) -> str:
    """The device name, validated (None: ``cpu``)."""
    device = "cpu" if device is None else str(device).lower()
    if device not in DEVICES:
        raise InputError(f"device must be one of {', '.join(DEVICES)} (got {device!r})")
    return device


def backend(device: str | None) -> SimpleNamespace:
    """The kernels of ``device``: ``engine`` (the DEM engine class), ``time_domain_signal``,
    ``pulse_samples`` (the stepping loop of the nonlinear DEM pulse) and, for the GPU,
    ``prepare_packings`` (many seeds advanced together).

    ``cpu`` imports only the CPU modules; another device's plug-in (:data:`PLUGINS`) checks
    that its device is usable before it returns, so a missing GPU fails before any work.
    """
    device = check_device(device)
    if device == "cpu":
        from .dem.integrator import Engine
        from .dem.pulse_kernels import pulse_samples
        from .linear.propagate import time_domain_signal

        return SimpleNamespace(device="cpu", engine=Engine, time_domain_signal=time_domain_signal,
                               pulse_samples=pulse_samples)
    return importlib.import_module(PLUGINS[device]).kernels()


def require(device: str | None) -> None:
    """Raise InputError (one line) unless ``device`` is usable on this machine, without loading
    its kernels: the CPU always is; another device's plug-in is asked by its ``require_gpu``."""
    device = check_device(device)
    if device != "cpu":
        importlib.import_module(PLUGINS[device]).require_gpu()
