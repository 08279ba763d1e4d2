"""Reading and writing granwave HDF5 files (layout: :mod:`granwave.io.schema`).

Writes are atomic: the file is built under a temporary name in the target
folder and renamed into place only when complete, so a stage killed halfway
never leaves a file that looks finished. Readers check the schema name and
major version and refuse anything else with an :class:`InputError`.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path
from typing import Iterator

import h5py
import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..model import Contacts, LinearSystem, Modes, Packing, Signal
from ..provenance import FILE_ATTRS, provenance_attrs
from . import schema as S


# ---------------------------------------------------------------- generic layer
#: Root attributes that describe the file itself, never copied from a caller's attrs.
RESERVED_ATTRS = frozenset(FILE_ATTRS)


def check_writable(path: str | os.PathLike) -> Path:
    """Fail early (before any computation) if ``path`` cannot be written."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"cannot write {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise InputError(f"cannot write {path}: folder {folder} is not writable")
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder")
    return path


@contextlib.contextmanager
def atomic_h5(path: str | os.PathLike, schema: str, attrs: dict) -> Iterator[h5py.File]:
    """Open a new HDF5 file for writing; it appears at ``path`` only on success."""
    path = check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    os.close(fd)
    try:
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
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; it is renamed to ``path`` only on success.

    For writers that want a file name rather than a handle (matplotlib's savefig,
    h5py): the one home of the temporary-then-rename rule. ``suffix`` keeps the
    extension a writer may look at (".png").
    """
    path = check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f"{suffix}.tmp", dir=path.parent or ".")
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_text(path: str | os.PathLike, text: str) -> None:
    """Write a text file (JSON, Markdown, CSV) atomically: temporary file, then rename."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def load_json(path: str | os.PathLike) -> object:
    """Read a JSON file; an unreadable or malformed file is an InputError naming it."""
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not a JSON file ({exc.msg}, line {exc.lineno})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a JSON file (not UTF-8 text)") from None


def _set_attr(f: h5py.File, key: str, value) -> None:
    if value is None:
        value = "none"
    if isinstance(value, (list, tuple)):
        value = np.asarray(value)
    f.attrs[key] = value


def put(f: h5py.File, schema: str, name: str, data) -> None:
    """Write one dataset with its ``units`` attribute from the schema table."""
    units, _ = S.DATASETS[schema][name]
    ds = f.create_dataset(name, data=np.asarray(data))
    ds.attrs["units"] = units


def _attr_value(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


@contextlib.contextmanager
def open_checked(path: str | os.PathLike, schema: str) -> Iterator[h5py.File]:
    """Open a granwave file for reading, refusing a foreign schema or major version."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"{path}: not an HDF5 file ({exc.__class__.__name__})") from None
    with f:
        found = _attr_value(f.attrs.get("schema", ""))
        if found != schema:
            raise InputError(f"{path}: expected a {schema} file, found schema {found!r}")
        version = str(_attr_value(f.attrs.get("schema_version", "")))
        if version.split(".")[0] != S.VERSIONS[schema].split(".")[0]:
            raise InputError(
                f"{path}: schema version {version!r} is not readable by this granwave "
                f"(reads {schema} {S.VERSIONS[schema].split('.')[0]}.x)"
            )
        missing = [a for a in S.REQUIRED_ATTRS[schema] if a not in f.attrs]
        if missing:
            raise InputError(f"{path}: missing root attribute(s) {', '.join(missing)}")
        yield f


def read_attrs(f: h5py.File) -> dict:
    return {k: _attr_value(v) for k, v in f.attrs.items()}


def file_schema(path: str | os.PathLike) -> str:
    """The schema name of a granwave file (for stages that take several kinds)."""
    try:
        with h5py.File(path, "r") as f:
            return str(_attr_value(f.attrs.get("schema", "")))
    except OSError:
        raise InputError(f"{path}: not an HDF5 file") from None


def _finite(path, name: str, arr: np.ndarray) -> np.ndarray:
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise InputError(f"{path}: dataset {name} contains NaN or infinite values")
    return arr


def _get(f: h5py.File, path, name: str) -> np.ndarray:
    if name not in f:
        raise InputError(f"{path}: missing dataset {name}")
    return _finite(path, name, f[name][()])


# ---------------------------------------------------------------- packing
def write_packing(path, packing: Packing) -> None:
    c = packing.contacts
    with atomic_h5(path, S.PACKING, {**packing.attrs, "dim": packing.dim}) as f:
        put(f, S.PACKING, "grains/position", packing.position)
        put(f, S.PACKING, "grains/radius", packing.radius)
        put(f, S.PACKING, "grains/mass", packing.mass)
        put(f, S.PACKING, "grains/inertia", packing.inertia)
        put(f, S.PACKING, "box/size", packing.box)
        put(f, S.PACKING, "contacts/i", c.i.astype(np.int64))
        put(f, S.PACKING, "contacts/j", c.j.astype(np.int64))
        put(f, S.PACKING, "contacts/normal", c.normal)
        put(f, S.PACKING, "contacts/overlap", c.overlap)
        put(f, S.PACKING, "contacts/force_normal", c.force_normal)
        put(f, S.PACKING, "contacts/force_tangential", c.force_tangential)
        put(f, S.PACKING, "contacts/stiffness_normal", c.stiffness_normal)
        put(f, S.PACKING, "contacts/stiffness_tangential", c.stiffness_tangential)


def read_packing(path) -> Packing:
    with open_checked(path, S.PACKING) as f:
        g = lambda name: _get(f, path, name)  # noqa: E731
        contacts = Contacts(
            i=g("contacts/i").astype(np.int64), j=g("contacts/j").astype(np.int64),
            normal=g("contacts/normal"), overlap=g("contacts/overlap"),
            force_normal=g("contacts/force_normal"),
            force_tangential=g("contacts/force_tangential"),
            stiffness_normal=g("contacts/stiffness_normal"),
            stiffness_tangential=g("contacts/stiffness_tangential"),
        )
        packing = Packing(
            position=g("grains/position"), radius=g("grains/radius"), mass=g("grains/mass"),
            inertia=g("grains/inertia"), box=g("box/size"), contacts=contacts,
            attrs=read_attrs(f),
        )
    n = packing.n_grains
    if len(contacts) and (contacts.i.min() < 0 or contacts.i.max() >= n or contacts.j.max() >= n
                          or contacts.j.min() < S.TOP_WALL):
        raise InputError(f"{path}: contact indices out of range")
    return packing


# ---------------------------------------------------------------- linear system
def write_linear(path, system: LinearSystem) -> None:
    D = sp.csr_matrix(system.stiffness)
    with atomic_h5(path, S.LINEAR, system.attrs) as f:
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


def read_linear(path) -> LinearSystem:
    with open_checked(path, S.LINEAR) as f:
        g = lambda name: _get(f, path, name)  # noqa: E731
        shape = tuple(int(s) for s in f["matrix"].attrs["shape"])
        D = sp.csr_matrix((g("matrix/data"), g("matrix/indices"), g("matrix/indptr")), shape=shape)
        return LinearSystem(
            stiffness=D, mass=g("mass"), dof_grain=g("dof/grain"), dof_axis=g("dof/axis"),
            source_velocity=g("source/velocity"), source_displacement=g("source/displacement"),
            detector=g("detector"), attrs=read_attrs(f),
        )


# ---------------------------------------------------------------- modes
def write_modes(path, modes: Modes) -> None:
    with atomic_h5(path, S.MODES, {**modes.attrs, "has_vectors": modes.vectors is not None}) as f:
        put(f, S.MODES, "omega2", modes.omega2)
        put(f, S.MODES, "amplitude_A", modes.amplitude_A)
        put(f, S.MODES, "amplitude_B", modes.amplitude_B)
        put(f, S.MODES, "coupling", modes.coupling)
        if modes.vectors is not None:
            put(f, S.MODES, "vectors", modes.vectors)


def read_modes(path, *, vectors: bool = False) -> Modes:
    """Read a modes file; the (large) eigenvectors only when ``vectors`` is asked for."""
    with open_checked(path, S.MODES) as f:
        g = lambda name: _get(f, path, name)  # noqa: E731
        vecs = None
        if vectors:
            if "vectors" not in f:
                raise InputError(f"{path}: no eigenvectors stored (rerun eigensolve with --vectors)")
            vecs = g("vectors")
        return Modes(omega2=g("omega2"), amplitude_A=g("amplitude_A"),
                     amplitude_B=g("amplitude_B"), coupling=g("coupling"), vectors=vecs,
                     attrs=read_attrs(f))


# ---------------------------------------------------------------- signal
def write_signal(path, signal: Signal) -> None:
    with atomic_h5(path, S.SIGNAL, signal.attrs) as f:
        put(f, S.SIGNAL, "signal/time", signal.time)
        put(f, S.SIGNAL, "signal/force", signal.force)
        if signal.snapshot_time is not None:
            put(f, S.SIGNAL, "snapshots/time", signal.snapshot_time)
            put(f, S.SIGNAL, "snapshots/displacement", signal.snapshot_displacement)
            put(f, S.SIGNAL, "snapshots/dof_grain", signal.dof_grain)
            put(f, S.SIGNAL, "snapshots/dof_axis", signal.dof_axis)
            if signal.position is not None:
                put(f, S.SIGNAL, "snapshots/position", signal.position)


def read_signal(path) -> Signal:
    with open_checked(path, S.SIGNAL) as f:
        g = lambda name: _get(f, path, name)  # noqa: E731
        sig = Signal(time=g("signal/time"), force=g("signal/force"), attrs=read_attrs(f))
        if "snapshots/time" in f:
            sig.snapshot_time = g("snapshots/time")
            sig.snapshot_displacement = g("snapshots/displacement")
            sig.dof_grain = g("snapshots/dof_grain")
            sig.dof_axis = g("snapshots/dof_axis")
            if "snapshots/position" in f:
                sig.position = g("snapshots/position")
        return sig
