"""Finite size of the scale-dependent moduli on the perfect triangular lattice (a script, not a test).

    python benchmarks/lattice_local_moduli.py [--write-docs]

Computes the local-modulus ratios of docs/method.md §6 (body force n = 1, 2;
imposed lines n = 1, 3; normal C22 and shear C33, each divided by the global
modulus) for `granwave.systems.triangular_lattice` (width 3, p = 1e-4 E*,
frictionless and mu = 0.5) with 12, 24, 48, 96 rows (and 25 rows: an odd
number puts the middle row on the n = 1 line). Prints a Markdown table and,
with ``--write-docs``, puts it into docs/moduli.md between the markers
``<!-- lattice-local-moduli:begin -->`` and ``<!-- lattice-local-moduli:end -->``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- lattice-local-moduli:begin -->", "<!-- lattice-local-moduli:end -->"
ROWS = (12, 24, 48, 96, 25)
KEYS = [f"{c}_{kind}_n{n}_ratio" for c in ("C22", "C33") for kind, ns in (("body", (1, 2)), ("lines", (1, 3)))
        for n in ns]


def table() -> str:
    from granwave.linear.moduli import moduli
    from granwave.systems import triangular_lattice

    head = "| μ | rows | L (d) | " + " | ".join(k.removesuffix("_ratio").replace("_", " ") for k in KEYS) + " |"
    lines = [head, "|" + "---|" * (3 + len(KEYS))]
    for friction in (0.0, 0.5):
        for rows in ROWS:
            pk = triangular_lattice(rows=rows, width=3, pressure=1e-4, friction=friction)
            res = moduli(pk, local=True)
            cells = " | ".join(f"{res[k]:.4f}" for k in KEYS)
            lines.append(f"| {friction:g} | {rows} | {pk.box[-1]:.2f} | {cells} |")
    return "\n".join(lines)


def write_docs(text: str) -> None:
    from granwave.io.files import replace_marked_block

    replace_marked_block(ROOT / "docs" / "moduli.md", BEGIN, END, text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--write-docs", action="store_true")
    a = ap.parse_args(argv)
    text = table()
    print(text)
    if a.write_docs:
        write_docs(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
