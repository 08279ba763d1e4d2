"""The package's modules stay small and import without cycles (issue 48).

A static scan of the import statements each module runs when it is imported (module level,
not inside functions) gives the dependency graph; it must have no cycle, and importing the
modules one by one in a fresh interpreter, dependencies first, must work.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import granwave

PACKAGE = Path(granwave.__file__).parent
MAX_LINES = 800

#: Modules allowed above MAX_LINES for now, each with why it is not split yet (none today).
PENDING: dict[str, str] = {}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _imports_at_import_time(tree: ast.Module):
    """Import statements run on import: module level, including under if/try, not in defs."""
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            for field in ("body", "orelse", "finalbody", "handlers"):
                for child in getattr(node, field, []):
                    todo.extend(child.body if isinstance(child, ast.ExceptHandler) else [child])


def _graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps = set()
        for node in _imports_at_import_time(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                base = package
                for _ in range(node.level - 1):
                    base = base.rpartition(".")[0]
                stem = node.module or ""
                root = ".".join(p for p in (base if node.level else "", stem) if p)
                # ``from X import y``: y a submodule of X if there is one, else a name of X
                targets = [f"{root}.{a.name}" if f"{root}.{a.name}" in modules else root for a in node.names]
            deps.update(t for t in targets if t in modules and t != name)
        graph[name] = deps
    return graph


def _order(graph: dict[str, set[str]]) -> list[str]:
    """Dependencies first; raises AssertionError naming a cycle if there is one."""
    order, state = [], {}

    def visit(m, stack):
        if state.get(m) == "done":
            return
        if state.get(m) == "open":
            cycle = stack[stack.index(m):] + [m]
            raise AssertionError("import cycle: " + " -> ".join(cycle))
        state[m] = "open"
        for d in sorted(graph[m]):
            visit(d, stack + [m])
        state[m] = "done"
        order.append(m)

    for m in sorted(graph):
        visit(m, [])
    return order


def test_no_module_over_the_line_limit():
    too_long = {}
    for path in PACKAGE.rglob("*.py"):
        rel = str(path.relative_to(PACKAGE.parent))
        n = len(path.read_text().splitlines())
        if n > MAX_LINES and rel not in PENDING:
            too_long[rel] = n
    assert too_long == {}


def test_pending_list_is_current():
    """A pending module that got split must leave the list."""
    for rel in PENDING:
        path = PACKAGE.parent / rel
        assert path.exists() and len(path.read_text().splitlines()) > MAX_LINES, rel


def test_the_scan_sees_a_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}
    try:
        _order(graph)
    except AssertionError as e:
        assert "a -> b -> c -> a" in str(e)
    else:
        raise AssertionError("cycle not found")


def test_modules_import_without_cycles():
    modules = _modules()
    order = _order(_graph(modules))  # raises on a static cycle
    # the GPU modules need numba.cuda; __main__ runs the CLI
    names = [m for m in order if not m.startswith("granwave.gpu") and m != "granwave.__main__"]
    code = "import importlib, sys\nfor m in sys.argv[1:]:\n    importlib.import_module(m)\n"
    r = subprocess.run([sys.executable, "-c", code, *names], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]


#: The engine's named state (granwave.dem.layout): read by field, never by a numbered slot.
_SLOT = (r"\b(fpar|ipar|piston|out|fpar1|piston1)\[\s*(K\.|layout\.)?[FIPO]_[A-Z_]+\s*\]|\b(fpar|ipar)\["
         r"|\bws\[\s*(K\.)?W_[A-Z]+\s*\]|\bws\[[0-9]+\]")


def test_kernels_index_no_parameter_array_by_number():
    """The engine's parameters, counters, piston and statistics are numpy records
    (granwave.dem.layout) and its workspace a named tuple (granwave.dem.workspace.Workspace),
    read by field name; no module of the package indexes them by a slot constant (F_*, I_*,
    P_*, O_*, W_*) or a number, and layout defines no such constant."""
    import re

    from granwave.dem import layout

    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if re.search(_SLOT, line):
                found.append(f"{path.relative_to(PACKAGE.parent)}:{n}: {line.strip()}")
    assert found == []
    assert not [name for name in vars(layout) if re.fullmatch(r"[FIPON]_[A-Z_]+", name)]
    from granwave.dem import workspace
    assert not [name for name in vars(workspace) if re.fullmatch(r"W_[A-Z]+", name)]
    for dtype in (layout.PARAMS, layout.COUNTERS, layout.PISTON, layout.OUT):
        assert dtype.names and len(set(dtype.names)) == len(dtype.names)


def _all_imports(tree: ast.Module, name: str, package: str, modules: dict) -> set[str]:
    """The package's modules a module imports anywhere (function bodies too)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("granwave"))
        elif isinstance(node, ast.ImportFrom):
            base = package
            for _ in range(node.level - 1):
                base = base.rpartition(".")[0]
            root = ".".join(p for p in (base if node.level else "", node.module or "") if p)
            out.update(f"{root}.{a.name}" if f"{root}.{a.name}" in modules else root for a in node.names)
    return {m for m in out if m.startswith("granwave") and m != name}


#: (importer prefix, imported prefix, why the importer must not): the layers' direction. The GPU
#: is a plug-in that granwave.devices loads by name; the report sits below the figures (which
#: format their numbers with it); the in-memory model below the files that read and write it.
LAYERS = (
    ("granwave", "granwave.gpu", "only granwave.devices picks a device's kernels (by name)"),
    ("granwave.gpu", "granwave.api", "the GPU kernels sit below the library API"),
    ("granwave.report", "granwave.figures", "the figures use the report's numbers, not the reverse"),
    ("granwave.model", "granwave.io", "the files read and write the model, not the reverse"),
)

#: Modules above both sides of a rule, with why: granwave.gpu.checks runs whole stages through
#: the library API on both devices and compares them (a harness, not a kernel module).
ABOVE = {"granwave.gpu.checks": "granwave.api"}


def _within(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def test_imports_point_down_the_layers():
    """No module imports against the layers of :data:`LAYERS`, not even inside a function
    (a lazy import hides a dependency but keeps it)."""
    modules = _modules()
    # the scan sees an import inside a function, relative or absolute
    lazy = ast.parse("def f():\n    from .gpu import batch\n    import granwave.figures.common\n")
    assert _all_imports(lazy, "granwave.api", "granwave", modules) == {"granwave.gpu.batch",
                                                                      "granwave.figures.common"}
    bad = []
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for target in _all_imports(ast.parse(path.read_text()), name, package, modules):
            for importer, imported, why in LAYERS:
                if (_within(name, importer) and _within(target, imported) and not _within(name, imported)
                        and name != "granwave.devices" and not _within(target, ABOVE.get(name, "-"))):
                    bad.append(f"{name} imports {target}: {why}")
    assert not bad, "\n".join(sorted(bad))
