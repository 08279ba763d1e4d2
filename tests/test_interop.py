"""LAMMPS export/import and ParaView export.

- the LAMMPS coefficients reproduce granwave's Hertz-Mindlin law and damping exactly
- data files and dumps read back what was written; bad files give one line, exit 2
- granwave -> dump -> granwave gives back the packing (positions, contacts)
- granwave -> LAMMPS (the deck run for real) -> granwave: positions within 1e-6 d, the
  same force-carrying contacts, LAMMPS' wall forces equal to granwave's
- VTK files read back with meshio: grains, contacts and snapshot series
"""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import contact as C
from granwave.cli import main
from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.errors import InputError
from granwave.interop import lammps as LM
from granwave.interop.relax import relax_grains
from granwave.io import files
from lammps_three_grains import three_grain_forces

TIGHT = 1e-13  # equilibrium tolerance of the round trips: displacement ~ tol / omega_min^2 << 1e-6


@pytest.fixture(scope="module")
def packing():
    """A small frictionless packing relaxed to TIGHT (a periodic frictionless packing's only
    history is its positions, so LAMMPS can continue it exactly)."""
    p = prepare_packing(PrepareParams(grains=40, friction=0.0, pressure=1e-4, seed=3))
    params = PrepareParams(grains=40, friction=0.0, pressure=1e-4, tol=TIGHT, max_steps=400_000,
                           piston_mass=float(p.attrs["piston_mass"]))
    return relax_grains(p.position, p.radius, p.box[:-1], params, piston_height=p.height)


def contact_set(pk):
    return set(zip(pk.contacts.i.tolist(), pk.contacts.j.tolist()))


def max_shift(a, b, lateral):
    d = a - b
    d[:, :-1] -= lateral * np.round(d[:, :-1] / lateral)
    return float(np.abs(d).max())


def run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


# ---------------------------------------------------------------- contact law
@pytest.mark.parametrize("zeta", [0.0, 0.1, 0.5, 0.9])
def test_lammps_damping_equals_granwave_damping(zeta):
    """LAMMPS coeff_restitution: c = sqrt(5) x(e) sqrt(m F_n / n), x = -ln e / sqrt(pi^2 + ln^2 e)
    (LAMMPS' GranSubModDampingCoeffRestitution); granwave: c = 2 zeta sqrt(m k_n)."""
    e = LM.restitution_for_damping(zeta)
    x = -math.log(e) / math.sqrt(math.pi**2 + math.log(e) ** 2)
    for overlap, r12, e12, m in [(1e-3, 0.25, 0.5, 0.3), (4e-5, 0.6, 1.0, 0.9)]:
        f = C.normal_force(overlap, r12, e12)
        lammps = math.sqrt(5.0) * x * math.sqrt(m * f / overlap)
        granwave = C.damping_coefficient(zeta, m, C.normal_stiffness(overlap, r12, e12))
        assert lammps == pytest.approx(granwave, rel=1e-12, abs=1e-300)


def test_lammps_stiffness_coefficients_equal_granwave_law():
    """hertz: F = k_n sqrt(R n) n; mindlin: k_t(n) = k_t sqrt(R n) (LAMMPS' definitions)."""
    for poisson in (0.0, 0.3):
        k = LM.lammps_coefficients(0.5, poisson, 0.5)
        for wall, kn, kt in ((False, k["kn_pair"], k["kt_pair"]), (True, k["kn_wall"], k["kt_wall"])):
            r12, n = 0.37, 2e-3
            assert kn * math.sqrt(r12 * n) * n == pytest.approx(
                C.normal_force(n, r12, C.effective_young(wall)), rel=1e-14)
            assert kt * math.sqrt(r12 * n) == pytest.approx(
                C.tangential_stiffness(n, r12, C.effective_shear(poisson, wall)), rel=1e-14)
        assert k["xgammat"] ** 2 == pytest.approx(C.stiffness_ratio(poisson), rel=1e-14)
    with pytest.raises(InputError, match="coeff_restitution"):
        LM.restitution_for_damping(0.95)


# ---------------------------------------------------------------- files
def test_data_file_reads_back_what_was_written(packing, tmp_path):
    LM.export_lammps(packing, tmp_path)
    state = LM.read_lammps(tmp_path / LM.DATA_NAME)
    g = LM.grains_of_state(state)
    assert g["dim"] == 2
    np.testing.assert_array_equal(g["position"], packing.position)
    np.testing.assert_array_equal(g["radius"], packing.radius)
    np.testing.assert_array_equal(g["lateral"], packing.box[:-1])
    assert g["piston_height"] == packing.height
    deck = (tmp_path / LM.DECK_NAME).read_text()
    assert "pair_style      granular" in deck and "read_data       packing.data" in deck


def _dump(packing, cols=("id", "type", "radius", "xs", "ys", "zs"), timesteps=(0, 500)):
    n = packing.n_grains
    lo, hi = np.zeros(3), np.array([packing.box[0], packing.height + 1.0, 0.5])
    lo[2] = -0.5
    pos = np.zeros((n, 3))
    pos[:, :2] = packing.position
    scaled = (pos - lo) / (hi - lo)
    values = {"id": np.arange(n, 0, -1), "type": np.ones(n), "radius": packing.radius,
              "diameter": 2 * packing.radius, "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2],
              "xs": scaled[:, 0], "ys": scaled[:, 1], "zs": scaled[:, 2]}
    out = []
    for ts in timesteps:  # the reader keeps the last snapshot
        out += ["ITEM: TIMESTEP", str(ts), "ITEM: NUMBER OF ATOMS", str(n), "ITEM: BOX BOUNDS pp ff pp"]
        out += [f"{float(lo[a])!r} {float(hi[a])!r}" for a in range(3)]
        out.append("ITEM: ATOMS " + " ".join(cols))
        for k in range(n)[::-1]:  # ids n..1 in reverse file order: the reader sorts by id
            out.append(" ".join(repr(float(values[c][k])) if c not in ("id", "type") else str(int(values[c][k]))
                                for c in cols))
    return "\n".join(out) + "\n"


def test_dump_round_trip_through_the_cli(packing, tmp_path):
    """granwave -> text dump (scaled coordinates, ids shuffled) -> import: the relaxed
    packing is the original (it was already at equilibrium)."""
    # ids run n..1 (grain k has id n-k), so the reader's order is the packing's reversed
    rev = packing.n_grains - 1 - np.arange(packing.n_grains)
    (tmp_path / "dump.txt").write_text(_dump(packing))
    out = tmp_path / "back.h5"
    r = run(["import", "lammps", tmp_path / "dump.txt", "-o", out, "--pressure", 1e-4, "--friction", 0,
             "--tol", TIGHT, "-q"])
    assert r.exit_code == 0, r.output
    back = files.read_packing(out)
    assert back.attrs["source_format"] == "lammps text dump" and back.attrs["source_timestep"] == 500
    assert back.attrs["source_file"].endswith("dump.txt")
    # the dump has no piston atom: the piston starts on the highest grain and comes down
    assert max_shift(back.position, packing.position[rev], packing.box[:-1]) < 1e-6
    assert back.height == pytest.approx(packing.height, abs=1e-6)
    assert len(back.contacts) == len(packing.contacts)


def _bad_files(packing, tmp_path):
    LM.export_lammps(packing, tmp_path)
    good = (tmp_path / LM.DATA_NAME).read_text()
    lines = good.splitlines()
    start = lines.index("Atoms # sphere") + 2
    short = lines[:start] + [" ".join(line.split()[:5]) for line in lines[start:]]
    return {
        "missing columns": ("\n".join(short) + "\n", "7 columns"),
        "unknown atom style": (good.replace("Atoms # sphere", "Atoms # atomic"), "unknown atom style 'atomic'"),
        "dump without radii": (_dump(packing, cols=("id", "type", "x", "y", "z")), "no radius or diameter"),
    }


@pytest.mark.parametrize("case", ["missing columns", "unknown atom style", "dump without radii"])
def test_bad_files_one_line_exit_2_no_output(packing, tmp_path, case):
    text, message = _bad_files(packing, tmp_path)[case]
    src = tmp_path / "bad.txt"
    src.write_text(text)
    out = tmp_path / "out.h5"
    r = run(["import", "lammps", src, "-o", out, "--pressure", 1e-4, "-q"])
    assert r.exit_code == 2, r.output
    assert message in r.output and len(r.output.strip().splitlines()) == 1
    assert "Traceback" not in r.output
    assert not out.exists() and not list(tmp_path.glob(".out.h5*"))


def test_not_relaxed_within_budget_exit_2_no_output(packing, tmp_path):
    """Grains pushed 5 % apart cannot settle in 50 steps."""
    spread = type(packing)(position=packing.position * [1.0, 1.05], radius=packing.radius,
                           mass=packing.mass, inertia=packing.inertia,
                           box=np.array([packing.box[0], packing.height * 1.05]),
                           contacts=packing.contacts, attrs=packing.attrs)
    LM.export_lammps(spread, tmp_path)
    out = tmp_path / "out.h5"
    r = run(["import", "lammps", tmp_path / LM.DATA_NAME, "-o", out, "--pressure", 1e-4, "--friction", 0,
             "--max-steps", 50, "-q"])
    assert r.exit_code == 2, r.output
    assert "did not relax" in r.output and len(r.output.strip().splitlines()) == 1
    assert not out.exists()


def test_export_lammps_bad_input_exit_2(packing, tmp_path):
    (tmp_path / "x.h5").write_text("not hdf5")
    r = run(["export", "lammps", tmp_path / "x.h5", "-o", tmp_path / "deck"])
    assert r.exit_code == 2 and "not an HDF5 file" in r.output
    assert not (tmp_path / "deck").exists()
    files.write_packing(tmp_path / "p.h5", packing)
    r = run(["export", "lammps", tmp_path / "p.h5", "-o", tmp_path / "deck", "--damping", 0.95])
    assert r.exit_code == 2 and "coeff_restitution" in r.output
    assert len(r.output.strip().splitlines()) == 1 and not (tmp_path / "deck").exists()


# ---------------------------------------------------------------- LAMMPS for real
@pytest.fixture(scope="module")
def lammps():
    lmp = LM.lammps_module()
    if lmp is None:
        pytest.skip("the lammps Python module is not installed (pip install lammps mpich); "
                    "benchmarks/lammps_roundtrip.py runs the same round trip")
    L = lmp.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    has = L.has_package("GRANULAR")
    L.close()
    if not has:
        pytest.skip("this LAMMPS build has no GRANULAR package")
    return lmp


def test_lammps_round_trip(packing, tmp_path, lammps):
    """granwave -> export -> LAMMPS runs the deck 3000 steps, write_data -> import: positions
    within 1e-6 d, the same force-carrying contacts; LAMMPS' piston wall forces at step 0
    equal granwave's top-wall contact forces."""
    src = tmp_path / "packing.h5"
    files.write_packing(src, packing)
    deck = tmp_path / "deck"
    r = run(["export", "lammps", src, "-o", deck, "--steps", 3000, "-q"])
    assert r.exit_code == 0, r.output
    continued = LM.run_deck(deck, lammps)
    out = tmp_path / "back.h5"
    r = run(["import", "lammps", continued, "-o", out, "--pressure", 1e-4, "--friction", 0,
             "--tol", TIGHT, "-q"])
    assert r.exit_code == 0, r.output
    back = files.read_packing(out)
    # from the piston atom (write_data prints 16 digits)
    assert back.attrs["piston_mass"] == pytest.approx(packing.attrs["piston_mass"], rel=1e-15)
    assert max_shift(back.position, packing.position, packing.box[:-1]) < 1e-6
    assert abs(back.height - packing.height) < 1e-6
    assert contact_set(back) == contact_set(packing)
    # what LAMMPS itself computes at the exported state: the piston's reaction per grain
    from lammps import LMP_STYLE_ATOM, LMP_TYPE_ARRAY
    text = (deck / LM.DECK_NAME).read_text()
    (deck / LM.DECK_NAME).write_text(text.replace("run             3000", "run 0").replace(
        "write_data      continued.data", ""))
    import os
    here = os.getcwd()
    os.chdir(deck)
    try:
        L = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
        L.file(LM.DECK_NAME)
        arr = L.numpy.extract_fix("top", LMP_STYLE_ATOM, LMP_TYPE_ARRAY).copy()
        ids = L.numpy.extract_atom("id").copy()
        L.close()
    finally:
        os.chdir(here)
    c = packing.contacts
    top = c.j == -2
    fy = dict(zip(ids.tolist(), arr[:, 2].tolist()))
    np.testing.assert_allclose([-fy[i + 1] for i in c.i[top]], c.force_normal[top], rtol=1e-9)


# ---------------------------------------------------------------- VTK
def test_vtk_packing_reads_back(packing, tmp_path):
    meshio = pytest.importorskip("meshio")
    src = tmp_path / "packing.h5"
    files.write_packing(src, packing)
    r = run(["export", "vtk", src, "-o", tmp_path / "packing.vtu", "-q"])
    assert r.exit_code == 0, r.output
    mesh = meshio.read(tmp_path / "packing.vtu")
    n = packing.n_grains
    np.testing.assert_array_equal(mesh.points[:n, :2], packing.position)
    np.testing.assert_array_equal(mesh.point_data["radius"][:n], packing.radius)
    np.testing.assert_array_equal(mesh.point_data["mass"][:n], packing.mass)
    from granwave.analysis.statics import find_rattlers
    np.testing.assert_array_equal(mesh.point_data["rattler"][:n], find_rattlers(packing)[0])
    lines = mesh.cells_dict["line"]
    c = packing.contacts
    assert len(lines) == len(c)
    np.testing.assert_array_equal(lines[:, 0], c.i)
    k = [b.type for b in mesh.cells].index("line")
    np.testing.assert_array_equal(mesh.cell_data["force_normal"][k], c.force_normal)
    np.testing.assert_array_equal(mesh.cell_data["force_tangential"][k][:, :2], c.force_tangential)
    # every line is as long as the contact's centre distance (periodic images, wall points)
    length = np.linalg.norm(mesh.points[lines[:, 1]] - mesh.points[lines[:, 0]], axis=1)
    ri = packing.radius[c.i]
    expect = np.where(c.j >= 0, ri + packing.radius[np.maximum(c.j, 0)] - c.overlap, ri - c.overlap)
    np.testing.assert_allclose(length, expect, rtol=1e-12)


def test_vtk_snapshot_series_reads_back(tmp_path):
    meshio = pytest.importorskip("meshio")
    from granwave.interop.vtk import read_pvd
    from granwave.systems import triangular_lattice

    pk = triangular_lattice(rows=4, width=6, pressure=1e-4, friction=0.5)
    files.write_packing(tmp_path / "lattice.h5", pk)
    for args in (["linearize", tmp_path / "lattice.h5", "-o", tmp_path / "lin.h5"],
                 ["propagate", tmp_path / "lin.h5", "-o", tmp_path / "sig.h5", "--t-max", 20,
                  "--snapshots", "5,10,15"]):
        r = run(args)
        assert r.exit_code == 0, r.output
    sig = files.read_signal(tmp_path / "sig.h5")
    r = run(["export", "vtk", tmp_path / "sig.h5", "-o", tmp_path / "snap.pvd", "-q"])
    assert r.exit_code == 2 and "give --packing" in r.output
    assert not list(tmp_path.glob("snap*"))
    r = run(["export", "vtk", tmp_path / "sig.h5", "-o", tmp_path / "snap.pvd", "--packing",
             tmp_path / "lattice.h5", "-q"])
    assert r.exit_code == 0, r.output
    series = read_pvd(tmp_path / "snap.pvd")
    assert [t for t, _ in series] == list(sig.snapshot_time)
    rot = sig.dof_axis >= 2
    for (t, path), u in zip(series, sig.snapshot_displacement):
        mesh = meshio.read(path)
        np.testing.assert_array_equal(mesh.points[:, :2], pk.position)
        disp = mesh.point_data["displacement"]
        np.testing.assert_array_equal(disp[sig.dof_grain[~rot], sig.dof_axis[~rot]], u[~rot])
        np.testing.assert_array_equal(mesh.point_data["rotation"][sig.dof_grain[rot], 2], u[rot])


def test_lammps_contact_law_equals_granwave_law(lammps):
    """Two grains (and one grain on a wall) in LAMMPS with the deck's model words, moved by
    fix move: the normal force with damping at an approach speed, and the tangential spring
    after a shear s = N v dt plus its damping, equal granwave's contact law (docs/method.md §2).
    Friction 0.5, Poisson 0.3 (k_t/k_n = 0.824), zeta = 0.4. Measured: normal forces to 1e-12,
    wall shear to 1e-13, pair shear to 5e-4 (LAMMPS turns the pair history with the moving
    normal; the tolerance is 2 steps of shear in 1000)."""
    mu, nu, zeta = 0.5, 0.3, 0.4
    r1, r2, n, vn, vt, dt, steps = 0.5, 0.45, 2e-3, 1e-4, 1e-5, 1e-3, 1000
    m1, m2 = math.pi / 6, math.pi * 0.9**3 / 6

    def forces(v_normal, v_tangential, nsteps):
        return three_grain_forces(lammps, LM.granular_model(mu, nu, zeta, wall=False),
                                  LM.granular_model(mu, nu, zeta, wall=True), r1=r1, r2=r2,
                                  overlap=n, v_normal=v_normal, v_tangential=v_tangential, dt=dt,
                                  nsteps=nsteps)

    # normal force with damping at the approach speed, no history (run 0)
    f, _ = forces(vn, 0.0, 0)
    r12 = 1 / (1 / r1 + 1 / r2)
    meff = m1 * m2 / (m1 + m2)
    e_p, e_w = C.effective_young(False), C.effective_young(True)
    for fx, r12_, e12, m in ((-f[0, 0], r12, e_p, meff), (f[2, 2], r1, e_w, m1)):
        k_n = C.normal_stiffness(n, r12_, e12)
        assert fx == pytest.approx(C.normal_force(n, r12_, e12) + C.damping_coefficient(zeta, m, k_n) * vn,
                                   rel=1e-9)
    # tangential: spring after the shear s = N vt dt, plus the damping at vt
    f, x = forces(0.0, vt, steps)
    g_p, g_w = C.effective_shear(nu, False), C.effective_shear(nu, True)
    for ft, r12_, g12, m, s in ((f[0, 1], r12, g_p, meff, x[1, 1]), (-f[2, 0], r1, g_w, m1, x[2, 0])):
        k_t = C.tangential_stiffness(n, r12_, g12)
        expect = k_t * s + C.damping_coefficient(zeta, m, k_t) * vt
        assert ft == pytest.approx(expect, rel=2.0 / steps)
