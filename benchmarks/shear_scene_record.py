"""Record a workflow shear scene's analysis in benchmarks/results/shear_scene.jsonl, from which
benchmarks/results/summarize.py writes docs/shear.md's scene pick table.

    PYTHONPATH=. python benchmarks/shear_scene_record.py RESULTS/shear/shear2d/analysis.json \\
        --command "snakemake ... results/figures/shear_shear2d.png" [--benchmarks RESULTS/benchmarks]
    python benchmarks/results/summarize.py

``--benchmarks``: the run's Snakemake benchmark folder; the CPU seconds of the scene's jobs
(its batches: the shear subfolder of that folder; the analysis and figure jobs have no benchmark file) go into the record.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_record import append_record, benchmark_cpu_seconds  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "shear_scene.jsonl"


def _cpu(folder: Path, scene: str) -> float | None:
    return benchmark_cpu_seconds(sorted((folder / "shear").glob(f"shear_batch_{scene}_*.tsv")))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("analysis")
    ap.add_argument("--command", required=True, help="the command that made the analysis")
    ap.add_argument("--benchmarks", default=None)
    ap.add_argument("--notes", default=None)
    args = ap.parse_args()
    a = json.loads(Path(args.analysis).read_text())
    f, g = a["fits"], a["G_max"]

    def exp(key):
        fit = f.get(key) or {}
        return fit.get("exponent")

    summary = {"packings": a["n_records"], "pick": a["pick"], "nu_s (V_s)": exp("V_s"),
               "nu_p (V_p)": exp("V_p"), "c_t exponent (moduli)": exp("c_t"),
               "n (G_max)": exp("G_max"), "(n - 1/3) / error": g.get("deviation_from_hertz")}
    if args.benchmarks:
        summary["batch CPU (s)"] = _cpu(Path(args.benchmarks), a.get("scene", ""))
    append_record(OUT, "shear_scene", args.command, summary, a, notes=args.notes)


if __name__ == "__main__":
    main()
