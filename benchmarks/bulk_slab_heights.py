"""c_l against column height: the whole cell's (c_l), the bulk slab's (c_l_slab) and the lowest
longitudinal standing waves' speed, on columns prepared like the continuum scene's.

    PYTHONPATH=. python benchmarks/bulk_slab_heights.py --heights 10 20 40 --seeds 4 [--record]

Each column: 2D, periodic width ``--width`` (25 d), round(width x height) grains, piston pressure
``--pressure``, friction ``--friction`` (0.5: the continuum scene's), the mean-flow compaction
rule (``--compaction``; columns up to 25 d are prepared alike by every rule), seeds 1 ..
``--seeds``. Per column: ``analyze moduli``'s c_l (whole-cell C22 over the bulk
Phi3* of ``analyze statics``), c_l_slab (the slab layer <= y <= H - layer: its C22 over its own
Phi3*, docs/moduli.md), sqrt(C22 / phi3_star_cell) (whole-cell C22 over the whole cell's density)
and, up to ``--modes-max-dof`` dofs, the speeds of the standing waves n = 1, 2, 3
(granwave.linear.standing: weighted median of each profile's spectral weight, H_eff = H
C22_slab / C22); with ``--profile W`` also C22 and Phi3* of W-thick slabs at each depth from the
walls. Prints mean ± standard error per height; ``--record`` appends the run to
benchmarks/results/bulk_slab.jsonl (then run benchmarks/results/summarize.py).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "results" / "bulk_slab.jsonl"


def column(height: float, seed: int, args) -> dict:
    from granwave.dem.protocol import prepare_packing
    from granwave.linear.assemble import linearize
    from granwave.linear.moduli import moduli
    from granwave.linear.standing import longitudinal_modes, mode_speeds
    from granwave.params import PrepareParams

    t0 = time.perf_counter()
    pk = prepare_packing(PrepareParams(dim=2, grains=round(args.width * height),
                                       aspect=height / args.width, pressure=args.pressure,
                                       friction=args.friction, compaction=args.compaction, seed=seed))
    t1 = time.perf_counter()
    m = moduli(pk, layer=args.layer)
    t2 = time.perf_counter()
    row = {"height_nominal": height, "seed": seed, "height": float(pk.box[-1]),
           "grains": int(pk.n_grains), "C22": m["C22"], "C22_slab": m["C22_slab"],
           "C22_slab_fit_err": m["C22_slab_fit_err"], "phi3_star": m["phi3_star"],
           "phi3_star_slab": m["phi3_star_slab"], "phi3_star_cell": m["phi3_star_cell"],
           "c_l": m["c_l"], "c_l_slab": m["c_l_slab"],
           "c_l_cell_density": math.sqrt(m["C22"] / m["phi3_star_cell"]),
           "c_t": m["c_t"], "c_t_slab": m["c_t_slab"], "slab": m["slab"],
           "wall_s": {"prepare": round(t1 - t0, 2), "moduli": round(t2 - t1, 2)}}
    if args.profile:
        row["profile"] = profile(pk, args.profile)
    system = linearize(pk)
    if system.n_dof <= args.modes_max_dof:
        modes = longitudinal_modes(system, pk, n_max=3)
        row["c_modes"] = [float(c) for c in mode_speeds(modes, m["C22"], m["C22_slab"])]
        row["mode_overlap"] = modes["overlap"]
        row["wall_s"]["modes"] = round(time.perf_counter() - t2, 2)
    return row


def profile(pk, width: float) -> list[dict]:
    """C22 and Phi3* of slabs ``width`` thick at depths d0 = 0, width/2, ... from each wall (the
    two walls' slabs of one depth averaged): how far the walls' influence reaches."""
    from granwave.linear.moduli import _cell, global_response, slab_density, slab_response

    cell = _cell(pk, False)
    C, _ = global_response(cell)
    H = float(pk.box[-1])
    out = []
    for d0 in np.arange(0.0, H / 2 - width + 1e-9, width / 2):
        c22, phi = [], []
        for lo, hi in ((d0, d0 + width), (H - d0 - width, H - d0)):
            c22.append(slab_response(cell, C, lo, hi)["C22"][0])
            phi.append(slab_density(cell, lo, hi))
        out.append({"depth": float(d0), "C22": float(np.mean(c22)), "phi3_star": float(np.mean(phi))})
    return out


def _mean(rows, key, index=None):
    v = np.array([r[key] if index is None else r[key][index] for r in rows if key in r], float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return math.nan, math.nan, 0
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else math.nan, v.size


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heights", type=float, nargs="+", default=[10, 20, 40])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--width", type=float, default=25.0)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--friction", type=float, default=0.5)
    ap.add_argument("--layer", type=float, default=3.0)
    ap.add_argument("--compaction", default="mean-flow", choices=("fixed", "height-scaled", "mean-flow"))
    ap.add_argument("--modes-max-dof", type=int, default=4000)
    ap.add_argument("--profile", type=float, default=0.0,
                    help="also C22 and Phi3* of slabs this thick (d) at each depth from the walls")
    ap.add_argument("--record", action="store_true")
    ap.add_argument("--notes", default=None)
    args = ap.parse_args()
    rows = []
    for h in args.heights:
        for s in range(1, args.seeds + 1):
            rows.append(column(h, s, args))
            r = rows[-1]
            print(f"h {h:g} seed {s}: H {r['height']:.2f} c_l {r['c_l']:.4f} c_l_slab {r['c_l_slab']:.4f} "
                  f"(fit {r['C22_slab_fit_err']:.3f}) c_l_cell_density {r['c_l_cell_density']:.4f} "
                  f"modes {np.round(r.get('c_modes', []), 4)} wall {r['wall_s']}", flush=True)
    table = []
    print(f"{'L':>6} {'n':>3} {'c_l':>16} {'c_l_slab':>16} {'c_l cell dens.':>16} {'modes n=1..3 mean':>18}")
    for h in args.heights:
        sub = [r for r in rows if r["height_nominal"] == h]
        line = {"height": h, "n": len(sub)}
        for key in ("c_l", "c_l_slab", "c_l_cell_density"):
            line[key], line[key + "_sem"], _ = _mean(sub, key)
        for r in sub:
            if "c_modes" in r:
                r["c_modes_mean"] = float(np.mean(r["c_modes"]))
        line["c_modes"], line["c_modes_sem"], line["n_modes"] = _mean(sub, "c_modes_mean")
        table.append(line)
        f = lambda k: f"{line[k]:.4f} ± {line[k + '_sem']:.4f}"  # noqa: E731
        print(f"{h:6g} {len(sub):3d} {f('c_l'):>16} {f('c_l_slab'):>16} {f('c_l_cell_density'):>16} "
              f"{f('c_modes'):>18}")
    if args.profile:
        depths = sorted({p["depth"] for r in rows for p in r.get("profile", [])})
        print(f"profile ({args.profile:g} d slabs, mean over the columns of each height): depth  C22  Phi3*")
        for h in args.heights:
            sub = [r for r in rows if r["height_nominal"] == h]
            for d in depths:
                v = np.array([[p["C22"], p["phi3_star"]] for r in sub for p in r["profile"] if p["depth"] == d])
                if len(v):
                    sem = v[:, 0].std(ddof=1) / math.sqrt(len(v)) if len(v) > 1 else math.nan
                    print(f"  L {h:g} depth {d:5.1f}: C22 {v[:, 0].mean():.5f} ± {sem:.5f}  "
                          f"Phi3* {v[:, 1].mean():.4f}")
    if args.record:
        from granwave.provenance import git_revision

        summary = {f"L={t['height']:g}": {"values": f"c_l {t['c_l']:.4f}, c_l_slab {t['c_l_slab']:.4f}, "
                                                    f"modes {t['c_modes']:.4f} (n={t['n']})"}
                   for t in table}
        summary["compaction"] = args.compaction
        rec = {"date": time.strftime("%Y-%m-%d"), "benchmark": "bulk_slab_heights",
               "command": "PYTHONPATH=. python benchmarks/bulk_slab_heights.py "
                          + " ".join(f"--{k.replace('_', '-')} {' '.join(map(str, v)) if isinstance(v, list) else v}"
                                     for k, v in vars(args).items() if k not in ("record", "notes")),
               "git_revision": git_revision(), "machine": {"cpu": platform.processor() or platform.machine()},
               "summary": summary, "result": {"table": table, "columns": rows}}
        if args.notes:
            rec["notes"] = args.notes
        with OUT.open("a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(f"appended to {OUT}")


if __name__ == "__main__":
    main()
