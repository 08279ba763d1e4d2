"""The output-name policy of the CLI (granwave.cli.common.OutputOption): a wrong suffix
or a name too long for the file system is one line, exit status 2, before any work and
without any file; export lammps writes into an existing folder; export vtk names every
file it wrote; propagate has -q."""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from granwave.cli import main
from granwave.io import atomic


def run(args):
    atomic._INPUTS.clear()  # as separate processes would
    return CliRunner().invoke(main, [str(a) for a in args])


def one_line_error(result, *words):
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    for w in words:
        assert w in lines[0], result.output


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """A chain of 8 balls, its linear file and a signal with two snapshots."""
    d = tmp_path_factory.mktemp("chain")
    assert run(["chain", "--balls", 8, "--pressure", 1e-4, "-o", d / "c.h5"]).exit_code == 0
    assert run(["linearize", d / "c.h5", "-o", d / "l.h5"]).exit_code == 0
    r = run(["propagate", d / "l.h5", "--method", "time", "--t-max", 20, "--snapshots", "5,10",
             "-q", "-o", d / "s.h5"])
    assert r.exit_code == 0, r.output
    return d


@pytest.mark.parametrize("name", ["c", "c.txt", "c.h5.bak"])
def test_hdf5_stage_refuses_a_name_without_its_suffix(tmp_path, name):
    r = run(["chain", "--balls", 4, "--pressure", 1e-4, "-o", tmp_path / name])
    one_line_error(r, "must end in .h5 or .hdf5")
    assert not list(tmp_path.iterdir())


def test_hdf5_suffix_in_capitals_and_hdf5_are_accepted(tmp_path):
    for name in ("c.H5", "c.hdf5"):
        assert run(["chain", "--balls", 4, "--pressure", 1e-4, "-o", tmp_path / name]).exit_code == 0
        assert (tmp_path / name).is_file()


def test_a_name_whose_temporary_name_is_too_long_is_refused_first(tmp_path, chain):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    name = "a" * (limit - 10) + ".h5"  # fits, its temporary name does not
    r = run(["linearize", chain / "c.h5", "-o", tmp_path / name])
    one_line_error(r, "temporary name", f"{limit}")
    r = run(["linearize", chain / "c.h5", "-o", tmp_path / ("a" * (limit + 1) + ".h5")])
    one_line_error(r, "bytes, over the file system")
    assert not list(tmp_path.iterdir())


def test_propagate_quiet(tmp_path, chain, monkeypatch):
    from granwave import api

    real = api.propagate

    def talkative(*args, progress=None, **kwargs):  # a progress line, as a long run prints
        progress("propagate: t = 1 / 10")
        return real(*args, progress=progress, **kwargs)

    monkeypatch.setattr(api, "propagate", talkative)
    args = ["propagate", chain / "l.h5", "--method", "time", "--t-max", 10, "-o", tmp_path / "s.h5"]
    loud = CliRunner().invoke(main, [str(a) for a in args])
    quiet = CliRunner().invoke(main, [str(a) for a in args + ["-q"]])
    assert loud.exit_code == quiet.exit_code == 0, (loud.output, quiet.output)
    assert "propagate: t = 1 / 10" in loud.stderr and not quiet.stderr


def test_export_vtk_suffix_follows_the_input(tmp_path, chain):
    one_line_error(run(["export", "vtk", chain / "c.h5", "-o", tmp_path / "out"]), ".vtu or .pvd")
    one_line_error(run(["export", "vtk", chain / "c.h5", "-o", tmp_path / "out.pvd"]), "must end in .vtu")
    one_line_error(run(["export", "vtk", chain / "s.h5", "--packing", chain / "c.h5",
                        "-o", tmp_path / "out.vtu"]), "must end in .pvd")
    assert not list(tmp_path.iterdir())


def test_export_vtk_names_every_file_written(tmp_path, chain):
    pytest.importorskip("meshio")
    r = CliRunner().invoke(main, ["export", "vtk", str(chain / "s.h5"), "--packing",
                                                  str(chain / "c.h5"), "-o", str(tmp_path / "snap.pvd")])
    assert r.exit_code == 0, r.output
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == ["snap.pvd", "snap_0000.vtu", "snap_0001.vtu"]
    assert r.stderr.startswith("wrote 3 files:")
    assert all(name in r.stderr for name in written)


def test_export_lammps_into_an_existing_folder(tmp_path, chain):
    # a chain is 1D, which LAMMPS does not run: use a tiny 2D lattice
    pk = tmp_path / "lat.h5"
    r = run(["lattice", "--rows", 2, "--width", 3, "--pressure", 1e-4, "-o", pk])
    assert r.exit_code == 0, r.output
    deck = tmp_path / "deck"
    deck.mkdir()
    for _ in range(2):  # an existing folder, then one holding the previous files
        r = run(["export", "lammps", pk, "-o", deck, "-q"])
        assert r.exit_code == 0, r.output
        assert (deck / "packing.data").is_file() and (deck / "in.granwave").is_file()
    one_line_error(run(["export", "lammps", pk, "-o", pk]), "not a folder")


#: Commands with an -o that print nothing on stderr but warnings (their result table is
#: on stdout, like --json): nothing for -q to silence.
NO_STDERR_SUMMARY = {"linearize", "eigensolve", "analyze ensemble", "pressure-sweep"}


def _commands(group, ctx, prefix=()):
    import click

    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, ctx, prefix + (name,))
        else:
            yield " ".join(prefix + (name,)), cmd


def test_every_command_with_an_output_declares_its_suffixes_and_has_quiet():
    import click

    from granwave.cli.common import OutputOption

    ctx = click.Context(main)
    seen = []
    for name, cmd in _commands(main, ctx):
        outputs = [p for p in cmd.params if "-o" in getattr(p, "opts", ())]
        if not outputs:
            continue
        seen.append(name)
        assert all(isinstance(p, OutputOption) for p in outputs), f"{name}: -o is not an OutputOption"
        assert all(p.suffixes or p.folder for p in outputs), f"{name}: -o declares no suffix"
        has_quiet = any("-q" in getattr(p, "opts", ()) for p in cmd.params)
        assert has_quiet or name in NO_STDERR_SUMMARY, f"{name}: no -q"
    assert {"propagate", "prepare-packing", "export vtk", "plot airy"} <= set(seen)


def test_quiet_silences_the_summary_lines(tmp_path):
    for args in (["chain", "--balls", 3, "--pressure", 1e-4, "-o", tmp_path / "c.h5"],
                 ["plot", "airy", "--n", 20, "-o", tmp_path / "a.png"]):
        loud, quiet = CliRunner().invoke(main, [str(a) for a in args]), \
            CliRunner().invoke(main, [str(a) for a in args + ["-q"]])
        assert loud.exit_code == quiet.exit_code == 0, (loud.output, quiet.output)
        assert loud.stderr and not quiet.stderr
