"""The documentation is self-contained: nothing a user reads points outside the repository.

Scanned: the ``--help`` text of ``granwave`` and of every command and subcommand
(walked through click's command tree), every string and comment of the Python
sources under ``granwave/``, ``benchmarks/`` and ``workflow/``, the workflow and
configuration files, and every Markdown file of the repository. Two rules:

- a cited repository path (``docs/method.md``, ``config/paper.yaml``,
  ``granwave/contact.py``, ``workflow/rules/*.smk``, ...) must exist;
- the reference for definitions is ``docs/method.md``: no text cites "SPEC", and
  every ``docs/method.md §N`` names one of its fourteen sections.

Failures list every offending ``file:line`` so the fix can be checked line by
line. The CLI loads its stages lazily, so walking ``--help`` imports no numba.

Also checked: the SI conversion tables of ``docs/units.md`` against the
material constants they state.
"""

from __future__ import annotations

import io
import itertools
import math
import re
import tokenize
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
THIS = Path(__file__).resolve()

# Top-level folders whose paths a text may cite; a citation is <folder>/<more>.
CITABLE = ("docs", "config", "benchmarks", "granwave", "tests", "workflow")
PATH_RE = re.compile(r"(?<![\w./-])((?:%s)/[\w./{},*-]*[\w/*}])" % "|".join(CITABLE))
# A citation names a file (with an extension, or a Snakefile) or a folder (trailing slash);
# "granwave/LAMMPS" (a ratio) is not one.
FILE_LIKE = re.compile(r"(\.[A-Za-z0-9*]+|/|(^|/)Snakefile)$")
SPEC_RE = re.compile(r"\bSPEC\b")
SKIP_DIRS = {".git", ".snakemake", "results", "__pycache__", "build", "dist", ".pytest_cache",
             "node_modules", ".venv", "venv"}


# ----------------------------------------------------------------------------- collecting texts

def _walk(top: Path, pattern: str):
    for path in sorted(top.rglob(pattern)):
        rel = path.relative_to(ROOT)
        if any(part in SKIP_DIRS or part.endswith(".egg-info") for part in rel.parts):
            continue
        if path.is_file() and path.resolve() != THIS:
            yield path


def _lines(label: str, text: str, first_line: int = 1):
    """(label:line, line text) of every line of ``text``."""
    for k, line in enumerate(text.splitlines()):
        yield f"{label}:{first_line + k}", line


def python_texts(path: Path):
    """Strings (docstrings, help texts, messages) and comments of a Python file, by line."""
    label = str(path.relative_to(ROOT))
    source = path.read_text(encoding="utf-8")
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    except (tokenize.TokenError, SyntaxError):  # not Python after all: scan it as text
        yield from _lines(label, source)
        return
    kinds = {tokenize.STRING, tokenize.COMMENT}
    kinds |= {getattr(tokenize, "FSTRING_MIDDLE")} if hasattr(tokenize, "FSTRING_MIDDLE") else set()
    for tok in tokens:
        if tok.type in kinds:
            yield from _lines(label, tok.string, tok.start[0])


def text_file(path: Path):
    yield from _lines(str(path.relative_to(ROOT)), path.read_text(encoding="utf-8"))


def source_texts():
    """Every scanned line of the repository's files, as (file:line, text)."""
    for folder in ("granwave", "benchmarks", "workflow"):
        for path in _walk(ROOT / folder, "*.py"):
            yield from python_texts(path)
    for pattern in ("Snakefile", "*.smk", "*.yaml", "*.yml"):
        for folder in ("workflow", "config"):
            for path in _walk(ROOT / folder, pattern):
                yield from text_file(path)
    for path in _walk(ROOT, "*.md"):
        yield from text_file(path)


def _commands(cmd: click.Command, path: tuple[str, ...]):
    """(argument path, command) of ``cmd`` and everything below it."""
    yield path, cmd
    if isinstance(cmd, click.Group):
        ctx = click.Context(cmd, info_name=path[-1] if path else "granwave")
        for name in cmd.list_commands(ctx):
            sub = cmd.get_command(ctx, name)
            if sub is not None:
                yield from _commands(sub, path + (name,))


def help_texts():
    """The --help output of granwave and of every (sub)command, as (label:line, text)."""
    from granwave.cli import main

    runner = CliRunner()
    for path, _ in _commands(main, ()):
        args = [*path, "--help"]
        # wide lines: click must not wrap a path at a hyphen
        result = runner.invoke(main, args, terminal_width=10_000, max_content_width=10_000)
        label = "granwave " + " ".join(args)
        assert result.exit_code == 0, f"{label} failed: {result.output}"
        yield from _lines(label, result.output)


# ----------------------------------------------------------------------------- the checks

def _expand(path: str) -> list[str]:
    """Brace alternatives {a,b} expanded (one level, any number of groups)."""
    parts = re.split(r"\{([^{}]*)\}", path)
    fixed, options = parts[0::2], [p.split(",") for p in parts[1::2]]
    out = []
    for choice in itertools.product(*options):
        s = fixed[0]
        for c, f in zip(choice, fixed[1:]):
            s += c + f
        out.append(s)
    return out


def _exists(path: str) -> bool:
    if "__pycache__" in path:
        return True  # build products, not documents
    if any(ch in path for ch in "*?["):
        return any(ROOT.glob(path))
    return (ROOT / path).exists()


def missing_paths(lines) -> list[str]:
    bad = []
    for where, text in lines:
        for match in PATH_RE.finditer(text):
            cited = match.group(1).rstrip(".")
            if not FILE_LIKE.search(cited):
                continue
            for path in _expand(cited):
                if not _exists(path):
                    bad.append(f"{where}: {path}")
    return bad


def spec_citations(lines) -> list[str]:
    return [f"{where}: {text.strip()}" for where, text in lines if SPEC_RE.search(text)]


@pytest.fixture(scope="module")
def sources():
    return list(source_texts())


@pytest.fixture(scope="module")
def helps():
    return list(help_texts())


def test_the_scan_sees_the_texts_it_checks(sources, helps):
    """The collectors find what they must (guards against a scan that checks nothing)."""
    files = {w.rsplit(":", 1)[0] for w, _ in sources}
    for expected in ("README.md", "docs/method.md", "docs/units.md", "config/README.md",
                     "granwave/contact.py", "granwave/cli/__init__.py"):
        assert expected in files
    commands = {w.rsplit(":", 1)[0] for w, _ in helps}
    for expected in ("granwave --help", "granwave analyze --help", "granwave analyze moduli --help",
                     "granwave propagate --help"):
        assert expected in commands
    # the path pattern finds citations in running text, with and without braces and globs
    demo = [("x:1", "see docs/nothing-here.md, `granwave/{contact,nope}.py` and workflow/rules/*.smk."),
            ("x:2", "granwave/LAMMPS = 2.2 (a ratio, not a path); workflow/Snakefile, tests/data/")]
    assert missing_paths(demo) == ["x:1: docs/nothing-here.md", "x:1: granwave/nope.py"]
    assert spec_citations([("x:2", "as in SPEC §4"), ("x:3", "SPECTRUM, spectral")]) == ["x:2: as in SPEC §4"]


def test_help_texts_cite_only_files_in_the_repository(helps):
    bad = missing_paths(helps)
    assert not bad, "--help cites files that are not in the repository:\n" + "\n".join(bad)


def test_sources_and_docs_cite_only_files_in_the_repository(sources):
    bad = missing_paths(sources)
    assert not bad, "texts cite files that are not in the repository:\n" + "\n".join(bad)


def test_help_texts_do_not_cite_spec(helps):
    bad = spec_citations(helps)
    assert not bad, ("--help cites SPEC; cite docs/method.md §N instead:\n" + "\n".join(bad))


def test_sources_and_docs_do_not_cite_spec(sources):
    bad = spec_citations(sources)
    assert not bad, (f"{len(bad)} lines cite SPEC; cite docs/method.md §N instead:\n" + "\n".join(bad))


# The container height is L (granwave/report/symbols.py); H was its second name in the docs.
HEIGHT_AS_H = re.compile(r"(?<![\w.\"'\[%])H(?=_e\b|_eff\b|[₁₂²³^]|\s*[−=<>/)]|\s+d\b|\.$)")


def height_written_h(lines) -> list[str]:
    return [f"{where}: {text.strip()}" for where, text in lines
            if where.split(":")[0].endswith(".md") and not where.startswith("docs/decisions/")
            and HEIGHT_AS_H.search(text)]


def test_height_is_written_l_in_docs_and_help(sources, helps):
    demo = [("a.md:1", "V = L1 H d̄ and 1/H."), ("a.md:2", "J. H. Snoeijer, %H:%M, s[\"H\"], HDF5, L = 25 d")]
    assert height_written_h(demo) == ["a.md:1: V = L1 H d̄ and 1/H."]
    bad = height_written_h(sources) + [f"{w}: {t.strip()}" for w, t in helps if HEIGHT_AS_H.search(t)]
    assert not bad, "the height is L (symbol table), not H:\n" + "\n".join(bad)


METHOD_CITATION = re.compile(r"docs/method\.md`?((?:\s*(?:§\d+(?:\s*\([a-z]\))?|,|/|and))+)")


def method_sections() -> set[int]:
    text = (ROOT / "docs/method.md").read_text(encoding="utf-8")
    return {int(n) for n in re.findall(r"^## (\d+)\. ", text, flags=re.M)}


def test_method_page_has_the_fourteen_sections_in_order():
    text = (ROOT / "docs/method.md").read_text(encoding="utf-8")
    numbers = [int(n) for n in re.findall(r"^## (\d+)\. ", text, flags=re.M)]
    assert numbers == list(range(1, 15))


def test_method_citations_name_existing_sections(sources, helps):
    sections = method_sections()
    bad = []
    for where, text in [*sources, *helps]:
        for match in METHOD_CITATION.finditer(text):
            for n in re.findall(r"§(\d+)", match.group(1)):
                if int(n) not in sections:
                    bad.append(f"{where}: §{n}")
    assert not bad, "citations of docs/method.md sections that do not exist:\n" + "\n".join(bad)
    demo = [("x:1", "see docs/method.md §4, §6 (b) and §15")]
    assert [n for _, t in demo for m in METHOD_CITATION.finditer(t)
            for n in re.findall(r"§(\d+)", m.group(1))] == ["4", "6", "15"]


def test_granwave_help_points_to_the_units_page(helps):
    text = "\n".join(t for w, t in helps if w.startswith("granwave --help:"))
    assert "docs/units.md" in text and (ROOT / "docs/units.md").is_file()


# ----------------------------------------------------------------------------- docs/units.md

PREFIX = {"G": 1e9, "M": 1e6, "k": 1e3, "": 1.0, "m": 1e-3, "µ": 1e-6, "n": 1e-9}
SUPERSCRIPT = str.maketrans("⁰¹²³⁴⁵⁶⁷⁸⁹⁻", "0123456789-")
QUANTITY_RE = re.compile(r"^\s*([0-9.]+)(?:\s*×\s*10([⁰¹²³⁴⁵⁶⁷⁸⁹⁻]+))?\s*([GMkmµn]?)(Pa|m/s²|m/s|s|rad/s|N/m|N|g|J)?\s*$")


def si_value(cell: str) -> float:
    """'66.5 GPa' -> 6.65e10; '2.66 × 10¹⁰ m/s²' -> 2.66e10; '0.870' -> 0.87."""
    m = QUANTITY_RE.match(cell)
    assert m, f"cannot read {cell!r}"
    x = float(m.group(1))
    if m.group(2):
        x *= 10.0 ** int(m.group(2).translate(SUPERSCRIPT))
    x *= PREFIX[m.group(3)]
    if m.group(4) == "g":
        x *= 1e-3  # grams to kilograms
    return x


def table_rows(text: str, first_cell: str) -> list[list[str]]:
    """Rows of the Markdown table whose header starts with ``first_cell`` (header excluded)."""
    lines = [line.strip() for line in text.splitlines()]
    start = next(k for k, line in enumerate(lines) if line.startswith(f"| {first_cell} |"))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split("|")])
    return rows


def _printed_matches(printed: float, exact: float) -> bool:
    """Three significant digits: within half a unit of the third digit."""
    return abs(printed - exact) <= 0.5001 * 10.0 ** (math.floor(math.log10(abs(exact))) - 2)


def test_units_page_conversions_follow_from_the_stated_constants():
    text = (ROOT / "docs/units.md").read_text(encoding="utf-8")
    header = next(line for line in text.splitlines() if line.startswith("| unit |"))
    materials = []
    for cell in header.strip("|").split("|")[1:]:
        E, nu, rho = re.search(r"E = ([0-9.]+) GPa, ν = ([0-9.]+), ρ = ([0-9.]+) kg/m³", cell).groups()
        materials.append((float(E) * 1e9, float(nu), float(rho)))
    assert len(materials) == 3
    d = 1e-3  # the table is for a mean diameter of 1 mm
    rows = {r[0]: r[1:] for r in table_rows(text, "unit")}
    for k, (E, nu, rho) in enumerate(materials):
        es = E / (1.0 - nu**2)
        speed = math.sqrt(es / rho)
        exact = {
            "pressure, stress, modulus: E*": es,
            "speed: sqrt(E*/ρ)": speed,
            "time: d̄/sqrt(E*/ρ)": d / speed,
            "angular frequency: sqrt(E*/ρ)/d̄": speed / d,
            "force: E* d̄²": es * d**2,
            "stiffness: E* d̄": es * d,
            "mass: ρ d̄³": rho * d**3,
            "mass of a grain of diameter d̄: ρπd̄³/6": rho * math.pi * d**3 / 6.0,
            "energy: E* d̄³": es * d**3,
            "acceleration: E*/(ρ d̄)": es / (rho * d),
            "η = k_t/k_n for this ν (`--poisson`)": 2.0 * (1.0 - nu) / (2.0 - nu),
        }
        assert set(exact) == set(rows)
        for name, value in exact.items():
            printed = si_value(rows[name][k])
            assert _printed_matches(printed, value), f"{name}, material {k}: {printed} vs {value}"

        pressures = table_rows(text, "reduced p")
        for row in pressures:
            p = 10.0 ** int(row[0].replace("10", "", 1).translate(SUPERSCRIPT))
            assert _printed_matches(si_value(row[1 + k]), p * es)

    # glass-bead lattice speeds (docs/method.md §12), frictionless and frictional
    from granwave.theory import lattice_speed

    es, rho, nu = materials[0][0] / (1 - materials[0][1] ** 2), materials[0][2], materials[0][1]
    speed = math.sqrt(es / rho)
    for row in table_rows(text, "p"):
        p = 10.0 ** int(row[0].replace("10", "", 1).translate(SUPERSCRIPT))
        assert _printed_matches(si_value(row[1]), p * es)
        for col, friction in ((2, False), (4, True)):
            c = float(lattice_speed(p, friction=friction, poisson=nu))
            assert _printed_matches(float(row[col]), c)
            assert _printed_matches(si_value(row[col + 1]), c * speed)


def test_formats_page_is_what_the_schema_writes_now():
    """docs/formats.md is generated from granwave/io/schema.py's tables (so a new dataset, such
    as a contact sub-model's history, appears there): ``python -m granwave.io.schema >
    docs/formats.md`` after changing the schema."""
    from granwave.io.schema import formats_markdown

    assert (ROOT / "docs" / "formats.md").read_text() == formats_markdown() + "\n"
