"""How many threads the parallel kernels use (one place to set it).

Compute stages take ``--threads N`` (default: the cores this process may run
on); the library sets numba's thread count here, once per process. Results
must not depend on it: parallel kernels sum in a fixed order.

The threading layer is chosen here too, on import (every module with parallel
kernels imports this one): OpenMP, whose idle threads spin ``GOMP_SPINCOUNT``
(SPIN_COUNT) times before they sleep. The engine opens two parallel regions per
step, so waking sleeping threads is what limits small steps: a passive policy (no spin) makes
the threads barely faster than one, an unbounded spin keeps the cores busy after the parallel
work, and a long spin makes two processes sharing the cores starve each other's threads.
1000 turns (libgomp's own spin when threads outnumber the cores) avoids all three
(docs/decisions/0012-thread-wait-policy.md). An explicit
``NUMBA_THREADING_LAYER``, ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` in the
environment is kept.
"""

from __future__ import annotations

import contextlib
import os

#: Preferred numba threading layer (falls back to numba's default when unavailable).
THREADING_LAYER = "omp"
#: Turns an idle OpenMP thread spins before it sleeps (``GOMP_SPINCOUNT``; module docstring)
SPIN_COUNT = 1000


def configure_layer() -> None:
    """Select the threading layer before numba starts its threads (idempotent)."""
    if "OMP_WAIT_POLICY" not in os.environ:
        os.environ.setdefault("GOMP_SPINCOUNT", str(SPIN_COUNT))
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
