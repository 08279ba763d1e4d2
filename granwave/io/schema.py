"""The HDF5 layout of every granwave file: the one place names live.

Every file carries root attributes ``schema`` (one of the names below) and
``schema_version`` ("MAJOR.MINOR"). Readers refuse another schema or another
major version; changes within a major version only add names.

Trees (dataset: shape, units)::

    granwave.packing                       (prepare-packing, lattice, chain)
    ├── grains/position          (N, dim)   d
    ├── grains/radius            (N,)       d
    ├── grains/mass              (N,)       rho d^3
    ├── grains/inertia           (N,)       rho d^5
    ├── box/size                 (dim,)     d   periodic lengths; last = wall-to-piston distance
    └── contacts/                (M rows, force-carrying contacts only)
        ├── i, j                 (M,)       int; j = -1 bottom wall, -2 top wall/piston
        ├── normal               (M, dim)   unit vector from i towards j
        ├── overlap              (M,)       d
        ├── force_normal         (M,)       E* d^2  magnitude; force on i is -force_normal*normal
        ├── force_tangential     (M, dim)   E* d^2  tangential force on i from j
        ├── stiffness_normal     (M,)       E* d
        ├── stiffness_tangential (M,)       E* d
        └── <history>            (M, dim)   optional: a contact sub-model's history, e.g.
                                            rolling_displacement (d; attribute rolling: the rolling spring's xi)

    granwave.linear                        (linearize)
    ├── matrix/data, matrix/indices, matrix/indptr    CSR of D (n, n)   E* d (per dof units)
    ├── mass                     (n,)       rho d^3 (translation) / rho d^5 (rotation)
    ├── dof/grain                (n,)       int, grain index in the packing
    ├── dof/axis                 (n,)       int, 0..dim-1 translation, dim.. rotation
    ├── source/velocity          (n,)       initial velocity of IC A
    ├── source/displacement      (n,)       initial displacement of IC B
    ├── detector                 (n,)       F_sig = detector . u   (E* d)
    ├── shear/source_velocity    (n,)       optional (friction > 0): IC A of the shear kick
    └── shear/detector           (n,)       optional: F_sig = shear/detector . u (top wall, x)

    granwave.modes                         (eigensolve)
    ├── omega2                   (n,)       1/t^2, ascending
    ├── amplitude_A, amplitude_B (n,)       a_n for IC A / B (mass-normalized modes)
    ├── coupling                 (n,)       b_n = detector . phi_n
    ├── shear/amplitude_A, shear/coupling (n,)  optional: a_n, b_n of the shear kick
    └── vectors                  (n, n)     optional, columns phi_n (M-orthonormal)

    granwave.signal                        (propagate; root attribute source_kind "normal"
                                            or "shear", absent before 1.2: read as "normal")
    ├── signal/time              (T,)       t
    ├── signal/force             (T,)       E* d^2
    ├── snapshots/time           (S,)       optional
    ├── snapshots/displacement   (S, n)     optional
    ├── snapshots/dof_grain, snapshots/dof_axis (n,)  optional
    ├── snapshots/position       (N, dim)   optional, reference positions
    └── pulse/...                (B,), (B, T) optional (DEM pulses, since 1.3): the pulse field by
                                            height bin: time, height, count, velocity,
                                            force_max, force_initial, arrival (docs/shocks.md);
                                            (T,) since 1.4: the contact counts so far, opened,
                                            formed, sliding_new

    granwave.ensemble                      (analyze ensemble)
    ├── ensemble/time, ensemble/mean, ensemble/rms   (T,)

The tables below (``DATASETS``) give units and a description of each name
(units in pint's grammar over granwave's reduced units, :mod:`granwave.units`;
the tree above abbreviates them), ``DIMS`` the dimension names of each axis
(HDF5 dimension scales: the files open in xarray with named dimensions, since
version 1.1) and ``EXTRA_ATTRS`` the attributes that link contacts to grains and
tell rotations from translations; ``docs/formats.md`` is generated from them by
``python -m granwave.io.schema``.
"""

from __future__ import annotations

from .. import units as U
from ..contact_models import options as CO
from ..model import BOTTOM_WALL, TOP_WALL  # noqa: F401  (the file's contacts/j codes)

# a_n of u = sum_n a_n phi_n with M-orthonormal phi_n in (rho d^3)^-1/2: a_n b_n is a force
AMPLITUDE = "d_bar * (rho * d_bar**3)**0.5"

PACKING = "granwave.packing"
LINEAR = "granwave.linear"
MODES = "granwave.modes"
SIGNAL = "granwave.signal"
ENSEMBLE = "granwave.ensemble"
SWEEP = "granwave.sweep"

VERSIONS = {
    PACKING: "1.1",
    LINEAR: "1.2",
    MODES: "1.2",
    SIGNAL: "1.4",
    ENSEMBLE: "1.1",
    SWEEP: "1.1",
}

# Wall indices in contacts/j: the model's (granwave.model), written as they are.

# dof/axis codes: 0..dim-1 translations, dim..(rotations) about x, y, z; in 3D a grain
# whose free spin was removed keeps two rotations about the pair normal to its spin
# axis, codes 6 and 7 (granwave.linear.assemble.spin_basis).
SPIN_REDUCED_AXES = (6, 7)

# name -> (units, description), per schema.
DATASETS: dict[str, dict[str, tuple[str, str]]] = {
    PACKING: {
        "grains/position": (U.LENGTH, "grain centres (N, dim); bottom wall at 0 along the last axis"),
        "grains/radius": (U.LENGTH, "grain radii (N,)"),
        "grains/mass": (U.MASS, "grain masses rho*pi*d^3/6 (N,)"),
        "grains/inertia": (U.INERTIA, "moments of inertia m d^2/10 (N,)"),
        "box/size": (U.LENGTH, "periodic lengths, then the bottom-wall-to-piston distance (dim,)"),
        "contacts/i": (U.DIMENSIONLESS, "first grain of a contact (M,)"),
        "contacts/j": (U.DIMENSIONLESS, "second grain, or -1 bottom wall, -2 top wall (M,)"),
        "contacts/normal": (U.DIMENSIONLESS, "unit vector from i towards j (M, dim)"),
        "contacts/overlap": (U.LENGTH, "overlap R_i + R_j - r_ij (M,)"),
        "contacts/force_normal": (U.FORCE, "normal force magnitude; force on i is -f n (M,)"),
        "contacts/force_tangential": (U.FORCE, "tangential force on i from j (M, dim)"),
        "contacts/stiffness_normal": (U.STIFFNESS, "k_n = dF_n/dn (M,)"),
        "contacts/stiffness_tangential": (U.STIFFNESS, "k_t (Mindlin) (M,)"),
        # the contact sub-models' histories (granwave.contact_models.kinds), optional
        **{f"contacts/{k['history']}": (U.LENGTH, f"{k['history_help']}, optional (M, dim)")
           for k in CO.KINDS.values() if k["history"]},
    },
    LINEAR: {
        "matrix/data": (U.STIFFNESS, "CSR data of the stiffness matrix D"),
        "matrix/indices": (U.DIMENSIONLESS, "CSR column indices"),
        "matrix/indptr": (U.DIMENSIONLESS, "CSR row pointers"),
        "mass": (U.MASS, "diagonal of M (mass or moment of inertia) (n,)"),
        "dof/grain": (U.DIMENSIONLESS, "grain index of each degree of freedom (n,)"),
        "dof/axis": (U.DIMENSIONLESS, "0..dim-1 translation axis, dim.. rotation axis (n,)"),
        "source/velocity": (U.SPEED, "initial velocity vector of initial condition A (n,)"),
        "source/displacement": (U.LENGTH, "initial displacement vector of initial condition B (n,)"),
        "detector": (U.STIFFNESS, "F_sig = detector . u (n,)"),
        "shear/source_velocity": (U.SPEED, "initial velocity of the shear kick (bottom wall along x, "
                                  "initial condition A); only with friction (n,)"),
        "shear/detector": (U.STIFFNESS, "F_sig = shear/detector . u, the top wall's force along x; "
                           "only with friction (n,)"),
    },
    MODES: {
        "omega2": (U.OMEGA2, "eigenvalues omega^2 of D phi = omega^2 M phi, ascending (n,)"),
        "amplitude_A": (AMPLITUDE, "a_n for initial condition A: u = sum a_n phi_n sin(w_n t) (n,)"),
        "amplitude_B": (AMPLITUDE, "a_n for initial condition B: u = sum a_n phi_n cos(w_n t) (n,)"),
        "coupling": (U.STIFFNESS + " / (rho * d_bar**3)**0.5", "b_n = detector . phi_n (n,)"),
        "shear/amplitude_A": (AMPLITUDE, "a_n of the shear kick (initial condition A), optional (n,)"),
        "shear/coupling": (U.STIFFNESS + " / (rho * d_bar**3)**0.5",
                           "b_n = shear/detector . phi_n, optional (n,)"),
        "vectors": ("(rho * d_bar**3)**-0.5", "M-orthonormal eigenvectors as columns (n, n), optional"),
    },
    SIGNAL: {
        "signal/time": (U.TIME, "sample times (T,)"),
        "signal/force": (U.FORCE, "extra force on the top wall: vertical, or along x when the root "
                         "attribute source_kind is shear (T,)"),
        "snapshots/time": (U.TIME, "snapshot times (S,)"),
        "snapshots/displacement": (U.LENGTH, "displacement field at the snapshot times (S, n)"),
        "snapshots/dof_grain": (U.DIMENSIONLESS, "grain index of each dof (n,)"),
        "snapshots/dof_axis": (U.DIMENSIONLESS, "axis of each dof (n,)"),
        "snapshots/position": (U.LENGTH, "equilibrium grain positions (N, dim)"),
        "pulse/time": (U.TIME, "sample times of the pulse field, those of signal/time (T,)"),
        "pulse/height": (U.LENGTH, "centre of each height bin of the pulse field, from the bottom wall (B,)"),
        "pulse/count": (U.DIMENSIONLESS, "grains in each bin, by their height at t = 0 (B,)"),
        "pulse/velocity": (U.SPEED, "mean velocity of each bin's grains along the kick (vertical, or x "
                           "for the shear source) at each sample (B, T)"),
        "pulse/force_max": (U.FORCE, "largest normal force of a grain-grain contact with its midpoint in "
                            "the bin, over the samples of the record (B,)"),
        "pulse/force_initial": (U.FORCE, "the same at t = 0 (B,)"),
        "pulse/arrival": (U.TIME, "the front's arrival in each bin (the front pick of the root attribute "
                          "front_pick); NaN where the bin has no front (B,)"),
        "pulse/opened": (U.DIMENSIONLESS, "contacts of t = 0 that lost their overlap at some step up to each "
                         "sample (T,)"),
        "pulse/formed": (U.DIMENSIONLESS, "contacts absent at t = 0 that gained an overlap at some step up to "
                         "each sample (T,)"),
        "pulse/sliding_new": (U.DIMENSIONLESS, "contacts not on their slider's limit at t = 0 that reached it "
                              "at some step up to each sample (T,)"),
    },
    ENSEMBLE: {
        "ensemble/time": (U.TIME, "common time grid (T,)"),
        "ensemble/mean": (U.FORCE, "average signal (T,)"),
        "ensemble/rms": (U.FORCE, "root-mean-square deviation from the average (T,)"),
    },
    SWEEP: {
        "sweep/pressure": (U.PRESSURE, "the pressures of the sweep, ascending (P,)"),
        "sweep/n_samples": (U.DIMENSIONLESS, "number of sample summaries per pressure (P,)"),
        "sweep/quantity": (U.DIMENSIONLESS, "names of the summarized quantities, 'section.key' (Q,) bytes"),
        "sweep/mean": (U.DIMENSIONLESS, "mean over the samples of each pressure (P, Q); NaN if none"),
        "sweep/std": (U.DIMENSIONLESS, "sample standard deviation (1/(n-1)) (P, Q); NaN if n < 2"),
        "sweep/count": (U.DIMENSIONLESS, "number of samples with a finite value (P, Q)"),
        "sweep/c_tof": (U.SPEED, "time-of-flight speed (10% edge) per pressure (P,)"),
        "sweep/c_tof_err": (U.SPEED, "its uncertainty (P,)"),
        "sweep/c_l": (U.SPEED, "continuum longitudinal speed sqrt(C22/phi3*) (P,)"),
        "sweep/c_l_err": (U.SPEED, "its uncertainty (standard error of the mean) (P,)"),
        "sweep/c_t": (U.SPEED, "continuum transverse speed sqrt(C33/phi3*) (P,)"),
        "sweep/c_t_err": (U.SPEED, "its uncertainty (standard error of the mean) (P,)"),
        "sweep/c_tof_over_c_l": (U.DIMENSIONLESS, "c_tof / c_l per pressure (P,)"),
        "sweep/c_tof_over_c_l_err": (U.DIMENSIONLESS, "its propagated uncertainty (P,)"),
        "sweep/lattice_frictionless": (U.SPEED, "triangular-lattice speed, no friction (P,)"),
        "sweep/lattice_frictional": (U.SPEED, "triangular-lattice speed with friction (P,)"),
    },
}

# ---------------------------------------------------------------- named dimensions
# Every dataset's axes are named (HDF5 dimension scales, so that xarray, netCDF and
# other HDF5 tools see them): name -> dimension names, per schema. A dimension
# whose name is also a dataset of the same group (signal/time, sweep/pressure) has
# that dataset as its coordinate; the others are plain dimensions stored at the
# root ("axis" with the labels x, y[, z]). The linear file names its degree-of-
# freedom dimension ``dof_index`` because ``dof`` is already the name of its group
# of per-dof tables (HDF5 allows one object per name).
AXIS_LABELS = ("x", "y", "z")
_P = ("grain",)
_C = ("contact",)
DIMS: dict[str, dict[str, tuple[str, ...]]] = {
    PACKING: {
        "grains/position": ("grain", "axis"), "grains/radius": _P, "grains/mass": _P,
        "grains/inertia": _P, "box/size": ("axis",),
        "contacts/i": _C, "contacts/j": _C, "contacts/normal": ("contact", "axis"),
        "contacts/overlap": _C, "contacts/force_normal": _C,
        "contacts/force_tangential": ("contact", "axis"), "contacts/stiffness_normal": _C,
        "contacts/stiffness_tangential": _C,
        **{f"contacts/{h}": ("contact", "axis") for h in CO.history_datasets()},
    },
    LINEAR: {
        "matrix/data": ("nonzero",), "matrix/indices": ("nonzero",), "matrix/indptr": ("row_pointer",),
        "mass": ("dof_index",), "dof/grain": ("dof_index",), "dof/axis": ("dof_index",),
        "source/velocity": ("dof_index",), "source/displacement": ("dof_index",),
        "detector": ("dof_index",),
        "shear/source_velocity": ("dof_index",), "shear/detector": ("dof_index",),
    },
    MODES: {
        "omega2": ("mode",), "amplitude_A": ("mode",), "amplitude_B": ("mode",),
        "coupling": ("mode",), "vectors": ("dof", "mode"),
        "shear/amplitude_A": ("mode",), "shear/coupling": ("mode",),
    },
    SIGNAL: {
        "signal/time": ("time",), "signal/force": ("time",),
        "snapshots/time": ("time",), "snapshots/displacement": ("time", "dof"),
        "snapshots/dof_grain": ("dof",), "snapshots/dof_axis": ("dof",),
        "snapshots/position": ("grain", "axis"),
        "pulse/time": ("time",), "pulse/height": ("height",), "pulse/count": ("height",),
        "pulse/velocity": ("height", "time"), "pulse/force_max": ("height",),
        "pulse/force_initial": ("height",), "pulse/arrival": ("height",),
        "pulse/opened": ("time",), "pulse/formed": ("time",), "pulse/sliding_new": ("time",),
    },
    ENSEMBLE: {"ensemble/time": ("time",), "ensemble/mean": ("time",), "ensemble/rms": ("time",)},
    SWEEP: {name: (("pressure", "quantity") if name in ("sweep/mean", "sweep/std", "sweep/count")
                   else ("quantity",) if name == "sweep/quantity" else ("pressure",))
            for name in DATASETS[SWEEP]},
}

# Extra attributes of some datasets. Contacts name their grains through CF's
# ``coordinates`` (xarray makes contacts/i and contacts/j coordinates of every
# contact variable). Datasets along the degrees of freedom mix translations and
# rotations: ``units`` holds the translations' units, ``units_rotation`` the
# rotations', and ``units_rule`` says how to tell the rows apart.
_ROT_RULE = ("rows with {axis} < dim (root attribute) are translations, in units; rows with "
             "{axis} >= dim are rotations (radians), in units_rotation")
_CONTACT_COORDS = {"coordinates": "i j"}
EXTRA_ATTRS: dict[str, dict[str, dict[str, str]]] = {
    PACKING: {
        **{name: _CONTACT_COORDS for name in DATASETS[PACKING]
           if name.startswith("contacts/") and name not in ("contacts/i", "contacts/j")},
        "contacts/i": {"refers_to": "grains (index along the grain dimension)"},
        "contacts/j": {"refers_to": "grains (index along the grain dimension); -1 bottom wall, "
                                     "-2 top wall / piston"},
    },
    LINEAR: {
        "mass": {"units_rotation": U.INERTIA, "units_rule": _ROT_RULE.format(axis="dof/axis")},
        "source/velocity": {"units_rotation": U.ANGULAR_SPEED,
                            "units_rule": _ROT_RULE.format(axis="dof/axis")},
        "source/displacement": {"units_rotation": U.DIMENSIONLESS,
                                "units_rule": _ROT_RULE.format(axis="dof/axis")},
        "detector": {"units_rotation": U.FORCE, "units_rule": _ROT_RULE.format(axis="dof/axis")},
        "shear/source_velocity": {"units_rotation": U.ANGULAR_SPEED,
                                  "units_rule": _ROT_RULE.format(axis="dof/axis")},
        "shear/detector": {"units_rotation": U.FORCE, "units_rule": _ROT_RULE.format(axis="dof/axis")},
        "matrix/data": {"units_translation_rotation": U.FORCE, "units_rotation": U.TORQUE,
                        "units_rule": "entry (r, c) of D is in units when r and c are translations "
                                      "(dof/axis < dim), units_translation_rotation when one is a "
                                      "rotation, units_rotation when both are"},
        "dof/grain": {"refers_to": "grains of the packing this was linearized from"},
    },
    MODES: {
        "vectors": {"units_rotation": "(rho * d_bar**5)**-0.5",
                    "units_rule": _ROT_RULE.format(axis="dof/axis of the linear file")},
    },
    SIGNAL: {
        "snapshots/displacement": {"units_rotation": U.DIMENSIONLESS,
                                   "units_rule": _ROT_RULE.format(axis="snapshots/dof_axis")},
    },
    ENSEMBLE: {},
    SWEEP: {
        name: {"units_rule": "per column: the units of the summary quantity named in sweep/quantity"}
        for name in ("sweep/mean", "sweep/std")
    },
}

# name -> (dtype kind, shape), per schema: what the validator (granwave.io.validate) checks
# before any reader uses a dataset. Kind "f" float, "i" integer (signed or unsigned), "S"
# bytes. A shape is a tuple of symbols shared within one file (a symbol takes its value
# at its first dataset, in table order; "n+1" is one more than n) or of integers; "dim"
# is the root attribute of that name. OPTIONAL names may be absent; a GROUPS entry is
# all present or all absent.
LAYOUT: dict[str, dict[str, tuple[str, tuple]]] = {
    PACKING: {
        "grains/position": ("f", ("N", "dim")),
        "grains/radius": ("f", ("N",)),
        "grains/mass": ("f", ("N",)),
        "grains/inertia": ("f", ("N",)),
        "box/size": ("f", ("dim",)),
        "contacts/i": ("i", ("M",)),
        "contacts/j": ("i", ("M",)),
        "contacts/normal": ("f", ("M", "dim")),
        "contacts/overlap": ("f", ("M",)),
        "contacts/force_normal": ("f", ("M",)),
        "contacts/force_tangential": ("f", ("M", "dim")),
        "contacts/stiffness_normal": ("f", ("M",)),
        "contacts/stiffness_tangential": ("f", ("M",)),
        **{f"contacts/{h}": ("f", ("M", "dim")) for h in CO.history_datasets()},
    },
    LINEAR: {
        "mass": ("f", ("n",)),
        "matrix/indptr": ("i", ("n+1",)),
        "matrix/data": ("f", ("nnz",)),
        "matrix/indices": ("i", ("nnz",)),
        "dof/grain": ("i", ("n",)),
        "dof/axis": ("i", ("n",)),
        "source/velocity": ("f", ("n",)),
        "source/displacement": ("f", ("n",)),
        "detector": ("f", ("n",)),
        "shear/source_velocity": ("f", ("n",)),
        "shear/detector": ("f", ("n",)),
    },
    MODES: {
        "omega2": ("f", ("n",)),
        "amplitude_A": ("f", ("n",)),
        "amplitude_B": ("f", ("n",)),
        "coupling": ("f", ("n",)),
        "shear/amplitude_A": ("f", ("n",)),
        "shear/coupling": ("f", ("n",)),
        "vectors": ("f", ("n_dof", "n")),
    },
    SIGNAL: {
        "signal/time": ("f", ("T",)),
        "signal/force": ("f", ("T",)),
        "snapshots/time": ("f", ("S",)),
        "snapshots/displacement": ("f", ("S", "n")),
        "snapshots/dof_grain": ("i", ("n",)),
        "snapshots/dof_axis": ("i", ("n",)),
        "snapshots/position": ("f", ("N", "d")),
        "pulse/time": ("f", ("T",)),
        "pulse/height": ("f", ("B",)),
        "pulse/count": ("i", ("B",)),
        "pulse/velocity": ("f", ("B", "T")),
        "pulse/force_max": ("f", ("B",)),
        "pulse/force_initial": ("f", ("B",)),
        "pulse/arrival": ("f", ("B",)),
        "pulse/opened": ("i", ("T",)),
        "pulse/formed": ("i", ("T",)),
        "pulse/sliding_new": ("i", ("T",)),
    },
    ENSEMBLE: {
        "ensemble/time": ("f", ("T",)),
        "ensemble/mean": ("f", ("T",)),
        "ensemble/rms": ("f", ("T",)),
    },
    SWEEP: {
        "sweep/pressure": ("f", ("P",)),
        "sweep/n_samples": ("i", ("P",)),
        "sweep/quantity": ("S", ("Q",)),
        "sweep/mean": ("f", ("P", "Q")),
        "sweep/std": ("f", ("P", "Q")),
        "sweep/count": ("i", ("P", "Q")),
        **{f"sweep/{k}": ("f", ("P",)) for k in (
            "c_tof", "c_tof_err", "c_l", "c_l_err", "c_t", "c_t_err", "c_tof_over_c_l",
            "c_tof_over_c_l_err", "lattice_frictionless", "lattice_frictional")},
    },
}

#: Datasets a file may lack.
#: The pulse field of a DEM pulse (granwave.dem.pulse), all or none.
PULSE_DATASETS = ("pulse/time", "pulse/height", "pulse/count", "pulse/velocity", "pulse/force_max",
                  "pulse/force_initial", "pulse/arrival")
#: The pulse's contact counts at every sample (since 1.4), all or none.
PULSE_CONTACTS = ("pulse/opened", "pulse/formed", "pulse/sliding_new")
OPTIONAL: dict[str, frozenset[str]] = {
    PACKING: frozenset(f"contacts/{h}" for h in CO.history_datasets()), ENSEMBLE: frozenset(), SWEEP: frozenset(),
    LINEAR: frozenset({"shear/source_velocity", "shear/detector"}),
    MODES: frozenset({"vectors", "shear/amplitude_A", "shear/coupling"}),
    SIGNAL: frozenset({"snapshots/time", "snapshots/displacement", "snapshots/dof_grain",
                       "snapshots/dof_axis", "snapshots/position", *PULSE_DATASETS, *PULSE_CONTACTS}),
}

#: Optional datasets that come together (all or none).
GROUPS: dict[str, tuple[frozenset[str], ...]] = {
    LINEAR: (frozenset({"shear/source_velocity", "shear/detector"}),),
    MODES: (frozenset({"shear/amplitude_A", "shear/coupling"}),),
    SIGNAL: (frozenset({"snapshots/time", "snapshots/displacement", "snapshots/dof_grain",
                        "snapshots/dof_axis"}), frozenset(PULSE_DATASETS), frozenset(PULSE_CONTACTS)),
}

# Root attributes every file of a schema must carry (beyond schema, schema_version,
# granwave_version, git_revision, command_line, software, machine).
REQUIRED_ATTRS: dict[str, tuple[str, ...]] = {
    PACKING: ("dim", "pressure", "friction", "poisson", "seed", "converged", "max_acceleration", "kind"),
    LINEAR: ("dim", "pressure", "friction", "height", "prestress"),
    MODES: ("dim", "pressure", "height", "n_zero_modes"),
    SIGNAL: ("ic", "method", "height"),
    ENSEMBLE: ("n_signals",),
    SWEEP: (),
}


# Types of the root attributes the stages read (any schema: a name means the same thing in
# every file). "number": an int or float scalar (not a bool, not a string); "int": an integer
# scalar; "bool": a boolean scalar (HDF5 enum) or the integers 0 and 1; "str": a string;
# "int[]": a 1D integer array. A reader refuses another type before any stage sees the value
# (granwave.io.validate.attr_types): a string "False" where a bool belongs would be true, an
# array where a scalar belongs fails deep inside. A number that was None when written is the
# string "none" (files._set_attr); it is accepted for attributes a schema does not require.
ATTR_TYPES: dict[str, str] = {
    **dict.fromkeys((
        "pressure", "friction", "poisson", "height", "max_acceleration", "t_max", "dt", "damping",
        "amplitude", "safety", "omega_max", "omega2_max", "omega_max_band", "nyquist_ratio",
        "zero_mode_threshold", "max_displacement", "height_mean", "height_std", "piston_mass",
        "background_damping_rate", "modified_energy_max_rel_deviation", "asymmetry",
        "contact_force", "wall_force", "spacing", "row_spacing", "polydispersity", "stiffness",
        *CO.PARAMETERS),  # the contact sub-models' parameters (granwave.contact_models)
        "number"),
    **dict.fromkeys((
        "dim", "seed", "n_zero_modes", "n_negative_modes", "expected_zero_modes", "n_rotations",
        "n_dof", "n_modes", "n_signals", "samples", "n_grains", "steps", "n_steps", "rebuilds",
        "n_rattlers", "n_spins_removed", "n_free_spins", "n_contacts", "rows", "width", "balls", "grains",
        "packing_seed"), "int"),
    **dict.fromkeys((
        "converged", "prestress", "aliased", "partial", "has_vectors", "forced_unconverged",
        "n_zero_modes_exact", "psd_check_converged", "modal_truncated"), "bool"),
    **dict.fromkeys((
        "schema", "schema_version", "kind", "ic", "method", "linear_source", "modes_source",
        "source_file", "packing_source", "device", "linear_digest", "packing_digest",
        *(k["option"] for k in CO.KINDS.values())), "str"),  # the contact sub-models' selection
    "spin_removed_grains": "int[]",
}


def formats_markdown() -> str:
    """The docs/formats.md text, generated from the tables above."""
    lines = [
        "# granwave file formats",
        "",
        "Generated by `python -m granwave.io.schema > docs/formats.md`; do not edit by hand.",
        "",
        "Every file is HDF5 with root attributes `schema`, `schema_version`, `granwave_version`,",
        "`git_revision`, `command_line`, `software` (the versions of Python, numpy, scipy, numba,",
        "llvmlite and h5py), `machine` (the CPU and numpy's SIMD loops on it), the run's parameters,",
        "and a `units` attribute on every dataset. Readers refuse another schema or another major",
        "version.",
        "Wall indices in `contacts/j`: bottom wall = -1, top wall / piston = -2.",
        "",
        "## Opening a file in xarray",
        "",
        "Every axis of every dataset is a named dimension (HDF5 dimension scales, which",
        "netCDF-4, h5netcdf and other HDF5 tools read too), so any granwave file opens as",
        "a tree of labelled arrays:",
        "",
        "```python",
        "import xarray as xr",
        'tree = xr.open_datatree("signal.h5", engine="h5netcdf")',
        'tree["signal"].dataset["force"].sel(time=10.0, method="nearest")',
        "```",
        "",
        "Coordinates: `signal/force` is indexed by `signal/time` (likewise `snapshots/time`,",
        "`ensemble/time`, `sweep/pressure`, `sweep/quantity`); every `contacts/*` variable",
        "carries the grains `i` and `j` of its contact as coordinates; `axis` is labelled",
        "x, y (, z). Dimensions without a coordinate (`grain`, `contact`, `mode`, `dof`, ...)",
        "are plain netCDF dimensions. The linear file's degree-of-freedom dimension is",
        "`dof_index`, since `dof` is the name of its group of per-dof tables.",
        "Files written before version 1.1 have no dimension scales: open them with",
        '`xr.open_datatree(path, engine="h5netcdf", phony_dims="sort")`.',
        "",
        "## Units",
        "",
        "`units` attributes are written for the [pint](https://pint.readthedocs.io) units",
        "library in granwave's reduced units (docs/method.md §1): `d_bar` (mean grain",
        "diameter), `rho` (grain density), `E_star` (grain modulus E/(1-nu^2)); time is",
        "`d_bar * (rho / E_star)**0.5`. They are defined once, in `granwave.units`:",
        "",
        "```python",
        "from granwave.units import registry",
        "ureg = registry()                                   # reduced units",
        'ureg = registry(diameter="1 mm", density="2500 kg/m^3", modulus="70 GPa")  # to SI',
        'ureg.parse_units(tree["signal"].dataset["time"].attrs["units"])',
        "```",
        "",
        "Datasets along the degrees of freedom mix translations and rotations (the linear",
        "file's `mass` holds masses, rho d^3, and moments of inertia, rho d^5): there `units`",
        "(= `units_translation`) holds the translations' units, `units_rotation` the",
        "rotations' (rotations in radians), and `units_rule` says which rows are which",
        "(`dof/axis` >= `dim`: a rotation). `matrix/data` has a third kind,",
        "`units_translation_rotation`, for entries coupling a translation to a rotation.",
        "Every reader validates a file before any stage uses it (`granwave/io/validate.py`):",
        "presence, dtype and shape of every dataset as in the tables below (a symbol such as",
        "N stands for the same size throughout one file; `dim` is the root attribute), index",
        "ranges (CSR `indptr` from 0 to nnz and non-decreasing, `indices` and contact indices",
        "in range), finite values, and the physical invariants: radii, masses, moments of",
        "inertia and box lengths > 0; centres between the walls; overlaps >= 0 and at most",
        "half the smaller radius; no two centres closer than the radii and the stored",
        "overlap allow; friction >= 0, 0 <= Poisson ratio < 0.5, pressure >= 0, height > 0.",
        "Also: no file without grains, degrees of freedom or modes; CSR column indices sorted",
        "and unique within each row; D not all zero; k_n > 0 where grains overlap; every float",
        "value within +-1e100 (time axes: finite) and every positive quantity at least 1e-100;",
        "sample times (signals, ensembles) at least two, increasing and evenly spaced (to 1e-6",
        "of the step); root attributes of the types the stages take (a number, an integer, a",
        "boolean, a string: never an array, nor a string where a number or boolean belongs).",
        "Arrays are converted to native float64 / int64 when that is exact (another byte order,",
        "float32, other integer widths; long double only when every value is a float64);",
        "otherwise refused. A modes file's `linear_source` is relative to its own folder (or",
        "absolute), and the linear file found must be the one the modes came from",
        "(`linear_digest`, sizes, sample attributes); `packing_digest` ties linear, modes and",
        "signal files to their packing the same way.",
        "A failure is one line naming the file, the dataset and what is wrong.",
        "",
    ]
    for schema, table in DATASETS.items():
        lines += [f"## `{schema}` (version {VERSIONS[schema]})", ""]
        req = ", ".join(f"`{a}`" for a in REQUIRED_ATTRS[schema]) or "none beyond provenance"
        lines += [f"Required root attributes: {req}.", ""]
        if table:
            dims = DIMS.get(schema, {})
            extra = EXTRA_ATTRS.get(schema, {})
            layout, optional = LAYOUT.get(schema, {}), OPTIONAL.get(schema, frozenset())
            lines += ["| dataset | dtype | shape | dimensions | units | meaning |",
                      "|---|---|---|---|---|---|"]
            for name, (units, desc) in table.items():
                kind, shape = layout.get(name, ("", ()))
                dtype = {"f": "float", "i": "int", "S": "bytes"}.get(kind, "")
                sizes = f"({', '.join(map(str, shape))}{',' if len(shape) == 1 else ''})" if kind else ""
                flag = " (optional)" if name in optional else ""
                dim = ", ".join(dims.get(name, ()))
                unit = f"`{units}`"
                if "units_rotation" in extra.get(name, {}):
                    unit += f"; rotations `{extra[name]['units_rotation']}`"
                lines.append(f"| `{name}`{flag} | {dtype} | {sizes} | ({dim}) | {unit} | {desc} |")
            lines.append("")
    lines += [
        "## Checkpoints (internal; `prepare-packing --checkpoint`)",
        "",
        "Not a granwave file kind: read only by `granwave.dem.checkpoint`, no schema, no units,",
        "a layout that may change with granwave's code (a checkpoint of other code is refused).",
        "HDF5 with root attributes `kind` = `granwave.checkpoint`, `version`, `params_digest`",
        "(the preparation's parameters, seed included) and `source_digest` (granwave's source),",
        "`device` (`cpu` or `gpu`: the device that wrote it, the only one that resumes it),",
        "`prepare_params` (JSON), `granwave_version`, `step`, `written` (UTC) and `rules` (JSON:",
        "the state of the settling and end-game rules); group `engine/`: the engine's arrays",
        "(positions, velocities, spins, accelerations, the pair list with its tangential",
        "histories, the wall contacts' histories; the records `piston`, `fpar`, `ipar`, `out` as",
        "one-element compound datasets, their fields named as in `granwave/dem/layout.py` (version 2;",
        "version 1 stored them as numbered float arrays and is refused); the mean-flow rates and slab",
        "means, and `ws_<name>`: the neighbour lists, pair constants and wall list of the last",
        "rebuild); `run/history` and",
        "`run/speeds`: (step, max |a|) and (step, largest speed) after every chunk of steps.",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    print(formats_markdown())
