"""What every output file records about how it was made."""

from __future__ import annotations

import functools
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from . import __version__


@functools.lru_cache(maxsize=1)
def git_revision() -> str:
    """The git revision of the granwave source tree, or 'unknown' outside a checkout."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "-C", str(here), "rev-parse", "--short=12", "HEAD"],
            capture_output=True, text=True, timeout=5, check=True,
        )
        dirty = subprocess.run(
            ["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True, timeout=5, check=True,
        )
        return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


#: The libraries whose versions a file records (``software``): those whose code computes it.
LIBRARIES = ("numpy", "scipy", "numba", "llvmlite", "h5py")


@functools.lru_cache(maxsize=1)
def software() -> str:
    """Python's and the computing libraries' versions, e.g. 'python 3.11.7, numpy 2.4.6, ...'."""
    parts = [f"python {platform.python_version()}"]
    for name in LIBRARIES:
        try:
            parts.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            parts.append(f"{name} absent")
    return ", ".join(parts)


@functools.lru_cache(maxsize=1)
def machine() -> str:
    """The CPU and the SIMD loops numpy chose on it, e.g. 'x86_64, AMD EPYC, numpy SIMD X86_V3
    X86_V4 AVX512_ICL'. numpy's power, exp, log, ... differ in the last bit between those loops,
    and OpenBLAS picks its kernels by CPU too: the packings no longer depend on it, but an
    eigensolve's last bits do (docs/dem.md "The same bits on every machine")."""
    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:
        pass
    dispatched, found = numpy_simd()
    simd = [f for f in dispatched if found.get(f)]
    return f"{platform.machine()}, {cpu or 'unknown CPU'}, numpy SIMD {' '.join(simd) or 'baseline'}"


def numpy_simd() -> tuple[list, dict]:
    """numpy's dispatched CPU features (the names NPY_DISABLE_CPU_FEATURES takes) and which CPU
    features this machine has ({name: bool}); empty where numpy does not say."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy < 2
        from numpy.core import _multiarray_umath as umath
    return list(getattr(umath, "__cpu_dispatch__", [])), dict(getattr(umath, "__cpu_features__", {}))


#: Root attributes that describe a file itself (written by every writer; never copied
#: from an input file's attributes into an output's).
FILE_ATTRS = ("schema", "schema_version", "granwave_version", "git_revision", "command_line", "software",
              "machine")

#: Attributes that identify a sample: every stage carries them from its input to its output
#: (each stage adds the few of its own that later stages need).
SAMPLE_ATTRS = ("pressure", "seed", "friction", "kind", "dim", "poisson", "material")


def carried(attrs: dict, keys=SAMPLE_ATTRS) -> dict:
    """The entries of ``attrs`` named in ``keys`` (those present), in the order of ``keys``."""
    return {k: attrs[k] for k in keys if k in attrs}


def provenance_attrs() -> dict:
    """Attributes written on the root of every granwave file."""
    return {
        "granwave_version": __version__,
        "git_revision": git_revision(),
        "command_line": " ".join(sys.argv),
        "software": software(),
        "machine": machine(),
    }
