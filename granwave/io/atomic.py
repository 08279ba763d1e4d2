"""Safe output files of every kind: atomic writes and the checks before them.

A file is built under a temporary name in the target folder and renamed into place only when
complete, so a stage killed halfway never leaves a file that looks finished. Every write goes
through :func:`check_writable`, which refuses an output that would destroy something: ``-``, an
existing target that is not a regular file (a folder, a device such as /dev/null, a FIFO) and a
target that is the same file (path, hard or symbolic link) as a file read in this process
(:func:`record_input`). Outputs get the permissions the umask allows; temporary files left by
killed runs are removed by the next write of the same output; a write that fails (disk full)
leaves no file and raises :class:`~granwave.errors.OutputError` with one line. The HDF5 layer
on top of it is :mod:`granwave.io.files`.
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

import numpy as np

from ..errors import InputError, OutputError


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
#: What runs once those outputs are all in place (:func:`after_outputs`); None: at once.
_AFTER: list | None = None


def after_outputs(callback) -> None:
    """Call ``callback()`` once the running command's outputs are all in place: at the end of the
    enclosing :func:`outputs_together` block, and only when its renames succeed (at once outside
    one). For what may go only when the outputs exist (a preparation's checkpoint)."""
    if _AFTER is None:
        callback()
    else:
        _AFTER.append(callback)


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
    global _PENDING, _AFTER
    if _PENDING is not None:
        yield
        return
    _PENDING = pending = []
    _AFTER = after = []
    try:
        try:
            yield
        except BaseException as exc:
            if keep is not None and isinstance(exc, Exception) and keep(exc):
                _rename_all(pending)
                _AFTER = None
                for callback in after:
                    callback()
            raise
        _rename_all(pending)
        _AFTER = None
        for callback in after:
            callback()
    finally:
        _PENDING = _AFTER = None
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


#: Deepest nesting of lists and objects a JSON input may have: granwave's own files nest a
#: few levels; far deeper is no summary (and Python's decoder, or any walk over it, would
#: run out of recursion).
MAX_JSON_DEPTH = 64


def _json_depth(obj) -> int:
    """Nesting depth of lists and dicts in ``obj`` ([] and {"a": 1} are 1; iterative: any
    depth is safe)."""
    depth, level = 0, [obj]
    while True:
        level = [x for x in level if isinstance(x, (list, dict))]
        if not level:
            return depth
        depth += 1
        level = [v for x in level for v in (x.values() if isinstance(x, dict) else x)]


def load_json(path: str | os.PathLike) -> object:
    """Read a JSON file; an unreadable or malformed file, or one nested deeper than
    MAX_JSON_DEPTH, is an InputError naming it."""
    record_input(path)
    deep = InputError(f"{path}: not a granwave JSON file (nested more than {MAX_JSON_DEPTH} levels deep)")
    try:
        with open(path, encoding="utf-8") as f:
            obj = json.load(f)
        if _json_depth(obj) > MAX_JSON_DEPTH:
            raise deep
        return obj
    except RecursionError:
        raise deep from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not a JSON file ({exc.msg}, line {exc.lineno})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a JSON file (not UTF-8 text)") from None


