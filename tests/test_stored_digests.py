"""Stored digests pin the bits of tiny Hertz-Mindlin runs, on 1 and 2 threads.

Each case is made through the library's API (granwave.api) with a fixed seed (two of them also
through the command line, read back from their files); its digest is the sha256 of the
arrays that carry its result (positions, radii, masses, box and contact forces of a packing;
the matrices and vectors of a linear system; the spectrum and projections of the modes; the
time and force arrays of a signal), not of whole HDF5 files, which also hold dates,
revisions and the machine. Every run must give the digests stored in
tests/data/digests.json, on one thread and on two (the parallel passes forced on these small
systems by lowering their thresholds, as tests/test_parallel.py does).

A change of these bits is a change of results. When it is intended (a new rule, a fixed
bug, a changed default), write a decision record (docs/decisions/NNNN-title.md: what changed,
why, and that files made before are records of the older code), then regenerate the file:

    python tests/test_stored_digests.py --update

recomputes every case, prints the cases whose digest changed (old -> new) and rewrites
tests/data/digests.json; without ``--update`` it prints the comparison and writes nothing.

Two groups, by what decides their bits besides granwave:

- ``portable``: the packings (2D and 3D frictional, 2D frictionless, 2D mean-flow
  compaction) and the DEM pulses (normal and shear source, 2D and 3D). numba compiles the
  kernels without fast-math (no fused multiply-add, no reordered sums) and they use only
  + - * / and sqrt; numpy's CPU-dispatched loops are kept out of the results
  (docs/decisions/0003-portable-bits.md). The same bits came out with numba's code for a
  generic x86-64 and for Haswell and with numpy's dispatched loops off (tests/data/README.md
  says what was checked where).
- ``openblas_haswell``: the linear results of the 2D frictional packing (linearize without
  and with prestress, the time-domain signal, the modes and the modal signal). Their last
  bits depend on OpenBLAS's kernels, which it picks by CPU (linearize's einsum calls BLAS;
  the eigensolve is LAPACK), so they are computed in a child process with OpenBLAS's Haswell
  kernels (OPENBLAS_CORETYPE=Haswell, one BLAS thread), which every AVX2 or AVX-512 CPU runs;
  skipped on a CPU without AVX2 and FMA or where OpenBLAS does not take the setting, and
  skipped where numpy, scipy or OpenBLAS are other versions than those the digests were
  stored with (``openblas_haswell_versions``): a new BLAS may round differently without
  any change in granwave.

3D frictional linear results are not pinned (the default for their free spins was being
changed when this file was made); add them to :func:`linear` once it has settled.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

STORE = Path(__file__).resolve().parent / "data" / "digests.json"

#: The tiny packings (PrepareParams fields): 5000-15000 steps each.
PACKINGS = {
    "packing_2d_frictional": dict(grains=40, seed=1, tol=1e-8),
    "packing_3d_frictional": dict(dim=3, grains=30, seed=2, tol=1e-8, friction=0.5),
    "packing_2d_frictionless": dict(grains=40, seed=3, tol=1e-8, friction=0.0),
    "packing_2d_mean_flow": dict(grains=40, seed=4, tol=1e-8, aspect=3.0, compaction="mean-flow",
                                 reference_height=2.0),
}
#: The DEM pulses (PropagateParams fields) on the 2D and 3D frictional packings.
PULSE = dict(method="dem", t_max=6.0, samples=31)
#: The linear signals of the 2D frictional packing; a given dt keeps the Lanczos estimate of
#: omega_max (BLAS) out of the time-domain bits.
LINEAR_SIGNAL = dict(t_max=6.0, samples=31)
TIME_DT = 0.05
#: OpenBLAS's kernels for the linear group, and the CPU flags they need.
BLAS_CORE, BLAS_FLAGS = "Haswell", ("avx2", "fma")
#: What the stored file is, written into it.
ABOUT = ("sha256 of the result arrays of the tiny cases of tests/test_stored_digests.py; an intended "
         "change needs a decision record, then: python tests/test_stored_digests.py --update")


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())  # the layout too, not only the bytes
        h.update(a.tobytes())
    return h.hexdigest()


def packing_digest(p) -> str:
    c = p.contacts
    return _digest(p.position, p.radius, p.mass, p.inertia, p.box, c.i, c.j, c.overlap,
                   c.force_normal, c.force_tangential)


def linear_digest(s) -> str:
    d = s.stiffness.tocsr()
    return _digest(d.data, d.indices, d.indptr, s.mass, s.dof_grain, s.dof_axis, s.source_velocity,
                   s.source_displacement, s.detector,
                   *(a for a in (s.shear_source_velocity, s.shear_detector) if a is not None))


def modes_digest(m) -> str:
    return _digest(m.omega2, m.amplitude_A, m.amplitude_B, m.coupling)


def signal_digest(s) -> str:
    return _digest(s.time, s.force)


class _Threads:
    """``threads`` threads, with the parallel passes on at any size when more than one (the
    DEM's and the time domain's thresholds lowered, restored on exit)."""

    def __init__(self, threads: int):
        self.threads = threads

    def __enter__(self):
        from granwave.dem import kernels as K
        from granwave.linear import propagate as LP

        self.saved = K.MIN_PARALLEL_GRAINS, LP.MIN_PARALLEL_ROWS
        if self.threads > 1:
            K.MIN_PARALLEL_GRAINS, LP.MIN_PARALLEL_ROWS = 0, 0
        return self

    def __exit__(self, *exc):
        from granwave.dem import kernels as K
        from granwave.linear import propagate as LP

        K.MIN_PARALLEL_GRAINS, LP.MIN_PARALLEL_ROWS = self.saved


def portable(threads: int = 1) -> dict:
    """{case: sha256} of the packings and DEM pulses at ``threads`` threads."""
    from granwave import api

    out = {}
    with _Threads(threads):
        packings = {name: api.prepare_packing(threads=threads, **kw) for name, kw in PACKINGS.items()}
        out.update({name: packing_digest(p) for name, p in packings.items()})
        for dim in (2, 3):
            for source in ("normal", "shear"):
                sig = api.propagate(packings[f"packing_{dim}d_frictional"], threads=threads,
                                    source_kind=source, **PULSE)
                out[f"dem_pulse_{dim}d_{source}"] = signal_digest(sig)
    return out


def linear(threads: int = 1) -> dict:
    """{case: sha256} of the linear results of the 2D frictional packing at ``threads``
    threads (their bits depend on OpenBLAS's kernels: see :func:`linear_in_child`)."""
    import warnings

    from granwave import api

    out = {}
    with _Threads(threads):
        packing = api.prepare_packing(threads=threads, **PACKINGS["packing_2d_frictional"])
        for prestress in (False, True):
            tag = "prestress" if prestress else "no_prestress"
            system = api.linearize(packing, threads=threads, prestress=prestress)
            out[f"linear_2d_{tag}"] = linear_digest(system)
            sig = api.propagate(system, threads=threads, method="time", dt=TIME_DT, **LINEAR_SIGNAL)
            out[f"time_signal_2d_{tag}"] = signal_digest(sig)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a tiny system: the aliasing note
                modes = api.eigensolve(system, threads=threads)
                sig = api.propagate(modes, threads=threads, **LINEAR_SIGNAL)
            out[f"modes_2d_{tag}"] = modes_digest(modes)
            out[f"modal_signal_2d_{tag}"] = signal_digest(sig)
    return out


def blas_core() -> str:
    """The core OpenBLAS picked its kernels for ('?': no OpenBLAS found)."""
    from threadpoolctl import threadpool_info

    import scipy.linalg  # noqa: F401  (loads scipy's BLAS too)

    cores = {str(lib.get("architecture")) for lib in threadpool_info() if lib.get("internal_api") == "openblas"}
    return cores.pop() if len(cores) == 1 else "?" if not cores else "+".join(sorted(cores))


def library_versions() -> dict:
    """The versions that decide the linear group's last bits besides granwave."""
    from threadpoolctl import threadpool_info

    import scipy
    import scipy.linalg  # noqa: F401  (loads scipy's BLAS too)

    blas = sorted({str(lib.get("version")) for lib in threadpool_info() if lib.get("internal_api") == "openblas"})
    return dict(numpy=np.__version__, scipy=scipy.__version__, openblas="+".join(blas))


def blas_core_unavailable() -> str | None:
    """Why OpenBLAS's Haswell kernels cannot run here, or None."""
    try:
        flags = next((line.split(":", 1)[1].split() for line in open("/proc/cpuinfo") if line.startswith("flags")), [])
    except OSError:
        flags = []
    missing = [f for f in BLAS_FLAGS if f not in flags]
    return f"this CPU lacks {', '.join(missing)} (OpenBLAS's {BLAS_CORE} kernels)" if missing else None


CHILD = """
import json, sys
sys.path[:0] = [{tests!r}, {root!r}]  # this checkout's granwave, whatever is installed
import test_stored_digests as T
print(json.dumps(dict(core=T.blas_core(), versions=T.library_versions(),
                      digests={{t: T.linear(t) for t in {threads!r}}})))
"""


def linear_in_child(threads=(1,)) -> tuple[str, dict, dict]:
    """(OpenBLAS's core, library versions, {threads: {case: sha256}}) of :func:`linear`, run in
    a child process with OpenBLAS's Haswell kernels on one BLAS thread."""
    env = dict(os.environ, OPENBLAS_CORETYPE=BLAS_CORE, OPENBLAS_NUM_THREADS="1")
    here = Path(__file__).resolve().parent
    code = CHILD.format(tests=str(here), root=str(here.parent), threads=tuple(threads))
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=1800)
    assert run.returncode == 0, run.stderr[-3000:]
    out = json.loads(run.stdout.strip().splitlines()[-1])
    return out["core"], out["versions"], {int(t): d for t, d in out["digests"].items()}


def stored() -> dict:
    return json.loads(STORE.read_text())


def _changed(got: dict, want: dict) -> list[str]:
    return [f"{k}: {want.get(k, 'absent')[:16]} -> {got.get(k, 'absent')[:16]}"
            for k in sorted(set(got) | set(want)) if got.get(k) != want.get(k)]


def _explain(group: str, threads: int, changed: list[str]) -> str:
    return (f"{group} digests at {threads} thread(s) differ from tests/data/digests.json:\n  "
            + "\n  ".join(changed) + "\nIf the change of bits is intended, write a decision record and run "
            "`python tests/test_stored_digests.py --update` (this file's docstring).")


two_threads = pytest.mark.skipif(__import__("numba").config.NUMBA_NUM_THREADS < 2, reason="needs 2 threads")


@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=two_threads)])
def test_packings_and_dem_pulses_give_the_stored_bits(threads):
    changed = _changed(portable(threads), stored()["portable"])
    assert not changed, _explain("portable", threads, changed)


def test_linear_results_give_the_stored_bits_with_openblas_haswell_kernels():
    why = blas_core_unavailable()
    if why:
        pytest.skip(why)
    threads = (1, 2) if __import__("numba").config.NUMBA_NUM_THREADS >= 2 else (1,)
    core, versions, by_threads = linear_in_child(threads)
    if core != BLAS_CORE:
        pytest.skip(f"OpenBLAS ran its {core} kernels, not {BLAS_CORE}'s (OPENBLAS_CORETYPE not taken)")
    want_versions = stored().get(f"openblas_{BLAS_CORE.lower()}_versions")
    if versions != want_versions:
        pytest.skip(f"the linear digests were stored with {want_versions}, this machine has {versions}")
    for t, got in by_threads.items():
        changed = _changed(got, stored()[f"openblas_{BLAS_CORE.lower()}"])
        assert not changed, _explain(f"linear (OpenBLAS {BLAS_CORE})", t, changed)


def test_the_command_lines_files_hold_the_stored_bits(tmp_path):
    """prepare-packing and a shear DEM pulse through the command line: the arrays read back
    from their files give the API's stored digests."""
    from click.testing import CliRunner

    from granwave.cli import main as cli
    from granwave.io.files import read_packing, read_signal

    packing, signal = tmp_path / "packing.h5", tmp_path / "signal.h5"
    kw = PACKINGS["packing_2d_frictional"]
    run = CliRunner().invoke(cli, ["prepare-packing", "--grains", str(kw["grains"]), "--seed", str(kw["seed"]),
                                   "--tol", str(kw["tol"]), "-o", str(packing)])
    assert run.exit_code == 0, run.output
    run = CliRunner().invoke(cli, ["propagate", str(packing), "--method", "dem", "--source", "shear", "-q",
                                   "--t-max", str(PULSE["t_max"]), "--samples", str(PULSE["samples"]),
                                   "-o", str(signal)])
    assert run.exit_code == 0, run.output
    want = stored()["portable"]
    assert packing_digest(read_packing(packing)) == want["packing_2d_frictional"]
    assert signal_digest(read_signal(signal)) == want["dem_pulse_2d_shear"]


def main(update: bool) -> int:
    """Recompute every case on one thread, print what changed, and with ``update`` rewrite
    the stored file (the linear group only where OpenBLAS's Haswell kernels ran)."""
    old = stored() if STORE.exists() else {}
    new = dict(old, about=ABOUT)
    new["portable"] = portable(1)
    key = f"openblas_{BLAS_CORE.lower()}"
    why = blas_core_unavailable()
    if why is None:
        core, versions, by_threads = linear_in_child((1,))
        if core == BLAS_CORE:
            new[key] = by_threads[1]
            new[f"{key}_versions"] = versions
        else:
            why = f"OpenBLAS ran its {core} kernels"
    if why is not None:
        print(f"{key}: not recomputed ({why}); kept as stored")
    changes = 0
    for group in ("portable", key):
        changed = _changed(new.get(group, {}), old.get(group, {}))
        changes += len(changed)
        print(f"{group}: " + ("unchanged" if not changed else f"{len(changed)} changed\n  " + "\n  ".join(changed)))
    if update and (changes or any(old.get(k) != new.get(k) for k in ("about", f"{key}_versions"))):
        STORE.write_text(json.dumps(new, indent=1, sort_keys=True) + "\n")
        print(f"wrote {STORE}")
    return 0 if not changes or update else 1


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # this checkout's granwave
    if set(sys.argv[1:]) - {"--update"}:
        sys.exit("usage: python tests/test_stored_digests.py [--update]")
    sys.exit(main("--update" in sys.argv[1:]))
