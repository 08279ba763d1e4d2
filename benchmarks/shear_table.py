"""The pick table of docs/shear.md: which shear arrival pick lands within 5 % of c_t, at which
distance and pulse wavelength, on the frictional triangular lattice (p = 1e-5, width 4).

    PYTHONPATH=. python benchmarks/shear_table.py --write docs/shear.md

c_t is the lattice's derived long-wavelength speed (granwave.theory.lattice_shear_speed);
the signals are modal sums of the shear kick. The table goes between the markers
<!-- shear-table --> and <!-- /shear-table --> of the file given to --write (else stdout).
"""

from __future__ import annotations

import argparse
import re

import numpy as np

from granwave import theory
from granwave.analysis.shear import PICKS, shear_picks
from granwave.linear.assemble import linearize
from granwave.linear.eigen import eigensolve
from granwave.linear.propagate import modal_signal
from granwave.systems import triangular_lattice

P = 1e-5
ROWS = (8, 25, 75)
WAVELENGTHS = (4.0, 8.0, 16.0)
PULSES = ("sine", "ricker")


def table() -> str:
    ct = theory.lattice_shear_speed(P)
    lines = ["| rows | L (d) | pulse | λ = c_t/f (d) | " + " | ".join(PICKS) + " | within 5 % |",
             "|---|---|---|---|" + "---|" * len(PICKS) + "---|"]
    for rows in ROWS:
        s = linearize(triangular_lattice(rows=rows, width=4, pressure=P, friction=0.5), check=False)
        modes = eigensolve(s).for_source("shear")
        for pulse in PULSES:
            for lam in WAVELENGTHS:
                f = ct / lam
                t = np.linspace(0.0, 3.0 * s.height / ct + 3.0 / f, 8001)
                r = shear_picks(t, modal_signal(modes, ic="A", times=t), height=s.height, frequency=f,
                                pulse=pulse, c_t=ct)
                ratios = [r["picks"][k]["ratio"] for k in PICKS]
                ok = [k for k, v in zip(PICKS, ratios) if np.isfinite(v) and abs(v - 1) <= 0.05]
                lines.append(f"| {rows} | {s.height:.1f} | {pulse} | {lam:g} | "
                             + " | ".join("–" if not np.isfinite(v) else f"{v:.3f}" for v in ratios)
                             + f" | {', '.join(ok) or 'none'} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", default=None)
    args = ap.parse_args()
    text = table()
    if args.write is None:
        print(text)
        return
    doc = open(args.write).read()
    new, n = re.subn(r"(<!-- shear-table -->\n)(?:.*?\n)?(<!-- /shear-table -->)",
                     lambda m: m.group(1) + text + "\n" + m.group(2), doc, flags=re.S)
    if n != 1:
        raise SystemExit(f"{args.write}: no <!-- shear-table --> ... <!-- /shear-table --> markers")
    open(args.write, "w").write(new)


if __name__ == "__main__":
    main()
