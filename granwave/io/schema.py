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
        └── stiffness_tangential (M,)       E* d

    granwave.linear                        (linearize)
    ├── matrix/data, matrix/indices, matrix/indptr    CSR of D (n, n)   E* d (per dof units)
    ├── mass                     (n,)       rho d^3 (translation) / rho d^5 (rotation)
    ├── dof/grain                (n,)       int, grain index in the packing
    ├── dof/axis                 (n,)       int, 0..dim-1 translation, dim.. rotation
    ├── source/velocity          (n,)       initial velocity of IC A
    ├── source/displacement      (n,)       initial displacement of IC B
    └── detector                 (n,)       F_sig = detector . u   (E* d)

    granwave.modes                         (eigensolve)
    ├── omega2                   (n,)       1/t^2, ascending
    ├── amplitude_A, amplitude_B (n,)       a_n for IC A / B (mass-normalized modes)
    ├── coupling                 (n,)       b_n = detector . phi_n
    └── vectors                  (n, n)     optional, columns phi_n (M-orthonormal)

    granwave.signal                        (propagate)
    ├── signal/time              (T,)       t
    ├── signal/force             (T,)       E* d^2
    ├── snapshots/time           (S,)       optional
    ├── snapshots/displacement   (S, n)     optional
    ├── snapshots/dof_grain, snapshots/dof_axis (n,)  optional
    └── snapshots/position       (N, dim)   optional, reference positions

    granwave.ensemble                      (analyze ensemble)
    ├── ensemble/time, ensemble/mean, ensemble/rms   (T,)

The tables below (``DATASETS``) give units and a description of each name;
``docs/formats.md`` is generated from them by ``python -m granwave.io.schema``.
"""

from __future__ import annotations

PACKING = "granwave.packing"
LINEAR = "granwave.linear"
MODES = "granwave.modes"
SIGNAL = "granwave.signal"
ENSEMBLE = "granwave.ensemble"
SWEEP = "granwave.sweep"

VERSIONS = {
    PACKING: "1.0",
    LINEAR: "1.0",
    MODES: "1.0",
    SIGNAL: "1.0",
    ENSEMBLE: "1.0",
    SWEEP: "1.0",
}

# Wall indices in contacts/j.
BOTTOM_WALL = -1
TOP_WALL = -2

# name -> (units, description), per schema.
DATASETS: dict[str, dict[str, tuple[str, str]]] = {
    PACKING: {
        "grains/position": ("d", "grain centres (N, dim); bottom wall at 0 along the last axis"),
        "grains/radius": ("d", "grain radii (N,)"),
        "grains/mass": ("rho d^3", "grain masses rho*pi*d^3/6 (N,)"),
        "grains/inertia": ("rho d^5", "moments of inertia m d^2/10 (N,)"),
        "box/size": ("d", "periodic lengths, then the bottom-wall-to-piston distance (dim,)"),
        "contacts/i": ("1", "first grain of a contact (M,)"),
        "contacts/j": ("1", "second grain, or -1 bottom wall, -2 top wall (M,)"),
        "contacts/normal": ("1", "unit vector from i towards j (M, dim)"),
        "contacts/overlap": ("d", "overlap R_i + R_j - r_ij (M,)"),
        "contacts/force_normal": ("E* d^2", "normal force magnitude; force on i is -f n (M,)"),
        "contacts/force_tangential": ("E* d^2", "tangential force on i from j (M, dim)"),
        "contacts/stiffness_normal": ("E* d", "k_n = dF_n/dn (M,)"),
        "contacts/stiffness_tangential": ("E* d", "k_t (Mindlin) (M,)"),
    },
    LINEAR: {
        "matrix/data": ("E* d", "CSR data of the stiffness matrix D"),
        "matrix/indices": ("1", "CSR column indices"),
        "matrix/indptr": ("1", "CSR row pointers"),
        "mass": ("rho d^3 | rho d^5", "diagonal of M (mass or moment of inertia) (n,)"),
        "dof/grain": ("1", "grain index of each degree of freedom (n,)"),
        "dof/axis": ("1", "0..dim-1 translation axis, dim.. rotation axis (n,)"),
        "source/velocity": ("sqrt(E*/rho)", "initial velocity vector of initial condition A (n,)"),
        "source/displacement": ("d", "initial displacement vector of initial condition B (n,)"),
        "detector": ("E* d", "F_sig = detector . u (n,)"),
    },
    MODES: {
        "omega2": ("E*/(rho d^2)", "eigenvalues omega^2 of D phi = omega^2 M phi, ascending (n,)"),
        "amplitude_A": ("d", "a_n for initial condition A: u = sum a_n phi_n sin(w_n t) (n,)"),
        "amplitude_B": ("d", "a_n for initial condition B: u = sum a_n phi_n cos(w_n t) (n,)"),
        "coupling": ("E* d / sqrt(rho d^3)", "b_n = detector . phi_n (n,)"),
        "vectors": ("1/sqrt(rho d^3)", "M-orthonormal eigenvectors as columns (n, n), optional"),
    },
    SIGNAL: {
        "signal/time": ("d/sqrt(E*/rho)", "sample times (T,)"),
        "signal/force": ("E* d^2", "extra vertical force on the top wall (T,)"),
        "snapshots/time": ("d/sqrt(E*/rho)", "snapshot times (S,)"),
        "snapshots/displacement": ("d", "displacement field at the snapshot times (S, n)"),
        "snapshots/dof_grain": ("1", "grain index of each dof (n,)"),
        "snapshots/dof_axis": ("1", "axis of each dof (n,)"),
        "snapshots/position": ("d", "equilibrium grain positions (N, dim)"),
    },
    ENSEMBLE: {
        "ensemble/time": ("d/sqrt(E*/rho)", "common time grid (T,)"),
        "ensemble/mean": ("E* d^2", "average signal (T,)"),
        "ensemble/rms": ("E* d^2", "root-mean-square deviation from the average (T,)"),
    },
    SWEEP: {
        "sweep/pressure": ("E*", "the pressures of the sweep, ascending (P,)"),
        "sweep/n_samples": ("1", "number of sample summaries per pressure (P,)"),
        "sweep/quantity": ("1", "names of the summarized quantities, 'section.key' (Q,) bytes"),
        "sweep/mean": ("per quantity", "mean over the samples of each pressure (P, Q); NaN if none"),
        "sweep/std": ("per quantity", "sample standard deviation (1/(n-1)) (P, Q); NaN if n < 2"),
        "sweep/count": ("1", "number of samples with a finite value (P, Q)"),
        "sweep/c_tof": ("sqrt(E*/rho)", "time-of-flight speed (10% edge) per pressure (P,)"),
        "sweep/c_tof_err": ("sqrt(E*/rho)", "its uncertainty (P,)"),
        "sweep/c_l": ("sqrt(E*/rho)", "continuum longitudinal speed sqrt(C22/phi3*) (P,)"),
        "sweep/c_l_err": ("sqrt(E*/rho)", "its uncertainty (standard error of the mean) (P,)"),
        "sweep/c_t": ("sqrt(E*/rho)", "continuum transverse speed sqrt(C33/phi3*) (P,)"),
        "sweep/c_t_err": ("sqrt(E*/rho)", "its uncertainty (standard error of the mean) (P,)"),
        "sweep/c_tof_over_c_l": ("1", "c_tof / c_l per pressure (P,)"),
        "sweep/c_tof_over_c_l_err": ("1", "its propagated uncertainty (P,)"),
        "sweep/lattice_frictionless": ("sqrt(E*/rho)", "triangular-lattice speed, no friction (P,)"),
        "sweep/lattice_frictional": ("sqrt(E*/rho)", "triangular-lattice speed with friction (P,)"),
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
    },
    MODES: {
        "omega2": ("f", ("n",)),
        "amplitude_A": ("f", ("n",)),
        "amplitude_B": ("f", ("n",)),
        "coupling": ("f", ("n",)),
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
OPTIONAL: dict[str, frozenset[str]] = {
    PACKING: frozenset(), LINEAR: frozenset(), ENSEMBLE: frozenset(), SWEEP: frozenset(),
    MODES: frozenset({"vectors"}),
    SIGNAL: frozenset({"snapshots/time", "snapshots/displacement", "snapshots/dof_grain",
                       "snapshots/dof_axis", "snapshots/position"}),
}

#: Optional datasets that come together (all or none).
GROUPS: dict[str, tuple[frozenset[str], ...]] = {
    SIGNAL: (frozenset({"snapshots/time", "snapshots/displacement", "snapshots/dof_grain",
                        "snapshots/dof_axis"}),),
}

# Root attributes every file of a schema must carry (beyond schema, schema_version,
# granwave_version, git_revision, command_line).
REQUIRED_ATTRS: dict[str, tuple[str, ...]] = {
    PACKING: ("dim", "pressure", "friction", "poisson", "seed", "converged", "max_acceleration", "kind"),
    LINEAR: ("dim", "pressure", "friction", "height", "prestress"),
    MODES: ("dim", "pressure", "height", "n_zero_modes"),
    SIGNAL: ("ic", "method", "height"),
    ENSEMBLE: ("n_signals",),
    SWEEP: (),
}


def formats_markdown() -> str:
    """The docs/formats.md text, generated from the tables above."""
    lines = [
        "# granwave file formats",
        "",
        "Generated by `python -m granwave.io.schema > docs/formats.md`; do not edit by hand.",
        "",
        "Every file is HDF5 with root attributes `schema`, `schema_version`, `granwave_version`,",
        "`git_revision`, `command_line`, the run's parameters, and a `units` attribute on every",
        "dataset. Readers refuse another schema or another major version.",
        "Wall indices in `contacts/j`: bottom wall = -1, top wall / piston = -2.",
        "",
        "Every reader validates a file before any stage uses it (`granwave/io/validate.py`):",
        "presence, dtype and shape of every dataset as in the tables below (a symbol such as",
        "N stands for the same size throughout one file; `dim` is the root attribute), index",
        "ranges (CSR `indptr` from 0 to nnz and non-decreasing, `indices` and contact indices",
        "in range), finite values, and the physical invariants: radii, masses, moments of",
        "inertia and box lengths > 0; centres between the walls; overlaps >= 0 and at most",
        "half the smaller radius; no two centres closer than the radii and the stored",
        "overlap allow; friction >= 0, 0 <= Poisson ratio < 0.5, pressure >= 0, height > 0.",
        "A failure is one line naming the file, the dataset and what is wrong.",
        "",
    ]
    for schema, table in DATASETS.items():
        lines += [f"## `{schema}` (version {VERSIONS[schema]})", ""]
        req = ", ".join(f"`{a}`" for a in REQUIRED_ATTRS[schema]) or "none beyond provenance"
        lines += [f"Required root attributes: {req}.", ""]
        if table:
            layout, optional = LAYOUT.get(schema, {}), OPTIONAL.get(schema, frozenset())
            lines += ["| dataset | dtype | shape | units | meaning |", "|---|---|---|---|---|"]
            for name, (units, desc) in table.items():
                kind, shape = layout.get(name, ("", ()))
                dtype = {"f": "float", "i": "int", "S": "bytes"}.get(kind, "")
                dims = f"({', '.join(map(str, shape))}{',' if len(shape) == 1 else ''})" if kind else ""
                flag = " (optional)" if name in optional else ""
                lines.append(f"| `{name}`{flag} | {dtype} | {dims} | {units} | {desc} |")
            lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(formats_markdown())
