"""The low-pressure normal laws (docs/method.md §2, "Low-pressure laws"): ``cone`` (Goddard's conical
asperity, F_n ~ n^2) and ``cone_hertz`` (the crossover law: the asperity below n*, Hertz above): exact checks.

- formulas through the dispatchers: F_n = dE/dn, k_n = dF_n/dn, k_t = eta k_n, the inverse
  overlap; the crossover's force, stiffness and k_t continuous at n*;
- two grains colliding head on without damping: the contact time of the closed form (F = A n^2:
  2 (n_m / V) sqrt(pi) Gamma(4/3) / Gamma(5/6); the crossover: the quadrature of its own energy,
  in either branch) and restitution 1;
- triangular lattices: k_n ~ f^(1/2) below the crossover and f^(1/3) above it, exactly; the
  lattice's longitudinal speed (its linear system's row chain, docs/method.md §12) goes as
  p^(1/4) below p* and p^(1/6) above, to the corrections of the shrinking spacing and the
  prestress; the front's c_tof through linearize, propagate and heights scales alike;
- DEM-prepared packings: the linearization equals the finite-difference Jacobian of the engine's
  frozen-history forces (the crossover's with contacts on both sides of n*), and the nonlinear DEM
  pulse at vanishing amplitude equals the linear signal;
- the CLI: the options, the files, and ``export lammps`` refusing them (no LAMMPS equivalent).
"""

import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy import integrate, optimize, special

from granwave import api
from granwave import contact as C
from granwave import contact_models as CM
from granwave.cli import main
from granwave.contact_models import options as CO
from granwave.dem.integrator import Engine
from granwave.linear.assemble import linearize
from granwave.params import PrepareParams

MASS = math.pi / 6
R12, E12, ROOT = 0.25, C.effective_young(False), 0.5  # two unit grains


def _values(law, **params):
    return CO.resolve(dict(contact_law=law, friction=0.5, poisson=0.0, **params))


def _law(law, **params):
    return CM.model_of("normal", _values(law, **params))


@pytest.mark.parametrize("law, params", [("cone", dict(cone_slope=0.05)), ("cone", dict(cone_slope=0.3)),
                                         ("cone_hertz", dict(crossover_overlap=1e-3))])
def test_formulas(law, params):
    m = _law(law, **params)
    g12 = C.effective_shear(0.0, False)
    for n in (1e-6, 3e-4, 9e-4, 1.2e-3, 5e-3):
        f = CM.law_force(m, n, ROOT, E12)
        k = CM.law_stiffness(m, n, ROOT, E12)
        h = n * 1e-6
        assert (CM.law_energy(m, n + h, R12, E12) - CM.law_energy(m, n - h, R12, E12)) / (2 * h) == \
            pytest.approx(f, rel=1e-8)
        assert (CM.law_force(m, n + h, ROOT, E12) - CM.law_force(m, n - h, ROOT, E12)) / (2 * h) == \
            pytest.approx(k, rel=1e-8)
        # Mindlin's k_t = 8 G*12 a = eta k_n (eta = 1 at nu = 0: 8 G*12 = 2 E*12)
        assert CM.law_tangential_stiffness(m, n, R12, g12) == pytest.approx(k, rel=1e-14)
        assert CM.overlap_at_force(_values(law, **params), f, R12, E12) == pytest.approx(n, rel=1e-14)
        assert CM.law_unloading_scale(m, n, 0.5 * n) == pytest.approx(
            CM.law_tangential_stiffness(m, 0.5 * n, R12, g12) / CM.law_tangential_stiffness(m, n, R12, g12), rel=1e-14)
    assert CM.law_force(m, -1e-4, ROOT, E12) == 0.0 and CM.law_stiffness(m, 0.0, ROOT, E12) == 0.0
    if law == "cone":  # F = (2/pi) E*12 n^2 / tan(beta)
        assert CM.law_force(m, 1e-3, ROOT, E12) == pytest.approx(2 / math.pi * E12 * 1e-6 / params["cone_slope"],
                                                                rel=1e-15)
    else:  # continuous at n*: force, stiffness (hence k_t), below n^2, above Hertz shifted by n*/4
        n_star = params["crossover_overlap"]
        below, above = n_star * (1 - 1e-12), n_star * (1 + 1e-12)
        for fn in (CM.law_force, CM.law_stiffness):
            assert fn(m, below, ROOT, E12) == pytest.approx(fn(m, above, ROOT, E12), rel=1e-9)
        assert CM.law_force(m, 4e-3, ROOT, E12) == pytest.approx(C.normal_force(4e-3 - n_star / 4, R12, E12), rel=1e-14)
        assert CM.law_force(m, 0.5 * n_star, ROOT, E12) == pytest.approx(CM.law_force(m, n_star, ROOT, E12) / 4,
                                                                         rel=1e-14)


def _contact_time(law, params, V):
    """Head-on collision of two unit grains at relative speed V (m_eff = m/2): the closed form."""
    meff = MASS / 2
    m = _law(law, **params)
    if law == "cone":
        A = CM.own_constants("normal", m)[0] * E12
        n_m = (3 * meff * V * V / (2 * A)) ** (1 / 3)
        return 2 * n_m / V * math.sqrt(math.pi) * special.gamma(4 / 3) / special.gamma(5 / 6), n_m
    energy = lambda n: CM.law_energy(m, n, R12, E12)  # noqa: E731
    n_m = optimize.brentq(lambda n: energy(n) - 0.5 * meff * V * V, 0.0, 0.1, xtol=1e-18, rtol=1e-15)
    n_star = params["crossover_overlap"]

    def smooth(n):
        """sqrt(n_m - n) / speed(n): the integrand without its 1/sqrt(n_m - n) singularity (quad's alg
        weight takes that), its limit 1 / sqrt(2 F(n_m) / m_eff) at the turning point."""
        gap = n_m - n
        if gap <= 1e-9 * n_m:
            return 1.0 / math.sqrt(2 * CM.law_force(m, n_m, ROOT, E12) / meff)
        return math.sqrt(gap / (V * V - 2 * energy(n) / meff))
    if n_m <= n_star:
        t = integrate.quad(smooth, 0, n_m, weight="alg", wvar=(0, -0.5), epsrel=1e-12)[0]
    else:
        t = integrate.quad(lambda n: 1 / math.sqrt(V * V - 2 * energy(n) / meff), 0, n_star, epsrel=1e-12)[0] + \
            integrate.quad(smooth, n_star, n_m, weight="alg", wvar=(0, -0.5), epsrel=1e-12)[0]
    return 2 * t, n_m


@pytest.mark.parametrize("law, params, V", [("cone", dict(cone_slope=0.05), 2e-3),
                                            ("cone_hertz", dict(crossover_overlap=1e-3), 5e-5),  # asperity only
                                            ("cone_hertz", dict(crossover_overlap=1e-3), 2e-3)])  # into Hertz
def test_head_on_collision_contact_time_and_restitution(law, params, V):
    """Contact time of the closed form to 1e-5 at 2000 steps per contact (velocity Verlet's error:
    measured -1.5e-7, (omega dt)^2 / 24 = 1e-7 for a linear spring; the start and end interpolated
    between steps), restitution 1 to 1e-8 (measured 1e-11; no damping). The crossover at the higher
    speed reaches past n*."""
    t_c, n_m = _contact_time(law, params, V)
    if law == "cone_hertz":
        assert (n_m > params["crossover_overlap"]) == (V > 1e-3)
    dt = t_c / 2000
    gap = 50.5 * V * dt
    e = Engine([[4.5 - gap / 2, 5.0], [5.5 + gap / 2, 5.0]], [0.5, 0.5], [10.0], 10.0, friction=0.0, damping=0.0,
               dt=dt, skin=0.2, check_every=0, velocity=[[V / 2, 0.0], [-V / 2, 0.0]], contact_law=law, **params)
    times, last, step = [], 1.0 - (e.position[1, 0] - e.position[0, 0]), 0
    while len(times) < 2 and step < 5000:
        e.run(1)
        step += 1
        now = 1.0 - (e.position[1, 0] - e.position[0, 0])
        if (last <= 0.0 < now) or (last > 0.0 >= now):
            times.append((step - 1 + last / (last - now)) * dt)
        last = now
    assert len(times) == 2
    assert times[1] - times[0] == pytest.approx(t_c, rel=1e-5)
    assert (e.velocity[1, 0] - e.velocity[0, 0]) / V == pytest.approx(1.0, abs=1e-8)


# ---------------------------------------------------------------- lattices
def _row_speed(lat, prestress=True):
    """The lattice's longitudinal speed across the rows from its own linear system: D maps
    row-uniform vertical motion onto itself (checked), a chain of row stiffness K_row (the
    off-diagonal of U^T D U / width), c = h sqrt(K_row / m)."""
    s = linearize(lat, prestress=prestress)
    D = s.stiffness.toarray()
    rows, width = lat.attrs["rows"], lat.attrs["width"]
    row_of = s.dof_grain // width
    ydof = s.dof_axis == 1
    U = np.zeros((s.n_dof, rows))
    U[ydof, row_of[ydof]] = 1.0
    DU = D @ U
    assert np.abs(DU[~ydof]).max() < 1e-12 * np.abs(D).max()
    chain = U.T @ DU / width
    k_row = -chain[rows // 2, rows // 2 + 1]
    return lat.attrs["row_spacing"] * math.sqrt(k_row / MASS)


@pytest.mark.parametrize("law, params, p1, p2, alpha", [
    ("cone", dict(cone_slope=0.05), 1e-9, 1e-8, 0.25),
    ("cone_hertz", dict(crossover_overlap=2e-5), 1e-12, 1e-11, 0.25),  # p* = (3/8) n*^(3/2) = 3.4e-8
    ("cone_hertz", dict(crossover_overlap=2e-5), 1e-6, 1e-5, 1 / 6),
    ("hertz", {}, 1e-6, 1e-5, 1 / 6),
])
def test_lattice_stiffness_and_speed_exponents(law, params, p1, p2, alpha):
    """k_n ~ f^(2 alpha) over the lattice's contacts (pair and wall, both pressures) to 1e-9; the
    speed of the lattice's linear system (with the prestress terms) ~ p^alpha to the corrections:
    the spacing a = 1 - n (c ~ a sqrt(K_row): ~ 2 n / (3 alpha) ... asked 2 n(p2)) and the prestress's
    p / (2 sqrt(3)) against (3/2) k_n (asked its ratio at p2), their sum under 2e-3 here."""
    lats = [api.lattice(rows=10, width=3, pressure=p, contact_law=law, **params) for p in (p1, p2)]
    kn = np.concatenate([lat.contacts.stiffness_normal for lat in lats])
    f = np.concatenate([lat.contacts.force_normal for lat in lats])
    wall = np.concatenate([lat.contacts.j < 0 for lat in lats])
    for w in (False, True):  # a pure power law within each contact kind
        x, y = np.log(f[wall == w]), np.log(kn[wall == w])
        slope = np.diff(y[[0, -1]]) / np.diff(x[[0, -1]])
        assert slope[0] == pytest.approx(2 * alpha, abs=1e-9)
    c1, c2 = (_row_speed(lat) for lat in lats)
    measured = math.log(c2 / c1) / math.log(p2 / p1)
    n2 = lats[1].contacts.overlap.max()
    prestress = p2 / (2 * math.sqrt(3)) / (1.5 * lats[1].contacts.stiffness_normal.min())
    tol = 2 * n2 + prestress
    assert tol < 2e-3
    assert measured == pytest.approx(alpha, abs=tol), (measured, tol)
    # and the leading-order row-chain speed of granwave.theory for this law
    from granwave import theory

    assert c2 == pytest.approx(theory.law_lattice_speed(p2, dict(contact_law=law, **params)), rel=2 * tol)


def test_lattice_front_speed_through_the_pipeline_scales_as_p_to_one_quarter():
    """The cone lattice (width 3, 10 and 29 rows) through linearize, propagate (modal) and heights:
    c_tof at p and 10 p. A pure power law makes the lattices at two pressures the same up to time
    scaling, so c_tof's exponent is 1/4 to the spacing's correction (asked 1e-3; measured ~1e-5),
    against Hertz's 1/6."""
    from granwave import theory

    out = {}
    for law in ("cone", "hertz"):
        for p in (1e-8, 1e-7):
            c = theory.law_lattice_speed(p, dict(contact_law=law))
            signals = []
            for rows in (10, 29):
                lat = api.lattice(rows=rows, width=3, pressure=p, contact_law=law)
                modes = api.eigensolve(api.linearize(lat))
                signals.append(api.propagate(modes, t_max=3.0 * lat.height / c, samples=3000))
            out[law, p] = api.heights(signals)["c_tof"]
    for law, alpha in (("cone", 0.25), ("hertz", 1 / 6)):
        assert math.log(out[law, 1e-7] / out[law, 1e-8]) / math.log(10) == pytest.approx(alpha, abs=1e-3)


# ---------------------------------------------------------------- DEM-prepared packings
@pytest.fixture(scope="module", params=["cone", "cone_hertz"])
def packing(request):
    from granwave.dem.protocol import prepare_packing

    # crossover: n* so that the contacts at p = 1e-4 sit on both sides (F* ~ the mean force)
    params = dict(cone_slope=0.1) if request.param == "cone" else dict(crossover_overlap=4e-3)
    return prepare_packing(PrepareParams(dim=2, grains=30, pressure=1e-4, friction=0.5, seed=3,
                                         contact_law=request.param, **params))


def test_prepared_packing_linearizes_as_the_dem_forces(packing):
    """Stored k_n is the law's at the stored overlaps; linearize(prestress=True) = -Jacobian of the
    frozen-history forces (central differences, eps = 1e-9 d, small beside the crossover's n*: a
    difference straddling n* sees the stiffness's kink only over eps) to 1e-6 relative."""
    from granwave.dem.forces import frozen_history_forces
    from granwave.linear.check import finite_difference_stiffness

    p = packing
    c = p.contacts
    values = CO.values_of_attrs(p.attrs)
    law = CM.model_of("normal", values)
    wall = c.j < 0
    r12 = np.where(wall, p.radius[c.i], p.radius[c.i] * p.radius[np.maximum(c.j, 0)] /
                   (p.radius[c.i] + p.radius[np.maximum(c.j, 0)]))
    e12 = np.where(wall, C.effective_young(True), C.effective_young(False))
    expect = [CM.law_stiffness(law, n, math.sqrt(r), e) for n, r, e in zip(c.overlap, r12, e12)]
    np.testing.assert_allclose(c.stiffness_normal, expect, rtol=1e-13)
    if p.attrs["contact_law"] == "cone_hertz":
        n_star = p.attrs["crossover_overlap"]
        assert (c.overlap < n_star).sum() >= 5 and (c.overlap > n_star).sum() >= 5
    s = linearize(p, prestress=True)
    fd = finite_difference_stiffness(s, lambda u, t: frozen_history_forces(p, u, t), p.n_grains, eps=1e-9)
    assert np.abs(s.stiffness.toarray() - fd).max() / np.abs(fd).max() < 1e-6


def test_dem_pulse_equals_linear_signal(packing):
    """EPS = 1e-4, zeta = 0: the DEM signal of the packing = the time-domain signal of
    linearize(prestress=True) within 1 % of its peak (as tests/test_harmonic.py asks), no contact
    opening, forming or sliding; the pulse ran the packing's law (its attributes)."""
    from granwave.dem import pulse as P
    from granwave.linear.propagate import time_domain_signal

    p = packing
    run = dict(ic="A", amplitude=1e-4, t_max=150.0, samples=301, dt_safety=0.0025)
    sig = P.propagate_dem(p, **run)
    ref = time_domain_signal(linearize(p, prestress=True, check=False), ic="A", t_max=150.0, samples=301,
                             safety=0.005)
    peak = np.abs(ref.force).max()
    assert peak > 0 and np.argmax(np.abs(ref.force)) > 30
    assert np.abs(sig.force - ref.force).max() / peak < 1e-2
    a = sig.attrs
    assert a["n_opened"] == a["n_formed"] == a["n_sliding"] == 0
    assert a["contact_law"].startswith(p.attrs["contact_law"])


# ---------------------------------------------------------------- CLI and files
def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_cli_options_files_and_no_lammps_equivalent(tmp_path):
    out = tmp_path / "lat.h5"
    r = invoke("lattice", "--rows", 4, "--width", 3, "--pressure", 1e-6, "--contact-law", "cone_hertz",
               "--crossover-overlap", 2e-4, "-o", out, "--quiet")
    assert r.exit_code == 0, r.output
    from granwave.io import files

    lat = files.read_packing(out)
    assert lat.attrs["contact_law"] == "cone_hertz" and lat.attrs["crossover_overlap"] == 2e-4
    r = invoke("lattice", "--rows", 4, "--width", 3, "--pressure", 1e-6, "--contact-law", "cone",
               "--cone-slope", 0, "-o", tmp_path / "bad.h5")
    assert r.exit_code == 2 and "cone_slope must be > 0" in r.output and not (tmp_path / "bad.h5").exists()
    r = invoke("export", "lammps", out, "-o", tmp_path / "lmp", "--quiet")
    assert r.exit_code == 2 and "no LAMMPS equivalent" in r.output and "cone_hertz" in r.output
    assert CO.SUBMODELS["cone_hertz"]["lammps"] in r.output and "Traceback" not in r.output
    assert not (tmp_path / "lmp").exists()
