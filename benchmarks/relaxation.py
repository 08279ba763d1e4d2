"""Steps a preparation needs to converge against the column height, old and new compaction (a script).

    python benchmarks/relaxation.py [--width 25] [--heights 25 50 100 200 400]
        [--pressures 1e-4 1e-7] [--seeds 1] [--old-max-height 200]
        [--results benchmarks/results/ensembles/relaxation.jsonl] [--table-only] [--write-docs]

For each pressure, height L and seed, prepares a 2D frictional packing (the
defaults of PrepareParams: mu = 0.5, polydispersity 0.2, zeta 0.5, b 0.3) of
width ``--width`` and expected height L (N = 0.82 W L / mean grain area
grains, aspect L / W) with the compaction 'fixed' (the protocol before: b at
every height) and 'height-scaled' (b divided by L / reference_height above
25 d), and records the steps to convergence (load independent, unlike
seconds) and the bulk statistics of the packing (layer 3 d). 'mean-flow' runs
with ``mean_flow_settling='compaction'``, the setting its records were made with;
'late' is the compaction 'mean-flow' with ``mean_flow_settling='late'``, the
default of granwave since 2026-11-26 (benchmarks/settling.py compares the
settling rules seed by seed). 'fixed' is
skipped above ``--old-max-height`` (its cost grows fastest); its steps
where it was not prepared are extrapolated from its fitted exponent and
marked "(…, fit)".

Fit: log(steps) = a + k log(L) by least squares over the heights measured,
k with its 95 % interval (Student t, n - 2 degrees of freedom). Every
finished preparation appends one JSON line to ``--results``; a rerun skips
what is there. ``--write-docs`` regenerates the block of benchmarks/results/TABLES.md between
``<!-- relaxation:begin -->`` and ``<!-- relaxation:end -->``. Run with
NUMBA_NUM_THREADS=1 (set by default) so that numbers are per core.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- relaxation:begin -->", "<!-- relaxation:end -->"
#: rules of the table: the three compactions (mean-flow with the settling of its first records,
#: 'compaction'), and 'late' = compaction mean-flow with late settling (granwave's default)
RULES = ("fixed", "height-scaled", "mean-flow", "late")
#: (compaction, mean_flow_settling) of each rule
RULE_SETTINGS = {"fixed": ("fixed", "compaction"), "height-scaled": ("height-scaled", "compaction"),
                 "mean-flow": ("mean-flow", "compaction"), "late": ("mean-flow", "late")}
#: mean_flow_slab of the records of rules other than mean-flow, and of mean-flow records made before
DEFAULT_SLAB = 4.0
STATS = [("phi2", "Φ2"), ("z_star", "z*"), ("rattler_fraction", "f0")]


def grains_for(width: float, height: float, polydispersity: float = 0.2) -> int:
    """Grains that fill width x height (d) at the expected solid fraction (2D)."""
    from granwave.geometry import EXPECTED_SOLID_FRACTION_2D

    mean_area = math.pi / 4.0 * (1.0 + polydispersity**2 / 3.0)  # E[d^2] for d uniform in [1-W, 1+W]
    return int(round(EXPECTED_SOLID_FRACTION_2D * width * height / mean_area))


def rule_of(record: dict) -> str:
    """The table's rule of a record (records before 'late' have no settling entry)."""
    return "late" if record.get("settling") == "late" else record["compaction"]


def measure(rule: str, pressure: float, height: float, width: float, seed: int,
            slab: float = DEFAULT_SLAB) -> dict:
    """Prepare one column under ``rule`` (:data:`RULE_SETTINGS`) and return its record (steps,
    sizes, bulk statistics)."""
    from granwave.analysis.statics import statics
    from granwave.dem.protocol import prepare_packing
    from granwave.params import PrepareParams

    n = grains_for(width, height)
    compaction, settling = RULE_SETTINGS[rule]
    params = PrepareParams(dim=2, grains=n, pressure=pressure, aspect=height / width, seed=seed,
                           compaction=compaction, max_steps=50_000_000, mean_flow_slab=slab,
                           mean_flow_settling=settling)
    t0 = time.process_time()
    packing = prepare_packing(params)
    cpu = time.process_time() - t0
    s = statics(packing, layer=3.0)
    extra = dict(slab=slab) if compaction == "mean-flow" else {}
    if rule == "late":
        extra["settling"] = settling
    prof = depth_profile(packing) if compaction == "mean-flow" and height >= 200 else {}
    return dict(compaction=compaction, pressure=pressure, height=height, width=width, seed=seed, grains=n, **extra,
                steps=int(packing.attrs["steps"]), final_height=float(packing.height),
                gamma=float(packing.attrs["background_damping_rate"]),
                residual=float(packing.attrs["max_acceleration"]), cpu_s=cpu,
                **{k: float(s[k]) for k in ("phi2", "z_star", "rattler_fraction", "F2", "mean_force_over_p",
                                            "stress_ratio")}, **prof)


def depth_profile(packing, step: float = 25.0) -> dict:
    """Phi2 of horizontal bands ``step`` d thick from the bottom wall (the top band shorter):
    the grains whose centre is in the band, their area over the band's (no layer removed)."""
    import numpy as np

    z = packing.position[:, -1]
    area = np.pi * packing.radius**2
    h = float(packing.height)
    lateral = float(np.prod(packing.box[:-1]))
    edges = np.append(np.arange(0.0, h, step), h)
    phi = [float(area[(z >= lo) & (z < hi)].sum() / (lateral * (hi - lo))) for lo, hi in zip(edges[:-1], edges[1:])]
    return dict(profile_edges=[float(e) for e in edges], profile_phi=phi)


def load(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def fit(heights, steps) -> tuple[float, float, float, float] | None:
    """(k, lo, hi, a): exponent of steps ~ L^k, its 95 % interval, log prefactor; None below 2 heights."""
    from scipy import stats

    h, s = np.log(np.asarray(heights, float)), np.log(np.asarray(steps, float))
    if len(np.unique(h)) < 2:
        return None
    r = stats.linregress(h, s)
    dof = len(h) - 2
    half = stats.t.ppf(0.975, dof) * r.stderr if dof > 0 else float("nan")
    return float(r.slope), float(r.slope - half), float(r.slope + half), float(r.intercept)


def _mean_se(values) -> str:
    """Mean (± standard error over more than one value) with four decimals; — for none."""
    if not values:
        return "—"
    if len(values) == 1:
        return f"{values[0]:.4f}"
    return f"{np.mean(values):.4f} ± {np.std(values, ddof=1) / math.sqrt(len(values)):.4f}"


def _rows(records, p, c, h=None, slab=DEFAULT_SLAB):
    """Records of rule ``c`` at pressure ``p`` (and height ``h``); mean-flow at slab ``slab`` only."""
    return [r for r in records if r["pressure"] == p and rule_of(r) == c
            and (h is None or r["height"] == h) and r.get("slab", DEFAULT_SLAB) == slab]


def report(records: list[dict], heights, pressures, old_max: float) -> str:
    lines = []
    fits = {}
    for p in pressures:
        for c in RULES:
            rows = [r for r in _rows(records, p, c) if r["height"] in heights]
            fits[p, c] = fit([r["height"] for r in rows], [r["steps"] for r in rows])
    lines.append("| p | L (d) | grains | seeds fixed / scaled / mean-flow / late | steps, fixed "
                 "| steps, height-scaled | steps, mean-flow | steps, late (default) | fixed / mean-flow |")
    lines.append("|" + "---|" * 9)
    stat_lines = ["| p | L (d) | " + " | ".join(f"{label} fixed / scaled / mean-flow / late" for _, label in STATS)
                  + " |",
                  "|" + "---|" * (2 + len(STATS))]
    for p in pressures:
        for h in heights:
            cell = {c: _rows(records, p, c, h) for c in RULES}
            if not any(cell.values()):
                continue
            n = next(rows for rows in cell.values() if rows)[0]["grains"]
            steps = {}
            txt = {}
            for c in RULES:
                if cell[c]:
                    steps[c] = float(np.mean([r["steps"] for r in cell[c]]))
                    txt[c] = f"{steps[c]:,.0f}"
                elif c == "fixed" and fits[p, c] is not None:  # not prepared (above --old-max-height)
                    k, _, _, a = fits[p, c]
                    steps[c] = math.exp(a + k * math.log(h))
                    txt[c] = f"({steps[c]:,.0f}, fit)"
                else:
                    steps[c], txt[c] = float("nan"), "—"
            ratio = steps["fixed"] / steps["mean-flow"]
            ratio_txt = f"{ratio:.2f}" if math.isfinite(ratio) else "—"
            seeds = " / ".join(str(len(cell[c])) for c in RULES)
            lines.append(f"| {p:g} | {h:g} | {n} | {seeds} | " + " | ".join(txt[c] for c in RULES)
                         + f" | {ratio_txt} |")
            st = [" / ".join(_mean_se([r[key] for r in cell[c]]) for c in RULES) for key, _ in STATS]
            stat_lines.append(f"| {p:g} | {h:g} | " + " | ".join(st) + " |")
    lines.append("")
    lines.append("Bulk statistics (layer 3 d; mean ± standard error where more than one seed):")
    lines.append("")
    lines.extend(stat_lines)
    lines.append("")
    lines.append("Fitted exponent k of steps ∝ L^k (least squares in log-log over the measured heights, "
                 "95 % interval):")
    lines.append("")
    for p in pressures:
        for c in RULES:
            f = fits[p, c]
            hs = sorted({r["height"] for r in _rows(records, p, c) if r["height"] in heights})
            if f is None:
                lines.append(f"- p = {p:g}, {c}: fewer than two heights measured")
                continue
            k, lo, hi, _ = f
            ci = f" [{lo:.2f}, {hi:.2f}]" if math.isfinite(lo) else " (two heights: no interval)"
            lines.append(f"- p = {p:g}, {c}: k = {k:.2f}{ci} over L = {', '.join(f'{h:g}' for h in hs)}")
    other = sorted({(r["pressure"], r["height"]) for r in records
                    if rule_of(r) == "mean-flow" and r.get("slab", DEFAULT_SLAB) != DEFAULT_SLAB})
    if other:
        lines.append("")
        lines.append(f"Slab thickness of the mean flow (mean-flow; the table: {DEFAULT_SLAB:g} d), the same seeds:")
        lines.append("")
        for p, h in other:
            mf = [r for r in records if rule_of(r) == "mean-flow" and r["pressure"] == p and r["height"] == h]
            slabs = sorted({r.get("slab", DEFAULT_SLAB) for r in mf})
            seeds = {r["seed"] for r in mf if r.get("slab", DEFAULT_SLAB) != DEFAULT_SLAB}
            for sl in slabs:
                rows = sorted((r for r in _rows(records, p, "mean-flow", h, sl) if r["seed"] in seeds),
                              key=lambda r: r["seed"])
                steps = ", ".join(f"{r['steps']:,}" for r in rows)
                stats = "; ".join(f"{label} " + ", ".join(f"{r[key]:.4f}" for r in rows) for key, label in STATS)
                lines.append(f"- p = {p:g}, L = {h:g}, slab {sl:g} d, seeds "
                             f"{', '.join(str(r['seed']) for r in rows)}: steps {steps}; {stats}")
    profiles = [r for r in records if "profile_phi" in r and r.get("slab", DEFAULT_SLAB) == DEFAULT_SLAB]
    if profiles:
        lines.append("")
        lines.append("Depth profile of Φ2 (mean-flow and late; bands from the bottom wall, grains by centre, "
                     "walls included):")
        lines.append("")
        for r in sorted(profiles, key=lambda r: (rule_of(r) == "late", -r["pressure"], r["height"])):
            e = r["profile_edges"]
            bands = ", ".join(f"{lo:g}–{hi:.0f} d {phi:.4f}" for lo, hi, phi in zip(e[:-1], e[1:], r["profile_phi"]))
            lines.append(f"- {rule_of(r)}, p = {r['pressure']:g}, L = {r['height']:g}, seed {r['seed']}: {bands}")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=float, default=25.0)
    ap.add_argument("--heights", type=float, nargs="+", default=[25, 50, 100, 200, 400])
    ap.add_argument("--pressures", type=float, nargs="+", default=[1e-4, 1e-7])
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first-seed .. first-seed + seeds - 1")
    ap.add_argument("--old-max-height", type=float, default=200.0,
                    help="largest height prepared with the 'fixed' compaction (default 200)")
    ap.add_argument("--only", choices=RULES, help="prepare only this rule (late: mean-flow with late settling)")
    ap.add_argument("--slab", type=float, default=DEFAULT_SLAB,
                    help="mean_flow_slab of the 'mean-flow' rule (d); the table shows the default's")
    ap.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results" / "ensembles" / "relaxation.jsonl")
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--write-docs", action="store_true")
    a = ap.parse_args(argv)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    done = {(rule_of(r), r["pressure"], r["height"], r["seed"]) for r in load(a.results)
            if r["width"] == a.width and r.get("slab", DEFAULT_SLAB) == a.slab}
    tasks = [(c, p, h, s) for c in RULES for p in a.pressures for h in a.heights for s in range(a.first_seed, a.first_seed + a.seeds)
             if (c, p, h, s) not in done and not (c == "fixed" and h > a.old_max_height)
             and (a.only is None or c == a.only)]
    # cheapest first (grain-steps ~ N L^k p^(-1/3)), so that a stopped run leaves the small heights
    tasks.sort(key=lambda t: t[2] ** (2.4 if t[0] == "fixed" else 2.0) * t[1] ** (-1.0 / 3.0))
    if a.slab != DEFAULT_SLAB:
        tasks = [t for t in tasks if RULE_SETTINGS[t[0]][0] == "mean-flow"]
    if not a.table_only:
        for c, p, h, s in tasks:
            rec = measure(c, p, h, a.width, s, a.slab)
            with open(a.results, "a") as fh:
                fh.write(json.dumps(rec) + "\n")
            print(f"{c} p={p:g} L={h:g} seed={s}: {rec['steps']} steps ({rec['grains']} grains, "
                  f"{rec['cpu_s']:.0f} s cpu)", flush=True)
    records = [r for r in load(a.results) if r["width"] == a.width]
    text = (f"Width {a.width:g} d, 2D, μ = 0.5, polydispersity 0.2; mean steps over the seeds prepared "
            f"(each seed one point of the fit); 'fixed' prepared up to L = {a.old_max_height:g}:\n\n"
            + report(records, sorted(a.heights), a.pressures, a.old_max_height))
    print(text)
    if a.write_docs:
        from granwave.io.files import replace_marked_block

        replace_marked_block(ROOT / "benchmarks" / "results" / "TABLES.md", BEGIN, END, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
