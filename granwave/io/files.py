"""Reading and writing granwave HDF5 files (layout: :mod:`granwave.io.schema`).

Writes are atomic and checked first (:mod:`granwave.io.atomic`, whose functions are found here
too): a stage killed halfway never leaves a file that looks finished, and no output destroys a
file it should not.

Readers check the schema name and major version, then validate every dataset
(:mod:`granwave.io.validate`) before returning, and refuse anything else with
an :class:`InputError`.
"""

from __future__ import annotations

import contextlib
import os
import re
from pathlib import Path
from typing import Iterator

import h5py
import numpy as np
import scipy.sparse as sp

from ..contact_models import options as CO
from ..errors import ConvergenceError, InputError
from ..model import Contacts, LinearSystem, Modes, Packing, Signal
from ..provenance import FILE_ATTRS, provenance_attrs
from . import schema as S
from . import validate as V
# the generic layer (granwave.io.atomic), also found here: callers read and write every file through this module
from .atomic import (_replace_on_success, _temporary, atomic_file, atomic_text, check_name_length,  # noqa: F401
                     check_target, check_writable, inputs_read, jsonable, load_json, outputs_together,
                     record_input, remove_stale_temporaries, replace_marked_block, same_file_as)


# ---------------------------------------------------------------- HDF5 layer
#: Root attributes that describe the file itself, never copied from a caller's attrs.
RESERVED_ATTRS = frozenset(FILE_ATTRS)


@contextlib.contextmanager
def atomic_h5(path: str | os.PathLike, schema: str, attrs: dict, *,
              nbytes: int = 0) -> Iterator[h5py.File]:
    """Open a new HDF5 file for writing; it appears at ``path`` only on success.

    ``nbytes``: the size of the data to be written, checked against the free disk
    space before anything is written (0: not checked).
    """
    path = check_writable(path)
    if nbytes:
        from ..resources import require_disk

        require_disk(path.parent if str(path.parent) else Path("."), nbytes, f"writing {path}")
    tmp = _temporary(path)
    with _replace_on_success(path, tmp, False):
        with h5py.File(tmp, "w") as f:
            # Attributes copied from an input file may carry that file's schema name and
            # provenance: this file's own are written last so they always win.
            for key, value in attrs.items():
                if key not in RESERVED_ATTRS:
                    _set_attr(f, key, value)
            for key, value in provenance_attrs().items():
                _set_attr(f, key, value)
            f.attrs["schema"] = schema
            f.attrs["schema_version"] = S.VERSIONS[schema]
            yield f


def _set_attr(f: h5py.File, key: str, value) -> None:
    if value is None:
        value = "none"
    if isinstance(value, (list, tuple)):
        value = np.asarray(value)
    f.attrs[key] = value


def put(f: h5py.File, schema: str, name: str, data) -> None:
    """Write one dataset with its ``units`` attribute from the schema table, its
    extra attributes (:data:`schema.EXTRA_ATTRS`) and its named dimensions."""
    units, _ = S.DATASETS[schema][name]
    ds = f.create_dataset(name, data=np.asarray(data))
    ds.attrs["units"] = units
    extra = S.EXTRA_ATTRS.get(schema, {}).get(name, {})
    if "units_rotation" in extra:
        ds.attrs["units_translation"] = units
    for key, value in extra.items():
        ds.attrs[key] = value
    _name_dimensions(f, ds, S.DIMS.get(schema, {}).get(name, ()))


#: The NAME of a dimension scale that is not a variable (netCDF-4's convention; h5netcdf
#: and netCDF-C read such a dataset as a bare dimension).
_BARE_DIMENSION = b"This is a netCDF dimension but not a netCDF variable."


def _name_dimensions(f: h5py.File, ds: h5py.Dataset, dims: tuple[str, ...]) -> None:
    """Attach HDF5 dimension scales named ``dims`` to the axes of ``ds``.

    A 1D dataset named like its dimension becomes that dimension's scale (a coordinate).
    Otherwise the scale is looked up in the dataset's group and its ancestors, and made
    at the root when missing: the labels x, y, z for "axis", a bare dimension otherwise.
    """
    if len(dims) != ds.ndim:
        return
    base = ds.name.rsplit("/", 1)[-1]
    if ds.ndim == 1 and base == dims[0]:
        ds.make_scale(dims[0])
        return
    for axis, dim in enumerate(dims):
        ds.dims[axis].attach_scale(_scale(f, ds.parent, dim, ds.shape[axis]))


def _scale(f: h5py.File, group: h5py.Group, dim: str, size: int) -> h5py.Dataset:
    while True:
        obj = group.get(dim)
        if isinstance(obj, h5py.Dataset) and obj.is_scale:
            return obj
        if group.name == "/":
            break
        group = group.parent
    if dim == "axis":
        scale = f.create_dataset(dim, data=np.array(S.AXIS_LABELS[:size], dtype=h5py.string_dtype()))
        scale.make_scale(dim)
        scale.attrs["units"] = "1"
        return scale
    scale = f.create_dataset(dim, shape=(size,), dtype=">f4")  # never written: no storage
    scale.make_scale(_BARE_DIMENSION + f"{size:10}".encode())
    return scale


def _attr_value(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


@contextlib.contextmanager
def open_checked(path: str | os.PathLike, schema: str) -> Iterator[h5py.File]:
    """Open a granwave file for reading, refusing a foreign schema or major version.

    The file is recorded as an input of this process (see :func:`check_writable`),
    and its layout (presence, dtype and shape of every dataset) is checked.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    record_input(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"{path}: not an HDF5 file ({exc.__class__.__name__})") from None
    with f:
        try:
            attrs = read_attrs(f)
        except (OSError, RuntimeError, ValueError, KeyError) as exc:
            raise InputError(f"{path}: unreadable root attributes ({exc.__class__.__name__})") from None
        found = attrs.get("schema", "")
        if not isinstance(found, str):  # an array (or a number) where the name belongs
            raise InputError(f"{path}: root attribute schema must be a string, found "
                             f"{type(found).__name__} {str(found)[:60]}: not a {schema} file")
        if found != schema:
            raise InputError(f"{path}: expected a {schema} file, found schema {found!r}")
        version = attrs.get("schema_version", "")
        if not isinstance(version, str) or not re.fullmatch(r"[0-9]+\.[0-9]+", version):
            raise InputError(f"{path}: root attribute schema_version must be \"MAJOR.MINOR\" "
                             f"(this granwave writes {S.VERSIONS[schema]}), found "
                             f"{type(version).__name__} {str(version)[:60]!r}")
        if version.split(".")[0] != S.VERSIONS[schema].split(".")[0]:
            raise InputError(
                f"{path}: schema version {version!r} is not readable by this granwave "
                f"(reads {schema} {S.VERSIONS[schema].split('.')[0]}.x)"
            )
        missing = [a for a in S.REQUIRED_ATTRS[schema] if a not in attrs]
        if missing:
            raise InputError(f"{path}: missing root attribute(s) {', '.join(missing)}")
        V.attr_types(path, attrs, S.REQUIRED_ATTRS[schema])
        try:
            V.check_layout(path, f, schema, attrs)
        except (OSError, RuntimeError, KeyError) as exc:  # a damaged HDF5 structure
            raise InputError(f"{path}: damaged HDF5 file ({exc.__class__.__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
        yield f


def read_attrs(f: h5py.File) -> dict:
    return {k: _attr_value(v) for k, v in f.attrs.items()}


def file_schema(path: str | os.PathLike) -> str:
    """The schema name of a granwave file (for stages that take several kinds)."""
    record_input(path)
    try:
        with h5py.File(path, "r") as f:
            return str(_attr_value(f.attrs.get("schema", "")))
    except OSError:
        raise InputError(f"{path}: not an HDF5 file") from None


def _finite(path, name: str, arr: np.ndarray) -> np.ndarray:
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise InputError(f"{path}: {name}: contains NaN or infinite values")
    return arr


def _read(f: h5py.File, path, name: str) -> np.ndarray:
    """One dataset's values in native byte order, floats as float64 and integers as int64
    (:func:`native`); a damaged (truncated) file is an InputError naming it."""
    try:
        a = f[name][()]
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        raise InputError(f"{path}: {name}: unreadable ({exc.__class__.__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else 'damaged file'})") from None
    return native(path, name, a)


def native(path, name: str, a) -> np.ndarray:
    """``a`` as the kernels take it: float64 or int64 in native byte order.

    Exact conversions are made silently: another byte order (a big-endian file), smaller
    floats (float16, float32) and other integer widths. Extended precision (long double)
    is converted only when float64 holds every value exactly (a file converted up from
    float64); otherwise it is refused, since rounding would change the values without a
    word. Unsigned integers beyond the int64 range are refused. Strings stay as they are.
    """
    a = np.asarray(a)
    kind = a.dtype.kind
    if kind == "f":
        if a.dtype.itemsize > 8:
            with np.errstate(over="ignore", invalid="ignore"):
                b = a.astype(np.float64)
                exact = np.array_equal(b.astype(a.dtype), a, equal_nan=True)
            if not exact:
                raise InputError(f"{path}: {name}: has dtype {a.dtype} (extended precision) with "
                                 "values float64 cannot hold exactly; granwave computes in float64: "
                                 "round the values to float64 and write them as float64")
            return b
        return a.astype(np.float64, copy=False) if a.dtype != np.float64 else a
    if kind in "iu":
        if kind == "u" and a.dtype.itemsize >= 8 and a.size and int(a.max()) > np.iinfo(np.int64).max:
            k = int(np.argmax(a))
            raise InputError(f"{path}: {name}: index {int(a.flat[k])} at entry {k} is out of range")
        return a.astype(np.int64, copy=False) if a.dtype != np.int64 else a
    return a


def _get(f: h5py.File, path, name: str) -> np.ndarray:
    if name not in f:
        raise InputError(f"{path}: {name}: missing dataset")
    return _finite(path, name, _read(f, path, name))


def _read_all(f: h5py.File, path, schema: str, skip=()) -> dict:
    """Every dataset of ``schema`` present in ``f`` (layout already checked), by name.

    The size the file declares is checked against the available memory first: a
    damaged file may declare a dataset far larger than the data it holds.
    """
    from ..resources import require_memory

    names = [name for name in S.LAYOUT[schema] if name in f and name not in skip]
    require_memory(sum(float(f[n].size) * f[n].dtype.itemsize for n in names), f"reading {path}")
    return {name: _read(f, path, name) for name in names}


def _nbytes(*arrays) -> int:
    total = 0
    for a in arrays:
        if a is not None:
            parts = (a.data, a.indices, a.indptr) if sp.issparse(a) else (np.asarray(a),)
            total += sum(x.nbytes for x in parts)
    return total


# ---------------------------------------------------------------- packing
def write_packing(path, packing: Packing, *, check: bool = True) -> None:
    """Write a packing; one that its reader would refuse (:func:`granwave.io.validate.packing`,
    e.g. an overlap above half a radius) is refused instead (InputError), and no file is written.
    ``check=False`` writes it as it is (tests of the readers)."""
    c = packing.contacts
    datasets = {"grains/position": packing.position, "grains/radius": packing.radius,
                "grains/mass": packing.mass, "grains/inertia": packing.inertia, "box/size": packing.box,
                "contacts/i": c.i.astype(np.int64), "contacts/j": c.j.astype(np.int64),
                "contacts/normal": c.normal, "contacts/overlap": c.overlap,
                "contacts/force_normal": c.force_normal, "contacts/force_tangential": c.force_tangential,
                "contacts/stiffness_normal": c.stiffness_normal,
                "contacts/stiffness_tangential": c.stiffness_tangential}
    for h in CO.history_datasets():  # a contact sub-model's history, where it keeps one
        if getattr(c, h) is not None:
            datasets[f"contacts/{h}"] = getattr(c, h)
    attrs = {**packing.attrs, "dim": packing.dim, "packing_digest": packing_digest(packing)}
    try:
        if check:
            V.packing(path, {k: np.asarray(v) for k, v in datasets.items()}, attrs)
    except InputError as exc:
        raise InputError(f"{exc} (not written: it would not read back)") from None
    with atomic_h5(path, S.PACKING, attrs, nbytes=_nbytes(*datasets.values())) as f:
        for name, data in datasets.items():
            put(f, S.PACKING, name, data)


def packing_digest(packing: Packing) -> str:
    """An identity of a packing: a hash of its grains (centres, radii), box and contact pairs.

    Like :func:`linear_digest`, a name, not a checksum: linearize copies it into the linear
    file, and from there it reaches the modes and signal files, so that a figure drawing a
    signal's snapshots on a packing's grains can tell whether they belong together.
    """
    import hashlib

    h = hashlib.sha256(np.asarray(packing.position.shape, dtype="<i8").tobytes())
    for a, dtype in ((packing.position, "<f8"), (packing.radius, "<f8"), (packing.box, "<f8"),
                     (packing.contacts.i, "<i8"), (packing.contacts.j, "<i8")):
        h.update(np.ascontiguousarray(a, dtype=dtype).tobytes())
    return h.hexdigest()[:32]


def read_packing(path) -> Packing:
    """Read a packing, validated (:func:`granwave.io.validate.packing`) before use."""
    with open_checked(path, S.PACKING) as f:
        a = _read_all(f, path, S.PACKING)
        attrs = read_attrs(f)
    V.packing(path, a, attrs)
    g = a.__getitem__
    contacts = Contacts(
        i=g("contacts/i").astype(np.int64), j=g("contacts/j").astype(np.int64),
        normal=g("contacts/normal"), overlap=g("contacts/overlap"),
        force_normal=g("contacts/force_normal"), force_tangential=g("contacts/force_tangential"),
        stiffness_normal=g("contacts/stiffness_normal"),
        stiffness_tangential=g("contacts/stiffness_tangential"),
        **{h: a.get(f"contacts/{h}") for h in CO.history_datasets()},
    )
    packing = Packing(position=g("grains/position"), radius=g("grains/radius"), mass=g("grains/mass"),
                      inertia=g("grains/inertia"), box=g("box/size"), contacts=contacts, attrs=attrs)
    packing.attrs["packing_digest"] = packing_digest(packing)  # of what was read (see linear_digest)
    return packing


# ---------------------------------------------------------------- linear system
# The writers look alike (one put() per dataset) but each writes its own schema's
# names: the layout itself lives once, in io/schema.py.
def write_linear(path, system: LinearSystem) -> None:
    D = sp.csr_matrix(system.stiffness)
    if not D.has_canonical_format:  # readers take sorted, unique column indices per row
        D = D.copy()
        D.sum_duplicates()
    size = _nbytes(D, system.mass, system.dof_grain, system.dof_axis, system.source_velocity,
                   system.source_displacement, system.detector, system.shear_source_velocity,
                   system.shear_detector)
    attrs = {**system.attrs, "linear_digest": linear_digest(system)}
    with atomic_h5(path, S.LINEAR, attrs, nbytes=size) as f:
        put(f, S.LINEAR, "matrix/data", D.data)
        put(f, S.LINEAR, "matrix/indices", D.indices.astype(np.int64))
        put(f, S.LINEAR, "matrix/indptr", D.indptr.astype(np.int64))
        f["matrix"].attrs["shape"] = np.asarray(D.shape, dtype=np.int64)
        put(f, S.LINEAR, "mass", system.mass)
        put(f, S.LINEAR, "dof/grain", system.dof_grain.astype(np.int64))
        put(f, S.LINEAR, "dof/axis", system.dof_axis.astype(np.int64))
        put(f, S.LINEAR, "source/velocity", system.source_velocity)
        put(f, S.LINEAR, "source/displacement", system.source_displacement)
        put(f, S.LINEAR, "detector", system.detector)
        if system.shear_source_velocity is not None:
            put(f, S.LINEAR, "shear/source_velocity", system.shear_source_velocity)
            put(f, S.LINEAR, "shear/detector", system.shear_detector)


#: Entries of the stiffness data and column indices that enter :func:`linear_digest` (strided
#: sample above this; the per-dof vectors and row pointers enter whole).
DIGEST_SAMPLE = 1 << 20


def linear_digest(system: LinearSystem) -> str:
    """An identity of a linear system: a hash of D's row pointers and (a strided sample of)
    its entries, M, the dof map and the source and detector vectors.

    Not a checksum against tampering but a name for "this system": the modes file records
    the digest of the system it was computed from (``linear_digest``, copied from the
    linear file's attributes), so that propagate can tell whether the file named by
    ``linear_source`` is still that system. Cost O(n) plus DIGEST_SAMPLE entries.
    """
    import hashlib

    D = sp.csr_matrix(system.stiffness)
    h = hashlib.sha256(np.asarray(D.shape, dtype="<i8").tobytes())
    step = max(1, D.nnz // DIGEST_SAMPLE)
    for a, dtype in ((D.indptr, "<i8"), (D.indices[::step], "<i8"), (D.data[::step], "<f8"),
                     (system.mass, "<f8"), (system.dof_grain, "<i8"), (system.dof_axis, "<i8"),
                     (system.source_velocity, "<f8"), (system.source_displacement, "<f8"),
                     (system.detector, "<f8")):
        h.update(np.ascontiguousarray(a, dtype=dtype).tobytes())
    return h.hexdigest()[:32]


def source_reference(source, output) -> str:
    """How a file written at ``output`` names its input ``source``: relative to the output's
    folder (the pair may move together), or absolute where no relative path exists."""
    try:
        return os.path.relpath(os.path.abspath(source), os.path.dirname(os.path.abspath(output)))
    except ValueError:  # another drive (Windows)
        return os.path.abspath(source)


def linear_of_modes(path, modes: Modes) -> LinearSystem:
    """The linear system a modes file at ``path`` was computed from, read from the file its
    ``linear_source`` attribute names, and checked to be that system.

    A relative ``linear_source`` is looked up beside the modes file first (how eigensolve
    writes it), then, for files written before that rule, from the current folder; an
    absolute one as it is. The file found must match the modes
    (:func:`granwave.io.validate.modes_match_linear`: its digest where the modes file
    records one, its size and sample attributes always); otherwise InputError, one line.
    """
    src = modes.attrs.get("linear_source")
    if not isinstance(src, str) or not src or src == "none":
        raise InputError(f"{path}: no linear_source attribute: snapshots need the dof map of the "
                         "linear file it came from; run propagate on the linear file instead "
                         "(--method modal or time)")
    ref = Path(src)
    candidates = [ref] if ref.is_absolute() else [Path(path).parent / ref, ref]
    found = []
    for c in candidates:
        if c.is_file() and not any(os.path.samefile(c, f) for f in found):
            found.append(c)
    if not found:
        raise InputError(f"{path}: snapshots need the dof map of the linear file it came from "
                         f"({src}, not found beside it{'' if ref.is_absolute() else ' nor here'}); "
                         "run propagate on the linear file instead (--method modal or time)")
    problems = []
    for c in found:
        system = read_linear(c)
        why = V.modes_match_linear(modes, system)
        if why is None:
            return system
        problems.append(f"{c} {why}")
    raise InputError(f"{path}: its linear_source {src!r} is not the system of these modes: "
                     f"{'; '.join(problems)}; run propagate on the right linear file instead")


def read_linear(path) -> LinearSystem:
    """Read a linear system, validated (:func:`granwave.io.validate.linear`) before scipy sees it."""
    with open_checked(path, S.LINEAR) as f:
        a = _read_all(f, path, S.LINEAR)
        shape = f["matrix"].attrs.get("shape")
        attrs = read_attrs(f)
    if shape is None:
        raise InputError(f"{path}: matrix: missing shape attribute")
    V.linear(path, a, attrs, shape)
    n = len(a["mass"])
    D = sp.csr_matrix((a["matrix/data"], a["matrix/indices"], a["matrix/indptr"]), shape=(n, n))
    V.stiffness_symmetry(path, D, attrs)  # an edited D is refused before its modes are written
    system = LinearSystem(
        stiffness=D, mass=a["mass"], dof_grain=a["dof/grain"], dof_axis=a["dof/axis"],
        source_velocity=a["source/velocity"], source_displacement=a["source/displacement"],
        detector=a["detector"], attrs=attrs,
        shear_source_velocity=a.get("shear/source_velocity"), shear_detector=a.get("shear/detector"),
    )
    # the identity of what was read (a stored one may be stale after an edit); eigensolve
    # copies it into the modes file
    system.attrs["linear_digest"] = linear_digest(system)
    return system


# ---------------------------------------------------------------- modes
def write_modes(path, modes: Modes) -> None:
    size = _nbytes(modes.omega2, modes.amplitude_A, modes.amplitude_B, modes.coupling, modes.vectors,
                   modes.shear_amplitude_A, modes.shear_coupling)
    with atomic_h5(path, S.MODES, {**modes.attrs, "has_vectors": modes.vectors is not None},
                   nbytes=size) as f:
        put(f, S.MODES, "omega2", modes.omega2)
        put(f, S.MODES, "amplitude_A", modes.amplitude_A)
        put(f, S.MODES, "amplitude_B", modes.amplitude_B)
        put(f, S.MODES, "coupling", modes.coupling)
        if modes.shear_amplitude_A is not None:
            put(f, S.MODES, "shear/amplitude_A", modes.shear_amplitude_A)
            put(f, S.MODES, "shear/coupling", modes.shear_coupling)
        if modes.vectors is not None:
            put(f, S.MODES, "vectors", modes.vectors)


def read_modes(path, *, vectors: bool = False) -> Modes:
    """Read a modes file, validated before use; the (large) eigenvectors only when asked for."""
    with open_checked(path, S.MODES) as f:
        if vectors and "vectors" not in f:
            raise InputError(f"{path}: no eigenvectors stored (rerun eigensolve with --vectors)")
        a = _read_all(f, path, S.MODES, skip=() if vectors else ("vectors",))
        attrs = read_attrs(f)
    V.modes(path, a, attrs)
    return Modes(omega2=a["omega2"], amplitude_A=a["amplitude_A"], amplitude_B=a["amplitude_B"],
                 coupling=a["coupling"], vectors=a.get("vectors"), attrs=attrs,
                 shear_amplitude_A=a.get("shear/amplitude_A"), shear_coupling=a.get("shear/coupling"))


# ---------------------------------------------------------------- signal
def write_signal(path, signal: Signal) -> None:
    """Write a signal file; a signal or snapshot that is not finite (an unstable integration) is
    refused with ConvergenceError before anything is written."""
    for name, values in (("signal", signal.force), ("time axis", signal.time),
                         ("snapshot displacement", signal.snapshot_displacement)):
        if values is not None and not np.all(np.isfinite(values)):
            raise ConvergenceError(f"{path}: the {name} is not finite (NaN or inf): the integration "
                                   f"became unstable; use a smaller time step (--dt or --safety)")
        if values is not None and name != "time axis" and np.size(values) and \
                float(np.max(np.abs(values))) > V.MAX_MAGNITUDE:  # what the reader would refuse
            raise ConvergenceError(f"{path}: the {name} reaches {float(np.max(np.abs(values))):.3g}, "
                                   f"beyond +-{V.MAX_MAGNITUDE:g}: the integration became unstable; "
                                   "use a smaller time step (--dt or --safety)")
    size = _nbytes(signal.time, signal.force, signal.snapshot_time, signal.snapshot_displacement,
                   signal.dof_grain, signal.dof_axis, signal.position,
                   *(signal.pulse.values() if signal.pulse is not None else ()))
    with atomic_h5(path, S.SIGNAL, signal.attrs, nbytes=size) as f:
        put(f, S.SIGNAL, "signal/time", signal.time)
        put(f, S.SIGNAL, "signal/force", signal.force)
        if signal.snapshot_time is not None:
            put(f, S.SIGNAL, "snapshots/time", signal.snapshot_time)
            put(f, S.SIGNAL, "snapshots/displacement", signal.snapshot_displacement)
            put(f, S.SIGNAL, "snapshots/dof_grain", signal.dof_grain)
            put(f, S.SIGNAL, "snapshots/dof_axis", signal.dof_axis)
            if signal.position is not None:
                put(f, S.SIGNAL, "snapshots/position", signal.position)
        if signal.pulse is not None:
            put(f, S.SIGNAL, "pulse/time", signal.time)
            for name in S.PULSE_DATASETS[1:]:
                put(f, S.SIGNAL, name, signal.pulse[name.split("/")[1]])
            if "opened" in signal.pulse:  # the contact counts (pulses since schema 1.4)
                for name in S.PULSE_CONTACTS:
                    put(f, S.SIGNAL, name, signal.pulse[name.split("/")[1]])


def read_signal(path) -> Signal:
    """Read a signal file, validated (:func:`granwave.io.validate.signal`) before use."""
    with open_checked(path, S.SIGNAL) as f:
        a = _read_all(f, path, S.SIGNAL)
        attrs = read_attrs(f)
    V.signal(path, a, attrs)
    attrs.setdefault("source_kind", "normal")  # files before 1.2 hold the normal kick only
    sig = Signal(time=a["signal/time"], force=a["signal/force"], attrs=attrs)
    if "snapshots/time" in a:
        sig.snapshot_time = a["snapshots/time"]
        sig.snapshot_displacement = a["snapshots/displacement"]
        sig.dof_grain = a["snapshots/dof_grain"]
        sig.dof_axis = a["snapshots/dof_axis"]
        sig.position = a.get("snapshots/position")
    if "pulse/height" in a:
        sig.pulse = {name.split("/")[1]: a[name] for name in S.PULSE_DATASETS[1:]
                     + (S.PULSE_CONTACTS if "pulse/opened" in a else ())}
    return sig
