"""CUDA device functions made from the CPU kernels' own source: the contact law is written once.

:func:`device_functions` takes the Python functions behind the ``numba.njit`` kernels of
:mod:`granwave.contact` (the scalar Hertz-Mindlin law), of the contact sub-models (their
formulas and the generated dispatchers, :mod:`granwave.contact_models`) and the per-contact routine
:func:`granwave.dem.kernels.contact_force3` (``.py_func``: the very code the CPU compiles)
and compiles them with ``cuda.jit(device=True)``; so also the rule
'mean-flow''s slab term and the per-grain part of a step (:mod:`granwave.dem.grain_step`: walls,
damping, convergence measures). Only their global names are rebound: inside
the device copies, a call to another contact function (``C.normal_force`` in
``contact_force3``, ``shear_modulus_star`` in ``effective_shear``) resolves to its device
copy instead of the CPU dispatcher, which CUDA kernels cannot call. No arithmetic is
re-written, so the GPU evaluates the same expressions in the same order as the CPU (up to
fused multiply-adds, which the CUDA compiler may contract; docs/gpu.md).
"""

from __future__ import annotations

import functools
import types

from .. import contact, geometry
from ..contact_models import _dispatch as CD
from ..dem import kernels as K, mean_flow
from . import load_cuda

cuda = load_cuda()  # numba.cuda, with numpy's names it needs (granwave.gpu.load_cuda)

#: The scalar functions of granwave.contact used by the per-contact routine (and each other; a
#: function after those it calls: each copy binds the names made before it).
CONTACT_FUNCTIONS = ("shear_modulus_star", "stiffness_ratio", "effective_radius", "effective_young",
                     "effective_shear", "normal_force_root", "normal_force", "normal_energy",
                     "normal_stiffness_root", "normal_stiffness",
                     "tangential_stiffness", "damping_coefficient", "reduced_mass",
                     "total_normal_force", "tangential_part3", "project_tangential3", "unloads",
                     "unloading_scale", "increment_and_cap3", "update_tangential3")

#: The compaction rule 'mean-flow''s per-grain term and its helpers (granwave.dem.mean_flow).
MEAN_FLOW_FUNCTIONS = ("_slab", "lateral_on", "add_slab_damping")

#: Helpers of the CPU force loop (granwave.dem.kernels) reused as device functions, each after
#: those it calls; the per-grain routines of granwave.dem.grain_step last.
ENGINE_FUNCTIONS = ("contact_force3", "_pair_geometry", "_spin", "_contact_velocity",
                    "_add_torque3", "wall_contact", "relative_spin", "couple_history", "store_couple_history",
                    "pair_couple", "wall_couple", "torque_with_couple", "add_torque_with_couple",
                    "piston_acceleration", "pair_constants3", "drift_grain", "_pair_law", "grain_walls",
                    "grain_damping", "grain_measures")


def _rebound(py_func, namespace: dict):
    """A copy of ``py_func`` whose global names are looked up in ``namespace`` first."""
    g = dict(py_func.__globals__)
    g.update(namespace)
    return types.FunctionType(py_func.__code__, g, py_func.__name__, py_func.__defaults__,
                              py_func.__closure__)


@functools.lru_cache(maxsize=None)
def device_functions() -> types.ModuleType:
    """Device versions of the contact law and of ``contact_force3`` (built once per process).

    Returns a module object with one attribute per name of :data:`CONTACT_FUNCTIONS` and
    :data:`ENGINE_FUNCTIONS`, plus ``nearest_image`` and ``fold_into_box``.
    """
    names: dict = {}
    # a module object: numba resolves ``C.name`` on modules at compile time (not on namespaces)
    ns = types.ModuleType("granwave_contact_device")
    for name in CONTACT_FUNCTIONS:
        fn = cuda.jit(device=True)(_rebound(getattr(contact, name).py_func, names))
        names[name] = fn
        setattr(ns, name, fn)
    # contact_force3 calls the law through the module alias ``C``: give it the device namespace
    names["C"] = ns
    # the contact sub-models (granwave.contact_models): each module's formulas (in a device module of
    # its own, under the name the generated dispatchers call it), then the readers and dispatchers,
    # which the engine calls as ``CD.law_force`` etc.
    subs = {}
    for alias, name in CD.DEVICE_FUNCTIONS:
        if alias is not None:
            module = CD.MODULES[alias]
            if alias not in subs:
                subs[alias] = (types.ModuleType(f"granwave{alias}_device"), dict(names))
            dev, local = subs[alias]
            fn = cuda.jit(device=True)(_rebound(getattr(module, name).py_func, local))
            local[name] = fn  # the module's own formulas call each other by their plain names
            setattr(dev, name, fn)
            continue
        names.update({a: dev for a, (dev, _) in subs.items()})
        fn = cuda.jit(device=True)(_rebound(getattr(CD, name).py_func, names))
        names[name] = fn
        setattr(ns, name, fn)
    for kind, tup in CD.MODELS.items():
        setattr(ns, tup.__name__, tup)
    names["CD"] = ns
    for name in MEAN_FLOW_FUNCTIONS:
        fn = cuda.jit(device=True)(_rebound(getattr(mean_flow, name).py_func, names))
        names[name] = fn
        setattr(ns, name, fn)
    for name in ("nearest_image", "fold_into_box"):
        fn = cuda.jit(device=True)(_rebound(getattr(geometry, name).py_func, names))
        names[name] = fn
        setattr(ns, name, fn)
    for name in ENGINE_FUNCTIONS:
        fn = cuda.jit(device=True)(_rebound(getattr(K, name).py_func, names))
        names[name] = fn
        setattr(ns, name, fn)
    return ns
