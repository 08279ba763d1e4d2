"""Replay every case of issue #66 as a user meets it: through the command line, each in a folder
of its own, its inputs' SHA-256 taken before and after.

    python benchmarks/hostile_replay.py            # every case (~10 minutes on a loaded core)
    python benchmarks/hostile_replay.py --fast     # without the workflow runs (~5 minutes)
    python benchmarks/hostile_replay.py --only NAME[,NAME...]

A case expects a refusal (exit 2, one line ``Error: ...`` or ``config: ...`` naming what it
must, no file left behind, the inputs untouched) or a run (exit 0, the inputs untouched, and its
own check of the result). Anything else (a traceback, exit 0 on bad input, a file left, an input
changed, a second line) is "not clean". Prints a table case -> outcome and appends one record
to benchmarks/results/hostile.jsonl (``--no-record``: print only); the fast checks of each
class are in tests/ (test_fuzz_*.py, test_older_files.py, test_workflow_resume.py).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "hostile.jsonl"
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
ENV.pop(("GRANWAVE_GPU_ELSEWHERE"), None)
T = ["--method", "modal", "--t-max", "60", "--samples", "600", "-q"]


@dataclass
class Case:
    name: str
    klass: str  # the class
    inputs: list  # base files copied into the case's folder (name or (name, new name))
    argv: list  # a granwave command line, or ["python", ...] / ["snakemake", ...]
    expect: str = "refuse"  # refuse | run | either (a valid run, or a clean refusal)
    words: tuple = ()
    edit: object = None  # f(folder): makes the case's damaged input from the copies
    check: object = None  # f(folder, proc) -> problem or None, for a run
    timeout: int = 300
    notes: str = ""
    consumed: tuple = ()  # inputs the command removes once done (a checkpoint resumed to its end)
    outcome: dict = field(default_factory=dict)


# ---------------------------------------------------------------- base files
def cli(*args, cwd, check=True, env=ENV, timeout=600):
    p = subprocess.run([sys.executable, "-m", "granwave", *map(str, args)], cwd=cwd, capture_output=True,
                       text=True, env=env, timeout=timeout)
    if check and p.returncode != 0:
        raise RuntimeError(f"base file: granwave {' '.join(map(str, args))}: {p.stdout}{p.stderr}")
    return p


def make_base(base: Path) -> None:
    """Small lattices (4 and 6 rows, frictional and frictionless), their linear files, signals,
    modes and moduli; a DEM packing; a checkpoint kept after a budget failure; a LAMMPS export."""
    for rows in (4, 6):
        cli("lattice", "--rows", rows, "--width", 4, "--pressure", 1e-3, "--friction", 0.5, "-o", f"p{rows}.h5", "-q",
            cwd=base)
        cli("linearize", f"p{rows}.h5", "-o", f"lin{rows}.h5", "-q", cwd=base)
        cli("propagate", f"lin{rows}.h5", "-o", f"n{rows}.h5", *T, cwd=base)
        cli("propagate", f"lin{rows}.h5", "-o", f"sh{rows}.h5", "--source", "shear", *T, cwd=base)
        (base / f"mod{rows}.json").write_text(cli("analyze", "moduli", f"p{rows}.h5", "--json", cwd=base).stdout)
    cli("eigensolve", "lin4.h5", "--vectors", "-o", "modes4.h5", cwd=base)
    cli("lattice", "--rows", 4, "--width", 4, "--pressure", 1e-3, "-o", "pf.h5", "-q", cwd=base)
    cli("linearize", "pf.h5", "-o", "linf.h5", "-q", cwd=base)
    cli("prepare-packing", "--grains", 12, "--seed", 3, "-o", "dem.h5", "-q", cwd=base)
    ck = cli("prepare-packing", "--grains", 12, "--seed", 3, "--max-steps", 1000, "--checkpoint", "ck.h5",
             "--checkpoint-every", 0, "-o", "never.h5", "-q", cwd=base, check=False)
    assert ck.returncode == 1 and (base / "ck.h5").exists(), ck.stdout + ck.stderr
    cli("export", "lammps", "dem.h5", "-o", "lmp", "-q", cwd=base)
    cli("lattice", "--rows", 3, "--width", 4, "--pressure", 1e-3, "--contact-law", "harmonic", "-o", "harm.h5", "-q",
        cwd=base)
    cli("export", "lammps", "harm.h5", "-o", "lmp_harm", "-q", cwd=base)


# ---------------------------------------------------------------- edits
def h5_attrs(name, **changes):
    def edit(folder):
        import h5py

        with h5py.File(folder / name, "a") as f:
            for k, v in changes.items():
                if v is None:
                    del f.attrs[k]
                else:
                    f.attrs[k] = v
    return edit


def h5_call(name, fn):
    def edit(folder):
        import h5py

        with h5py.File(folder / name, "a") as f:
            fn(f)
    return edit


def json_edit(name, target, **changes):
    def edit(folder):
        m = json.loads((folder / name).read_text())
        for k, v in changes.items():
            if v is None:
                m.pop(k, None)
            else:
                m[k] = v
        (folder / target).write_text(json.dumps(m))
    return edit


def asymmetric(f):
    import numpy as np

    g = f["matrix"]
    data = g["data"][()]
    data[: max(1, len(data) // 7)] *= 1.5
    del g["data"]
    g["data"] = data
    _ = np


def zero_omega(f):
    w = f["omega2"][()]
    w[:] = 0.0
    del f["omega2"]
    f["omega2"] = w


def lammps_edit(fn, folder_name="lmp"):
    def edit(folder):
        path = folder / folder_name / "packing.data"
        path.write_text(fn(path.read_text()))
    return edit


def duplicate_atom(text):
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.strip().startswith("Atoms"))
    j = i + 2
    second = lines[j + 1].split()
    first = lines[j].split()
    second[0] = first[0]
    lines[j + 1] = " ".join(second)
    return "\n".join(lines) + "\n"


def zero_atoms(text):
    lines = text.splitlines()
    out = []
    skip = False
    for line in lines:
        if line.strip().endswith(" atoms") and line.split()[0].isdigit():
            out.append("0 atoms")
            continue
        if line.strip().startswith("Atoms"):
            skip = True
            out.append(line)
            out.append("")
            continue
        if skip:
            if line.strip() and line.strip()[0].isalpha():
                skip = False
                out.append(line)
            continue
        out.append(line)
    return "\n".join(out) + "\n"


def damage_middle(name):
    def edit(folder):
        data = bytearray((folder / name).read_bytes())
        mid = len(data) // 2
        data[mid:mid + 256] = bytes((b * 7 + 13) % 256 for b in range(256))
        (folder / name).write_bytes(bytes(data))
    return edit


def truncate(name):
    def edit(folder):
        data = (folder / name).read_bytes()
        (folder / name).write_bytes(data[: len(data) // 2])
    return edit


def write(name, text):
    def edit(folder):
        (folder / name).write_text(text)
    return edit


def nested(name, depth=100000):
    return write(name, "[" * depth + "]" * depth)


def api(code):
    """A few lines through the API, a user's script: InputError printed as the CLI prints it."""
    wrapped = ("import sys\nfrom granwave.errors import InputError\ntry:\n"
               + "".join(f"    {line}\n" for line in code.strip().splitlines())
               + "except InputError as exc:\n    print(f'Error: {exc}', file=sys.stderr)\n    sys.exit(2)\n")
    return ["python", "-c", wrapped]


# ---------------------------------------------------------------- workflow configs
QUICK = (ROOT / "config" / "config.yaml").read_text()


def config_edit(path_value_pairs, name="c.yaml"):
    def edit(folder):
        import yaml

        cfg = yaml.safe_load(QUICK)
        for path, value in path_value_pairs:
            node = cfg
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = value
        (folder / name).write_text(yaml.safe_dump(cfg, sort_keys=False))
    return edit


def dry(name="c.yaml"):
    return ["snakemake", "-s", str(ROOT / "workflow" / "Snakefile"), "-n", "--quiet", "--configfile", name]


CHAINS = """\
name: resume
results: results
ic: A
samples: {samples}
t_max_factor: 2.5
chains:
  chain_A:
    balls: [20, 40, 80]
damping:
  enabled: false
"""


def store_case(kind):
    """A batch cut after its first sample under one config, then run under another (the
    signal's samples changed: same paths, other parameters). ``kind``: "edited" (the same
    folder, the config edited between the runs) or "foreign" (a folder holding only the first
    run's finished-sample store)."""
    def run(folder):
        cut, other = folder / "cut", folder / "other"
        cut.mkdir()
        (cut / "c.yaml").write_text(CHAINS.format(samples=800))
        batch = "results/timings/batch_reference_0.tsv"
        sm = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"), batch, "--cores", "1",
              "--configfile", "c.yaml"]
        p = subprocess.run(sm, cwd=cut, capture_output=True, text=True, timeout=900,
                           env={**ENV, "GRANWAVE_TEST_STOP_BATCH_AFTER": "1"})
        if p.returncode == 0 or not (cut / "results" / "finished").exists():
            return {"problem": "the cut run was not cut", "rc": p.returncode}
        where = cut
        if kind == "foreign":
            other.mkdir()
            shutil.copytree(cut / "results" / "finished", other / "results" / "finished")
            where = other
        (where / "c.yaml").write_text(CHAINS.format(samples=900))
        p = subprocess.run([*sm, "--rerun-incomplete"], cwd=where, capture_output=True, text=True, timeout=900,
                           env=ENV)
        log = (where / "results" / "logs" / "batch" / "batch_reference_0.log")
        text = log.read_text() if log.exists() else ""
        import h5py

        signal = where / "results" / "signal" / "chain_A" / "p0.0001" / "n20" / "s0.h5"
        samples = None
        if signal.exists():
            with h5py.File(signal) as f:
                samples = int(f.attrs["samples"])
        ok = p.returncode == 0 and "restored from" not in text and samples == 900
        return {"rc": p.returncode, "clean": ok, "line": next((line for line in text.splitlines()
                                                               if "recipe" in line or "parameters" in line), ""),
                "problem": None if ok else f"rc {p.returncode}, samples {samples}, restored: {'restored from' in text}"}
    return run


def same_linear(folder, proc):
    """The snapshot signal made from sub/modes4.h5, run from the folder above: of sub/lin4.h5."""
    import h5py

    if not (folder / "s.h5").exists():
        return "no output"
    with h5py.File(folder / "s.h5") as f, h5py.File(folder / "sub" / "lin4.h5") as g:
        if f.attrs.get("linear_digest") != g.attrs.get("linear_digest"):
            return "the signal names another linear system"
    return None


# ---------------------------------------------------------------- the cases
def cases() -> list[Case]:
    C = []
    add = C.append
    # --- round three: silently wrong or accepted
    add(Case("linear_source from another folder", "silently wrong", ["lin4.h5", "modes4.h5"],
             ["propagate", "sub/modes4.h5", "--method", "modal", "--t-max", "30", "--samples", "200",
              "--snapshots", "10", "-o", "s.h5", "-q"], expect="run",
             edit=lambda f: ((f / "sub").mkdir(), shutil.move(f / "modes4.h5", f / "sub" / "modes4.h5"),
                             shutil.move(f / "lin4.h5", f / "sub" / "lin4.h5")),
             check=same_linear))
    add(Case("export vtk on another packing", "silently wrong", ["n4.h5", "lin4.h5", "p6.h5"],
             ["export", "vtk", "snap.h5", "--packing", "p6.h5", "-o", "v.pvd", "-q"],
             edit=lambda f: cli("propagate", "lin4.h5", "--method", "time", "--t-max", 10, "--snapshots", 5,
                                "-o", "snap.h5", "-q", cwd=f), words=("snap.h5",)))
    add(Case("asymmetric D", "silently wrong", ["lin4.h5"], ["eigensolve", "lin4.h5", "-o", "m.h5"],
             edit=h5_call("lin4.h5", asymmetric), words=("symmetric",)))
    add(Case("modes with omega^2 = 0", "silently wrong", ["modes4.h5", "lin4.h5"],
             ["propagate", "modes4.h5", "-o", "s.h5", *T], edit=h5_call("modes4.h5", zero_omega)))
    add(Case("signal with an unknown ic", "silently wrong", ["n4.h5"], ["analyze", "front", "n4.h5"],
             edit=h5_attrs("n4.h5", ic="Q"), words=("ic",)))
    add(Case("packing schema version garbage", "silently wrong", ["p4.h5"], ["linearize", "p4.h5", "-o", "l.h5"],
             edit=h5_attrs("p4.h5", schema_version="banana"), words=("schema",)))
    add(Case("lammps duplicate atom ids", "silently wrong", ["lmp"],
             ["import", "lammps", "lmp/packing.data", "--pressure", "1e-4", "-o", "i.h5"],
             edit=lammps_edit(duplicate_atom), words=("atom",)))
    add(Case("workflow t_max_factor 0.7", "silently wrong", [], dry(), edit=config_edit([(("t_max_factor",), 0.7)]),
             words=("t_max_factor",)))
    add(Case("workflow t_max_factor 1.0 (front's lobe cut)", "silently wrong", [], dry(),
             edit=config_edit([(("t_max_factor",), 1.0)]), words=("t_max_factor", "needs t_max")))
    # --- round three: tracebacks
    add(Case("schema attribute as an array", "traceback", ["p4.h5"], ["linearize", "p4.h5", "-o", "l.h5"],
             edit=h5_attrs("p4.h5", pressure=[1e-3, 2e-3])))
    add(Case("nested JSON to pressure-sweep", "traceback", [], ["pressure-sweep", "deep.json", "-o", "sw.h5"],
             edit=nested("deep.json")))
    add(Case("nested JSON to report", "traceback", [], ["report", "--summaries", "deep.json", "-o", "r.md"],
             edit=nested("deep.json")))
    add(Case("API linearize: contact to a missing grain", "traceback", ["p4.h5"], api("""
from granwave import api
from granwave.io import files as F
p = F.read_packing('p4.h5')
p.contacts.i[0] = 10**6
api.linearize(p)
"""), notes="contacts' field names from granwave.model"))
    add(Case("API propagate: negative mass", "traceback", ["lin4.h5"], api("""
from granwave import api
from granwave.io import files as F
s = F.read_linear('lin4.h5')
s.mass[3] = -1.0
api.propagate(s, method='time', t_max=5, samples=16)
"""), words=("mass",)))
    add(Case("API front: a Signal without a height", "traceback", ["n4.h5"], api("""
from granwave import api
from granwave.io import files as F
s = F.read_signal('n4.h5')
s.attrs.pop('height')
api.front(s)
"""), words=("height",)))
    add(Case("plot airy --n 1e9", "killed", [], ["plot", "airy", "--n", "1000000000", "-o", "a.png"]))
    add(Case("API grains=np.int64(10)", "valid refused", [], api("""
import numpy as np
from granwave import api
p = api.prepare_packing(grains=np.int64(10), pressure=np.float32(1e-3), seed=np.int64(2))
assert p.n_grains == 10
"""), expect="run"))
    # --- round four: inputs that do not belong together
    add(Case("front of a shear signal, another packing's moduli", "belong together", ["sh4.h5", "mod6.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "mod6.json"], words=("another packing",)))
    add(Case("3D moduli for a 2D signal", "belong together", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "m.json"],
             edit=json_edit("mod4.json", "m.json", dim=3, packing_digest=None), words=("dim",)))
    add(Case("moduli dim 7", "belong together", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "m.json"], edit=json_edit("mod4.json", "m.json", dim=7),
             words=("dim 7",)))
    add(Case("c_t as a string", "belong together", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "m.json"], edit=json_edit("mod4.json", "m.json", c_t="0.3"),
             words=("c_t",)))
    for analysis in ("continuum", "attenuation"):
        extra = ["--moduli", "mod4.json", "--moduli", "mod4.json"] if analysis == "continuum" else []
        add(Case(f"{analysis}: one file twice", "belong together", ["n4.h5", "mod4.json"],
                 ["analyze", analysis, "n4.h5", "n4.h5", *extra], words=("twice",)))
        ex2 = ["--moduli", "mod4.json", "--moduli", "mod6.json"] if analysis == "continuum" else []
        for key, value in (("dim", 3), ("lateral_width", 9.0), ("friction", 0.0), ("source_kind", "shear"),
                           ("pressure", 1e-4), ("contact_law", "harmonic")):
            add(Case(f"{analysis}: mixed {key}", "belong together", ["n4.h5", "n6.h5", "mod4.json", "mod6.json"],
                     ["analyze", analysis, "n4.h5", "n6.h5", *ex2], edit=h5_attrs("n6.h5", **{key: value}),
                     words=("n6.h5",)))
        if analysis == "continuum":
            add(Case("continuum: moduli with the wrong heights", "belong together",
                     ["n4.h5", "n6.h5", "mod4.json", "mod6.json"],
                     ["analyze", "continuum", "n4.h5", "n6.h5", "--moduli", "mod6.json", "--moduli", "mod4.json"],
                     words=("another packing",)))
    add(Case("continuum: one height", "belong together", ["n4.h5", "mod4.json"],
             ["analyze", "continuum", "n4.h5", "--moduli", "mod4.json"]))
    # --- options silently ignored
    for name, argv, words in (
            ("--checkpoint-every without --checkpoint", ["prepare-packing", "--grains", 10, "--checkpoint-every", 5],
             "--checkpoint"),
            ("--harmonic-stiffness under Hertz", ["prepare-packing", "--grains", 10, "--harmonic-stiffness", 2],
             "harmonic"),
            ("--rolling-stiffness without --rolling sds", ["prepare-packing", "--grains", 10, "--rolling-stiffness", 2],
             "--rolling sds")):
        add(Case(name, "option ignored", [], [*map(str, argv), "-o", "p.h5"], words=(words,)))
    add(Case("--material without --units si", "option ignored", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "mod4.json", "--material", "quartz"], words=("--units si",)))
    add(Case("shear options on a compressional signal", "option ignored", ["n4.h5"],
             ["analyze", "front", "n4.h5", "--frequency", "0.1"], words=("only for shear signals",)))
    add(Case("--frequency with --wavelength", "option ignored", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "mod4.json", "--frequency", "0.05", "--wavelength", "8"],
             words=("give one",)))
    add(Case("import lammps of a harmonic packing", "option ignored", ["lmp_harm"],
             ["import", "lammps", "lmp_harm/packing.data", "--pressure", "1e-3", "-o", "i.h5"], words=("harmonic",)))
    # --- the API's types
    for seeds in ("[1.5, 2.7]", "'12'", "[True, 2]"):
        add(Case(f"API seeds={seeds}", "API types", [], api(f"""
from granwave import api
api.prepare_packings(seeds={seeds}, grains=10)
"""), words=("seed",)))
    add(Case("API shear_front moduli as a list", "API types", ["sh4.h5"], api("""
from granwave import api
from granwave.io import files as F
api.shear_front(F.read_signal('sh4.h5'), moduli=[0.3, 0.5])
"""), words=("moduli",)))
    # --- tracebacks of round four
    add(Case("checkpoint damaged in its middle", "traceback", ["ck.h5"],
             ["prepare-packing", "--grains", 12, "--seed", 3, "--checkpoint", "ck.h5", "-o", "p.h5", "-q"],
             edit=damage_middle("ck.h5"), words=("ck.h5",)))
    add(Case("lammps data file with 0 atoms", "traceback", ["lmp"],
             ["import", "lammps", "lmp/packing.data", "--pressure", "1e-4", "-o", "i.h5"],
             edit=lammps_edit(zero_atoms)))
    # --- no guard
    add(Case("--seeds 0-100000000", "no guard", [], ["prepare-packing", "--seeds", "0-100000000", "-o", "p_{seed}.h5"],
             words=("--allow-long-run",)))
    add(Case("checkpoint after a budget failure, larger budget", "no guard", ["ck.h5"],
             ["prepare-packing", "--grains", 12, "--seed", 3, "--max-steps", 100000, "--checkpoint", "ck.h5",
              "--checkpoint-every", 0, "-o", "p.h5", "-q"], expect="run", consumed=("ck.h5",),
             check=lambda f, p: None if (f / "p.h5").exists() and not (f / "ck.h5").exists() else "no packing"))
    # --- messages that mislead
    add(Case("linear file without its shear group", "message", ["lin4.h5"],
             ["propagate", "lin4.h5", "--source", "shear", "-o", "s.h5", *T],
             edit=h5_call("lin4.h5", lambda f: f.__delitem__("shear")), words=("without its shear group",)))
    add(Case("pulse above Nyquist", "message", ["sh4.h5"], ["analyze", "front", "sh4.h5", "--frequency", "100"],
             words=("Nyquist",)))
    add(Case("pulse longer than the record", "message", ["sh4.h5"], ["analyze", "front", "sh4.h5", "--frequency", "0.01"],
             words=("longer than the record",)))
    add(Case("checkpoint of another run names the differences", "message", ["ck.h5"],
             ["prepare-packing", "--grains", 12, "--seed", 4, "--checkpoint", "ck.h5", "-o", "p.h5"],
             words=("seed 3 (this run: 4)",), check=None))
    for width in (1, 1.5):
        add(Case(f"workflow width {width}", "message", [], dry(),
                 edit=config_edit([(("disordered", "frictional2d", "width"), width)]), words=("width",)))
    # --- round two's own list: the new features
    add(Case("propagate --source shear on a frictionless packing", "new features", ["linf.h5"],
             ["propagate", "linf.h5", "--source", "shear", "-o", "s.h5", *T], words=("frictionless",)))
    add(Case("front with non-finite moduli", "new features", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "m.json"],
             edit=lambda f: (f / "m.json").write_text((f / "mod4.json").read_text().replace(
                 '"c_t": ', '"c_t": NaN, "c_t_was": ', 1)), words=("c_t",)))
    add(Case("unknown --material", "new features", ["sh4.h5"],
             ["analyze", "front", "sh4.h5", "--units", "si", "--material", "unobtainium", "--frequency", "0.05"],
             words=("unobtainium",)))
    add(Case("absurd --wavelength", "new features", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "mod4.json", "--wavelength", "-3"]))
    add(Case("continuum: too few packings", "new features", ["n4.h5", "mod4.json"],
             ["analyze", "continuum", "n4.h5", "--moduli", "mod4.json"]))
    add(Case("checkpoint truncated", "new features", ["ck.h5"],
             ["prepare-packing", "--grains", 12, "--seed", 3, "--checkpoint", "ck.h5", "-o", "p.h5"],
             edit=truncate("ck.h5"), words=("ck.h5",)))
    add(Case("checkpoint resumed with changed options", "new features", ["ck.h5"],
             ["prepare-packing", "--grains", 12, "--seed", 3, "--friction", 0.3, "--checkpoint", "ck.h5", "-o", "p.h5"],
             words=("friction",)))
    for spec in ("5-1", "0-3,2", "4,4"):
        add(Case(f"--seeds {spec}", "new features", [], ["prepare-packing", "--seeds", spec, "--grains", 5, "-o",
                                                         "p_{seed}.h5"], words=("--seeds",)))
    add(Case("--seeds without {seed} in -o", "new features", [], ["prepare-packing", "--seeds", "0-1", "--grains", 5,
                                                                  "-o", "p.h5"], words=("{seed}",)))
    add(Case("--rolling sds on a frictionless packing", "new features", [],
             ["prepare-packing", "--grains", 10, "--friction", 0, "--rolling", "sds", "-o", "p.h5"]))
    add(Case("export lammps of a law LAMMPS has no words for", "new features", [],
             ["export", "lammps", "cone.h5", "-o", "out"],
             edit=lambda f: cli("lattice", "--rows", 3, "--width", 4, "--pressure", 1e-3, "--contact-law", "cone",
                                "-o", "cone.h5", "-q", cwd=f), words=("cone",)))
    add(Case("workflow: unknown contact law", "new features", [], dry(),
             edit=config_edit([(("disordered", "frictional2d", "contact"), {"contact_law": "velcro"})]),
             words=("velcro",)))
    add(Case("workflow: zero height", "new features", [], dry(),
             edit=config_edit([(("disordered", "frictional2d", "heights"), [0, 8])]), words=("heights",)))
    add(Case("workflow: device gpu without a GPU", "new features", [], dry(),
             edit=config_edit([(("device",), "gpu")]), words=("device",)))
    add(Case("workflow: a finished-sample store of another config", "new features", [], ["store", "foreign"],
             expect="run", timeout=1800))
    add(Case("workflow: a config edited mid-run", "new features", [], ["store", "edited"], expect="run", timeout=1800))
    add(Case("report: markup in the title", "new features", [],
             ["report", "--figures", "figs", "--title", "<script>alert(1)</script>", "-o", "r.md", "-q"], expect="run",
             edit=lambda f: ((f / "figs").mkdir(), cli("plot", "airy", "--n", 25, "-o", "figs/a<b>.png", "-q", cwd=f)),
             check=lambda f, p: "no HTML" if not (f / "r.html").exists() else
             ("markup reached the page" if "<script>" in (f / "r.html").read_text() else None)))
    add(Case("harmonic law with friction", "new features", [],
             ["lattice", "--rows", 3, "--width", 4, "--pressure", 1e-3, "--contact-law", "harmonic", "--friction", 0.5,
              "-o", "h.h5", "-q"], expect="either",
             check=lambda f, p: None if (f / "h.h5").exists() else "no output"))
    add(Case("continuum: signals of other lengths and steps", "new features",
             ["n4.h5", "lin6.h5", "mod4.json", "mod6.json"],
             ["analyze", "continuum", "n4.h5", "n6b.h5", "--moduli", "mod4.json", "--moduli", "mod6.json", "--json"],
             expect="either", edit=lambda f: cli("propagate", "lin6.h5", "-o", "n6b.h5", "--method", "modal", "--t-max",
                                                 90, "--samples", 700, "-q", cwd=f)))
    add(Case("propagate --samples 10^10", "no guard", ["lin4.h5"],
             ["propagate", "lin4.h5", "-o", "s.h5", "--method", "time", "--t-max", "60", "--samples", "10000000000"]))
    add(Case("plot airy --n 1e6", "no guard", [], ["plot", "airy", "--n", "1000000", "-o", "a.png", "-q"],
             expect="either", timeout=120, notes="within bounds: it runs (in seconds), or is refused with its estimate"))
    # --- older files (decision 0048): accepted with one warning
    add(Case("older moduli without packing_digest", "older files", ["sh4.h5", "mod4.json"],
             ["analyze", "front", "sh4.h5", "--moduli", "old.json", "--json"], expect="run",
             edit=json_edit("mod4.json", "old.json", packing_digest=None),
             check=lambda f, p: None if p.stderr.count("warning: ") == 1 else "no single warning line"))
    add(Case("older signals without width and digest", "older files", ["n4.h5", "n6.h5"],
             ["analyze", "attenuation", "n4.h5", "n6.h5", "--bootstrap", "5", "--json"], expect="run",
             edit=lambda f: (h5_attrs("n4.h5", lateral_width=None, packing_digest=None)(f),
                             h5_attrs("n6.h5", lateral_width=None, packing_digest=None)(f)),
             check=lambda f, p: None if p.stderr.count("warning: ") == 1 else "no single warning line"))
    return C


# ---------------------------------------------------------------- running one case
def digests(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and ".snakemake" not in p.parts}


def run_case(case: Case, base: Path, work: Path) -> dict:
    folder = work / "".join(c if c.isalnum() else "_" for c in case.name)[:60]
    folder.mkdir()
    for name in case.inputs:
        src = base / name
        (shutil.copytree if src.is_dir() else shutil.copy)(src, folder / name)
    if case.edit:
        case.edit(folder)
    t0 = time.perf_counter()
    if case.argv[0] == "store":
        res = store_case(case.argv[1])(folder)
        res["seconds"] = round(time.perf_counter() - t0, 1)
        res["outcome"] = "clean" if res.get("clean") else "not clean"
        return res
    before = digests(folder)
    if case.argv[0] == "python":
        cmd = [sys.executable, *case.argv[1:]]
    elif case.argv[0] == "snakemake":
        cmd = [sys.executable, "-m", "snakemake", *case.argv[1:]]
    else:
        cmd = [sys.executable, "-m", "granwave", *map(str, case.argv)]
    try:
        p = subprocess.run(cmd, cwd=folder, capture_output=True, text=True, env=ENV, timeout=case.timeout)
    except subprocess.TimeoutExpired:
        return {"outcome": "not clean", "problem": f"ran past {case.timeout} s", "seconds": case.timeout}
    after = digests(folder)
    changed = [k for k in before if after.get(k) != before[k]
               and not (k in case.consumed and k not in after and p.returncode == 0)]
    new = sorted(set(after) - set(before))
    text = (p.stdout + p.stderr)
    lines = [line for line in text.splitlines() if line.strip()]
    problems = []
    if "Traceback" in text:
        problems.append("traceback")
    if changed:
        problems.append(f"input changed: {changed}")
    expect = case.expect
    if expect == "either":  # valid input may run; a clear refusal is as good
        expect = "run" if p.returncode == 0 else "refuse"
    if expect == "refuse":
        errors = [line for line in lines if line.startswith(("Error: ", "config: ")) and "warning" not in line[:18]]
        if case.argv[0] == "snakemake":
            lines = errors  # snakemake's own lines around it are not ours
        if p.returncode != 2:
            problems.append(f"exit {p.returncode}")
        if len(lines) != 1 or len(errors) != 1:
            problems.append(f"{len(lines)} lines")
        for w in case.words:
            if errors and w not in errors[0]:
                problems.append(f"does not name {w!r}")
        left = [n for n in new if not n.startswith("results/") or case.argv[0] != "snakemake"]
        if left:
            problems.append(f"left {left}")
        line = errors[0] if errors else (lines[-1] if lines else "")
    else:
        if p.returncode != 0:
            problems.append(f"exit {p.returncode}")
        if case.check and p.returncode == 0:
            why = case.check(folder, p)
            if why:
                problems.append(why)
        warns = [line for line in lines if line.startswith("warning: ") or line.startswith("config: warning")]
        line = warns[0] if warns else "(ran)"
    return {"outcome": "clean" if not problems else "not clean", "rc": p.returncode, "line": line[:300],
            "problem": "; ".join(problems) or None, "seconds": round(time.perf_counter() - t0, 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="leave out the workflow runs (the store cases)")
    ap.add_argument("--only", help="comma-separated case names (substrings)")
    ap.add_argument("--no-record", action="store_true", help="print the table only")
    args = ap.parse_args(argv)
    todo = cases()
    if args.fast:
        todo = [c for c in todo if c.argv[0] != "store"]
    if args.only:
        keys = args.only.split(",")
        todo = [c for c in todo if any(k in c.name for k in keys)]
    with tempfile.TemporaryDirectory(prefix="hostile_") as tmp:
        tmp = Path(tmp)
        base = tmp / "base"
        base.mkdir()
        t0 = time.perf_counter()
        make_base(base)
        print(f"base files made in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
        rows = []
        for case in todo:
            try:
                res = run_case(case, base, tmp)
            except Exception as exc:  # noqa: BLE001 - the replay's own failure, shown as such
                res = {"outcome": "not clean", "problem": f"replay: {type(exc).__name__}: {exc}"}
            rows.append({"case": case.name, "class": case.klass, "expect": case.expect, **res})
            print(f"{res['outcome']:>9}  {case.klass:<16} {case.name:<55} {res.get('problem') or res.get('line', '')}"[:240],
                  flush=True)
    clean = sum(r["outcome"] == "clean" for r in rows)
    by_class = {}
    for r in rows:
        c = by_class.setdefault(r["class"], [0, 0])
        c[0] += 1
        c[1] += r["outcome"] == "clean"
    print(f"\n{clean} of {len(rows)} cases clean")
    for k, (n, ok) in by_class.items():
        print(f"  {k:<16} {ok}/{n}")
    if not args.no_record and not args.only:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                             text=True).stdout.strip()
        rec = {"date": datetime.date.today().isoformat(), "benchmark": "hostile_replay",
               "command": "python benchmarks/hostile_replay.py" + (" --fast" if args.fast else ""),
               "git_revision": rev, "machine": {"cpu": f"{os.cpu_count()} cores, shared"},
               "summary": {"cases": len(rows), "clean": clean, "not clean": len(rows) - clean,
                           **{f"clean: {k}": f"{ok}/{n}" for k, (n, ok) in by_class.items()}},
               "notes": "issue #66's cases through the CLI, each in its own folder, inputs hashed before and after",
               "result": rows}
        with open(RESULTS, "a") as f:
            f.write(json.dumps(rec) + "\n")
        print(f"appended to {RESULTS.relative_to(ROOT)}")
    return 0 if clean == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
