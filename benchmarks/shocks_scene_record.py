"""Record a workflow shocks scene's analysis in benchmarks/results/shocks_scene.jsonl, from which
benchmarks/results/summarize.py writes docs/shocks.md's scene tables.

    PYTHONPATH=. python benchmarks/shocks_scene_record.py RESULTS/shocks/<scene>/analysis.json ... \\
        --command "snakemake ... --configfile config/shocks.yaml" [--benchmarks RESULTS/benchmarks]
    python benchmarks/results/summarize.py

One record per scene of each analysis. ``--benchmarks``: the run's Snakemake benchmark folder; the
CPU seconds of the scene's batches (its shocks subfolder) go into the record.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_record import append_record, benchmark_cpu_seconds  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "shocks_scene.jsonl"


def _cpu(folder: Path, scene: str) -> float | None:
    """The CPU seconds of the scene's batches, shocks_batch_<scene>_<k>.tsv (exactly: a scene named
    like another's prefix, hertz_frictional and hertz_frictional_3d, does not take its files)."""
    batch = re.compile(rf"shocks_batch_{re.escape(scene)}_\d+\.tsv")
    return benchmark_cpu_seconds(sorted(f for f in (folder / "shocks").glob("shocks_batch_*.tsv")
                                        if batch.fullmatch(f.name)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("analyses", nargs="+")
    ap.add_argument("--command", required=True, help="the command that made the analysis")
    ap.add_argument("--benchmarks", default=None)
    ap.add_argument("--notes", default=None)
    args = ap.parse_args()
    for path in args.analyses:
        for scene, a in json.loads(Path(path).read_text())["scenes"].items():
            t, sc = a["tail_exponent"], a["crossover_scaling"]
            summary = {"packings": a["n_packings"], "law": a["contact_law"], "friction": a["friction"],
                       "exponent": t["mean"], "exponent error": t["error"],
                       "expected exponent": a["tail_exponent_expected"],
                       "mean-field exponent (same window)": a["tail_exponent_mean_field"],
                       "crossover p-exponent": sc["exponent"], "crossover p-exponent error": sc["error"]}
            if args.benchmarks:
                summary["batch CPU (s)"] = _cpu(Path(args.benchmarks), scene)
            append_record(OUT, "shocks_scene", args.command, summary, a, notes=args.notes, scene=scene)


if __name__ == "__main__":
    main()
