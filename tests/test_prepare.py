"""Prepared packings: equilibrium from the file alone, reproducibility, frozen-history forces, CLI."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.cli import main
from granwave.dem.forces import frozen_history_forces, static_residual
from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.errors import InputError
from granwave.geometry import wall_area
from granwave.io import files

TOL = 1e-10


@pytest.fixture(scope="module")
def packing2d():
    return prepare_packing(PrepareParams(grains=60, seed=3, tol=TOL))


@pytest.fixture(scope="module")
def packing3d():
    return prepare_packing(PrepareParams(dim=3, grains=120, friction=0.0, polydispersity=0.0, seed=1, tol=TOL))


def balance_from_contacts(packing):
    """Force and torque on every grain summed directly from the stored contact table
    (f_i = -F_n n + F_t, torque (a_i n) x F_t; docs/conventions.md), independently of the engine."""
    c = packing.contacts
    d = packing.dim
    f_on_i = -c.force_normal[:, None] * c.normal + c.force_tangential
    force = np.zeros((packing.n_grains, d))
    np.add.at(force, c.i, f_on_i)
    pair = c.j >= 0
    np.add.at(force, c.j[pair], -f_on_i[pair])
    ai = packing.radius[c.i] - np.where(pair, 0.5, 1.0) * c.overlap
    torque = np.zeros((packing.n_grains, 3))
    n3 = np.zeros((len(c), 3))
    f3 = np.zeros((len(c), 3))
    n3[:, :d], f3[:, :d] = c.normal, c.force_tangential
    np.add.at(torque, c.i, ai[:, None] * np.cross(n3, f3))
    aj = packing.radius[c.j[pair]] - 0.5 * c.overlap[pair]
    np.add.at(torque, c.j[pair], aj[:, None] * np.cross(n3[pair], f3[pair]))
    return force, torque


@pytest.mark.parametrize("which", ["packing2d", "packing3d"])
def test_prepared_packing_is_in_equilibrium(which, request):
    """Every grain: |F|/m and |tau|/I below tol (1e-10), i.e. |F| < 1e-6 p d^2 at p = 1e-4; the
    piston: contact force equals p A within 1e-6 relative; all from the stored contacts."""
    packing = request.getfixturevalue(which)
    a = packing.attrs
    assert a["converged"] and a["max_acceleration"] < TOL
    force, torque = balance_from_contacts(packing)
    assert np.max(np.linalg.norm(force, axis=1) / packing.mass) < TOL
    assert np.max(np.linalg.norm(force, axis=1)) < 1e-6 * packing.pressure
    assert np.max(np.linalg.norm(torque, axis=1) / packing.inertia) < TOL
    c = packing.contacts
    f_top = c.force_normal[c.is_top].sum()
    assert f_top == pytest.approx(packing.pressure * wall_area(packing.box[:-1]), rel=1e-6)
    # contacts are force-carrying, normals unit, stiffnesses consistent with overlaps
    assert np.all(c.overlap > 0) and np.all(c.force_normal > 0)
    np.testing.assert_allclose(np.linalg.norm(c.normal, axis=1), 1.0, rtol=1e-12)
    assert c.is_bottom.any() and c.is_top.any()
    # the box is about square (aspect 1) and lateral coordinates are wrapped
    assert 0.6 < packing.height / packing.box[0] < 1.6
    assert np.all(packing.position[:, :-1] >= 0) and np.all(packing.position[:, :-1] < packing.box[:-1])


def test_friction_is_used_and_frictionless_has_no_tangential(packing2d, packing3d):
    c = packing2d.contacts
    assert np.abs(c.force_tangential).max() > 1e-3 * c.force_normal.max()
    assert np.all(np.linalg.norm(c.force_tangential, axis=1) <= 0.5 * c.force_normal * (1 + 1e-9))
    assert np.all(packing3d.contacts.force_tangential == 0)
    assert np.all(packing3d.contacts.stiffness_tangential == 0)


def test_frozen_history_forces_at_zero_displacement_is_the_stored_balance(packing2d):
    force, torque = frozen_history_forces(packing2d)
    ref_f, ref_t = balance_from_contacts(packing2d)
    scale = packing2d.pressure
    np.testing.assert_allclose(force, ref_f, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(torque[:, 0], ref_t[:, 2], rtol=0, atol=1e-12 * scale)
    assert max(static_residual(packing2d)[:2]) < TOL


def test_frozen_history_forces_newton_third_law(packing2d):
    """Random small displacements and rotations: pair forces cancel (total force equals the sum
    of the wall-contact forces to 1e-12 of the total magnitude)."""
    rng = np.random.default_rng(0)
    n = packing2d.n_grains
    disp = rng.normal(0, 1e-4, size=(n, 2))
    rot = rng.normal(0, 1e-3, size=(n, 1))
    force, _ = frozen_history_forces(packing2d, disp, rot)
    c = packing2d.contacts
    only_walls = type(packing2d)(packing2d.position, packing2d.radius, packing2d.mass, packing2d.inertia,
                                 packing2d.box, type(c)(*(getattr(c, f)[c.j < 0] for f in (
                                     "i", "j", "normal", "overlap", "force_normal", "force_tangential",
                                     "stiffness_normal", "stiffness_tangential"))), packing2d.attrs)
    wall_force, _ = frozen_history_forces(only_walls, disp, rot)
    assert np.abs(force - 0).max() > 1e-3 * packing2d.pressure  # the displacement did something
    np.testing.assert_allclose(force.sum(axis=0), wall_force.sum(axis=0), rtol=0,
                               atol=1e-12 * np.abs(force).sum())


def test_same_seed_same_packing_bit_for_bit(packing2d):
    again = prepare_packing(PrepareParams(grains=60, seed=3, tol=TOL))
    for name in ("position", "radius", "box"):
        np.testing.assert_array_equal(getattr(again, name), getattr(packing2d, name))
    np.testing.assert_array_equal(again.contacts.force_tangential, packing2d.contacts.force_tangential)
    other = prepare_packing(PrepareParams(grains=60, seed=4, tol=1e-6))
    assert not np.array_equal(other.radius, packing2d.radius)


@pytest.mark.parametrize("kwargs", [
    dict(pressure=0.0), dict(pressure=-1e-4), dict(poisson=0.5), dict(poisson=-0.1), dict(friction=-0.1),
    dict(grains=0), dict(polydispersity=1.0), dict(pressure=math.nan), dict(tol=0.0), dict(dim=4),
    dict(damping=1.5), dict(aspect=0.0),
])
def test_params_refuse_bad_input(kwargs):
    with pytest.raises(InputError):
        PrepareParams(**kwargs)


def test_cli_writes_a_packing(tmp_path):
    out = tmp_path / "p.h5"
    result = CliRunner().invoke(main, ["prepare-packing", "--grains", "40", "--pressure", "1e-5", "--seed", "2",
                                       "-o", str(out)])
    assert result.exit_code == 0, result.output
    p = files.read_packing(out)
    assert p.n_grains == 40 and p.attrs["kind"] == "disordered" and p.attrs["converged"]
    for key in ("damping", "piston_mass", "gas_density", "background_damping", "dt_safety", "tol",
                "convergence_test", "steps", "seed", "pressure"):
        assert key in p.attrs
    assert "step" in result.output  # progress lines (stderr is mixed into output by CliRunner)


@pytest.mark.parametrize("args", [
    ["--pressure", "0"], ["--pressure", "-1e-4"], ["--poisson", "0.5"], ["--poisson", "-0.2"],
    ["--friction", "-0.1"], ["--grains", "0"], ["--friction", "nan"], ["--pressure", "nan"],
    ["-o", "/nonexistent-folder/p.h5"], ["--max-steps", "50"],
])
def test_cli_bad_input_one_line_error_no_file(tmp_path, args):
    out = tmp_path / "p.h5"
    full = ["prepare-packing", "--grains", "30", "-q"]
    if "-o" not in args:
        full += ["-o", str(out)]
    result = CliRunner().invoke(main, full + args)
    assert result.exit_code != 0
    assert "Traceback" not in result.output
    error_lines = [line for line in result.output.splitlines() if line.startswith("Error")]
    assert len(error_lines) == 1, result.output
    assert not out.exists() and not list(tmp_path.iterdir())


def _gas(grains, aspect, seed, dim=2, polydispersity=0.2, gas_density=None):
    """The granular gas exactly as prepare_packing builds it (same generator draws)."""
    from granwave.dem.protocol import granular_gas
    from granwave.geometry import lateral_size

    rng = np.random.default_rng(seed)
    w = polydispersity
    diameter = rng.uniform(1.0 - w, 1.0 + w, size=grains) if w > 0 else np.ones(grains)
    radius = 0.5 * diameter
    lateral = np.full(dim - 1, lateral_size(radius, dim, aspect))
    density = gas_density if gas_density is not None else (0.5 if dim == 2 else 0.3)
    pos, height = granular_gas(radius, lateral, density, rng)
    return radius, lateral, pos, height


@pytest.mark.parametrize("grains, aspect, dim", [
    (96, 0.67, 2), (192, 1.33, 2), (600, 1.0, 2), (40, 1.0, 2), (6, 0.1, 2), (5, 1.0, 2), (13, 0.3, 2),
    (300, 3.0, 2), (1000, 0.5, 2), (60, 1.0, 3), (120, 1.0, 3), (500, 2.0, 3),
])
def test_granular_gas_places_every_grain(grains, aspect, dim):
    """Every (grains, aspect, seed) gives N non-overlapping grains inside the box (formerly
    grains=96 aspect=0.67 seeds 1,2,3,5,10, grains=192 aspect=1.33 seeds 2,5,10, grains=5 and
    3D grains=60 seed=2 raised numpy's 'Cannot take a larger sample than population')."""
    for seed in (0, 1, 2, 3, 5, 10, 17):
        radius, lateral, pos, height = _gas(grains, aspect, seed, dim)
        assert pos.shape == (grains, dim)
        assert np.all(pos[:, -1] - radius >= -1e-12) and np.all(pos[:, -1] + radius <= height + 1e-12)
        for a in range(dim - 1):
            assert np.all(pos[:, a] - radius >= -1e-12) and np.all(pos[:, a] + radius <= lateral[a] + 1e-12)
        x = pos[None, :, :] - pos[:, None, :]
        for a in range(dim - 1):
            x[:, :, a] -= lateral[a] * np.round(x[:, :, a] / lateral[a])
        dist = np.sqrt(np.sum(x * x, axis=2))
        gap = dist - (radius[:, None] + radius[None, :])
        np.fill_diagonal(gap, 1.0)
        assert gap.min() > -1e-12, (grains, aspect, seed)
        # same seed, same gas bit for bit
        again = _gas(grains, aspect, seed, dim)
        np.testing.assert_array_equal(again[2], pos)
        assert again[3] == height


def test_granular_gas_refuses_a_box_narrower_than_a_grain():
    with pytest.raises(InputError, match="periodic length"):
        _gas(1, 1.0, 0)
