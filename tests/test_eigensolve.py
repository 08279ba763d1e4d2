"""eigensolve (docs/method.md §7): exact chain spectrum, M-orthonormality, partial solver, zero/negative modes."""

import math
import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from click.testing import CliRunner

from granwave import theory
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files
from granwave.linear.assemble import linearize
from granwave.linear.check import reference_chain, reference_lattice
from granwave.linear.eigen import NegativeModesWarning, eigensolve
from granwave.linear.propagate import modal_signal
from granwave.model import LinearSystem


def test_chain_spectrum_is_exact():
    n, K = 50, 1.7
    m = math.pi / 6
    modes = eigensolve(linearize(reference_chain(n, stiffness=K)))
    _, omega = theory.chain_modes(n, stiffness=K, mass=m)
    np.testing.assert_allclose(modes.omega2, np.sort(omega**2), rtol=0, atol=1e-13 * (4 * K / m))
    assert modes.attrs["n_zero_modes"] == 0 and not modes.attrs["partial"]


def test_modes_are_m_orthonormal_and_projections_consistent():
    s = linearize(reference_lattice(5, 4, pressure=1e-4, friction=0.5))
    modes = eigensolve(s, vectors=True)
    phi = modes.vectors
    np.testing.assert_allclose(phi.T @ (s.mass[:, None] * phi), np.eye(s.n_dof), atol=1e-12)
    D = s.stiffness.toarray()
    resid = D @ phi - (s.mass[:, None] * phi) * modes.omega2
    assert np.abs(resid).max() < 1e-12 * modes.omega2[-1] * s.mass.max()
    # the modal expansion reproduces the initial conditions: sum a_n omega_n phi_n = v0 (A), sum a_n phi_n = u0 (B)
    omega = np.sqrt(modes.omega2)
    np.testing.assert_allclose(phi @ (modes.amplitude_A * omega), s.source_velocity, atol=1e-12 * s.source_velocity.max())
    np.testing.assert_allclose(phi @ modes.amplitude_B, s.source_displacement, atol=1e-12)
    np.testing.assert_allclose(modes.coupling, s.detector @ phi, rtol=1e-15, atol=1e-15)
    assert np.all(np.diff(modes.omega2) >= 0)


def test_partial_solver_matches_dense_lowest_modes():
    s = linearize(reference_lattice(8, 5, pressure=1e-4, friction=0.5))
    full = eigensolve(s)
    k = 15
    part = eigensolve(s, k=k)
    assert part.attrs["partial"] and len(part.omega2) == k
    np.testing.assert_allclose(part.omega2, full.omega2[:k], rtol=1e-9)
    # a_n b_n does not depend on the sign of phi_n; compare on non-degenerate modes only
    gap = np.diff(full.omega2[:k + 1])
    nondeg = (np.r_[np.inf, gap[:-1]] > 1e-8) & (gap > 1e-8)
    for amp in ("amplitude_A", "amplitude_B"):
        np.testing.assert_allclose((getattr(part, amp) * part.coupling)[nondeg],
                                   (getattr(full, amp) * full.coupling)[:k][nondeg],
                                   atol=1e-8 * np.abs(getattr(full, amp) * full.coupling).max())


def test_zero_modes_clipped_and_counted():
    s = linearize(reference_lattice(6, 5, pressure=1e-5, friction=0.0))
    modes = eigensolve(s)
    assert modes.attrs["n_zero_modes"] == 1 and modes.omega2[0] == 0.0 and modes.omega2[1] > 0
    assert modes.amplitude_A[0] == 0.0
    assert modes.attrs["zero_mode_drift_A"] == pytest.approx(0.0, abs=1e-12)  # sliding mode is horizontal


def test_negative_eigenvalue_is_reported_never_silent():
    n = 4
    D = sp.csr_matrix(np.diag([1.0, 2.0, 3.0, -0.5]))
    s = LinearSystem(stiffness=D, mass=np.ones(n), dof_grain=np.arange(n), dof_axis=np.zeros(n, int),
                     source_velocity=np.ones(n), source_displacement=np.ones(n), detector=np.ones(n),
                     attrs=dict(dim=1, pressure=1.0, friction=0.0, height=1.0, prestress=False))
    with pytest.warns(NegativeModesWarning):
        modes = eigensolve(s)
    assert modes.attrs["n_negative_modes"] == 1 and modes.omega2[0] == pytest.approx(-0.5)
    with pytest.raises(InputError, match="negative"):
        modal_signal(modes, ic="A", times=np.linspace(0, 1, 5))


def test_cli_eigensolve(tmp_path):
    files.write_linear(tmp_path / "l.h5", linearize(reference_lattice(4, 4, pressure=1e-4, friction=0.5)))
    run = CliRunner().invoke
    r = run(main, ["eigensolve", str(tmp_path / "l.h5"), "-o", str(tmp_path / "m.h5")])
    assert r.exit_code == 0, r.output
    m = files.read_modes(tmp_path / "m.h5")
    assert m.vectors is None and m.attrs["n_modes"] == 48 and m.attrs["kind"] == "lattice"
    with pytest.raises(InputError, match="--vectors"):
        files.read_modes(tmp_path / "m.h5", vectors=True)
    r = run(main, ["eigensolve", str(tmp_path / "l.h5"), "-o", str(tmp_path / "mv.h5"), "--vectors",
                   "--lowest", "5"])
    assert r.exit_code == 0, r.output
    mv = files.read_modes(tmp_path / "mv.h5", vectors=True)
    assert mv.vectors.shape == (48, 5)
    np.testing.assert_allclose(mv.omega2, m.omega2[:5], rtol=1e-9)
    # a packing is not a linear file: one-line error, no output
    files.write_packing(tmp_path / "p.h5", reference_lattice(3, 3, pressure=1e-4))
    r = run(main, ["eigensolve", str(tmp_path / "p.h5"), "-o", str(tmp_path / "bad.h5")])
    assert r.exit_code != 0 and "expected a granwave.linear file" in r.output
    assert len(r.output.strip().splitlines()) == 1 and not (tmp_path / "bad.h5").exists()
