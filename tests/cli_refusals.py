"""The CLI call and the one-line refusal check the hostile-input tests share
(tests/test_fuzz_guards.py, tests/test_fuzz_pairs.py)."""

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
