"""granwave: computational granular acoustics.

Units throughout (docs/method.md §1): mean grain diameter = 1, grain density = 1,
modified Young modulus E* = E/(1-nu^2) = 1; time then follows so that the
longitudinal sound speed of the grain material is 1.

The library API is :mod:`granwave.api` (one function per stage) with the
parameter classes of :mod:`granwave.params`; both are also reachable here
(``granwave.linearize``, ``granwave.PrepareParams``, ...), imported on first
use so that ``import granwave`` stays light.
"""

__version__ = "0.1.0"

_API = ("prepare_packing", "lattice", "chain", "linearize", "eigensolve", "propagate", "choose_method",
        "statics", "moduli", "front", "heights", "ensemble", "spectrum", "damping", "pressure_sweep")
_PARAMS = ("PrepareParams", "LatticeParams", "ChainParams", "LinearizeParams", "EigenParams",
           "PropagateParams", "StaticsParams", "ModuliParams", "FrontParams", "HeightsParams",
           "EnsembleParams", "SpectrumParams", "DampingParams", "SweepParams")


def __getattr__(name):
    import importlib

    if name in ("api", "params"):
        return importlib.import_module(f"{__name__}.{name}")
    if name in _API:
        return getattr(importlib.import_module(f"{__name__}.api"), name)
    if name in _PARAMS:
        return getattr(importlib.import_module(f"{__name__}.params"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), "api", "params", *_API, *_PARAMS])
