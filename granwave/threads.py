"""How many threads the parallel kernels use (one place to set it).

Compute stages take ``--threads N`` (default: the cores this process may run
on); the library sets numba's thread count here, once per process. Results
must not depend on it: parallel kernels sum in a fixed order.

The threading layer is chosen here too, on import (every module with parallel
kernels imports this one): OpenMP, whose idle threads spin ``GOMP_SPINCOUNT =
100000`` times before they sleep. The engine and the time domain open two parallel
regions per step, so waking sleeping threads is what limits small steps: on a quiet
2-core machine (benchmarks/scale.py, threads 1 -> 2) a passive wait policy (no
spinning, 60 us per region) gave 1.08x (DEM, 10^4 grains) and 1.43x (time domain,
3 * 10^4 dofs); spinning 100000 times gave 1.97x and 1.95x, 3000 times 1.89x and
1.80x. An unbounded spin (``OMP_WAIT_POLICY=ACTIVE`` alone) made as good a ratio but
kept the threads busy after the parallel work (a single-thread rate measured after it
fell by half). numba's workqueue layer costs about 100 us per region. An explicit
``NUMBA_THREADING_LAYER``, ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` in the
environment is kept.
"""

from __future__ import annotations

import contextlib
import os

#: Preferred numba threading layer (falls back to numba's default when unavailable).
THREADING_LAYER = "omp"


def configure_layer() -> None:
    """Select the threading layer before numba starts its threads (idempotent)."""
    if "OMP_WAIT_POLICY" not in os.environ:
        os.environ.setdefault("GOMP_SPINCOUNT", "100000")
    if "NUMBA_THREADING_LAYER" in os.environ:
        return
    import numba

    try:
        from numba.np.ufunc import omppool  # noqa: F401  (is the OpenMP layer built?)
    except ImportError:
        return
    numba.config.THREADING_LAYER = THREADING_LAYER


configure_layer()


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


@contextlib.contextmanager
def at_most(size: int, minimum: int):
    """One thread inside the block when ``size`` < ``minimum`` (a system too small to gain
    from threads), else the threads set; results are the same either way."""
    import numba

    threads = numba.get_num_threads()
    if size < minimum and threads > 1:
        numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(threads)
