"""Validation of granwave files before any stage uses them: one function per file kind.

The readers of :mod:`granwave.io.files` call :func:`check_layout` on every file they
open (presence, dtype and shape of every dataset, against ``schema.LAYOUT``) and then
the function of the file's kind on the arrays they read (index ranges, finiteness and
the physical invariants). A failure is an :class:`~granwave.errors.InputError` whose
one-line message names the file, the dataset and what is wrong, so that no kernel
(numba, scipy's sparse routines) ever sees a corrupt array.

Ranges shared with the parameters of the stages (units of docs/method.md §1):
friction mu >= 0, Poisson ratio nu in [0, 0.5), pressure >= 0.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from . import schema as S

#: Poisson ratio nu: [POISSON_MIN, POISSON_MAX) (G* stays positive, docs/method.md §2).
POISSON_MIN, POISSON_MAX = 0.0, 0.5
#: Largest overlap accepted, as a fraction of the smaller radius of the pair. The Hertz
#: law assumes overlaps much smaller than the radius, but the stiffest packings the
#: project prepares (p = 1e-2, 2D, frictional) reach 0.36 R at their most loaded
#: contact; half the radius lets them pass and still refuses the nonsense of a
#: corrupted or hand-made file (overlaps of diameters, coincident grains).
MAX_OVERLAP_FRACTION = 0.5
#: Relative asymmetry ||D - D^T||_F / ||D||_F a linearization gives D where no tangential
#: force enters it (no prestress, or frictionless): the assembly adds each contact's block
#: and its transpose, so D is symmetric to round-off (measured 0 to 1e-17).
SYMMETRY_ROUNDOFF = 1e-9
#: With prestress the stored tangential forces F_t add a non-symmetric part to D
#: (docs/linear.md) of relative size ~0.4 mu delta/d (measured: 4.3e-4 at p = 1e-4, 9.5e-3 at
#: p = 1e-2, mu = 0.5, 40-grain 2D Hertz packings). Overlaps are below MAX_OVERLAP_FRACTION
#: of a radius (delta/d < 0.25), so such a D stays below 0.1 mu; PRESTRESS_ASYMMETRY_PER_MU mu
#: leaves a factor 5 above that (docs/decisions/0045-what-belongs-together.md).
PRESTRESS_ASYMMETRY_PER_MU = 0.5
#: Relative tolerance on |n| = 1 for contact normals.
NORMAL_TOL = 1e-6
#: Tolerance on centre distance below R_i + R_j - overlap, relative to R_i + R_j.
DISTANCE_TOL = 1e-6
#: Largest magnitude of any float value in a file. Reduced units (d, rho, E*) keep every
#: quantity of a granular packing within a few decades of 1; a value beyond this is a
#: corrupt file, and a product of two such values must stay finite (a coupling of 1e300
#: times an amplitude overflows to a NaN signal).
MAX_MAGNITUDE = 1e100
#: Smallest value of a positive quantity (radius, mass, inertia, box): its reciprocal
#: (1/sqrt(m) in the mass-weighted matrix) stays finite.
MIN_POSITIVE = 1e-100
#: Largest deviation of a sample interval from the mean one, relative to it (linspace
#: rounding is ~1e-16 relative to t_max).
REGULAR_RTOL = 1e-6


def _fail(path, name: str, what: str):
    where = f"{path}: {name}: " if name else f"{path}: "
    raise InputError(where + what)


# ---------------------------------------------------------------- structure
def check_layout(path, f, schema: str, attrs: dict) -> None:
    """Presence, dtype and shape of every dataset of ``schema`` in the open file ``f``.

    Reads only metadata (no dataset is loaded). ``attrs``: the file's root attributes.
    """
    table = S.LAYOUT.get(schema, {})
    optional = S.OPTIONAL.get(schema, frozenset())
    sizes: dict[str, tuple[int, str]] = {}
    if "dim" in attrs and schema in (S.PACKING, S.LINEAR, S.MODES):
        dim = attrs["dim"]
        if isinstance(dim, (bool, np.bool_)) or not isinstance(dim, (int, np.integer)) or not 1 <= dim <= 3:
            _fail(path, "", f"root attribute dim must be 1, 2 or 3, found {dim!r}")
        sizes["dim"] = (int(dim), "the root attribute dim")
    for group in S.GROUPS.get(schema, ()):
        present = sorted(n for n in group if n in f)
        if present and len(present) < len(group):
            missing = sorted(group - set(present))
            _fail(path, missing[0], f"missing (it comes with {present[0]})")
    for name, (kind, shape) in table.items():
        if name not in f:
            if name in optional:
                continue
            _fail(path, name, "missing dataset")
        ds = f[name]
        if not hasattr(ds, "dtype") or not hasattr(ds, "shape"):
            _fail(path, name, "is a group, expected a dataset")
        found = ds.dtype.kind
        ok = {"f": "f", "i": "iu", "S": "SO"}[kind]
        if found not in ok:
            expected = {"f": "floating point", "i": "integer", "S": "strings"}[kind]
            _fail(path, name, f"has dtype {ds.dtype}, expected {expected}")
        if ds.shape is None or len(ds.shape) != len(shape):
            _fail(path, name, f"has shape {ds.shape}, expected ({', '.join(map(str, shape))})")
        for axis, (symbol, size) in enumerate(zip(shape, ds.shape)):
            if isinstance(symbol, int):
                if size != symbol:
                    _fail(path, name, f"has shape {ds.shape}, expected {symbol} along axis {axis}")
                continue
            base, extra = (symbol[:-2], 1) if symbol.endswith("+1") else (symbol, 0)
            if base in sizes:
                want, origin = sizes[base]
                if size != want + extra:
                    _fail(path, name, f"has shape {ds.shape}, expected {symbol} = {want + extra} "
                                      f"along axis {axis} (from {origin})")
            else:
                if size - extra < 0:
                    _fail(path, name, f"has shape {ds.shape}, expected at least {extra} along axis {axis}")
                sizes[base] = (size - extra, name)


def attr_types(path, attrs: dict, required=()) -> None:
    """Every root attribute named in ``schema.ATTR_TYPES`` has its type (no array where a
    scalar belongs, no string where a number or a bool belongs, no bool where a number
    belongs). ``required``: attributes the file's schema requires (for these the string
    "none", a None when written, is refused too)."""
    for key, kind in S.ATTR_TYPES.items():
        if key not in attrs:
            continue
        v = attrs[key]
        if isinstance(v, np.ndarray) and v.ndim == 0:
            v = v[()]
        if isinstance(v, np.generic):
            v = v.item()
        if kind == "int[]":
            if not (isinstance(v, np.ndarray) and v.ndim == 1 and (v.dtype.kind in "iu" or v.size == 0)):
                _fail(path, "", f"root attribute {key} must be a 1D integer array, found {_show(v)}")
            continue
        if isinstance(v, np.ndarray):
            _fail(path, "", f"root attribute {key} must be {_KIND_WORDS[kind]}, "
                            f"found an array of shape {v.shape}")
        if v == "none" and kind != "str" and key not in required:
            continue  # a None when written (files._set_attr)
        if kind == "str":
            ok = isinstance(v, str)
        elif kind == "bool":
            ok = isinstance(v, bool) or (isinstance(v, int) and v in (0, 1))
        elif kind == "int":
            ok = isinstance(v, int) and not isinstance(v, bool)
        else:
            ok = isinstance(v, (int, float)) and not isinstance(v, bool)
        if not ok:
            _fail(path, "", f"root attribute {key} must be {_KIND_WORDS[kind]}, found {_show(v)}")


_KIND_WORDS = {"number": "a number", "int": "an integer", "bool": "a boolean (true/false)",
               "str": "a string", "int[]": "a 1D integer array"}


def _show(v) -> str:
    """A short description of an attribute value for a message (type and value)."""
    text = repr(v)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(v).__name__} {text}"


# ---------------------------------------------------------------- shared value checks
def _finite(path, arrays: dict) -> None:
    """Finite values in every float array, of magnitude at most MAX_MAGNITUDE except on time
    axes (only compared and subtracted; a modal sum may sample a record of any length)."""
    for name, a in arrays.items():
        if a is None or a.dtype.kind != "f":
            continue
        if not np.all(np.isfinite(a)):
            _fail(path, name, "contains NaN or infinite values")
        if a.size and not name.endswith("time"):
            k = int(np.argmax(np.abs(a)))
            if abs(a.flat[k]) > MAX_MAGNITUDE:
                _fail(path, name, f"entry {k} is {a.flat[k]:g}, beyond +-{MAX_MAGNITUDE:g}: no "
                                  "quantity in granwave's reduced units comes near (a corrupt file?)")


def _positive(path, name: str, a: np.ndarray) -> None:
    """> 0, and for floats at least MIN_POSITIVE (its reciprocal must stay finite)."""
    if a.size and not np.all(a > 0):
        k = int(np.argmin(a))
        _fail(path, name, f"must be > 0, entry {k} is {a.flat[k]:g}")
    if a.size and a.dtype.kind == "f" and np.min(a) < MIN_POSITIVE:
        k = int(np.argmin(a))
        _fail(path, name, f"entry {k} is {a.flat[k]:g}, below {MIN_POSITIVE:g}: no quantity in "
                          "granwave's reduced units comes near (a corrupt file?)")


def _not_empty(path, name: str, n: int, what: str) -> None:
    if n == 0:
        _fail(path, name, f"is empty: the file holds no {what}")


def time_axis(path, name: str, t: np.ndarray) -> None:
    """At least two sample times, increasing and evenly spaced (to REGULAR_RTOL of the step):
    the front features, spectra, interpolation onto common grids and the Nyquist check all
    take a regular axis."""
    if t.size < 2:
        _fail(path, name, f"has {t.size} sample time(s), at least 2 are needed")
    d = np.diff(t)
    if np.any(d <= 0):
        k = int(np.flatnonzero(d <= 0)[0])
        _fail(path, name, f"times must increase (entry {k + 1} is {t[k + 1]:g} after {t[k]:g})")
    h = (t[-1] - t[0]) / (t.size - 1)
    off = np.abs(d - h)
    k = int(np.argmax(off))
    if off[k] > REGULAR_RTOL * h:
        _fail(path, name, f"times are not evenly spaced (step {d[k]:g} after entry {k}, mean step "
                          f"{h:g}): granwave's analyses take a regular time axis")


def _non_negative(path, name: str, a: np.ndarray) -> None:
    if a.size and not np.all(a >= 0):
        k = int(np.argmin(a))
        _fail(path, name, f"must be >= 0, entry {k} is {a.flat[k]:g}")


def _in_range(path, name: str, a: np.ndarray, lo: int, hi: int) -> None:
    """Integers in [lo, hi)."""
    if a.size and (a.min() < lo or a.max() >= hi):
        bad = int(np.flatnonzero((a < lo) | (a >= hi))[0])
        _fail(path, name, f"index {a[bad]} at entry {bad} is out of range [{lo}, {hi})")


def _attr_number(path, attrs: dict, key: str, *, lo: float | None = None, lo_open=False,
                 hi: float | None = None, hi_open=False) -> None:
    """A numeric root attribute, if present, finite and in range."""
    if key not in attrs:
        return
    v = attrs[key]
    try:
        x = float(v)
    except (TypeError, ValueError):
        _fail(path, "", f"root attribute {key} must be a number, found {v!r}")
    if not math.isfinite(x):
        _fail(path, "", f"root attribute {key} must be finite, found {x}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        _fail(path, "", f"root attribute {key} must be {'>' if lo_open else '>='} {lo:g}, found {x:g}")
    if hi is not None and (x > hi or (hi_open and x == hi)):
        _fail(path, "", f"root attribute {key} must be {'<' if hi_open else '<='} {hi:g}, found {x:g}")


def material_attrs(path, attrs: dict) -> None:
    """pressure >= 0, friction >= 0, Poisson ratio in [0, 0.5), height > 0 (where present)."""
    _attr_number(path, attrs, "pressure", lo=0.0)
    _attr_number(path, attrs, "friction", lo=0.0)
    _attr_number(path, attrs, "poisson", lo=POISSON_MIN, hi=POISSON_MAX, hi_open=True)
    _attr_number(path, attrs, "height", lo=0.0, lo_open=True)


def contact_law_attrs(path, attrs: dict) -> None:
    """A packing's contact sub-models are known ones (absent: the defaults) and their recorded
    parameters numbers in range (granwave.contact_models). Signal files use ``contact_law`` for a
    description of the DEM pulse's law, so only packings are checked."""
    from ..contact_models import options as CO

    for kind, k in CO.KINDS.items():
        name = attrs.get(k["option"], k["default"])
        if name not in CO.names(kind):
            _fail(path, "", f"root attribute {k['option']} must be one of {', '.join(CO.names(kind))}, "
                            f"found {name!r}")
    for name, p in CO.PARAMETERS.items():
        _attr_number(path, attrs, name, lo=p["lo"], lo_open=p["lo_open"], hi=p["hi"], hi_open=p["hi_open"])


def _nearest_image(x: np.ndarray, box: np.ndarray, dim: int) -> np.ndarray:
    """Fold every lateral (periodic) component of the separation vectors x (M, dim)."""
    x = np.array(x, copy=True)
    for k in range(dim - 1):
        x[:, k] -= box[k] * np.round(x[:, k] / box[k])
    return x


# ---------------------------------------------------------------- packing
def contact_indices(path, n: int, i, j) -> None:
    """Contact indices of a packing of ``n`` grains in range: i a grain, j a grain or a wall
    (-1 bottom, -2 top), and no contact joining a grain to itself. The part of :func:`packing`
    the library's entry points check on a packing built in memory (an index past the last
    grain would otherwise be an IndexError deep inside the assembly)."""
    i, j = np.asarray(i), np.asarray(j)
    if i.shape != j.shape or i.ndim != 1:
        _fail(path, "contacts/j", f"has shape {j.shape}, contacts/i {i.shape}: one index pair per contact")
    for name, a in (("contacts/i", i), ("contacts/j", j)):
        if a.size and a.dtype.kind not in "iu":
            _fail(path, name, f"must hold integers, found {a.dtype}")
    _in_range(path, "contacts/i", i, 0, n)
    _in_range(path, "contacts/j", j, S.TOP_WALL, n)
    if np.any(i == j):
        _fail(path, "contacts/j", f"contact {int(np.flatnonzero(i == j)[0])} joins a grain to itself")


def packing(path, a: dict, attrs: dict) -> None:
    """Invariants of a packing (``a``: dataset name -> array, as read).

    Radii, masses, inertia and the box are positive; centres lie between the walls;
    contact indices are in range (j: a grain, -1 bottom wall or -2 top wall); normals
    are unit vectors; overlaps, normal forces and stiffnesses are >= 0 and overlaps
    below MAX_OVERLAP_FRACTION of the smaller radius; no two centres in contact are
    closer than R_i + R_j - overlap (no grain closer to a wall than R - overlap), and
    no two grains that are not in contact overlap by more than MAX_OVERLAP_FRACTION
    (coincident grains are refused).
    """
    _finite(path, a)
    material_attrs(path, attrs)
    contact_law_attrs(path, attrs)
    pos, radius = a["grains/position"], a["grains/radius"]
    box = a["box/size"]
    n, dim = pos.shape
    _not_empty(path, "grains/position", n, "grains")
    for name in ("grains/radius", "grains/mass", "grains/inertia", "box/size"):
        _positive(path, name, a[name])
    if n:
        y = pos[:, -1]
        if not (np.all(y > 0) and np.all(y < box[-1])):
            k = int(np.flatnonzero(~((y > 0) & (y < box[-1])))[0])
            _fail(path, "grains/position", f"grain {k} lies outside the walls "
                                           f"(coordinate {y[k]:g}, walls at 0 and {box[-1]:g})")
    i, j = a["contacts/i"], a["contacts/j"]
    contact_indices(path, n, i, j)
    for name in ("contacts/overlap", "contacts/force_normal", "contacts/stiffness_normal",
                 "contacts/stiffness_tangential"):
        _non_negative(path, name, a[name])
    loaded = (a["contacts/overlap"] > 0) & (a["contacts/stiffness_normal"] <= 0)
    if np.any(loaded):
        k = int(np.flatnonzero(loaded)[0])
        _fail(path, "contacts/stiffness_normal", f"contact {k} overlaps by {a['contacts/overlap'][k]:g} "
                                                 "but has zero stiffness (the contact law gives k_n > 0)")
    normal = a["contacts/normal"]
    if len(normal):
        err = np.abs(np.linalg.norm(normal, axis=1) - 1.0)
        if np.any(err > NORMAL_TOL):
            _fail(path, "contacts/normal", f"contact {int(np.argmax(err))} has no unit normal")
    overlap = a["contacts/overlap"]
    grain = j >= 0
    r_min = np.where(grain, np.minimum(radius[i], radius[np.where(grain, j, 0)]), radius[i])
    too_big = overlap > MAX_OVERLAP_FRACTION * r_min
    if np.any(too_big):
        k = int(np.flatnonzero(too_big)[0])
        _fail(path, "contacts/overlap", f"contact {k} overlaps by {overlap[k]:g}, more than "
                                        f"{MAX_OVERLAP_FRACTION:g} of the radius {r_min[k]:g}")
    # The geometry must not overlap more than the stored overlaps say: grain pairs by
    # their centre distance, wall contacts by the distance to the wall. (Farther apart
    # than claimed is only a stale contact list, harmless to every stage.)
    gi, gj = i[grain], j[grain]
    if len(gi):
        r = np.linalg.norm(_nearest_image(pos[gi] - pos[gj], box, dim), axis=1)
        claimed = radius[gi] + radius[gj] - overlap[grain]
        bad = r < claimed - DISTANCE_TOL * (radius[gi] + radius[gj])
        if np.any(bad):
            k = int(np.flatnonzero(grain)[np.flatnonzero(bad)[0]])
            kk = int(np.flatnonzero(bad)[0])
            _fail(path, "contacts/overlap",
                  f"contact {k} (grains {i[k]}, {j[k]}): centre distance {r[kk]:.9g} is less "
                  f"than R_i + R_j - overlap = {claimed[kk]:.9g}")
    for wall, gap_of in ((S.BOTTOM_WALL, lambda y: y), (S.TOP_WALL, lambda y: box[-1] - y)):
        w = j == wall
        if np.any(w):
            gap = gap_of(pos[i[w], -1])
            claimed = radius[i[w]] - overlap[w]
            bad = gap < claimed - DISTANCE_TOL * 2 * radius[i[w]]
            if np.any(bad):
                k = int(np.flatnonzero(w)[np.flatnonzero(bad)[0]])
                _fail(path, "contacts/overlap", f"wall contact {k} (grain {i[k]}): distance to the "
                                                f"wall is less than R - overlap")
    _no_hidden_overlaps(path, pos, radius, box, i[grain], j[grain])


def _no_hidden_overlaps(path, pos, radius, box, ci, cj) -> None:
    """No two grains outside the contact list overlap by more than MAX_OVERLAP_FRACTION."""
    n, dim = pos.shape
    if n < 2:
        return
    from scipy.spatial import cKDTree

    wrapped = np.array(pos, dtype=float, copy=True)
    size = np.empty(dim)
    for k in range(dim - 1):
        wrapped[:, k] = np.mod(wrapped[:, k], box[k])
        size[k] = box[k]
    # The wall-normal axis is not periodic: a period far beyond the walls.
    wrapped[:, -1] -= wrapped[:, -1].min()
    size[-1] = 2.0 * (wrapped[:, -1].max() + 4.0 * radius.max()) + 1.0
    wrapped = np.minimum(wrapped, np.nextafter(size, 0))  # mod may round up to exactly L
    tree = cKDTree(wrapped, boxsize=size)
    # Only pairs closer than the largest distance that could be refused.
    cutoff = 2.0 * float(radius.max()) - MAX_OVERLAP_FRACTION * float(radius.min())
    pairs = tree.query_pairs(cutoff, output_type="ndarray")
    if not len(pairs):
        return
    p, q = pairs[:, 0], pairs[:, 1]
    r = np.linalg.norm(_nearest_image(pos[p] - pos[q], box, dim), axis=1)
    allowed = radius[p] + radius[q] - MAX_OVERLAP_FRACTION * np.minimum(radius[p], radius[q])
    close = r < allowed
    if not np.any(close):
        return
    listed = set(zip(np.minimum(ci, cj).tolist(), np.maximum(ci, cj).tolist()))
    for k in np.flatnonzero(close):
        a, b = int(min(p[k], q[k])), int(max(p[k], q[k]))
        if (a, b) not in listed:
            _fail(path, "grains/position", f"grains {a} and {b} overlap by "
                                           f"{radius[a] + radius[b] - r[k]:g} (centre distance {r[k]:g}) "
                                           "without a contact")


# ---------------------------------------------------------------- linear system
def linear(path, a: dict, attrs: dict, shape) -> None:
    """Invariants of a linear system: CSR structure, positive masses, dof map in range.

    ``shape``: the ``matrix`` group's shape attribute (must be (n, n)).
    """
    material_attrs(path, attrs)
    n = len(a["mass"])
    try:
        shape = tuple(int(s) for s in np.asarray(shape).ravel())
    except (TypeError, ValueError):
        _fail(path, "matrix", f"shape attribute {shape!r} is not a pair of integers")
    if shape != (n, n):
        _fail(path, "matrix", f"shape attribute {shape} does not match the {n} dofs of mass")
    _not_empty(path, "mass", n, "degrees of freedom")
    indptr, indices = a["matrix/indptr"], a["matrix/indices"]
    nnz = len(indices)
    if indptr[0] != 0 or indptr[-1] != nnz:
        _fail(path, "matrix/indptr", f"must run from 0 to {nnz} (found {indptr[0]} .. {indptr[-1]})")
    if np.any(np.diff(indptr) < 0):
        _fail(path, "matrix/indptr", f"decreases at row {int(np.flatnonzero(np.diff(indptr) < 0)[0])}")
    _in_range(path, "matrix/indices", indices, 0, n)
    _sorted_unique_rows(path, indptr, indices)
    _finite(path, {k: v for k, v in a.items() if k != "matrix/indptr"})
    if not np.any(a["matrix/data"]):
        _fail(path, "matrix/data", "every entry is zero: D holds no stiffness (no contacts?)")
    _positive(path, "mass", a["mass"])
    _non_negative(path, "dof/grain", a["dof/grain"])
    dim = int(attrs.get("dim", 3))
    # 3D: rotations 3..5, or 6, 7 for a grain whose free spin was removed
    _in_range(path, "dof/axis", a["dof/axis"], 0,
              S.SPIN_REDUCED_AXES[-1] + 1 if dim == 3 else dim + dim * (dim - 1) // 2)


def asymmetry_limit(attrs: dict) -> float:
    """The largest relative asymmetry ||D - D^T||_F / ||D||_F a linearization can give a
    system with these attributes: round-off without prestress or without friction, else
    PRESTRESS_ASYMMETRY_PER_MU x friction above it."""
    prestress = attrs.get("prestress", False)
    try:
        friction = float(attrs.get("friction", 0.0))
    except (TypeError, ValueError):
        friction = 0.0
    if isinstance(prestress, (bool, np.bool_, int, np.integer)) and bool(prestress) and friction > 0:
        return SYMMETRY_ROUNDOFF + PRESTRESS_ASYMMETRY_PER_MU * friction
    return SYMMETRY_ROUNDOFF


def stiffness_symmetry(path, D, attrs: dict) -> float:
    """The relative asymmetry of the stiffness matrix ``D`` (scipy sparse), InputError where
    it exceeds :func:`asymmetry_limit`: such a D was not made by a linearization (an edited or
    foreign file), and its symmetric part is not the system's (its modes, often negative,
    would be written as if they were). Cost O(nnz)."""
    import scipy.sparse.linalg as spla

    norm = float(spla.norm(D))
    asym = float(spla.norm(D - D.T)) / norm if norm > 0 else 0.0
    limit = asymmetry_limit(attrs)
    if not asym <= limit:
        why = ("with prestress and friction " + f"{float(attrs.get('friction')):g}"
               if limit > SYMMETRY_ROUNDOFF else
               "the round-off of a linearization without prestress or without friction")
        _fail(path, "matrix", f"D is not symmetric: relative asymmetry ||D - D^T||/||D|| = {asym:.3g}, "
                              f"above the {limit:.3g} of {why}; the stiffness matrix was altered or "
                              "is not a linearization's (rebuild it with granwave linearize)")
    return asym


def linear_system(system, what: str = "the linear system") -> None:
    """The checks of a linear file (:func:`linear`, :func:`stiffness_symmetry`) on a
    LinearSystem built in memory (the API takes them without a file): positive finite masses,
    finite entries, every per-dof vector of the dofs' length. InputError naming ``what``."""
    import scipy.sparse as sp

    D = sp.csr_matrix(system.stiffness, copy=True)
    D.sum_duplicates()  # canonical rows, as a file holds them
    n = len(np.asarray(system.mass))
    a = {"matrix/data": np.asarray(D.data, float), "matrix/indices": np.asarray(D.indices, np.int64),
         "matrix/indptr": np.asarray(D.indptr, np.int64), "mass": np.asarray(system.mass, float),
         "dof/grain": np.asarray(system.dof_grain, np.int64), "dof/axis": np.asarray(system.dof_axis, np.int64)}
    for name, v in (("source/velocity", system.source_velocity), ("detector", system.detector),
                    ("source/displacement", system.source_displacement)):
        v = np.asarray(v, float)
        if v.shape != (n,):
            _fail(what, name, f"has shape {v.shape}, the system {n} dofs")
        if name != "source/displacement" or np.isfinite(v).all():  # NaN: a shear kick's (IC A only)
            a[name] = v
    for name in ("dof/grain", "dof/axis"):
        if a[name].shape != (n,):
            _fail(what, name, f"has shape {a[name].shape}, the system {n} dofs")
    linear(what, a, dict(system.attrs), D.shape)
    stiffness_symmetry(what, D, dict(system.attrs))


def _sorted_unique_rows(path, indptr: np.ndarray, indices: np.ndarray) -> None:
    """Column indices strictly increasing within every row (canonical CSR, as granwave writes
    it): a repeated index would be summed into an entry no writer meant (an asymmetric D)."""
    if len(indices) < 2:
        return
    step = np.diff(indices)
    # positions k where k and k+1 lie in the same row: k+1 is not the start of a row
    same_row = np.ones(len(indices) - 1, dtype=bool)
    starts = indptr[1:-1]
    starts = starts[(starts > 0) & (starts < len(indices))]
    same_row[starts - 1] = False
    bad = same_row & (step <= 0)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0]) + 1
        row = int(np.searchsorted(indptr, k, side="right")) - 1
        what = "repeated" if step[k - 1] == 0 else "not sorted"
        _fail(path, "matrix/indices", f"column indices of row {row} are {what} (entry {k}: "
                                      f"{indices[k]} after {indices[k - 1]}); CSR rows must be sorted "
                                      "and unique")


# ---------------------------------------------------------------- modes
def modes(path, a: dict, attrs: dict) -> None:
    """Invariants of a modes file: finite values, omega^2 ascending, height > 0."""
    material_attrs(path, attrs)
    _not_empty(path, "omega2", len(a["omega2"]), "modes")
    _finite(path, a)
    w = a["omega2"]
    if np.any(np.diff(w) < 0):
        _fail(path, "omega2", f"not ascending at entry {int(np.flatnonzero(np.diff(w) < 0)[0]) + 1}")


#: Attributes a modes file copies from its linear file that must agree with the linear file
#: it names (floats to 1e-12 relative).
MATCHING_ATTRS = ("dim", "n_dof", "pressure", "friction", "poisson", "height", "seed", "kind",
                  "prestress", "n_rattlers")


def _same_attr(a, b) -> bool:
    """Whether two recorded attribute values agree: numbers to 1e-12 relative, others exactly."""
    if isinstance(a, float) or isinstance(b, float):
        try:
            return math.isclose(float(a), float(b), rel_tol=1e-12)
        except (TypeError, ValueError):
            return False
    return a == b


def modes_match_linear(modes, system) -> str | None:
    """Why ``system`` (a LinearSystem) is not the one ``modes`` were computed from, or None.

    The digest ``linear_digest`` decides where the modes record one; sizes (eigenvector
    rows = dofs, no more modes than dofs) and the sample attributes of MATCHING_ATTRS
    always count (files written before the digest, and a digest collision nobody made).
    """
    n = system.n_dof
    if modes.vectors is not None and modes.vectors.shape[0] != n:
        return f"has {n} dofs, the eigenvectors {modes.vectors.shape[0]}"
    if len(modes.omega2) > n:
        return f"has {n} dofs, fewer than the {len(modes.omega2)} modes"
    for key in MATCHING_ATTRS:
        a, b = modes.attrs.get(key), system.attrs.get(key)
        if a is None or b is None:
            continue
        if not _same_attr(a, b):
            return f"has {key} = {b!r}, the modes {a!r}"
    want, got = modes.attrs.get("linear_digest"), system.attrs.get("linear_digest")
    if isinstance(want, str) and want and want != "none" and got is not None and want != got:
        return f"is not the system the modes were computed from (linear_digest {got}, the modes {want})"
    return None


#: Attributes of a packing that a linear, modes or signal file made from it carries
#: (under the same name, except the seed: ``packing_seed`` where present).
PACKING_ATTRS = ("dim", "pressure", "friction", "poisson", "kind", "n_grains")


def belongs_to_packing(obj, packing) -> str | None:
    """Why ``obj`` (a LinearSystem, Modes or Signal with its attrs) was not made from
    ``packing``, or None: the recorded ``packing_digest`` where both have one; the grain
    indices of its dof map within the packing's grains; stored reference positions equal to
    the packing's; the sample attributes PACKING_ATTRS and the seed."""
    want, got = obj.attrs.get("packing_digest"), packing.attrs.get("packing_digest")
    if isinstance(want, str) and want not in ("", "none") and got is not None and want != got:
        return f"was made from another packing (packing_digest {want}, the packing's {got})"
    n = packing.n_grains
    grains = getattr(obj, "dof_grain", None)
    if grains is not None and len(grains) and int(np.max(grains)) >= n:
        return f"refers to grain {int(np.max(grains))}, the packing has {n} grains"
    position = getattr(obj, "position", None)
    if position is not None:
        if position.shape != packing.position.shape:
            return f"stores positions of shape {position.shape}, the packing's are {packing.position.shape}"
        if not np.allclose(position, packing.position, rtol=1e-9, atol=1e-12):
            return "stores other grain positions than the packing's"
    seed = obj.attrs.get("packing_seed", obj.attrs.get("seed"))
    pairs = [(key, obj.attrs.get(key), packing.n_grains if key == "n_grains" else packing.attrs.get(key))
             for key in PACKING_ATTRS]
    pairs.append(("seed", seed, packing.attrs.get("seed")))
    pairs.append(("height", obj.attrs.get("height"), float(packing.box[-1])))  # wall to wall
    for key, a, b in pairs:
        if a is None or b is None or a == "none" or b == "none":
            continue
        if not _same_attr(a, b):
            return f"has {key} = {a!r}, the packing {b!r}"
    return None


def same_packing(path, obj, packing_path, packing) -> None:
    """InputError unless ``obj`` (read from ``path``) was made from ``packing``."""
    why = belongs_to_packing(obj, packing)
    if why is not None:
        _fail(path, "", f"{why}: it does not belong to {packing_path}; give the packing it was "
                        "computed from")
    digest = obj.attrs.get("packing_digest")
    if not isinstance(digest, str) or digest in ("", "none"):
        import warnings

        from ..errors import OlderFileWarning

        warnings.warn(OlderFileWarning(
            f"{path} records no packing_digest (an older granwave): checked against {packing_path} by its "
            "recorded attributes and grains only; remake it from its packing (granwave linearize, then "
            "propagate) to have it checked"), stacklevel=2)


def same_system(path, modes, linear_path, system) -> None:
    """InputError unless ``modes`` (read from ``path``) are those of ``system``."""
    why = modes_match_linear(modes, system)
    if why is not None:
        _fail(path, "", f"{linear_path} {why}: give the linear file these modes were computed from")


# ---------------------------------------------------------------- signal
#: The initial conditions a signal can be of (docs/conventions.md): A impulse, B displacement.
SIGNAL_ICS = ("A", "B")


def signal(path, a: dict, attrs: dict) -> None:
    """Invariants of a signal file: finite values, a regular increasing time axis, snapshot
    times >= 0 (in the order asked for, not necessarily sorted), dof map >= 0, the initial
    condition (``ic``) A or B."""
    material_attrs(path, attrs)
    if "ic" in attrs and attrs["ic"] not in SIGNAL_ICS:
        _fail(path, "", f"root attribute ic must be one of {', '.join(SIGNAL_ICS)} (the initial "
                        f"condition), found {attrs['ic']!r}")
    _finite(path, {k: v for k, v in a.items() if k != "pulse/arrival"})  # NaN: a bin without a front
    time_axis(path, "signal/time", a["signal/time"])
    for name in ("snapshots/time", "snapshots/dof_grain", "snapshots/dof_axis"):
        if a.get(name) is not None:
            _non_negative(path, name, a[name])


# ---------------------------------------------------------------- ensemble
def ensemble(path, a: dict, attrs: dict) -> None:
    """Invariants of an ensemble file: finite values, a regular increasing time axis, rms >= 0."""
    _finite(path, a)
    time_axis(path, "ensemble/time", a["ensemble/time"])
    _non_negative(path, "ensemble/rms", a["ensemble/rms"])
