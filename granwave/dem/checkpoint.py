"""Checkpoints of a preparation: stop a long compression and go on later with the same bits.

A checkpoint holds everything the run goes on from at a chunk boundary of
:meth:`granwave.dem.protocol.Compression.relax`: the engine's state arrays
(:meth:`granwave.dem.integrator.Engine.state`: positions, velocities, spins, accelerations,
the pair list with its tangential histories, the wall contacts' histories, the piston, the
time step and step counters, the neighbour lists of the last rebuild), the state of the
settling and end-game rules, and the run's convergence history (for its ETA and its hint
on failure). Nothing else is needed: the grains and the gas come again from the seed, and
the chunking, the thread count and the moment a checkpoint is written change no bit of
the run (docs/dem.md "Checkpoints"). The GPU engine's state is the same host arrays: each of
its runs uploads them and downloads them at the end (granwave.gpu.dem), and what it keeps on
the device (the device rebuild's work arrays, the control words) is made again from them at
the next upload; an ensemble's member likewise (granwave.gpu.batch).

The file is HDF5, internal to granwave (docs/formats.md): written to a temporary file
beside it and renamed (a run killed while writing leaves the previous checkpoint whole),
keyed by a digest of the preparation's parameters (seed included) and one of granwave's
source, and marked with the device that ran it: a checkpoint of other parameters, of other
code or of the other device is refused, never resumed (the GPU reduces the piston force in
another order than the CPU, so the two devices' runs part in the last bits: a run resumed on
the other device would be the packing of neither).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import time
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError, OutputError

#: what the file says it is (not a schema of granwave.io: nothing but this module reads it)
KIND = "granwave.checkpoint"
#: the layout's version; a checkpoint of another version is refused
VERSION = 2
#: default seconds between two checkpoints (``--checkpoint-every``)
EVERY = 600.0


#: Parameters that say where a run stops, not how it steps: left out of :func:`params_digest`,
#: so that a checkpoint kept after a step-budget failure goes on under a larger ``max_steps``.
NOT_IN_DIGEST = ("max_steps",)


def _digested(params) -> dict:
    return {k: v for k, v in params.as_dict().items() if k not in NOT_IN_DIGEST}


def params_digest(params) -> str:
    """A digest of a preparation's parameters (a frozen dataclass with ``as_dict``; the seed is
    one of them, the step budget not): the run a checkpoint belongs to."""
    text = json.dumps(_digested(params), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _differences(stored: str, params, most: int = 4) -> str:
    """The parameters in which a checkpoint's run (its ``prepare_params`` JSON) differs from
    ``params``, as 'seed 3 (this run: 4), ...' (at most ``most``, then a count)."""
    try:
        theirs = json.loads(stored)
    except (TypeError, ValueError):
        return "unreadable parameters"
    ours = json.loads(json.dumps(_digested(params)))
    keys = sorted(k for k in set(theirs) | set(ours) if k not in NOT_IN_DIGEST and theirs.get(k) != ours.get(k))
    if not keys:
        return "parameters recorded under another digest"
    text = ", ".join(f"{k} {theirs.get(k)!r} (this run: {ours.get(k)!r})" for k in keys[:most])
    return text + (f" and {len(keys) - most} more" if len(keys) > most else "")


#: What reading a damaged file can raise (h5py: OSError for a bad header, RuntimeError or
#: KeyError for a damaged B-tree or object header in its middle)
DAMAGED = (OSError, RuntimeError, KeyError, ValueError, TypeError)


def _damaged(path, exc) -> InputError:
    first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    return InputError(f"checkpoint {path} is damaged ({type(exc).__name__}: {first}); remove it to start over")


def source_digest() -> str:
    """A digest of granwave's source files: other code may step to other bits."""
    from ..kernel_cache import source_hash

    return source_hash()[:32]


def state_digest(engine: dict, history, speeds) -> str:
    """A digest of a checkpoint's state (the engine's arrays by name, dtype and shape, the run's
    history and speeds): HDF5 checks no data, so a file damaged inside a dataset would resume
    to another packing without it."""
    h = hashlib.sha256()
    for name in sorted(engine):
        a = np.ascontiguousarray(engine[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape};".encode())
        h.update(a.tobytes())
    for rows in (history, speeds):
        h.update(np.ascontiguousarray(np.array(rows, dtype=np.float64).reshape(-1, 2)).tobytes())
    return h.hexdigest()[:32]


def _int(value) -> int | None:
    try:
        return int(value)
    except (TypeError, ValueError):
        return None


class Checkpoint:
    """The checkpoint file ``path`` of one preparation (parameters ``params``) run on ``device``
    ("cpu" or "gpu"), written at most every ``every`` seconds (0: at every chunk boundary).

    :meth:`resume` restores a run from the file if it exists; :meth:`due` / :meth:`save` write
    it; :meth:`remove` deletes it once the packing is safe.
    """

    def __init__(self, path, params, every: float = EVERY, device: str = "cpu"):
        if not (isinstance(every, (int, float)) and every >= 0 and np.isfinite(every)):
            raise InputError(f"checkpoint interval must be a number of seconds >= 0, got {every!r}")
        self.path = Path(path)
        self.every = float(every)
        self.params = params
        self.device = str(device)
        self.key = params_digest(params)
        self.saves = 0  # checkpoints written by this process
        self._last = time.monotonic()

    # ------------------------------------------------------------------ reading
    def check(self) -> None:
        """Refuse, in one line, a checkpoint that is not one or belongs to another run or code
        (before any work); nothing when the file does not exist yet."""
        if not self.path.exists():
            self._check_folder()
            return
        try:
            with self._open() as f:
                a = dict(f.attrs)
        except InputError:
            raise
        except DAMAGED as exc:
            raise _damaged(self.path, exc) from None
        if a.get("kind") != KIND or _int(a.get("version", -1)) != VERSION:
            raise InputError(f"checkpoint {self.path} is not a granwave checkpoint of version "
                             f"{VERSION}; remove it or choose another --checkpoint")
        if a.get("params_digest") != self.key:
            raise InputError(f"checkpoint {self.path} belongs to another preparation "
                             f"({_differences(a.get('prepare_params'), self.params)}); remove it or "
                             "choose another --checkpoint")
        written_on = str(a.get("device", "cpu"))
        if written_on != self.device:
            raise InputError(f"checkpoint {self.path} was written on the {written_on.upper()}: resume it with "
                             f"--device {written_on} (the devices' runs part in the last bits), or remove it "
                             "to start over")
        if a.get("source_digest") != source_digest():
            raise InputError(f"checkpoint {self.path} was written by other granwave code (version "
                             f"{a.get('granwave_version')}), which may step to other bits; remove it to "
                             "start over")

    def _check_folder(self) -> None:
        from ..io.files import check_writable

        check_writable(self.path)

    @contextlib.contextmanager
    def _open(self):
        try:
            f = h5py.File(self.path, "r")
        except OSError as exc:
            raise InputError(f"checkpoint {self.path} cannot be read ({exc}); remove it to start over") from None
        with f:
            yield f

    def resume(self, run) -> tuple[list, list] | None:
        """Restore ``run`` (a :class:`granwave.dem.protocol.Compression` just built from the same
        parameters) from the file; returns the run's (history, speeds), or None when there is
        no checkpoint yet."""
        if not self.path.exists():
            return None
        self.check()
        try:
            with self._open() as f:
                engine = {k: f["engine"][k][()] for k in f["engine"]}
                rules = json.loads(f.attrs["rules"])
                history_rows, speed_rows = f["run/history"][()], f["run/speeds"][()]
                stored = f.attrs.get("state_digest")
            if stored != state_digest(engine, history_rows, speed_rows):
                raise InputError(f"checkpoint {self.path} is damaged (its state does not match the digest "
                                 "it was written with); remove it to start over")
            history = [(int(s), float(a)) for s, a in history_rows]
            speeds = [(int(s), float(v)) for s, v in speed_rows]
            if engine["position"].shape != run.engine.position.shape:
                raise InputError(f"checkpoint {self.path} holds {engine['position'].shape[0]} grains, "
                                 f"the run {run.engine.position.shape[0]}; remove it to start over")
            run.engine.restore(engine)
            for name in ("settling", "end_game"):
                rule = getattr(run, name)
                if (rule is None) != (rules.get(name) is None):
                    raise InputError(f"checkpoint {self.path} does not match the run's {name} rule; remove it")
                if rule is not None:
                    rule.restore(rules[name])
        except InputError:
            raise
        except DAMAGED as exc:
            raise _damaged(self.path, exc) from None
        self._last = time.monotonic()
        return history, speeds

    # ------------------------------------------------------------------ writing
    def due(self) -> bool:
        """Whether ``every`` seconds have passed since the last checkpoint (or the start)."""
        return time.monotonic() - self._last >= self.every

    def save(self, run, history, speeds) -> None:
        """Write the state of ``run`` at a chunk boundary: a temporary file beside ``path``,
        then renamed over it at once (not held back with a command's outputs: it is not one)."""
        from .. import __version__
        from ..io.atomic import _temporary, _write_failure

        rules = {name: (None if getattr(run, name) is None else getattr(run, name).state())
                 for name in ("settling", "end_game")}
        tmp = _temporary(self.path)
        try:
            with h5py.File(tmp, "w") as f:
                f.attrs.update(kind=KIND, version=VERSION, params_digest=self.key, device=self.device,
                               source_digest=source_digest(), granwave_version=__version__,
                               prepare_params=json.dumps(self.params.as_dict(), sort_keys=True),
                               step=run.engine.steps, written=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                               rules=json.dumps(rules))
                g = f.create_group("engine")
                state = run.engine.state()
                for name, a in state.items():
                    g.create_dataset(name, data=a)
                f.create_dataset("run/history", data=np.array(history, dtype=np.float64).reshape(-1, 2))
                f.create_dataset("run/speeds", data=np.array(speeds, dtype=np.float64).reshape(-1, 2))
                # of what the file holds, read back as resume() will read it
                f.attrs["state_digest"] = state_digest({k: g[k][()] for k in g}, f["run/history"][()],
                                                       f["run/speeds"][()])
            with open(tmp, "rb") as fh:  # on disk before it replaces the last good checkpoint
                os.fsync(fh.fileno())
            os.replace(tmp, self.path)
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise _write_failure(self.path, exc) from None
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
        self.saves += 1
        self._last = time.monotonic()

    def remove(self) -> None:
        """Delete the checkpoint (the packing is written); nothing if there is none."""
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass
        except OSError as exc:
            raise OutputError(f"cannot remove checkpoint {self.path}: {exc.strerror or exc}") from None
