"""Record a workflow continuum scene's analyses in benchmarks/results/continuum_scene.jsonl, from
which benchmarks/results/summarize.py writes docs/continuum.md's tables (the newest record of
each scene).

    PYTHONPATH=. python benchmarks/continuum_scene_record.py RESULTS continuum2d_p4 \\
        --command "snakemake --configfile config/continuum.yaml ..." [--benchmarks RESULTS/benchmarks]
    python benchmarks/results/summarize.py

RESULTS is the run's results folder: the scene's ``continuum/<scene>/front.json`` and
``attenuation.json`` (`analyze continuum`, `analyze attenuation`) are recorded, without their
per-packing and per-height spectra (the tables do not use them). ``--benchmarks``: the run's
Snakemake benchmark folder; the CPU seconds of the scene's batches (``batch/batch_<scene>_*.tsv``)
and of the scene's lone-sample jobs (``<stage>/<scene>/...``) go into the record.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scene_record import append_record, benchmark_cpu_seconds  # noqa: E402

OUT = Path(__file__).resolve().parent / "results" / "continuum_scene.jsonl"
#: left out of the record: per-packing rows and per-height spectra (large; the tables use neither)
DROP = {"front": ("samples",), "attenuation": ("noise_floor", "spectrum_amplitude", "coherent_amplitude")}


def scene_cpu(folder: Path, scene: str) -> float | None:
    """CPU seconds of the scene's sample jobs (batches, and lone samples run by the per-sample
    rules), from Snakemake's benchmark files."""
    paths = list((folder / "batch").glob(f"batch_{scene}_*.tsv"))
    paths += [p for p in folder.rglob("*.tsv") if f"/{scene}/" in str(p)]
    return benchmark_cpu_seconds(sorted(set(paths)), digits=1)


def _finite(x):
    return None if x is None or (isinstance(x, float) and not math.isfinite(x)) else x


def headline(front: dict, att: dict) -> dict:
    """The record's summary: what the scene's answer is in a few numbers."""
    lam = att.get("continuum_length") or {}
    loc, app = front["local"], front["approach"]
    return {"packings": front["n_signals"], "heights": front["n_heights"],
            "packings per height": front["per_height"]["count"],
            "c_l (mean)": front["c_l"].get("mean"), "c0": att.get("c0"), "c0 err": att.get("c0_err"),
            "band": att.get("band"), "lateral cutoff": att.get("omega_cutoff"),
            "lambda*": _finite(lam.get("lambda_star")), "lambda* 95%": lam.get("lambda_star_ci"),
            "lambda* status": lam.get("status"), "L_lambda": _finite(lam.get("L_lambda")),
            "c_tof/c_l at the tallest distance": loc["ratio"][-1],
            "its error": loc["ratio_err"][-1], "L* (10% edge, 5%)": _finite(app.get("L_star")),
            "L* status": app.get("status")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", help="the run's results folder")
    ap.add_argument("scene")
    ap.add_argument("--command", required=True, help="the command(s) that made the analyses")
    ap.add_argument("--benchmarks", default=None, help="the run's Snakemake benchmark folder")
    ap.add_argument("--revision", default=None,
                    help="the git revision the run used (default: this checkout's)")
    ap.add_argument("--notes", default=None)
    args = ap.parse_args()
    folder = Path(args.results) / "continuum" / args.scene
    result = {}
    for kind in ("front", "attenuation"):
        data = json.loads((folder / f"{kind}.json").read_text())
        result[kind] = {k: v for k, v in data.items() if k not in DROP[kind]}
    summary = headline(result["front"], result["attenuation"])
    if args.benchmarks:
        summary["sample jobs CPU (s)"] = scene_cpu(Path(args.benchmarks), args.scene)
    append_record(OUT, "continuum_scene", args.command, summary, result, notes=args.notes,
                  revision=args.revision, scene=args.scene)


if __name__ == "__main__":
    main()
