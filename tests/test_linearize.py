"""linearize (docs/method.md §5): matrix entries, prestress = FD of frozen-history forces, zero modes, errors."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files
from granwave.linear import assemble, stiffness_check
from granwave.linear.assemble import expected_zero_modes, linearize
from granwave.linear.check import (finite_difference_stiffness, reference_chain,
                                   reference_frozen_forces, reference_lattice)


@pytest.fixture(scope="module")
def dem_packing_2d():
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    return prepare_packing(PrepareParams(dim=2, grains=40, pressure=1e-4, friction=0.5, seed=1))


@pytest.fixture(scope="module")
def dem_packing_3d():
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    return prepare_packing(PrepareParams(dim=3, grains=40, pressure=1e-4, friction=0.5, seed=2,
                                         aspect=0.8))


def test_chain_matrix_is_the_spring_chain():
    K, n = 2.5, 7
    s = linearize(reference_chain(n, stiffness=K, pressure=1e-3))
    expected = K * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    np.testing.assert_allclose(s.stiffness.toarray(), expected, rtol=0, atol=1e-14 * K)
    m = math.pi / 6
    np.testing.assert_allclose(s.mass, m, rtol=1e-15)
    # conventions: IC A velocity k_wall/m on the first ball; IC B displacement 1; detector K on the last
    np.testing.assert_allclose(s.source_velocity, np.eye(n)[0] * K / m, rtol=1e-15)
    np.testing.assert_allclose(s.source_displacement, np.eye(n)[0], rtol=1e-15)
    np.testing.assert_allclose(s.detector, np.eye(n)[-1] * K, rtol=1e-15)
    assert s.attrs["n_zero_modes"] == 0 and s.attrs["n_negative_modes"] == 0
    assert s.attrs["kind"] == "chain" and s.attrs["dim"] == 1 and s.attrs["prestress"] is False


def _relative_max(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.mark.parametrize("which", ["2d", "3d"])
def test_prestress_is_finite_difference_of_frozen_history_forces(which, request):
    """D(prestress) = -Jacobian of granwave.dem.forces.frozen_history_forces, to 1e-6 relative.

    Central differences with eps = 1e-7 d have a truncation error ~(eps/delta)^2 ~ 1e-8 here.
    The packings are DEM-prepared with friction, so F_t != 0 on grain and wall contacts.
    """
    from granwave.dem.forces import frozen_history_forces

    p = request.getfixturevalue(f"dem_packing_{which}")
    assert np.abs(p.contacts.force_tangential).max() > 0.05 * p.contacts.force_normal.mean()
    fd = None
    for prestress in (True, False):
        s = linearize(p, prestress=prestress)
        if fd is None:
            fd = finite_difference_stiffness(s, lambda u, t: frozen_history_forces(p, u, t),
                                             p.n_grains, eps=1e-7)
        err = _relative_max(s.stiffness.toarray(), fd)
        if prestress:
            assert err < 1e-6
            assert s.attrs["asymmetry"] > 1e-6  # F_t != 0: the frozen-history Jacobian is not symmetric
        else:
            assert err > 1e-4  # the prestress terms are not negligible: material-only D differs
            assert s.attrs["asymmetry"] < 1e-14


def test_prestress_matches_independent_reference_forces_on_lattice_with_tangential_forces():
    """Same check against the plain-numpy reference of docs/conventions.md (lattice, random F_t)."""
    lat = reference_lattice(3, 4, pressure=1e-4, friction=0.5)
    c = lat.contacts
    t = np.random.default_rng(1).standard_normal((len(c), 2))
    t -= (t * c.normal).sum(1)[:, None] * c.normal
    c.force_tangential[:] = 0.3 * c.force_normal[:, None] * t
    s = linearize(lat, prestress=True)
    fd = finite_difference_stiffness(s, lambda u, r: reference_frozen_forces(lat, u, r),
                                     lat.n_grains, eps=1e-7)
    assert _relative_max(s.stiffness.toarray(), fd) < 1e-6


def test_rattlers_are_removed(dem_packing_2d):
    p = dem_packing_2d
    s = linearize(p)
    c = p.contacts
    touched = np.unique(np.concatenate([c.i[c.force_normal > 0], c.j[(c.force_normal > 0) & (c.j >= 0)]]))
    assert s.attrs["n_rattlers"] == p.n_grains - len(touched)
    assert set(np.unique(s.dof_grain)) == set(touched)
    assert s.n_dof == 3 * len(touched)  # x, y, theta per grain with friction
    assert s.attrs["seed"] == 1 and s.attrs["friction"] == 0.5 and s.attrs["height"] == p.box[-1]


@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_zero_modes_of_lattices(friction):
    """Frictionless: one zero mode (rigid sliding along the frictionless walls, x periodic);
    frictional: none (tangential wall springs pin it). Rotations only with friction."""
    s = linearize(reference_lattice(6, 5, pressure=1e-5, friction=friction))
    assert s.attrs["n_rotations"] == (1 if friction else 0)
    assert s.attrs["n_zero_modes"] == expected_zero_modes(2, friction) == (0 if friction else 1)
    assert s.attrs["n_negative_modes"] == 0
    assert s.attrs["lowest_nonzero_omega2"] > 1e3 * s.attrs["zero_mode_threshold"] * s.attrs["omega2_max"]


def test_sparse_check_agrees_with_dense(monkeypatch):
    lat = reference_lattice(6, 5, pressure=1e-5, friction=0.0)
    dense = linearize(lat).attrs
    monkeypatch.setattr(stiffness_check, "DENSE_CHECK_MAX_DOF", 10)
    sparse = linearize(lat).attrs
    assert sparse["psd_check"].startswith("lobpcg") and sparse["psd_check_converged"]
    assert sparse["n_zero_modes"] == dense["n_zero_modes"] == 1
    assert sparse["n_zero_modes_exact"]
    # LOBPCG stops at residual 1e-6 omega^2_max; the Ritz value is far closer (tests/test_stiffness_check.py)
    assert sparse["lowest_nonzero_omega2"] == pytest.approx(dense["lowest_nonzero_omega2"], rel=1e-6)


def test_frictionless_dem_packing_zero_modes_at_least_expected():
    from granwave.dem.params import PrepareParams
    from granwave.dem.protocol import prepare_packing

    p = prepare_packing(PrepareParams(dim=2, grains=40, pressure=1e-4, friction=0.0, seed=3))
    s = linearize(p)
    assert s.attrs["n_rotations"] == 0 and s.n_dof == 2 * (p.n_grains - s.attrs["n_rattlers"])
    assert s.attrs["n_zero_modes"] >= 1 and s.attrs["n_negative_modes"] == 0


def test_unconverged_and_nan_packings_are_refused():
    lat = reference_lattice(3, 4, pressure=1e-4)
    lat.attrs["converged"] = False
    with pytest.raises(InputError, match="not converged"):
        linearize(lat)
    assert linearize(lat, force=True).attrs["forced_unconverged"] is True
    lat.attrs["converged"] = True
    lat.contacts.stiffness_normal[2] = np.nan
    with pytest.raises(InputError, match="NaN"):
        linearize(lat)


def test_cli_linearize(tmp_path):
    files.write_packing(tmp_path / "p.h5", reference_lattice(4, 4, pressure=1e-4, friction=0.5))
    r = CliRunner().invoke(main, ["linearize", str(tmp_path / "p.h5"), "-o", str(tmp_path / "l.h5"),
                                 "--prestress", "--json"])
    assert r.exit_code == 0, r.output
    s = files.read_linear(tmp_path / "l.h5")
    assert s.attrs["prestress"] and s.attrs["kind"] == "lattice" and s.attrs["pressure"] == 1e-4
    assert s.attrs["packing_source"] == str(tmp_path / "p.h5")
    np.testing.assert_array_equal(
        s.stiffness.toarray(), linearize(files.read_packing(tmp_path / "p.h5"), prestress=True).stiffness.toarray())


def _contact_points(p, g):
    """Force-carrying contact points of grain g seen from its centre (arm along the
    outward normal: R - delta/2 to a grain, R - delta to a wall), written out here."""
    c = p.contacts
    pts = []
    for k in np.flatnonzero(c.force_normal > 0):
        wall = c.j[k] < 0
        if c.i[k] == g:
            pts.append((p.radius[g] - (c.overlap[k] if wall else 0.5 * c.overlap[k])) * c.normal[k])
        elif c.j[k] == g:
            pts.append(-(p.radius[g] - 0.5 * c.overlap[k]) * c.normal[k])
    return pts


def test_free_spins_of_two_contact_grains(dem_packing_3d, tmp_path):
    """3D, friction: a grain with two contacts turns at no cost about the line through its
    contact points (theta = e, u = -e x r1). That motion is a null vector of the full D.
    linearize keeps it by default (the DEM's dofs): one expected zero mode per spin, none
    negative, none seen by either wall; with prestress they turn zero or slightly negative.
    remove_spins=True removes it (two rotations kept): no zero mode, and with prestress no
    negative mode."""
    p = dem_packing_3d
    spins, axes = assemble.free_spins(p, 3)
    assert len(spins) >= 2
    # the full layout (spins kept): each spin is a null vector of D
    full = assemble.dof_layout(p, 3, remove_spins=False)
    keep, blocks = assemble.contact_blocks(p, n_rot=3)
    D = assemble.scatter_blocks(blocks, assemble.contact_dofs(full.full_first, p.contacts.i[keep],
                                                              p.contacts.j[keep], 6), full.n_full)
    nulls = []
    for g, e in zip(spins, axes):
        pts = _contact_points(p, g)
        assert len(pts) == 2
        d = pts[1] - pts[0]
        assert abs(abs(e @ d) - np.linalg.norm(d)) < 1e-12  # axis along the line
        z = np.zeros(full.n_full)
        z[full.full_first[g]:full.full_first[g] + 3] = -np.cross(e, pts[0])
        z[full.full_first[g] + 3:full.full_first[g] + 6] = e
        assert np.linalg.norm(D @ z) < 1e-12 * abs(D).max()
        nulls.append(z)
    n_active = len(np.unique(full.dof_grain))
    # the default keeps them: expected zero modes, invisible to both walls (source and detector)
    kept = linearize(p)
    assert kept.n_dof == 6 * n_active and kept.attrs["n_spins_removed"] == 0
    assert kept.attrs["n_free_spins"] == len(spins)
    assert kept.attrs["n_zero_modes"] == kept.attrs["expected_zero_modes"] == len(spins)
    assert kept.attrs["n_negative_modes"] == 0
    for vec in (kept.source_velocity * kept.mass, kept.detector, kept.shear_source_velocity * kept.mass,
                kept.shear_detector):
        assert np.abs(np.array(nulls) @ vec).max() < 1e-12 * np.abs(vec).max()
    with_prestress = linearize(p, prestress=True).attrs
    assert with_prestress["n_negative_modes"] + with_prestress["n_zero_modes"] == len(spins)
    assert with_prestress["n_negative_modes"] > 0
    # slightly: far below the lowest positive mode
    assert -with_prestress["min_omega2"] < 1e-2 * with_prestress["lowest_nonzero_omega2"]
    for prestress in (False, True):
        s = linearize(p, prestress=prestress, remove_spins=True)
        assert s.n_dof == 6 * n_active - len(spins)
        assert s.attrs["n_spins_removed"] == s.attrs["n_free_spins"] == len(spins)
        assert s.attrs["n_zero_modes"] == 0 and s.attrs["n_negative_modes"] == 0
        assert s.attrs["expected_zero_modes"] == 0
        red = np.isin(s.dof_axis, assemble.SPIN_REDUCED_AXES)
        assert red.sum() == 2 * len(spins)
        np.testing.assert_allclose(s.mass[red], p.inertia[s.dof_grain[red]], rtol=1e-15)
        ax = assemble.rotation_axes(s)[red].reshape(-1, 2, 3)  # orthonormal, normal to e
        gram = np.einsum("kad,kbd->kab", ax, ax)
        np.testing.assert_allclose(gram, np.broadcast_to(np.eye(2), gram.shape), atol=1e-14)
        assert np.abs(np.einsum("kad,kd->ka", ax, axes)).max() < 1e-14
    path = tmp_path / "linear.h5"
    files.write_linear(path, s)
    back = files.read_linear(path)
    np.testing.assert_array_equal(back.attrs["spin_removed_grains"], spins)
    np.testing.assert_allclose(assemble.rotation_axes(back), assemble.rotation_axes(s), rtol=0, atol=0)


def test_kept_spins_through_eigensolve_propagate_and_moduli(dem_packing_3d):
    """The kept free spins downstream: eigensolve finds them as zero modes (omega = 0, no
    amplitude, no drift: the walls do not see them) and the modal signal equals the time
    domain's; with prestress they are negative modes: eigensolve warns, the modal sum refuses
    them naming the way out, the time domain runs. The moduli are those of the constrained
    system (a spin costs no energy), with or without the kept-spin linear file."""
    import warnings

    from granwave import api
    from granwave.linear.eigen import NegativeModesWarning, eigensolve
    from granwave.linear.propagate import modal_signal, time_domain_signal

    p = dem_packing_3d
    kept = linearize(p)
    spins = kept.attrs["n_free_spins"]
    modes = eigensolve(kept)
    assert modes.attrs["n_zero_modes"] == spins and modes.attrs["n_negative_modes"] == 0
    zero = modes.omega2 == 0
    assert zero.sum() == spins and not np.any(modes.amplitude_A[zero])
    assert abs(modes.attrs["zero_mode_drift_A"]) < 1e-12 and abs(modes.attrs["shear_zero_mode_drift_A"]) < 1e-12
    for kind in ("normal", "shear"):
        td = time_domain_signal(kept.for_source(kind), ic="A", t_max=60.0, samples=121, safety=0.02)
        modal = modal_signal(modes.for_source(kind), ic="A", times=td.time)
        assert np.abs(modal - td.force).max() < 5e-3 * np.abs(modal).max()  # the step: measured 1.4e-3
    pre = linearize(p, prestress=True)
    with pytest.warns(NegativeModesWarning):
        pre_modes = eigensolve(pre)
    with pytest.raises(InputError, match="remove-spins"):
        modal_signal(pre_modes, ic="A", times=td.time)
    assert np.all(np.isfinite(time_domain_signal(pre, ic="A", t_max=60.0, samples=121).force))
    ref = api.moduli(p)
    for system in (kept, linearize(p, remove_spins=True)):
        got = api.moduli(p, system=system)
        for key in ("C33", "C44", "C55", "c_t", "c_l"):
            assert got[key] == pytest.approx(ref[key], rel=1e-12)
    foreign = linearize(p)
    foreign.stiffness = foreign.stiffness * 1.01
    with pytest.raises(InputError, match="does not match"):
        api.moduli(p, system=foreign)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning without prestress
        eigensolve(kept)


def test_sparse_check_counts_every_kept_spin(dem_packing_3d, monkeypatch):
    """Above the dense limit, when LOBPCG does not converge, the shift-invert fallback computes
    past every expected zero mode (a 3D column keeps tens of free spins), so the count is exact
    and the lowest positive mode found: here forced with one LOBPCG step and a fallback of one
    mode, which without that rule would report a single zero mode."""
    dense = linearize(dem_packing_3d).attrs
    monkeypatch.setattr(stiffness_check, "DENSE_CHECK_MAX_DOF", 10)
    monkeypatch.setattr(stiffness_check, "SPARSE_CHECK_MODES", 1)
    monkeypatch.setattr(stiffness_check, "CHECK_MAXITER", 1)
    sparse = linearize(dem_packing_3d).attrs
    assert sparse["psd_check"].startswith("eigsh shift-invert")
    assert sparse["n_zero_modes"] == dense["n_zero_modes"] == sparse["expected_zero_modes"] > 1
    assert sparse["n_zero_modes_exact"]
    assert sparse["lowest_nonzero_omega2"] == pytest.approx(dense["lowest_nonzero_omega2"], rel=1e-6)


def test_no_spins_removed_in_2d(dem_packing_2d, tmp_path):
    s = linearize(dem_packing_2d)
    assert s.attrs["n_spins_removed"] == 0 and len(s.attrs["spin_removed_grains"]) == 0
    path = tmp_path / "linear.h5"
    files.write_linear(path, s)
    assert files.read_linear(path).attrs["n_spins_removed"] == 0
