"""Inputs that must belong together (issue #66): a signal and its moduli, the signals of one
height series, options that only mean something with others. Every mismatch is refused in one
line naming the file (exit 2, nothing written); the matching inputs run. Tiny lattices (4 and 6
rows, modal signals): the module's files take a few seconds, each case well under one."""

from __future__ import annotations

import json
import shutil

import pytest

from cli_refusals import SIGNAL_ARGS, lattice_files, one_line_refusal as refused, run  # noqa: E402

T = SIGNAL_ARGS


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Per lattice (rows 4 and 6; frictional): its packing, linear file, signals and moduli."""
    return lattice_files(tmp_path_factory)


def edited(files, tmp_path, **changes):
    m = json.loads(files[4]["moduli"].read_text())
    m.update(changes)
    path = tmp_path / "m.json"
    path.write_text(json.dumps(m))
    return path


def test_the_moduli_of_a_shear_signal_must_be_its_packings(files, tmp_path):
    """analyze front of a shear signal took another packing's moduli, 3D moduli for a 2D
    signal, a dim of 7 and a c_t given as a string, with exit 0."""
    sh = files[4]["shear"]
    assert run(["analyze", "front", sh, "--moduli", files[4]["moduli"], "--json"]).exit_code == 0
    refused(run(["analyze", "front", sh, "--moduli", files[6]["moduli"]]), "another packing", "mod.json")
    old = json.loads(files[6]["moduli"].read_text())
    old.pop("packing_digest")  # a file written before the moduli named their packing: its height
    (tmp_path / "old.json").write_text(json.dumps(old))
    refused(run(["analyze", "front", sh, "--moduli", tmp_path / "old.json"]), "height")
    m = json.loads(files[4]["moduli"].read_text())
    m.pop("packing_digest")
    for changes, words in (({"dim": 3}, "dim = 3, the signal 2"), ({"dim": 7}, "dim 7"),
                           ({"c_t": "0.3"}, "c_t '0.3' is not a finite number"),
                           ({"c_t": True}, "c_t True"), ({"dim": True}, "dim True")):
        path = tmp_path / "m.json"
        path.write_text(json.dumps({**m, **changes}))
        refused(run(["analyze", "front", sh, "--moduli", path]), *words)


@pytest.mark.parametrize("option", [["--moduli", "MOD"], ["--pulse", "ricker"], ["--response", "delay"],
                                    ["--frequency", "0.1"], ["--wavelength", "4"], ["--units", "si"],
                                    ["--material", "quartz"], ["--any-poisson"], ["--diameter", "2"]])
def test_shear_options_on_a_compressional_signal_are_refused(files, option):
    option = [str(files[4]["moduli"]) if o == "MOD" else o for o in option]
    refused(run(["analyze", "front", files[4]["normal"], *option]), "only for shear signals", option[0])


@pytest.mark.parametrize("args, words", [(["--frequency", "0.05", "--wavelength", "8"], "give one"),
                                         (["--material", "quartz"], "only for --units si"),
                                         (["--diameter", "2"], "only for --units si")])
def test_options_that_one_another_silence_are_refused(files, args, words):
    """--frequency with --wavelength (one silently won), --material without --units si."""
    refused(run(["analyze", "front", files[4]["shear"], "--moduli", files[4]["moduli"], *args]), words)


def test_a_height_series_counts_each_packing_once(files, tmp_path):
    """analyze continuum and attenuation counted one file given twice (or two copies of it) as
    two packings, and paired moduli with the wrong heights."""
    a, b = files[4], files[6]
    ok = run(["analyze", "continuum", a["normal"], b["normal"], "--moduli", a["moduli"], "--moduli",
              b["moduli"], "--bootstrap", 5, "--json"])
    assert ok.exit_code == 0, ok.output
    refused(run(["analyze", "continuum", a["normal"], b["normal"], "--moduli", b["moduli"], "--moduli",
                 a["moduli"]]), "another packing")
    refused(run(["analyze", "continuum", a["normal"], a["normal"], "--moduli", a["moduli"], "--moduli",
                 a["moduli"]]), "given twice")
    copy = shutil.copy(a["normal"], tmp_path / "copy.h5")
    for cmd in (["continuum", a["normal"], copy, b["normal"], *sum((["--moduli", m] for m in
                 (a["moduli"], edited(files, tmp_path), b["moduli"])), [])],
                ["attenuation", a["normal"], copy, b["normal"]]):
        refused(run(["analyze", *cmd]), "signals of one packing", "copy.h5")
    refused(run(["analyze", "attenuation", a["normal"], b["normal"], "--moduli", b["moduli"], "--moduli",
                 a["moduli"]]), "another packing")


@pytest.mark.parametrize("analysis", ["continuum", "attenuation"])
@pytest.mark.parametrize("key, value", [("source_kind", "shear"), ("dim", 3), ("friction", 0.0),
                                        ("lateral_width", 5.0), ("contact_law", "harmonic"), ("pressure", 1e-4)])
def test_a_height_series_is_one_kind_of_column(files, tmp_path, analysis, key, value):
    """Mixing 2D and 3D, widths, friction, laws, source kinds (a shear signal analysed as a
    compressional front) or pressures: refused naming the signal."""
    import h5py

    other = shutil.copy(files[6]["normal"], tmp_path / "other.h5")
    with h5py.File(other, "a") as f:
        f.attrs[key] = value
    extra = ["--moduli", files[4]["moduli"], "--moduli", files[6]["moduli"]] if analysis == "continuum" else []
    # (continuum: a 3D signal is refused by its 2D moduli, naming it, before the mix is seen)
    refused(run(["analyze", analysis, files[4]["normal"], other, *extra]), "other.h5")


# ---------------------------------------------------------------- options silently ignored
@pytest.mark.parametrize("args, words", [
    (["prepare-packing", "--grains", 10, "--harmonic-stiffness", 2], "--contact-law harmonic"),
    (["prepare-packing", "--grains", 10, "--rolling-stiffness", 2], "--rolling sds"),
    (["prepare-packing", "--grains", 10, "--cone-slope", 0.1, "--contact-law", "harmonic"], "--contact-law cone"),
    (["prepare-packing", "--grains", 10, "--viscous-damping", 0.1], "--damping-law constant_viscous"),
    (["lattice", "--rows", 3, "--width", 4, "--pressure", 1e-3, "--harmonic-stiffness", 2], "--contact-law harmonic"),
    (["prepare-packing", "--grains", 10, "--checkpoint-every", 5], "--checkpoint-every without --checkpoint"),
])
def test_an_option_without_effect_is_refused(tmp_path, args, words):
    """Options that only mean something with another were ignored without a word."""
    out = tmp_path / "p.h5"
    refused(run([*args, "-o", out]), words)
    assert not out.exists()


def test_a_sub_models_parameter_with_its_sub_model_runs(tmp_path):
    out = tmp_path / "p.h5"
    r = run(["lattice", "--rows", 3, "--width", 4, "--pressure", 1e-3, "--contact-law", "harmonic",
             "--harmonic-stiffness", 2, "-o", out, "-q"])
    assert r.exit_code == 0 and out.exists(), r.output


def test_import_lammps_refuses_a_harmonic_packings_data_file(tmp_path):
    """A harmonic packing's data file was relaxed as Hertz without a word: the law is read from
    the data file's title (or the deck beside it) and a law other than Hertz refused."""
    p = tmp_path / "h.h5"
    assert run(["lattice", "--rows", 3, "--width", 4, "--pressure", 1e-3, "--contact-law", "harmonic",
                "-o", p, "-q"]).exit_code == 0
    folder = tmp_path / "ex"
    assert run(["export", "lammps", p, "-o", folder, "-q"]).exit_code == 0
    data = folder / "packing.data"
    out = tmp_path / "imp.h5"
    refused(run(["import", "lammps", data, "--pressure", 1e-3, "-o", out]), "contact law is harmonic")
    lines = data.read_text().splitlines()  # a title without the law (older export): the deck tells
    data.write_text("\n".join([lines[0].replace(", contact_law harmonic", ""), *lines[1:]]) + "\n")
    refused(run(["import", "lammps", data, "--pressure", 1e-3, "-o", out]), "hooke")
    assert not out.exists()


# ---------------------------------------------------------------- messages that name the cause
@pytest.mark.parametrize("args, words", [
    (["--frequency", 100], "above the record's Nyquist frequency"),   # was "identically zero"
    (["--frequency", 0.01], "longer than the record"),               # was "never reaches its peak"
    (["--frequency", 0.04, "--pulse", "ricker"], "longer than the record"),
])
def test_a_pulse_the_record_cannot_hold_is_named(files, args, words):
    refused(run(["analyze", "front", files[4]["shear"], *args]), words)


def test_a_frictional_linear_file_without_its_shear_group(files, tmp_path):
    """Was refused as 'the packing is frictionless (friction = 0.5)'."""
    import h5py

    lin = shutil.copy(files[4]["packing"].with_name("lin.h5"), tmp_path / "lin.h5")
    with h5py.File(lin, "a") as f:
        del f["shear"]
    out = tmp_path / "s.h5"
    line = refused(run(["propagate", lin, "--source", "shear", "-o", out, *T]), "without its shear group")
    assert "frictionless" not in line and not out.exists()


# ---------------------------------------------------------------- the API's objects
@pytest.mark.parametrize("damage, words", [("negative_mass", "mass: must be > 0"),
                                           ("nan_detector", "detector: contains NaN"),
                                           ("short_detector", "has shape (47,)"),
                                           ("asymmetric", "D is not symmetric")])
def test_a_linear_system_built_in_memory_is_checked_like_a_file(files, damage, words):
    """api.propagate of a system with a negative mass ended in ArpackError -9999 and
    api.eigensolve gave NaN modes: the file reader's checks run on the object."""
    import numpy as np
    import scipy.sparse as sp

    from granwave import api
    from granwave.errors import InputError
    from granwave.io import files as F

    s = F.read_linear(files[4]["packing"].with_name("lin.h5"))
    assert s.n_dof == 48
    if damage == "negative_mass":
        s.mass[3] = -1.0
    elif damage == "nan_detector":
        s.detector[0] = np.nan
    elif damage == "short_detector":
        s.detector = s.detector[:-1]
    else:
        s.stiffness = (s.stiffness + 0.1 * sp.triu(s.stiffness, k=1)).tocsr()
    for call in (lambda: api.propagate(s, method="time", t_max=5, samples=16), lambda: api.eigensolve(s)):
        with pytest.raises(InputError, match=words.replace("(", r"\(").replace(")", r"\)")):
            call()


def test_widths_a_few_per_cent_apart_are_one_series(files, tmp_path):
    """A prepared packing's width follows from its drawn radii (a few per cent apart within one
    config): accepted; another width (WIDTH_RTOL apart) is refused by the case above."""
    import h5py

    other = shutil.copy(files[6]["normal"], tmp_path / "other.h5")
    with h5py.File(other, "a") as f:
        f.attrs["lateral_width"] = 1.03 * float(f.attrs["lateral_width"])
    r = run(["analyze", "continuum", files[4]["normal"], other, "--moduli", files[4]["moduli"],
             "--moduli", files[6]["moduli"], "--bootstrap", 5, "--json"])
    assert r.exit_code == 0, r.output
