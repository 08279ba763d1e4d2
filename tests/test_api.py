"""The library API (granwave.api) and the stage parameters (granwave.params).

- docs/api.md's opening example runs as written;
- parameters: keyword-only, frozen, ranges checked, the same range for the same
  physical parameter on every stage, CLI defaults and help taken from the fields;
- method="auto" picks the cheaper linear method by the cost model and records why;
- the API and the CLI give the same result for the same seed;
- lattice / chain refuse a pressure that leaves no positive spacing; propagate warns
  when the sample interval cannot resolve the band (and refuses an uncountable run).
"""

import contextlib
import dataclasses
import io
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import api, params as P, systems
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files

DOCS = Path(__file__).resolve().parents[1] / "docs" / "api.md"
ALL_PARAMS = [P.PrepareParams, P.LatticeParams, P.ChainParams, P.LinearizeParams, P.EigenParams,
              P.PropagateParams, P.StaticsParams, P.ModuliParams, P.FrontParams, P.HeightsParams,
              P.EnsembleParams, P.SpectrumParams, P.DampingParams, P.SweepParams]
#: The command of each parameter class, for the option checks.
COMMANDS = {P.PrepareParams: ["prepare-packing"], P.LatticeParams: ["lattice"],
            P.ChainParams: ["chain"], P.LinearizeParams: ["linearize"],
            P.EigenParams: ["eigensolve"], P.PropagateParams: ["propagate"],
            P.StaticsParams: ["analyze", "statics"], P.ModuliParams: ["analyze", "moduli"],
            P.FrontParams: ["analyze", "front"], P.HeightsParams: ["analyze", "heights"],
            P.EnsembleParams: ["analyze", "ensemble"], P.SpectrumParams: ["analyze", "spectrum"],
            P.DampingParams: ["analyze", "damping"], P.SweepParams: ["pressure-sweep"]}


def _command(path):
    import click

    cmd = main
    ctx = click.Context(main)
    for name in path:
        cmd = cmd.get_command(ctx, name)
    return cmd


# --------------------------------------------------------------------------- the docs example
def test_docs_example_runs():
    text = DOCS.read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks and text.index("```python") < text.index("## "), "the doc must open with the example"
    out = io.StringIO()
    scope = {}
    with contextlib.redirect_stdout(out):
        exec(compile(blocks[0], str(DOCS), "exec"), scope)
    printed = out.getvalue()
    assert "grains" in printed and "method:" in printed
    sig, front = scope["signal"], scope["front"]
    assert sig.attrs["method_requested"] == "auto" and sig.attrs["method"] in ("modal", "time")
    # the front arrives after the kick and before the end of the record
    assert 0 < front["t_lead10"] < front["t_peak"] < front["t_zero"] < sig.time[-1]


# --------------------------------------------------------------------------- parameters
def test_params_are_frozen_keyword_only_and_validated():
    with pytest.raises(TypeError):
        P.LatticeParams(4, 4, 1e-4)  # keyword-only
    p = P.LatticeParams(rows=4, width=4, pressure=1e-4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.rows = 5
    for cls, bad in [(P.LatticeParams, dict(rows=4, width=4, pressure=1e-4, poisson=0.7)),
                     (P.LatticeParams, dict(rows=4, width=4, pressure=1e6)),
                     (P.LatticeParams, dict(rows=1, width=4, pressure=1e-4)),
                     (P.ChainParams, dict(balls=3, pressure=1e-4, polydispersity=1.5)),
                     (P.ChainParams, dict(balls=3, pressure=1e-4, stiffness=1.0, hertz=True)),
                     (P.SweepParams, dict(poisson=0.6)),
                     (P.PropagateParams, dict(t_max=math.nan)),
                     (P.PropagateParams, dict(t_max=10.0, ic="C")),
                     (P.PropagateParams, dict(t_max=10.0, snapshots=(11.0,))),
                     (P.PropagateParams, dict(t_max=10.0, method="time", damping=0.1)),
                     (P.FrontParams, dict(peak_fraction=0.0)),
                     (P.HeightsParams, dict(edge_heights=(8.0,))),
                     (P.StaticsParams, dict(layer=-1.0)),
                     (P.EigenParams, dict(lowest=0)),
                     (P.PrepareParams, dict(grains=2.5))]:
        with pytest.raises(InputError):
            cls(**bad)
    # integral floats become ints, ints become floats where a float is meant
    assert P.PrepareParams(grains=40.0).grains == 40 and isinstance(P.StaticsParams(layer=2).layer, float)


def test_same_parameter_same_range_everywhere():
    """Every field named poisson / friction / pressure / seed / polydispersity has one range."""
    seen = {}
    for cls in ALL_PARAMS:
        for f in dataclasses.fields(cls):
            if f.name in ("poisson", "friction", "pressure", "seed", "polydispersity"):
                rng = tuple(f.metadata[k] for k in ("lo", "hi", "lo_open", "hi_open"))
                seen.setdefault(f.name, set()).add(rng)
    assert seen["poisson"] == {(0.0, 0.5, False, True)}
    assert seen["pressure"] == {(P.MIN_PRESSURE, P.MAX_PRESSURE, False, False)}
    assert all(len(r) == 1 for r in seen.values()), seen


@pytest.mark.parametrize("cls", ALL_PARAMS, ids=lambda c: c.__name__)
def test_cli_options_come_from_the_fields(cls):
    """Each field with a CLI option: same default, its help text, its units; plus --threads
    on the compute stages."""
    cmd = _command(COMMANDS[cls])
    options = {p.name: p for p in cmd.params}
    for f in dataclasses.fields(cls):
        if f.metadata.get("cli") == "":
            assert f.name not in options
            continue
        opt = options[f.name]
        assert f.metadata["help"] in opt.help
        if f.metadata.get("units"):
            assert f.metadata["units"] in opt.help
        if f.default is dataclasses.MISSING:
            assert opt.required
        elif isinstance(f.default, tuple):
            assert tuple(float(x) for x in opt.default.split(",")) == f.default
        elif f.metadata.get("choices") is not None and f.default is not None:
            assert opt.default == str(f.default)
        else:
            assert opt.default == f.default
    threaded = cls in (P.PrepareParams, P.LinearizeParams, P.EigenParams, P.PropagateParams,
                       P.ModuliParams)
    assert ("threads" in options) == threaded
    if threaded:
        from granwave.threads import available_cores

        import click

        assert options["threads"].get_default(click.Context(cmd)) == available_cores()


def test_params_recorded_in_outputs(tmp_path):
    pk = api.lattice(rows=4, width=4, pressure=1e-4)
    assert json.loads(pk.attrs["lattice_params"]) == dataclasses.asdict(
        P.LatticeParams(rows=4, width=4, pressure=1e-4))
    files.write_packing(tmp_path / "l.h5", pk)
    sys_ = api.linearize(files.read_packing(tmp_path / "l.h5"), prestress=True)
    assert json.loads(sys_.attrs["linearize_params"])["prestress"] is True
    sig = api.propagate(sys_, t_max=20.0, samples=201)
    assert json.loads(sig.attrs["propagate_params"])["t_max"] == 20.0


# --------------------------------------------------------------------------- method auto
@pytest.fixture(scope="module")
def lattice_system():
    return api.linearize(api.lattice(rows=8, width=6, pressure=1e-4))


def test_auto_picks_the_cheaper_method_and_records_it(lattice_system):
    """Few steps: the time domain is cheaper; a long record (many steps) makes the dense
    eigensolve the cheaper one. The choice follows the cost model's formulas."""
    system = lattice_system
    n, nnz = system.n_dof, system.stiffness.nnz
    wmax = api._omega_max_bound(system)
    for t_max in (10.0, 1e5):
        p = P.PropagateParams(t_max=t_max, samples=401, method="auto")
        steps = api._time_steps(p, p.safety * 2 / wmax)
        t_time = (api.VERLET_SECONDS_PER_NNZ_STEP * nnz * steps
                  + api.TIME_SAMPLE_SECONDS_PER_DOF * n * p.samples)
        t_modal = api.EIGEN_SECONDS_PER_DOF3 * n**3 + api.MODAL_SUM_SECONDS_PER_TERM * n * p.samples
        expected = "modal" if t_modal <= t_time else "time"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", api.AliasingWarning)
            sig = api.propagate(system, p)
            direct = api.propagate(system, dataclasses.replace(p, method=expected))
        assert sig.attrs["method"] == expected and sig.attrs["method_requested"] == "auto"
        assert expected.replace("modal", "modal sum").replace("time", "time domain") in sig.attrs["method_reason"]
        np.testing.assert_array_equal(sig.force, direct.force)
    assert api.choose_method(system, P.PropagateParams(t_max=10.0, samples=401))[0] == "time"
    assert api.choose_method(system, P.PropagateParams(t_max=1e5, samples=401))[0] == "modal"


def test_auto_takes_the_time_domain_beyond_the_dense_limit(lattice_system, monkeypatch):
    import granwave.linear.eigen as eigen

    monkeypatch.setattr(eigen, "DENSE_MAX_DOF", lattice_system.n_dof - 1)
    method, why = api.choose_method(lattice_system, P.PropagateParams(t_max=1e5, method="auto"))
    assert method == "time" and "dense eigensolve limit" in why


def test_cli_prints_the_auto_choice(tmp_path):
    r = CliRunner().invoke(main, ["lattice", "--rows", "6", "--width", "6", "--pressure", "1e-4",
                                  "-o", str(tmp_path / "l.h5")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["linearize", str(tmp_path / "l.h5"), "-o", str(tmp_path / "s.h5")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["propagate", str(tmp_path / "s.h5"), "--method", "auto",
                                  "--t-max", "40", "-o", str(tmp_path / "sig.h5"), "--quiet"])
    assert r.exit_code == 0, r.output
    sig = files.read_signal(tmp_path / "sig.h5")
    assert f"method auto -> {sig.attrs['method_reason']}" in r.output
    assert sig.attrs["method_requested"] == "auto"


# --------------------------------------------------------------------------- API = CLI
def test_api_equals_cli_for_the_same_seed(tmp_path):
    out = tmp_path / "p.h5"
    r = CliRunner().invoke(main, ["prepare-packing", "--grains", "40", "--seed", "3", "--tol", "1e-8",
                                  "--threads", "1", "-q", "-o", str(out)])
    assert r.exit_code == 0, r.output
    from_cli = files.read_packing(out)
    from_api = api.prepare_packing(grains=40, seed=3, tol=1e-8, threads=1)
    for name in ("position", "radius", "box", "mass"):
        np.testing.assert_array_equal(getattr(from_cli, name), getattr(from_api, name))
    np.testing.assert_array_equal(from_cli.contacts.force_normal, from_api.contacts.force_normal)
    # downstream: linearize + time-domain signal + front, file route against object route
    for args in (["linearize", str(out), "-o", str(tmp_path / "s.h5")],
                 ["propagate", str(tmp_path / "s.h5"), "--t-max", "60", "--samples", "601", "--quiet",
                  "-o", str(tmp_path / "sig.h5")],
                 ["analyze", "front", str(tmp_path / "sig.h5"), "--json"]):
        r = CliRunner().invoke(main, args)
        assert r.exit_code == 0, r.output
    sig = api.propagate(api.linearize(from_api), t_max=60.0, samples=601)
    np.testing.assert_array_equal(files.read_signal(tmp_path / "sig.h5").force, sig.force)
    assert json.loads(r.output)["t_peak"] == api.front(sig)["t_peak"]


# --------------------------------------------------------------------------- refusals and warnings
def test_lattice_and_chain_refuse_pressures_without_positive_spacing(tmp_path):
    # the library (no 0.1 E* cap there) refuses by the geometry
    with pytest.raises(InputError, match="no positive spacing"):
        systems.triangular_lattice(rows=4, width=4, pressure=1e6)
    with pytest.raises(InputError, match="no positive spacing"):
        systems.chain(n_balls=3, pressure=0.1, stiffness=0.01)  # overlap 10 d
    # the commands refuse before building anything: one line, exit 2, no file
    for args in (["lattice", "--rows", "4", "--width", "4", "--pressure", "1e6"],
                 ["chain", "--balls", "3", "--pressure", "1e6"],
                 ["chain", "--balls", "3", "--pressure", "0.1", "--stiffness", "0.01"],
                 ["lattice", "--rows", "4", "--width", "4", "--pressure", "1e-4", "--poisson", "0.7"]):
        out = tmp_path / "x.h5"
        r = CliRunner().invoke(main, [*args, "-o", str(out)])
        assert r.exit_code == 2, r.output
        assert r.output.strip().startswith("Error:") and len(r.output.strip().splitlines()) == 1
        assert not out.exists()


def test_propagate_warns_when_the_samples_cannot_resolve_the_band(lattice_system, tmp_path):
    wmax = math.sqrt(max(api.eigensolve(lattice_system).omega2))
    # h = 0.9 pi/omega_max: resolved, no warning
    ok_t = 0.9 * math.pi / wmax * 100
    with warnings.catch_warnings():
        warnings.simplefilter("error", api.AliasingWarning)
        sig = api.propagate(lattice_system, t_max=ok_t, samples=101, method="modal")
    assert not sig.attrs["aliased"] and sig.attrs["nyquist_ratio"] == pytest.approx(0.9, rel=1e-9)
    with pytest.warns(api.AliasingWarning, match="alias"):
        sig = api.propagate(lattice_system, t_max=1e300, samples=2001, method="modal")
    assert sig.attrs["aliased"] and sig.attrs["nyquist_ratio"] > 1e290
    # CLI: a warning line, the file written; the time domain refuses an uncountable run
    files.write_linear(tmp_path / "s.h5", lattice_system)
    r = CliRunner().invoke(main, ["propagate", str(tmp_path / "s.h5"), "--method", "modal",
                                  "--t-max", "1e300", "-o", str(tmp_path / "a.h5"), "--quiet"])
    assert r.exit_code == 0 and "warning: the sample interval" in r.output
    assert files.read_signal(tmp_path / "a.h5").attrs["aliased"]
    r = CliRunner().invoke(main, ["propagate", str(tmp_path / "s.h5"), "--method", "time",
                                  "--t-max", "1e300", "-o", str(tmp_path / "b.h5"), "--quiet"])
    assert r.exit_code == 2 and "shorter --t-max" in r.output and not (tmp_path / "b.h5").exists()


def test_api_refuses_wrong_objects_and_parameter_types(lattice_system):
    with pytest.raises(InputError, match="LinearizeParams"):
        api.linearize(api.lattice(rows=4, width=4, pressure=1e-4), P.StaticsParams())
    with pytest.raises(InputError, match="Modes, LinearSystem or Packing"):
        api.propagate("signal.h5", t_max=1.0)
    with pytest.raises(InputError, match="method dem"):
        api.propagate(lattice_system, t_max=1.0, method="dem")


def test_threads_reach_numba_and_bad_counts_are_refused(tmp_path):
    import numba

    before = numba.get_num_threads()
    try:
        api.lattice(rows=4, width=4, pressure=1e-4)  # no threads argument: setting left alone
        assert numba.get_num_threads() == before
        api.linearize(api.lattice(rows=4, width=4, pressure=1e-4), threads=1)
        assert numba.get_num_threads() == 1
        with pytest.raises(InputError, match="threads"):
            api.linearize(api.lattice(rows=4, width=4, pressure=1e-4), threads=0)
    finally:
        numba.set_num_threads(before)
    r = CliRunner().invoke(main, ["lattice", "--rows", "4", "--width", "4", "--pressure", "1e-4",
                                  "-o", str(tmp_path / "l.h5")])
    assert r.exit_code == 0
    r = CliRunner().invoke(main, ["linearize", str(tmp_path / "l.h5"), "--threads", "0",
                                  "-o", str(tmp_path / "s.h5")])
    assert r.exit_code == 2 and not (tmp_path / "s.h5").exists()
