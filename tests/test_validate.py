"""Every reader validates before use: a corrupt or physically impossible file is one
InputError line naming the file and the dataset, never a traceback or a crash.

The property test at the end feeds each reader randomly corrupted copies of a valid
file (seeded, bounded) in a subprocess, so that even a crash inside a C library
would show as a failed test instead of ending the test run.
"""

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from granwave import systems
from granwave.analysis.ensemble import ensemble_average, read_ensemble, write_ensemble
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files, validate
from granwave.linear.assemble import linearize
from granwave.linear.eigen import eigensolve
from granwave.linear.propagate import modal_propagate

HERE = Path(__file__).resolve().parent


def make_files(folder: Path) -> dict:
    """Valid files of every stage from a small frictional lattice (and a chain)."""
    folder.mkdir(parents=True, exist_ok=True)
    pk = systems.triangular_lattice(rows=4, width=4, pressure=1e-3, friction=0.5)
    system = linearize(pk)
    modes = eigensolve(system, vectors=True)
    sig = modal_propagate(modes, ic="A", t_max=20.0, samples=64, snapshots=[1.0, 2.0],
                          dof_grain=system.dof_grain, dof_axis=system.dof_axis)
    sig.position = pk.position
    out = {k: folder / f"{k}.h5" for k in ("packing", "linear", "modes", "signal", "chain")}
    files.write_packing(out["packing"], pk)
    files.write_linear(out["linear"], system)
    files.write_modes(out["modes"], modes)
    files.write_signal(out["signal"], sig)
    files.write_packing(out["chain"], systems.chain(n_balls=6, pressure=1e-4, polydispersity=0.1, seed=2))
    return out


@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    out = make_files(tmp_path_factory.mktemp("valid"))
    s = files.read_signal(out["signal"])
    out["ensemble"] = out["signal"].with_name("ensemble.h5")
    write_ensemble(out["ensemble"], ensemble_average([s, s]))
    return out


def copy(src: Path, dst: Path) -> Path:
    shutil.copyfile(src, dst)
    return dst


def replace(path: Path, name: str, data) -> None:
    with h5py.File(path, "a") as f:
        units = f[name].attrs.get("units", "")
        del f[name]
        f[name] = data
        f[name].attrs["units"] = units


def test_valid_files_of_every_stage_pass(valid, tmp_path):
    pk = files.read_packing(valid["packing"])
    assert pk.n_grains == 16 and len(pk.contacts) > 0
    assert files.read_packing(valid["chain"]).dim == 1
    lin = files.read_linear(valid["linear"])
    assert lin.stiffness.shape == (lin.n_dof, lin.n_dof)
    m = files.read_modes(valid["modes"], vectors=True)
    assert m.vectors.shape == (lin.n_dof, lin.n_dof)
    s = files.read_signal(valid["signal"])
    assert s.snapshot_displacement.shape == (2, lin.n_dof)
    ens = ensemble_average([s, s])
    write_ensemble(tmp_path / "e.h5", ens)
    np.testing.assert_array_equal(read_ensemble(tmp_path / "e.h5").mean, ens.mean)


def test_corrupt_indptr_is_one_line_not_a_segfault(valid, tmp_path):
    p = copy(valid["linear"], tmp_path / "lin.h5")
    with h5py.File(p, "r") as f:
        indptr = f["matrix/indptr"][()]
    bad = indptr.copy()
    bad[3] = 10**9
    replace(p, "matrix/indptr", bad)
    with pytest.raises(InputError, match=r"lin\.h5: matrix/indptr: must run from 0|matrix/indptr: decreases"):
        files.read_linear(p)
    bad = indptr.copy()
    bad[2], bad[3] = bad[3], bad[2]  # not monotone, still bounded
    replace(p, "matrix/indptr", bad)
    with pytest.raises(InputError, match="matrix/indptr: decreases at row 2"):
        files.read_linear(p)
    # The stage that crashed inside scipy (assemble.asymmetry) now stops cleanly.
    r = CliRunner().invoke(main, ["eigensolve", str(p), "-o", str(tmp_path / "m.h5")])
    assert r.exit_code == 2 and "matrix/indptr" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "m.h5").exists()


def test_indices_out_of_range(valid, tmp_path):
    p = copy(valid["linear"], tmp_path / "lin.h5")
    with h5py.File(p, "r") as f:
        idx = f["matrix/indices"][()]
        n = len(f["mass"])
    idx[5] = n
    replace(p, "matrix/indices", idx)
    with pytest.raises(InputError, match=rf"matrix/indices: index {n} at entry 5 is out of range"):
        files.read_linear(p)


def test_missing_matrix_group(valid, tmp_path):
    p = copy(valid["linear"], tmp_path / "lin.h5")
    with h5py.File(p, "a") as f:
        del f["matrix"]
    with pytest.raises(InputError, match=r"lin\.h5: matrix/\w+: missing dataset"):
        files.read_linear(p)


def test_wrong_length_radius(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    replace(p, "grains/radius", np.full(15, 0.5))
    with pytest.raises(InputError, match=r"grains/radius: has shape \(15,\), expected N = 16"):
        files.read_packing(p)


@pytest.mark.parametrize("name", ["grains/radius", "grains/mass", "grains/inertia", "box/size"])
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_zero_or_negative_grain_properties(valid, tmp_path, name, value):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "r") as f:
        a = f[name][()]
    a[1] = value
    replace(p, name, a)
    with pytest.raises(InputError, match=rf"{name}: must be > 0, entry 1 is {value:g}"):
        files.read_packing(p)


def test_zero_mass_in_a_linear_file(valid, tmp_path):
    """Zero masses gave an all-NaN modes file; now the linear file is refused."""
    p = copy(valid["linear"], tmp_path / "lin.h5")
    with h5py.File(p, "r") as f:
        m = f["mass"][()]
    m[0] = 0.0
    replace(p, "mass", m)
    with pytest.raises(InputError, match="mass: must be > 0, entry 0 is 0"):
        files.read_linear(p)


def test_huge_radii(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "r") as f:
        r = f["grains/radius"][()]
    replace(p, "grains/radius", np.full_like(r, 1e6))
    with pytest.raises(InputError, match="p.h5: (grains/position|contacts/overlap): "):
        files.read_packing(p)


def test_overlap_of_110_diameters(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "r") as f:
        ov = f["contacts/overlap"][()]
    ov[0] = 110.0
    replace(p, "contacts/overlap", ov)
    with pytest.raises(InputError, match="contacts/overlap: contact 0 overlaps by 110, more than 0.5"):
        files.read_packing(p)


def test_coincident_grains(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "r") as f:
        pos = f["grains/position"][()]
        i, j = f["contacts/i"][()], f["contacts/j"][()]
    # put grain 5 on top of a grain it does not touch (then also its contacts lie)
    touching = set(j[i == 5]) | set(i[j == 5])
    other = next(k for k in range(16) if k != 5 and k not in touching)
    pos[5] = pos[other]
    replace(p, "grains/position", pos)
    either = r"p\.h5: (grains/position: grains \d+ and \d+ overlap|contacts/overlap)"
    with pytest.raises(InputError, match=either):
        files.read_packing(p)
    # and two grains on top of each other, none of them in any contact list
    with h5py.File(p, "a") as f:
        for name in list(f["contacts"]):
            data = f[f"contacts/{name}"][()][:0]
            del f[f"contacts/{name}"]
            f[f"contacts/{name}"] = data
    with pytest.raises(InputError, match=r"grains/position: grains \d+ and \d+ overlap by"):
        files.read_packing(p)


@pytest.mark.parametrize("attr,value,message", [
    ("poisson", 0.7, "poisson must be < 0.5"), ("poisson", -0.1, "poisson must be >= 0"),
    ("friction", -0.5, "friction must be >= 0"), ("pressure", float("nan"), "pressure must be finite"),
    ("dim", 4, "dim must be 1, 2 or 3"),
])
def test_material_attributes(valid, tmp_path, attr, value, message):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "a") as f:
        f.attrs[attr] = value
    with pytest.raises(InputError, match=message):
        files.read_packing(p)


def test_contact_index_out_of_range_and_nan(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    with h5py.File(p, "r") as f:
        j = f["contacts/j"][()]
    j[0] = -3
    replace(p, "contacts/j", j)
    with pytest.raises(InputError, match=r"contacts/j: index -3 at entry 0 is out of range \[-2, 16\)"):
        files.read_packing(p)
    p = copy(valid["signal"], tmp_path / "s.h5")
    with h5py.File(p, "r") as f:
        force = f["signal/force"][()]
    force[3] = np.inf
    replace(p, "signal/force", force)
    with pytest.raises(InputError, match="signal/force: contains NaN or infinite values"):
        files.read_signal(p)


def test_snapshot_group_is_all_or_nothing(valid, tmp_path):
    p = copy(valid["signal"], tmp_path / "s.h5")
    with h5py.File(p, "a") as f:
        del f["snapshots/dof_axis"]
    with pytest.raises(InputError, match="snapshots/dof_axis: missing"):
        files.read_signal(p)


def test_dtype_is_checked(valid, tmp_path):
    p = copy(valid["packing"], tmp_path / "p.h5")
    replace(p, "contacts/i", np.zeros(len(files.read_packing(valid["packing"]).contacts)))
    with pytest.raises(InputError, match="contacts/i: has dtype float64, expected integer"):
        files.read_packing(p)


# ---------------------------------------------------------------- property test
def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _corrupt(rng: np.random.Generator, path: Path) -> str:
    """Damage the file at ``path`` in one random way; return what was done."""
    how = rng.choice(["truncate", "delete", "shape", "values", "dtype", "attr"])
    if how == "truncate":
        size = path.stat().st_size
        cut = int(rng.integers(0, size))
        with open(path, "r+b") as fh:
            fh.truncate(cut)
        return f"truncated to {cut} bytes"
    with h5py.File(path, "a") as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        name = names[int(rng.integers(len(names)))]
        a = f[name][()]
        if how == "delete":
            del f[name]
            return f"deleted {name}"
        if how == "attr":
            key = rng.choice(["dim", "poisson", "friction", "height", "pressure", "schema_version"])
            f.attrs[key] = rng.choice([-1, 0, 7, np.nan, 1e300])
            return f"attribute {key} = {f.attrs[key]}"
        del f[name]
        if how == "shape":
            if a.ndim and len(a) > 1 and rng.random() < 0.5:
                f[name] = a[: len(a) - int(rng.integers(1, len(a)))]
            elif rng.random() < 0.5:
                f[name] = np.concatenate([a, a[:1]]) if a.size else np.zeros(3)
            else:
                f[name] = a.reshape(-1)[:, None] if a.size else np.zeros((2, 2))
            return f"reshaped {name}"
        if how == "dtype":
            f[name] = np.full(a.shape, b"x", dtype="S1") if a.ndim else b"x"
            return f"{name} as bytes"
        b = np.array(a, copy=True)
        flat = b.reshape(-1)
        if flat.size:
            k = rng.integers(flat.size, size=int(rng.integers(1, 4)))
            if b.dtype.kind == "f":
                flat[k] = rng.choice([np.nan, np.inf, -1.0, 0.0, 1e300, -1e-3, 110.0])
            else:
                flat[k] = rng.choice([-(2**40), -3, -1, 2**40, 10**9])
        f[name] = b
        return f"values of {name}"


_READERS = {
    "packing": "read_packing", "chain": "read_packing", "linear": "read_linear",
    "modes": "read_modes", "signal": "read_signal", "ensemble": None,
}


def fuzz(kind: str, valid_path: str, folder: str, seed: int, cases: int) -> list:
    """Run the reader of ``kind`` on ``cases`` corrupted copies; return the unexpected outcomes."""
    from granwave.linear.assemble import asymmetry

    rng = np.random.default_rng(seed)
    reader = read_ensemble if kind == "ensemble" else getattr(files, _READERS[kind])
    problems = []
    for case in range(cases):
        p = Path(folder) / f"{kind}_{case}.h5"
        shutil.copyfile(valid_path, p)
        what = _corrupt(rng, p)
        before = _digest(p)
        try:
            obj = reader(p, vectors=True) if kind == "modes" else reader(p)
            # accepted: the result must be usable by the kernels that crashed before
            if kind == "linear":
                asymmetry(obj.stiffness)
                obj.stiffness @ np.ones(obj.n_dof)
            if kind in ("packing", "chain"):
                linearize(obj, check=False, force=True)
        except InputError as exc:
            msg = str(exc)
            if "\n" in msg or str(p) not in msg:
                problems.append(f"{what}: message not one line naming the file: {msg!r}")
        except Exception as exc:  # noqa: BLE001 - exactly what the test looks for
            problems.append(f"{what}: {type(exc).__name__}: {exc}")
        if _digest(p) != before:
            problems.append(f"{what}: the reader changed its input")
    return problems


@pytest.mark.parametrize("kind", ["packing", "chain", "linear", "modes", "signal", "ensemble"])
def test_randomly_corrupted_files_give_a_clean_error_or_a_correct_result(valid, tmp_path, kind):
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import test_validate as T; "
            "print(json.dumps(T.fuzz(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]), 40)))")
    run = subprocess.run([sys.executable, "-c", code, str(HERE), kind, str(valid[kind]), str(tmp_path),
                          str(17 + len(kind))], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(HERE.parent)})
    assert run.returncode == 0, f"reader crashed (status {run.returncode}): {run.stderr[-3000:]}"
    problems = json.loads(run.stdout.strip().splitlines()[-1])
    assert problems == [], "\n".join(problems)


def test_limits_are_the_parameter_ranges():
    """The validator's Poisson range is the one the preparation parameters enforce."""
    from granwave.dem.params import PrepareParams

    PrepareParams(poisson=validate.POISSON_MIN)
    with pytest.raises(InputError):
        PrepareParams(poisson=validate.POISSON_MAX)


def test_layout_covers_every_documented_dataset():
    from granwave.io import schema as S

    for name, table in S.DATASETS.items():
        assert set(S.LAYOUT[name]) == set(table), name
        assert S.OPTIONAL[name] <= set(table), name


def test_the_stiffest_prepared_packings_pass(tmp_path):
    """p = 1e-2, the stiffest pressure the project prepares: the overlap bound lets it pass."""
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    pk = prepare_packing(PrepareParams(grains=150, pressure=1e-2, friction=0.5))
    files.write_packing(tmp_path / "p.h5", pk)
    q = files.read_packing(tmp_path / "p.h5")
    ratio = q.contacts.overlap / q.radius[q.contacts.i]
    assert 0.25 < ratio.max() < validate.MAX_OVERLAP_FRACTION  # overlaps are large, still accepted


def test_unsorted_and_repeated_snapshot_times_are_valid(tmp_path):
    """Snapshots are stored in the order asked for; only sample times must increase."""
    system = linearize(systems.chain(n_balls=4, pressure=1e-4))
    modes = eigensolve(system, vectors=True)
    sig = modal_propagate(modes, ic="B", t_max=10.0, samples=20, snapshots=[5.0, 1.0, 1.0],
                          dof_grain=system.dof_grain, dof_axis=system.dof_axis)
    files.write_signal(tmp_path / "s.h5", sig)
    np.testing.assert_array_equal(files.read_signal(tmp_path / "s.h5").snapshot_time, [5.0, 1.0, 1.0])
    with h5py.File(tmp_path / "s.h5", "a") as f:
        f["snapshots/time"][0] = -1.0
    with pytest.raises(InputError, match="snapshots/time: must be >= 0, entry 0 is -1"):
        files.read_signal(tmp_path / "s.h5")
