"""The check of D above the dense limit (docs/linear.md, "Checks on D"): LOBPCG with an AMG
preconditioner agrees with the dense eigenvalues, finds the negative mode of a broken D, falls
back cleanly, and reports progress. The dense limit is lowered (``dense_max``) instead of
building a large system: a 20 x 20 lattice has 800 (frictionless) or 1200 (frictional) dofs."""

import numpy as np
import pytest
import scipy.sparse as sp

from granwave.linear import assemble, stiffness_check
from granwave.linear.assemble import check_stiffness, linearize
from granwave.linear.check import reference_lattice
from granwave.model import LinearSystem

SMALL = 100  # dense_max below the test systems: the sparse path runs


@pytest.fixture(scope="module", params=[0.0, 0.5], ids=["frictionless", "frictional"])
def lattice_system(request):
    return linearize(reference_lattice(20, 20, pressure=1e-4, friction=request.param), check=False)


def with_stiffness(system: LinearSystem, D) -> LinearSystem:
    return LinearSystem(stiffness=sp.csr_matrix(D), mass=system.mass, dof_grain=system.dof_grain,
                        dof_axis=system.dof_axis, source_velocity=system.source_velocity,
                        source_displacement=system.source_displacement, detector=system.detector,
                        attrs=dict(system.attrs))


_PINV_II: dict = {}


def _pinv_ii(system: LinearSystem, i: int) -> float:
    """(A^+)_ii, A = M^-1/2 D M^-1/2: one dense pseudo-inverse per system (not one per test, it
    is the whole cost of these tests), BLAS on one thread where threadpoolctl is installed (its
    threads only spun on the shared cores)."""
    key = (id(system), i)
    if key not in _PINV_II:
        s = 1.0 / np.sqrt(system.mass)
        A = (sp.diags(s) @ system.stiffness @ sp.diags(s)).toarray()
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:  # pragma: no cover
            _PINV_II[key] = system, float(np.linalg.pinv(A)[i, i])
        else:
            with threadpool_limits(limits=1, user_api="blas"):
                _PINV_II[key] = system, float(np.linalg.pinv(A)[i, i])
    return _PINV_II[key][1]  # (the system is kept with it, so that its id is not reused)


def broken(system: LinearSystem, factor: float) -> LinearSystem:
    """D - c m_i e_i e_i^T on one dof: a rank-one negative update, so at most one negative mode;
    ``factor`` x the smallest c that makes one (c* = 1 / (A^+)_ii, A = M^-1/2 D M^-1/2)."""
    i = system.n_dof // 2 + 1
    c = factor / _pinv_ii(system, i)
    D = system.stiffness.tolil()
    D[i, i] -= c * system.mass[i]
    return with_stiffness(system, D)


def test_sparse_path_agrees_with_dense(lattice_system):
    dense = check_stiffness(lattice_system)
    sparse = check_stiffness(lattice_system, dense_max=SMALL)
    assert dense["psd_check"] == "dense eigvalsh" and sparse["psd_check"].startswith("lobpcg + AMG")
    assert sparse["psd_check_converged"] and sparse["psd_check_residual"] <= 1.01 * stiffness_check.CHECK_RESIDUAL
    assert sparse["n_zero_modes"] == dense["n_zero_modes"] == lattice_system.attrs["expected_zero_modes"]
    assert sparse["n_zero_modes_exact"]
    assert sparse["n_negative_modes"] == dense["n_negative_modes"] == 0
    # the Ritz value converges quadratically: 1e-6 relative is loose (measured ~1e-9)
    assert sparse["lowest_nonzero_omega2"] == pytest.approx(dense["lowest_nonzero_omega2"], rel=1e-6)
    # omega^2_max only sets the threshold's scale: a Ritz value, within a few per cent
    assert sparse["omega2_max"] == pytest.approx(dense["omega2_max"], rel=0.03)
    assert sparse["asymmetry"] == dense["asymmetry"] < 1e-12


@pytest.mark.parametrize("factor", [1.05, 50.0], ids=["barely-negative", "strongly-negative"])
def test_negative_mode_of_a_broken_stiffness_is_found(lattice_system, factor):
    bad = broken(lattice_system, factor)
    dense = check_stiffness(bad)
    assert dense["n_negative_modes"] == 1  # exactly one, by construction
    sparse = check_stiffness(bad, dense_max=SMALL)
    assert sparse["n_negative_modes"] == 1
    assert sparse["min_omega2"] == pytest.approx(dense["min_omega2"], rel=1e-2)


def test_symmetry_check_unchanged_above_the_dense_limit(lattice_system):
    D = lattice_system.stiffness.tolil()
    e = 1e-3 * abs(D[0, 0])
    D[0, 1] += e  # an antisymmetric change: reported as asymmetry, (D + D^T)/2 and its modes unchanged
    D[1, 0] -= e
    bad = with_stiffness(lattice_system, D)
    dense, sparse = check_stiffness(bad), check_stiffness(bad, dense_max=SMALL)
    assert dense["asymmetry"] == sparse["asymmetry"] == assemble.asymmetry(bad.stiffness) > 1e-5
    ref = check_stiffness(lattice_system, dense_max=SMALL)
    assert sparse["n_negative_modes"] == dense["n_negative_modes"] == 0
    assert sparse["n_zero_modes"] == dense["n_zero_modes"] == ref["n_zero_modes"]
    assert sparse["lowest_nonzero_omega2"] == pytest.approx(ref["lowest_nonzero_omega2"], rel=1e-6)


def test_unconverged_lobpcg_falls_back_to_shift_invert(lattice_system, monkeypatch):
    monkeypatch.setattr(stiffness_check, "CHECK_MAXITER", 1)
    lines = []
    res = check_stiffness(lattice_system, dense_max=SMALL, progress=lines.append)
    assert res["psd_check"].startswith("eigsh shift-invert") and "lobpcg did not converge" in res["psd_check"]
    assert res["n_zero_modes"] == lattice_system.attrs["expected_zero_modes"]
    assert any("falling back" in line for line in lines)
    # too large for a sparse LU: the unconverged Ritz values are reported, flagged
    monkeypatch.setattr(stiffness_check, "SHIFT_INVERT_MAX_DOF", 10)
    res = check_stiffness(lattice_system, dense_max=SMALL)
    assert not res["psd_check_converged"] and res["psd_check"].endswith("not converged")
    assert not res["n_zero_modes_exact"]


def test_linearize_reports_progress_above_the_dense_limit(monkeypatch):
    monkeypatch.setattr(stiffness_check, "DENSE_CHECK_MAX_DOF", SMALL)
    lines = []
    s = linearize(reference_lattice(10, 10, pressure=1e-4, friction=0.5), progress=lines.append)
    assert s.attrs["psd_check"].startswith("lobpcg + AMG") and s.attrs["psd_check_converged"]
    assert lines[0].startswith("assembled D: 300 dofs")
    assert "LOBPCG" in lines[1] and lines[-1].startswith("check D done in")
    quiet = []
    linearize(reference_lattice(3, 4, pressure=1e-4), progress=quiet.append)  # dense: no lines
    assert quiet == []


def test_cli_linearize_prints_the_check_above_the_dense_limit(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from granwave.cli import main
    from granwave.io import files

    monkeypatch.setattr(stiffness_check, "DENSE_CHECK_MAX_DOF", SMALL)
    files.write_packing(tmp_path / "p.h5", reference_lattice(10, 10, pressure=1e-4, friction=0.5))
    args = ["linearize", str(tmp_path / "p.h5"), "-o", str(tmp_path / "l.h5")]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    assert "LOBPCG" in r.output and "check D done in" in r.output
    attrs = files.read_linear(tmp_path / "l.h5").attrs
    assert attrs["psd_check"].startswith("lobpcg + AMG") and bool(attrs["psd_check_converged"])
    r = CliRunner().invoke(main, args[:-1] + [str(tmp_path / "quiet.h5"), "--quiet"])
    assert r.exit_code == 0, r.output
    assert "check D done" not in r.output
