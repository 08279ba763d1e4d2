"""Contact sub-models as parts: each a small module registered by one line
(:mod:`.registry`; docs/dem.md, "How to add a contact model").

A sub-model module (:mod:`.hertz`, :mod:`.harmonic`: normal laws; :mod:`.damping_critical`: the
damping law; :mod:`.mindlin`: the tangential law; :mod:`.rolling`: rolling resistance) declares
its kind (:mod:`.kinds`), name, parameters (:class:`.declare.Parameter`)
and the numba formulas of its kind. ``python -m granwave.contact_models.generate`` writes from
the registry the plain facts (``_table.py``, read through :mod:`.options` without numba: the
options, file attributes and checks) and the dispatchers the engines compile (``_dispatch.py``:
per kind, one function per formula branching on the selected sub-model's code). The Python
side for the engines, the linearization and LAMMPS is :mod:`.models`.

Importing this package loads nothing heavy (the command line reads :mod:`.options` at start);
the names of :mod:`.models` (``law_force``, ``contact_model``, ...) load it on first use.
"""

from __future__ import annotations

import importlib
import os


def __getattr__(name: str):
    if name.startswith("__"):
        raise AttributeError(name)
    # a module of this package (``from . import registry`` asks here before importing it)
    if os.path.exists(os.path.join(os.path.dirname(__file__), name + ".py")):
        return importlib.import_module(f"{__name__}.{name}")
    # the Python API (numba kernels included) on first use: ``CM.law_force`` etc.
    return getattr(importlib.import_module(f"{__name__}.models"), name)
