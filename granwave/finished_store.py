"""The finished-sample store of a workflow batch: what a killed batch job keeps.

A batch job (workflow/rules/batches.smk) makes up to ``batch_size`` samples, and Snakemake
removes every output of a job that did not end well (a time limit, Ctrl-C, a crash) before it
runs the job again. So each sample is also kept, as it finishes, in its batch's store:
``<results>/finished/<batch>/<scene>/<pressure>/<size>/<seed>/`` (no rule's output, so
Snakemake leaves it alone), one file per stage (``packing.h5``, ..., ``summary.json``) and a
``stamp.json`` written last, which holds the digest of the sample's recipe (the sample's dict as
the batch receives it), the files' sizes and the sample's timing rows. When the batch runs
again, a sample whose entry is complete and has the same recipe is put back at its output
paths (the same bytes) instead of being computed, once the files themselves are checked to
record the parameters the sample asks for (:func:`provenance_mismatch`); any other entry is
replaced when its sample finishes. The batch removes its store once it has written all its outputs.

Files are hard links of the outputs (no extra disk) where the file system allows them, else
copies (the store then holds a second copy of the batch's finished samples until it ends).
Both are written beside their target and renamed into place (granwave.io.files.atomic_file).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
from pathlib import Path

from .errors import InputError, OutputError

#: The stamp's kind and version: a stamp of another kind or version is not used.
STAMP_KIND = "granwave.finished_sample"
STAMP_VERSION = 1
STAMP_NAME = "stamp.json"

#: For tests only: a batch stops (KeyboardInterrupt, as SIGTERM makes it) after computing and
#: keeping this many samples, so that a test can cut a batch at a known sample.
STOP_AFTER_ENV = "GRANWAVE_TEST_STOP_BATCH_AFTER"


def recipe_digest(sample: dict) -> str:
    """SHA-256 of ``sample`` as canonical JSON (sorted keys): any change of an option, a path or
    a stage gives another digest, so a changed config never reuses the files of the old one."""
    text = json.dumps(sample, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def sample_files(sample: dict) -> dict[str, str]:
    """{stage: path} of the files a batch makes for ``sample`` (its ``out``): the batch rule's
    outputs, i.e. without a packing that is given (made by the GPU job of its height)."""
    return {stage: path for stage, path in sample["out"].items()
            if not (stage == "packing" and sample.get("packing_given"))}


def entry_of(store, sample: dict, keys) -> Path:
    """The folder of ``sample`` in ``store``: one level per key (scene, pressure, size, seed)."""
    return Path(store).joinpath(*(str(sample[k]) for k in keys))


def _place(source, target) -> str:
    """``target`` becomes the file ``source`` (a hard link, else a copy), atomically; returns
    "link" or "copy". Nothing is done when ``target`` is already that file."""
    from .io.files import atomic_file

    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    if target.exists() and os.path.samefile(source, target):
        return "link"
    with atomic_file(target) as tmp:
        os.unlink(tmp)  # os.link makes a new name only
        try:
            os.link(source, tmp)
            return "link"
        except OSError:  # no hard links here (some network or FUSE file systems), or another device
            shutil.copyfile(source, tmp)
            return "copy"


def _stamp(entry: Path) -> dict | None:
    """The entry's stamp, or None (absent, unreadable, of another kind or version)."""
    try:
        stamp = json.loads((entry / STAMP_NAME).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(stamp, dict) or stamp.get("kind") != STAMP_KIND or stamp.get("version") != STAMP_VERSION:
        return None
    return stamp


def _recorded(path: Path) -> dict | None:
    """The parameters a kept file records: an HDF5 file's attributes, a JSON object's keys;
    None for a file that records none (another format)."""
    if path.suffix == ".h5":
        import h5py

        try:
            if not h5py.is_hdf5(path):
                return None
            with h5py.File(path, "r") as f:
                return {k: f.attrs[k] for k in f.attrs}
        except (OSError, RuntimeError, ValueError):
            return {"unreadable": True}
    if path.suffix == ".json":
        try:
            obj = json.loads(path.read_text())
        except (OSError, ValueError):
            return None
        return obj if isinstance(obj, dict) else None
    return None


def _same(recorded, wanted) -> bool:
    import numpy as np

    if isinstance(wanted, bool) or isinstance(recorded, (bool, np.bool_)):
        return bool(recorded) == bool(wanted)
    if isinstance(wanted, (int, float)):
        try:
            return math.isclose(float(recorded), float(wanted), rel_tol=1e-9, abs_tol=0.0)
        except (TypeError, ValueError):
            return False
    if isinstance(recorded, bytes):
        recorded = recorded.decode(errors="replace")
    return str(recorded) == str(wanted)


def provenance_mismatch(entry: Path, kept: dict, sample: dict) -> str | None:
    """What the kept files of ``sample`` record against what this run asks for, or None when
    they agree: the packing's recorded parameters against the sample's ``make`` options (the
    ones both name: seed, pressure, friction, grains, ...), and the packing digest of every
    file that records one against the packing's (the kept one, or the given packing at its
    output path: device gpu remakes it). The stamp's recipe digest says what the batch asked
    for; this says what the files are, so an entry copied from another config's results or
    left by a config edited mid-run is not put back under this run's names."""
    recorded = {stage: _recorded(entry / info["name"]) for stage, info in kept.items()
                if isinstance(info, dict) and "name" in info}
    for stage, attrs in recorded.items():
        if attrs and attrs.get("unreadable") is True:
            return f"{kept[stage]['name']} is not readable"
    packing = recorded.get("packing")
    if packing is None and sample.get("packing_given") and "packing" in sample.get("out", {}):
        packing = _recorded(Path(sample["out"]["packing"]))
    if packing:
        for key, wanted in (sample.get("make") or {}).items():
            if key in packing and not _same(packing[key], wanted):
                return f"packing {key} {packing[key]}, this run {wanted}"
        digest = packing.get("packing_digest")
        if digest is not None:
            for stage, attrs in recorded.items():
                theirs = (attrs or {}).get("packing_digest") if stage != "packing" else None
                if theirs is not None and not _same(theirs, digest):
                    return f"{kept[stage]['name']} is of another packing (digest {theirs}, the packing's {digest})"
    return None


def restore(store, sample: dict, keys, label: str, log=print) -> list[dict] | None:
    """Put ``sample``'s kept files back at its output paths and return its timing rows, if its
    entry in ``store`` is complete and of the same recipe; else None (the sample is computed).
    ``label``: the sample's name in the log lines (one of its files)."""
    entry = entry_of(store, sample, keys)
    stamp = _stamp(entry)
    if stamp is None:
        return None
    files = sample_files(sample)
    if stamp.get("recipe") != recipe_digest(sample):
        log(f"{label}: the files kept in {entry} are of another recipe: computed again")
        return None
    kept = stamp.get("files", {})
    if set(kept) != set(files):
        return None
    try:  # every file there, of the size it had (an entry edited by hand is not used)
        if not all((entry / kept[stage]["name"]).stat().st_size == kept[stage]["bytes"] for stage in files):
            return None
    except (OSError, KeyError, TypeError):
        return None
    mismatch = provenance_mismatch(entry, kept, sample)
    if mismatch:
        log(f"{label}: the files kept in {entry} were made with other parameters ({mismatch}): "
            "computed again")
        return None
    try:
        for stage, path in files.items():
            _place(entry / kept[stage]["name"], path)
    except (OSError, OutputError, InputError) as exc:  # the run writes every file anew
        log(f"{label}: not restored from {entry} ({exc}): computed again")
        return None
    log(f"{label}: restored from {entry} (finished before the batch was cut), not computed again")
    return stamp["timings"]


def keep(store, sample: dict, keys, timings: list[dict], log=print) -> None:
    """Keep ``sample``'s files (just written) and ``timings`` in ``store``, replacing any entry
    it had; the stamp comes last, so an entry cut while being written is not used. A failure
    (a full disk for the copies) is a log line, not the batch's end: the sample is done."""
    from .io.files import atomic_text

    entry = entry_of(store, sample, keys)
    try:
        (entry / STAMP_NAME).unlink(missing_ok=True)  # an old entry is void before any file changes
        if entry.exists():
            shutil.rmtree(entry)
        entry.mkdir(parents=True)
        kept, how = {}, set()
        for stage, path in sample_files(sample).items():
            name = stage + Path(path).suffix
            how.add(_place(path, entry / name))
            kept[stage] = {"name": name, "bytes": os.path.getsize(path)}
        stamp = {"kind": STAMP_KIND, "version": STAMP_VERSION, "recipe": recipe_digest(sample),
                 "files": kept, "timings": timings}
        atomic_text(entry / STAMP_NAME, json.dumps(stamp, indent=1) + "\n")
    except (OSError, OutputError, InputError) as exc:
        log(f"{entry}: not kept ({exc}); a cut batch would compute this sample again")
        return
    if "copy" in how:
        log(f"{entry}: kept as copies (no hard links on this file system)")


def remove(store, log=print) -> None:
    """Remove ``store`` (the batch has written all its outputs); a part that cannot be removed
    is named in the log, not an error: the batch's outputs are complete."""
    shutil.rmtree(store, ignore_errors=True)
    if Path(store).exists():
        log(f"{store}: could not be removed entirely; remove it by hand")


def stop_for_tests(computed: int) -> None:
    """The test hook of :data:`STOP_AFTER_ENV`: KeyboardInterrupt once ``computed`` samples have
    been computed and kept, when the variable says so."""
    stop = os.environ.get(STOP_AFTER_ENV)
    if stop and computed >= int(stop):
        raise KeyboardInterrupt(f"{STOP_AFTER_ENV}={stop}: batch stopped after {computed} samples")
