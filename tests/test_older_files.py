"""Files written by an older granwave, without the attributes the checks of belonging read
(issue #66; docs/decisions/0048-older-files-checked-as-far-as-they-record.md): accepted, checked
by what they do record, with one warning line that names the file and how to remake it; a
mismatch in what they record is still one refusal line (no warning then). Tiny lattices (4 and
6 rows, modal signals): a few seconds."""

from __future__ import annotations

import json
import shutil

import pytest

from cli_refusals import lattice_files, one_line_refusal, run



@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Per lattice (rows 4 and 6; frictional): its packing, linear file, signals and moduli."""
    return lattice_files(tmp_path_factory)


def _older_signal(path, target, *drop):
    import h5py

    shutil.copy(path, target)
    with h5py.File(target, "a") as f:
        for key in drop:
            del f.attrs[key]
    return target


def _older_moduli(path, target, *drop):
    m = json.loads(path.read_text())
    for key in drop:
        m.pop(key)
    target.write_text(json.dumps(m))
    return target


def _warnings(output):
    return [line for line in output.splitlines() if line.startswith("warning: ")]


def test_older_moduli_are_checked_by_what_they_record_with_one_warning(files, tmp_path):
    old = _older_moduli(files[4]["moduli"], tmp_path / "old.json", "packing_digest")
    r = run(["analyze", "front", files[4]["shear"], "--moduli", old, "--json"])
    assert r.exit_code == 0, r.output
    (line,) = _warnings(r.output)
    assert "old.json records no packing_digest" in line and "by dim, pressure, friction, seed, height only" in line
    assert "granwave analyze moduli PACKING --json" in line
    json.loads(r.output.replace(line, ""))  # the result itself is whole
    # what it does record is still compared: another packing's (another height), one line, no warning
    other = _older_moduli(files[6]["moduli"], tmp_path / "other.json", "packing_digest")
    line = one_line_refusal(run(["analyze", "front", files[4]["shear"], "--moduli", other]), "other.json", "height")
    # the oldest kind: no packing named at all, dimension only
    oldest = _older_moduli(files[6]["moduli"], tmp_path / "oldest.json", "packing_digest", "pressure", "friction",
                           "seed", "height")
    r = run(["analyze", "front", files[4]["shear"], "--moduli", oldest, "--json"])
    assert r.exit_code == 0 and "by dim only" in _warnings(r.output)[0], r.output


def test_current_files_give_no_warning(files):
    r = run(["analyze", "front", files[4]["shear"], "--moduli", files[4]["moduli"], "--json"])
    assert r.exit_code == 0 and not _warnings(r.output), r.output
    r = run(["analyze", "attenuation", files[4]["normal"], files[6]["normal"], "--bootstrap", 5, "--json"])
    assert r.exit_code == 0 and not _warnings(r.output), r.output


@pytest.mark.parametrize("analysis", ["continuum", "attenuation"])
def test_older_signals_in_a_height_series_warn_once_and_run(files, tmp_path, analysis):
    a = _older_signal(files[4]["normal"], tmp_path / "a.h5", "lateral_width", "packing_digest")
    b = _older_signal(files[6]["normal"], tmp_path / "b.h5", "lateral_width", "packing_digest")
    extra = ["--moduli", files[4]["moduli"], "--moduli", files[6]["moduli"]] if analysis == "continuum" else []
    r = run(["analyze", analysis, a, b, *extra, "--bootstrap", 5, "--json"])
    assert r.exit_code == 0, r.output
    lines = _warnings(r.output)
    series = [line for line in lines if "record no lateral_width" in line]
    assert len(series) == 1 and f"a.h5 and {b} record no" in series[0] and "no packing_digest" in series[0], lines
    assert len(lines) == (2 if analysis == "continuum" else 1), lines  # continuum: the moduli's pairing too
    assert "granwave linearize, then propagate" in series[0]
    # mixed with a current file of another width: the older file is not compared, the rest is
    c = _older_signal(files[6]["normal"], tmp_path / "c.h5")
    import h5py

    with h5py.File(c, "a") as f:
        f.attrs["lateral_width"] = 2.0 * float(f.attrs["lateral_width"])
    r = run(["analyze", analysis, files[4]["normal"], c, *extra, "--bootstrap", 5])
    one_line_refusal(r, "c.h5")


def test_export_of_an_older_signal_on_its_packing_warns(files, tmp_path):
    """plot/export check a signal against --packing: an older one by its attributes and grains."""
    lin = files[4]["linear"]
    snap = tmp_path / "snap.h5"
    r = run(["propagate", lin, "--method", "time", "--t-max", 10, "--snapshots", "5", "-o", snap, "-q"])
    assert r.exit_code == 0, r.output
    _older_signal(snap, tmp_path / "old.h5", "packing_digest")
    out = tmp_path / "snap.pvd"
    r = run(["export", "vtk", tmp_path / "old.h5", "--packing", files[4]["packing"], "-o", out, "-q"])
    assert r.exit_code == 0, r.output
    (line,) = _warnings(r.output)
    assert "old.h5 records no packing_digest" in line
    r = run(["export", "vtk", tmp_path / "old.h5", "--packing", files[6]["packing"], "-o", tmp_path / "vtk2.pvd", "-q"])
    one_line_refusal(r, "old.h5")
    assert not list(tmp_path.glob("vtk2*"))
