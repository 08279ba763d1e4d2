"""Expected run time of a workflow config, extrapolated from measured per-job times.

Usage (after a run of the quick config, which writes results/benchmarks/):
    python benchmarks/workflow_runtime.py --measured results --config config/paper.yaml

Models, fitted to the measured jobs (Snakemake `benchmark:` files, CPU seconds):
- prepare_packing: t = a N p^(-1/3)  (steps grow as p^(-1/3), docs/dem.md; cost per step ~ N)
- eigensolve:      t = c0 + b n^3   (dense LAPACK; n = degrees of freedom)
- linearize, propagate, moduli, damping_signal: t = c0 + c1 N
- every other job: the median wall time of a light CLI job, measured here.
The target config's jobs come from `snakemake -n -p` (its own job list and shell
commands). The estimate is printed per rule and as wall time on a given number of cores
(perfect packing of independent jobs; the gather steps are short).
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
LINEAR_IN_N = ("linearize", "propagate", "moduli", "damping_signal")


def read_benchmarks(results: Path) -> dict[str, list[tuple[Path, float]]]:
    """{stage: [(benchmark file, cpu seconds)]} from results/benchmarks/<stage>/..."""
    out = defaultdict(list)
    for tsv in (results / "benchmarks").rglob("*.tsv"):
        stage = tsv.relative_to(results / "benchmarks").parts[0]
        with open(tsv) as f:
            row = next(csv.DictReader(f, delimiter="\t"))
        cpu = float(row.get("cpu_time") or 0.0) or float(row["s"])
        out[stage].append((tsv, cpu))
    return out


def sample_of(results: Path, stage: str, tsv: Path) -> tuple[Path, float]:
    """The packing file of a benchmarked sample and its pressure."""
    rel = tsv.relative_to(results / "benchmarks" / stage).with_suffix(".h5")
    packing = results / "packing" / rel
    return packing, float(rel.parts[1][1:])


def grains(packing: Path) -> int:
    with h5py.File(packing) as f:
        return int(f["grains/radius"].shape[0])


def dofs(results: Path, rel: Path) -> int:
    with h5py.File(results / "linear" / rel) as f:
        return int(f["mass"].shape[0])


def fit_models(results: Path) -> dict:
    bench = read_benchmarks(results)
    models = {}
    rows = [(grains(sample_of(results, "packing", t)[0]), sample_of(results, "packing", t)[1], c)
            for t, c in bench.get("packing", [])]
    if rows:
        models["prepare_packing"] = statistics.median(c / (n * p ** (-1 / 3)) for n, p, c in rows)
    rows = []
    for t, c in bench.get("modes", []):
        rel = t.relative_to(results / "benchmarks" / "modes").with_suffix(".h5")
        if rel.parts[0].startswith("chain"):
            continue  # chains use the tridiagonal path
        rows.append((dofs(results, rel), c))
    if rows:
        n, c = np.array(rows, float).T
        A = np.stack([np.ones_like(n), n**3], 1)
        models["eigensolve"] = tuple(np.linalg.lstsq(A, c, rcond=None)[0])
    for stage, rule in (("linear", "linearize"), ("signal", "propagate"), ("moduli", "moduli")):
        rows = []
        for t, c in bench.get(stage, []):
            packing, _ = sample_of(results, stage, t)
            if packing.exists():
                rows.append((grains(packing), c))
        if len(rows) >= 2:
            n, c = np.array(rows, float).T
            models[rule] = tuple(np.linalg.lstsq(np.stack([np.ones_like(n), n], 1), c, rcond=None)[0])
    if bench.get("damping"):
        models["damping_signal_each"] = statistics.median(c for _, c in bench["damping"])
    return models


def light_job_seconds() -> float:
    """Median wall time of a light CLI job (interpreter, imports, one small file)."""
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        subprocess.run(["granwave", "chain", "--balls", "10", "--pressure", "1e-4", "-o",
                        str(Path(tempfile.mkdtemp()) / "c.h5")], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def planned_jobs(config: Path) -> list[dict]:
    """Jobs of a config from `snakemake -n -p` (rule, wildcards, shell command)."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
                              "-n", "-p", "--configfile", str(config.resolve()),
                              "--config", f"results={tmp}/results"],
                             cwd=tmp, capture_output=True, text=True, check=True)
    jobs, cur = [], None
    for line in run.stdout.splitlines():
        m = re.match(r"^(?:local)?rule (\w+):", line)
        if m:
            cur = {"rule": m.group(1), "text": ""}
            jobs.append(cur)
        elif cur is not None:
            cur["text"] += line + "\n"
    return jobs


def grains_of_job(job: dict, config_sizes: dict) -> int:
    m = re.search(r"--grains (\d+)", job["text"])
    if m:
        return int(m.group(1))
    m = re.search(r"wildcards: (.*)", job["text"])
    wc = dict(kv.split("=", 1) for kv in m.group(1).split(", ")) if m else {}
    return config_sizes.get((wc.get("scene"), wc.get("pressure"), wc.get("size") or wc.get("height")), 0)


def estimate(config: Path, models: dict, light: float) -> tuple[Counter, Counter]:
    jobs = planned_jobs(config)
    # grain count of every sample, from the prepare_packing commands of the same dry run
    sizes = {}
    for job in jobs:
        if job["rule"] == "prepare_packing":
            wc = dict(kv.split("=", 1) for kv in re.search(r"wildcards: (.*)", job["text"]).group(1).split(", "))
            n = int(re.search(r"--grains (\d+)", job["text"]).group(1))
            sizes[(wc["scene"], wc["pressure"], f"h{wc['height']}")] = n
        elif job["rule"] in ("make_lattice", "make_chain"):
            wc = dict(kv.split("=", 1) for kv in re.search(r"wildcards: (.*)", job["text"]).group(1).split(", "))
            width = re.search(r"--width (\S+)", job["text"])
            n = int(wc["rows"]) * int(float(width.group(1))) if "rows" in wc else int(wc["balls"])
            sizes[(wc["scene"], wc["pressure"], f"r{wc['rows']}" if "rows" in wc else f"n{wc['balls']}")] = n
    seconds, counts = Counter(), Counter()
    for job in jobs:
        rule = job["rule"]
        counts[rule] += 1
        wc_m = re.search(r"wildcards: (.*)", job["text"])
        wc = dict(kv.split("=", 1) for kv in wc_m.group(1).split(", ")) if wc_m else {}
        n = sizes.get((wc.get("scene"), wc.get("pressure"), wc.get("size") or f"h{wc.get('height')}"), 0)
        if rule == "prepare_packing" and "prepare_packing" in models:
            t = models["prepare_packing"] * n * float(wc["pressure"]) ** (-1 / 3)
        elif rule == "eigensolve" and "eigensolve" in models and not wc.get("scene", "").startswith("chain"):
            c0, b = models["eigensolve"]
            dof = 3 * n  # 2D frictional: 3 per grain (an upper bound: rattlers are removed)
            t = max(light, c0 + b * dof**3)
        elif rule in models and rule in LINEAR_IN_N:
            c0, c1 = models[rule]
            t = max(light, c0 + c1 * n)
        elif rule == "damping_signal" and "damping_signal_each" in models:
            t = models["damping_signal_each"]
        else:
            t = light
        seconds[rule] += t
    return seconds, counts


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--measured", type=Path, default=ROOT / "results")
    ap.add_argument("--config", type=Path, default=ROOT / "config" / "paper.yaml")
    ap.add_argument("--cores", type=int, default=2)
    args = ap.parse_args(argv)
    models = fit_models(args.measured)
    light = light_job_seconds()
    print(f"models fitted to {args.measured}/benchmarks (CPU seconds):")
    for k, v in models.items():
        print(f"  {k}: {v}")
    print(f"  light job (measured here): {light:.2f} s")
    seconds, counts = estimate(args.config, models, light)
    total = sum(seconds.values())
    print(f"\nexpected cost of {args.config} ({sum(counts.values())} jobs):")
    for rule, t in seconds.most_common():
        print(f"  {rule:<20} {counts[rule]:>6} jobs  {t / 3600:8.2f} CPU h")
    print(f"  {'total':<20} {sum(counts.values()):>6} jobs  {total / 3600:8.2f} CPU h"
          f"  -> about {total / 3600 / args.cores:.1f} h wall on {args.cores} cores"
          f" ({total / 86400 / args.cores:.1f} days)")


if __name__ == "__main__":
    main()
