"""Two ensembles of packings of the same protocol, statistic by statistic (a script, not a test).

    python benchmarks/compare_ensembles.py OLD.jsonl NEW.jsonl [--setting default] [--seeds 20]

Reads the per-packing records that ``benchmarks/protocol_sensitivity.py`` writes (one JSON
line per packing) from two files, keeps the records of ``--setting`` with seeds below
``--seeds`` (the last record of each (pressure, seed) in each file), and prints per pressure a
table of mean +- standard error of the mean in each file and the difference in combined
standard errors, and how many packings are the same bytes (equal digests). Used when a
change of the engine changes the rounding of every run (docs/decisions/0006-folded-positions-adaptive-skin.md): the packings then differ seed by seed, and only their statistics can agree.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

STATS = (("phi2", "Φ2"), ("z_star", "z*"), ("rattler_fraction", "f0"), ("mean_force_over_p", "⟨N⟩/p"),
         ("F2", "F2"), ("stress_ratio", "σ1/σ2"), ("C22_over_p", "C22/p"), ("C33_over_p", "C33/p"),
         ("steps", "steps"))


def records(path: Path, setting: str, seeds: int) -> dict:
    """{(pressure, seed): record}, the last one of each in the file."""
    out = {}
    for line in path.read_text().splitlines():
        r = json.loads(line)
        if r.get("setting") == setting and r.get("ok", True) and r["seed"] < seeds:
            out[(r["pressure"], r["seed"])] = r
    return out


def mean_se(values) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else math.nan


def table(old: dict, new: dict, names=("before", "after")) -> str:
    lines = []
    for p in sorted({k[0] for k in old} | {k[0] for k in new}, reverse=True):
        a = [r for k, r in sorted(old.items()) if k[0] == p]
        b = [r for k, r in sorted(new.items()) if k[0] == p]
        same = sum(1 for k, r in new.items() if k[0] == p and k in old and old[k]["digest"] == r["digest"])
        lines += [f"p = {p:g}: {len(a)} and {len(b)} packings, {same} the same bytes", "",
                  f"| statistic | {names[0]} | {names[1]} | difference / combined SE |", "|---|---|---|---|"]
        for key, label in STATS:
            ma, sa = mean_se([r[key] for r in a])
            mb, sb = mean_se([r[key] for r in b])
            z = (mb - ma) / math.hypot(sa, sb) if sa > 0 or sb > 0 else 0.0
            lines.append(f"| {label} | {ma:.5g} ± {sa:.2g} | {mb:.5g} ± {sb:.2g} | {z:+.2f} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--setting", default="default")
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args()
    print(table(records(args.old, args.setting, args.seeds), records(args.new, args.setting, args.seeds)))


if __name__ == "__main__":
    main()
