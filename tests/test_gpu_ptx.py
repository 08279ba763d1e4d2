"""Every GPU kernel compiles for a real GPU (PTX for compute capability 9.0, an H100).

The CUDA simulator runs kernels as Python and cannot tell whether they would compile; this
test compiles each kernel of granwave.gpu with the CUDA compiler (libNVVM) for 2D and 3D,
with and without friction's rotation columns. It needs no GPU, only libNVVM (the gpu extra's
CUDA wheels provide it); without libNVVM it is skipped, saying why (docs/gpu.md).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

if os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0"):
    pytest.skip("the CUDA simulator is on: no compiler to test", allow_module_level=True)

cuda = pytest.importorskip("numba.cuda")
import numba  # noqa: E402


@pytest.fixture(autouse=True)
def _no_device(monkeypatch):
    """Device functions called by a kernel are compiled for the current device's compute
    capability; without a GPU there is none: give them cc 9.0, as the kernels."""
    import types

    from numba.cuda import dispatcher

    if hasattr(dispatcher, "get_current_device"):
        fake = types.SimpleNamespace(compute_capability=(9, 0))
        monkeypatch.setattr(dispatcher, "get_current_device", lambda: fake)


def _nvvm_or_skip():
    def probe(x):
        x[0] = 1.0

    try:
        cuda.compile_ptx(probe, (numba.float64[::1],), cc=(9, 0))
    except Exception as exc:  # noqa: BLE001 - NvvmSupportError and kin, by version
        pytest.skip(f"libNVVM not available, cannot compile for a GPU ({type(exc).__name__}: "
                    f"{str(exc).splitlines()[0] if str(exc) else ''}); pip install 'granwave[gpu]'")


def _types(*values):
    return tuple(numba.typeof(v) for v in values)


def _has_couple(ptx: str) -> bool:
    """Whether a kernel's PTX holds the rolling couple (its frame threshold, a literal of the
    couple's code): the couple is a run-time branch of the pair kernel, one specialization with
    and without rolling resistance, so compiling it here compiles the couple too."""
    import struct

    from granwave.contact_models import rolling

    return struct.pack(">d", rolling.FRAME_EPSILON).hex().upper() in ptx.upper()


@pytest.mark.parametrize("dim,rot", [(2, 1), (2, 0), (3, 3)])
def test_gpu_dem_kernels_compile_to_ptx(dim, rot):
    _nvvm_or_skip()
    from granwave.gpu import dem as G

    n, m = 4, 6
    f2 = lambda c: np.zeros((n, c))  # noqa: E731
    p2 = lambda c: np.zeros((m, c))  # noqa: E731
    v = np.zeros(n)
    i64 = np.zeros(m, np.int64)
    from granwave.dem import layout

    fp = np.zeros(1, layout.PARAMS)  # the records, as the engine uploads them (one-element arrays)
    ps = np.zeros(1, layout.PISTON)
    ctl = np.zeros(10, np.int64)
    sigs = {
        G.kick_drift: _types(f2(dim), f2(dim), f2(dim), f2(rot), f2(rot), np.zeros(dim - 1), f2(dim),
                             ps, 1.0, v, v, ctl),
        G.pair_forces: _types(f2(dim), f2(dim), f2(rot), v, v, v, np.zeros(dim - 1), i64, i64, ctl,
                              p2(dim), np.zeros(m), fp, p2(3), p2(max(rot, 1)),
                              p2(max(rot, 1)), np.zeros(m)),
        G.grain_forces: _types(f2(dim), f2(dim), f2(dim), f2(rot), f2(rot), v, v, v,
                               np.zeros(n + 1, np.int64), i64, p2(3), p2(max(rot, 1)), p2(max(rot, 1)),
                               np.zeros((2 * n, dim)), np.zeros(2 * n), ps, fp, v, v, v,
                               v, ctl, np.zeros(3), np.zeros((dim + 1, 5))),
        G.step_partials: _types(v, v, v, v, v, v, np.zeros(m), ctl, np.zeros((3, 7))),
        G.finish: _types(np.zeros((3, 7)), ps, fp, np.zeros(3), np.zeros(7), ctl),
        G.measure_kernel: _types(f2(dim), f2(dim), f2(rot), f2(rot), v, v, v, np.zeros(5)),
    }
    assert set(sigs) == set(G.KERNELS)
    from granwave.gpu import pulse as P

    s8 = np.zeros(m, np.int8)
    sigs.update({
        P.classify_pairs: _types(dim, v, i64, i64, 1, p2(dim), np.zeros(m), fp, s8, False),
        P.classify_walls: _types(dim, v, np.zeros((2 * n, dim)), np.zeros(2 * n), fp, np.zeros(2 * n, np.int8),
                                 False),
        P.track_displacement: _types(f2(dim), f2(dim), np.zeros(dim - 1), v),
    })
    assert set(P.KERNELS) <= set(sigs)
    from granwave.gpu import neighbours as NB

    i2 = np.zeros((n, 2), np.int64)
    i2p = np.zeros((n + 1, 2), np.int64)
    iv = np.zeros(n, np.int64)
    ip = np.zeros(n + 1, np.int64)
    lat = np.zeros(dim - 1)
    sigs.update({
        NB.rb_trigger: _types(np.zeros(7), fp, ps, lat, ctl, 1),
        NB.rb_cell_count: _types(f2(dim), lat, ps, ctl, iv, i2),
        NB.rb_cell_fill: _types(ctl, iv, i2, i2p, iv),
        NB.rb_count: _types(f2(dim), v, lat, fp, ctl, iv, i2p, iv, i64, i2),
        NB.rb_fill: _types(f2(dim), v, lat, fp, ctl, iv, i2p, iv, i2p, i64, 1),
        NB.rb_merge: _types(ctl, i2p, i64, ip, i64, p2(dim), np.zeros(m), i64, i64, p2(dim), np.zeros(m), i64),
        NB.rb_commit: _types(ctl, i2p, f2(dim), f2(dim), i64, i64, p2(dim), np.zeros(m), i64, i64, i64, p2(dim),
                             np.zeros(m), ip, ip, i64, i2),
        NB.scan_partials: _types(ctl, i2, i2),
        NB.scan_offsets: _types(ctl, i2),
        NB.scan_apply: _types(ctl, i2, i2, i2p),
        NB.rb_small: _types(np.zeros(7), fp, ps, lat, f2(dim), v, f2(dim), ctl, iv, i2, i2p, iv,
                            i2, i2p, i64, ip, i64, i64, p2(dim), np.zeros(m), i64, i64, p2(dim), np.zeros(m), i64,
                            ip, i64),
    })
    assert set(NB.KERNELS) <= set(sigs)
    from granwave.gpu import mean_flow as MF

    ns = 5
    sigs.update({
        MF.slab_bin: _types(f2(dim), np.zeros(3), iv, np.zeros(ns, np.int64), np.zeros(ns, np.int64), ctl),
        MF.slab_sums: _types(f2(dim), v, fp, np.zeros(3), iv, np.zeros(ns, np.int64),
                             np.zeros(ns, np.int64), np.zeros((dim + 1, ns)), ctl),
    })
    assert set(MF.KERNELS) <= set(sigs)
    for kernel, sig in sigs.items():
        ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=(9, 0))
        assert ".target sm_90" in ptx
        assert "fma.rn" not in ptx, kernel.py_func.__name__  # products and sums rounded as on the CPU (gpu.load_cuda)
        if kernel is G.pair_forces:
            assert _has_couple(ptx)


def test_gpu_linear_kernels_compile_to_ptx():
    _nvvm_or_skip()
    from granwave.gpu import linear as L

    v = np.zeros(5)
    sigs = {
        L.verlet_step: _types(np.zeros(6, np.int64), np.zeros(9, np.int32), np.zeros(9), v, v, v, v, v, v,
                              1.0, 1.0, True),
        L.sample_partials: _types(v, v, v, v, v, np.zeros((3, 4))),
        L.sample_sums: _types(np.zeros((3, 4)), np.zeros((3, 4)), 1),
    }
    assert set(sigs) == set(L.KERNELS)
    for kernel, sig in sigs.items():
        ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=(9, 0))
        assert ".target sm_90" in ptx
        assert "fma.rn" not in ptx, kernel.py_func.__name__  # products and sums rounded as on the CPU (gpu.load_cuda)


@pytest.mark.parametrize("dim,rot", [(2, 1), (2, 0), (3, 3)])
def test_gpu_batch_kernels_compile_to_ptx(dim, rot):
    """The kernels of ensembles per launch (granwave.gpu.batch, and the segmented rebuild of
    granwave.gpu.batch_rebuild): concatenated grains and pairs, one row per packing of pistons,
    parameters, rates, slabs, reductions and control words."""
    _nvvm_or_skip()
    from granwave.dem import layout
    from granwave.gpu import batch as B
    from granwave.gpu import dem as G

    n, m, k, ns = 6, 8, 2, 5
    f2 = lambda c: np.zeros((n, c))  # noqa: E731
    p2 = lambda c: np.zeros((m, c))  # noqa: E731
    v = np.zeros(n)
    i64 = np.zeros(m, np.int64)
    gi = np.zeros(n, np.int64)
    off = np.zeros(k + 1, np.int64)
    kv = np.zeros(k, np.int64)
    fps = np.zeros(k, layout.PARAMS)
    pss = np.zeros(k, layout.PISTON)
    ctl = np.zeros((k, B.N_CTL_BATCH), np.int64)
    lat = np.zeros((k, dim - 1))
    mf = np.zeros((k, 3))
    lo = np.zeros((k, ns), np.int64)
    slabs = np.zeros((k, dim + 1, ns))
    r1 = max(rot, 1)
    sigs = {
        B.kick_drift_batch: _types(f2(dim), f2(dim), f2(dim), f2(rot), f2(rot), lat, f2(dim), pss, fps, v, v, ctl,
                                   gi),
        B.pair_forces_batch: _types(f2(dim), f2(dim), f2(rot), v, v, v, lat, i64, i64, ctl, p2(dim), np.zeros(m),
                                    fps, p2(3), p2(r1), p2(r1), np.zeros(m), off, off, i64),
        B.slab_bin_batch: _types(f2(dim), mf, kv, fps, gi, lo, lo, kv, ctl, off, gi),
        B.slab_sums_batch: _types(f2(dim), v, fps, mf, kv, gi, lo, lo, slabs, kv, ctl, off),
        B.grain_forces_batch: _types(f2(dim), f2(dim), f2(dim), f2(rot), f2(rot), v, v, v,
                                     np.zeros(n + k, np.int64), np.zeros(2 * m, np.int64), p2(3), p2(r1), p2(r1),
                                     np.zeros((2 * n, dim)), np.zeros(2 * n), pss, fps, v, v, v, v, ctl, mf, kv,
                                     slabs, kv, off, off, gi),
        B.step_partials_batch: _types(v, v, v, v, v, v, np.zeros(m), ctl, np.zeros((k, 3, G.N_RED)), off, off),
        B.finish_batch: _types(np.zeros((k, 3, G.N_RED)), pss, fps, mf, kv, np.zeros((k, G.N_RED)), ctl),
        B.rb_small_batch: _types(np.zeros((k, G.N_RED)), fps, pss, lat, f2(dim), v, f2(dim), ctl, gi,
                                 np.zeros((4, 2), np.int64), np.zeros((4 + k, 2), np.int64), gi,
                                 np.zeros((n, 2), np.int64), np.zeros((n + k, 2), np.int64), np.zeros(2 * m, np.int64),
                                 np.zeros(n + k, np.int64), i64, i64, p2(dim), np.zeros(m), i64, i64, p2(dim),
                                 np.zeros(m), np.zeros(2 * m, np.int64), np.zeros(n + k, np.int64),
                                 np.zeros(2 * m, np.int64), off, off, off, kv),
        B.measure_batch: _types(f2(dim), f2(dim), f2(rot), f2(rot), v, v, v, np.zeros((k, 5)), off),
    }
    assert set(sigs) == set(B.KERNELS)
    from granwave.gpu import batch_rebuild as BR

    # the segmented rebuild of the large packings (batch-long cells and sums; ctl per packing)
    i2 = np.zeros((n, 2), np.int64)
    c2 = np.zeros((4, 2), np.int64)
    c2p = np.zeros((5, 2), np.int64)
    g2p = np.zeros((n + 1, 2), np.int64)
    gpk = np.zeros((n + k, 2), np.int64)
    ipk = np.zeros(n + k, np.int64)
    i2m = np.zeros(2 * m, np.int64)
    any_ctl = np.zeros(B.N_CTL, np.int64)
    sigs_rb = {
        BR.rb_trigger_batch: _types(np.zeros((k, G.N_RED)), fps, pss, lat, ctl, off, kv, any_ctl),
        BR.rb_cell_count_batch: _types(f2(dim), lat, pss, ctl, gi, c2, off, gi),
        BR.rb_cell_fill_batch: _types(ctl, gi, c2, c2p, gi, off, off, gi),
        BR.rb_count_batch: _types(f2(dim), v, lat, fps, ctl, gi, c2p, gi, i2m, i2, off, off, gi),
        BR.rb_fill_batch: _types(f2(dim), v, lat, fps, ctl, gi, c2p, gi, g2p, gpk, i2m, off, off, off, gi),
        BR.rb_merge_batch: _types(ctl, gpk, i2m, ipk, i64, p2(dim), np.zeros(m), i64, i64, p2(dim), np.zeros(m), i2m,
                                  off, off, gi),
        BR.rb_commit_batch: _types(ctl, gpk, f2(dim), f2(dim), i64, i64, p2(dim), np.zeros(m), i2m, i64, i64,
                                   p2(dim), np.zeros(m), ipk, ipk, i2m, c2, off, off, off, any_ctl),
    }
    assert set(sigs_rb) == set(BR.KERNELS)
    sigs.update(sigs_rb)
    for kernel, sig in sigs.items():
        ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=(9, 0))
        assert ".target sm_90" in ptx
        assert "fma.rn" not in ptx, kernel.py_func.__name__  # products and sums rounded as on the CPU (gpu.load_cuda)
        if kernel is B.pair_forces_batch:
            assert _has_couple(ptx)
