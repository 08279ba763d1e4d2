"""Perfect triangular lattice and 1D chain states (docs/method.md §3) and their CLI."""

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from granwave import contact, systems, theory
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files


def net_force(p):
    c = p.contacts
    f_on_i = -c.force_normal[:, None] * c.normal + c.force_tangential
    force = np.zeros_like(p.position)
    np.add.at(force, c.i, f_on_i)
    np.add.at(force, c.j[c.j >= 0], -f_on_i[c.j >= 0])
    return force


@pytest.mark.parametrize("pressure", [1e-7, 1e-4, 1e-2])
def test_lattice_equilibrium_stress_and_wall_force(pressure):
    rows, width = 7, 5
    p = systems.triangular_lattice(rows=rows, width=width, pressure=pressure, friction=0.5, poisson=0.3)
    c = p.contacts
    assert p.n_grains == rows * width and p.dim == 2
    # per-grain force balance to round-off (relative to the contact force scale p)
    assert np.max(np.abs(net_force(p))) <= 1e-15 * pressure * 10
    assert p.attrs["max_acceleration"] <= 1e-14 * pressure
    # the geometry follows from the overlaps: every grain pair sits at R_i + R_j - delta
    pair = c.j >= 0
    d = p.position[c.j[pair]] - p.position[c.i[pair]]
    d[:, 0] -= p.box[0] * np.round(d[:, 0] / p.box[0])
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0 - c.overlap[pair], rtol=1e-14)
    y = p.position[:, 1]
    wall = ~pair
    gap = np.where(c.j[wall] == -1, y[c.i[wall]], p.box[1] - y[c.i[wall]])
    np.testing.assert_allclose(gap, 0.5 - c.overlap[wall], rtol=1e-14)
    # overlaps invert Hertz (contact.py) at the stored forces; stiffnesses are contact.py's
    r12 = np.where(wall, 0.5, 0.25)
    e12 = np.where(wall, 1.0, 0.5)
    law = np.array([contact.normal_force(o, r, e) for o, r, e in zip(c.overlap, r12, e12)])
    np.testing.assert_allclose(law, c.force_normal, rtol=1e-12)
    kn = np.array([contact.normal_stiffness(o, r, e) for o, r, e in zip(c.overlap, r12, e12)])
    np.testing.assert_allclose(c.stiffness_normal, kn, rtol=1e-15)
    eta = contact.stiffness_ratio(0.3)
    np.testing.assert_allclose(c.stiffness_tangential / c.stiffness_normal, eta, rtol=1e-13)
    # sigma_22 from the contacts (whole cell, walls with their arms) equals p
    arm = np.where(wall[:, None], (0.5 - c.overlap)[:, None] * c.normal, 0.0)
    branch = np.zeros_like(c.normal)
    branch[pair] = d
    branch[wall] = arm[wall]
    sigma22 = np.sum(c.force_normal * c.normal[:, 1] * branch[:, 1]) / (p.box[0] * p.box[1])
    assert sigma22 == pytest.approx(pressure, rel=1e-12)
    # wall force per length (per one diameter of thickness) equals p, on both walls
    for j in (-1, -2):
        assert c.force_normal[c.j == j].sum() / p.box[0] == pytest.approx(pressure, rel=1e-13)
    # contact counts: 6 in the bulk rows, 5 (4 grains + wall) in the first and last row
    z = np.bincount(c.i, minlength=p.n_grains) + np.bincount(c.j[pair], minlength=p.n_grains)
    row = np.round((y - y.min()) / p.attrs["row_spacing"]).astype(int)
    assert np.all(z[(row > 0) & (row < rows - 1)] == 6)
    assert np.all(z[(row == 0) | (row == rows - 1)] == 5)


def test_lattice_spacing_and_leading_order_force():
    # to leading order the contact force is p/sqrt(3) and the spacing 1 (docs/method.md §12)
    pressure = 1e-6
    p = systems.triangular_lattice(rows=3, width=3, pressure=pressure)
    a = p.attrs["spacing"]
    f = p.contacts.force_normal[p.contacts.j >= 0]
    np.testing.assert_allclose(f, pressure * a / np.sqrt(3), rtol=1e-15)
    assert 1 - a == pytest.approx((np.sqrt(3) * pressure) ** (2 / 3), rel=1e-3)
    assert p.attrs["row_spacing"] == pytest.approx(a * np.sqrt(3) / 2, rel=1e-15)
    assert p.box[0] == pytest.approx(3 * a, rel=1e-15)
    # tangential stiffness is computed also without friction (the linearization ignores it)
    assert np.all(p.contacts.stiffness_tangential > 0) and p.attrs["friction"] == 0.0


def test_lattice_bad_input():
    with pytest.raises(InputError, match="width"):
        systems.triangular_lattice(rows=4, width=2, pressure=1e-4)
    with pytest.raises(InputError, match="rows"):
        systems.triangular_lattice(rows=1, width=4, pressure=1e-4)
    with pytest.raises(InputError, match="pressure"):
        systems.triangular_lattice(rows=4, width=4, pressure=-1.0)


def test_chain_monodisperse_matches_theory_chain():
    pressure, n = 1e-4, 12
    ch = systems.chain(n_balls=n, pressure=pressure)
    c = ch.contacts
    assert ch.dim == 1 and ch.position.shape == (n, 1) and len(c) == n + 1
    # default K: Hertz k_n of two unit balls at contact force p (contact.py), on every spring
    r12, e12 = contact.effective_radius(2.0, 2.0), contact.effective_young(False)
    overlap = (pressure / contact.normal_force(1.0, r12, e12)) ** (2 / 3)
    K = contact.normal_stiffness(overlap, r12, e12)
    np.testing.assert_allclose(c.stiffness_normal, K, rtol=1e-14)
    np.testing.assert_allclose(c.force_normal, pressure, rtol=0)
    assert np.max(np.abs(net_force(ch))) == 0.0
    # positions: spacing 1 - p/K between balls (linear springs), walls at 0 and box[0]
    np.testing.assert_allclose(np.diff(ch.position[:, 0]), 1 - pressure / K, rtol=1e-14)
    assert ch.position[0, 0] == pytest.approx(0.5 - pressure / K, rel=1e-14)
    assert ch.box[0] - ch.position[-1, 0] == pytest.approx(0.5 - pressure / K, rel=1e-14)
    # the spring network is the chain of theory.py: same frequencies
    D = np.zeros((n, n))
    for i, j, k in zip(c.i, c.j, c.stiffness_normal):
        D[i, i] += k
        if j >= 0:
            D[j, j] += k
            D[i, j] -= k
            D[j, i] -= k
    w2 = np.linalg.eigvalsh(D / ch.mass[0])
    _, omega = theory.chain_modes(n, stiffness=K, mass=np.pi / 6)
    np.testing.assert_allclose(np.sqrt(w2), omega, rtol=1e-12)


def test_chain_polydisperse_seeded_and_hertz_option():
    a = systems.chain(n_balls=50, pressure=1e-5, polydispersity=0.3, seed=7)
    b = systems.chain(n_balls=50, pressure=1e-5, polydispersity=0.3, seed=7)
    other = systems.chain(n_balls=50, pressure=1e-5, polydispersity=0.3, seed=8)
    np.testing.assert_array_equal(a.position, b.position)
    assert not np.array_equal(a.radius, other.radius)
    d = 2 * a.radius
    assert d.min() >= 0.7 and d.max() <= 1.3 and d.std() > 0.05
    np.testing.assert_allclose(a.mass, np.pi * d**3 / 6, rtol=1e-15)
    np.testing.assert_allclose(a.contacts.stiffness_normal, a.contacts.stiffness_normal[0], rtol=0)
    centre_gap = np.diff(a.position[:, 0])
    np.testing.assert_allclose(centre_gap, a.radius[:-1] + a.radius[1:] - a.contacts.overlap[1:-1], rtol=1e-14)
    h = systems.chain(n_balls=5, pressure=1e-5, polydispersity=0.3, seed=7, stiffness_model="hertz")
    c = h.contacts
    wall = c.j < 0
    r12 = np.where(wall, h.radius[c.i], 1 / (1 / h.radius[c.i] + 1 / h.radius[np.maximum(c.j, 0)]))
    e12 = np.where(wall, 1.0, 0.5)
    np.testing.assert_allclose([contact.normal_force(o, r, e) for o, r, e in zip(c.overlap, r12, e12)],
                               1e-5, rtol=1e-12)
    np.testing.assert_allclose(c.stiffness_normal,
                               [contact.normal_stiffness(o, r, e) for o, r, e in zip(c.overlap, r12, e12)],
                               rtol=1e-14)
    with pytest.raises(InputError):
        systems.chain(n_balls=5, pressure=1e-5, polydispersity=1.2)
    with pytest.raises(InputError):
        systems.chain(n_balls=0, pressure=1e-5)
    with pytest.raises(InputError, match="overlaps"):
        systems.chain(n_balls=3, pressure=1.0, stiffness=1.0)


def test_cli_lattice_and_chain(tmp_path):
    runner = CliRunner()
    out = tmp_path / "lat.h5"
    res = runner.invoke(main, ["lattice", "--rows", "5", "--width", "4", "--pressure", "1e-5",
                               "--friction", "0.5", "--poisson", "0.2", "-o", str(out)])
    assert res.exit_code == 0, res.output
    lat = files.read_packing(out)
    ref = systems.triangular_lattice(rows=5, width=4, pressure=1e-5, friction=0.5, poisson=0.2)
    np.testing.assert_array_equal(lat.position, ref.position)
    assert lat.attrs["kind"] == "lattice" and lat.attrs["rows"] == 5 and lat.attrs["friction"] == 0.5
    with h5py.File(out) as f:  # parameters recorded in the file
        assert f.attrs["pressure"] == 1e-5 and f.attrs["poisson"] == 0.2 and f.attrs["width"] == 4
    out = tmp_path / "ch.h5"
    res = runner.invoke(main, ["chain", "--balls", "9", "--pressure", "1e-4", "--polydispersity", "0.2",
                               "--seed", "3", "-o", str(out)])
    assert res.exit_code == 0, res.output
    ch = files.read_packing(out)
    np.testing.assert_array_equal(
        ch.radius, systems.chain(n_balls=9, pressure=1e-4, polydispersity=0.2, seed=3).radius)
    assert ch.attrs["kind"] == "chain" and ch.dim == 1
    res = runner.invoke(main, ["chain", "--balls", "4", "--pressure", "1e-4", "--stiffness", "0.5",
                               "-o", str(tmp_path / "k.h5")])
    assert res.exit_code == 0
    assert np.all(files.read_packing(tmp_path / "k.h5").contacts.stiffness_normal == 0.5)
    assert "--pressure" in runner.invoke(main, ["lattice", "--help"]).output


@pytest.mark.parametrize("args", [
    ["lattice", "--rows", "5", "--width", "2", "--pressure", "1e-5"],
    ["lattice", "--rows", "5", "--width", "4", "--pressure", "nan"],
    ["chain", "--balls", "5", "--pressure", "1e-4", "--polydispersity", "1.5"],
    ["chain", "--balls", "5", "--pressure", "1.0", "--stiffness", "1.0"],
])
def test_cli_bad_input_writes_nothing(tmp_path, args):
    out = tmp_path / "x.h5"
    res = CliRunner().invoke(main, args + ["-o", str(out)])
    assert res.exit_code != 0 and "Traceback" not in res.output
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("ic", ["A", "B"])
def test_chain_through_linear_pipeline_equals_exact_modal_sum(ic):
    # End to end: systems.chain -> linearize -> eigensolve -> modal_signal against theory.py.
    # docs/conventions.md: (A) the wall-touching ball gets v = k_wall/m, (B) u = k_wall/<k_wall> = 1;
    # theory's (A) has velocity c = l sqrt(K/m) and (B) displacement l, so take l = 1 and
    # scale (A) by (K/m)/sqrt(K/m).
    from granwave.linear.assemble import linearize
    from granwave.linear.eigen import eigensolve
    from granwave.linear.propagate import modal_signal

    n = 30
    ch = systems.chain(n_balls=n, pressure=1e-4)
    K, m = ch.attrs["stiffness"], ch.mass[0]
    t = np.linspace(0, 3 * theory.chain_travel_time(n, stiffness=K, mass=m), 400)
    got = modal_signal(eigensolve(linearize(ch)), ic=ic, times=t)
    scale = np.sqrt(K / m) if ic == "A" else 1.0
    ref = scale * theory.chain_wall_force(t, n, ic=ic, stiffness=K, mass=m, spacing=1.0)
    assert np.max(np.abs(got - ref)) <= 1e-10 * np.max(np.abs(ref))
