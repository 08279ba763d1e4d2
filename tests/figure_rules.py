"""The rules every figure follows (issue 62), checked on the matplotlib Figure a figure function
saves: a title with its scene, p, L and n where they apply; units on every axis; no empty panel;
legend numbers by the report's number rule; every symbol of its labels defined once
(granwave.report.symbols). Used by tests/test_plots.py, test_continuum.py, test_shear_scene.py."""

from __future__ import annotations

import re

import numpy as np

from granwave.report.numbers import fmt
from granwave.report.symbols import plain_text, undefined_symbols

_PM = re.compile(r"(?<![\w.])(-?\d+(?:\.\d+)?) ± (\d+(?:\.\d+)?)(?![\w.])")


def capture(monkeypatch) -> list:
    """Record every Figure a granwave figure function saves (the files are still written)."""
    import importlib
    import pkgutil

    import granwave.figures as F
    from granwave.figures import common

    seen, real = [], common.save_figure

    def keep(fig, path, **kw):
        seen.append(fig)
        return real(fig, path, **kw)

    for info in pkgutil.iter_modules(F.__path__):
        mod = importlib.import_module(f"granwave.figures.{info.name}")
        if hasattr(mod, "save_figure"):
            monkeypatch.setattr(mod, "save_figure", keep)
    return seen


def texts(fig) -> dict[str, list[str]]:
    """The figure's words: titles, axis labels, legend entries (plain text, mathtext undone)."""
    out = {"title": [fig._suptitle.get_text()] if fig._suptitle else [], "axis": [], "legend": []}
    for ax in fig.get_axes():
        out["title"].append(ax.get_title())
        out["axis"] += [ax.get_xlabel(), ax.get_ylabel()]
        leg = ax.get_legend()
        if leg is not None:
            out["legend"] += [t.get_text() for t in leg.get_texts()]
            if leg.get_title().get_text():
                out["legend"].append(leg.get_title().get_text())
    return {k: [plain_text(t) for t in v if t] for k, v in out.items()}


def number_problems(text: str) -> list[str]:
    """Every "value ± error" of ``text`` off the rule of granwave.report.numbers.fmt: the error
    to one significant digit (two when it starts with 1) and the value to the same decimal
    place. Read back from the printed digits (0.0096 prints as 0.01, so "0.16 ± 0.01" is right);
    an error of three or more digits, or a value with more or fewer decimals, is not."""
    bad = []
    for m in _PM.finditer(text):
        v, e = m.group(1), m.group(2)
        dec = (lambda x: len(x.split(".")[1]) if "." in x else 0)
        digits = e.replace(".", "").lstrip("0")
        ok = dec(v) == dec(e) and (len(digits) == 1 or (len(digits) == 2 and digits[0] == "1")
                                   or (digits.endswith("0") and len(digits.rstrip("0")) <= 2))
        if not ok:
            bad.append(f"{m.group(0)!r} (the rule: {fmt(float(v), float(e))!r})")
    return bad


def _has_data(ax) -> bool:
    for line in ax.get_lines():
        y = np.asarray(line.get_ydata(), float)
        if y.size and np.isfinite(y).any():
            return True
    return bool(ax.collections or ax.patches or ax.images)


def check(fig, *, scene: str | None = None, pressure: bool = True, height: bool = True,
          count: bool = True) -> None:
    """Assert the rules on one figure; ``scene`` the name its title must carry (None: any),
    ``pressure``/``height``/``count``: whether its title must give p, L, n."""
    words = texts(fig)
    title = " ".join(words["title"])
    assert title.strip(), "no title"
    for want, part in ((scene, scene), (pressure, "p = "), (height, "L = "), (count, "n = ")):
        if want:
            assert part in title, f"the title does not give {part!r}: {title!r}"
    for ax in fig.get_axes():
        polar = ax.name == "polar"
        if not polar:
            for label, ticks, axis in ((ax.get_xlabel(), ax.get_xticklabels(), ax.xaxis),
                                       (ax.get_ylabel(), ax.get_yticklabels(), ax.yaxis)):
                if not axis.get_visible():
                    continue
                if label:
                    assert "[" in label and "]" in label, f"no unit on the axis {label!r}"
                elif any(t.get_visible() and t.get_text() for t in ticks):
                    assert _is_colorbar(ax) and (ax.get_xlabel() or ax.get_ylabel()), \
                        f"an axis with numbers but no label ({ax.get_title()!r})"
        if not _is_colorbar(ax):
            assert _has_data(ax), f"an empty panel ({ax.get_title()!r})"
    bad = [p for t in words["legend"] + words["title"] for p in number_problems(t)]
    assert not bad, "numbers off the rule: " + "; ".join(bad)
    undefined = set().union(*(undefined_symbols(t) for v in words.values() for t in v))
    assert not undefined, f"symbols the symbol table does not define: {sorted(undefined)}"


def _is_colorbar(ax) -> bool:
    return getattr(ax, "_colorbar", None) is not None or ax.get_label() == "<colorbar>"
