"""The nonlinear DEM pulse on one GPU: :func:`pulse_samples_gpu`, the device twin of
:func:`granwave.dem.pulse_kernels.pulse_samples` (same arguments, same results).

Each step is :meth:`granwave.gpu.dem.GpuEngine.step` (the engine's own step on the device),
followed by the contact bookkeeping of the CPU loop as two kernels: the contact flags of every
pair and wall slot (the CPU's per-contact classification, with the sub-models' slider limit and
normal law, compiled for the device from its source, :mod:`granwave.gpu.compile`), and every grain's largest displacement so far
(kept per grain on the device, reduced once per call). After a host neighbour rebuild the
flags are carried to the new list by the CPU's ``carry_flags``. When the pair arrays need more
room, the call returns minus the sample to resume, as the CPU loop does.

The piston drive (docs/shocks.md) needs nothing of its own here: its source grains are the
CPU set-up's (masses made :data:`granwave.dem.pulse.PISTON_MASS_FACTOR` times larger, their
velocity set), uploaded with the rest of the state. The per-sample readings the CPU loop takes
inside its call (the pulse field, the shear force: :class:`granwave.dem.pulse_kernels.Readings`)
are the CPU's :func:`~granwave.dem.pulse_kernels.read_sample` on the state brought to the host
at each sample: one copy of the state per sample, while the steps stay on the device; with the
field, also the contact flags, which the CPU's :func:`~granwave.dem.pulse_kernels.count_contacts`
counts.
"""

from __future__ import annotations

import math

import numpy as np

from .. import geometry
from . import load_cuda
from ..dem import kernels as K
from ..dem import pulse_kernels as PK
from .compile import _rebound, device_functions
from .dem import BLOCK, GpuEngine, _blocks

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

_DF = device_functions()
# the CPU's per-contact classification, compiled from its source: its calls of the contact
# sub-models' dispatchers (``CM.``, ``C.``) and of its helpers resolve to their device copies
_names = {"C": _DF, "CM": _DF, "nearest_image": _DF.nearest_image}
_names["_on_limit"] = cuda.jit(device=True)(_rebound(PK._on_limit.py_func, _names))
_names["_touching_state"] = cuda.jit(device=True)(_rebound(PK._touching_state.py_func, _names))
_classify_pair = cuda.jit(device=True)(_rebound(PK._classify_pair.py_func, _names))
_classify_wall = cuda.jit(device=True)(_rebound(PK._classify_wall.py_func, _names))
periodic_distance2 = cuda.jit(device=True)(_rebound(geometry.periodic_distance2.py_func, _names))


@cuda.jit
def classify_pairs(d, rad, pair_i, pair_j, npairs, pair_ft, pair_ov, fpar1, pair_state, initial):
    """The pair loop of :func:`granwave.dem.pulse_kernels.classify`, a thread per pair (``fpar1``:
    the engine's parameter record as a one-element array, whose tangential and normal models set
    the slider's limit)."""
    fpar = fpar1[0]
    tangential = _DF.friction_of(fpar)
    law = _DF.law_of(fpar)
    for p in range(cuda.grid(1), npairs, cuda.gridsize(1)):
        _classify_pair(p, d, rad, pair_i, pair_j, pair_ft, pair_ov, tangential, pair_state, initial, law)


@cuda.jit
def classify_walls(d, rad, wall_ft, wall_ov, fpar1, wall_state, initial):
    """The wall loop of :func:`granwave.dem.pulse_kernels.classify`, a thread per wall slot."""
    fpar = fpar1[0]
    tangential = _DF.friction_of(fpar)
    law = _DF.law_of(fpar)
    for w in range(cuda.grid(1), wall_ov.shape[0], cuda.gridsize(1)):
        _classify_wall(w, d, rad, wall_ft, wall_ov, tangential, wall_state, initial, law)


@cuda.jit
def track_displacement(pos, pos_ref, lateral, best2):
    """best2[i] = max(best2[i], |r_i - r_i(0)|^2) (nearest periodic image)."""
    for i in range(cuda.grid(1), pos.shape[0], cuda.gridsize(1)):
        s = periodic_distance2(pos, i, pos_ref, i, lateral)
        if s > best2[i]:
            best2[i] = s


#: Every kernel of this module (compiled to PTX by tests/test_gpu_ptx.py).
KERNELS = (classify_pairs, classify_walls, track_displacement)


class _NeedRoom(Exception):
    def __init__(self, needed: int, width: int):
        self.needed, self.width = needed, width


class _Session(GpuEngine):
    """A GpuEngine over the arrays of a CPU engine (the same objects): growing them is left to
    the caller, as with the CPU loop. The first version's host rebuild: the contact flags are
    carried across rebuilds on the host (``on_rebuild``)."""

    device_rebuild = False

    def grow(self, needed: int, width: int = 0) -> None:
        raise _NeedRoom(needed, width)


_ARRAYS = ("position", "velocity", "acceleration", "angular_velocity", "angular_acceleration", "radius",
           "mass", "inertia", "lateral", "pos0", None, "pair_i", "pair_j", "pair_ft", "pair_ov", "wall_ft",
           "wall_ov", "piston", "fpar", "ipar", "out", "ws")


def pulse_samples_gpu(pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pos_ref, pair_i,
                      pair_j, pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws, pair_state,
                      wall_state, archive, k_start, k_stop, sub, force_out, stats, rd):
    """:func:`granwave.dem.pulse_kernels.pulse_samples` with the steps on the GPU (module
    docstring); the host arrays are updated in place when it returns. The sample's readings
    ``rd`` (pulse field, shear force: :class:`granwave.dem.pulse_kernels.Readings`) are the CPU's
    own :func:`~granwave.dem.pulse_kernels.read_sample`, on the state brought to the host at
    that sample (only when a reading is on)."""
    eng = object.__new__(_Session)
    values = (pos, vel, acc, omega, alpha, rad, mass, inertia, lateral, pos0, pos_ref, pair_i, pair_j,
              pair_ft, pair_ov, wall_ft, wall_ov, piston, fpar, ipar, out, ws)
    for name, value in zip(_ARRAYS, values):
        if name is not None:
            setattr(eng, name, value)
    n, d = pos.shape
    eng.dim = d
    eng.mflow, eng.slabs = ws.mflow, ws.slabs  # the compaction rule's (off in a pulse)
    eng.upload()
    dev = {"state": cuda.to_device(pair_state), "wall": cuda.to_device(wall_state),
           "ref": cuda.to_device(pos_ref), "best": cuda.to_device(np.zeros(n))}

    def carry(old_i, old_j, n_old):
        old_state = dev["state"].copy_to_host()[:n_old].copy()
        PK.carry_flags(n, old_i, old_j, old_state, n_old, eng.pair_i, eng.pair_j, int(ipar.npairs),
                       pair_state, archive)
        dev["state"] = cuda.to_device(pair_state)

    eng.on_rebuild = carry
    g = eng.g
    reads = rd.grain_bin.shape[0] > 0 or rd.shear.shape[0] > 0
    k = k_start
    try:
        while k < k_stop:
            for _ in range(int(stats[1]), sub):
                eng.step()
                m = int(ipar.npairs)
                if m:
                    classify_pairs[_blocks(m), BLOCK](d, g["radius"], eng.gp["i"], eng.gp["j"], m,
                                                      eng.gp["ft"], eng.gp["ov"], g["fpar"], dev["state"], False)
                classify_walls[_blocks(2 * n), BLOCK](d, g["radius"], g["wall_ft"], g["wall_ov"], g["fpar"],
                                                      dev["wall"], False)
                track_displacement[_blocks(n), BLOCK](g["position"], dev["ref"], g["lateral"], dev["best"])
                stats[1] += 1.0
            stats[1] = 0.0
            force_out[k] = piston.f_con
            if reads:
                eng.download()
                PK.read_sample(k, pos, vel, omega, rad, mass, pair_i, pair_j, int(ipar.npairs), pair_ov, ws.pair_c,
                               wall_ft, wall_ov, piston, fpar, rd)
            if rd.contacts.shape[0] > 0:  # the flags so far, brought to the host (int8: 1 byte a slot)
                pair_state[...] = dev["state"].copy_to_host()
                wall_state[...] = dev["wall"].copy_to_host()
                PK.count_contacts(k, pair_state, int(ipar.npairs), wall_state, archive, rd)
            k += 1
        return k_stop
    except _NeedRoom as exc:
        ipar.needed = exc.needed
        ipar.width = exc.width
        return -k
    finally:
        eng.download()
        pair_state[...] = dev["state"].copy_to_host()
        wall_state[...] = dev["wall"].copy_to_host()
        best = float(np.max(dev["best"].copy_to_host(), initial=0.0))
        stats[0] = max(stats[0], math.sqrt(best))
