"""Reading and writing granwave HDF5 files (layout: :mod:`granwave.io.schema`).

Writes are atomic: the file is built under a temporary name in the target
folder and renamed into place only when complete, so a stage killed halfway
never leaves a file that looks finished. Every write goes through
:func:`check_writable`, which refuses an output that would destroy something:
``-``, an existing target that is not a regular file (a folder, a device such
as /dev/null, a FIFO) and a target that is the same file (path, hard or
symbolic link) as a file read in this process. Outputs get the permissions the
umask allows; temporary files left by killed runs are removed by the next
write of the same output; a write that fails (disk full) leaves no file and
raises :class:`~granwave.errors.OutputError` with one line.

Readers check the schema name and major version, then validate every dataset
(:mod:`granwave.io.validate`) before returning, and refuse anything else with
an :class:`InputError`.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import socket
import stat
import tempfile
import time
import zlib
from pathlib import Path
from typing import Iterator

import h5py
import numpy as np
import scipy.sparse as sp

from ..contact_models import options as CO
from ..errors import ConvergenceError, InputError, OutputError
from ..model import Contacts, LinearSystem, Modes, Packing, Signal
from ..provenance import FILE_ATTRS, provenance_attrs
from . import schema as S
from . import validate as V


# ---------------------------------------------------------------- generic layer
#: Root attributes that describe the file itself, never copied from a caller's attrs.
RESERVED_ATTRS = frozenset(FILE_ATTRS)

#: Absolute paths of every file read in this process (insertion ordered), so that no
#: write replaces one of them (checked by identity: links count).
_INPUTS: dict[str, None] = {}

#: A temporary file of another host, or of an older granwave, is stale after this long (s).
STALE_AGE = 3600.0

#: This host, in the tag of temporary names (see :func:`_tag`).
_HOST = f"{zlib.crc32(socket.gethostname().encode()):08x}"


def _tag() -> str:
    """Tag in temporary names: the writing process and host, so that the next run can
    tell a killed writer's leftovers from a live writer's file (computed per call: a
    forked worker has its own pid)."""
    return f"p{os.getpid()}h{_HOST}"


def record_input(path: str | os.PathLike) -> None:
    """Remember that ``path`` was read: later writes refuse to replace it."""
    _INPUTS[os.path.abspath(path)] = None


def inputs_read() -> list[str]:
    """The files read so far in this process (absolute paths)."""
    return list(_INPUTS)


def same_file_as(path: str | os.PathLike, candidates) -> str | None:
    """The first of ``candidates`` that is the same file as ``path`` (links count), or None."""
    if not os.path.exists(path):
        return None
    for c in candidates:
        try:
            if os.path.samefile(c, path):
                return str(c)
        except (OSError, TypeError, ValueError):
            continue
    return None


def check_target(path: str | os.PathLike, inputs=None) -> None:
    """Refuse a target whose replacement would destroy something.

    Refused: ``-`` (no stage writing through here writes to standard output), an
    existing target that is not a regular file (a folder, a device such as
    /dev/null, a FIFO), and a target that is the same file as one of ``inputs``
    (default: every file read in this process; ``()``: none).
    """
    if str(path) == "-":
        raise InputError("cannot write to '-' (standard output): this output must be a file name")
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return  # absent (or a dangling link, which the rename replaces)
    if not stat.S_ISREG(mode):
        kind = ("a folder" if stat.S_ISDIR(mode) else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
                else "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode)
                else "not a regular file")
        raise InputError(f"cannot write {path}: it is {kind}, not a regular file")
    same = same_file_as(path, _INPUTS if inputs is None else inputs)
    if same is not None:
        raise InputError(f"cannot write {path}: it is the input file {same}; "
                         "choose another output name")
    if _read_only(path):
        raise InputError(f"cannot write {path}: it exists and is read-only; remove it or make it "
                         "writable first (granwave does not replace a read-only file)")


def _read_only(path) -> bool:
    """Whether an existing file is read-only for this user: no write permission where the
    kernel would check it (owner, else any write bit; root is not exempt, so that a file
    protected with chmod a-w is never replaced by the rename of an atomic write)."""
    try:
        st = os.stat(path)
    except OSError:
        return False
    if st.st_uid == os.geteuid():
        return not st.st_mode & stat.S_IWUSR
    if os.geteuid() == 0:
        return not st.st_mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH)
    return not os.access(path, os.W_OK)


def check_writable(path: str | os.PathLike, *, replace_input: bool = False) -> Path:
    """Fail early (before any computation) if ``path`` cannot or must not be written.

    Besides :func:`check_target` (``replace_input``: a stage that updates a file in
    place may replace a file it read), the folder must exist and be writable, and
    the name and its temporary name must fit the file system (:func:`check_name_length`).
    """
    check_target(path, () if replace_input else None)
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"cannot write {path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise InputError(f"cannot write {path}: folder {folder} is not writable")
    check_name_length(path)
    return path


#: Random characters tempfile.mkstemp puts in a name (its _RandomNameSequence).
_RANDOM_CHARS = 8


def _temporary_prefix_suffix(path: Path, suffix: str = "") -> tuple[str, str]:
    """The prefix and suffix of :func:`_temporary`'s name for ``path`` (one home)."""
    return f".{path.name}.{_tag()}.", f"{suffix}.tmp"


def check_name_length(path: str | os.PathLike, *, temporary: bool = True) -> None:
    """Refuse a name longer than its folder's file system allows (``PC_NAME_MAX``).

    ``temporary``: the temporary name an atomic write forms from it (longer by the
    writer's tag, random characters and the file's suffix plus ``.tmp``) must fit
    too, so that a long name fails here, not after the whole computation.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        limit = os.pathconf(folder if folder.is_dir() else ".", "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    if not limit or limit < 0:
        return
    name = len(os.fsencode(path.name))
    if name > limit:
        raise InputError(f"cannot write {path}: its name is {name} bytes, over the file "
                         f"system's {limit}; choose a shorter name")
    if temporary:
        prefix, suffix = _temporary_prefix_suffix(path, path.suffix)
        tmp = len(os.fsencode(prefix + suffix)) + _RANDOM_CHARS
        if tmp > limit:
            raise InputError(f"cannot write {path}: its name is {name} bytes and the temporary "
                             f"name written first is {tmp - name} bytes longer, over the file "
                             f"system's {limit}; choose a name of at most {limit - (tmp - name)} bytes")


def _umask() -> int:
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)  # no read-only query elsewhere: set and restore
    os.umask(mask)
    return mask


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Remove ``.NAME.*.tmp`` files beside ``path`` left by killed writers; return them.

    A temporary of this host whose writer process is gone is stale at once; one of
    another host or an older naming only after STALE_AGE seconds without change
    (a live writer on a shared file system keeps modifying its file).
    """
    removed = []
    prefix = f".{path.name}."
    try:
        entries = list(os.scandir(path.parent if str(path.parent) else "."))
    except OSError:
        return removed
    now = time.time()
    for e in entries:
        if not (e.name.startswith(prefix) and e.name.endswith(".tmp")):
            continue
        try:
            if not e.is_file(follow_symlinks=False):
                continue
            tag = e.name[len(prefix):].split(".", 1)[0]
            stale = now - e.stat(follow_symlinks=False).st_mtime > STALE_AGE
            if tag.startswith("p") and "h" in tag:
                pid, host = tag[1:].split("h", 1)
                if host == _HOST and pid.isdigit() and int(pid) != os.getpid():
                    stale = stale or not _pid_alive(int(pid))
            if stale:
                os.unlink(e.path)
                removed.append(Path(e.path))
        except (OSError, ValueError):
            continue
    return removed


def _temporary(path: Path, suffix: str = "") -> str:
    """A new empty file beside ``path``, with the permissions the umask gives new files."""
    remove_stale_temporaries(path)
    try:
        prefix, suffix = _temporary_prefix_suffix(path, suffix)
        fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=suffix,
                                   dir=path.parent if str(path.parent) else ".")
    except OSError as exc:  # no space or no inode left for even an empty file
        raise _write_failure(path, exc) from None
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; outputs are ordinary files
    return tmp


def _write_failure(path: Path, exc: OSError) -> OutputError:
    """One line for a failed write: a full disk says so and how much space is left."""
    text = str(exc)
    if getattr(exc, "errno", None) == errno.ENOSPC or "No space left" in text:
        from ..resources import available_disk, format_bytes

        free = available_disk(path.parent if str(path.parent) else ".")
        reason = f"no space left on the device ({format_bytes(free)} free); no output written"
    else:
        first = text.splitlines()[0] if text else exc.__class__.__name__
        reason = f"{getattr(exc, 'strerror', None) or first}; no output written"
    return OutputError(f"cannot write {path}: {reason}")


#: Renames held back until the running command has written all its outputs
#: (:func:`outputs_together`): (temporary, target, replace_input); None: rename at once.
_PENDING: list | None = None


@contextlib.contextmanager
def outputs_together(keep=None) -> Iterator[None]:
    """All the atomic writes inside the block appear together, or none does.

    Each write goes to its temporary file as usual, but the renames wait for the end of
    the block: then every target is checked again (:func:`check_writable`) and all are
    renamed. A failure anywhere inside (a later output refused, an error, Ctrl-C, SIGTERM)
    removes every temporary, so a command never leaves some of its outputs behind (a
    report without its HTML twin, part of a VTK series, a sweep's tables without the
    sweep). ``keep``: a test of the exception under which the files written so far are
    still renamed into place before it propagates (the command line's: printing the
    summary failed, after the outputs were complete). Nested blocks join the outermost
    one. :func:`granwave.cli.common.stage` runs every command inside one.
    """
    global _PENDING
    if _PENDING is not None:
        yield
        return
    _PENDING = pending = []
    try:
        try:
            yield
        except BaseException as exc:
            if keep is not None and isinstance(exc, Exception) and keep(exc):
                _rename_all(pending)
            raise
        _rename_all(pending)
    finally:
        _PENDING = None
        for tmp, _, _ in pending:  # what was not renamed (an error, an interrupt)
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _rename_all(pending: list) -> None:
    """Check every held-back target again, then rename them all; a rename that fails takes
    back the files this command already put in place (one OutputError line)."""
    for _, path, replace_input in pending:  # a target may have appeared meanwhile
        check_writable(path, replace_input=replace_input)
    done: list[Path] = []
    for entry in list(pending):
        tmp, path, _ = entry
        try:
            os.replace(tmp, path)
        except OSError as exc:
            for p in done:
                with contextlib.suppress(OSError):
                    os.unlink(p)
            raise _write_failure(Path(path), exc) from None
        pending.remove(entry)  # renamed: no longer a temporary to remove
        done.append(path)


@contextlib.contextmanager
def _replace_on_success(path: Path, tmp: str, replace_input: bool) -> Iterator[None]:
    """Rename ``tmp`` to ``path`` when the body succeeds (at the end of the enclosing
    :func:`outputs_together` block, if any); remove it otherwise."""
    try:
        yield
        check_writable(path, replace_input=replace_input)  # the target may have appeared meanwhile
        if _PENDING is not None:
            _PENDING.append((tmp, path, replace_input))
            return
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise _write_failure(path, exc) from None
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


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


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path beside ``path``; it is renamed to ``path`` only on success.

    For writers that want a file name rather than a handle (matplotlib's savefig,
    h5py): the one home of the temporary-then-rename rule. ``suffix`` keeps the
    extension a writer may look at (".png").
    """
    path = check_writable(path)
    tmp = _temporary(path, suffix)
    with _replace_on_success(path, tmp, False):
        yield Path(tmp)


def atomic_text(path: str | os.PathLike, text: str, *, replace_input: bool = False) -> None:
    """Write a text file (JSON, Markdown, CSV) atomically: temporary file, then rename.

    ``replace_input``: the write deliberately updates a file read in this process.
    """
    path = check_writable(path, replace_input=replace_input)
    tmp = _temporary(path)
    with _replace_on_success(path, tmp, replace_input):
        with open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)


def jsonable(x):
    """``x`` with numpy arrays and scalars as plain lists and numbers, NaN/inf as None
    and dict keys as strings: the one rule by which granwave writes and prints JSON."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, np.generic):
        return jsonable(x.item())
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def replace_marked_block(path: str | os.PathLike, begin: str, end: str, text: str) -> None:
    """Replace what lies between the lines ``begin`` and ``end`` of a text file (atomically).

    How the benchmarks regenerate their tables inside hand-written docs.
    """
    path = Path(path)
    doc = path.read_text(encoding="utf-8")
    if begin not in doc or end not in doc:
        raise InputError(f"{path} has no {begin} ... {end} markers")
    head, rest = doc.split(begin, 1)
    _, tail = rest.split(end, 1)
    atomic_text(path, head + begin + "\n" + text + "\n" + end + tail)


def load_json(path: str | os.PathLike) -> object:
    """Read a JSON file; an unreadable or malformed file is an InputError naming it."""
    record_input(path)
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
        if found != schema:
            raise InputError(f"{path}: expected a {schema} file, found schema {found!r}")
        version = str(attrs.get("schema_version", ""))
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
def write_packing(path, packing: Packing) -> None:
    c = packing.contacts
    size = _nbytes(packing.position, packing.radius, packing.mass, packing.inertia, c.i, c.j,
                   c.normal, c.overlap, c.force_normal, c.force_tangential, c.stiffness_normal,
                   c.stiffness_tangential, *(getattr(c, h) for h in CO.history_datasets()))
    attrs = {**packing.attrs, "dim": packing.dim, "packing_digest": packing_digest(packing)}
    with atomic_h5(path, S.PACKING, attrs, nbytes=size) as f:
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
        for h in CO.history_datasets():  # a contact sub-model's history, where it keeps one
            if getattr(c, h) is not None:
                put(f, S.PACKING, f"contacts/{h}", getattr(c, h))


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
                   signal.dof_grain, signal.dof_axis, signal.position)
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
    return sig
