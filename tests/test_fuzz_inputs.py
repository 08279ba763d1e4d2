"""Bad input that used to end in a traceback of another type (issue #66): each case is a tiny
input, through the API (a clean InputError naming the problem) or through click's CliRunner
(exit status 2, one line, no output file, the input untouched)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import api
from granwave.cli import main
from granwave.errors import InputError
from granwave.model import Signal


def run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


def refused(r, *words):
    """Exit 2, one line naming each of ``words``, no traceback."""
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    lines = [x for x in r.output.splitlines() if x.strip()]
    assert len(lines) == 1, r.output
    for w in words:
        assert w in lines[0], r.output


@pytest.fixture(scope="module")
def lattice():
    return api.lattice(rows=3, width=3, pressure=1e-3, friction=0.5)


def test_linearize_refuses_a_contact_to_a_missing_grain(lattice):
    n = len(lattice.radius)
    j = lattice.contacts.j.copy()
    lattice.contacts.j[0] = n + 90
    try:
        with pytest.raises(InputError, match=rf"contacts/j: index {n + 90} at entry 0 is out of range"):
            api.linearize(lattice)
    finally:
        lattice.contacts.j[:] = j
    api.linearize(lattice)  # the same packing, repaired, is linearized


@pytest.fixture(scope="module")
def signal(lattice):
    return api.propagate(api.eigensolve(api.linearize(lattice)), method="modal", t_max=20, samples=64)


def test_front_refuses_a_signal_without_a_height(signal):
    height = signal.attrs.pop("height")
    try:
        with pytest.raises(InputError, match="signal has no height attribute"):
            api.front(signal)
        signal.attrs["height"] = "tall"
        with pytest.raises(InputError, match="height must be a number"):
            api.front(signal)
    finally:
        signal.attrs["height"] = height
    assert api.front(signal)["height"] == height


@pytest.mark.parametrize("text", ['{"a":' * 100000 + "1" + "}" * 100000,  # past the decoder's recursion
                                  "[" * 65 + "]" * 65],  # decodes, but deeper than any summary
                         ids=["past-recursion", "depth-65"])
def test_deeply_nested_json_is_refused(tmp_path, text):
    src = tmp_path / "sums" / "s.json"
    src.parent.mkdir()
    src.write_text(text)
    for args, out in ((["pressure-sweep", src, "-o", tmp_path / "sw.h5"], tmp_path / "sw.h5"),
                      (["report", "--summaries", src.parent, "-o", tmp_path / "r.md"], tmp_path / "r.md")):
        refused(run(args), str(src), "nested more than 64 levels deep")
        assert not out.exists()
    assert src.read_text() == text


def _lammps_data(rows, n=None):
    """A LAMMPS data file (atom_style sphere: id type diameter density x y z) of ``rows``."""
    n = len(rows) if n is None else n
    return "\n".join(["LAMMPS data file", "", f"{n} atoms", "1 atom types", "0 4 xlo xhi", "0 4 ylo yhi",
                      "-0.5 0.5 zlo zhi", "", "Atoms # sphere", "", *rows, ""])


def import_refused(tmp_path, text, *words):
    src = tmp_path / "in.data"
    src.write_text(text)
    out = tmp_path / "out.h5"
    refused(run(["import", "lammps", src, "-o", out, "--pressure", 1e-4, "-q"]), str(src), *words)
    assert not out.exists() and not list(tmp_path.glob(".out.h5*"))
    assert src.read_text() == text


def test_lammps_data_file_without_atoms_is_refused(tmp_path):
    import_refused(tmp_path, _lammps_data([]), "no atoms")


def test_lammps_data_file_with_a_repeated_atom_id_is_refused(tmp_path):
    from granwave.interop import lammps as LM

    rows = ["1 1 1.0 1.0 1.0 1.0 0.0", "2 1 1.0 1.0 3.0 1.0 0.0"]
    import_refused(tmp_path, _lammps_data([rows[0], "1" + rows[1][1:]]), "atom id 1 appears more than once")
    (tmp_path / "ok.data").write_text(_lammps_data(rows))
    assert len(LM.read_data(tmp_path / "ok.data").radius) == 2  # distinct ids read


def test_analyze_front_refuses_an_unknown_initial_condition(signal, tmp_path):
    import h5py

    from granwave.io import files

    src = tmp_path / "s.h5"
    files.write_signal(src, signal)
    assert run(["analyze", "front", src, "--json"]).exit_code == 0
    with h5py.File(src, "a") as f:
        f.attrs["ic"] = "Z"
    before = src.read_bytes()
    refused(run(["analyze", "front", src, "--json"]), str(src), "root attribute ic must be one of A, B")
    assert src.read_bytes() == before


def test_propagate_refuses_modes_whose_omega2_are_all_zero(lattice, tmp_path):
    import h5py

    from granwave.io import files

    src, out = tmp_path / "m.h5", tmp_path / "s.h5"
    files.write_modes(src, api.eigensolve(api.linearize(lattice)))
    with h5py.File(src, "a") as f:
        f["omega2"][...] = 0.0
    before = src.read_bytes()
    refused(run(["propagate", src, "-o", out, "--t-max", 20, "--samples", 64, "-q"]),
            "modes have omega^2 = 0: none oscillates")
    assert not out.exists() and not list(tmp_path.glob(".s.h5*"))
    assert src.read_bytes() == before


def test_numpy_scalars_are_taken_where_python_numbers_are():
    from granwave.params import LatticeParams, PrepareParams

    p = PrepareParams(grains=np.int64(10), pressure=np.float32(1e-4), friction=np.float64(0.5), seed=np.uint8(2))
    assert (type(p.grains), type(p.pressure), type(p.seed)) == (int, float, int) and p.grains == 10
    assert p.pressure == float(np.float32(1e-4))
    assert api.lattice(rows=np.int32(3), width=np.array(3), pressure=np.float64(1e-3)).attrs == \
        api.lattice(rows=3, width=3, pressure=1e-3).attrs
    with pytest.raises(InputError, match="rows must be an integer"):
        LatticeParams(rows=np.float64(3.5), width=3, pressure=1e-3)
    with pytest.raises(InputError, match="pressure must be a number"):
        LatticeParams(rows=3, width=3, pressure=np.bool_(True))


@pytest.mark.parametrize("seeds,match", [([1.5, 2.7], r"seeds\[0\]: seed must be an integer, got 1.5"),
                                         ("12", "seeds must be a sequence of integers, got str"),
                                         ([True, 2], r"seeds\[0\]: seed must be an integer, got True"),
                                         ([3, "4"], r"seeds\[1\]: seed must be an integer")])
def test_prepare_packings_refuses_seeds_that_are_not_integers(seeds, match):
    with pytest.raises(InputError, match=match):  # refused before any DEM step
        api.prepare_packings(grains=10, pressure=1e-4, friction=0.0, seeds=seeds)


@pytest.mark.parametrize("moduli", [[1.0, 2.0], "moduli.json", 0.09])
def test_shear_front_refuses_moduli_that_are_not_a_mapping(moduli):
    t = np.linspace(0.0, 100.0, 1001)
    sig = Signal(time=t, force=np.exp(-((t - 50.0) / 5.0) ** 2),
                 attrs=dict(ic="A", height=20.0, source_kind="shear", method="modal"))
    with pytest.raises(InputError, match=f"moduli must be a mapping .*got {type(moduli).__name__}"):
        api.shear_front(sig, moduli=moduli)


@pytest.mark.parametrize("args, words", [
    (["propagate", "x.h5", "--ic", "Q"], "Invalid value for '--ic'"),
    (["analyze", "front", "sh.h5", "--material", "unobtainium", "--units", "si"], "'unobtainium' is not one of"),
    (["lattice", "--rows", "abc"], "'abc' is not a valid integer"),
    (["analyze", "front"], "Missing argument 'SIGNAL'"),
    (["bogus"], "No such command 'bogus'"),
])
def test_usage_errors_are_one_line(args, words):
    """Click's usage errors printed the usage and a hint above the error (three lines): one line,
    exit 2, naming the command's --help (issue #66: unknown --material)."""
    from cli_refusals import one_line_refusal, run

    line = one_line_refusal(run(args), words)
    assert line.endswith("--help')"), line


def test_help_and_version_still_exit_0():
    from cli_refusals import run

    for args in (["--help"], ["--version"], ["analyze", "front", "--help"]):
        r = run(args)
        assert r.exit_code == 0 and len(r.output.splitlines()) >= 1, (args, r.output)
