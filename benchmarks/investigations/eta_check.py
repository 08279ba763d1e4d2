"""How well the preparation's progress line foretells its end (a script, not a test).

    python benchmarks/investigations/eta_check.py [--dim 3] [--grains 5000] [--pressure 1e-4]
        [--friction 0.5] [--seed 1] [--threads 2] [--log FILE]

Prepares one packing (granwave.api.prepare_packing, the default protocol) and, at every
progress line (about one a second), takes the ETA two ways from the same histories: from
max |a| alone (the rule before 2026-11-26: the time for max |a| to reach tol) and from the
slowest quantity of the convergence test (max |a| against tol, the largest of |v|, |w| R and
the piston's speed against the velocity threshold: granwave's rule since). Once the run has
converged, each line's ETA is compared with the time that was actually left, and per rule
and per quarter of the run (by wall time from the first line) it prints the share of lines
with no ETA ("?"), with an ETA within a factor 2 of the time left, the median of ETA / time
left and the median of |log2(ETA / time left)| (1: off by a factor 2 either way), and the
same over the whole run. Ratios from one run: the host's speed changes alike for both rules.
``--log`` writes every line's time, both ETAs and the time left as JSON lines.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--grains", type=int, default=5000)
    ap.add_argument("--pressure", type=float, default=1e-4)
    ap.add_argument("--friction", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--log", type=Path)
    a = ap.parse_args()

    from granwave import api
    from granwave.dem import protocol
    from granwave.params import PrepareParams

    lines = []  # (time, ETA from max |a| alone, ETA from the slowest quantity)
    shipped = protocol.eta_seconds
    pending = {}

    def both_rules(quantities, steps_per_second, **kw):
        # the first quantity is max |a| against tol (protocol.Compression.relax)
        pending["a"] = shipped(quantities[:1], steps_per_second, **kw)
        pending["all"] = shipped(quantities, steps_per_second, **kw)
        return pending["all"]

    def on_progress(line: str) -> None:
        print(line, flush=True)
        if line.startswith("step"):
            lines.append((time.perf_counter(), pending.get("a"), pending.get("all")))

    protocol.eta_seconds = both_rules
    params = PrepareParams(dim=a.dim, grains=a.grains, pressure=a.pressure, friction=a.friction, seed=a.seed)
    t0 = time.perf_counter()
    packing = api.prepare_packing(params, progress=on_progress, threads=a.threads)
    t_end = time.perf_counter()
    protocol.eta_seconds = shipped
    print(f"\n{a.dim}D, {a.grains} grains, p = {a.pressure:g}, mu = {a.friction:g}, seed {a.seed}, "
          f"{a.threads} threads: converged after {packing.attrs['steps']} steps in {t_end - t0:.1f} s; "
          f"{len(lines)} progress lines")
    if a.log:
        with open(a.log, "w") as f:
            for t, e_a, e_all in lines:
                f.write(json.dumps(dict(t=t - t0, left=t_end - t, eta_max_a=e_a, eta_slowest=e_all)) + "\n")
    print("| quarter of the run | rule | lines | no ETA | within 2x of the time left | median ETA / time left "
          "| median abs log2 (ETA / time left) |")
    print("|---|---|---|---|---|---|---|")
    # quarters from the first progress line (before it, numba may still be compiling)
    start = lines[0][0] if lines else t0
    span = t_end - start
    for q in range(5):  # the four quarters, then the whole run
        part = [x for x in lines if q == 4 or q * span / 4 <= x[0] - start < (q + 1) * span / 4]
        for name, k in (("max |a| alone", 1), ("slowest tested", 2)):
            known = [(x[k], t_end - x[0]) for x in part if x[k] is not None]
            within = sum(1 for e, left in known if 0.5 <= e / left <= 2.0)
            ratio = statistics.median(e / left for e, left in known) if known else float("nan")
            miss = statistics.median(abs(math.log2(e / left)) for e, left in known) if known else float("nan")
            n = max(1, len(part))
            print(f"| {'all' if q == 4 else q + 1} | {name} | {len(part)} | "
                  f"{100 * (len(part) - len(known)) / n:.0f} % | {100 * within / n:.0f} % | {ratio:.3g} "
                  f"| {miss:.2f} |")


if __name__ == "__main__":
    main()
