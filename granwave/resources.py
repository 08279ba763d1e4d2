"""Memory and disk estimates, and the guard that refuses requests that cannot fit.

Each stage that can allocate without bound calls one ``check_*`` function at its
top, before allocating: the request is refused with a :class:`ResourceError`
(an :class:`InputError`: one line, exit status 2 on the command line) that gives
the estimate and the amount available, instead of ending in a MemoryError, the
kernel's out-of-memory killer or a half-written file.

The estimates are the peak memory of the stage (bytes), measured on 1e5..2e6
grain runs (peak resident size minus the interpreter's) and rounded up:

=======================  =====================================================
stage                    peak memory
=======================  =====================================================
prepare-packing          2300 B per grain (2D), 8800 B per grain (3D): whole
                         preparations of 1e5 grains on 2 threads, less the
                         interpreter with granwave imported, plus about 10 %
chain                    200 B per ball
lattice                  600 B per ball
linearize                50 B per stiffness-block entry: (2 p)^2 per contact,
                         p dofs per grain, plus 100 B per grain
eigensolve (dense)       4 n^2 doubles (matrix, eigenvectors, LAPACK workspace)
eigensolve (chain)       n^2 doubles (eigenvectors of the tridiagonal matrix)
eigensolve (k lowest)    2 (2 k + 1) n doubles of Lanczos basis, plus k n vectors
propagate                4 doubles per sample, 3 n doubles per snapshot
propagate (time domain)  plus 10 n doubles of state and 40 B per stiffness
                         entry (int64 copies of the CSR arrays, the scaled
                         matrix of the omega_max estimate)
=======================  =====================================================

"Available" is the smallest of the kernel's MemAvailable, the cgroup's limit
minus its usage and the address-space limit (``ulimit -v``) minus what this
process already maps; a request is refused beyond HEADROOM of it, so that the
machine keeps room for the interpreter, the page cache and other jobs.
"""

from __future__ import annotations

import math
import os
import resource as _rlimit

from .errors import ResourceError

#: Fraction of the available memory a single request may take.
HEADROOM = 0.9
DOUBLE = 8


def format_bytes(n: float) -> str:
    """Bytes in a readable unit (1 kB = 1000 B)."""
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"


def _read_int(path: str) -> int | None:
    try:
        with open(path, encoding="ascii") as fh:
            text = fh.read().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def available_memory() -> int:
    """Bytes this process can still allocate (see the module docstring)."""
    candidates = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    candidates.append(int(line.split()[1]) * 1024)
                    break
    except (OSError, ValueError, IndexError):
        pass
    if not candidates:
        try:
            candidates.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (OSError, ValueError, AttributeError):
            pass
    # cgroup v2, then v1 (a container or a batch job's limit)
    for limit_file, usage_file in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                                   ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                    "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        limit, usage = _read_int(limit_file), _read_int(usage_file)
        if limit is not None and usage is not None and limit < 1 << 60:
            candidates.append(max(0, limit - usage))
            break
    soft, _ = _rlimit.getrlimit(_rlimit.RLIMIT_AS)
    if soft != _rlimit.RLIM_INFINITY:
        try:
            with open("/proc/self/statm", encoding="ascii") as fh:
                mapped = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, IndexError):
            mapped = 0
        candidates.append(max(0, soft - mapped))
    return min(candidates) if candidates else 1 << 62


def available_disk(folder: str | os.PathLike) -> int:
    """Bytes an unprivileged user can still write in ``folder``'s file system."""
    try:
        st = os.statvfs(folder)
    except OSError:
        return 1 << 62
    return st.f_bavail * st.f_frsize


def require_memory(nbytes: float, what: str) -> None:
    """Refuse ``what`` if its estimate ``nbytes`` exceeds HEADROOM of the available memory."""
    avail = available_memory()
    if not math.isfinite(nbytes) or nbytes > HEADROOM * avail:
        raise ResourceError(f"{what} needs about {format_bytes(nbytes)} of memory; "
                            f"{format_bytes(avail)} available: reduce the request")


def require_disk(folder: str | os.PathLike, nbytes: float, what: str) -> None:
    """Refuse ``what`` if ``nbytes`` (plus 1 MB of file overhead) exceeds the free disk space."""
    avail = available_disk(folder)
    if not math.isfinite(nbytes) or nbytes + 1_000_000 > avail:
        raise ResourceError(f"{what} needs about {format_bytes(nbytes)} of disk; "
                            f"{format_bytes(avail)} free in {folder}")


# ---------------------------------------------------------------- per-stage guards
#: peak bytes per grain of a preparation (module table), 2D and 3D: whole 10^5-grain runs peaked
#: at 2070 and 7970 B per grain beyond the interpreter (docs/dem.md), plus about 10 %
PREPARE_BYTES_PER_GRAIN = {2: 2300, 3: 8800}


def prepare_bytes(grains: int, dim: int) -> float:
    """Estimated peak memory (B) of preparing ``grains`` grains in ``dim`` dimensions."""
    return float(grains) * PREPARE_BYTES_PER_GRAIN[3 if dim >= 3 else 2]


def check_prepare(grains: int, dim: int) -> None:
    """prepare-packing of ``grains`` grains in ``dim`` dimensions."""
    require_memory(prepare_bytes(grains, dim), f"a packing of {grains} grains")


def check_chain(n_balls: int) -> None:
    """A chain of ``n_balls`` balls."""
    require_memory(200.0 * float(n_balls), f"a chain of {n_balls} balls")


def check_lattice(rows: int, width: int) -> None:
    """A triangular lattice of ``rows`` x ``width`` balls."""
    require_memory(600.0 * float(rows) * float(width), f"a lattice of {rows} x {width} balls")


#: bytes per ball of the chain's exact wall force (granwave.theory.chain_wall_force): its modes,
#: wave numbers, signs and weights, and their temporaries (about eight arrays of N doubles)
CHAIN_FORCE_BYTES_PER_BALL = 80


def check_chain_force(n_balls: int, samples: int) -> float:
    """The exact wall force of a chain of ``n_balls`` balls at ``samples`` times: refused when
    its arrays cannot fit (before any is allocated); returns its predicted seconds (O(samples N))."""
    require_memory(CHAIN_FORCE_BYTES_PER_BALL * float(n_balls) + 3 * DOUBLE * float(1 << 21),
                   f"the exact wall force of a chain of {n_balls} balls")
    return predicted_seconds("chain-modal-sum", float(n_balls), float(samples), threads=1)


def check_linearize(n_grains: int, n_contacts: int, dim: int, friction: float) -> None:
    """Stiffness matrix of a packing: (2 p)^2 block entries per contact."""
    p = dim + (dim * (dim - 1) // 2 if friction > 0 else 0)
    need = 50.0 * (2 * p) ** 2 * float(n_contacts) + 100.0 * float(n_grains)
    require_memory(need, f"the stiffness matrix of {n_contacts} contacts")


def check_eigensolve(n_dof: int, k: int | None = None, tridiagonal: bool = False) -> None:
    """Eigensolve of ``n_dof`` dofs: dense, tridiagonal (chains) or the ``k`` lowest modes."""
    n = float(n_dof)
    if k is not None and k < n_dof - 1:
        need, how = DOUBLE * n * (2 * (2 * k + 1) + k), f"the {k} lowest modes"
    elif tridiagonal:
        need, how = DOUBLE * n * n, "all modes (tridiagonal)"
    else:
        need, how = 4 * DOUBLE * n * n, "a dense eigensolve"
    require_memory(need, f"{how} of {n_dof} dofs")


def check_propagate(n_dof: int, samples: int, snapshots: int = 0) -> None:
    """A signal of ``samples`` samples and ``snapshots`` displacement fields of ``n_dof`` dofs."""
    need = 4 * DOUBLE * float(samples) + 3 * DOUBLE * float(snapshots) * float(n_dof)
    shots = f" and {snapshots} snapshots of {n_dof} dofs" if snapshots else ""
    require_memory(need, f"a signal of {samples} samples{shots}")


def check_time_domain(n_dof: int, n_entries: int, samples: int, snapshots: int = 0) -> None:
    """The time-domain integration of ``n_dof`` dofs with ``n_entries`` stiffness entries,
    recording ``samples`` samples and ``snapshots`` displacement fields."""
    need = (11 * DOUBLE * float(n_dof) + 40.0 * float(n_entries) + 4 * DOUBLE * float(samples)
            + 3 * DOUBLE * float(snapshots) * float(n_dof))
    require_memory(need, f"the time-domain run of {n_dof} dofs ({n_entries} stiffness entries)")


# ---------------------------------------------------------------- run time
#: Longest predicted run (s) that starts without an explicit ``--allow-long-run``: one day.
RUN_LIMIT = 86400.0

#: Seconds of one core per unit of work, (per-unit cost, fixed cost per step), the one home of
#: the run-time model. Measured on a 2-core AMD EPYC shared with other jobs (load ~3 per core,
#: about 3x an idle core), so that the prediction errs long: the time domain on 16- and 3600-
#: grain frictional lattices (4.2-5.2e-9 s per stored entry of D per step; 3e-6 s per step of a
#: 16-dof system), the DEM pulse on a 20-grain packing (2.6e-4 s per step, kicked run and
#: baseline counted apart).
SECONDS_PER_UNIT = {
    "time-domain": (6e-9, 3e-6),   # per stored entry of D per step, per step
    "dem-pulse": (3e-6, 2e-4),     # per grain per step, per step
    # the chain's exact modal sum (granwave.theory.chain_wall_force): per (time, mode) pair;
    # measured 6e-8 (N = 1e5) to 1.2e-7 s (N = 1e4) with 800 times on the machine above
    "chain-modal-sum": (1.2e-7, 0.0),
    # a preparation's DEM step: 1.5e7 grain-steps/s on one idle core (docs/dem.md), per step
    "dem-prepare": (6.7e-8, 1e-5),
}

#: Fewest steps a preparation takes (40 grains: 4300 steps at p = 1e-2, 15800 at 1e-4), and the
#: seconds of writing its file: a lower bound of one seed's cost under ``--seeds``.
PREPARE_MIN_STEPS, PREPARE_FILE_SECONDS = 1000, 0.01


def prepare_seconds(grains: int) -> float:
    """A lower bound of the seconds of preparing (and writing) one packing of ``grains`` grains
    on one thread."""
    return predicted_seconds("dem-prepare", float(grains), PREPARE_MIN_STEPS, threads=1) + PREPARE_FILE_SECONDS

_run_limit = [RUN_LIMIT]


def format_duration(seconds: float) -> str:
    """A duration in the largest fitting unit: 45 s, 12 min, 3.5 h, 2.1 days, 3.2e+292 years."""
    s = float(seconds)
    if not math.isfinite(s):
        return "forever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= size:
            x = s / size
            text = f"{x:.2g}" if x < 100 else f"{x:.0f}" if x < 1e6 else f"{x:.2g}"
            return "1 day" if text == "1" and unit == "days" else f"{text} {unit}"
    return f"{s:.0f} s"


def predicted_seconds(kind: str, units: float, steps: float, threads: int | None = None) -> float:
    """Predicted wall time of ``steps`` steps over ``units`` (stored entries of D for
    "time-domain", grains for "dem-pulse") with :data:`SECONDS_PER_UNIT`, on ``threads``
    threads at half parallel efficiency (default: numba's thread count)."""
    per_unit, per_step = SECONDS_PER_UNIT[kind]
    if threads is None:
        try:
            import numba

            threads = numba.get_num_threads()
        except Exception:  # noqa: BLE001 - no numba: one thread
            threads = 1
    speedup = max(1.0, 0.5 * float(threads)) if units > 10_000 else 1.0
    return float(steps) * (float(units) * per_unit / speedup + per_step)


def run_time_limit() -> float:
    """The current limit (s) above which :func:`check_run_time` refuses a run."""
    return _run_limit[0]


class allow_long_run:  # noqa: N801 - used like a function: ``with allow_long_run():``
    """Context manager lifting :data:`RUN_LIMIT` (``limit``: another limit, s) for the runs
    started inside it: what ``--allow-long-run`` does on the command line."""

    def __init__(self, limit: float = math.inf):
        self.limit = float(limit)

    def __enter__(self):
        self.saved = _run_limit[0]
        _run_limit[0] = self.limit
        return self

    def __exit__(self, *exc):
        _run_limit[0] = self.saved
        return False


def check_run_time(seconds: float, what: str, progress=None) -> float:
    """Refuse ``what`` if it is predicted to take ``seconds`` > :func:`run_time_limit`
    (ResourceError, one line naming the estimate and ``--allow-long-run``); tell ``progress``
    the estimate of a run longer than a minute. Returns ``seconds``."""
    limit = run_time_limit()
    if not seconds <= limit:
        raise ResourceError(f"{what} is predicted to take about {format_duration(seconds)} on this "
                            f"machine, over the {format_duration(limit)} limit: shorten it, or rerun "
                            "with --allow-long-run to start it anyway")
    if progress is not None and seconds > 60.0:
        progress(f"{what}: predicted to take about {format_duration(seconds)}")
    return seconds
