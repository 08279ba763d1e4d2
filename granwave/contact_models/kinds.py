"""The kinds of contact sub-model and the fixed signature of each kind's formulas (no numba).

A sub-model is sized by what it needs: it declares ``CONSTANTS``, the names of its kernels'
constants (any number; ``kernel_constants(values)`` computes them from its parameters), and its
formulas take the kind's arguments followed by exactly those constants (``{c}`` below: ``c0, c1,
...`` of that sub-model). The generator (:mod:`.generate`) sizes a kind's model tuple and the
engine's record to the largest count of its sub-models, passes each sub-model its own, and
checks every hook's presence and arity. The time-step hooks receive from the engine the
stiffness (``k``, ``kn``: the normal law's ``step_stiffness``, E* d) and the mass (``m``: the
lightest grain, rho d^3) of the contact that bounds the step.

normal: the elastic normal force and what follows from it. Numba functions ``force(overlap,
root_r12, e12, {c})``, ``stiffness(overlap, root_r12, e12, {c})``, ``energy(overlap, r12, e12,
{c})``, ``tangential_stiffness(overlap, r12, g12, {c})``, ``unloading_scale(overlap_old,
overlap_new, {c})`` (k_t(new) / k_t(old), the rescale of F_t on unloading) and
``step_stiffness(overlap, root_r12, e12, {c})`` (the stiffness the time step takes: k_n times
the contacts of a grain it assumes act together); in Python ``overlap_at_force(f, r12, e12,
{c})`` and ``IMPACT_WORK`` ((1/2) m v^2 = IMPACT_WORK F delta: the work of the force up to
delta over F delta, for the preparation's impact speed), ``SUMMARY``, ``DESCRIPTION``.

damping: the contact's dashpot. Numba ``acts({c}) -> bool`` (whether the dashpot acts at all:
the engines skip its terms otherwise; every damping law with all its constants 0 does not act,
which is how the pulse switches the dashpot off), ``coefficient(meff, k, overlap, {c}) -> c``
(the viscous coefficient of a spring of stiffness ``k`` (E* d) between masses of reduced mass
``meff`` at ``overlap``: the normal force gets ``-c v_n`` with ``k = k_n``, a sticking
tangential force ``c v_t`` with ``k = k_t``) and ``step_ratio(k, m, {c}) -> zeta`` (the damping
ratio of a spring ``k`` on a mass ``m`` with this dashpot, for the time step). The kind's
parameter ``damping`` (zeta) is every damping law's (its meaning is the law's: the default's, a
fraction of critical); a law with a constant of its own declares it as a parameter.

tangential: the tangential spring with its slider. Its history (F_t, the first ``dim`` columns
of ``pair_ft`` / ``wall_ft``) is carried into each step's tangent plane by the engines (its
magnitude kept; geometry, as LAMMPS's pair style does for every tangential model); the kind's
parameters ``friction`` (mu; 0: frictionless, no tangential force and no rotations) and
``poisson`` (nu; G*12, which the normal law's k_t takes) are every tangential law's, and every
tangential law's first constant is friction (``LEADING``: the frozen-history forces set it to inf, no
cap). Numba ``acts({c}) -> bool`` (a tangential force at all), ``stiffness(kt_law, overlap, e12,
{c}) -> k_t`` (``kt_law``: the normal law's ``tangential_stiffness``; ``e12``: E*12, 1/2 between
grains and 1 at a rigid wall), ``unloads(overlap_old, overlap_new, rescale, {c}) -> bool``
(whether F_t is scaled by the normal law's ``unloading_scale`` first; ``rescale``: the engine's
unloading rule), ``increment(fx, fy, fz, sx, sy, sz, kt, fel, {c}) -> (fx, fy, fz, slid)`` (F_t
after the slip increment s: spring and slider), ``step_ratio(kn, m, poisson, {c}) -> k_t / k_n``
(at the contact that bounds the step, for its tangential mode) and ``at_limit(fx, fy, fz, fel,
tol, {c}) -> bool`` (F_t on the slider's limit within the relative tolerance ``tol``: a sliding
contact, for the nonlinear pulse's contact flags).

rolling: a couple from the contact's relative rotation with a history (three components, of
which the engines store ``dim``: ``history_width(dim) == dim``, the columns after the tangential
history's in ``pair_ft`` / ``wall_ft``). Numba ``couple({c}, nx, ny, nz, rx, ry, rz, r12, fel,
hx, hy, hz, dt) -> (cx, cy, cz, hx, hy, hz)``, ``spring_couple({c}, nx, ny, nz, rx, ry, rz, r12,
hx, hy, hz) -> (cx, cy, cz)`` (frozen history: the linearization's contract), ``in_plane(hx, hy,
hz, nx, ny, nz)`` (the history carried into the tangent plane) and ``step_mode({c}, m_min) ->
(omega, zeta)`` (its fastest mode, for the time step); in Python ``history_width(dim)``,
``linear_blocks(...)`` and the flag ``NEEDS_FRICTION``.

Every sub-model also declares ``KIND``, ``NAME``, ``SUMMARY`` (one line for the option's help
and the docs' tables), ``DESCRIPTION``, ``PARAMETERS`` (:class:`.declare.Parameter`),
``CONSTANTS``, ``kernel_constants(values)``, ``DEVICE_FUNCTIONS`` (its numba functions in the
order the GPU compiles them, each after those it calls; every formula of its kind among them),
optionally ``DEVICES`` (default both) and its LAMMPS equivalent: the kind's LAMMPS hook (below,
``LAMMPS_HOOKS``) or ``NO_LAMMPS = "why"`` (an explicit "no LAMMPS equivalent": ``export
lammps`` then refuses the selection with that reason).

A kind's sub-models are numbered in registry order (1, 2, ... where the kind has an ``off``
name, which is code 0; 0, 1, ... otherwise); the engines carry the selected one as a named
tuple ``(code, c0, ..., c{n-1})``, n the largest ``len(CONSTANTS)`` of the kind (generated:
granwave.contact_models._dispatch).
"""

from __future__ import annotations

from .declare import Kind, Parameter

#: (function of the sub-model, its dispatcher's name, the dispatcher's arguments after the model,
#: the call's arguments ({c}: the sub-model's own constants c0, c1, ...), what the dispatcher
#: returns when the kind is off)
NORMAL_FUNCTIONS = (
    ("force", "law_force", "overlap, root_r12, e12", "overlap, root_r12, e12, {c}", None),
    ("stiffness", "law_stiffness", "overlap, root_r12, e12", "overlap, root_r12, e12, {c}", None),
    ("energy", "law_energy", "overlap, r12, e12", "overlap, r12, e12, {c}", None),
    ("tangential_stiffness", "law_tangential_stiffness", "overlap, r12, g12", "overlap, r12, g12, {c}", None),
    ("unloading_scale", "law_unloading_scale", "overlap_old, overlap_new", "overlap_old, overlap_new, {c}", None),
    ("step_stiffness", "law_step_stiffness", "overlap, root_r12, e12", "overlap, root_r12, e12, {c}", None),
)
DAMPING_FUNCTIONS = (
    ("acts", "dashpot_acts", "", "{c}", None),
    ("coefficient", "dashpot_coefficient", "meff, k, overlap", "meff, k, overlap, {c}", None),
    ("step_ratio", "dashpot_step_ratio", "k, m", "k, m, {c}", None),
)
TANGENTIAL_FUNCTIONS = (
    ("acts", "friction_acts", "", "{c}", None),
    ("stiffness", "tangential_spring", "kt_law, overlap, e12", "kt_law, overlap, e12, {c}", None),
    ("unloads", "tangential_unloads", "overlap_old, overlap_new, rescale", "overlap_old, overlap_new, rescale, {c}",
     None),
    ("increment", "tangential_increment", "fx, fy, fz, sx, sy, sz, kt, fel", "fx, fy, fz, sx, sy, sz, kt, fel, {c}",
     None),
    ("step_ratio", "tangential_step_ratio", "kn, m, poisson", "kn, m, poisson, {c}", None),
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

#: kind -> the Python hooks that write a sub-model's LAMMPS words (granwave.contact_models.models.
#: lammps_words): a sub-model defines all of them or declares ``NO_LAMMPS = "why"``.
#: normal: ``lammps_words(values, e12_pair, e12_wall, g12_pair, g12_wall) -> dict`` (kn_pair,
#: kn_wall, kt_pair, kt_wall, normal, tangential) and ``LAMMPS_RESTITUTION_SCALE``; damping:
#: ``lammps_words(values, scale, normal, kt_over_kn) -> dict`` (normal_damping: the number after
#: k_n in the normal model, xgammat, damping_words; ``kt_over_kn`` None where k_t / k_n is not
#: constant); tangential: ``lammps_tangential(values, words, side, xgammat) -> "tangential ..."``
#: (``words``: the normal law's, ``side``: "pair" or "wall") and ``lammps_stiffness_ratio(values,
#: words) -> k_t / k_n or None``; rolling: ``lammps_fragment(values) -> "rolling ..."``
LAMMPS_HOOKS = {
    "normal": ("lammps_words", "LAMMPS_RESTITUTION_SCALE"),
    "damping": ("lammps_words",),
    "tangential": ("lammps_tangential", "lammps_stiffness_ratio"),
    "rolling": ("lammps_fragment",),
}

NORMAL = Kind("normal", option="contact_law", help="Normal contact law", default="hertz", recorded=True,
              reader="law_of", functions=NORMAL_FUNCTIONS,
              python=("overlap_at_force", "IMPACT_WORK"))
DAMPING = Kind("damping", option="damping_law", help="Contact damping law", default="critical_fraction",
               fields=("damping",), reader="dashpot_of", functions=DAMPING_FUNCTIONS,
               parameters=(Parameter("damping", 0.5, None, "Contact damping zeta, fraction of critical (normal "
                                     "and tangential).", lo=0.0, hi=1.0),))
TANGENTIAL = Kind("tangential", option="tangential", help="Tangential contact law", default="mindlin",
                  fields=("friction",), leading=("friction",), reader="friction_of", functions=TANGENTIAL_FUNCTIONS,
                  parameters=(Parameter("friction", 0.5, None, "Coulomb friction coefficient mu (0: frictionless, "
                                        "no rotational degrees of freedom).", lo=0.0),
                              Parameter("poisson", 0.0, None, "Poisson ratio nu of the grains: k_t/k_n = "
                                        "2(1-nu)/(2-nu).", lo=0.0, hi=0.5, hi_open=True)))
ROLLING = Kind("rolling", option="rolling", help="Rolling resistance", default="none", off="none",
               history="rolling_displacement",
               history_help="rolling displacement xi of the rolling spring (root attribute rolling)",
               reader="couple_of", functions=ROLLING_FUNCTIONS, python=("history_width", "linear_blocks"))

#: every kind the engines call, in the order their models are passed
KINDS = (NORMAL, DAMPING, TANGENTIAL, ROLLING)
