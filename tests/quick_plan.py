"""Dry runs of the workflow (`snakemake -n`), each made once per test session and shared by the
tests that read it: the same commands each test ran on its own.

- :func:`dry_run`: the job table of a config (`-n --quiet rules` in an empty folder, as
  benchmarks/results/summarize.workflow_jobs runs it): tests/test_workflow.py,
  tests/test_shear_scene.py, tests/test_generated_docs.py.
- :func:`shell_commands`: the shell commands (`-n -p`) of some targets of a config:
  tests/test_workflow.py and tests/test_checkpoint.py ask for packings of config/continuum.yaml.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _snakemake(*args) -> tuple[int, str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    with tempfile.TemporaryDirectory() as work:
        run = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"), *args],
                             cwd=work, capture_output=True, text=True, env=env, timeout=600)
    return run.returncode, run.stdout + run.stderr


@functools.lru_cache(maxsize=None)
def dry_run(config: str = "config/config.yaml") -> tuple[int, str]:
    """(exit status, stdout + stderr) of `snakemake -n --quiet rules` with ``config`` (relative
    to the repository) in an empty folder."""
    return _snakemake("-n", "--quiet", "rules", "--configfile", str(ROOT / config))


@functools.lru_cache(maxsize=None)
def shell_commands(config: str, targets: tuple[str, ...], cores: int, allowed_rules: tuple[str, ...]
                   ) -> tuple[int, str]:
    """(exit status, stdout + stderr) of `snakemake TARGETS -n -p --cores CORES --configfile
    CONFIG --allowed-rules RULES` in an empty folder: each target's job with its shell command."""
    return _snakemake(*targets, "-n", "-p", "--cores", str(cores), "--configfile", str(ROOT / config),
                      "--allowed-rules", *allowed_rules)


#: packings of config/continuum.yaml whose commands the tests read: a tall column (12 800 grains),
#: a short one and the tallest (51 200), in one dry run with 16 cores
CONTINUUM_PACKINGS = tuple(f"results/packing/continuum2d_p4/p0.0001/h{h}/s0.h5" for h in (512, 64, 2048))


def continuum_packing_commands(cores: int = 16) -> tuple[int, str]:
    """:func:`shell_commands` of :data:`CONTINUUM_PACKINGS` (only their own rule)."""
    return shell_commands("config/continuum.yaml", CONTINUUM_PACKINGS if cores == 16 else CONTINUUM_PACKINGS[:1],
                          cores, ("prepare_packing",))


def command_of(output: str, target: str, program: str) -> str:
    """The shell command line (of ``program``) that writes ``target`` (``-o TARGET``), from a
    :func:`shell_commands` output."""
    for line in output.splitlines():
        if program in line and f"-o {target} " in line + " ":
            return line
    raise AssertionError(f"no {program!r} command writing {target} in:\n{output[-3000:]}")
