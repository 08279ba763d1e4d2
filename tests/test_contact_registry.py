"""The contact sub-models' registry (granwave.contact_models): one line per sub-model.

What it guarantees: adding a sub-model of an existing kind touches its own module, one line of
granwave/contact_models/registry.py and its tests; ``python -m granwave.contact_models.generate``
then rewrites the generated ``_table.py`` and ``_dispatch.py``. Checked here:

- the generated files equal what the generator writes now (so a stale one fails);
- the static rule below: no module of granwave outside granwave/contact_models/ names a
  sub-model or its parameters;
- the derived things follow the registry: PrepareParams' fields (hence prepare-packing's
  options), the engine's parameter record, the file attributes.

The static rule is granwave.contact_models.names' (its docstring): no module of granwave
outside granwave/contact_models/ uses a sub-model's name, a kind that can be off or a parameter's
name as an identifier or a string; the generator refuses a registry whose names collide with an
identifier of the package, naming the collision. Codes, counts and names are read from the
registry here, never typed in.
"""

from __future__ import annotations

import dataclasses
import types
from pathlib import Path

import numpy as np
import pytest

from granwave.contact_models import generate as G
from granwave.contact_models import names as N
from granwave.contact_models import options as CO
from granwave.errors import InputError

ROOT = Path(__file__).resolve().parent.parent / "granwave"


def _banned() -> tuple[list, list]:
    """(names matched as runs of words, names matched whole): the registry's."""
    words = list(CO.SUBMODELS) + [x for k, v in CO.KINDS.items() if v["off"] is not None for x in (k, v["option"])]
    return words, list(CO.PARAMETERS) + list(CO.history_datasets())


def _named(source: str, allowed: set = frozenset()) -> list:
    """Where ``source`` names a sub-model or its parameters (granwave.contact_models.names' rule)."""
    return N.named(source, *_banned(), allowed)


def test_generated_files_are_current():
    """_table.py and _dispatch.py are what ``python -m granwave.contact_models.generate`` writes."""
    for path, text in G.outputs().items():
        assert path.read_text() == text, f"{path.name} is stale: run python -m granwave.contact_models.generate"


def test_no_module_outside_contact_models_names_a_sub_model():
    """The rule over the package, as the generator runs it (so no collision is left to refuse)."""
    offenders = N.collisions(*_banned())
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

    from granwave.contact_models.kinds import KINDS

    for kind in KINDS:
        k = CO.KINDS[kind.name]
        assert PARAMS.fields[f"{kind.name}_code"][0].kind == "i"
        # as many constants as its sub-model with the most needs
        assert k["slots"] == max((len(s["constants"]) for s in CO.SUBMODELS.values() if s["kind"] == kind.name),
                                 default=0)
        # the names the kind declares (damping: damping, tangential: friction, after their parameters), then generated ones
        assert len(k["fields"]) == k["slots"] and all(f in PARAMS.names for f in k["fields"])
        assert k["fields"] == tuple(kind.fields[i] if i < len(kind.fields) else f"{kind.name}_c{i}"
                                    for i in range(k["slots"]))
        assert all(PARAMS.fields[f][0] == np.float64 for f in k["fields"])


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
    """One more normal law registered (a stand-in module here) gets the next code, its branch in
    every normal dispatcher, its parameter in the table; nothing else changes in the generated text."""
    from granwave.contact_models import harmonic
    from granwave.contact_models.declare import Parameter

    fake = types.SimpleNamespace(**{k: getattr(harmonic, k) for k in dir(harmonic) if not k.startswith("__")})
    fake.NAME, fake.__name__ = "stiffer", "granwave.contact_models.stiffer"
    fake.PARAMETERS = (Parameter("stiffer_stiffness", 2.0, "E* d", "k of the stand-in law.", lo=0.0),)
    fake.kernel_constants = lambda values: (2.0 * values["stiffer_stiffness"],)
    code = len(CO.names("normal"))  # the next code: the kind has no off name
    before = G.dispatch_source()
    monkeypatch.setattr(G, "modules", lambda real=G.modules: [*real(), fake])
    after = G.dispatch_source()
    assert "from . import stiffer as _normal_stiffer" in after
    for fn, name, _, _, _ in G.KINDS[0].functions:
        assert f"def {name}(" in after
        assert f"    if model.code == {code}:\n        return _normal_stiffer.{fn}(" in after
    assert after.count(f"model.code == {code}:") == len(G.KINDS[0].functions)
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
    # a damping law with a constant of its own (LAMMPS's ``damping velocity``, say; ``velocity``
    # itself would be refused: granwave has velocity identifiers)
    ("damping", "damping_critical", "stand_in_dashpot", "stand_in_coefficient"),
    # a tangential law with a constant of its own (a constant k_t, say)
    ("tangential", "mindlin", "stand_in_spring", "stand_in_stiffness"),
])
def test_a_second_damping_or_tangential_law_is_one_more_branch_of_every_dispatcher(monkeypatch, kind_name,
                                                                                    real_name, name, parameter):
    """One more damping (or tangential) law registered (a stand-in module) gets the next code, its
    branch in every dispatcher of its kind (the engines' contact routine, the tile law's general path, the
    GPU's device copies and the time step all call these), its parameter in the table and so a
    PrepareParams field; the other kinds' dispatchers are unchanged."""
    import importlib

    from granwave.contact_models.declare import Parameter

    real = importlib.import_module(f"granwave.contact_models.{real_name}")
    kind = next(k for k in G.KINDS if k.name == kind_name)
    fake = _stand_in(real, name, (Parameter(parameter, 1.0, "E* d", "the stand-in's constant.", lo=0.0),))
    code = len(CO.names(kind_name))  # the next code (neither kind has an off name)
    before = G.dispatch_source()
    monkeypatch.setattr(G, "modules", lambda real=G.modules: [*real(), fake])
    after = G.dispatch_source()
    alias = f"_{kind_name}_{name}"
    assert f"from . import {name} as {alias}" in after
    for fn, dispatcher, _, _, _ in kind.functions:
        body = after.split(f"def {dispatcher}(", 1)[1].split("\n\n\n", 1)[0]
        assert f"    if model.code == {code}:\n        return {alias}.{fn}(" in body
        assert f"return _{kind_name}_{real.NAME}.{fn}(" in body  # the default: the fall-through
    assert after.count(f"return {alias}.") == len(kind.functions)
    # nothing else changes: the new lines are its import, its branches and its device functions
    added = set(after.splitlines()) - set(before.splitlines())
    assert all(alias in line or line == f"    if model.code == {code}:" for line in added)
    table = {}
    exec(G.table_source(), table)
    assert table["SUBMODELS"][name]["kind"] == kind_name and table["SUBMODELS"][name]["code"] == code
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
    default = {kind: CO.SUBMODELS[CO.KINDS[kind]["default"]]["code"] for kind in ("damping", "tangential")}
    fpar = record(PARAMS)
    CM.fill_params(fpar, CO.resolve(dict(friction=0.3, damping=0.2, poisson=0.1)))
    assert (fpar.friction, fpar.damping, fpar.damping_code, fpar.tangential_code) == (0.3, 0.2, default["damping"],
                                                                             default["tangential"])
    assert CM.damping_model(0.2)[:2] == (default["damping"], 0.2)
    assert CM.tangential_model(0.3)[:2] == (default["tangential"], 0.3)
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
        assert CD.dashpot_step_ratio(damping, k, m) == 0.3
        assert CD.tangential_spring(tangential, k, n, 0.5) == k
    assert CD.friction_acts(tangential) and not CD.friction_acts(CD.TangentialModel(0, 0.0))
    for old, new, rescale in [(2e-3, 1e-3, True), (1e-3, 2e-3, True), (2e-3, 1e-3, False)]:
        assert CD.tangential_unloads(tangential, old, new, rescale) == C.unloads(old, new, rescale)
    for f, s in [((1e-4, -2e-4, 0.0), (1e-3, 0.0, 2e-3)), ((1e-2, 0.0, 0.0), (1.0, 1.0, 0.0))]:  # sticks, slides
        assert CD.tangential_increment(tangential, *f, *s, 0.05, 0.01) == C.increment_and_cap3(*f, *s, 0.05, 0.01, 0.4)
    assert CD.tangential_increment(tangential, 1e-2, 0.0, 0.0, 1.0, 1.0, 0.0, 0.05, 0.01)[3]


# ------------------------------------------------ the generator's checks (granwave.contact_models.generate)
def _registered_plus(monkeypatch, fake):
    monkeypatch.setattr(G, "modules", lambda real=G.modules: [*real(), fake])


@pytest.mark.parametrize("name, identifier", [("velocity", r"\w*velocity\w*"), ("on_limit", r"_on_limit")])
def test_a_name_colliding_with_an_identifier_of_the_package_is_refused(monkeypatch, name, identifier):
    """A sub-model named like an identifier elsewhere in granwave is refused with the collision
    named (file and line): its name as a run of words in an identifier (``on_limit`` in
    ``_on_limit``) counts, as a whole one does."""
    from granwave.contact_models import damping_critical

    _registered_plus(monkeypatch, _stand_in(damping_critical, name, ()))
    with pytest.raises(G.RegistryError, match=rf"the name '{name}' collides with the identifier '{identifier}' "
                                              r"\(granwave/[\w/]+\.py line \d+\)"):
        G.dispatch_source()


def test_a_parameter_named_like_an_identifier_or_taken_is_refused(monkeypatch):
    from granwave.contact_models import damping_critical
    from granwave.contact_models.declare import Parameter

    _registered_plus(monkeypatch, _stand_in(damping_critical, "stand_in", (Parameter("pressure", 1.0, None, "x"),)))
    with pytest.raises(G.RegistryError, match=r"the name 'pressure' collides with the (identifier|string) 'pressure'"):
        G.dispatch_source()
    monkeypatch.undo()
    taken = next(iter(CO.KIND_PARAMETERS))
    _registered_plus(monkeypatch, _stand_in(damping_critical, "stand_in", (Parameter(taken, 1.0, None, "x"),)))
    with pytest.raises(G.RegistryError, match=rf"the parameter name '{taken}' is taken \(a parameter of the"):
        G.dispatch_source()


def test_a_formula_of_the_wrong_arity_is_refused(monkeypatch):
    """Each formula takes its kind's arguments and exactly its own constants: one too many (a
    second constant the module does not declare) is refused, naming the function and the call."""
    import numba

    from granwave.contact_models import damping_critical

    fake = _stand_in(damping_critical, "stand_in", (), coefficient=numba.njit(lambda meff, k, overlap, damping, extra: 0.0))
    _registered_plus(monkeypatch, fake)
    with pytest.raises(G.RegistryError, match=r"coefficient\(meff, k, overlap, damping, extra\) takes 5 arguments, the "
                                              r"damping kind calls it with 4: \(meff, k, overlap, damping;"):
        G.dispatch_source()
    # kernel_constants must give one number per declared constant
    fake.coefficient = damping_critical.coefficient
    fake.kernel_constants = lambda values: (values["damping"], 1.0)
    with pytest.raises(G.RegistryError, match=r"kernel_constants gives \(0.5, 1.0\) at the defaults, expected 1 "
                                              r"floats \(damping\)"):
        G.dispatch_source()


def test_a_missing_hook_or_lammps_words_is_refused(monkeypatch):
    """A formula of the kind missing, a formula the GPU would not compile (not in DEVICE_FUNCTIONS),
    and neither LAMMPS words nor NO_LAMMPS: each refused in one line."""
    from granwave.contact_models import mindlin

    real = G.modules
    for change, message in [(dict(at_limit=None, DEVICE_FUNCTIONS=mindlin.DEVICE_FUNCTIONS[:-1]),
                             r"defines the numba function at_limit"),
                            (dict(DEVICE_FUNCTIONS=("acts", "stiffness")), r"list unloads in DEVICE_FUNCTIONS"),
                            (dict(lammps_tangential=None, lammps_stiffness_ratio=None),
                             r"define its LAMMPS words .* or say NO_LAMMPS"),
                            (dict(CONSTANTS=("k",), kernel_constants=lambda v: (1.0,)),
                             r"the tangential kind's constants start with friction")]:
        fake = _stand_in(mindlin, "stand_in", ())
        for k, v in change.items():
            if v is None:
                delattr(fake, k)
            else:
                setattr(fake, k, v)
        monkeypatch.setattr(G, "modules", lambda real=real, fake=fake: [*real(), fake])
        with pytest.raises(G.RegistryError, match=message):
            G.dispatch_source()
    # an explicit "no LAMMPS equivalent" is accepted, and recorded in the table
    fake = _stand_in(mindlin, "stand_in", ())
    del fake.lammps_tangential, fake.lammps_stiffness_ratio
    fake.NO_LAMMPS = "a stand-in"
    monkeypatch.setattr(G, "modules", lambda: [*real(), fake])
    table = {}
    exec(G.table_source(), table)
    assert table["SUBMODELS"]["stand_in"]["lammps"] == "a stand-in"


def test_every_damping_law_is_off_with_its_constants_at_zero():
    """The pulse switches the dashpot off by zeroing the damping law's constants (models.without_dashpot):
    every registered damping law must then not act, and the record comes back as it was."""
    from granwave.contact_models import _dispatch as CD
    from granwave.contact_models import models as CM
    from granwave.dem.layout import PARAMS, record

    for name, s in CO.SUBMODELS.items():
        if s["kind"] == "damping":
            assert not CD.dashpot_acts(CD.DampingModel(s["code"])), name
    fpar = record(PARAMS)
    CM.fill_params(fpar, CO.resolve(dict(damping=0.4, friction=0.5, poisson=0.0)))
    with CM.without_dashpot(fpar):
        assert not CD.dashpot_acts(CD.dashpot_of(fpar))
    assert fpar.damping == 0.4 and CD.dashpot_acts(CD.dashpot_of(fpar))


def test_the_docs_tables_are_the_registry_s():
    """Every generated span of the docs (granwave.contact_models.docs) is what the registry gives
    now, each document has some, and a stale one is found: one more sub-model changes them."""
    from granwave.contact_models import docs as D

    texts = D.outputs()
    assert {p.relative_to(D.ROOT).as_posix() for p in texts} == set(D.DOCUMENTS)
    for path, text in texts.items():
        assert D.SPAN.search(path.read_text()), f"{path} has no generated span"
        assert path.read_text() == text, f"{path.name} is stale: run python -m granwave.contact_models.generate"
    table = D.submodels_table()
    for name, s in CO.SUBMODELS.items():
        assert f"| `{name}`" in table and s["summary"].replace("|", "\\|") in table
    for name in CO.ALL_PARAMETERS:
        assert f"`--{name.replace('_', '-')}`" in D.parameters_table()
