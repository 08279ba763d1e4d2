"""The names of the sub-models and their parameters against the identifiers of the package.

A sub-model is chosen by its name and set by its parameters' names everywhere through generic
code (the options, the file attributes, the engine's record), so no module of granwave outside
granwave/contact_models/ names one: a name that an identifier elsewhere already uses would
either be such a naming or read as one. The generator (:mod:`.generate`) refuses a registry
whose names collide, naming the collision; tests/test_contact_registry.py runs the same check.

The rule, for every ``.py`` file under granwave/ except granwave/contact_models/, parsed with
``ast``: no identifier (a name, attribute, function, class, argument, keyword, imported name or
module) has among its ``_``-separated words (case-insensitive) the words of a sub-model's name in
a row (``cone`` in ``on_cone``; ``linear_history`` in ``linear_history_k``), nor the name or
option of a kind that can be off (rolling), nor is a parameter's name or a history dataset's
name (harmonic_stiffness, rolling_displacement, ...); and no string that is not a docstring
equals (up to case and surrounding blanks) one of those. Comments and docstrings may name them
(they document). The normal kind's option (``contact_law``) and the dispatchers' generic names
may appear: every engine has a normal law. Exceptions, by file, where "hertz" is Hertz's theory
and not the engine's choice of law (:data:`THEORY`).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

#: the package's folder
PACKAGE = Path(__file__).resolve().parent.parent

#: files that use "hertz" for Hertz's theory, not for the engine's contact law: the analytic
#: Hertzian chains and lattices' stiffness model (systems, params' ChainParams.hertz, api's
#: chain, the linear check's reference lattice), the effective-medium exponent p^(1/3) of the
#: shear scene and its report, figure and table, the closed forms of theory.py (the Hertzian
#: chain's solitary wave)
THEORY = {"granwave/theory.py": {"hertz"}, "granwave/systems.py": {"hertz"}, "granwave/params.py": {"hertz"}, "granwave/api.py": {"hertz"},
          "granwave/linear/check.py": {"hertz"}, "granwave/analysis/shear_scene.py": {"hertz"},
          "granwave/report/shear.py": {"hertz"}, "granwave/figures/shear.py": {"hertz"},
          "granwave/report/tables.py": {"hertz"}}


def _words(name: str) -> tuple:
    return tuple(w for w in name.lower().split("_") if w)


def _has_run(words: tuple, run: tuple) -> bool:
    """Whether ``run`` occurs in ``words`` as consecutive words."""
    n = len(run)
    return any(words[k:k + n] == run for k in range(len(words) - n + 1))


@functools.lru_cache(maxsize=512)  # the package's modules are parsed once per process
def identifiers(source: str) -> tuple[tuple[int, str, str], ...]:
    """(line, "identifier" or "string", text) of every identifier and every string that is not a
    docstring in ``source`` (the rule of the module docstring)."""
    tree = ast.parse(source)
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and n.body
            and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    out = []
    for node in ast.walk(tree):
        ids = []
        if isinstance(node, ast.Name):
            ids.append(node.id)
        elif isinstance(node, ast.Attribute):
            ids.append(node.attr)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            ids.append(node.name)
        elif isinstance(node, ast.arg):
            ids.append(node.arg)
        elif isinstance(node, ast.keyword) and node.arg:
            ids.append(node.arg)
        elif isinstance(node, ast.alias):
            ids += node.name.split(".") + ([node.asname] if node.asname else [])
        elif isinstance(node, ast.ImportFrom) and node.module:
            ids += node.module.split(".")
        out += [(node.lineno, "identifier", name) for name in ids]
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            out.append((node.lineno, "string", node.value))
    return tuple(out)


def named(source: str, names, whole, allowed=frozenset()) -> list[tuple[int, str, str, str]]:
    """Where ``source`` uses one of ``names`` (matched as a run of words) or ``whole`` (matched as
    an entire identifier): (line, "identifier"/"string", its text, the name it uses); ``allowed``:
    names this file may use (:data:`THEORY`)."""
    runs = {n: _words(n) for n in names if n not in allowed}
    whole = set(whole) - set(allowed)
    found = []
    for line, what, text in identifiers(source):
        if what == "identifier":
            words = _words(text)
            hits = [n for n, run in runs.items() if _has_run(words, run)] + ([text] if text in whole else [])
        else:
            key = text.strip().lower()
            hits = [n for n in runs if key == n.lower()] + [n for n in whole if key == n.lower()]
        found += [(line, what, text, n) for n in hits]
    return found


@functools.lru_cache(maxsize=None)
def _sources() -> tuple:
    """(relative path, source) of every module of the package outside contact_models/."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).as_posix()
        if not rel.startswith("granwave/contact_models/"):
            out.append((rel, path.read_text()))
    return tuple(out)


def collisions(names, whole, sources=None) -> list[str]:
    """One line per collision of the sub-model (and off) names ``names`` and the parameter and
    dataset names ``whole`` with an identifier or string of the package (module docstring), e.g.
    ``the name 'cone' collides with the identifier CONE0 (granwave/dem/pulse_kernels.py line 33)``.
    ``sources``: (path, text) pairs to check instead of the package's modules."""
    lines = []
    for rel, text in (_sources() if sources is None else sources):
        for line, what, found, name in named(text, names, whole, THEORY.get(rel, set())):
            lines.append(f"the name {name!r} collides with the {what} {found!r} ({rel} line {line}): "
                         "rename one of them")
    return lines
