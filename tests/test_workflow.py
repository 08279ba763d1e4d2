"""The Snakemake workflow: config validation, lint, the SLURM profile, and a tiny end-to-end run.

The end-to-end run uses tests/data/tiny_workflow.yaml (every rule family once, on the
smallest systems that still have a front) and checks that the report contains every
table and every figure the workflow made.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "workflow" / "Snakefile"
TINY = ROOT / "tests" / "data" / "tiny_workflow.yaml"


def snakemake(*args, cwd):
    return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE), *args],
                          cwd=cwd, capture_output=True, text=True, timeout=1200)


def test_config_typo_fails_at_once(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("t_max_factor", "t_max_factr"))
    run = snakemake("-n", "--configfile", str(bad), cwd=tmp_path)
    assert run.returncode != 0
    assert "t_max_factr" in run.stdout + run.stderr


def test_lint_is_clean(tmp_path):
    run = snakemake("--lint", "--configfile", str(TINY), cwd=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "Congratulations, your workflow is in a good condition!" in run.stdout + run.stderr


@pytest.mark.parametrize("config", ["config.yaml"])
def test_slurm_profile_dry_run_resolves_resources(tmp_path, config):
    pytest.importorskip("snakemake_executor_plugin_slurm")
    run = snakemake("-n", "--profile", str(ROOT / "workflow" / "profiles" / "slurm"),
                    "--configfile", str(ROOT / "config" / config), cwd=tmp_path)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-3000:]
    total = re.search(r"^total\s+(\d+)", out, re.M)
    assert total and int(total.group(1)) > 100
    assert "This was a dry-run" in out


@pytest.mark.slow
def test_tiny_workflow_end_to_end(tmp_path):
    run = snakemake("--cores", "2", "--configfile", str(TINY), cwd=tmp_path)
    assert run.returncode == 0, (run.stdout + run.stderr)[-5000:]
    report = (tmp_path / "results" / "report" / "index.md").read_text()
    assert (tmp_path / "results" / "report" / "index.html").is_file()
    for heading in ["## Statics per pressure", "## Elastic moduli per pressure",
                    "## Sound speeds against pressure", "## Front scaling with distance",
                    "## Triangular lattices against the formula",
                    "## Damping series (nonlinear DEM", "## Provenance and numerical checks",
                    "## Figures"]:
        assert heading in report, heading
    figures = sorted(p.name for p in (tmp_path / "results" / "figures").glob("*.png"))
    assert len(figures) >= 12, figures
    for name in figures:
        assert f"figures/{name}" in report, name
    assert "tiny" in report  # the config it came from
    # Rerunning with nothing changed does nothing.
    again = snakemake("--cores", "2", "--configfile", str(TINY), cwd=tmp_path)
    assert again.returncode == 0
    assert "Nothing to be done" in again.stdout + again.stderr


@pytest.mark.slow
def test_interrupted_workflow_finishes_on_rerun(tmp_path):
    """SIGTERM (what a scheduler or `kill` sends) mid-run, then the same command finishes the rest."""
    import os
    import signal
    import time

    cmd = [sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE), "--cores", "2",
           "--configfile", str(TINY)]
    first = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, start_new_session=True)
    time.sleep(12)
    os.killpg(first.pid, signal.SIGTERM)
    log = first.communicate(timeout=300)[0]
    done = [int(m) for m in re.findall(r"(\d+) of \d+ steps", log)]
    total = int(re.search(r"of (\d+) steps", log).group(1)) if done else None
    assert first.returncode != 0 and done and done[-1] < total, log[-2000:]
    rerun = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=1200)
    assert rerun.returncode == 0, (rerun.stdout + rerun.stderr)[-3000:]
    assert (tmp_path / "results" / "report" / "index.md").is_file()
    # no temporary file of an interrupted atomic write is left looking like an output
    assert not [p for p in (tmp_path / "results").rglob("*") if p.name.endswith(".tmp")]
