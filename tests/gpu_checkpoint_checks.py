"""Checkpoints of GPU preparations, small enough for numba's CUDA simulator: run by
tests/test_gpu_checkpoint.py as ``python tests/gpu_checkpoint_checks.py [NAME ...]`` with
``NUMBA_ENABLE_CUDASIM=1`` (on a real GPU it runs unchanged); prints one JSON object.

Each check runs ``granwave prepare-packing --device gpu`` three times, in this process (click's
runner): straight, with no checkpoint; with ``--checkpoint`` written after every call of the
engine, interrupted (KeyboardInterrupt, what SIGTERM becomes) once a few checkpoints were
written; and again, resuming. It reports whether the resumed file holds the straight file's bytes
(data and every attribute but the command line).

The tiny packings converge in a few hundred steps, under the protocol's first call of 2000, so
the interrupted run's engine advances at most :data:`CALL_STEPS` steps a call (the bits do not
depend on the calls' lengths, docs/dem.md); the straight and resumed runs are the unchanged code.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
from click.testing import CliRunner

from granwave.cli import main as cli
from granwave.dem import checkpoint as CK
from granwave.gpu import batch as GB
from granwave.gpu import dem as GD
from granwave.io import files
from packing_bytes import packing_data

#: Most steps one engine call makes in the interrupted runs (a checkpoint after each call).
CALL_STEPS = 40
#: The tiny packings (2D: 10 grains, 3D: 20; frictional, the default friction 0.5).
TINY = ["--tol", "1e-2", "--pressure", "1e-2"]
CASES = {
    "single_2d": dict(args=["--grains", "10", "--seed", "1"], saves=3),
    "single_3d": dict(args=["--dim", "3", "--grains", "20", "--aspect", "0.4", "--seed", "1"], saves=3),
    "single_mean_flow_2d": dict(args=["--grains", "20", "--aspect", "2.0", "--seed", "1", "--compaction", "mean-flow",
                                      "--mean-flow-settling", "compaction", "--background-damping", "0.1",
                                      "--reference-height", "1.0", "--mean-flow-slab", "1.0"], saves=3),
    "seeds_2d": dict(args=["--grains", "10", "--seeds", "0-1"], saves=2),
}




def _cli(*args):
    return CliRunner().invoke(cli, ["prepare-packing", *TINY, "--device", "gpu", *args])


def _capped(cls):
    """Make ``cls.run`` advance at most CALL_STEPS steps a call (an ensemble's second engine
    CALL_STEPS - 10: its seeds stop at other steps); returns the way back."""
    keep = cls.__dict__["run"]
    caps = {}

    def run(self, n):
        cap = caps.setdefault(id(self), CALL_STEPS - 10 * min(len(caps), 1))
        return keep(self, min(int(n), cap))

    cls.run = run
    return lambda: setattr(cls, "run", keep)


def interrupted_and_resumed(name: str, folder: Path) -> dict:
    """One case of :data:`CASES`: straight, interrupted after ``saves`` checkpoints (of every seed),
    resumed; the files compared."""
    case = CASES[name]
    args, seeds = case["args"], "--seeds" in case["args"]
    suffix = "_{seed}.h5" if seeds else ".h5"
    straight = str(folder / f"{name}_straight{suffix}")
    out = str(folder / f"{name}{suffix}")
    ck = str(folder / f"{name}_ck{suffix}")
    r = _cli(*args, "-q", "-o", straight)
    assert r.exit_code == 0, r.output
    seed_list = [0, 1] if seeds else [None]
    paths = [ck.replace("{seed}", str(s)) if s is not None else ck for s in seed_list]

    saves = {}
    keep_save = CK.Checkpoint.save

    def save(self, run, history, speeds):
        keep_save(self, run, history, speeds)
        saves[str(self.path)] = saves.get(str(self.path), 0) + 1
        if not seeds and saves[str(self.path)] >= case["saves"]:
            raise KeyboardInterrupt  # a kill right after a checkpoint

    keep_advance = GB.Ensemble.advance

    def advance(self, requests):
        if all(saves.get(p, 0) >= case["saves"] for p in paths):
            raise KeyboardInterrupt  # the driver killed: every protocol stops
        return keep_advance(self, requests)

    CK.Checkpoint.save = save
    GB.Ensemble.advance = advance
    undo = [_capped(GD.GpuEngine), _capped(GB.BatchMember)]
    try:
        stopped = _cli(*args, "--checkpoint", ck, "--checkpoint-every", "0", "-o", out)
    finally:
        CK.Checkpoint.save = keep_save
        GB.Ensemble.advance = keep_advance
        for u in undo:
            u()
    outs = [out.replace("{seed}", str(s)) if s is not None else out for s in seed_list]
    refs = [straight.replace("{seed}", str(s)) if s is not None else straight for s in seed_list]
    res = {"stopped_exit": stopped.exit_code, "stopped_no_output": not any(Path(o).exists() for o in outs),
           "checkpoints_left": all(Path(p).exists() for p in paths)}
    steps = []
    for p in paths:
        with h5py.File(p, "r") as f:
            steps.append(int(f.attrs["step"]))
            res["device_attr"] = str(f.attrs["device"])
    res["checkpoint_steps"] = steps
    # the other device refuses it, in one line, and leaves it
    other = CliRunner().invoke(cli, ["prepare-packing", *TINY, *args, "--checkpoint", ck, "-o", out])
    res["cpu_refused_exit"] = other.exit_code
    res["cpu_refused_line"] = other.output.strip()
    res["cpu_refused_kept"] = all(Path(p).exists() for p in paths)
    resumed = _cli(*args, "--checkpoint", ck, "-o", out)
    res["resumed_exit"] = resumed.exit_code
    res["resumed_output"] = resumed.output[-2000:]
    res["resumed_lines"] = [f"resumed from step {s} ({p})" in resumed.output for s, p in zip(steps, paths)]
    res["checkpoints_removed"] = not any(Path(p).exists() for p in paths)
    straight_steps = []
    same = []
    for o, ref in zip(outs, refs):
        a, b = packing_data(o), packing_data(ref)
        same.append(a[0] == b[0] and a[1] == b[1])
        straight_steps.append(int(files.read_packing(ref).attrs["steps"]))
    res["same"] = same
    res["straight_steps"] = straight_steps
    return res


def engine_state(first: int = 14, then: int = 14) -> dict:
    """What a checkpoint relies on, at the engine's level and cheaply (the test suite runs this;
    the whole preparations of :data:`CASES` take minutes each in the simulator): the dense
    frictional gas of granwave.gpu.checks on the GPU engine, with the device rebuild and with a
    piston, run ``first`` steps, its :meth:`state` taken into a fresh engine built with the same
    arguments, ``then`` more steps there; against ``first + then`` steps of one engine: state,
    pair list and histories, wall histories, piston, counters compared bitwise. 2D (pair arrays
    cut, so that the device asks for room) and 3D."""
    from granwave.gpu import checks as GC

    out = {}
    for dim, room in ((2, 0), (3, None)):
        kw = dict(seed=1, room=room, piston_mass=1.0, piston_force=20.0)
        straight = GC._gas(GD.GpuEngine, dim, first + then, **kw)
        before = GC._gas(GD.GpuEngine, dim, first, **kw)
        saved = before.state()
        after = GC._gas_engine(GD.GpuEngine, dim, **kw)
        after.restore(saved)
        after.run(then)
        m = straight.n_pairs
        key = f"{dim}d"
        out[f"same_state_{key}"] = all(getattr(straight, n).tobytes() == getattr(after, n).tobytes()
                                       for n in (*GC.STATE, *GC.WALLS))
        out[f"same_pairs_{key}"] = bool(after.n_pairs == m and all(
            getattr(straight, n)[:m].tobytes() == getattr(after, n)[:m].tobytes()
            for n in ("pair_i", "pair_j", "pair_ft", "pair_ov")))
        out[f"same_piston_{key}"] = straight.piston.tobytes() == after.piston.tobytes()
        out[f"same_counters_{key}"] = (straight.steps, straight.rebuilds) == (after.steps, after.rebuilds)
        out[f"rebuilds_after_restore_{key}"] = after.rebuilds - before.rebuilds
        out[f"pairs_{key}"] = m
        start = GC._gas_engine(GD.GpuEngine, dim, **kw)
        out[f"piston_moved_{key}"] = float(abs(np.asarray(straight.piston["h"]).ravel()[0]
                                               - np.asarray(start.piston["h"]).ravel()[0]))
    return out


def main(argv) -> None:
    names = argv or list(CASES)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            t0 = time.perf_counter()
            out[name] = engine_state() if name == "engine_state" else interrupted_and_resumed(name, Path(tmp))
            out[name]["seconds"] = time.perf_counter() - t0
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1:])
