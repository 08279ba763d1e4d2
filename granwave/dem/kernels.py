"""The DEM engine's numba kernels, by name: a facade over the modules that hold them.

The kernels live in modules with one job each: :mod:`granwave.dem.layout` (the records of
the engine's state), :mod:`granwave.dem.contact_law` (pair and wall contacts),
:mod:`granwave.dem.grain_step` (a grain's walls, damping and measures),
:mod:`granwave.dem.blocks` (grain blocks and their claims), :mod:`granwave.dem.workspace`
(work arrays, incoming and wall lists), :mod:`granwave.dem.passes` (the parallel force
passes), :mod:`granwave.dem.team_steps` (a team of threads), :mod:`granwave.dem.piston`,
:mod:`granwave.dem.time_step` (time step, rebuild and skin rules) and
:mod:`granwave.dem.chunk` (:func:`run_chunk`). This module re-exports their names for the
callers that take them as ``kernels.NAME`` (the GPU engine, tests, benchmarks); nothing in
those modules imports it.
"""

from __future__ import annotations

from .layout import as_array, copy_record, COUNTERS, OUT, PARAMS, PISTON, record  # noqa: F401
from .contact_law import (_add_torque3, _contact_velocity, _pair_geometry, _pair_law, _spin, add_torque,
                          add_torque_with_couple, contact_force, contact_force3, dashpot_of, friction_of, law_of,
                          N_PCOL,
                          pair_constants, pair_constants3, pair_couple, PC_MEFF, PC_R12, PC_ROOT,
                          relative_spin, couple_history, couple_of, rotation_velocity,
                          store_couple_history, torque_with_couple, wall_contact, wall_couple)  # noqa: F401
from .blocks import (block_bounds, block_count, BLOCK_GRAINS, BLOCK_MULTIPLE, block_taken, BLOCKS_PER_THREAD,
                     claim_block, G_ALMAX, G_AMAX, G_DISP, G_DMAX, G_DVMAX, G_KIN, G_NC, G_NTOP, G_VMAX,
                     G_WMAX, grains, MIN_BLOCK_GRAINS, N_GCOL, open_claims, take_block, visit_order)  # noqa: F401
from .workspace import (boundary_fraction, boundary_room, first_wall_entry, grown_workspace, incoming_lists,
                        _lists, N_TEAM_TIMES, prepare_blocks, refresh_wall_list, T_END, T_PASS1, T_PASS2,
                        T_WAIT1, T_WAIT2, wall_list, with_blocks, workspace, Workspace)  # noqa: F401
from .grain_step import grain_damping, grain_measures, grain_walls  # noqa: F401
from .piston import (piston_acceleration, piston_contact_force, piston_half_kick, piston_kick_drift)  # noqa: F401
from .time_step import (needs_rebuild, next_skin, rebuild_due, ROTATION_FACTOR,
                        SAFETY_AT_LIMIT, SKIN_STEPS, stable_dt, stable_dt_at, verlet_limit)  # noqa: F401
from .passes import (_await_slab_means, _block_max, _displacement_pass, _drift_pass, _finish, _forces,
                     _incoming_block, _incoming_pass, _row_block, _row_pass, _slab_job, compute_forces,
                     drift_grain, measure, SLABS_READY, SLABS_RUNNING, SLABS_TODO, to_accelerations)  # noqa: F401
from .team_steps import (_team_region, _team_steps, _team_thread)  # noqa: F401
from .chunk import (MIN_PARALLEL_GRAINS, run_chunk)  # noqa: F401
