"""The kinds of contact sub-model and the fixed signature of each kind's formulas (no numba).

normal: the elastic normal force and what follows from it. A module of this kind defines the
numba functions ``force(overlap, root_r12, e12, k)``, ``stiffness(overlap, root_r12, e12, k)``,
``energy(overlap, r12, e12, k)``, ``tangential_stiffness(overlap, r12, g12, k)`` and
``unloading_scale(overlap_old, overlap_new)``, ``step_stiffness(overlap, root_r12, e12, k)`` (the
stiffness the time step takes; ``k``: its one kernel constant), and in Python
``overlap_at_force(f, r12, e12, k)``, ``kernel_constants(values) -> (k,)``,
``lammps_words(values, e12_pair, e12_wall, g12_pair, g12_wall) -> dict`` and the constants
``IMPACT_WORK``, ``STEP_CONTACTS``, ``LAMMPS_RESTITUTION_SCALE``, ``SUMMARY``, ``DESCRIPTION``.

rolling: a couple from the contact's relative rotation with a history (three components, of
which the engines store ``dim``: ``history_width(dim) == dim``, the columns after the tangential
history's in ``pair_ft`` / ``wall_ft``).
A module of this kind defines ``couple(c0, c1, c2, nx, ny, nz, rx, ry, rz, r12, fel, hx, hy, hz,
dt) -> (cx, cy, cz, hx, hy, hz)``, ``spring_couple(c0, c1, c2, nx, ny, nz, rx, ry, rz, r12, hx,
hy, hz) -> (cx, cy, cz)`` (frozen history: the linearization's contract),
``in_plane(hx, hy, hz, nx, ny, nz)`` (the history carried into the tangent plane) and
``step_mode(c0, c1, c2, m_min) -> (omega, zeta)`` (its fastest mode, for the time step), and in
Python ``kernel_constants(values)``, ``history_width(dim)``, ``linear_blocks(...)`` and
``lammps_fragment(values)``, and the flags ``NEEDS_FRICTION`` and ``DEVICES``.

A kind's sub-models are numbered in registry order (1, 2, ... where the kind has an ``off``
name, which is code 0; 0, 1, ... otherwise); the engines carry the selected one as a named
tuple ``(code, c0, ..., c{slots-1})`` (generated: granwave.contact_models._dispatch).
"""

from __future__ import annotations

from .declare import Kind

#: (function of the sub-model, its dispatcher's name, the dispatcher's arguments after the model,
#: the call's arguments ({c}: the model's constants c0, c1, ...), what the dispatcher returns
#: when the kind is off)
NORMAL_FUNCTIONS = (
    ("force", "law_force", "overlap, root_r12, e12", "overlap, root_r12, e12, {c}", None),
    ("stiffness", "law_stiffness", "overlap, root_r12, e12", "overlap, root_r12, e12, {c}", None),
    ("energy", "law_energy", "overlap, r12, e12", "overlap, r12, e12, {c}", None),
    ("tangential_stiffness", "law_tangential_stiffness", "overlap, r12, g12", "overlap, r12, g12, {c}", None),
    ("unloading_scale", "law_unloading_scale", "overlap_old, overlap_new", "overlap_old, overlap_new", None),
    ("step_stiffness", "law_step_stiffness", "overlap, root_r12, e12", "overlap, root_r12, e12, {c}", None),
)
ROLLING_FUNCTIONS = (
    ("couple", "contact_couple", "nx, ny, nz, rx, ry, rz, r12, fel, hx, hy, hz, dt",
     "{c}, nx, ny, nz, rx, ry, rz, r12, fel, hx, hy, hz, dt", "0.0, 0.0, 0.0, hx, hy, hz"),
    ("spring_couple", "spring_couple", "nx, ny, nz, rx, ry, rz, r12, hx, hy, hz",
     "{c}, nx, ny, nz, rx, ry, rz, r12, hx, hy, hz", "0.0, 0.0, 0.0"),
    ("in_plane", "couple_in_plane", "hx, hy, hz, nx, ny, nz", "hx, hy, hz, nx, ny, nz", "hx, hy, hz"),
    ("step_mode", "couple_step_mode", "m_min", "{c}, m_min", "math.inf, 0.0"),
)

NORMAL = Kind("normal", option="contact_law", help="Normal contact law", default="hertz", recorded=True,
              slots=1, reader="law_of", functions=NORMAL_FUNCTIONS)
ROLLING = Kind("rolling", option="rolling", help="Rolling resistance", default="none", off="none", slots=3,
               history="rolling_displacement",
               history_help="rolling displacement xi of the rolling spring (root attribute rolling)",
               reader="couple_of", functions=ROLLING_FUNCTIONS)

#: every kind the engines call, in the order their models are passed
KINDS = (NORMAL, ROLLING)
