"""Append one run of ``benchmarks/gpu.py --all`` (its JSON file) to gpu.jsonl, with headline numbers.

    python benchmarks/results/record_gpu.py RUN.json --revision REV [--notes TEXT]
    python benchmarks/results/record_gpu.py RUN.json --revision REV --print   # the headline only

A run of the CUDA simulator (``--tiny``) is refused (exit status 2): its numbers are no measurement.

The headline (``summary``) is computed from the run's own fields, never typed: the DEM and
time-domain rates with their ratios to one core and to the goals, the agreement checks and
the packings' statistics. ``summarize.py`` then regenerates RESULTS.md, docs/gpu.md's and docs/dem.md's tables.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def headline(run: dict) -> dict:
    """The numbers of one --all run that docs/gpu.md's table shows."""
    goals, out = run.get("goals", {}), {}
    if "bandwidth" in run:
        out["copy bandwidth (GB/s)"] = round(run["bandwidth"]["copy_GBps"], 1)
    for name, check in run.get("checks", {}).items():
        out[f"check {name}"] = check.get("skipped") or ("pass" if check.get("pass") else "FAIL")
    dem = run.get("dem")
    if dem:
        for key, label in (("gpu", "every step"), ("gpu_rebuild_every_8", "every 8 steps")):
            if key in dem:
                r = dem[key]
                out[f"DEM {dem['grains']:.3g} grains, rebuild test {label}: grain-steps/s"] = {
                    "values": f"{r['grain_steps_per_s']:.3g} ({r['rebuilds']} rebuilds in {r['steps']} steps)",
                    "ratio": round(r["grain_steps_per_s"] / dem["cpu"]["grain_steps_per_s"], 1),
                    "goal": goals.get("dem_speedup")}
        if "gpu_plain" in dem:
            p = dem["gpu_plain"]
            out["DEM without rebuilds: host time to queue the launches / run time"] = round(
                p["host_queue_s"] / p["seconds"], 3)
        out["DEM one core: grain-steps/s"] = f"{dem['cpu']['grain_steps_per_s']:.3g}"
        out["DEM fraction of the 2e9 grain-steps/s goal"] = round(dem["goal_ratio_rate"], 3)
    td = run.get("time_domain")
    if td and "gpu_s_per_step" in td:
        out[f"time domain {td['n_dof']:.3g} dofs: s/step GPU, one core"] = {
            "values": f"{td['gpu_s_per_step']:.3g}, {td['cpu_s_per_step']:.3g}",
            "ratio": round(td["speedup_vs_one_core"], 1), "goal": goals.get("td_speedup")}
        out["time domain: fraction of the copy roofline"] = {
            "values": "", "ratio": round(td["roofline_fraction"], 3), "goal": goals.get("td_roofline")}
    pk = run.get("packings")
    if pk:
        st = pk["statics"]
        out[f"{pk['grains']}-grain packings, GPU vs CPU ({pk['seeds_done']} of {pk['seeds_asked']} seeds)"] = (
            f"byte-identical {sum(pk['byte_identical'])}/{len(pk['byte_identical'])}; within 3 s.e.: "
            + ", ".join(f"{k} {'yes' if v['agree_3_sigma'] else 'no'}" for k, v in st.items()))
        out["packing seconds, GPU / CPU (means)"] = round(
            sum(pk["seconds"]["gpu"]) / max(sum(pk["seconds"]["cpu"]), 1e-300), 1)
    b = run.get("batch")
    if isinstance(b, dict) and "gpu" in b and "cpu" in b:  # packings in one batch against CPU cores
        g, c = b["gpu"], b["cpu"]
        out[f"{b['packings']} packings of {b['grains']} grains in one batch: s per packing, GPU and "
            f"{b['cpu_cores']} CPU cores"] = {
            "values": (f"{g['per_packing_s']:.3g} ({g['done']} done in {g['seconds']:.3g} s"
                       + (f"; {g['note']}" if "note" in g else "") + f"), {c['per_packing_s']:.3g} "
                       f"({c['done']} packings in {c['seconds']:.3g} s)"),
            "ratio": None if b.get("cpu_over_gpu_per_packing") is None else round(b["cpu_over_gpu_per_packing"], 2),
            "goal": 1.0}
        st = b.get("statics", {})
        if "skipped" not in st:
            out["batch ensembles' statics within 3 s.e. (GPU vs CPU)"] = ", ".join(
                f"{k} {'yes' if v['agree_3_sigma'] else 'no'}" for k, v in st.items())
    for name, r in run.get("goal_table", {}).items():  # the goals: measured, goal, pass
        verdict = "not measured" if r.get("pass") is None else ("pass" if r["pass"] else "FAIL")
        m = r.get("measured")
        out[f"goal {name}"] = f"{verdict}: {m:.4g} ({r['goal']})" if isinstance(m, (int, float)) else (
            f"{verdict} ({r['goal']})")
    col = run.get("columns", "")
    if isinstance(col, dict) and "s_per_batched_step" in col:  # columns in one batch (ensembles per launch)
        out[f"{col['columns']} mean-flow columns of {col['grains_per_column']} grains in one batch: s/step; "
            "whole batch predicted"] = (
            f"{col['s_per_batched_step']:.3g} s/step over {col['steps']} steps (rebuild test every "
            f"{col['rebuild_every']}); {col['predicted_batch_s'] / 60:.3g} min for the batch "
            f"({col['cpu_steps_of_one_column']} steps, one column's CPU run)")
    elif isinstance(col, dict) and "s_per_step" in col:  # one column measured, the preparation predicted
        out[f"mean-flow column {col['grains']} grains: s/step on the GPU; whole preparation predicted"] = (
            f"{col['s_per_step']:.3g} s/step over {col['steps']} steps; {col['predicted_one_column_s'] / 3600:.3g} h "
            f"for one column ({col['cpu_steps_of_one_column']} steps, its CPU run); ten in one batch: "
            f"{col['ten_in_one_batch']}")
    elif "columns" in run:  # older runs (a sentence), or a part skipped or failed
        out["columns (ten 2048 d)"] = (col.get("skipped") or col.get("error", "")) if isinstance(col, dict) else col
    out["wall time of the run (s)"] = round(run.get("wall_s", float("nan")), 1)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run")
    ap.add_argument("--revision", required=True, help="the git revision that ran")
    ap.add_argument("--notes", default="")
    ap.add_argument("--print", action="store_true", help="print the headline only (nothing recorded)")
    args = ap.parse_args(argv)
    run = json.loads(Path(args.run).read_text())
    if args.print:
        print(json.dumps(headline(run), indent=1))
        return 0
    if run.get("simulator"):
        print(f"record_gpu.py: {args.run} is a CUDA-simulator run (--tiny): not a measurement, not recorded",
              file=sys.stderr)
        return 2
    v = run.get("versions", {})
    rec = {"date": run["date"][:10], "benchmark": "gpu", "command": run.get("benchmark", "benchmarks/gpu.py --all"),
           "git_revision": args.revision,
           "machine": {"gpu": run.get("device", "?"),
                       "software": ", ".join(f"{k} {v[k]}" for k in ("python", "numba", "numba-cuda", "numpy",
                                                                      "cuda_runtime") if k in v)},
           "summary": headline(run), "notes": args.notes, "result": run}
    with open(HERE / "gpu.jsonl", "a") as f:
        f.write(json.dumps(rec) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
