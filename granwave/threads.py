"""How many threads the parallel kernels use (one place to set it).

Compute stages take ``--threads N`` (default: the cores this process may run
on); the library sets numba's thread count here, once per process. Results
must not depend on it: parallel kernels sum in a fixed order.
"""

from __future__ import annotations

import os


def available_cores() -> int:
    """Cores this process may run on (the affinity mask, e.g. a SLURM allocation)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def set_threads(n: int | None = None) -> int:
    """Use ``n`` threads in numba's parallel kernels (None: every available core); return n."""
    import numba

    n = available_cores() if n is None else int(n)
    if n < 1:
        from .errors import InputError

        raise InputError(f"threads must be >= 1, got {n}")
    n = min(n, numba.config.NUMBA_NUM_THREADS)
    numba.set_num_threads(n)
    return n
