"""Do two preparations follow the same trajectory? Their progress logs, compared (a script, not a test).

    python benchmarks/investigations/same_progress.py A.log B.log

A preparation prints a progress line about once a second (granwave prepare-packing, or
``benchmarks/scale.py --large``): the step, max |a|, max |v|, max |w| R, kinetic energy,
piston height, contacts and dt, then the rate and an ETA. Which steps get a line depends on
the wall time, but the state at a given step does not (the same seed gives the same bytes for
any thread count and any chunking): two runs of the same code and seed print the same
quantities at every step both printed. This compares them there (without the rate and the
ETA), and the line that reports the mean-flow rule's settling switch where both logs have
it, and says whether they agree (exit 0) or where they first differ (exit 1). It is how a
large run that takes hours is checked against an older run's log at a fraction of the cost
(run the other code with ``scale.py --large NAME --stop-at STEPS``; a reference log is kept
in benchmarks/reference/). Agreement is to the printed digits (4 significant; the piston to
1e-4 d), not byte for byte; but those digits change from one printed line to the next, so
logs identical at hundreds of steps spread over the run can hardly come from two
trajectories.
"""

from __future__ import annotations

import argparse
import re
import sys

# a progress line up to (not including) the rate: "step  <n>  max|a| ... dt <dt>"
LINE = re.compile(r"^step\s+(\d+)\s+(.*?\bdt\s+\S+)")
# the end game's damping rate (--end-game adaptive): a setting, not a state; left out so that a
# run with the end game compares with one without it up to where the rate first changes
DAMPING = re.compile(r"\s+damping\s+\S+")


def progress_states(lines) -> dict[int, str]:
    """step -> the line's deterministic part (the quantities up to dt, spaces normalised)."""
    states = {}
    for line in lines:
        m = LINE.match(line)
        if m:
            states[int(m.group(1))] = " ".join(DAMPING.sub("", m.group(2)).split())
    return states


def settling_switch(lines) -> str | None:
    """The line that reports the mean-flow rule's settling switch (printed once, at fixed step
    counts: deterministic like the progress lines), or None."""
    return next((line.strip() for line in lines if line.startswith("plug arrived")), None)


def compare(a: dict[int, str], b: dict[int, str]) -> tuple[list[int], int | None]:
    """The steps both logs printed, and the first of them where the lines differ (None: none)."""
    common = sorted(set(a) & set(b))
    first = next((s for s in common if a[s] != b[s]), None)
    return common, first


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log_a")
    ap.add_argument("log_b")
    args = ap.parse_args()
    logs, switches = [], []
    for path in (args.log_a, args.log_b):
        try:
            with open(path) as f:
                lines = f.readlines()
        except OSError as err:
            raise SystemExit(f"{path}: {err.strerror}")
        states = progress_states(lines)
        if not states:
            raise SystemExit(f"{path}: no progress lines")
        logs.append(states)
        switches.append(settling_switch(lines))
        print(f"{path}: {len(states)} progress lines, steps {min(states)}-{max(states)}")
    common, first = compare(*logs)
    if not common:
        raise SystemExit("no step printed in both logs: nothing to compare")
    if None not in switches:
        if switches[0] != switches[1]:
            print(f"DIFFERENT settling switch:\n  A: {switches[0]}\n  B: {switches[1]}")
            sys.exit(1)
        print(f"settling switch: the same ({switches[0]})")
    elif switches != [None, None]:
        print("settling switch: in one log only (the other stopped before it, or has no such rule)")
    if first is None:
        print(f"same: identical at all {len(common)} common steps, {common[0]}-{common[-1]}")
        return
    agreed = [s for s in common if s < first]
    print(f"DIFFERENT at step {first} (identical at the {len(agreed)} common steps before it"
          + (f", up to {agreed[-1]})" if agreed else ")"))
    print(f"  A: {logs[0][first]}\n  B: {logs[1][first]}")
    sys.exit(1)


if __name__ == "__main__":
    main()
