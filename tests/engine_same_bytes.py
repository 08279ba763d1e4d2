"""Shared check of the tests of contact sub-models: a packing's bytes are the same from the
one-thread pair loop, the parallel passes on one thread and (where numba has two) the passes
on two threads, with the parallel threshold lowered so that small packings take the passes
(as tests/test_parallel.py does)."""

from __future__ import annotations

import numpy as np


def packing_bytes(p, *extra_contact_fields: str) -> bytes:
    """The arrays that carry a packing's result (positions, box, contacts' keys, overlaps and
    forces, and ``extra_contact_fields`` of its contacts)."""
    c = p.contacts
    arrays = [p.position, p.box, c.i, c.j, c.overlap, c.force_normal, c.force_tangential]
    arrays += [getattr(c, name) for name in extra_contact_fields]
    return b"".join(np.ascontiguousarray(x).tobytes() for x in arrays)


def assert_same_bytes_loop_passes_threads(monkeypatch, params, *extra_contact_fields: str) -> None:
    import numba

    from granwave import threads
    from granwave.dem import kernels as K
    from granwave.dem import serial
    from granwave.dem.protocol import prepare_packing

    monkeypatch.setattr(K, "MIN_PARALLEL_GRAINS", 0)
    keep = numba.get_num_threads()
    try:
        threads.set_threads(1)
        one = prepare_packing(params)
        with monkeypatch.context() as m:
            m.setattr(serial, "run_chunk", K.run_chunk)
            passes = prepare_packing(params)
        assert one.attrs["steps"] == passes.attrs["steps"] > 1000
        want = packing_bytes(one, *extra_contact_fields)
        assert packing_bytes(passes, *extra_contact_fields) == want
        if numba.config.NUMBA_NUM_THREADS >= 2:
            threads.set_threads(2)
            two = prepare_packing(params)
            assert two.attrs["steps"] == one.attrs["steps"]
            assert packing_bytes(two, *extra_contact_fields) == want
    finally:
        numba.set_num_threads(keep)
