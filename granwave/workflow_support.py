"""Small helpers the Snakemake workflow calls when it builds its job graph.

They use only the closed forms (no input files exist yet at that point).
"""

from __future__ import annotations

import math

from .geometry import grain_mass
from .systems import default_chain_stiffness
from .theory import chain_travel_time, lattice_speed


def crossing_time(kind: str, spec: dict, pressure: float, size: str) -> float:
    """Time (d/sqrt(E*/rho)) for a front to cross one sample, estimated from theory.

    ``kind`` is the config section ("disordered", "lattices", "chains") and
    ``size`` the sample's size label (h<height>, r<rows>, n<balls>). Disordered
    packings and lattices use the perfect-lattice speed of SPEC §12 (with
    friction when the scene has it), which is an upper bound of the disordered
    speed, so the real arrival comes later than this estimate; chains use
    their exact wall-to-wall time (N+1) l / c with unit balls.
    """
    value = float(size[1:])
    if kind == "chains":
        return chain_travel_time(int(value), stiffness=default_chain_stiffness(pressure),
                                 mass=float(grain_mass(0.5)))
    height = value * math.sqrt(3.0) / 2.0 if kind == "lattices" else value
    return height / lattice_speed(pressure, friction=spec.get("friction", 0.0) > 0,
                                  poisson=spec.get("poisson", 0.0))
