"""The CLI call, the one-line refusal check and the small lattices' files the hostile-input tests
share (tests/test_fuzz_guards.py, tests/test_fuzz_pairs.py, tests/test_older_files.py)."""

from __future__ import annotations

from click.testing import CliRunner

from granwave.cli import main


def run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


def one_line_refusal(r, *words):
    """Exit 2, no exception but SystemExit, one line "Error: ..." naming each of ``words``."""
    assert r.exit_code == 2, r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), r.output
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


#: the signals' record: modal, t = 60, 600 samples
SIGNAL_ARGS = ["--method", "modal", "--t-max", 60, "--samples", 600, "-q"]


def lattice_files(tmp_path_factory) -> dict:
    """Per frictional lattice (rows 4 and 6, width 4, p = 1e-3), made through the CLI: its packing,
    linear file, normal and shear signals and its moduli (JSON)."""
    out = {}
    for rows in (4, 6):
        d = tmp_path_factory.mktemp(f"r{rows}")
        p, lin, n, sh, mod = (d / x for x in ("p.h5", "lin.h5", "n.h5", "sh.h5", "mod.json"))
        for args in (["lattice", "--rows", rows, "--width", 4, "--pressure", 1e-3, "--friction", 0.5, "-o", p, "-q"],
                     ["linearize", p, "-o", lin, "-q"],
                     ["propagate", lin, "-o", n, *SIGNAL_ARGS],
                     ["propagate", lin, "-o", sh, "--source", "shear", *SIGNAL_ARGS]):
            r = run(args)
            assert r.exit_code == 0, r.output
        r = run(["analyze", "moduli", p, "--json"])
        assert r.exit_code == 0, r.output
        mod.write_text(r.output)
        out[rows] = {"packing": p, "linear": lin, "normal": n, "shear": sh, "moduli": mod}
    return out
