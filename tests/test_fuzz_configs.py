"""Fuzzed workflow configs: every mutation of config/config.yaml is refused at parse time in one
line naming a config key (exit 2, no traceback), or accepted only when every job's parameters
pass their stage's own checks (granwave/params.py).

The workflow is parsed in-process through Snakemake's API (about 0.2-0.8 s a config: the
Snakefile, common.smk's checks and every rule, no job graph); a few cases also go through
`snakemake -n` as a user runs it. Mutations are seeded, so a failure reproduces.
"""

import contextlib
import copy
import io
import math
import os
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from granwave import workflow_config as ws
from granwave import workflow_record as wr

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "workflow" / "Snakefile"
QUICK = ROOT / "config" / "config.yaml"
BASE = yaml.safe_load(QUICK.read_text())


def parse(config_path: Path, workdir: Path):
    """Parse the workflow with one config file, in this process: (exit code, stderr, globals).

    Exit code 0 and the workflow's globals (``batches``, ``config``, ...) when it is accepted;
    the code of ``sys.exit`` and None when common.smk refuses it; any other exception is
    returned as its repr (a traceback the user would see)."""
    from snakemake.api import SnakemakeApi
    from snakemake.settings.types import ConfigSettings, OutputSettings, ResourceSettings

    err, code, globals_ = io.StringIO(), 0, None
    cwd = os.getcwd()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            with SnakemakeApi(OutputSettings()) as api:
                wf = api.workflow(resource_settings=ResourceSettings(),
                                  config_settings=ConfigSettings(configfiles=[Path(config_path)]),
                                  snakefile=SNAKEFILE, workdir=Path(workdir))
                globals_ = wf._workflow.globals
    except SystemExit as exc:
        code = exc.code
    except BaseException as exc:  # noqa: BLE001 - a traceback is what the test looks for
        code = repr(exc)
    finally:
        os.chdir(cwd)
    return code, err.getvalue(), globals_


def job_refusals(g) -> list:
    """What each job's stage would refuse, built from the parsed workflow as its rules pass it
    (the oracle of an accepted config; empty when every job would run)."""
    from granwave.errors import InputError
    from granwave.params import (AttenuationParams, ChainParams, HeightsParams, LatticeParams,
                                 PrepareParams, PropagateParams)

    config = g["config"]
    makers = {"disordered": PrepareParams, "continuum": PrepareParams, "lattices": LatticeParams,
              "chains": ChainParams}
    tries = []
    for name, _scene, samples in g["batches"]():
        for s in samples:
            make = dict(s["make"])
            if s["kind"] == "chains":
                make["balls"] = make.pop("n_balls")
            tries.append((name, makers[s["kind"]], make))
            tries.append((name, PropagateParams, dict(s["signal"])))
    tries.append(("heights", HeightsParams, dict(edge_heights=config["edge_heights"])))
    for scene, spec in config["continuum"].items():
        tries.append((f"attenuation {scene}", AttenuationParams, dict(bootstrap=spec["bootstrap"])))
    d = config["damping"]
    if d["enabled"]:
        for z in d["zetas"]:
            tries.append((f"damping {z}", PropagateParams,
                          dict(method="dem", ic=config["ic"], t_max=float(f"{g['damping_t_max']():.6g}"),
                               samples=config["samples"], amplitude=d["amplitude"],
                               damping=float(f"{z:g}"))))
    if g["main_sample"]():
        from types import SimpleNamespace

        scene, p, size = g["main_sample"]()
        wc = SimpleNamespace(scene=scene, pressure=p, size=size, seed=0)
        tries.append(("snapshot", PropagateParams,
                      dict(method="time", ic=config["ic"], t_max=float(f"{g['t_max'](wc):.6g}"),
                           snapshots=[float(x) for x in g["snapshot_times"](wc)])))
    out = []
    for name, cls, values in tries:
        try:
            cls(**values)
        except InputError as exc:
            out.append(f"{name}: {exc}")
    return out


def _leaves(node, path=()):
    """Every (path, value) of the config, lists and mappings included."""
    yield path, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _leaves(v, (*path, i))


def _set(cfg, path, value):
    node = cfg
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value


def _get(cfg, path):
    node = cfg
    for k in path:
        node = node[k]
    return node


# What a mutation puts in place of a value: wrong types, out-of-range and non-finite numbers,
# negative and huge counts, integers written as floats, empty lists, bad paths.
MUTATIONS = {
    "string": lambda rng, v: "x",
    "bool": lambda rng, v: True,
    "null": lambda rng, v: None,
    "list": lambda rng, v: [v],
    "mapping": lambda rng, v: {"a": 1},
    "nan": lambda rng, v: math.nan,
    "inf": lambda rng, v: rng.choice([math.inf, -math.inf]),
    "negative": lambda rng, v: -abs(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and v else -1,
    "zero": lambda rng, v: 0,
    "tiny": lambda rng, v: rng.choice([1e-300, 5e-324, 1e-13]),
    "huge": lambda rng, v: rng.choice([1e300, 10**30, 10**400, 2**63, 10**6]),
    "scaled": lambda rng, v: v * rng.choice([1e-6, 0.3, 3, 1e6]) if isinstance(v, (int, float)) and not isinstance(v, bool) else v,
    "float_for_int": lambda rng, v: float(v) if isinstance(v, int) and not isinstance(v, bool) else 2.5,
    "empty_list": lambda rng, v: [],
    "duplicate_item": lambda rng, v: v + v[:1] if isinstance(v, list) else [v, v],
    "bad_path": lambda rng, v: rng.choice(["", "/etc/hostname", "/proc/x/results", "a b", "res{x}",
                                          "x" * 300]),
}


def _mutants(seed: int, count: int):
    """``count`` seeded mutants of config.yaml: (description, key path, config or None, text)."""
    rng = random.Random(seed)
    leaves = [(p, v) for p, v in _leaves(BASE) if p]
    out = []
    while len(out) < count:
        kind = rng.choice(list(MUTATIONS) + ["unknown_key", "duplicate_key"])
        cfg = copy.deepcopy(BASE)
        if kind == "unknown_key":
            path, value = rng.choice([(p, v) for p, v in leaves if isinstance(v, dict)] + [((), BASE)])
            _set(cfg, (*path, "typo_key"), 1) if path else cfg.__setitem__("typo_key", 1)
            out.append((f"unknown key under {path}", (*path, "typo_key"), cfg, None))
            continue
        if kind == "duplicate_key":  # a top-level key given again at the end of the file
            key = rng.choice(list(BASE))
            text = QUICK.read_text() + f"\n{key}: {yaml.safe_dump(BASE[key], default_flow_style=True).strip()}\n"
            out.append((f"duplicate key {key}", (key,), None, text))
            continue
        path, value = (("results",), BASE["results"]) if kind == "bad_path" else rng.choice(leaves)
        new = MUTATIONS[kind](rng, value)
        _set(cfg, path, new)
        out.append((f"{kind} at {path}: {value!r} -> {new!r}"[:200], path, cfg, None))
    return out


def _key_text(path) -> str:
    return ws._key(path)


def _named_key(message: str) -> str:
    """The config key a refusal names: the text after 'config: ' up to ':', ' =' or ' ('."""
    text = message[len("config: "):]
    text = text[len("unknown key "):] if text.startswith("unknown key ") else text
    return re.split(r":| =| \(", text, maxsplit=1)[0].strip()


def _resolves(cfg, key: str) -> bool:
    """Whether ``key`` (damping.zetas[1], disordered.x.series.heights[0], ...) exists in cfg."""
    node = cfg
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", key):
        if part.startswith("["):
            i = int(part[1:-1])
            if not isinstance(node, list) or i >= len(node):
                return False
            node = node[i]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return False
    return True


CASES = _mutants(seed=50, count=36)


@pytest.mark.parametrize("what, path, cfg, text", CASES, ids=[c[0][:60] for c in CASES])
def test_mutated_config_is_refused_in_one_line_or_every_job_accepts_it(tmp_path, what, path, cfg, text):
    config_file = tmp_path / "mutant.yaml"
    config_file.write_text(text if text is not None else yaml.safe_dump(cfg, sort_keys=False))
    work = tmp_path / "work"
    work.mkdir()
    code, err, g = parse(config_file, work)
    assert code in (0, 2), f"{what}: not a clean refusal: {code}\n{err}"
    if code == 0:
        refused = job_refusals(g)
        assert not refused, f"{what}: accepted at parse time, but a job would refuse it: {refused[0]}"
        return
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("config: "), f"{what}: {err}"
    message = lines[0]
    if text is not None:  # a key given twice: the file and the key are named
        assert "given twice" in message and repr(path[0]) in message, message
        return
    key = _named_key(message)
    assert _resolves(cfg, key) or key == "(top level)", f"{what}: names no key of the config: {message}"
    mutated = _key_text(path)
    # the mutated key itself, or a key that refers to it (damping.pressure to the scene's
    # pressures, t_max_factor to a record, a list to one of its items, a scene to its values)
    related = (re.sub(r"\[\d+\]$", "", mutated) in message or key.startswith(mutated)
               or mutated.startswith(key.split("[")[0])
               or key.startswith(("damping.", "t_max_factor", "edge_heights")))
    assert related, f"{what}: names {key!r}, not the mutated {mutated!r}: {message}"


def test_the_quick_config_itself_is_accepted_and_every_job_would_run(tmp_path):
    code, err, g = parse(QUICK, tmp_path)
    assert code == 0, err
    assert job_refusals(g) == []


# Hand-picked cases the hostile round found, and the key each refusal must name.
def _with(path, value):
    cfg = copy.deepcopy(BASE)
    _set(cfg, path, value)
    return cfg


NAMED = [
    (("damping", "zetas"), [0.0, 2.0], "damping.zetas[1]"),
    (("damping", "zetas"), [], "damping.zetas"),
    (("edge_heights",), [-1, 25], "edge_heights"),
    (("t_max_factor",), 0.5, "t_max_factor"),  # snapshot times beyond the record
    (("chains", "chain_A", "pressure"), 0.5, "chains.chain_A.pressure"),
    (("chains", "chain_A", "balls"), [100, 100], "chains.chain_A.balls[1]"),
    (("disordered", "frictionless2d", "heights"), [8, 8.0000001], "disordered.frictionless2d.heights[1]"),
    (("disordered", "frictionless2d", "heights"), [8, 1e-5], "disordered.frictionless2d.heights[1]"),
    (("disordered", "frictionless2d", "seeds"), 10**12, "disordered.frictionless2d.seeds"),
    (("disordered", "frictionless2d", "seeds"), 2.0, "disordered.frictionless2d.seeds"),
    (("disordered", "frictional2d", "pressures", 1), 0.5, "disordered.frictional2d.pressures[1]"),
    (("disordered", "frictional2d", "series", "heights", 0), 1e7, "disordered.frictional2d.series.heights[0]"),
    (("lattices", "lattice_frictional", "width"), 2, "lattices.lattice_frictional.width"),
    (("continuum", "continuum2d", "samples"), 1, "continuum.continuum2d.samples"),
    (("continuum", "continuum2d", "time_safety"), math.nan, "continuum.continuum2d.time_safety"),
    # #66: a record too short for the tallest column's front, widths below the DEM's limit
    (("t_max_factor",), 0.7, "t_max_factor"),
    (("continuum", "continuum2d", "t_max_factor"), 0.9, "continuum.continuum2d.t_max_factor"),
    (("t_max_factor",), 1.0, "t_max_factor"),  # the front arrives at the end: its lobe is cut
    (("t_max_factor",), 1.004, "t_max_factor"),
    (("disordered", "frictional2d", "width"), 1.5, "disordered.frictional2d.width"),
    (("continuum", "continuum2d", "width"), 1, "continuum.continuum2d.width"),
    (("results",), "/etc/hostname", "results"),
    (("results",), "", "results"),
    (("results",), "my results", "results"),
]


@pytest.mark.parametrize("path, value, key", NAMED, ids=[n[2] + "=" + repr(n[1])[:20] for n in NAMED])
def test_hostile_values_are_refused_naming_their_key(tmp_path, path, value, key):
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(_with(path, value), sort_keys=False))
    code, err, _ = parse(config_file, tmp_path)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1, err
    assert lines[0].startswith(f"config: {key}") and _named_key(lines[0]) == key, lines[0]


FILES = [
    (bytes(range(256)), "not a text file"),
    (b"name: quick\x00\n", "not a text file"),
    (b"name: " + b"[" * 100000 + b"]" * 100000 + b"\n", "nested too deeply"),
    (b'{"a": ' + b"[" * 100000 + b"]" * 100000 + b"}", "nested too deeply"),
    (b"- 1\n- 2\n", "must be a mapping of keys"),
    (b"", "must be a mapping of keys"),
    (b"a: [1\n", "not valid YAML or JSON at line"),
    (b'{"samples": 100, "samples": 200}', "'samples' is given twice"),
    (b"damping:\n  zetas: [0]\n  zetas: [1]\n", "'zetas' is given twice in one mapping (lines 2 and 3)"),
]


@pytest.mark.parametrize("content, words", FILES, ids=[w for _, w in FILES])
def test_config_files_are_read_strictly_in_one_line(tmp_path, content, words):
    path = tmp_path / "c.yaml"
    path.write_bytes(content)
    config, message = ws.read_config_file(path)
    assert config is None and "\n" not in message and message.startswith("config: file "), message
    assert words in message, message


def test_a_config_file_that_reads_cleanly_gives_the_mapping():
    config, message = ws.read_config_file(QUICK)
    assert message is None and config == BASE


@pytest.mark.xfail(strict=True, reason="Snakemake reads --configfile files itself, before the "
                   "workflow's code runs, and prints a traceback for a binary or deeply nested "
                   "one; the workflow cannot intercept it (granwave.workflow_config."
                   "read_config_file says it in one line for a wrapper that reads first)")
def test_binary_configfile_on_the_command_line_is_one_line(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_bytes(bytes(range(256)))
    code, err, _ = parse(path, tmp_path)
    assert code == 2, code


def _dry_run(config_file, cwd):
    return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(SNAKEFILE), "-n", "--quiet",
                           "--configfile", str(config_file)], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


def test_dry_run_refuses_a_duplicate_key_and_a_job_range_in_one_line(tmp_path):
    """As the user sees it: `snakemake -n` with a config whose key is given twice, and with
    one whose damping ratio the DEM pulse would refuse (both passed the dry run before)."""
    dup = tmp_path / "dup.yaml"
    dup.write_text(QUICK.read_text() + "\nsamples: 100\n")
    zeta = tmp_path / "zeta.yaml"
    zeta.write_text(yaml.safe_dump(_with(("damping", "zetas"), [0.0, 2.0]), sort_keys=False))
    for path, expected in ((dup, "key 'samples' is given twice in one mapping"),
                           (zeta, "config: damping.zetas[1]: damping must be in [0, 1], got 2")):
        run = _dry_run(path, tmp_path)
        assert run.returncode == 2, run.stderr
        assert "Traceback" not in run.stdout + run.stderr
        lines = [line for line in run.stderr.splitlines() if line.startswith("config:")]
        assert len(lines) == 1 and expected in lines[0], run.stderr


# ---------------------------------------------------------------- the record and the device (#66)
@pytest.mark.parametrize("ic", ["A", "B"])
def test_the_first_lobe_bound_is_below_the_exact_chains(ic):
    """record_error's bound (arrival + first_lobe_time) never exceeds the exact chain's end of
    its first lobe as the front rule measures it (property, 1 to 400 balls): a record it refuses
    cannot hold the front of the fastest column of that size."""
    import numpy as np

    from granwave import theory as T
    from granwave.analysis.front import front_features

    for n in (1, 2, 3, 5, 7, 8, 9, 13, 25, 60, 150, 400):
        if ic == "B" and n == 1:
            continue  # its signal starts at its peak: no front to measure
        t0 = T.chain_travel_time(n)
        t = np.linspace(0.0, 2.5 * t0, 8000)
        f = front_features(t, T.chain_wall_force(t, n, ic=ic))
        bound = t0 + wr.first_lobe_time("chains", f"n{n}", t0, ic)
        assert bound <= f.t_zero, (n, bound, f.t_zero)
        if ic == "A" or n >= wr.LOBE_B_MIN_ROWS:
            assert bound > t0  # the lobe counts: a factor just above 1 is refused
        assert bound > 0.9 * f.t_zero if n >= 8 else bound > 0.5 * f.t_zero  # a bound that bites


def test_a_record_that_cannot_hold_the_front_names_the_height_and_the_needed_t_max():
    cfg = copy.deepcopy(BASE)
    cfg["t_max_factor"] = 1.0
    cfg["disordered"] = {"d": {"pressures": [1e-4], "heights": [8, 30], "seeds": 1, "friction": 0.5,
                               "poisson": 0.0, "width": 24}}
    cfg["lattices"], cfg["chains"], cfg["continuum"] = {}, {}, {}
    message = wr.record_error(cfg)
    assert message.startswith("config: t_max_factor = 1: the record of disordered.d's tallest column (height 30")
    needed = float(re.search(r"needs t_max >= ([0-9.e+-]+)", message).group(1))
    arrival = float(re.search(r"arrival not before ([0-9.e+-]+)", message).group(1))
    assert needed > arrival and "\n" not in message
    cfg["t_max_factor"] = 1.001 * needed / arrival
    assert wr.record_error(cfg) is None
    assert "needs t_max >= " in wr.record_warning(cfg)  # below 2 crossings: a warning line
    cfg["t_max_factor"] = 2.0
    assert wr.record_warning(cfg) is None


def test_a_short_disordered_record_warns_at_the_dry_run(tmp_path):
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(_with(("t_max_factor",), 1.5), sort_keys=False))
    code, err, _ = parse(config_file, tmp_path)
    assert code == 0, err
    lines = [line for line in err.splitlines() if line.startswith("config: warning: t_max_factor = 1.5")]
    assert len(lines) == 1 and "needs t_max >= " in lines[0], err


def _gpu_usable():
    from granwave.devices import require
    from granwave.errors import InputError

    try:
        require("gpu")
        return True
    except InputError:
        return False


def test_device_gpu_without_a_gpu_is_refused_at_the_dry_run(tmp_path, monkeypatch):
    """device: gpu passed the dry run on a machine without a GPU, and every GPU job failed:
    refused in one line, unless the GPU jobs run elsewhere (GRANWAVE_GPU_ELSEWHERE)."""
    if _gpu_usable():
        pytest.skip("a GPU is usable here")
    monkeypatch.delenv(ws.GPU_ELSEWHERE_ENV, raising=False)
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(_with(("device",), "gpu"), sort_keys=False))
    code, err, _ = parse(config_file, tmp_path)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("config: device = gpu: no usable CUDA GPU"), err
    monkeypatch.setenv(ws.GPU_ELSEWHERE_ENV, "1")
    code, err, g = parse(config_file, tmp_path)
    assert code == 0 and g["gpu_packings"](), err


def test_the_device_check_asks_only_for_device_gpu():
    calls = []
    assert ws.device_error({"device": "cpu"}, gpu_usable=lambda: calls.append(1)) is None and not calls
    assert ws.device_error({"device": "gpu"}, gpu_usable=lambda: calls.append(1)) is None and calls


def test_a_shear_record_too_short_for_its_pulse_is_refused(tmp_path):
    """The shear scenes' record (crossings at c_t plus four periods) had no bound: a record that
    ends before the longest wavelength's pulse can have passed is refused naming it."""
    cfg = yaml.safe_load((ROOT / "config" / "shear.yaml").read_text())
    scene = next(iter(cfg["shear"]))
    cfg["shear"][scene]["record"] = 0.001
    cfg["shear"][scene]["wavelengths"] = [1]
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    code, err, _ = parse(path, tmp_path)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"config: shear.{scene}.record = 0.001"), err
    assert "needs t_max >= " in lines[0] and "height " in lines[0]
    cfg["shear"][scene]["record"] = 1.0
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    code, err, _ = parse(path, tmp_path)
    assert code == 0, err
