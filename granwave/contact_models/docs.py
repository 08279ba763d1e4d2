"""The docs' lists and tables of the contact sub-models, written from the registry.

Each is a span ``<!-- gen:NAME -->text<!-- /gen -->`` in the docs (the markers of
tests/test_generated_docs.py), rewritten by ``python -m granwave.contact_models.generate``;
tests/test_contact_registry.py fails when one is not what the registry gives now:

- ``contact-names KIND``: the names a kind's option accepts, the default first (prose);
- ``contact-submodels``: one row per sub-model: kind and option, name, what it is (its
  ``SUMMARY``), its own parameters (default, units), the devices it runs on, its LAMMPS
  equivalent;
- ``contact-parameters``: one row per parameter (the kinds' and the sub-models'): option,
  default, units, range, meaning;
- ``contact-lammps``: one row per sub-model: the words ``export lammps`` writes for it with the
  other kinds at their defaults (granwave.contact_models.models.lammps_words), or why it has none
  (its ``NO_LAMMPS``, or the refusal of that combination).
"""

from __future__ import annotations

import re
from pathlib import Path

from . import options as O

ROOT = Path(__file__).resolve().parents[2]
#: the documents that hold spans of this module
DOCUMENTS = ("docs/dem.md", "docs/method.md", "docs/interop.md")
SPAN = re.compile(r"(<!-- gen:(?P<name>contact-[^>]*?) -->)(?P<text>.*?)(<!-- /gen -->)", re.S)


def _option(name: str) -> str:
    return "--" + name.replace("_", "-")


def _range(p: dict) -> str:
    lo, hi = p["lo"], p["hi"]
    parts = ([f"{'>' if p['lo_open'] else '≥'} {lo:g}"] if lo is not None else []) + \
        ([f"{'<' if p['hi_open'] else '≤'} {hi:g}"] if hi is not None else [])
    return ", ".join(parts) or "any"


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|")


def names_text(kind: str) -> str:
    """`default` (default), `other`, ...: the names an option of ``kind`` accepts."""
    k = O.KINDS[kind]
    out = []
    for n in O.names(kind):
        out.append(f"`{n}`" + (" (default)" if n == k["default"] else ""))
    return ", ".join(out)


def submodels_table() -> str:
    rows = ["| kind (option) | name | what it is | its parameters | devices | LAMMPS |", "|---|---|---|---|---|---|"]
    for name, s in O.SUBMODELS.items():
        k = O.KINDS[s["kind"]]
        params = ", ".join(f"`{_option(p)}` ({O.PARAMETERS[p]['default']:g}"
                           f"{' ' + O.PARAMETERS[p]['units'] if O.PARAMETERS[p]['units'] else ''})"
                           for p in s["parameters"]) or "—"
        default = " (default)" if name == k["default"] else ""
        lammps = "yes" if s["lammps"] is None else f"none: {s['lammps']}"
        rows.append(f"| {s['kind']} (`{_option(k['option'])}`) | `{name}`{default} | {_cell(s['summary'])} | "
                    f"{params} | {', '.join(s['devices'])} | {_cell(lammps)} |")
    return "\n".join(rows)


def parameters_table() -> str:
    rows = ["| option | default | units | range | meaning |", "|---|---|---|---|---|"]
    for kind, k in O.KINDS.items():
        rows.append(f"| `{_option(k['option'])}` | `{k['default']}` | | {', '.join(f'`{n}`' for n in O.names(kind))} "
                    f"| {_cell(k['help'])} (its sub-models: docs/dem.md, \"How to add a contact model\") |")
        for n, p in O.ALL_PARAMETERS.items():
            if p["kind"] == kind:
                whose = f" (`{p['submodel']}`)" if "submodel" in p else ""
                rows.append(f"| `{_option(n)}`{whose} | {p['default']:g} | {p['units'] or '—'} | {_range(p)} | "
                            f"{_cell(p['help'])} |")
    return "\n".join(rows)


def lammps_table() -> str:
    from . import models as M

    rows = ["| sub-model | `export lammps` writes (pair, at the defaults) |", "|---|---|"]
    for name, s in O.SUBMODELS.items():
        k = O.KINDS[s["kind"]]
        if s["lammps"] is not None:
            rows.append(f"| `{name}` | none: {_cell(s['lammps'])} |")
            continue
        values = O.values_of({k["option"]: name})
        try:
            words, fragments, fixed = M.lammps_words(values, O.KIND_PARAMETERS["friction"]["default"],
                                                     O.KIND_PARAMETERS["poisson"]["default"],
                                                     O.KIND_PARAMETERS["damping"]["default"])
        except ValueError as e:  # this combination has none (the refusal export lammps prints)
            rows.append(f"| `{name}` | none with the other defaults: {_cell(e)} |")
            continue
        text = " ".join([fixed("pair"), *fragments])
        text = re.sub(r"(?<![\w.])-?\d+\.\d+(e-?\d+)?", lambda m: f"{float(m.group(0)):.4g}", text)
        rows.append(f"| `{name}` | `{text}` |")
    return "\n".join(rows)


def span_text(name: str) -> str:
    """The text of the span ``name`` (module docstring); ValueError for an unknown one."""
    if name.startswith("contact-names "):
        kind = name.split(" ", 1)[1]
        if kind not in O.KINDS:
            raise ValueError(f"unknown kind {kind!r} in <!-- gen:{name} -->")
        return names_text(kind)
    tables = {"contact-submodels": submodels_table, "contact-parameters": parameters_table,
              "contact-lammps": lammps_table}
    if name not in tables:
        raise ValueError(f"unknown generated span <!-- gen:{name} -->")
    return "\n" + tables[name]() + "\n"


def outputs(root: Path = ROOT) -> dict:
    """path -> its text with every span of this module rewritten (documents that exist)."""
    out = {}
    for doc in DOCUMENTS:
        path = root / doc
        if path.is_file():
            text = path.read_text()
            out[path] = SPAN.sub(lambda m: m.group(1) + span_text(m.group("name")) + m.group(4), text)
    return out
