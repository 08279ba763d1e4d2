"""Static characterization (docs/method.md §4) on the perfect lattice and hand-built packings."""

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy import integrate

from granwave import systems
from granwave.analysis.statics import KEYS, statics
from granwave.cli import main
from granwave.errors import InputError
from granwave.io import files
from granwave.model import Contacts, Packing

P = 1e-5


@pytest.fixture(scope="module")
def lattice():
    return systems.triangular_lattice(rows=14, width=5, pressure=P, friction=0.5)


def test_lattice_bulk_statistics(lattice):
    s = statics(lattice)
    a = lattice.box[0] / 5
    directions = np.arange(6) * np.pi / 3  # the six contact directions of a bulk ball
    assert s["z_star"] == 6.0 and s["rattler_fraction"] == 0.0
    assert s["F2"] == pytest.approx(np.mean(np.sin(directions) ** 2), abs=1e-14)
    assert s["Z2"] == pytest.approx(1.0, abs=1e-14) and s["Z3"] == pytest.approx(1.0, abs=1e-14)
    assert s["mean_force_over_p"] == pytest.approx(a / np.sqrt(3), rel=1e-14)  # f = p a / sqrt(3)
    assert np.isnan(s["F2_strong"])  # all forces equal: no contact is above the mean
    assert s["max_force_residual"] < 1e-12
    assert abs(s["piston_balance"]) < 1e-13


def test_lattice_stress_from_geometry(lattice):
    s = statics(lattice)
    rows = 14
    a = lattice.box[0] / 5
    height = lattice.box[1]
    f = P * a / np.sqrt(3)
    # per column of width a: `rows` in-row contacts (along x, length a) and 2(rows-1) inclined
    # ones at 60 deg; sigma_11 = sum F_x r_x / (a H), walls add nothing along x.
    sigma11 = (rows * f * a + 2 * (rows - 1) * f * a * np.cos(np.pi / 3) ** 2) / (a * height)
    sigma = np.asarray(s["stress"])
    assert sigma[1, 1] == pytest.approx(P, rel=1e-12)
    assert sigma[0, 0] == pytest.approx(sigma11, rel=1e-12)
    assert abs(sigma[0, 1]) < 1e-12 * P and abs(sigma[1, 0]) < 1e-12 * P
    assert s["stress_ratio"] == pytest.approx(sigma11 / P, rel=1e-12)


def test_lattice_solid_fraction_at_actual_spacing(lattice):
    a = lattice.box[0] / 5
    h = a * np.sqrt(3) / 2
    y0 = lattice.position[:, 1].min()
    # a slab from mid-row to mid-row spans whole periods of the row structure, so the cut
    # disks add up to exactly one ball per cell a x h
    layer = y0 + 2.5 * h
    s = statics(lattice, layer=layer)
    assert s["phi2"] == pytest.approx(np.pi * 0.25 / (a * h), rel=1e-12)
    assert s["phi3"] == pytest.approx((np.pi / 6) / (a * h * 1.0), rel=1e-12)
    assert s["phi3_star"] == s["phi3"]
    # a slab that is not whole periods differs, but only by the cut of one row
    s3 = statics(lattice)
    assert abs(s3["phi2"] - s["phi2"]) < 0.5 / (lattice.box[1] - 6)


def column_packing(*, tangential=0.0, side_force=1e-6 * P, dim=2):
    """Two unit balls stacked between the walls (force F = p L1 on each contact), a free ball C
    and a ball D pressed only against C (C and D: one contact each, so both are rattlers)."""
    L1 = 4.0
    F = P * L1 if dim == 2 else P * L1 * L1
    dw = (F / (4 / 3 * np.sqrt(0.5))) ** (2 / 3)  # Hertz against a wall
    dg = (F / (4 / 3 * np.sqrt(0.25) * 0.5)) ** (2 / 3)
    ya = 0.5 - dw
    yb = ya + 1 - dg
    H = yb + 0.5 - dw
    rc, rd, dcd = 0.4, 0.45, 1e-6
    lat = [1.0] * (dim - 1)
    pos = np.array([lat + [ya], lat + [yb], [3.0] * (dim - 1) + [H / 2], [3.0] * (dim - 1) + [H / 2]])
    pos[3, 0] = 3.0 - (rc + rd - dcd)  # D left of C
    up = np.zeros(dim); up[-1] = 1.0
    ex = np.zeros(dim); ex[0] = 1.0
    normal = np.array([-up, up, up, -ex])  # A-bottom, A-B, B-top, C-D (from C towards D)
    ft = np.zeros((4, dim))
    ft[0, 0], ft[1, 0], ft[2, 0] = -tangential, tangential, tangential
    contacts = Contacts(i=np.array([0, 0, 1, 2]), j=np.array([-1, 1, -2, 3]), normal=normal,
                        overlap=np.array([dw, dg, dw, dcd]), force_normal=np.array([F, F, F, side_force]),
                        force_tangential=ft, stiffness_normal=np.ones(4), stiffness_tangential=np.ones(4))
    radius = np.array([0.5, 0.5, rc, rd])
    box = np.array([L1] * (dim - 1) + [H])
    p = Packing(position=pos, radius=radius, mass=np.pi * (2 * radius) ** 3 / 6,
                inertia=np.pi * (2 * radius) ** 5 / 60, box=box, contacts=contacts,
                attrs=dict(pressure=P, friction=0.5, poisson=0.0, seed=0, converged=True,
                           max_acceleration=0.0, kind="test"))
    return p, dict(F=F, dw=dw, dg=dg, H=H, L1=L1)


def test_rattlers_fractions_and_residuals():
    p, g = column_packing()
    s = statics(p, layer=0.0)
    assert s["rattler_fraction"] == 0.5 and s["n_rattlers_bulk"] == 2
    assert s["z_star"] == 2.0  # A and B: one wall and one grain contact each
    assert s["F2"] == 1.0 and s["mean_force_over_p"] == pytest.approx(g["L1"], rel=1e-14)
    # solid fractions: spheres cut by the wall planes, integrated independently
    def inside(r, yc):
        return integrate.quad(lambda y: np.pi * (r * r - (y - yc) ** 2), max(0.0, yc - r),
                              min(g["H"], yc + r), epsabs=1e-14)[0]
    vol = [inside(r, y) for r, y in zip(p.radius, p.position[:, 1])]
    area = g["L1"] * g["H"]
    assert s["phi3"] == pytest.approx(sum(vol) / area, rel=1e-10)
    assert s["phi3_star"] == pytest.approx((vol[0] + vol[1]) / area, rel=1e-10)
    # stress: the column's branch vectors add up to H, so sigma_22 = F / L1 = p;
    # the C-D pair adds its F r along x.
    sigma = np.asarray(s["stress"])
    assert sigma[1, 1] == pytest.approx(P, rel=1e-13)
    assert sigma[0, 0] == pytest.approx(1e-6 * P * (0.85 - 1e-6) / area, rel=1e-12)
    assert s["piston_balance"] == pytest.approx(0.0, abs=1e-14)
    # the unbalanced C-D pair is the worst residual: 1e-6 p
    assert s["max_force_residual"] == pytest.approx(1e-6, rel=1e-9)
    # literal rule: C and D each have a force-carrying contact, so they are not rattlers
    assert statics(p, layer=0.0, min_contacts=1)["rattler_fraction"] == 0.0


def test_torque_residual_uses_contact_arms():
    t = 1e-3 * P
    p, g = column_packing(tangential=t)
    s = statics(p, layer=0.0)
    # forces on A and B balance, torques do not: arms R - delta/2 (pair), R - delta (wall)
    arm_pair, arm_wall = 0.5 - g["dg"] / 2, 0.5 - g["dw"]
    assert s["max_force_residual"] == pytest.approx(t * (arm_pair + arm_wall) / P, rel=1e-12)
    # a piston that pushes 1% too hard shows up in piston_balance
    p.contacts.force_normal[2] *= 1.01
    assert statics(p, layer=0.0)["piston_balance"] == pytest.approx(0.01, rel=1e-12)


def test_three_dimensional_column():
    p, g = column_packing(dim=3)
    s = statics(p, layer=0.0)
    assert np.isnan(s["phi2"]) and s["phi3"] > 0
    sigma = np.asarray(s["stress"])
    assert sigma.shape == (3, 3) and sigma[2, 2] == pytest.approx(P, rel=1e-13)
    assert s["piston_balance"] == pytest.approx(0.0, abs=1e-14)


def test_chain_statics():
    ch = systems.chain(n_balls=20, pressure=P, polydispersity=0.3, seed=2)
    s = statics(ch)
    assert s["z_star"] == 2.0 and s["F2"] == 1.0 and s["rattler_fraction"] == 0.0
    assert np.asarray(s["stress"])[0, 0] == pytest.approx(P, rel=1e-13)
    assert s["piston_balance"] == pytest.approx(0.0, abs=1e-14)
    assert s["max_force_residual"] == 0.0 and np.isnan(s["phi3"])


def test_layer_too_thick_is_refused(lattice):
    with pytest.raises(InputError, match="no bulk"):
        statics(lattice, layer=lattice.height / 2 + 0.1)


def test_cli_statics(tmp_path, lattice):
    files.write_packing(tmp_path / "lat.h5", lattice)
    runner = CliRunner()
    res = runner.invoke(main, ["analyze", "statics", str(tmp_path / "lat.h5"), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert set(KEYS) <= set(out)
    assert out["z_star"] == 6.0 and out["stress"][1][1] == pytest.approx(P, rel=1e-12)
    assert out["F2_strong"] is None  # NaN -> null
    res = runner.invoke(main, ["analyze", "statics", str(tmp_path / "lat.h5"), "--layer", "1"])
    assert res.exit_code == 0 and "z_star" in res.output
    res = runner.invoke(main, ["analyze", "statics", str(tmp_path / "lat.h5"), "--layer", "100"])
    assert res.exit_code != 0 and "no bulk" in res.output and len(res.output.strip().splitlines()) == 1
    (tmp_path / "foreign.h5").write_text("nope")
    res = runner.invoke(main, ["analyze", "statics", str(tmp_path / "foreign.h5")])
    assert res.exit_code != 0 and "not an HDF5 file" in res.output
