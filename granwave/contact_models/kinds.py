"""The kinds of contact sub-model and the fixed signature of each kind's formulas (no numba).

normal: the elastic normal force and what follows from it. A module of this kind defines the
numba functions ``force(overlap, root_r12, e12, k)``, ``stiffness(overlap, root_r12, e12, k)``,
``energy(overlap, r12, e12, k)``, ``tangential_stiffness(overlap, r12, g12, k)`` and
``unloading_scale(overlap_old, overlap_new)``, ``step_stiffness(overlap, root_r12, e12, k)`` (the
stiffness the time step takes; ``k``: its one kernel constant), and in Python
``overlap_at_force(f, r12, e12, k)``, ``kernel_constants(values) -> (k,)``,
``lammps_words(values, e12_pair, e12_wall, g12_pair, g12_wall) -> dict`` and the constants
``IMPACT_WORK``, ``STEP_CONTACTS``, ``LAMMPS_RESTITUTION_SCALE``, ``SUMMARY``, ``DESCRIPTION``.

damping: the contact's dashpot. A module of this kind defines the numba functions
``acts(c0) -> bool`` (whether the dashpot acts at all: the engines skip its terms otherwise),
``coefficient(meff, k, overlap, c0) -> c`` (the viscous coefficient of a spring of stiffness
``k`` (E* d) between masses of reduced mass ``meff`` at ``overlap``: the normal force gets
``-c v_n`` with ``k = k_n``, a sticking tangential force ``c v_t`` with ``k = k_t``) and
``step_ratio(c0) -> zeta`` (the damping ratio of a contact's mode for the time step), and in
Python ``kernel_constants(values) -> (c0,)``. The kind's parameter ``damping`` is every damping
law's strength (as LAMMPS's normal models carry the damping coefficient and its damping model
gives it its form); its meaning is the law's (the default's: zeta, a fraction of critical).

tangential: the tangential spring with its slider. Its history (F_t, the first ``dim`` columns
of ``pair_ft`` / ``wall_ft``) is carried into each step's tangent plane by the engines (its
magnitude kept; geometry, as LAMMPS's pair style does for every tangential model); the kind's
parameters ``friction`` (mu; 0: frictionless, no tangential force and no rotations) and
``poisson`` (nu; G*12, which the normal law's k_t takes) are every tangential law's. A module
of this kind defines ``acts(mu) -> bool`` (a tangential force at all), ``stiffness(kt_law,
overlap, mu) -> k_t`` (``kt_law``: the normal law's ``tangential_stiffness``),
``unloads(overlap_old, overlap_new, rescale, mu) -> bool`` (whether F_t is scaled by the normal
law's ``unloading_scale`` first; ``rescale``: the engine's unloading rule) and
``increment(fx, fy, fz, sx, sy, sz, kt, fel, mu) -> (fx, fy, fz, slid)`` (F_t after the slip
increment s: spring and slider), ``step_ratio(poisson, mu) -> k_t / k_n`` (at the stiffest
contact, for the time step's tangential mode), ``at_limit(fx, fy, fz, fel, tol, mu) -> bool``
(F_t on the slider's limit within the relative tolerance ``tol``: a sliding contact, for the
nonlinear pulse's contact flags), and in Python ``kernel_constants(values) -> (mu,)``.

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

from .declare import Kind, Parameter

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
DAMPING_FUNCTIONS = (
    ("acts", "dashpot_acts", "", "{c}", None),
    ("coefficient", "dashpot_coefficient", "meff, k, overlap", "meff, k, overlap, {c}", None),
    ("step_ratio", "dashpot_step_ratio", "", "{c}", None),
)
TANGENTIAL_FUNCTIONS = (
    ("acts", "friction_acts", "", "{c}", None),
    ("stiffness", "tangential_spring", "kt_law, overlap", "kt_law, overlap, {c}", None),
    ("unloads", "tangential_unloads", "overlap_old, overlap_new, rescale", "overlap_old, overlap_new, rescale, {c}",
     None),
    ("increment", "tangential_increment", "fx, fy, fz, sx, sy, sz, kt, fel", "fx, fy, fz, sx, sy, sz, kt, fel, {c}",
     None),
    ("step_ratio", "tangential_step_ratio", "poisson", "poisson, {c}", None),
    ("at_limit", "tangential_at_limit", "fx, fy, fz, fel, tol", "fx, fy, fz, fel, tol, {c}", None),
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
DAMPING = Kind("damping", option="damping_law", help="Contact damping law", default="critical_fraction", slots=1,
               fields=("zeta",), reader="dashpot_of", functions=DAMPING_FUNCTIONS,
               parameters=(Parameter("damping", 0.5, None, "Contact damping zeta, fraction of critical (normal "
                                     "and tangential).", lo=0.0, hi=1.0),))
TANGENTIAL = Kind("tangential", option="tangential", help="Tangential contact law", default="mindlin", slots=1,
                  fields=("mu",), reader="friction_of", functions=TANGENTIAL_FUNCTIONS,
                  parameters=(Parameter("friction", 0.5, None, "Coulomb friction coefficient mu (0: frictionless, "
                                        "no rotational degrees of freedom).", lo=0.0),
                              Parameter("poisson", 0.0, None, "Poisson ratio nu of the grains: k_t/k_n = "
                                        "2(1-nu)/(2-nu).", lo=0.0, hi=0.5, hi_open=True)))
ROLLING = Kind("rolling", option="rolling", help="Rolling resistance", default="none", off="none", slots=3,
               history="rolling_displacement",
               history_help="rolling displacement xi of the rolling spring (root attribute rolling)",
               reader="couple_of", functions=ROLLING_FUNCTIONS)

#: every kind the engines call, in the order their models are passed
KINDS = (NORMAL, DAMPING, TANGENTIAL, ROLLING)
