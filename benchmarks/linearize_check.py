"""Time ``linearize`` of a 10^6-grain frictional lattice, stiffness check included (printed, not a test).

    python benchmarks/linearize_check.py [--rows 1000 --width 1000] [--no-record]

The 2D triangular lattice of granwave.linear.check.reference_lattice (p = 1e-4,
mu = 0.5, 3 dofs per grain, 3e6 dofs at 1000 x 1000), linearized with the
default check (above 3000 dofs: LOBPCG with a smoothed-aggregation AMG
preconditioner, docs/linear.md "Checks on D"). Prints the assembly time, the
check time, the total and its ratio to the 2-minute goal, and appends one JSON
line (date, host CPU, numbers) to benchmarks/results/linearize_check.jsonl.
Absolute times drift on a shared machine: say what else ran. Both wall-clock and
process CPU seconds (all threads of this process) are recorded: with other work
on the cores, the CPU seconds are the better estimate of the wall time alone.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import pathlib
import platform
import subprocess
import time

from granwave.linear.assemble import check_stiffness, linearize
from granwave.linear.check import reference_lattice

GOAL_SECONDS = 120.0
RESULTS = pathlib.Path(__file__).parent / "results" / "linearize_check.jsonl"


def cpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        for line in out.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.CalledProcessError):
        pass
    return platform.processor() or "unknown"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=1000)
    ap.add_argument("--width", type=int, default=1000)
    ap.add_argument("--no-record", action="store_true", help="do not append to the JSONL file")
    ap.add_argument("--note", default="", help="free text stored with the result (e.g. other load)")
    args = ap.parse_args()

    t = time.perf_counter()
    packing = reference_lattice(args.rows, args.width, pressure=1e-4, friction=0.5)
    t_lattice = time.perf_counter() - t
    t, c = time.perf_counter(), time.process_time()
    system = linearize(packing, check=False)
    t_assemble, c_assemble = time.perf_counter() - t, time.process_time() - c
    t, c = time.perf_counter(), time.process_time()
    result = check_stiffness(system, progress=lambda line: print(line, flush=True))
    t_check, c_check = time.perf_counter() - t, time.process_time() - c
    total, c_total = t_assemble + t_check, c_assemble + c_check
    print(f"lattice {args.rows} x {args.width}: {packing.n_grains} grains, {system.n_dof} dofs "
          f"(building the packing itself: {t_lattice:.1f} s, not counted)")
    print(f"assembly {t_assemble:.1f} s, check {t_check:.1f} s ({result['psd_check']}, "
          f"converged {result['psd_check_converged']}), total {total:.1f} s = "
          f"{total / GOAL_SECONDS:.2f} x the 2-minute goal; check / assembly = {t_check / t_assemble:.2f}")
    print(f"CPU seconds of this process: assembly {c_assemble:.1f}, check {c_check:.1f}, total {c_total:.1f}"
          f" = {c_total / GOAL_SECONDS:.2f} x the goal; check / assembly = {c_check / c_assemble:.2f}")
    print(f"n_negative_modes {result['n_negative_modes']}, n_zero_modes {result['n_zero_modes']}, "
          f"lowest omega^2 {result['min_omega2']:.4g} = {result['min_omega2'] / result['omega2_max']:.3g} "
          "omega^2_max")
    row = dict(date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               host_cpu=cpu_model(), grains=packing.n_grains, n_dof=system.n_dof,
               assemble_s=round(t_assemble, 2), check_s=round(t_check, 2), total_s=round(total, 2),
               goal_ratio=round(total / GOAL_SECONDS, 3), assemble_cpu_s=round(c_assemble, 2),
               check_cpu_s=round(c_check, 2), total_cpu_s=round(c_total, 2),
               goal_ratio_cpu=round(c_total / GOAL_SECONDS, 3), load_average_1min=os.getloadavg()[0],
               logical_cpus=os.cpu_count(), psd_check=result["psd_check"],
               converged=result["psd_check_converged"], n_negative_modes=result["n_negative_modes"],
               n_zero_modes=result["n_zero_modes"], min_omega2_rel=result["min_omega2"] / result["omega2_max"],
               note=args.note)
    if not args.no_record:
        RESULTS.parent.mkdir(parents=True, exist_ok=True)
        with RESULTS.open("a") as f:
            f.write(json.dumps(row) + "\n")
        print(f"appended to {RESULTS}")


if __name__ == "__main__":
    main()
