"""Append one record of a workflow scene's analysis to a JSONL file of benchmarks/results (the
fields benchmarks/results/summarize.py reads: date, benchmark, command, git_revision, machine,
summary, result, optional notes). Used by shear_scene_record.py and continuum_scene_record.py."""

from __future__ import annotations

import csv
import json
import platform
import time
from pathlib import Path

from granwave.provenance import git_revision


def append_record(path: Path, benchmark: str, command: str, summary: dict, result, *,
                  notes: str | None = None, revision: str | None = None, **fields) -> dict:
    """Write the record as one line at the end of ``path`` and return it; ``revision``: the git
    revision the run used (default: this checkout's); ``fields`` go in after ``benchmark``."""
    rec = {"date": time.strftime("%Y-%m-%d"), "benchmark": benchmark, **fields, "command": command,
           "git_revision": revision or git_revision(),
           "machine": {"cpu": platform.processor() or platform.machine()}, "summary": summary,
           "result": result}
    if notes:
        rec["notes"] = notes
    with Path(path).open("a") as fh:
        fh.write(json.dumps(rec) + "\n")
    print(f"appended to {path}")
    return rec


def benchmark_cpu_seconds(paths, digits: int = 2) -> float | None:
    """The summed ``cpu_time`` (s) of Snakemake benchmark files (TSV, first row each), rounded to
    ``digits``; None when there are none."""
    total, found = 0.0, False
    for path in paths:
        row = next(csv.DictReader(Path(path).open(), delimiter="\t"))
        total += float(row["cpu_time"])
        found = True
    return round(total, digits) if found else None
