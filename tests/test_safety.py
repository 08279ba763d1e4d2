"""Outputs never destroy anything; requests that cannot fit are refused before allocating.

One test per case: an output that is an input (same path, hard link, symbolic link),
a target that is not a regular file (FIFO, folder), '-', umask permissions, stale
temporary files of killed runs, a full disk, and the size guards.
"""

import errno
import hashlib
import os
import stat
import subprocess
import sys
import time

import click
import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from granwave import resources, systems
from granwave.cli import main
from granwave.cli.common import stage
from granwave.errors import InputError, OutputError, ResourceError
from granwave.io import atomic, files
from granwave.linear.assemble import linearize
from granwave.linear.eigen import eigensolve
from granwave.linear.propagate import modal_propagate


def digest(path) -> str:
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.fixture
def pk_file(tmp_path):
    p = tmp_path / "pk.h5"
    files.write_packing(p, systems.triangular_lattice(rows=3, width=3, pressure=1e-4, friction=0.5))
    return p


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


# ---------------------------------------------------------------- output is an input
def test_linearize_refuses_to_overwrite_its_input(pk_file):
    before = digest(pk_file)
    r = invoke("linearize", pk_file, "-o", pk_file)
    assert r.exit_code == 2, r.output
    assert "is the input file" in r.output and "Traceback" not in r.output
    assert len(r.output.strip().splitlines()) == 1
    assert digest(pk_file) == before


@pytest.mark.parametrize("link", [os.link, os.symlink])
def test_links_to_an_input_count_as_the_input(pk_file, tmp_path, link):
    alias = tmp_path / "alias.h5"
    link(pk_file, alias)
    before = digest(pk_file)
    r = invoke("linearize", pk_file, "-o", alias)
    assert r.exit_code == 2 and "is the input file" in r.output
    assert digest(pk_file) == before


def test_eigensolve_and_ensemble_refuse_their_inputs(pk_file, tmp_path):
    lin = tmp_path / "lin.h5"
    assert invoke("linearize", pk_file, "-o", lin).exit_code == 0
    before = digest(lin)
    r = invoke("eigensolve", lin, "-o", lin)
    assert r.exit_code == 2 and "is the input file" in r.output and digest(lin) == before
    system = files.read_linear(lin)
    modes = eigensolve(system)
    for name in ("a", "b"):
        files.write_signal(tmp_path / f"{name}.h5", modal_propagate(modes, ic="A", t_max=20.0, samples=50))
    before = digest(tmp_path / "a.h5")
    r = invoke("analyze", "ensemble", tmp_path / "a.h5", tmp_path / "b.h5", "-o", tmp_path / "a.h5")
    assert r.exit_code == 2 and "is the input file" in r.output
    assert digest(tmp_path / "a.h5") == before


def test_library_writers_refuse_a_file_read_in_this_process(pk_file):
    """The check lives in the writers: no CLI module needs to remember it."""
    pk = files.read_packing(pk_file)
    before = digest(pk_file)
    with pytest.raises(InputError, match="is the input file"):
        files.write_linear(pk_file, linearize(pk))
    with pytest.raises(InputError, match="is the input file"):
        files.atomic_text(pk_file, "x")
    with pytest.raises(InputError, match="is the input file"):
        with files.atomic_file(pk_file):
            pass
    assert digest(pk_file) == before
    files.atomic_text(pk_file, "updated\n", replace_input=True)  # an explicit update in place
    assert pk_file.read_text() == "updated\n"


# ---------------------------------------------------------------- non-regular targets
def test_fifo_and_folder_targets_are_refused(pk_file, tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    r = invoke("linearize", pk_file, "-o", fifo)
    assert r.exit_code == 2 and "FIFO, not a regular file" in r.output
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)  # still a FIFO, not replaced
    pk = files.read_packing(pk_file)
    for writer in (lambda p: files.write_packing(p, pk), lambda p: files.atomic_text(p, "x")):
        with pytest.raises(InputError, match="FIFO, not a regular file"):
            writer(fifo)
        with pytest.raises(InputError, match="folder, not a regular file"):
            writer(tmp_path)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_device_target_is_refused():
    with pytest.raises(InputError, match="device, not a regular file"):
        files.check_writable(os.devnull)


def test_dash_is_not_a_file_name(pk_file, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = invoke("linearize", pk_file, "-o", "-")
    assert r.exit_code == 2 and "'-'" in r.output
    assert not (tmp_path / "-").exists()
    with pytest.raises(InputError, match="standard output"):
        files.atomic_text("-", "x")


# ---------------------------------------------------------------- permissions and leftovers
@pytest.mark.parametrize("mask", [0o022, 0o027, 0o002])
def test_outputs_get_the_umask_permissions(tmp_path, mask):
    old = os.umask(mask)
    try:
        pk = systems.chain(n_balls=3, pressure=1e-4)
        files.write_packing(tmp_path / "p.h5", pk)
        files.atomic_text(tmp_path / "t.json", "{}")
        with files.atomic_file(tmp_path / "f.png", suffix=".png") as tmp:
            tmp.write_bytes(b"png")
    finally:
        os.umask(old)
    for name in ("p.h5", "t.json", "f.png"):
        assert stat.S_IMODE(os.stat(tmp_path / name).st_mode) == 0o666 & ~mask, name


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_stale_temporaries_of_killed_runs_are_removed(tmp_path):
    host = atomic._HOST
    killed = tmp_path / f".out.h5.p{_dead_pid()}h{host}.k1ll3d00.tmp"
    live = tmp_path / f".out.h5.p{os.getppid()}h{host}.l1ve0000.tmp"  # a live writer's file
    old_legacy = tmp_path / ".out.h5.abcd1234.tmp"  # an older granwave's name, hours old
    new_legacy = tmp_path / ".out.h5.efgh5678.tmp"  # maybe a writer on another host: kept
    other = tmp_path / ".other.h5.abcd1234.tmp"  # another output's temporary: not ours
    for p in (killed, live, old_legacy, new_legacy, other):
        p.write_bytes(b"partial")
    hours_ago = time.time() - 3 * atomic.STALE_AGE
    os.utime(old_legacy, (hours_ago, hours_ago))
    os.utime(other, (hours_ago, hours_ago))
    files.write_packing(tmp_path / "out.h5", systems.chain(n_balls=3, pressure=1e-4))
    assert not killed.exists() and not old_legacy.exists()
    assert live.exists() and new_legacy.exists() and other.exists()
    assert files.read_packing(tmp_path / "out.h5").n_grains == 3
    left = sorted(p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp"))
    assert left == sorted([live.name, new_legacy.name, other.name])


# ---------------------------------------------------------------- full disk
def _no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_full_disk_during_an_hdf5_write(tmp_path, monkeypatch):
    pk = systems.chain(n_balls=3, pressure=1e-4)
    monkeypatch.setattr(h5py.Group, "create_dataset", _no_space)
    with pytest.raises(OutputError, match=r"cannot write .*p\.h5: no space left on the device \(.* free\); "
                                          "no output written"):
        files.write_packing(tmp_path / "p.h5", pk)
    assert list(tmp_path.iterdir()) == []


def test_full_disk_during_a_file_write_keeps_the_old_output(tmp_path):
    out = tmp_path / "fig.png"
    out.write_bytes(b"old")
    with pytest.raises(OutputError, match="no space left"):
        with files.atomic_file(out, suffix=".png") as tmp:
            tmp.write_bytes(b"half")
            _no_space()
    assert out.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["fig.png"]


def test_full_disk_on_the_command_line(tmp_path, monkeypatch):
    monkeypatch.setattr(h5py.Group, "create_dataset", _no_space)
    r = invoke("chain", "--balls", 4, "--pressure", 1e-4, "-o", tmp_path / "c.h5")
    assert r.exit_code == 1 and "no space left on the device" in r.output
    assert len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output
    assert list(tmp_path.iterdir()) == []


def test_disk_estimate_refuses_before_writing(tmp_path, monkeypatch):
    monkeypatch.setattr(resources, "available_disk", lambda folder: 1000)
    with pytest.raises(ResourceError, match=r"writing .*p\.h5 needs about .* of disk; 1 kB free"):
        files.write_packing(tmp_path / "p.h5", systems.chain(n_balls=3, pressure=1e-4))
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- size guards
@pytest.mark.parametrize("args", [
    ["prepare-packing", "--grains", "10000000000"],
    ["chain", "--balls", "100000000000", "--pressure", "1e-4"],
    ["lattice", "--rows", "1000000", "--width", "1000000", "--pressure", "1e-4"],
])
def test_requests_that_cannot_fit_are_one_line(tmp_path, args):
    r = invoke(*args, "-o", tmp_path / "x.h5")
    assert r.exit_code == 2, r.output
    line = r.output.strip()
    assert "\n" not in line and "of memory;" in line and "available" in line
    assert not (tmp_path / "x.h5").exists()


def test_cli_chain_of_1e8_balls_against_a_small_machine(tmp_path, monkeypatch):
    monkeypatch.setattr(resources, "available_memory", lambda: 4_000_000_000)
    r = invoke("chain", "--balls", 100_000_000, "--pressure", 1e-4, "-o", tmp_path / "c.h5")
    assert r.exit_code == 2
    assert "a chain of 100000000 balls needs about 20 GB of memory; 4 GB available" in r.output


def test_propagate_samples_and_snapshots_are_guarded(tmp_path):
    pk = systems.chain(n_balls=4, pressure=1e-4)
    system = linearize(pk)
    modes = eigensolve(system, vectors=True)
    files.write_modes(tmp_path / "m.h5", modes)
    r = invoke("propagate", tmp_path / "m.h5", "--t-max", 10, "--samples", 10**13, "-o", tmp_path / "s.h5")
    assert r.exit_code == 2 and "a signal of 10000000000000 samples" in r.output
    with pytest.raises(ResourceError, match="needs about"):
        modal_propagate(modes, ic="A", t_max=1.0, samples=10**13)


def test_library_guards_use_the_available_memory(monkeypatch):
    monkeypatch.setattr(resources, "available_memory", lambda: 10_000_000)  # 10 MB
    with pytest.raises(ResourceError, match="a chain of 100000 balls needs about 20 MB of memory; 10 MB"):
        systems.chain(n_balls=100_000, pressure=1e-4)
    with pytest.raises(ResourceError, match="a lattice of 200 x 200 balls"):
        systems.triangular_lattice(rows=200, width=200, pressure=1e-4)
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    need = resources.format_bytes(resources.prepare_bytes(100_000, 2))
    with pytest.raises(ResourceError, match=f"a packing of 100000 grains needs about {need} of memory; 10 MB"):
        prepare_packing(PrepareParams(grains=100_000))
    with pytest.raises(ResourceError, match="a dense eigensolve of 1000 dofs needs about 32 MB"):
        resources.check_eigensolve(1000)
    resources.check_eigensolve(1000, k=10)  # the lowest modes fit
    with pytest.raises(ResourceError, match="the stiffness matrix of 10000 contacts"):
        resources.check_linearize(5000, 10000, 3, 0.5)
    small = systems.chain(n_balls=50, pressure=1e-4)  # small requests still run
    assert eigensolve(linearize(small)).omega2.shape == (50,)


def test_available_amounts_are_real_numbers(tmp_path):
    assert 0 < resources.available_memory() < 1 << 60
    assert 0 < resources.available_disk(tmp_path) < 1 << 62
    assert resources.format_bytes(20e9) == "20 GB" and resources.format_bytes(999) == "999 B"


def test_memory_error_anywhere_is_one_line():
    @click.command()
    @stage
    def greedy():
        np.empty(10)
        raise MemoryError

    r = CliRunner().invoke(greedy, [])
    assert r.exit_code == 2 and r.output.startswith("Error: out of memory: the request does not fit (")
    assert len(r.output.strip().splitlines()) == 1


def test_a_file_declaring_huge_datasets_is_refused_before_reading(tmp_path):
    """HDF5 stores a never-written dataset in no space: its declared size is checked first."""
    p = tmp_path / "s.h5"
    files.write_signal(p, modal_propagate(eigensolve(linearize(systems.chain(n_balls=3, pressure=1e-4))),
                                          ic="A", t_max=5.0, samples=10))
    with h5py.File(p, "a") as f:
        for name in ("signal/time", "signal/force"):
            del f[name]
            f.create_dataset(name, shape=(10**13,), dtype="f8")  # 80 TB declared, nothing stored
    assert p.stat().st_size < 1_000_000
    with pytest.raises(ResourceError, match=r"reading .*s\.h5 needs about 160 TB of memory"):
        files.read_signal(p)
