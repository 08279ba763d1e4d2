"""The time domain's step against its accuracy, per source kind and record length.

    python benchmarks/time_step.py                 # 600 grains (prepare-packing's default), ~3 CPU-min
    python benchmarks/time_step.py --grains 60 --seed 3 --no-record   # a quick look

On one frictional 2D packing (prepare-packing's defaults: p = 1e-4, mu = 0.5): for the
compressional and the shear kick (initial condition A) and records of 1-5 crossings (t_max =
crossings x height / c, c = c_l or c_t from the moduli, as the shear scene sizes its records):

- why the shear kick is worse: the share of each source's modal weight |a_n b_n| and of its
  |a_n b_n| omega_n^3 (what the step's phase error weighs) by frequency band, the rotational
  part of the modes there, and max|F'''| / max|F| over the record;
- the error of the time domain against the exact modal sum (max over the record of
  |F_time - F_modal| / max|F_modal|, on the output grid) at fixed steps, beside each run's own
  estimate (granwave.linear.step_rule) and its wall time;
- the default (api.propagate: safety 0.1, tolerance 1 %): its error, runs, final step and wall
  time, against the modal sum's (dense eigensolve + sum) and the fixed step the table shows
  was needed.

Appends one record to benchmarks/results/time_step.jsonl; docs/tradeoffs.md's table is
generated from the newest record by benchmarks/results/summarize.py.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from granwave import api  # noqa: E402
from granwave.linear.propagate import modal_signal, time_domain_signal  # noqa: E402
from granwave.params import PropagateParams  # noqa: E402

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "time_step.jsonl"
BANDS = ((0.0, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 1.0), (1.0, np.inf))


def _error(force, ref) -> float:
    return float(np.max(np.abs(force - ref)) / np.max(np.abs(ref)))


def spectrum_rows(system, modes, kind, t_max) -> dict:
    """Where the kick's modal weight lies, and how rotational the modes there are."""
    mo = modes.for_source(kind)
    om = np.sqrt(np.maximum(mo.omega2, 0.0))
    w = np.abs(mo.amplitude_A * mo.coupling)
    w3 = w * om**3
    rot = system.dof_axis >= int(system.attrs.get("dim", 2))  # rotations (model.LinearSystem)
    m = np.sqrt(system.mass)[:, None] * modes.vectors  # M^1/2 phi: unit columns
    rot_frac = np.sum(m[rot] ** 2, axis=0)
    t = np.linspace(0.0, t_max, 4001)
    f = modal_signal(mo, ic="A", times=t)
    jerk = -(np.cos(np.outer(t, om)) * om**3) @ (mo.amplitude_A * mo.coupling)
    bands = []
    for lo, hi in BANDS:
        k = (om >= lo) & (om < hi)
        bands.append({"band": [lo, None if hi == np.inf else hi], "share_w": float(w[k].sum() / w.sum()),
                      "share_w3": float(w3[k].sum() / w3.sum()),
                      "rot_frac": float(np.mean(rot_frac[k])) if k.any() else None})
    return {"omega_max": float(om.max()), "rot_frac_w": float((w * rot_frac).sum() / w.sum()),
            "rot_frac_w3": float((w3 * rot_frac).sum() / w3.sum()),
            "jerk_over_f": float(np.abs(jerk).max() / np.abs(f).max()), "bands": bands}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grains", type=int, default=600)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--crossings", type=float, nargs="+", default=[1, 2, 3, 5])
    ap.add_argument("--safeties", type=float, nargs="+", default=[0.2, 0.1, 0.05, 0.02, 0.01])
    ap.add_argument("--samples", type=int, default=2001)
    ap.add_argument("--no-record", action="store_true", help="print, do not append to time_step.jsonl")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    cpu0 = time.process_time()
    packing = api.prepare_packing(grains=args.grains, seed=args.seed, pressure=args.pressure)
    system = api.linearize(packing)
    mod = api.moduli(packing, system=system)
    speeds = {"normal": float(mod["c_l"]), "shear": float(mod["c_t"])}
    t0 = time.perf_counter()
    api.eigensolve(system)
    t_eig = time.perf_counter() - t0
    modes = api.eigensolve(system, vectors=True)
    tol = PropagateParams.__dataclass_fields__["tolerance"].default
    time_domain_signal(system, ic="A", t_max=10.0, samples=11)  # warm-up (numba cache load)
    result = {"grains": args.grains, "seed": args.seed, "pressure": args.pressure, "n_dof": system.n_dof,
              "nnz": int(system.stiffness.nnz), "height": system.height, "samples": args.samples,
              "tolerance": tol, "c": speeds, "eigensolve_s": t_eig, "spectrum": {}, "fixed": [], "default": []}
    for kind in ("normal", "shear"):
        crossing = system.height / speeds[kind]
        result["spectrum"][kind] = spectrum_rows(system, modes, kind, max(args.crossings) * crossing)
        for n in args.crossings:
            t_max = n * crossing
            t = np.linspace(0.0, t_max, args.samples)
            t0 = time.perf_counter()
            ref = modal_signal(modes.for_source(kind), ic="A", times=t)
            t_modal = t_eig + time.perf_counter() - t0
            fixed = []
            for safety in args.safeties:
                t0 = time.perf_counter()
                sig = time_domain_signal(system.for_source(kind), ic="A", t_max=t_max, samples=args.samples,
                                         safety=safety)
                row = {"kind": kind, "crossings": n, "safety": safety, "dt": sig.attrs["dt"],
                       "omega_max_dt": sig.attrs["omega_max_dt"], "steps": sig.attrs["n_steps"],
                       "error": _error(sig.force, ref), "estimate": sig.attrs["step_error_estimate"],
                       "wall": time.perf_counter() - t0}
                fixed.append(row)
                print(json.dumps(row), flush=True)
            result["fixed"] += fixed
            t0 = time.perf_counter()
            sig = api.propagate(system, method="time", source_kind=kind, t_max=t_max, samples=args.samples)
            wall = time.perf_counter() - t0
            good = [r for r in fixed if r["error"] <= tol]
            best = max(good, key=lambda r: r["dt"]) if good else None
            row = {"kind": kind, "crossings": n, "t_max": t_max, "runs": sig.attrs["step_runs"],
                   "dt": sig.attrs["dt"], "omega_max_dt": sig.attrs["omega_max_dt"],
                   "first_dt": sig.attrs["step_first_dt"], "error": _error(sig.force, ref),
                   "estimate": sig.attrs["step_error_estimate"], "wall": wall, "modal_wall": t_modal,
                   "best_fixed_safety": None if best is None else best["safety"],
                   "best_fixed_wall": None if best is None else best["wall"]}
            result["default"].append(row)
            print(json.dumps(row), flush=True)
    wall, cpu = time.perf_counter() - t_start, time.process_time() - cpu0
    worst = {k: max(r["error"] for r in result["default"] if r["kind"] == k) for k in ("normal", "shear")}
    first = {k: max(r["error"] for r in result["fixed"] if r["kind"] == k and r["safety"] == 0.1)
             for k in ("normal", "shear") if any(r["safety"] == 0.1 for r in result["fixed"])}
    from granwave.provenance import git_revision

    rec = {"date": f"{datetime.date.today()}", "benchmark": "time_step",
           "command": " ".join(["python benchmarks/time_step.py", *(argv if argv is not None else sys.argv[1:])]),
           "git_revision": git_revision(), "machine": {"cpu": platform.machine(), "note": "shared 2-core machine"},
           "summary": {f"default: worst error / max|F| ({k})": f"{v:.2e}" for k, v in worst.items()}
           | {f"safety 0.1 alone: worst error ({k})": f"{v:.2e}" for k, v in first.items()}
           | {"wall (s)": round(wall, 1), "CPU (s)": round(cpu, 1)},
           "result": result}
    print(json.dumps(rec["summary"]))
    if not args.no_record:
        with RESULTS.open("a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(f"appended to {RESULTS}; now: python benchmarks/results/summarize.py")


if __name__ == "__main__":
    main()
