"""propagate (docs/method.md §8): modal vs time domain (dt^2 convergence), energy, snapshots, CLI errors."""

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.cli import main
from granwave.io import files
from granwave.linear.assemble import linearize
from granwave.linear.check import reference_lattice
from granwave.linear.eigen import eigensolve
from granwave.linear.propagate import modal_propagate, modal_signal, time_domain_signal


@pytest.fixture(scope="module")
def lattice_system():
    return linearize(reference_lattice(8, 5, pressure=1e-4, friction=0.5))


@pytest.fixture(scope="module")
def lattice_modes(lattice_system):
    return eigensolve(lattice_system, vectors=True)


@pytest.mark.parametrize("ic", ["A", "B"])
def test_time_domain_converges_to_modal_as_dt_squared(lattice_system, lattice_modes, ic):
    t_max, samples = 60.0, 121
    ref = modal_propagate(lattice_modes, ic=ic, t_max=t_max, samples=samples).force
    errors = []
    for dt in (0.1, 0.05, 0.025):
        sig = time_domain_signal(lattice_system, ic=ic, t_max=t_max, samples=samples, dt=dt)
        assert sig.attrs["dt"] == dt  # dt divides the sample interval 0.5
        errors.append(np.abs(sig.force - ref).max() / np.abs(ref).max())
    ratios = errors[0] / errors[1], errors[1] / errors[2]
    assert all(3.8 < r < 4.2 for r in ratios), (errors, ratios)
    # and the error itself is second order: below (omega_max dt)^2 at the finest step
    assert errors[-1] < (sig.attrs["omega_max"] * 0.025) ** 2


def test_energy_conserved(lattice_system):
    sig = time_domain_signal(lattice_system, ic="A", t_max=400.0, samples=801)
    w_dt = sig.attrs["omega_max_dt"]
    assert w_dt <= 0.2 + 1e-12  # default safety 0.1 of the stability limit 2
    # velocity Verlet conserves the modified energy exactly (roundoff only) ...
    assert sig.attrs["modified_energy_max_rel_deviation"] < 1e-11
    # ... and the plain energy only oscillates by O((omega dt)^2), without drift
    assert sig.attrs["energy_max_rel_deviation"] < w_dt**2 / 4


def test_snapshots_modal_and_time_agree(lattice_system, lattice_modes):
    st = [5.0, 20.0]
    m = modal_propagate(lattice_modes, ic="A", t_max=20.0, samples=41, snapshots=st,
                        dof_grain=lattice_system.dof_grain, dof_axis=lattice_system.dof_axis)
    t = time_domain_signal(lattice_system, ic="A", t_max=20.0, samples=41, dt=0.005, snapshots=st)
    np.testing.assert_allclose(t.snapshot_time, st, rtol=1e-12)
    scale = np.abs(m.snapshot_displacement).max()
    assert np.abs(t.snapshot_displacement - m.snapshot_displacement).max() < 1e-4 * scale
    np.testing.assert_array_equal(t.dof_grain, lattice_system.dof_grain)


def test_modal_signal_independent_of_chunking(lattice_modes):
    times = np.linspace(0, 50, 333)
    a = modal_signal(lattice_modes, ic="B", times=times)
    b = modal_signal(lattice_modes, ic="B", times=times, chunk_elements=7)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-14 * np.abs(a).max())
    assert a[0] == pytest.approx(lattice_modes.amplitude_B @ lattice_modes.coupling)


def test_time_domain_bits_do_not_depend_on_the_kernel_calls(lattice_system, monkeypatch):
    """The run is cut into kernel calls of about CHUNK_WORK entries of D (so that signals and
    progress are not held up); a cut after every step gives the same bytes."""
    from granwave.linear import propagate as P

    whole = time_domain_signal(lattice_system, ic="A", t_max=40.0, samples=21, dt=0.05)
    monkeypatch.setattr(P, "CHUNK_WORK", 1)
    lines = []
    cut = time_domain_signal(lattice_system, ic="A", t_max=40.0, samples=21, dt=0.05,
                             progress=lines.append, progress_interval=0.0)
    assert whole.force.tobytes() == cut.force.tobytes()
    assert lines and lines[-1].startswith("propagate: t = 40 / 40, step 800/800")


@pytest.mark.slow
def test_sigterm_stops_a_long_time_domain_run_promptly(tmp_path, lattice_system):
    """A run of 4e7 steps in one sample interval (--dt far below the default) is stopped by SIGTERM within a few
    seconds once it is stepping (its first progress line), with no output file left."""
    import signal
    import subprocess
    import sys
    import time

    lin, out = tmp_path / "lin.h5", tmp_path / "sig.h5"
    files.write_linear(lin, lattice_system)
    proc = subprocess.Popen([sys.executable, "-m", "granwave", "propagate", str(lin), "--method", "time",
                             "--dt", "1e-5", "--t-max", "400", "--samples", "2", "-o", str(out)],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        for line in proc.stderr:  # progress lines come every 10 s
            if line.startswith("propagate: t ="):
                break
        else:
            pytest.fail(f"no progress line (exit {proc.wait()})")
        t0 = time.perf_counter()
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=30)
        waited = time.perf_counter() - t0
    finally:
        proc.kill()
    assert code != 0
    assert waited < 3.0, f"took {waited:.1f} s to stop"
    assert list(tmp_path.iterdir()) == [lin]


def test_cli_propagate_methods_and_errors(tmp_path, lattice_system, lattice_modes):
    files.write_linear(tmp_path / "l.h5", lattice_system)
    files.write_modes(tmp_path / "m.h5", eigensolve(lattice_system))
    run = CliRunner().invoke
    common = ["--t-max", "30", "--samples", "61"]
    r = run(main, ["propagate", str(tmp_path / "m.h5"), "-o", str(tmp_path / "sm.h5"), "--ic", "B", *common])
    assert r.exit_code == 0, r.output
    r = run(main, ["propagate", str(tmp_path / "l.h5"), "-o", str(tmp_path / "st.h5"), "--ic", "B",
                   "--dt", "0.01", "--snapshots", "10,30", *common])
    assert r.exit_code == 0, r.output
    sm, st = files.read_signal(tmp_path / "sm.h5"), files.read_signal(tmp_path / "st.h5")
    assert sm.attrs["method"] == "modal" and st.attrs["method"] == "time"
    for s in (sm, st):
        assert s.attrs["ic"] == "B" and s.attrs["height"] == lattice_system.height
        assert s.attrs["pressure"] == 1e-4 and s.attrs["kind"] == "lattice" and s.attrs["friction"] == 0.5
    assert np.abs(sm.force - st.force).max() < 1e-3 * np.abs(sm.force).max()
    assert st.snapshot_displacement.shape == (2, lattice_system.n_dof)
    bad = [
        # modes without vectors cannot give snapshots
        (["propagate", str(tmp_path / "m.h5"), "--snapshots", "5", *common], "--vectors"),
        # the time domain needs the linear file
        (["propagate", str(tmp_path / "m.h5"), "--method", "time", *common], "linear file"),
        # a snapshot outside the run
        (["propagate", str(tmp_path / "l.h5"), "--snapshots", "31", *common], "snapshot"),
        # a step beyond the stability limit
        (["propagate", str(tmp_path / "l.h5"), "--dt", "3", "--t-max", "30", "--samples", "3"], "unstable"),
        (["propagate", str(tmp_path / "l.h5"), "--t-max", "nan"], "finite"),
    ]
    for args, msg in bad:
        out = tmp_path / "bad.h5"
        r = run(main, [*args, "-o", str(out)])
        assert r.exit_code != 0 and msg in r.output, (args, r.output)
        assert not out.exists()
        # one error line (click adds its usage lines for a bad option value), no traceback
        errors = [line for line in r.output.splitlines() if line.startswith("Error")]
        assert len(errors) == 1 and "Traceback" not in r.output, r.output
