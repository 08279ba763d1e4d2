"""Expected CPU time of a workflow config, extrapolated from the measured cost of a finished run.

Usage (after a run of the quick config, which writes results/timings/ and results/benchmarks/):
    python benchmarks/workflow_runtime.py --measured results --config config/paper.yaml
    python benchmarks/workflow_runtime.py --measured results --config slice.yaml --check slice/results

The last line reads `<name> config: <X> CPU-h, <Y> h on <cores> cores`.

Measured inputs (CPU seconds, not wall time: the machines these runs share drift):
- results/timings/batch_*.tsv: every sample's stages, timed inside its batch process
  (workflow/scripts/sample_batch.py), with grains, dofs and DEM steps;
- results/benchmarks/batch/*.tsv (Snakemake `benchmark:`, cpu_time): a batch's total, whose
  excess over its samples' stages is the start-up of one batch process;
- the signal and linear files: which method each signal used, its steps, nnz(D), omega_max;
- results/timings/analyses/*.tsv: the CPU seconds of each command of the jobs that run several
  commands in one process (a scene's height series, ensembles and sweep; the main study's
  figures; the main sample's spectrum, mode shapes, snapshot and nonlinear damping pulses; a
  continuum scene's analyses), per command kind (heights, ensemble, sweep, figure, damping, ...);
- here and now: the CPU time of one light `granwave` command (the start-up of every job that
  is not a batch; the gather, analysis and figure jobs that stay one process each).

Models fitted to them (classes: dimension x frictional or not):
- DEM preparation: cpu = k N x steps, steps = a L^g p^e S(tol). Relaxation steps grow with
  the container height L faster than the grain count does (g and e fitted, a per class);
  S(tol), steps against the convergence tolerance, is the packing-tolerance table of
  docs/tradeoffs.md (measured by benchmarks/tradeoffs.py), interpolated in log10(tol).
- linearize: cpu = c0 + c1 n + c3 n^3 up to 3000 dofs (its dense eigenvalue check),
  c0 + c1 n above (Lanczos), non-negative least squares.
- signal: time domain cpu = kt nnz(D) x steps, with steps = (samples - 1) x
  ceil(h omega_max / (2 safety)), omega_max = b p^s per class (fitted), nnz per grain per
  class; modal cpu = km n^3 (chains: the tridiagonal solver, km2 n^2); for `auto` scenes
  the cheaper of the two, as the workflow chooses.
- statics, moduli, front: power laws in N fitted per stage.

Continuum scenes (config/continuum.yaml) are costed as disordered packings with time-domain
signals at their own time_safety / samples / t_max_factor, global moduli (costed with the
fitted moduli model, which includes local moduli: an overestimate) and no statics. Their DEM
steps follow the tall-column law (steps = a_tall L^g_tall p^e, fitted to the packings of
L >= 30 d of the same class) extrapolated to the tallest columns: a prediction, not a
measurement. The time on N cores is at least the longest batch (one process, one core).
"""

from __future__ import annotations

import argparse
import csv
import math
import re
import resource
import statistics
import subprocess
import sys
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

import h5py
import numpy as np
import yaml
from scipy.optimize import nnls

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from granwave.workflow_support import crossing_time  # noqa: E402

DENSE_CHECK_MAX_DOF = 3000  # linearize's dense eigenvalue check (granwave linearize --help)
SCENE_DEFAULTS = {"dim": 2, "friction": 0.5, "width": 24, "polydispersity": 0.2, "poisson": 0.0,
                  "tol": 1e-10}  # the schema's defaults (workflow/schemas/config.schema.yaml)
TALL_FROM = 30.0  # heights (d) of the tall-column steps law
CONTINUUM_DEFAULTS = {**SCENE_DEFAULTS, "width": 25, "tol": 1e-8}  # the continuum section's


# ------------------------------------------------------------------ measured
def tolerance_steps() -> tuple[np.ndarray, np.ndarray]:
    """(log10 tol, DEM steps) of the packing-tolerance table of docs/tradeoffs.md."""
    text = (ROOT / "docs" / "tradeoffs.md").read_text()
    section = text.split("## 1. Packing tolerance", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:5] for line in section.splitlines() if re.match(r"\| \d", line)]
    tol, steps = np.array([[math.log10(float(r[0])), float(r[3])] for r in rows]).T
    return tol, steps


def steps_factor(tol: float) -> float:
    """S(tol): DEM steps to converge at tol, relative units (docs/tradeoffs.md table)."""
    x, y = tolerance_steps()
    order = np.argsort(x)
    return float(np.interp(math.log10(tol), x[order], y[order]))


def read_tsv(path: Path) -> list[dict]:
    with open(path) as f:
        return list(csv.DictReader(f, delimiter="\t"))


def bench_cpu(path: Path) -> float:
    row = read_tsv(path)[0]
    return float(row.get("cpu_time") or 0.0) or float(row["s"])


def kind_of(scene: str, results: Path) -> str:
    """disordered, lattices or chains: a continuum column is a disordered packing (same DEM and
    signal models; its tall heights extend the fit of the DEM steps against L)."""
    with h5py.File(next((results / "packing" / scene).rglob("*.h5"))) as f:
        kind = f.attrs.get("kind", "")
    kind = kind.decode() if isinstance(kind, bytes) else str(kind)
    return {"lattice": "lattices", "chain": "chains"}.get(kind, "disordered")


def sample_rows(results: Path) -> list[dict]:
    """One dict per measured sample: its stages' CPU seconds and sizes."""
    samples = {}
    for tsv in sorted((results / "timings").glob("*.tsv")):
        for r in read_tsv(tsv):
            key = (r["scene"], r["pressure"], r["size"], r["seed"])
            s = samples.setdefault(key, {"scene": r["scene"], "pressure": float(r["pressure"]),
                                         "size": r["size"], "seed": int(r["seed"]),
                                         "N": int(r["n_grains"]), "n": int(r["n_dof"]),
                                         "steps": int(r["steps"]), "batch": (str(results), tsv.stem),
                                         "p_label": r["pressure"]})
            s[r["stage"]] = float(r["cpu_s"])
    kinds = {}
    for s in samples.values():
        if s["scene"] not in kinds:
            kinds[s["scene"]] = kind_of(s["scene"], results)
        s["kind"] = kinds[s["scene"]]
        tail = f"{s['scene']}/p{s['p_label']}/{s['size']}/s{s['seed']}.h5"
        with h5py.File(results / "linear" / tail) as f:
            s["nnz"] = int(f["matrix/data"].shape[0]) if "matrix/data" in f else None
            s["omega_max"] = math.sqrt(float(f.attrs.get("omega2_max", float("nan"))))
            s["dim"] = int(f.attrs.get("dim", 2))
            s["frictional"] = float(f.attrs.get("friction", 0.0)) > 0
        with h5py.File(results / "packing" / tail) as f:
            s["tol"] = float(f.attrs.get("tol", 1e-10))
        with h5py.File(results / "signal" / tail) as f:
            method = f.attrs["method"]
            s["method"] = method.decode() if isinstance(method, bytes) else str(method)
            s["signal_steps"] = int(f.attrs.get("n_steps", 0))
    return list(samples.values())


def cls(kind: str, dim: int, frictional: bool) -> str:
    return f"{kind}/{dim}D/{'frictional' if frictional else 'frictionless'}"


def fit_models(folders: list[Path]) -> dict:
    """The cost models, fitted to the samples of one or more finished runs' results folders."""
    rows = [s for results in folders for s in sample_rows(results)]
    if not rows:
        sys.exit(f"{', '.join(map(str, folders))}: no batch timings (run the workflow first)")
    m = {"classes": {}}
    for s in rows:
        s["class"] = cls(s["kind"], s["dim"], s["frictional"])
        s["H"] = float(s["size"][1:])
    # DEM preparation: steps = a_class L^g p^e (least squares in logs), cpu = k_class N steps
    dem = [s for s in rows if s["kind"] == "disordered" and s["steps"] > 0]
    names = sorted({s["class"] for s in dem})
    X = np.array([[math.log(s["H"]), math.log(s["pressure"])] + [s["class"] == c for c in names]
                  for s in dem], float)
    coef = np.linalg.lstsq(X, np.log([s["steps"] / steps_factor(s["tol"]) for s in dem]), rcond=None)[0]
    m["steps_g"], m["steps_e"] = coef[:2]
    for c, a in zip(names, coef[2:]):
        m["classes"].setdefault(c, {})["steps_a"] = math.exp(a)
        m["classes"][c]["k_step"] = statistics.median(s["packing"] / (s["N"] * s["steps"])
                                                      for s in dem if s["class"] == c)
    # Tall columns: the steps grow faster with L at the tall end than the all-height law says
    # (measured: x3 from 32 to 64 d, x2.1 from 64 to 100 d at p = 1e-4). Per class with at
    # least three packings at L >= TALL_FROM over two heights, steps = a_tall L^g_tall p^e_tall
    # (e_tall fitted where the tall packings span two pressures, else e from above: the short
    # samples' e underpredicted tall columns at p = 1e-6 sevenfold); continuum scenes use it.
    for c in names:
        tall = [s for s in dem if s["class"] == c and s["H"] >= TALL_FROM]
        if len(tall) >= 3 and len({s["H"] for s in tall}) >= 2:
            y = np.log([s["steps"] / steps_factor(s["tol"]) for s in tall])
            log_h, log_p = np.log([s["H"] for s in tall]), np.log([s["pressure"] for s in tall])
            if len({s["pressure"] for s in tall}) >= 2:
                a, g, e = np.linalg.lstsq(np.column_stack([np.ones_like(log_h), log_h, log_p]), y,
                                          rcond=None)[0]
            else:
                e = m["steps_e"]
                g, a = np.polyfit(log_h, y - e * log_p, 1)
            m["classes"][c].update(steps_g_tall=float(g), steps_a_tall=math.exp(a), steps_e_tall=float(e))
    for kind in ("lattices", "chains"):
        made = [s["packing"] / s["N"] for s in rows if s["kind"] == kind]
        if made:
            m[f"make_{kind}"] = statistics.median(made)
    # linearize: nnls on [1, n, n^3 (dense check only)]
    A = np.array([[1.0, s["n"], s["n"] ** 3 if s["n"] <= DENSE_CHECK_MAX_DOF else 0.0] for s in rows])
    m["linear"] = tuple(nnls(A, np.array([s["linear"] for s in rows]))[0])
    # signals
    timed = [s for s in rows if s["method"] == "time" and s["signal_steps"] and s["nnz"]]
    if timed:
        m["kt"] = statistics.median(s["signal"] / (s["nnz"] * s["signal_steps"]) for s in timed)
    modal = [s for s in rows if s["method"] == "modal" and s["kind"] != "chains"]
    if modal:
        m["km"] = statistics.median(s["signal"] / s["n"] ** 3 for s in modal)
    chains = [s for s in rows if s["method"] == "modal" and s["kind"] == "chains"]
    if chains:
        m["km2"] = statistics.median(s["signal"] / s["n"] ** 2 for s in chains)
    for c in {s["class"] for s in rows}:
        mine = [s for s in rows if s["class"] == c]
        d = m["classes"].setdefault(c, {})
        d["dof_per_grain"] = statistics.median(s["n"] / s["N"] for s in mine)
        d["nnz_per_grain"] = statistics.median(s["nnz"] / s["N"] for s in mine if s["nnz"])
        ok = [s for s in mine if math.isfinite(s["omega_max"])]
        if len({s["pressure"] for s in ok}) >= 2:
            b = np.polyfit(np.log([s["pressure"] for s in ok]), np.log([s["omega_max"] for s in ok]), 1)
            d["omega_s"], d["omega_b"] = float(b[0]), math.exp(b[1])
        elif ok:  # one pressure: omega_max ~ k^(1/2) ~ p^(1/6) (Hertz)
            d["omega_s"] = 1 / 6
            d["omega_b"] = statistics.median(s["omega_max"] / s["pressure"] ** (1 / 6) for s in ok)
    # statics, moduli, front: log cpu = a + b log N
    for stage in ("statics", "moduli", "front"):
        pts = [(s["N"], s[stage]) for s in rows if stage in s and s[stage] > 0]
        if len(pts) >= 2:
            b, a = np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)
            m[stage] = (math.exp(a), b)
    # start-up of a batch process: its Snakemake total minus its samples' stages
    stages = defaultdict(float)
    for s in rows:
        stages[s["batch"]] += sum(s.get(k, 0.0) for k in ("packing", "linear", "signal", "statics",
                                                          "moduli", "front"))
    over = [bench_cpu(t) - stages[str(results), t.stem] for results in folders
            for t in (results / "benchmarks" / "batch").glob("*.tsv") if (str(results), t.stem) in stages]
    m["batch_overhead"] = max(0.0, statistics.median(over)) if over else 0.0
    # commands run together in one job (analyses_<scene>, figures_study, sample_extras,
    # continuum_<scene>): median CPU per kind
    commands = defaultdict(list)
    for tsv in sorted(t for results in folders for t in (results / "timings" / "analyses").glob("*.tsv")):
        for r in read_tsv(tsv):
            commands[r["stage"]].append(float(r["cpu_s"]))
    m["command"] = {stage: statistics.median(v) for stage, v in commands.items()}
    m["n_measured"] = len(rows)
    return m


def command_kinds(outputs: list[str]) -> list[str]:
    """The kinds of the commands a multi-command job runs, one per command, from its outputs."""
    kinds = []
    for path in outputs:
        if "/timings/" in path:
            continue
        if path.endswith(".png"):
            kinds.append("figure")
        elif "/damping/zeta" in path:
            kinds.append("damping")
        elif path.endswith("/damping/table.json"):
            kinds.append("damping_table")
        elif "/modes/" in path or "/modes_vectors/" in path:
            kinds.append("eigensolve")
        elif "/spectrum/" in path:
            kinds.append("spectrum")
        elif "/snapshots/" in path:
            kinds.append("snapshot")
        elif "/continuum/" in path:
            kinds.append("attenuation" if path.endswith("attenuation.json") else "continuum")
        elif "/heights/" in path:
            kinds.append("heights")
        elif path.endswith(".h5") and "/ensemble/" in path:
            kinds.append("ensemble")
        elif path.endswith(".h5") and "/sweep/" in path:
            kinds.append("sweep")
    return kinds


def light_job_cpu() -> float:
    """CPU seconds of one light `granwave` command (interpreter, imports, one small file)."""
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(3):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run([sys.executable, "-m", "granwave", "chain", "--balls", "10", "--pressure", "1e-4",
                            "-o", f"{tmp}/c{i}.h5"], check=True, capture_output=True,
                           env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            times.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return statistics.median(times)


# ------------------------------------------------------------------ planned
def planned_jobs(config: Path) -> list[dict]:
    """Jobs of a config from `snakemake -n` (rule name and output files)."""
    with tempfile.TemporaryDirectory() as tmp:
        run = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
                              "-n", "--configfile", str(config.resolve()), "--config", "results=results"],
                             cwd=tmp, capture_output=True, text=True,
                             env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})
    if run.returncode:
        sys.exit(run.stderr.strip().splitlines()[-1] if run.stderr.strip() else "snakemake -n failed")
    jobs, cur = [], None
    for line in run.stdout.splitlines():
        mt = re.match(r"^(?:local)?rule (\w+):", line)
        if mt:
            cur = {"rule": mt.group(1), "output": []}
            jobs.append(cur)
        elif cur is not None and line.strip().startswith("output:"):
            cur["output"] = [p.strip() for p in line.split(":", 1)[1].split(",")]
    return jobs


def load_config(path: Path) -> dict:
    cfg = yaml.safe_load(path.read_text())
    cfg.setdefault("samples", 4000)
    cfg.setdefault("t_max_factor", 3.0)
    cfg.setdefault("time_safety", 0.1)
    return cfg


def sample_cost(m: dict, cfg: dict, scene: str, p: float, size: str) -> dict:
    """Predicted CPU seconds of one sample's stages."""
    kind = next(k for k in ("disordered", "lattices", "chains", "continuum") if scene in (cfg.get(k) or {}))
    spec = {**(CONTINUUM_DEFAULTS if kind == "continuum" else SCENE_DEFAULTS),
            **({"friction": 0.0} if kind == "lattices" else {}), **cfg[kind][scene]}
    cfg = dict(cfg)
    if kind == "continuum":  # time-domain signals, the scene's own step and record, no statics
        spec = {**spec, "solver": "time", "no_statics": True, "tall": True}
        cfg.update({k: spec[k] for k in ("time_safety", "samples", "t_max_factor") if k in spec})
        kind = "disordered"
    H = float(size[1:])
    if kind == "disordered":
        w = spec["width"]
        N = max(1, round(w * H)) if spec["dim"] == 2 else max(1, round(w * w * H * 0.62 / (math.pi / 6)))
    elif kind == "lattices":
        N = int(H) * int(spec["width"])
    else:
        N = int(H)
    dim = spec.get("dim", 2) if kind == "disordered" else (2 if kind == "lattices" else 1)
    frictional = spec.get("friction", 0.0) > 0 if kind != "chains" else False
    c = m["classes"].get(cls(kind, dim, frictional))
    if c is None:  # no measured sample of this class: the nearest measured one of the same kind
        c = next(v for k, v in m["classes"].items() if k.startswith(kind))
    out = {}
    if kind == "disordered" and spec.get("tall") and "steps_g_tall" in c and H >= TALL_FROM:
        steps = c["steps_a_tall"] * H ** c["steps_g_tall"] * p ** c["steps_e_tall"] * steps_factor(spec["tol"])
        out["packing"] = c["k_step"] * N * steps
        out["dem_steps"] = steps  # not a cost: reported against max_steps
    elif kind == "disordered":
        steps = c["steps_a"] * H ** m["steps_g"] * p ** m["steps_e"] * steps_factor(spec["tol"])
        out["packing"] = c["k_step"] * N * steps
    else:
        out["packing"] = m.get(f"make_{kind}", 0.0) * N
    n = c["dof_per_grain"] * N
    c0, c1, c3 = m["linear"]
    out["linear"] = c0 + c1 * n + (c3 * n**3 if n <= DENSE_CHECK_MAX_DOF else 0.0)
    method = "modal" if kind == "chains" else spec.get("solver", "auto")
    modal = m.get("km2", 0.0) * n**2 if kind == "chains" else m.get("km", 0.0) * n**3
    time = math.inf
    if "kt" in m and "omega_b" in c:
        t_max = cfg["t_max_factor"] * crossing_time(kind, spec, p, size)
        h = t_max / (cfg["samples"] - 1)
        sub = max(1, math.ceil(h * c["omega_b"] * p ** c["omega_s"] / (2 * cfg["time_safety"])))
        time = m["kt"] * c["nnz_per_grain"] * N * sub * (cfg["samples"] - 1)
    out["signal"] = {"modal": modal, "time": time}.get(method, min(modal, time))
    if kind != "chains":
        if H * (math.sqrt(3) / 2 if kind == "lattices" else 1) > 7 and "statics" in m \
                and not spec.get("no_statics"):
            out["statics"] = m["statics"][0] * N ** m["statics"][1]
        if spec.get("moduli", True) and "moduli" in m:
            out["moduli"] = m["moduli"][0] * N ** m["moduli"][1]
    if "front" in m:
        out["front"] = m["front"][0] * N ** m["front"][1]
    return out


SAMPLE = re.compile(r"/packing/(\w+)/p([0-9.e+-]+)/([hrn][0-9.]+)/s\d+\.h5$")


def estimate(config: Path, m: dict, light: float) -> tuple[Counter, Counter]:
    """(CPU seconds per stage or rule, job counts); also ``seconds["_longest_batch"]`` (one
    batch job runs on one core: no run is shorter than it), ``seconds["_longest_sample"]`` and
    ``seconds["_max_dem_steps"]`` (not costs)."""
    cfg = load_config(config)
    seconds, counts = Counter(), Counter()
    longest = longest_sample = max_steps = 0.0
    for job in planned_jobs(config):
        rule = job["rule"]
        if rule.startswith("batch_"):
            counts["batch (per-sample pipelines)"] += 1
            seconds["batch start-up"] += m["batch_overhead"]
            batch = m["batch_overhead"]
            for path in job["output"]:
                mt = SAMPLE.search(path)
                if mt:
                    cost = sample_cost(m, cfg, mt.group(1), float(mt.group(2)), mt.group(3))
                    max_steps = max(max_steps, cost.pop("dem_steps", 0.0))
                    for stage, t in cost.items():
                        seconds[f"  {stage}"] += t
                    batch += sum(cost.values())
                    longest_sample = max(longest_sample, sum(cost.values()))
            longest = max(longest, batch)
            continue
        if any("/timings/analyses/" in path for path in job["output"]):
            # one start-up, then each command's measured CPU (not grown with its number of
            # signals: an underestimate where a scene has thousands)
            counts["analyses and figures (several commands each)"] += 1
            seconds["analyses and figures"] += light + sum(m["command"].get(k, 0.0)
                                                           for k in command_kinds(job["output"]))
            continue
        counts[rule] += 1
        seconds[rule] += light
    return seconds, counts, {"longest_batch": longest, "longest_sample": longest_sample,
                             "max_dem_steps": max_steps}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--measured", type=Path, nargs="+", default=[ROOT / "results"],
                    help="results folders of finished runs (several: their samples fitted together)")
    ap.add_argument("--config", type=Path, default=ROOT / "config" / "paper.yaml")
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--check", type=Path, default=None,
                    help="results of a real run of --config: compare its measured batch CPU time "
                         "with the prediction")
    args = ap.parse_args(argv)
    m = fit_models(args.measured)
    light = light_job_cpu()
    print(f"models fitted to {m['n_measured']} samples of {', '.join(map(str, args.measured))} (CPU seconds):")
    print(f"  DEM steps = a L^{m['steps_g']:.2f} p^{m['steps_e']:.3f} S(tol); cpu = k N steps")
    for c, d in sorted(m["classes"].items()):
        print(f"    {c}: " + ", ".join(f"{k} {v:.3g}" for k, v in d.items()))
    for k in ("linear", "kt", "km", "km2", "statics", "moduli", "front", "batch_overhead"):
        if k in m:
            v = m[k]
            print(f"  {k}: " + (", ".join(f"{x:.3g}" for x in v) if isinstance(v, tuple) else f"{v:.3g}"))
    print(f"  light job (a granwave command, measured here): {light:.2f} s")
    seconds, counts, extremes = estimate(args.config, m, light)
    total = sum(seconds.values())
    name = load_config(args.config).get("name", args.config.stem)
    print(f"\nexpected cost of {args.config} ({sum(counts.values())} jobs):")
    for key, n in sorted(counts.items()):
        print(f"  {key:<32} {n:>6} jobs")
    for key, t in sorted(seconds.items(), key=lambda kv: -kv[1]):
        print(f"  {key:<32} {t / 3600:8.3f} CPU h")
    if args.check:
        measured = sum(bench_cpu(t) for t in (args.check / "benchmarks" / "batch").glob("*.tsv"))
        predicted = sum(t for k, t in seconds.items() if k.startswith("  ") or k == "batch start-up")
        print(f"\ncheck against {args.check}: batch jobs measured {measured:.1f} CPU-s, "
              f"predicted {predicted:.1f} CPU-s ({predicted / measured - 1:+.0%})")
    if extremes["max_dem_steps"]:
        print(f"\ntall columns: the longest batch {extremes['longest_batch'] / 3600:.2f} CPU-h and the "
              f"longest sample {extremes['longest_sample'] / 3600:.2f} CPU-h run on one core each "
              f"(no run is shorter); largest predicted DEM step count {extremes['max_dem_steps']:.3g}")
    wall = max(total / args.cores, extremes["longest_batch"])
    print(f"{name} config: {total / 3600:.2f} CPU-h, {wall / 3600:.2f} h on {args.cores} cores")


if __name__ == "__main__":
    main()
