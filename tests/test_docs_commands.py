"""Every `granwave ...` command line of the docs runs as written, on tiny inputs.

The command lines are taken from the fenced code blocks of docs/*.md and README.md
(backslash and indented continuations joined, `# comments` dropped) and from code
spans in headings that carry an option (`## ParaView: `granwave export vtk ...``).
Each one is either run (after the substitutions below: placeholders to file names,
big sizes to tiny ones, `[optional parts]` dropped) or listed in SKIP with a reason;
a docs command that is neither fails the test, and so does a SKIP entry that no docs
line matches any more.

The commands run in one temporary folder through click's CliRunner, README's block
first (it makes packing.h5, linear.h5, modes.h5, the files the other lines read),
then SETUP, then every other line in the order of the docs: about 10 s on 2 cores once
numba's cache holds the kernels (a first run compiles the DEM, pulse and time-domain
kernels, minutes, as any test using them does).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

from click.testing import CliRunner

from granwave.cli import main
from granwave.io import atomic, files

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]

#: Replacements applied in order to a docs line before it runs: sizes to tiny ones,
#: placeholders to the files made here. Plain text, whole words only.
SUBSTITUTIONS = [
    ("--grains 600", "--grains 60"),       # README's packing: 60 grains (20 leave no bulk for statics)
    ("-o PACKING", "-o imported.h5"),       # import lammps writes a packing; keep packing.h5 as made
    ("(MODES | LINEAR)", "MODES"),           # a choice in a synopsis: the first
    ("DATA_OR_DUMP", "deck/packing.data"),  # the data file export lammps wrote
    ("SIGNAL --packing PACKING", "snapshots.h5 --packing snapshot_packing.h5"),  # its own (SETUP)
    ("PACKING", "packing.h5"),
    ("LINEAR", "linear.h5"),
    ("MODES", "modes.h5"),
    ("SIGNAL", "snapshots.h5"),             # a signal with snapshots (SETUP)
    ("OUT.vtu", "packing.vtu"),
    ("OUT.pvd", "snapshots.pvd"),
    ("DIR", "deck"),
    ("--pressure P", "--pressure 1e-4"),
    ("--t-max T", "--t-max 30"),
]

#: Commands run after README's block: files some docs lines read that no docs line makes.
SETUP = [  # the snapshots' packing kept apart: docs lines write packing.h5 again, and export vtk
    # refuses a signal's snapshots on another packing's grains
    "granwave lattice --rows 6 --width 6 --pressure 1e-4 --friction 0.5 -q -o snapshot_packing.h5",
    "granwave linearize snapshot_packing.h5 -q -o snapshot_linear.h5",
    "granwave propagate snapshot_linear.h5 --method time --t-max 30 --snapshots 10,20 -q -o snapshots.h5",
]

#: Docs lines (as extracted, see :func:`docs_commands`) not run, and why.
SKIP = {
    "granwave report --config config/config.yaml --summaries results/summary --heights results/heights "
    "--sweep results/sweep/frictional2d.json --figures results/figures -o results/report/index.md":
        "reads a whole workflow run's results/ (summaries, heights, sweep, figures); "
        "tests/test_report.py runs it on small made inputs",
    "granwave prepare-packing --grains 100000 --pressure 1e-4 --device gpu -o packing.h5":
        "needs an NVIDIA GPU (tests/test_gpu_device.py runs the GPU path where there is one)",
    "granwave propagate linear.h5 --method time --t-max 2000 --device gpu -o signal.h5":
        "needs an NVIDIA GPU (tests/test_gpu_device.py runs the GPU path where there is one)",
    "granwave prepare-packing --grains 600 --pressure 1e-4 --seeds 0-9 --device gpu -o 'packing_{seed}.h5'":
        "needs an NVIDIA GPU (tests/test_gpu_batch.py runs --seeds on the CPU and the batch in the "
        "CUDA simulator)",
    "granwave prepare-packing --grains 600 --device gpu --checkpoint run.ckpt.h5 -o run.h5":
        "needs an NVIDIA GPU (tests/test_gpu_checkpoint.py runs it in the CUDA simulator)",
    "granwave prepare-packing --grains 600 --seeds 0-9 --device gpu --checkpoint 'ck_{seed}.h5' -o 'p_{seed}.h5'":
        "needs an NVIDIA GPU (tests/test_gpu_checkpoint.py runs it in the CUDA simulator)",
}

COMMAND = re.compile(r"^\s*(?:\$\s+)?(granwave\s.*)$")
HEADING_SPAN = re.compile(r"`(granwave\s[^`]*)`")


def _clean(line: str) -> str:
    return re.sub(r"\s+#\s.*$", "", line).strip()


def docs_commands() -> list[tuple[str, str]]:
    """(where, command line) of every docs command, in the order of the files."""
    found = []
    for path in DOCS:
        lines = path.read_text(encoding="utf-8").splitlines()
        in_block, language, current = False, "", None
        for number, line in enumerate(lines, 1):
            where = f"{path.relative_to(ROOT)}:{number}"
            if line.lstrip().startswith("```"):
                in_block = not in_block
                language = line.strip()[3:].strip().lower() if in_block else ""
                current = None
                continue
            if not in_block:
                if line.startswith("#"):
                    found += [(where, span.strip()) for span in HEADING_SPAN.findall(line)
                              if re.search(r"\s-", span)]
                continue
            if language in ("python", "py", "pycon", "yaml", "json"):
                continue
            if current is not None and (current[1].endswith("\\") or line[:1].isspace()) \
                    and not COMMAND.match(line):
                text = current[1].rstrip("\\").rstrip() + " " + _clean(line)
                current = (current[0], text)
                found[-1] = current
                continue
            m = COMMAND.match(line)
            current = (where, _clean(m.group(1))) if m else None
            if current is not None:
                found.append(current)
    return found


def runnable(command: str) -> list[str]:
    """The arguments (after `granwave`) a docs line runs with here (a trailing ``> FILE``
    kept as the last two: :func:`split_redirect` takes it off)."""
    text = re.sub(r"\s*\[[^\[\]]*\]", "", command)  # optional parts of a synopsis
    for old, new in SUBSTITUTIONS:
        text = re.sub(rf"(?<![\w.-]){re.escape(old)}(?![\w-])", new, text)
    args = shlex.split(text)
    assert args[0] == "granwave", command
    return args[1:]


def split_redirect(args: list[str]) -> tuple[list[str], str | None]:
    """``args`` without a trailing shell redirection ``> FILE``, and FILE (None without one)."""
    if len(args) >= 2 and args[-2] == ">":
        return args[:-2], args[-1]
    return args, None


def test_docs_commands_are_all_run_or_skipped():
    commands = docs_commands()
    texts = {c for _, c in commands}
    assert len(commands) >= 10, commands  # the extraction finds the docs' command lines
    stale = [s for s in SKIP if s not in texts]
    assert not stale, f"SKIP names lines no docs hold any more: {stale}"
    for where, command in commands:
        if command not in SKIP:
            args, _ = split_redirect(runnable(command))
            assert not any(re.search(r"[<>]|\b[A-Z]{2,}\b", a) for a in args), \
                f"{where}: placeholder left in {args}: add a substitution or a SKIP entry"


def test_docs_commands_run_as_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    commands = docs_commands()
    readme = [c for c in commands if c[0].startswith("README")]
    others = [c for c in commands if not c[0].startswith("README")]
    plan = readme + [("SETUP", s) for s in SETUP] + others
    runner = CliRunner()
    for where, command in plan:
        if command in SKIP:
            continue
        args, redirect = split_redirect(runnable(command))
        # Each line runs as its own process would: forget the files earlier lines read
        # (a file read in this process may not be replaced by a later write).
        atomic._INPUTS.clear()
        result = runner.invoke(main, args, catch_exceptions=False)
        assert result.exit_code == 0, f"{where}: `granwave {' '.join(args)}` failed:\n{result.output}"
        if redirect:
            Path(redirect).write_text(result.stdout)
