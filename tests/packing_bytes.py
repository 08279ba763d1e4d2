"""A packing file's content for byte comparisons, without its command line (shared by
tests/test_gpu_checkpoint.py and tests/gpu_checkpoint_checks.py)."""

from __future__ import annotations

import h5py
import numpy as np

from granwave.io import files
from granwave.provenance import FILE_ATTRS


def packing_data(path) -> tuple[bytes, dict]:
    """A packing file's arrays (bytes) and its attributes but the command line's."""
    p = files.read_packing(path)
    c = p.contacts
    data = b"".join(np.ascontiguousarray(x).tobytes() for x in (
        p.position, p.radius, p.box, c.i, c.j, c.normal, c.overlap, c.force_normal, c.force_tangential,
        c.stiffness_normal, c.stiffness_tangential))
    with h5py.File(path, "r") as f:
        attrs = {k: str(v) for k, v in f.attrs.items() if k not in FILE_ATTRS}
    return data, attrs
