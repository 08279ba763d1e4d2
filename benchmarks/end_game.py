"""The packing statistics with and without the adaptive end game (a script, not a test).

    python benchmarks/end_game.py [--dim 2] [--grains 600] [--pressures 1e-4 1e-7] [--seeds 20]
        [--workers 2] [--results benchmarks/results/ensembles/end_game_2d.jsonl] [--table-only]

Prepares seeds 0..seeds-1 of the default protocol (PrepareParams; in 3D friction 0.5 and the
'mean-flow' compaction of the large cubes) with ``end_game`` 'none' and 'adaptive' at every
pressure, and measures per packing what the protocol tables of benchmarks/results/TABLES.md list (docs/method.md
§4, §6; bulk: 3 d excluded next to each wall): the solid fraction, z*, f0, <N>/p, F2,
sigma1/sigma2 (2D) or the vertical over the mean horizontal stress (3D), the global moduli
(2D C22, C33; 3D C33, C55) over p^(1/3), the steps, what the end game did (its changes of
the rate and the lowest rate) and a digest of the packing's arrays (equal digests: the same
packing). Every packing appends one JSON line to ``--results`` (a rerun skips what is there).
Prints per pressure the mean +- standard error of each statistic under both rules, their
difference in combined standard errors, and how many packings are the same bytes.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import time
from pathlib import Path

import numpy as np

from compare_ensembles import mean_se
from protocol_sensitivity import digest

RULES = ("none", "adaptive")
STATS = {2: (("phi2", "Φ2"), ("z_star", "z*"), ("rattler_fraction", "f0"), ("mean_force_over_p", "⟨N⟩/p"),
             ("F2", "F2"), ("stress_ratio", "σ1/σ2"), ("Cn_over_p", "C22/p^(1/3)"),
             ("Cs_over_p", "C33/p^(1/3)"), ("steps", "steps")),
         3: (("phi3", "Φ3"), ("z_star", "z*"), ("rattler_fraction", "f0"), ("mean_force_over_p", "⟨N⟩/p"),
             ("F2", "F2"), ("stress_ratio", "σ ratio"), ("Cn_over_p", "C33/p^(1/3)"),
             ("Cs_over_p", "C55/p^(1/3)"), ("steps", "steps"))}


def params(dim: int, grains: int, pressure: float, seed: int, rule: str):
    from granwave.dem.params import PrepareParams

    extra = dict(friction=0.5, compaction="mean-flow") if dim == 3 else {}
    return PrepareParams(dim=dim, grains=grains, pressure=pressure, seed=seed, end_game=rule, **extra)


def measure(task: tuple) -> dict:
    """Prepare one packing and measure it; returns one result record."""
    dim, grains, pressure, seed, rule = task
    from granwave.analysis.statics import statics
    from granwave.dem.protocol import prepare_packing
    from granwave.errors import ConvergenceError
    from granwave.linear.moduli import moduli

    record = dict(dim=dim, grains=grains, pressure=pressure, seed=seed, rule=rule)
    t0 = time.process_time()
    try:
        packing = prepare_packing(params(dim, grains, pressure, seed, rule))
    except ConvergenceError as exc:
        record.update(ok=False, error=str(exc), cpu_s=time.process_time() - t0)
        return record
    s = statics(packing, layer=3.0)
    m = moduli(packing)
    normal, shear = ("C22", "C33") if dim == 2 else ("C33", "C55")
    a = packing.attrs
    record.update(ok=True, **{k: float(s[k]) for k in ("phi2" if dim == 2 else "phi3", "z_star",
                                                        "rattler_fraction", "mean_force_over_p", "F2",
                                                        "stress_ratio")},
                  Cn_over_p=float(m[normal]) / pressure ** (1 / 3), Cs_over_p=float(m[shear]) / pressure ** (1 / 3),
                  steps=int(a["steps"]), end_game_step=int(a.get("end_game_step", -1)),
                  end_game_changes=int(a.get("end_game_changes", 0)),
                  end_game_lowest_rate=float(a.get("end_game_lowest_rate", math.nan)),
                  gamma=float(a["background_damping_rate"]), digest=digest(packing),
                  cpu_s=time.process_time() - t0)
    return record


def load(path: Path) -> dict:
    """{(dim, grains, pressure, seed, rule): record}, the last one of each."""
    out = {}
    if path.exists():
        for line in path.read_text().splitlines():
            r = json.loads(line)
            out[(r["dim"], r["grains"], r["pressure"], r["seed"], r["rule"])] = r
    return out


def table(records: dict, dim: int, grains: int, pressures, seeds: int) -> str:
    lines = []
    for p in pressures:
        by = {rule: [records.get((dim, grains, p, s, rule)) for s in range(seeds)] for rule in RULES}
        pairs = [(a, b) for a, b in zip(by["none"], by["adaptive"]) if a and b and a["ok"] and b["ok"]]
        if not pairs:
            continue
        failed = {rule: sum(1 for r in by[rule] if r and not r["ok"]) for rule in RULES}
        same = sum(a["digest"] == b["digest"] for a, b in pairs)
        acted = sum(b["end_game_changes"] > 0 for _, b in pairs)
        low = [b["end_game_lowest_rate"] / b["gamma"] for _, b in pairs if b["end_game_changes"] > 0]
        lines += [f"{dim}D, {grains} grains, p = {p:g}: {len(pairs)} seeds under both rules "
                  f"(not converged: {failed['none']} 'none', {failed['adaptive']} 'adaptive'); "
                  f"{same} the same bytes; the end game changed the rate in {acted}"
                  + (f" (lowest rate {min(low):.3g}-{max(low):.3g} of b / t_i)" if low else ""), "",
                  "| statistic | end game 'none' | 'adaptive' | difference / combined SE |", "|---|---|---|---|"]
        for key, label in STATS[dim]:
            ma, sa = mean_se([a[key] for a, _ in pairs])
            mb, sb = mean_se([b[key] for _, b in pairs])
            z = (mb - ma) / math.hypot(sa, sb) if sa > 0 or sb > 0 else 0.0
            lines.append(f"| {label} | {ma:.5g} ± {sa:.2g} | {mb:.5g} ± {sb:.2g} | {z:+.2f} |")
        steps = np.array([b["steps"] / a["steps"] for a, b in pairs])
        lines += [f"| steps, 'adaptive' / 'none' (per seed) | median {np.median(steps):.3f} | "
                  f"range {steps.min():.3f}-{steps.max():.3f} | |", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, choices=(2, 3), default=2)
    ap.add_argument("--grains", type=int, default=600)
    ap.add_argument("--pressures", type=float, nargs="+", default=[1e-4, 1e-7])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--results", type=Path, default=None, help="default: benchmarks/results/ensembles/end_game_<dim>d.jsonl")
    ap.add_argument("--table-only", action="store_true")
    args = ap.parse_args(argv)
    results = args.results or Path(__file__).resolve().parent / "results" / "ensembles" / f"end_game_{args.dim}d.jsonl"
    done = load(results)
    tasks = [(args.dim, args.grains, p, s, rule) for p in args.pressures for s in range(args.seeds)
             for rule in RULES if (args.dim, args.grains, p, s, rule) not in done]
    if tasks and not args.table_only:
        print(f"{len(tasks)} packings to prepare ({args.workers} workers) -> {results}", flush=True)
        with multiprocessing.get_context("spawn").Pool(args.workers, maxtasksperchild=20) as pool, \
                results.open("a") as out:
            for r in pool.imap_unordered(measure, tasks):
                out.write(json.dumps(r) + "\n")
                out.flush()
                print(f"  {r['dim']}D p={r['pressure']:g} seed {r['seed']} {r['rule']}: "
                      + (f"{r['steps']} steps, changes {r['end_game_changes']}" if r["ok"] else "FAILED")
                      + f" ({r['cpu_s']:.1f} s CPU)", flush=True)
        done = load(results)
    print(table(done, args.dim, args.grains, args.pressures, args.seeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
