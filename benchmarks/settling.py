"""Critical settling against the compaction rate to the end, in tall mean-flow columns (a script).

    python benchmarks/settling.py [--rule critical|late] [--heights 100] [--pressures 1e-4]
        [--seeds 10] [--workers 2] [--results benchmarks/results/ensembles/settling.jsonl] [--table-only]
        [--write-docs]

For each pressure, height L and seed, prepares the 2D frictional column of
benchmarks/relaxation.py (width 25 d, the defaults of PrepareParams, compaction
'mean-flow') twice: with ``mean_flow_settling`` ``--rule`` ('critical' or 'late') and
'compaction' (the default, the rule before), and records the steps and the bulk statistics
(layer 3 d). The table gives each statistic's mean ± standard error over the
seeds for both rules and their difference over its standard error (paired by
seed: the two runs of one seed share the gas and the compaction up to the
switch). Runs are one core each (NUMBA_NUM_THREADS=1), ``--workers`` at a time;
every finished pair appends one JSON line to ``--results`` and a rerun skips
what is there (default files: benchmarks/results/ensembles/settling.jsonl for 'critical',
benchmarks/results/ensembles/settling_late.jsonl for 'late'). ``--write-docs`` regenerates the block of
benchmarks/results/TABLES.md between ``<!-- settling:begin -->`` and ``<!-- settling:end -->`` (for
'late': ``settling-late:begin`` / ``end``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
#: the rules a run compares with 'compaction'
RULES = ("critical", "late")
STATS = [("steps", "steps"), ("phi2", "Φ2"), ("z_star", "z*"), ("rattler_fraction", "f0"),
         ("mean_force_over_p", "⟨N⟩/p"), ("F2", "F2"), ("stress_ratio", "σ1/σ2")]


def measure_pair(pressure: float, height: float, width: float, seed: int, rule: str = "critical") -> dict:
    """Prepare one column with ``rule`` and with 'compaction'; the record of the pair."""
    from relaxation import grains_for

    from granwave.analysis.statics import statics
    from granwave.dem.protocol import prepare_packing
    from granwave.params import PrepareParams

    n = grains_for(width, height)
    rec = dict(pressure=pressure, height=height, width=width, seed=seed, grains=n)
    for rule in (rule, "compaction"):
        params = PrepareParams(dim=2, grains=n, pressure=pressure, aspect=height / width, seed=seed,
                               compaction="mean-flow", mean_flow_settling=rule, max_steps=50_000_000)
        t0 = time.process_time()
        packing = prepare_packing(params)
        s = statics(packing, layer=3.0)
        a = packing.attrs
        rec[rule] = dict(steps=int(a["steps"]), cpu_s=time.process_time() - t0,
                         settling_step=int(a.get("settling_step", -1)),
                         breathing_frequency=float(a.get("breathing_frequency", math.nan)),
                         residual=float(a["max_acceleration"]),
                         **{k: float(s[k]) for k, _ in STATS[1:]})
    return rec


def load(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def report(records: list[dict], rule: str = "critical") -> str:
    lines = []
    groups = sorted({(r["pressure"], r["height"]) for r in records})
    for p, h in groups:
        rows = [r for r in records if r["pressure"] == p and r["height"] == h]
        n = len(rows)
        omega = [r[rule]["breathing_frequency"] for r in rows]
        lines.append(f"p = {p:g}, L = {h:g} d, {rows[0]['grains']} grains, {n} seeds; breathing frequency "
                     f"measured {np.nanmean(omega):.3g} (ω L = {np.nanmean(omega) * h:.3f}); switch after "
                     f"{np.mean([r[rule]['settling_step'] for r in rows]):.0f} steps on average\n")
        lines.append(f"| statistic | {rule} | compaction | difference / its SE |")
        lines.append("|---|---|---|---|")
        for key, label in STATS:
            a = np.array([r[rule][key] for r in rows], float)
            b = np.array([r["compaction"][key] for r in rows], float)
            se = lambda x: np.std(x, ddof=1) / math.sqrt(len(x)) if len(x) > 1 else math.nan  # noqa: E731
            diff = a - b
            z = np.mean(diff) / se(diff) if n > 1 and se(diff) > 0 else math.nan
            fmt = ".0f" if key == "steps" else ".4f"
            # steps: a soft grain creeping in the end game can multiply one run's steps, so the median too
            med = (lambda x: f" (median {np.median(x):.0f})") if key == "steps" else (lambda x: "")
            lines.append(f"| {label} | {np.mean(a):{fmt}} ± {se(a):{fmt}}{med(a)} | {np.mean(b):{fmt}} ± "
                         f"{se(b):{fmt}}{med(b)} | {z:+.2f} |")
        lines.append("")
    return "\n".join(lines).rstrip()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rule", choices=RULES, default="critical", help="the rule compared with 'compaction'")
    ap.add_argument("--width", type=float, default=25.0)
    ap.add_argument("--heights", type=float, nargs="+", default=[100.0])
    ap.add_argument("--pressures", type=float, nargs="+", default=[1e-4])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--results", type=Path, default=None)
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--write-docs", action="store_true")
    args = ap.parse_args(argv)
    if args.results is None:
        name = "settling.jsonl" if args.rule == "critical" else f"settling_{args.rule}.jsonl"
        args.results = ROOT / "benchmarks" / "results" / "ensembles" / name
    records = [r for r in load(args.results) if args.rule in r]
    done = {(r["pressure"], r["height"], r["seed"]) for r in records}
    todo = [(p, h, args.width, s) for p in args.pressures for h in args.heights for s in range(args.seeds)
            if (p, h, s) not in done]
    if todo and not args.table_only:
        with ProcessPoolExecutor(args.workers) as pool:
            for rec in pool.map(measure_pair, *zip(*todo), [args.rule] * len(todo)):
                with args.results.open("a") as f:
                    f.write(json.dumps(rec) + "\n")
                records.append(rec)
                c, o = rec[args.rule], rec["compaction"]
                print(f"p {rec['pressure']:g} L {rec['height']:g} seed {rec['seed']}: steps {c['steps']} "
                      f"({args.rule}) / {o['steps']} (compaction), Φ2 {c['phi2']:.4f} / {o['phi2']:.4f}", flush=True)
    keep = {(p, h) for p in args.pressures for h in args.heights}
    table = report([r for r in records if (r["pressure"], r["height"]) in keep], args.rule)
    print(table)
    if args.write_docs:
        from granwave.io.files import replace_marked_block

        tag = "settling" if args.rule == "critical" else f"settling-{args.rule}"
        command = "python benchmarks/settling.py" + ("" if args.rule == "critical" else f" --rule {args.rule}")
        text = (f"Measured by `{command}` on {time.strftime('%Y-%m-%d', time.gmtime())} "
                f"(records in benchmarks/results/ensembles/{args.results.name}).\n\n" + table)
        replace_marked_block(ROOT / "benchmarks" / "results" / "TABLES.md", f"<!-- {tag}:begin -->", f"<!-- {tag}:end -->", text)
        print("wrote benchmarks/results/TABLES.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
