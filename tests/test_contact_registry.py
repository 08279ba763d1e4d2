"""The contact sub-models' registry (granwave.contact_models): one line per sub-model.

What it guarantees: adding a sub-model of an existing kind touches its own module, one line of
granwave/contact_models/registry.py and its tests; ``python -m granwave.contact_models.generate``
then rewrites the generated ``_table.py`` and ``_dispatch.py``. Checked here:

- the generated files equal what the generator writes now (so a stale one fails);
- the static rule below: no module of granwave outside granwave/contact_models/ names a
  sub-model or its parameters;
- the derived things follow the registry: PrepareParams' fields (hence prepare-packing's
  options), the engine's parameter record, the file attributes.

The static rule (``_named``): in every ``.py`` file under granwave/ except granwave/contact_models/,
parsed with ``ast``, no identifier (a name, attribute, function, class, argument, keyword,
imported name or module) has as one of its ``_``-separated words (case-insensitive) a registered
sub-model's name (hertz, harmonic, sds) or the name or option of a kind that can be off (rolling),
and is not a parameter's name or a history's dataset name (harmonic_stiffness,
rolling_stiffness, rolling_displacement, ...); and no string that is not a docstring equals (up
to case and surrounding blanks) one of those. Comments and docstrings may name them (they
document). The normal kind's option (``contact_law``) and the dispatchers' generic names may
appear: every engine has a normal law, and a new law of that kind needs no change there.
Exceptions, by file, where "hertz" is Hertz's theory and not the engine's choice of law
(:data:`THEORY`).
"""

from __future__ import annotations

import ast
import dataclasses
import types
from pathlib import Path

import pytest

from granwave.contact_models import generate as G
from granwave.contact_models import options as CO
from granwave.errors import InputError

ROOT = Path(__file__).resolve().parent.parent / "granwave"

#: files that use "hertz" for Hertz's theory, not for the engine's contact law: the analytic
#: Hertzian chains and lattices' stiffness model (systems, params' SystemsParams.hertz, api's
#: build_system, the linear check's reference lattice), the effective-medium exponent p^(1/3) of
#: the shear scene and its report, figure and table
THEORY = {"granwave/systems.py": {"hertz"}, "granwave/params.py": {"hertz"}, "granwave/api.py": {"hertz"},
          "granwave/linear/check.py": {"hertz"}, "granwave/analysis/shear_scene.py": {"hertz"},
          "granwave/report/shear.py": {"hertz"}, "granwave/figures/shear.py": {"hertz"},
          "granwave/report/tables.py": {"hertz"}}


def _banned() -> tuple[set, set]:
    """(words banned inside identifiers, whole names banned)."""
    words = set(CO.SUBMODELS) | {k for k, v in CO.KINDS.items() if v["off"] is not None} | \
        {v["option"] for v in CO.KINDS.values() if v["off"] is not None}
    return words, set(CO.PARAMETERS) | set(CO.history_datasets())


def _named(source: str, allowed: set = frozenset()) -> list[str]:
    """Where ``source`` names a sub-model or its parameters (the module docstring's rule)."""
    words, whole = _banned()
    words -= allowed
    tree = ast.parse(source)
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and n.body
            and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    found = []
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
        for name in ids:
            if set(name.lower().split("_")) & words or name in whole:
                found.append(f"line {node.lineno}: identifier {name}")
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            text = node.value.strip().lower()
            if text in words or text in whole:
                found.append(f"line {node.lineno}: string {node.value!r}")
    return found


def test_generated_files_are_current():
    """_table.py and _dispatch.py are what ``python -m granwave.contact_models.generate`` writes."""
    for path, text in G.outputs().items():
        assert path.read_text() == text, f"{path.name} is stale: run python -m granwave.contact_models.generate"


def test_no_module_outside_contact_models_names_a_sub_model():
    offenders = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).as_posix()
        if rel.startswith("granwave/contact_models/"):
            continue
        offenders += [f"{rel}: {x}" for x in _named(path.read_text(), THEORY.get(rel, set()))]
    assert not offenders, "\n".join(offenders)


@pytest.mark.parametrize("code", [
    'if p.rolling != "none":\n    pass',
    "from granwave.contact_models import rolling",
    "x = CM.harmonic.force",
    "Engine(pos, rad, lat, h, harmonic_stiffness=0.1)",
    'attrs.get("rolling_friction", 0.0)',
    "def _add_rolling_blocks(b):\n    return b",
    "k = params['SDS']",
])
def test_the_rule_finds_a_named_sub_model(code):
    """The rule is not empty: each of these names a sub-model or a parameter (and would fail)."""
    assert _named(code)


def test_the_rule_lets_generic_code_and_docs_through():
    code = ('"""Rolling resistance and the harmonic law are documented here."""\n'
            "for kind, k in CO.KINDS.items():\n    name = values[k['option']]  # e.g. rolling: sds\n"
            "x = CD.contact_couple(couple, 0.0)\ny = p.contact_law\n")
    assert _named(code) == []


def test_prepare_params_fields_are_the_registry_s():
    """Every kind's option and every sub-model parameter is a PrepareParams field (so an option of
    prepare-packing and a file attribute) with the declared default, units and range."""
    from granwave.params import PrepareParams

    fields = {f.name: f for f in dataclasses.fields(PrepareParams)}
    for kind, k in CO.KINDS.items():
        f = fields[k["option"]]
        assert f.default == k["default"] and f.metadata["choices"] == CO.names(kind)
    for name, p in CO.PARAMETERS.items():
        f = fields[name]
        assert f.default == p["default"] and f.type == "float"
        assert all(f.metadata[key] == p[key] for key in ("units", "lo", "lo_open", "hi", "hi_open"))


def test_engine_parameters_hold_each_kind_s_code_and_constants():
    from granwave.dem.layout import PARAMS

    for kind, k in CO.KINDS.items():
        assert PARAMS.fields[f"{kind}_code"][0].kind == "i"
        # generated names, or the engine's older ones the kind declares (damping: zeta, tangential: mu)
        assert len(k["fields"]) == k["slots"] and all(f in PARAMS.names for f in k["fields"])
        assert k["fields"] == tuple(f"{kind}_c{i}" for i in range(k["slots"])) or kind in ("damping", "tangential")


def test_a_selection_goes_through_the_file_attributes_and_back():
    values = CO.values_of(dict(contact_law="harmonic", harmonic_stiffness=0.03, rolling="sds",
                               rolling_stiffness=0.02, rolling_damping=0.005, rolling_friction=0.2))
    attrs = CO.attrs_of(values)
    assert attrs == dict(contact_law="harmonic", harmonic_stiffness=0.03, rolling="sds", rolling_stiffness=0.02,
                         rolling_damping=0.005, rolling_friction=0.2)
    assert CO.values_of_attrs(attrs) == values
    # the defaults: files as before the sub-models (the normal law always recorded)
    assert CO.attrs_of(CO.defaults()) == dict(contact_law=CO.KINDS["normal"]["default"])
    assert CO.attrs_of(CO.defaults(), recorded=False) == {}
    assert CO.values_of_attrs({}) == CO.defaults()


def test_checks_come_from_the_declarations():
    with pytest.raises(ValueError, match="unknown contact law 'hooke'"):
        CO.check(CO.values_of(dict(contact_law="hooke")))
    with pytest.raises(ValueError, match="rolling_stiffness must be > 0"):
        CO.check(CO.values_of(dict(rolling="sds", rolling_stiffness=0.0)))
    with pytest.raises(ValueError, match="needs friction > 0"):
        CO.check(CO.values_of(dict(rolling="sds")), friction=0.0)
    # a parameter of a sub-model that is not selected is not checked (as before the registry)
    assert CO.check(CO.values_of(dict(rolling_stiffness=0.0))) == {"normal": "hertz", "damping": "critical_fraction",
                                                                     "tangential": "mindlin", "rolling": None}
    # the kinds' own parameters, where a selection holds them
    with pytest.raises(ValueError, match="poisson must be >= 0 and < 0.5"):
        CO.check(CO.resolve(dict(poisson=0.5)))
    with pytest.raises(TypeError, match="'rolling_stifness'"):
        CO.resolve(dict(rolling_stifness=1.0))


def test_a_new_sub_model_is_one_more_branch_of_the_generated_dispatchers(monkeypatch):
    """A third normal law registered (a stand-in module here) gets code 2, its branch in every
    normal dispatcher, its parameter in the table; nothing else changes in the generated text."""
    from granwave.contact_models import harmonic
    from granwave.contact_models.declare import Parameter

    fake = types.SimpleNamespace(**{k: getattr(harmonic, k) for k in dir(harmonic) if not k.startswith("__")})
    fake.NAME, fake.__name__ = "stiffer", "granwave.contact_models.stiffer"
    fake.PARAMETERS = (Parameter("stiffer_stiffness", 2.0, "E* d", "k of the stand-in law.", lo=0.0),)
    before = G.dispatch_source()
    monkeypatch.setattr(G, "modules", lambda real=G.modules: [*real(), fake])
    after = G.dispatch_source()
    assert "from . import stiffer as _normal_stiffer" in after
    for fn, name, _, _, _ in G.KINDS[0].functions:
        assert f"def {name}(" in after
        assert f"    if model.code == 2:\n        return _normal_stiffer.{fn}(" in after
    assert after.count("model.code == 2") == len(G.KINDS[0].functions)
    assert len(after.splitlines()) > len(before.splitlines())
    table = G.table_source()
    assert "'stiffer_stiffness': {'submodel': 'stiffer'" in table


def test_the_normal_kind_s_default_must_come_first(monkeypatch):
    """Code 0 of the normal kind is its default (the dispatchers' fall-through and the tile law's
    vector loop of contact.py's formulas rely on it): registering another law first is refused."""
    real = G.modules()
    monkeypatch.setattr(G, "modules", lambda: [real[1], real[0], *real[2:]])
    with pytest.raises(ValueError, match="default 'hertz' first"):
        G.dispatch_source()


def _stand_in(real, name: str, parameters: tuple, **formulas):
    """A stand-in sub-model: ``real``'s declarations under another name, with its own parameters
    and formulas."""
    fake = types.SimpleNamespace(**{k: getattr(real, k) for k in dir(real) if not k.startswith("__")})
    fake.NAME, fake.__name__, fake.PARAMETERS = name, f"granwave.contact_models.{name}", parameters
    for k, v in formulas.items():
        setattr(fake, k, v)
    return fake


@pytest.mark.parametrize("kind_name, real_name, name, parameter", [
    # LAMMPS's ``damping velocity``: a constant coefficient
    ("damping", "damping_critical", "velocity", "velocity_coefficient"),
    # LAMMPS's ``tangential linear_history``: a constant k_t
    ("tangential", "mindlin", "linear_history", "linear_history_stiffness"),
])
def test_a_second_damping_or_tangential_law_is_one_more_branch_of_every_dispatcher(monkeypatch, kind_name,
                                                                                    real_name, name, parameter):
    """A second damping (or tangential) law registered (a stand-in module) gets code 1, its branch in
    every dispatcher of its kind (the engines' contact routine, the tile law's general path, the
    GPU's device copies and the time step all call these), its parameter in the table and so a
    PrepareParams field; the other kinds' dispatchers are unchanged."""
    import importlib

    from granwave.contact_models.declare import Parameter

    real = importlib.import_module(f"granwave.contact_models.{real_name}")
    kind = next(k for k in G.KINDS if k.name == kind_name)
    fake = _stand_in(real, name, (Parameter(parameter, 1.0, "E* d", "the stand-in's constant.", lo=0.0),))
    before = G.dispatch_source()
    monkeypatch.setattr(G, "modules", lambda real=G.modules: [*real(), fake])
    after = G.dispatch_source()
    alias = f"_{kind_name}_{name}"
    assert f"from . import {name} as {alias}" in after
    for fn, dispatcher, _, _, _ in kind.functions:
        body = after.split(f"def {dispatcher}(", 1)[1].split("\n\n\n", 1)[0]
        assert f"    if model.code == 1:\n        return {alias}.{fn}(" in body
        assert f"return _{kind_name}_{real.NAME}.{fn}(" in body  # the default: the fall-through
    assert after.count(f"return {alias}.") == len(kind.functions)
    # nothing else changes: the new lines are its import, its branches and its device functions
    added = set(after.splitlines()) - set(before.splitlines())
    assert all(alias in line or line == "    if model.code == 1:" for line in added)
    table = {}
    exec(G.table_source(), table)
    assert table["SUBMODELS"][name]["kind"] == kind_name and table["SUBMODELS"][name]["code"] == 1
    assert table["PARAMETERS"][parameter]["submodel"] == name and table["PARAMETERS"][parameter]["kind"] == kind_name


def test_the_kinds_parameters_are_fields_and_engine_constants():
    """friction, poisson (the tangential kind's) and damping (the damping kind's) are declared once:
    PrepareParams' fields (options of prepare-packing, file attributes) with their meanings and
    defaults as before the kinds, and the engine record's constants of the kinds."""
    from granwave.contact_models import models as CM
    from granwave.dem.layout import PARAMS, record
    from granwave.params import LatticeParams, PrepareParams

    fields = {f.name: f for f in dataclasses.fields(PrepareParams)}
    assert (fields["friction"].default, fields["poisson"].default, fields["damping"].default) == (0.5, 0.0, 0.5)
    assert fields["damping"].metadata["hi"] == 1.0 and fields["poisson"].metadata["hi_open"]
    assert {f.name: f.default for f in dataclasses.fields(LatticeParams)}["friction"] == 0.0
    assert CO.KINDS["tangential"]["parameters"] == ("friction", "poisson")
    assert CO.KINDS["damping"]["parameters"] == ("damping",)
    fpar = record(PARAMS)
    CM.fill_params(fpar, CO.resolve(dict(friction=0.3, damping=0.2, poisson=0.1)))
    assert (fpar.mu, fpar.zeta, fpar.damping_code, fpar.tangential_code) == (0.3, 0.2, 0, 0)
    assert CM.damping_model(0.2) == (0, 0.2) and CM.tangential_model(0.3) == (0, 0.3)
    with pytest.raises(InputError, match=r"damping must be in \[0, 1\], got 1.5"):
        PrepareParams(damping=1.5)


def test_the_default_damping_and_tangential_laws_are_contact_py_s_formulas():
    """Through their dispatchers, the defaults evaluate contact.py's own formulas (the tile law's
    vector loops call those directly for code 0): the same bits."""
    from granwave import contact as C
    from granwave.contact_models import _dispatch as CD

    damping, tangential = CD.DampingModel(0, 0.3), CD.TangentialModel(0, 0.4)
    for m, k, n in [(0.5, 2e-3, 1e-3), (0.3, 0.7, 0.02)]:
        assert CD.dashpot_coefficient(damping, m, k, n) == C.damping_coefficient(0.3, m, k)
        assert CD.dashpot_acts(damping) and not CD.dashpot_acts(CD.DampingModel(0, 0.0))
        assert CD.dashpot_step_ratio(damping) == 0.3
        assert CD.tangential_spring(tangential, k, n) == k
    assert CD.friction_acts(tangential) and not CD.friction_acts(CD.TangentialModel(0, 0.0))
    for old, new, rescale in [(2e-3, 1e-3, True), (1e-3, 2e-3, True), (2e-3, 1e-3, False)]:
        assert CD.tangential_unloads(tangential, old, new, rescale) == C.unloads(old, new, rescale)
    for f, s in [((1e-4, -2e-4, 0.0), (1e-3, 0.0, 2e-3)), ((1e-2, 0.0, 0.0), (1.0, 1.0, 0.0))]:  # sticks, slides
        assert CD.tangential_increment(tangential, *f, *s, 0.05, 0.01) == C.increment_and_cap3(*f, *s, 0.05, 0.01, 0.4)
    assert CD.tangential_increment(tangential, 1e-2, 0.0, 0.0, 1.0, 1.0, 0.0, 0.05, 0.01)[3]
