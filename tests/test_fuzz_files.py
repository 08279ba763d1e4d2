"""Fuzz tests of the files granwave reads (issue #50, items 4 and 7): structure, semantics, signals.

Valid tiny files are made once through the CLI (a 4 x 4 frictional lattice: packing, linear,
modes with eigenvectors, a signal with snapshots); every case mutates a copy and runs the
stage that reads it, in-process (click's CliRunner). Each run must end either

* refused: exit status 2, one line naming the file, no traceback, no output file (and no
  temporary left beside it); or
* correct: exit status 0 and an output that its own reader accepts (for the exact
  conversions, byte order and float width, the same result as the original file).

Seeded and deterministic; all of it takes a few seconds (no time-domain kernel is compiled:
the linear files are propagated with --method modal, and the one time-domain case is refused
before stepping).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from granwave import api
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files
from granwave.io import schema as S

SEED = 50
T_MAX = ["--t-max", "20", "--samples", "64"]


# ---------------------------------------------------------------- the valid files
def run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    """packing, linear, modes (with vectors), signal (with snapshots) of one small lattice, and
    a second system (six rows) in its own folder for foreign-file cases."""
    out = {}
    for tag, rows in (("", 4), ("other_", 6)):
        folder = tmp_path_factory.mktemp(f"valid{tag or '_'}")
        p, lin, m, s = (folder / n for n in ("p.h5", "lin.h5", "m.h5", "s.h5"))
        for args in (["lattice", "--rows", rows, "--width", 4, "--pressure", 1e-3, "--friction", 0.5,
                      "-o", p, "-q"],
                     ["linearize", p, "-o", lin, "-q"],
                     ["eigensolve", lin, "-o", m, "--vectors"],
                     ["propagate", m, "-o", s, *T_MAX, "--snapshots", "1,2", "-q"]):
            r = run(args)
            assert r.exit_code == 0, r.output
        out.update({f"{tag}packing": p, f"{tag}linear": lin, f"{tag}modes": m, f"{tag}signal": s})
    return out


def consume(kind: str, path: Path, out: Path, extra=()):
    """Run the stage that reads a file of ``kind``; return click's result."""
    if kind == "packing":
        return run(["linearize", path, "-o", out, "-q", *extra])
    if kind == "linear":
        return run(["propagate", path, "-o", out, "--method", "modal", *T_MAX, "-q", *extra])
    if kind == "modes":
        return run(["propagate", path, "-o", out, *T_MAX, "--snapshots", "1", "-q", *extra])
    if kind == "signal":
        return run(["analyze", "ensemble", path, path, "-o", out, *extra])
    raise AssertionError(kind)


READ_OUTPUT = {"packing": files.read_linear, "linear": files.read_signal, "modes": files.read_signal,
               "signal": lambda p: h5py.File(p, "r").close()}


def refused(r, path: Path, out: Path, match: str | None = None) -> str:
    """Assert a clean refusal; return its message."""
    assert r.exit_code == 2, f"exit {r.exit_code}: {r.output[-2000:]}"
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    text = r.output.strip()
    assert "Traceback" not in text, text
    lines = text.splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), text
    assert path.name in lines[0], f"message does not name {path.name}: {lines[0]}"
    if match is not None:
        assert match in lines[0], lines[0]
    assert not out.exists(), f"{out} written by a refused run"
    assert not list(out.parent.glob(f".{out.name}.*")), "temporary left behind"
    return lines[0]


def refused_or_correct(r, kind: str, path: Path, out: Path, what: str) -> str:
    """Either a clean refusal or exit 0 with an output its reader accepts."""
    if r.exit_code == 0:
        assert out.exists(), f"{what}: exit 0 without an output"
        READ_OUTPUT[kind](out)
        out.unlink()
        return "accepted"
    try:
        return refused(r, path, out)
    except AssertionError as exc:
        raise AssertionError(f"{what}: {exc}") from None


def copy(src: Path, dst: Path) -> Path:
    shutil.copyfile(src, dst)
    return dst


def datasets(path: Path) -> list[str]:
    names = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
    schema = files.file_schema(path)
    return [n for n in names if n in S.LAYOUT[schema]]  # not the dimension scales


def replace(path: Path, name: str, data) -> None:
    with h5py.File(path, "a") as f:
        del f[name]
        f[name] = data


def mutate_dataset(path: Path, name: str, fn) -> None:
    with h5py.File(path, "r") as f:
        a = f[name][()]
    replace(path, name, fn(a))


# ---------------------------------------------------------------- structure
def _structure(rng, path: Path) -> tuple[str, bool]:
    """One random structural change; return (what, whether a correct run is the only answer)."""
    names = datasets(path)
    name = names[int(rng.integers(len(names)))]
    how = str(rng.choice(["delete", "extra", "bytes", "bool", "complex", "float_for_int", "truncate",
                          "extend", "add_axis", "scalar", "big_endian", "float32", "longdouble_exact",
                          "longdouble_inexact", "group"]))
    with h5py.File(path, "r") as f:
        a = f[name][()]
    if how == "delete":
        with h5py.File(path, "a") as f:
            del f[name]
    elif how == "extra":  # an additive change within the major version: must be accepted
        with h5py.File(path, "a") as f:
            f["extra/dataset"] = np.arange(3.0)
            f.attrs["extra_attribute"] = "ignored"
        return "extra dataset and attribute", True
    elif how == "bytes":
        replace(path, name, np.full(a.shape, b"x", dtype="S1"))
    elif how == "bool":
        replace(path, name, np.zeros(a.shape, dtype=bool))
    elif how == "complex":
        replace(path, name, a.astype(complex))
    elif how == "float_for_int":
        if a.dtype.kind not in "iu":
            return _structure(rng, path)
        replace(path, name, a.astype(float) + 0.5)
    elif how == "truncate":
        if not a.ndim or len(a) < 2:
            return _structure(rng, path)
        replace(path, name, a[: len(a) - 1])
    elif how == "extend":
        replace(path, name, np.concatenate([a, a[:1]]) if a.ndim and len(a) else np.zeros(3))
    elif how == "add_axis":
        replace(path, name, a[..., None])
    elif how == "scalar":
        replace(path, name, a.reshape(-1)[0] if a.size else 0.0)
    elif how == "group":
        with h5py.File(path, "a") as f:
            del f[name]
            f.create_group(name)
    elif how == "big_endian":  # an exact conversion: must be accepted
        with h5py.File(path, "a") as f:
            for n in names:
                b = f[n][()]
                if b.dtype.kind in "fiu":
                    del f[n]
                    f[n] = b.astype(b.dtype.newbyteorder(">"))
        return "big-endian datasets", True
    elif how == "float32":  # rounded values: accepted as float64, or refused if they no longer fit
        if a.dtype.kind != "f":
            return _structure(rng, path)
        replace(path, name, a.astype(np.float32))
    elif how == "longdouble_exact":
        if a.dtype.kind != "f":
            return _structure(rng, path)
        replace(path, name, a.astype(np.longdouble))
        return f"{name} as long double (exact)", True
    elif how == "longdouble_inexact":
        if a.dtype.kind != "f" or np.finfo(np.longdouble).nmant <= 52 or not a.size:
            return _structure(rng, path)
        b = a.astype(np.longdouble)
        b.flat[0] = (b.flat[0] if b.flat[0] != 0 else np.longdouble(1)) * (1 + np.longdouble(2.0) ** -60)
        replace(path, name, b)
    return f"{how} {name}", False


@pytest.mark.parametrize("kind", ["packing", "linear", "modes", "signal"])
def test_structure_fuzz(valid, tmp_path, kind):
    """Missing, extra, wrongly typed and wrongly shaped datasets, other byte orders and widths."""
    rng = np.random.default_rng([SEED, len(kind)])
    outcomes = []
    for case in range(20):
        folder = tmp_path / f"c{case}"
        folder.mkdir()
        for k in ("linear",) if kind == "modes" else ():  # the modes' linear_source, beside them
            copy(valid[k], folder / valid[k].name)
        p = copy(valid[kind], folder / valid[kind].name)
        what, must_accept = _structure(rng, p)
        out = folder / "out.h5"
        r = consume(kind, p, out)
        outcome = refused_or_correct(r, kind, p, out, what)
        if must_accept:
            assert outcome == "accepted", f"{what}: refused: {outcome}"
        if what.startswith("longdouble_inexact"):
            assert "extended precision" in outcome, f"{what}: {outcome}"
        outcomes.append(outcome)
    assert any(o != "accepted" for o in outcomes)  # the fuzz did reach the checks


def test_exact_conversions_give_the_same_signal(valid, tmp_path):
    """Big-endian and long double (exactly representable) linear files: the same signal."""
    ref = tmp_path / "ref.h5"
    assert consume("linear", valid["linear"], ref).exit_code == 0
    for how in ("big", "long"):
        p = copy(valid["linear"], tmp_path / f"{how}.h5")
        with h5py.File(p, "a") as f:
            for n in datasets(p):
                b = f[n][()]
                del f[n]
                f[n] = b.astype(b.dtype.newbyteorder(">")) if how == "big" else (
                    b.astype(np.longdouble) if b.dtype.kind == "f" else b)
        out = tmp_path / f"{how}_s.h5"
        r = consume("linear", p, out)
        assert r.exit_code == 0, r.output
        np.testing.assert_array_equal(files.read_signal(out).force, files.read_signal(ref).force)


@pytest.mark.skipif(np.finfo(np.longdouble).nmant <= 52, reason="long double is float64 here")
def test_inexact_long_double_is_refused(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    mutate_dataset(p, "grains/radius", lambda a: a.astype(np.longdouble) + np.longdouble(2.0) ** -60)
    refused(consume("packing", p, tmp_path / "o.h5"), p, tmp_path / "o.h5", "extended precision")


# ---------------------------------------------------------------- semantics: attributes
WRONG = {
    "number": ["1e-3", "False", True, np.array([1.0, 2.0]), np.array([[1]])],
    "int": ["2", 2.5, True, np.array([2, 3])],
    "bool": ["False", "True", 0.5, np.array([True, False]), 2],
    "str": [3, 1.5, np.array([1, 2])],
}


def test_attribute_type_fuzz(valid, tmp_path):
    """Every typed root attribute of every file, set to a random value of the wrong type: refused,
    naming the file and the attribute (a string "False" was taken as converged)."""
    rng = np.random.default_rng(SEED)
    n = 0
    for kind in ("packing", "linear", "modes", "signal"):
        with h5py.File(valid[kind], "r") as f:
            present = [k for k in f.attrs if k in S.ATTR_TYPES and S.ATTR_TYPES[k] in WRONG]
        for key in present:
            if key in ("schema", "schema_version"):
                continue  # a foreign schema: its own message, tested below
            choices = WRONG[S.ATTR_TYPES[key]]
            value = choices[int(rng.integers(len(choices)))]
            folder = tmp_path / f"{kind}_{key}"
            folder.mkdir()
            if kind == "modes":
                copy(valid["linear"], folder / valid["linear"].name)
            p = copy(valid[kind], folder / valid[kind].name)
            with h5py.File(p, "a") as f:
                f.attrs[key] = value
            out = folder / "out.h5"
            msg = refused(consume(kind, p, out), p, out)
            assert key in msg, msg
            n += 1
    assert n > 40


@pytest.mark.parametrize("key,value,match", [
    ("schema", "granwave.signal", "expected a granwave.packing file"),
    ("schema_version", "2.0", "schema version '2.0'"),
    ("schema", np.array(["granwave.packing", "x"], dtype=h5py.string_dtype()),
     "root attribute schema must be a string"),  # was a ValueError (truth value of an array), #66
    ("schema_version", "1.garbage", "schema_version must be \"MAJOR.MINOR\""),  # was read, #66
    ("schema_version", np.array([1, 1]), "schema_version must be"),
    ("converged", "False", "converged must be a boolean"),
    ("pressure", np.array([1e-3, 2e-3]), "pressure must be a number, found an array"),
    ("dim", 2.0, "dim must be"),
])
def test_named_attribute_cases(valid, tmp_path, key, value, match):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "a") as f:
        f.attrs[key] = value
    refused(consume("packing", p, tmp_path / "o.h5"), p, tmp_path / "o.h5", match)


def test_none_string_is_accepted_where_an_attribute_is_optional(valid, tmp_path):
    """A None written by granwave is the string "none": fine for an optional number."""
    p = copy(valid["signal"], tmp_path / "s.h5")
    with h5py.File(p, "a") as f:
        f.attrs["dt"] = "none"
    assert consume("signal", p, tmp_path / "e.h5").exit_code == 0


# ---------------------------------------------------------------- semantics: consistency
def test_foreign_linear_source(valid, tmp_path):
    """A modes file whose linear_source resolves to another system's linear file: refused (was
    a self-inconsistent signal with exit 0). Looked up beside the modes file, not in the
    current folder."""
    here = tmp_path / "elsewhere"
    here.mkdir()
    m = copy(valid["modes"], here / "m.h5")
    copy(valid["other_linear"], here / "lin.h5")  # a six-row system under the name the modes give
    out = here / "s.h5"
    refused(consume("modes", m, out), m, out, "is not the system of these modes")
    # the same size and another pressure: the digest and the attributes tell
    p4 = tmp_path / "p4.h5"
    assert run(["lattice", "--rows", 4, "--width", 4, "--pressure", 1e-4, "--friction", 0.5,
                "-o", p4, "-q"]).exit_code == 0
    (here / "lin.h5").unlink()
    assert run(["linearize", p4, "-o", here / "lin.h5", "-q"]).exit_code == 0
    refused(consume("modes", m, out), m, out, "pressure")
    # the same system with one value changed: only the digest tells
    copy(valid["linear"], here / "lin.h5")
    mutate_dataset(here / "lin.h5", "detector", lambda a: np.where(a != 0, a * 1.001, a))
    refused(consume("modes", m, out), m, out, "linear_digest")
    # the right file beside the modes file, run from another folder: accepted
    copy(valid["linear"], here / "lin.h5")
    r = consume("modes", m, out)
    assert r.exit_code == 0, r.output
    s = files.read_signal(out)
    assert s.dof_grain.shape == (s.snapshot_displacement.shape[1],)
    # no file at all
    (here / "lin.h5").unlink()
    out.unlink()
    refused(consume("modes", m, out), m, out, "not found")


def test_snapshots_on_another_packing(valid, tmp_path):
    """plot snapshot of a signal on a packing it was not computed from: refused."""
    for other in ("other_packing",):
        png = tmp_path / "snap.png"
        r = run(["plot", "snapshot", valid["signal"], "--packing", valid[other], "-o", png])
        assert r.exit_code == 2 and "does not belong to" in r.output, r.output
        assert len(r.output.strip().splitlines()) == 1 and not png.exists()
    p = tmp_path / "p4.h5"
    assert run(["lattice", "--rows", 4, "--width", 4, "--pressure", 1e-4, "--friction", 0.5,
                "-o", p, "-q"]).exit_code == 0
    r = run(["plot", "snapshot", valid["signal"], "--packing", p, "-o", tmp_path / "s.png"])
    assert r.exit_code == 2 and "packing_digest" in r.output, r.output
    r = run(["plot", "snapshot", valid["signal"], "--packing", valid["packing"], "--modes", valid["modes"],
             "--linear", valid["other_linear"], "-o", tmp_path / "s.png"])
    assert r.exit_code == 2 and "does not belong to" in r.output, r.output


def test_linear_and_modes_of_another_system(valid):
    """analyze moduli --packing and analyze spectrum --linear with files of another system."""
    r = run(["analyze", "moduli", valid["linear"], "--packing", valid["other_packing"]])
    assert r.exit_code == 2 and "does not belong to" in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1
    r = run(["analyze", "spectrum", valid["modes"], "--linear", valid["other_linear"]])
    assert r.exit_code == 2 and "not the same system" in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1


@pytest.mark.parametrize("case", ["empty", "zero_stiffness", "unsorted", "duplicate", "shape_attr",
                                  "short_mass", "indptr", "huge_detector", "tiny_mass", "asymmetric"])
def test_linear_file_cases(valid, tmp_path, case):
    """Linear files that ended in tracebacks (or NaN signals) before: each refused in one line."""
    p = copy(valid["linear"], tmp_path / "lin.h5")
    with h5py.File(p, "a") as f:
        ip, ix, data = f["matrix/indptr"][()], f["matrix/indices"][()], f["matrix/data"][()]
        if case == "empty":
            for n in datasets(p):
                b = f[n][()]
                del f[n]
                f[n] = np.zeros(1, np.int64) if n == "matrix/indptr" else b[:0]
            f["matrix"].attrs["shape"] = np.array([0, 0])
        elif case == "zero_stiffness":
            f["matrix/data"][...] = 0.0
        elif case == "unsorted":
            for r in range(len(ip) - 1):
                s = slice(ip[r], ip[r + 1])
                ix[s], data[s] = ix[s][::-1].copy(), data[s][::-1].copy()
            f["matrix/indices"][...], f["matrix/data"][...] = ix, data
        elif case == "duplicate":
            ix[1] = ix[0]
            f["matrix/indices"][...] = ix
        elif case == "shape_attr":
            f["matrix"].attrs["shape"] = np.array([3, 3])
        elif case == "short_mass":
            m = f["mass"][()]
            del f["mass"]
            f["mass"] = m[:-1]
        elif case == "indptr":
            ip[2], ip[3] = ip[3], ip[2]
            f["matrix/indptr"][...] = ip
        elif case == "huge_detector":
            f["detector"][...] = 1e300
        elif case == "tiny_mass":
            f["mass"][0] = 1e-300
        elif case == "asymmetric":  # eigensolve wrote the modes of its symmetric part, 0 exit
            rows = np.repeat(np.arange(len(ip) - 1), np.diff(ip))
            f["matrix/data"][...] = np.where(ix > rows, 1.5 * data, data)
    for cmd in (["eigensolve", p, "-o", tmp_path / "m.h5"],
                ["propagate", p, "-o", tmp_path / "s.h5", *T_MAX, "-q"]):
        refused(run(cmd), p, Path(cmd[cmd.index("-o") + 1]))


def test_asymmetry_limit_follows_prestress_and_friction(valid):
    """A D more asymmetric than a linearization of its attributes can make is refused by
    eigensolve (was a warning about negative modes and exit 0); the prestress asymmetry of a
    frictional packing (well below PRESTRESS_ASYMMETRY_PER_MU mu) is solved as before."""
    from granwave.io import validate as V
    import scipy.sparse as sp

    system = files.read_linear(valid["linear"])
    D = system.stiffness.tocsr()
    upper = sp.triu(D, k=1).tocsr()
    for prestress, friction, scale, ok in ((False, 0.5, 1e-12, True), (False, 0.5, 1e-3, False),
                                           (True, 0.5, 1e-3, True), (True, 0.0, 1e-3, False),
                                           (True, 0.5, 1.5, False)):
        system.stiffness = (D + scale * upper).tocsr()
        system.attrs.update(prestress=prestress, friction=friction)
        asym = float(sp.linalg.norm(system.stiffness - system.stiffness.T) / sp.linalg.norm(system.stiffness))
        assert (asym <= V.asymmetry_limit(system.attrs)) == ok, (prestress, friction, scale, asym)
        if ok:
            assert api.eigensolve(system).attrs["stiffness_asymmetry"] == pytest.approx(asym)
        else:
            with pytest.raises(InputError, match="D is not symmetric"):
                api.eigensolve(system)


def test_vtk_export_of_another_packings_grains(valid, tmp_path):
    """export vtk SIGNAL --packing OTHER drew the snapshots on another packing's grains with
    exit 0: refused by its digest; the signal's own packing is drawn."""
    out = tmp_path / "v.pvd"
    for other in (valid["other_packing"],):
        r = run(["export", "vtk", valid["signal"], "--packing", other, "-o", out])
        refused(r, valid["signal"], out, "does not belong to")
        assert not list(tmp_path.glob("*.vtu"))
    p4 = tmp_path / "p4.h5"  # the same grains at another pressure: only the digest tells
    assert run(["lattice", "--rows", 4, "--width", 4, "--pressure", 1e-4, "--friction", 0.5,
                "-o", p4, "-q"]).exit_code == 0
    refused(run(["export", "vtk", valid["signal"], "--packing", p4, "-o", out]), valid["signal"], out,
            "packing_digest")
    r = run(["export", "vtk", valid["signal"], "--packing", valid["packing"], "-o", out, "-q"])
    assert r.exit_code == 0 and out.exists(), r.output


def test_negative_definite_stiffness_is_refused_before_stepping(valid, tmp_path):
    p = copy(valid["linear"], tmp_path / "lin.h5")
    mutate_dataset(p, "matrix/data", lambda a: -a)
    out = tmp_path / "s.h5"
    r = run(["propagate", p, "-o", out, "--method", "time", *T_MAX, "-q"])
    assert r.exit_code == 2 and "no positive eigenvalue" in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1 and not out.exists()


def test_packing_cases(valid, tmp_path):
    """An all-zero stiffness under overlapping grains, and a packing of no grains."""
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "a") as f:
        f["contacts/stiffness_normal"][...] = 0.0
    refused(consume("packing", p, tmp_path / "l.h5"), p, tmp_path / "l.h5", "zero stiffness")
    p = copy(valid["packing"], tmp_path / "p0.h5")
    with h5py.File(p, "a") as f:
        for n in [n for n in datasets(p) if n != "box/size"]:
            b = f[n][()][:0]
            del f[n]
            f[n] = b
    refused(consume("packing", p, tmp_path / "l.h5"), p, tmp_path / "l.h5", "no grains")


def test_modes_cases(valid, tmp_path):
    """A coupling of 1e300 (a NaN signal before), no modes, omega^2 not ascending."""
    for case, fn, match in (
            ("coupling", lambda f: f["coupling"].__setitem__(Ellipsis, 1e300), "beyond"),
            ("omega2", lambda f: f["omega2"].__setitem__(0, 1e3), "not ascending")):
        p = copy(valid["modes"], tmp_path / f"{case}.h5")
        with h5py.File(p, "a") as f:
            fn(f)
        out = tmp_path / f"{case}_s.h5"
        refused(run(["propagate", p, "-o", out, *T_MAX, "-q"]), p, out, match)


# ---------------------------------------------------------------- signals
def _signal_change(rng, path: Path) -> str:
    how = str(rng.choice(["nan", "inf", "huge", "irregular", "decreasing", "repeated", "one_sample",
                          "time_nan", "snap_negative"]))
    with h5py.File(path, "a") as f:
        t, F = f["signal/time"][()], f["signal/force"][()]
        k = int(rng.integers(1, len(t) - 1))
        if how in ("nan", "inf", "huge"):
            F[k] = {"nan": np.nan, "inf": np.inf, "huge": 1e300}[how]
            f["signal/force"][...] = F
        elif how == "irregular":
            t[k] += 0.3 * (t[k + 1] - t[k])
            f["signal/time"][...] = t
        elif how == "decreasing":
            t[k], t[k + 1] = t[k + 1], t[k]
            f["signal/time"][...] = t
        elif how == "repeated":
            t[k] = t[k - 1]
            f["signal/time"][...] = t
        elif how == "time_nan":
            t[k] = np.nan
            f["signal/time"][...] = t
        elif how == "snap_negative":
            f["snapshots/time"][0] = -1.0
        elif how == "one_sample":
            for n in ("signal/time", "signal/force"):
                b = f[n][()][:1]
                del f[n]
                f[n] = b
    return f"{how} at {k}"


def test_signal_fuzz(valid, tmp_path):
    """NaN/inf/huge samples, irregular, decreasing or repeated sample times: refused in one line."""
    rng = np.random.default_rng(SEED + 1)
    for case in range(16):
        p = copy(valid["signal"], tmp_path / f"s{case}.h5")
        what = _signal_change(rng, p)
        out = tmp_path / f"e{case}.h5"
        r = run(["analyze", "ensemble", valid["signal"], p, "-o", out])
        try:
            refused(r, p, out)
        except AssertionError as exc:
            raise AssertionError(f"{what}: {exc}") from None


@pytest.mark.parametrize("key,value,match", [
    ("height", None, "mixed heights"), ("pressure", 2e-3, "mixed pressure"), ("ic", "B", "mixed ic"),
    ("kind", "chain", "mixed kind"), ("friction", 0.0, "mixed friction"), ("dim", 3, "mixed dim"),
])
def test_mismatched_ensembles_are_refused(valid, tmp_path, key, value, match):
    """analyze ensemble averaged signals of different heights (or systems) with exit 0."""
    p = copy(valid["signal"], tmp_path / "b.h5")
    if key == "height":
        p = valid["other_signal"]  # the six-row lattice
    else:
        with h5py.File(p, "a") as f:
            f.attrs[key] = value
    out = tmp_path / "e.h5"
    r = run(["analyze", "ensemble", valid["signal"], p, "-o", out])
    assert r.exit_code == 2 and match in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1 and not out.exists()


def test_ensemble_of_heights_within_the_tolerance(valid, tmp_path):
    """Disordered packings of one nominal height differ a little: still one ensemble."""
    p = copy(valid["signal"], tmp_path / "b.h5")
    with h5py.File(p, "a") as f:
        f.attrs["height"] = f.attrs["height"] * 1.02
    out = tmp_path / "e.h5"
    assert run(["analyze", "ensemble", valid["signal"], p, "-o", out]).exit_code == 0


# ---------------------------------------------------------------- the API's entry points
def test_api_refuses_wrong_objects(valid):
    pk = files.read_packing(valid["packing"])
    lin = files.read_linear(valid["linear"])
    modes = files.read_modes(valid["modes"], vectors=True)
    sig = files.read_signal(valid["signal"])
    other = files.read_linear(valid["other_linear"])
    cases = [
        lambda: api.linearize(str(valid["packing"])), lambda: api.linearize(lin),
        lambda: api.eigensolve(pk), lambda: api.eigensolve(None),
        lambda: api.propagate({}), lambda: api.propagate(modes, snapshots=(1.0,), system=pk),
        lambda: api.propagate(modes, t_max=10, samples=8, snapshots=(1.0,), system=other),
        lambda: api.front(lin), lambda: api.statics(lin), lambda: api.moduli(lin),
        lambda: api.moduli(pk, system=modes), lambda: api.ensemble(sig), lambda: api.ensemble([sig, lin]),
        lambda: api.heights([pk]), lambda: api.spectrum(lin), lambda: api.spectrum(modes, system=pk),
        lambda: api.damping([modes]), lambda: api.pressure_sweep({"a": 1}),
        lambda: api.linearize(pk, threads="2"), lambda: api.propagate(lin, progress=5),
        lambda: api.ensemble([sig, sig], labels="ab"),
        lambda: api.lattice(rows=4, width=4, pressure=True),
        lambda: api.propagate(lin, t_max="10"), lambda: api.propagate(lin, snapshots="15"),
    ]
    for k, case in enumerate(cases):
        with pytest.raises(InputError) as info:
            case()
        assert "\n" not in str(info.value), (k, str(info.value))
