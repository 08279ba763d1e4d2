"""How the packing statistics move with each preparation-protocol parameter (a script, not a test).

    python benchmarks/protocol_sensitivity.py [--seeds 10] [--grains 600] [--workers 1]
        [--results benchmarks/results/ensembles/protocol_sensitivity.jsonl] [--table-only] [--write-docs]

For the default 2D frictional protocol (granwave.dem.params.PrepareParams) and
for each protocol knob moved one at a time (contact damping zeta, background
damping b, piston mass M, initial gas density, the compaction rule; 'mean-flow' with a
reference height of 5 d, so that it acts on 600 grains), prepares
``--seeds`` packings of ``--grains`` grains at p = 1e-4 and p = 1e-7 (seeds
0..seeds-1, the same seeds for every setting; ``--settings`` restricts the
settings prepared), and measures per packing (docs/method.md §4, §6): Phi2, z*,
f0 (rattler fraction), <N>/p (mean normal force) and F2 (fabric) of the bulk
(layer 3 d excluded next to each wall), sigma1/sigma2 of the whole cell, the
global moduli C22 and C33 (linear model without prestress) in units of E*, and
a digest of the packing's arrays (equal digests: identical packings).

Every finished packing appends one JSON line to ``--results`` (a rerun skips
the (setting, pressure, seed) triples already there, so the script can be
stopped and resumed). The tables (mean +- standard error of the mean over the
seeds, the ensemble size n per row; each setting's shift from the default in
combined standard errors) are printed, and with ``--write-docs`` they
replace the part of benchmarks/results/TABLES.md between the markers
``<!-- protocol-sensitivity:begin -->`` and ``<!-- protocol-sensitivity:end -->``.
Order: every setting at p = 1e-4 first (seed-major), then p = 1e-7 seed-major,
the settings of ``FIRST_AT_LOW_P`` before the others, so that a stopped run
leaves the settings of one group with about the same number of seeds.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import sys
import time
from pathlib import Path

import numpy as np

PRESSURES = (1e-4, 1e-7)
#: (name, label, PrepareParams overrides); "piston_mass_factor" multiplies the default
#: piston mass (one layer of grains: mean grain mass x L1), computed per seed.
SETTINGS = [
    ("default", "default (ζ 0.5, b 0.3, M = 1 layer, gas 0.50, compaction fixed)", {}),
    ("scaled", "compaction 'height-scaled'", {"compaction": "height-scaled"}),
    ("meanflow5", "compaction 'mean-flow', reference height 5 d",
     {"compaction": "mean-flow", "reference_height": 5.0}),
    ("zeta0.1", "contact damping ζ = 0.1", {"damping": 0.1}),
    ("zeta0.9", "contact damping ζ = 0.9", {"damping": 0.9}),
    ("b0.1", "background damping b = 0.1", {"background_damping": 0.1}),
    ("b1", "background damping b = 1", {"background_damping": 1.0}),
    ("M0.1", "piston mass M = 0.1 layer", {"piston_mass_factor": 0.1}),
    ("M10", "piston mass M = 10 layers", {"piston_mass_factor": 10.0}),
    ("gas0.3", "initial gas density 0.30", {"gas_density": 0.30}),
    ("gas0.58", "initial gas density 0.58", {"gas_density": 0.58}),
]
#: settings prepared first at the low pressure (default and the larger move of each knob)
FIRST_AT_LOW_P = ("default", "zeta0.1", "b0.1", "b1", "M10", "gas0.3")
QUANTITIES = [("phi2", "Φ2"), ("z_star", "z*"), ("rattler_fraction", "f0"),
              ("mean_force_over_p", "⟨N⟩/p"), ("F2", "F2"), ("stress_ratio", "σ1/σ2"),
              ("C22_over_p", "C22/p^(1/3)"), ("C33_over_p", "C33/p^(1/3)"), ("steps", "steps")]
ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- protocol-sensitivity:begin -->", "<!-- protocol-sensitivity:end -->"


def default_piston_mass(grains: int, seed: int, polydispersity: float) -> float:
    """The protocol's default piston mass for this seed (mean grain mass x L1, 2D)."""
    from granwave.geometry import grain_mass, lateral_size

    rng = np.random.default_rng(seed)  # the same first draw as prepare_packing
    diameter = rng.uniform(1.0 - polydispersity, 1.0 + polydispersity, size=grains)
    radius = 0.5 * diameter
    return float(grain_mass(radius).mean()) * lateral_size(radius, 2, 1.0)


def measure(task: tuple) -> dict:
    """Prepare one packing and measure it; returns one result record."""
    name, overrides, pressure, seed, grains = task
    from granwave.analysis.statics import statics
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing
    from granwave.errors import ConvergenceError
    from granwave.linear.moduli import moduli

    kw = dict(overrides)
    factor = kw.pop("piston_mass_factor", None)
    base = PrepareParams(dim=2, grains=grains, pressure=pressure, seed=seed)
    if factor is not None:
        kw["piston_mass"] = factor * default_piston_mass(grains, seed, base.polydispersity)
    params = PrepareParams(dim=2, grains=grains, pressure=pressure, seed=seed, **kw)
    record = dict(setting=name, pressure=pressure, seed=seed, grains=grains)
    t0 = time.process_time()
    try:
        packing = prepare_packing(params)
    except ConvergenceError as exc:
        record.update(ok=False, error=str(exc), cpu_s=time.process_time() - t0)
        return record
    s = statics(packing, layer=3.0)
    m = moduli(packing)
    record.update(ok=True, phi2=s["phi2"], z_star=s["z_star"], rattler_fraction=s["rattler_fraction"],
                  mean_force_over_p=s["mean_force_over_p"], F2=s["F2"],
                  stress_ratio=s["stress_ratio"], C22=float(m["C22"]),
                  C22_over_p=float(m["C22"]) / pressure ** (1.0 / 3.0), C33=float(m["C33"]),
                  C33_over_p=float(m["C33"]) / pressure ** (1.0 / 3.0), steps=int(packing.attrs["steps"]),
                  digest=digest(packing), cpu_s=time.process_time() - t0)
    return record


def digest(packing) -> str:
    """sha256 of the packing's arrays (positions, radii, box, contacts): equal digests, equal packings."""
    import hashlib

    h = hashlib.sha256()
    c = packing.contacts
    for a in (packing.position, packing.radius, packing.box, c.i, c.j, c.normal, c.overlap, c.force_normal,
              c.force_tangential):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def load(path: Path) -> list[dict]:
    """The records of ``path``, the last one of each (setting, pressure, seed, grains) only (a record
    measured again, e.g. for quantities added later, replaces the earlier one)."""
    if not path.exists():
        return []
    last = {}
    for line in path.read_text().splitlines():
        if line.strip():
            r = json.loads(line)
            last[r["setting"], r["pressure"], r["seed"], r["grains"]] = r
    return list(last.values())


def complete(record: dict) -> bool:
    """A failed preparation, or one with every quantity of QUANTITIES measured."""
    return not record.get("ok") or all(key in record for key, _ in QUANTITIES)


def mean_se(values) -> tuple[float, float, int]:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], float)
    if len(v) == 0:
        return float("nan"), float("nan"), 0
    se = float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else float("nan")
    return float(v.mean()), se, len(v)


def _fmt(m: float, se: float) -> str:
    if not math.isfinite(m):
        return "—"
    if not math.isfinite(se) or se == 0:
        return f"{m:.4g}"
    digits = max(0, 1 - int(math.floor(math.log10(se))))  # two significant digits of the error
    return f"{m:.{digits}f} ± {se:.{digits}f}"


def table(records: list[dict], grains: int) -> str:
    """Markdown tables, one per pressure: mean ± standard error over the seeds."""
    lines = []
    for p in PRESSURES:
        lines.append(f"**p = {p:g} E\\*** ({grains} grains, 2D, μ = 0.5; mean ± standard error "
                     "over n seeds; failed: preparations that did not converge)")
        lines.append("")
        head = "| setting | n | failed | " + " | ".join(label for _, label in QUANTITIES) + " |"
        lines.append(head)
        lines.append("|" + "---|" * (3 + len(QUANTITIES)))
        for name, label, _ in SETTINGS:
            rows = [r for r in records if r["setting"] == name and r["pressure"] == p]
            ok = [r for r in rows if r.get("ok")]
            cells = [_fmt(*mean_se(r.get(key) for r in ok)[:2]) for key, _ in QUANTITIES]
            lines.append(f"| {label} | {len(ok)} | {len(rows) - len(ok)} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def shifts(records: list[dict]) -> str:
    """Markdown table of each setting's shift from the default: Δ = mean - default mean and
    its size in standard errors, z = Δ / sqrt(se² + se_default²); |z| >= 3 in bold."""
    lines = ["| setting | p | " + " | ".join(f"Δ{label} (z)" for _, label in QUANTITIES) + " |",
             "|" + "---|" * (2 + len(QUANTITIES))]
    for name, label, _ in SETTINGS[1:]:
        for p in PRESSURES:
            cells = []
            for key, _ in QUANTITIES:
                m, se, n = mean_se(r.get(key) for r in records
                                   if r["setting"] == name and r["pressure"] == p and r.get("ok"))
                m0, se0, n0 = mean_se(r.get(key) for r in records
                                      if r["setting"] == "default" and r["pressure"] == p and r.get("ok"))
                err = math.hypot(se, se0)
                if n < 2 or n0 < 2 or not err > 0:
                    cells.append("—")
                    continue
                z = (m - m0) / err
                cell = f"{m - m0:+.3g} ({z:+.1f})"
                cells.append(f"**{cell}**" if abs(z) >= 3 else cell)
            lines.append(f"| {label} | {p:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def spreads(records: list[dict]) -> str:
    """One line per pressure: the range (max - min) of the setting means of each quantity."""
    out = []
    for p in PRESSURES:
        parts = []
        for key, label in QUANTITIES:
            means = [mean_se(r.get(key) for r in records if r["setting"] == name and r["pressure"] == p
                             and r.get("ok"))[0] for name, _, _ in SETTINGS]
            means = [m for m in means if math.isfinite(m)]
            if means:
                parts.append(f"{label} {min(means):.4g} to {max(means):.4g}")
        out.append(f"- p = {p:g}: " + ", ".join(parts))
    return "Range of the setting means:\n\n" + "\n".join(out) + "\n"


def write_docs(text: str) -> None:
    from granwave.io.files import replace_marked_block

    replace_marked_block(ROOT / "benchmarks" / "results" / "TABLES.md", BEGIN, END, text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--grains", type=int, default=600)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results" / "ensembles" / "protocol_sensitivity.jsonl")
    ap.add_argument("--settings", nargs="+", choices=[name for name, _, _ in SETTINGS],
                    help="prepare only these settings (default: all)")
    ap.add_argument("--table-only", action="store_true", help="only tabulate the results file")
    ap.add_argument("--write-docs", action="store_true", help="write the table into benchmarks/results/TABLES.md")
    a = ap.parse_args(argv)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    done = {(r["setting"], r["pressure"], r["seed"]) for r in load(a.results)
            if r["grains"] == a.grains and complete(r)}
    # cheap pressure first (a p = 1e-7 packing costs about 6 times a 1e-4 one), then the
    # low pressure seed-major, the settings of FIRST_AT_LOW_P first, so that a run stopped
    # early leaves every setting with about the same number of seeds
    order = {name: k for k, name in enumerate(FIRST_AT_LOW_P)}
    tasks = [(name, over, p, seed, a.grains)
             for p in PRESSURES for seed in range(a.seeds)
             for name, _, over in sorted(SETTINGS, key=lambda s: order.get(s[0], len(order)))
             if (name, p, seed) not in done and (a.settings is None or name in a.settings)]
    tasks.sort(key=lambda t: (PRESSURES.index(t[2]), order.get(t[0], len(order)) >= len(order), t[3]))
    if not a.table_only and tasks:
        print(f"{len(tasks)} packings to prepare ({len(done)} already in {a.results})", flush=True)
        ctx = multiprocessing.get_context("spawn")
        with ctx.Pool(a.workers, maxtasksperchild=20) as pool:
            for k, rec in enumerate(pool.imap(measure, tasks), 1):
                with open(a.results, "a") as fh:
                    fh.write(json.dumps(rec) + "\n")
                state = "ok" if rec.get("ok") else "FAILED"
                print(f"[{k}/{len(tasks)}] {rec['setting']} p={rec['pressure']:g} seed={rec['seed']} "
                      f"{state} {rec['cpu_s']:.1f} s cpu", flush=True)
    records = [r for r in load(a.results) if r["grains"] == a.grains]
    cpu = sum(r.get("cpu_s", 0.0) for r in records)
    text = (table(records, a.grains) + f"\n{len(records)} preparations, {cpu / 60:.0f} min of CPU in all "
            "(preparation and measurement).\n\n**Shift from the default** (Δ = setting − default, z = Δ in "
            "combined standard errors; bold: |z| ≥ 3)\n\n" + shifts(records) + "\n\n"
            + spreads(records))
    print(text)
    if a.write_docs:
        write_docs(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
