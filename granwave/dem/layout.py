"""The DEM engine's small named structures: numpy structured dtypes of one record each, which
every kernel of :mod:`granwave.dem` (and :mod:`granwave.gpu.dem`) reads by field name.

A record (:func:`record`) is passed to the numba kernels by reference: ``fpar.dt = x`` in a
kernel writes into the engine's record. On the GPU the records travel as one-element device
arrays (``a[0]`` in a kernel is the record, by reference too).

``fpar`` (:data:`PARAMS`), the step's parameters: dt (time step), damping (the damping law's
constant: the default law's zeta), friction (mu), poisson, gamma (background damping rate, 1 / time), skin (of the pair
list, d), safety (dt safety factor), overlap_floor (the overlap the time step assumes at
least), tol_a and tol_v (convergence tolerances), r_max (largest radius), m_min (smallest
mass), v_max (the last step's largest speed), rescale (unloading rule, 1: rescale F_t on
unloading, 0: plain incremental; contact.update_tangential), wall_h (piston height when the
wall list was made, :func:`granwave.dem.workspace.wall_list`), skin_min and skin_max (an
adaptive skin when they differ, :func:`granwave.dem.time_step.next_skin`), then per kind of
contact sub-model its code and constants (``<kind>_code``, ``<kind>_c0``, ...: generated from the
registry, granwave.contact_models; read by its generated reader, ``law_of``, ``couple_of``).

``ipar`` (:data:`COUNTERS`): pairs listed (npairs), steps asked (nsteps), steps done (steps),
steps between checks (check), adaptive dt (adaptive), rebuilds, the sizes a rebuild needs
(needed pairs, width), the step of the last rebuild (built), whether plain steps run in a team
of threads (team; 1: yes, 0: no, -1: a team did not start;
:func:`granwave.dem.team_steps._team_steps`), steps run so far in teams (team_steps).

``piston`` (:data:`PISTON`): height h, velocity v, acceleration a, mass (inf = fixed wall),
downward force f_ext = p A, contact force f_con (up, from the grains).

``out`` (:data:`OUT`), the statistics of a step or check: largest |a| (a_max), |alpha|
(alpha_max), the piston's |a| (a_piston), largest |v| (v_max), |w| R (w_max), kinetic energy
(kin), top-wall contacts (ntop), largest overlap (d_max), contacts (ncontact).
"""

from __future__ import annotations

import numpy as np

from ..contact_models._table import PARAMS_FIELDS

#: the step's parameters (``fpar``); rescale and the sub-models' ``*_code`` are codes
PARAMS = np.dtype([("dt", np.float64), ("damping", np.float64), ("friction", np.float64), ("poisson", np.float64),
                   ("gamma", np.float64), ("skin", np.float64), ("safety", np.float64),
                   ("overlap_floor", np.float64), ("tol_a", np.float64), ("tol_v", np.float64),
                   ("r_max", np.float64), ("m_min", np.float64), ("v_max", np.float64), ("rescale", np.int64),
                   ("wall_h", np.float64), ("skin_min", np.float64), ("skin_max", np.float64),
                   *((name, np.dtype(kind)) for name, kind in PARAMS_FIELDS)], align=True)
#: the engine's counters (``ipar``)
COUNTERS = np.dtype([(name, np.int64) for name in ("npairs", "nsteps", "steps", "check", "adaptive", "rebuilds",
                                                    "needed", "width", "built", "team", "team_steps")],
                    align=True)
#: the piston (top wall)
PISTON = np.dtype([(name, np.float64) for name in ("h", "v", "a", "mass", "f_ext", "f_con")], align=True)
#: the statistics of a step or a check (``out``)
OUT = np.dtype([(name, np.float64) for name in ("a_max", "alpha_max", "a_piston", "v_max", "w_max", "kin", "ntop",
                                                "d_max", "ncontact")], align=True)


def record(dtype: np.dtype, values=None) -> np.record:
    """A new record of ``dtype`` (zeros, or the fields of ``values``: a record or a one-element
    array of the same fields), with attribute access (``r.dt``); numba kernels take it by
    reference."""
    r = np.zeros(1, dtype).view(np.recarray)[0]
    if values is not None:
        copy_record(r, values)
    return r


def copy_record(dst, src) -> None:
    """Every field of ``src`` (a record or a one-element structured array) into the record ``dst``."""
    src = np.asarray(src).reshape(-1)[0] if not isinstance(src, np.void) else src
    for name in dst.dtype.names:
        dst[name] = src[name]


def as_array(r) -> np.ndarray:
    """A one-element structured array holding a copy of the record ``r`` (files, device uploads)."""
    a = np.zeros(1, r.dtype)
    a[0] = r
    return a
