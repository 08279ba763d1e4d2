"""Memory traffic model of the GPU DEM step, for the bandwidth roofline of benchmarks/gpu.py
(no CUDA needed)."""

from __future__ import annotations


def bytes_per_step(n: int, npairs: int, dim: int, rot: int, history: int | None = None) -> int:
    """Bytes one step must move at least (a model for the roofline, 8-byte words): per grain the
    state read and written by the kick-drift and force kernels and the reductions; per pair its
    indices, history, stored force and torques (written once, read twice: once per grain) and
    its incidence entries. Gathers of neighbours' state are counted once (cached).
    ``history``: columns of a contact's history (the engine's ``pair_ft.shape[1]``: ``dim`` for
    the tangential force alone, more with rolling resistance); None: ``dim``."""
    d, r = dim, rot
    h = d if history is None else int(history)
    grain = (4 * d + 2 * r) + (2 * d + r + 2)          # kick_drift: read, write
    grain += (2 * d + r + 3)                            # pair_forces' gathers, once per grain
    grain += 1 + (3 * d + 2 * r + 4) + (d + r + 4)      # grain_forces: pointer, reads, writes
    grain += 2 * (2 * h + 1) + 6                        # wall history read and write, reduction
    pair = 2 + 2 * (h + 1) + (3 + 2 * r + 1)            # pair_forces: i, j, history r/w, outputs
    pair += 2 * (1 + 3 + r)                             # grain_forces: 2 incidence entries, reads
    return 8 * (grain * n + pair * npairs)
