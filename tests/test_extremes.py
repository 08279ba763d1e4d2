"""Stability at the extremes: every case runs to a sensible result or stops with
a clear, specific error (InputError / ConvergenceError / one-line CLI error) — never a hang,
a NaN or a silently wrong answer. Every run is bounded (small grain counts, small max_steps).

Cases that fail today because of a bug elsewhere are ``xfail(strict=True)`` with the bug
stated, so they flip when it is fixed.
"""

import math
import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from click.testing import CliRunner

from granwave import systems
from granwave.analysis.front import front_features
from granwave.analysis.statics import statics
from granwave.cli import main
from granwave.dem.params import PrepareParams
from granwave.dem.protocol import prepare_packing
from granwave.errors import ConvergenceError, InputError
from granwave.linear.assemble import linearize
from granwave.linear.eigen import eigensolve
from granwave.linear.propagate import modal_signal, time_domain_signal
from granwave.model import Contacts, Packing

TOL = 1e-10
#: Lattice speed prefactor of docs/method.md §12 (frictionless, leading order in p).
LATTICE_PREFACTOR = 3 ** (19 / 12) / (2 ** 1.5 * math.sqrt(math.pi))


def small(**kw):
    """A bounded 2D preparation: 40 grains, at most 200 000 steps."""
    base = dict(grains=40, seed=1, max_steps=200_000)
    base.update(kw)
    return prepare_packing(PrepareParams(**base))


def check_linear_pipeline(packing, t_max, samples=4001):
    """linearize -> eigensolve -> modal signal: sane spectrum, finite signal, a front."""
    system = linearize(packing)
    a = system.attrs
    assert a["n_negative_modes"] == 0
    assert a["n_zero_modes"] >= a["expected_zero_modes"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a NegativeModesWarning would fail here
        modes = eigensolve(system)
    assert np.all(modes.omega2 >= 0.0)
    assert modes.attrs["n_zero_modes"] == a["n_zero_modes"]
    t = np.linspace(0.0, t_max, samples)
    force = modal_signal(modes, ic="A", times=t)
    assert np.all(np.isfinite(force))
    return system, modes, t, force, front_features(t, force)


# --------------------------------------------------------------------------- DEM extremes
@pytest.mark.parametrize("pressure", [1e-8, 1e-2])
def test_prepare_soft_and_stiff_packings_through_the_pipeline(pressure):
    pk = small(pressure=pressure)
    assert pk.attrs["converged"] and pk.attrs["max_acceleration"] < TOL
    s = statics(pk, layer=1.0)
    assert 2.0 < s["z_star"] < 6.0
    # the piston is balanced by the top-wall contacts to the convergence tolerance
    assert abs(s["piston_balance"]) < 1e-4
    c_guess = 0.5 * LATTICE_PREFACTOR * pressure ** (1 / 6)
    _, _, _, _, ff = check_linear_pipeline(pk, t_max=6 * pk.height / c_guess)
    # the front arrives after a plausible time: slower than 3x the lattice speed
    assert ff.t_lead10 > pk.height / (3 * LATTICE_PREFACTOR * pressure ** (1 / 6) * 1.16)
    assert ff.amplitude > 0 and ff.width > 0


def _row_stiffness_speed(lattice):
    """Exact long-wavelength speed of the lattice's row chain (docs/method.md §12) from the stored
    k_n and geometry: c = h sqrt((3/2) k_n (1 + eta/3) / m), eta = k_t/k_n (0 if frictionless)."""
    c = lattice.contacts
    pair = c.j >= 0
    kn = c.stiffness_normal[pair][0]
    eta = c.stiffness_tangential[pair][0] / kn if lattice.friction > 0 else 0.0
    return lattice.attrs["row_spacing"] * math.sqrt(1.5 * kn * (1 + eta / 3) / lattice.mass[0])


@pytest.mark.parametrize("pressure", [1e-8, 1e-2])
@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_lattice_peak_speed_at_extreme_pressures(pressure, friction):
    """Peak speed between 10 and 30 rows equals the exact row-chain speed to 1%."""
    t_peak, heights = [], []
    for rows in (10, 30):
        lat = systems.triangular_lattice(rows=rows, width=4, pressure=pressure, friction=friction)
        c = _row_stiffness_speed(lat)
        *_, ff = check_linear_pipeline(lat, t_max=2.0 * lat.height / c, samples=6001)
        t_peak.append(ff.t_peak)
        heights.append(lat.height)
    c_peak = (heights[1] - heights[0]) / (t_peak[1] - t_peak[0])
    assert c_peak == pytest.approx(c, rel=0.01)
    if pressure == 1e-8:  # leading order of docs/method.md §12 holds at low pressure
        theory = LATTICE_PREFACTOR * pressure ** (1 / 6) * (math.sqrt(4 / 3) if friction else 1.0)
        assert c == pytest.approx(theory, rel=1e-3)


@pytest.mark.parametrize("pressure", [1e-8, 1e-2])
def test_chain_peak_speed_at_extreme_pressures(pressure):
    t_peak, heights = [], []
    for n in (20, 60):
        ch = systems.chain(n_balls=n, pressure=pressure)
        K = ch.contacts.stiffness_normal[0]
        spacing = 1.0 - pressure / K
        c = spacing * math.sqrt(K / ch.mass[0])
        *_, ff = check_linear_pipeline(ch, t_max=2.0 * ch.height / c, samples=6001)
        t_peak.append(ff.t_peak)
        heights.append(ch.height)
    assert (heights[1] - heights[0]) / (t_peak[1] - t_peak[0]) == pytest.approx(c, rel=0.01)


@pytest.mark.parametrize("friction", [0.0, 10.0])
def test_friction_extremes(friction):
    pk = small(friction=friction)
    assert pk.attrs["converged"]
    system, *_ = check_linear_pipeline(pk, t_max=6 * pk.height / (0.5 * LATTICE_PREFACTOR * 1e-4 ** (1 / 6)))
    assert system.attrs["n_rotations"] == (0 if friction == 0 else 1)
    if friction == 0:
        assert np.all(pk.contacts.stiffness_tangential == 0.0)
        assert np.all(pk.contacts.force_tangential == 0.0)
    else:  # mu = 10: no contact is anywhere near the Coulomb cone
        c = pk.contacts
        assert np.all(np.linalg.norm(c.force_tangential, axis=1) <= friction * c.force_normal)


@pytest.mark.parametrize("poisson", [0.0, 0.49])
def test_poisson_extremes_set_the_stiffness_ratio(poisson):
    pk = small(poisson=poisson)
    c = pk.contacts
    eta = 2 * (1 - poisson) / (2 - poisson)
    np.testing.assert_allclose(c.stiffness_tangential / c.stiffness_normal, eta, rtol=1e-12)
    check_linear_pipeline(pk, t_max=6 * pk.height / (0.5 * LATTICE_PREFACTOR * 1e-4 ** (1 / 6)))


def test_poisson_half_is_refused():
    with pytest.raises(InputError, match="poisson"):
        PrepareParams(poisson=0.5)


def test_zero_contact_damping_converges_with_background_damping():
    pk = small(damping=0.0)
    assert pk.attrs["converged"] and pk.attrs["max_acceleration"] < TOL


def test_no_damping_at_all_fails_cleanly():
    with pytest.raises(ConvergenceError, match=r"20000 steps did not converge"):
        small(damping=0.0, background_damping=0.0, max_steps=20_000)


def test_critical_contact_damping_converges():
    """Formerly never converged (the step ignored damping and rotations)."""
    pk = small(damping=1.0, max_steps=100_000)
    assert pk.attrs["converged"] and pk.attrs["max_acceleration"] < TOL


def test_critical_contact_damping_frictionless_converges():
    pk = small(damping=1.0, friction=0.0, max_steps=100_000)
    assert pk.attrs["converged"] and pk.attrs["max_acceleration"] < TOL


def test_time_step_safety_inside_the_allowed_range_converges():
    """dt = safety/0.1 of the estimated stability limit (kernels.stable_dt): 0.1 would be at the
    limit and is refused with a clear message; the largest accepted value converges at zeta 1."""
    with pytest.raises(InputError, match="stability limit"):
        PrepareParams(safety=0.1)
    pk = small(safety=0.06, damping=1.0, max_steps=100_000)
    assert pk.attrs["converged"] and pk.attrs["max_acceleration"] < TOL


def test_stalled_run_says_so():
    """Without any damping max |a| never falls: the error says it stalled and suggests damping,
    not more steps."""
    with pytest.raises(ConvergenceError, match="stalled") as err:
        small(damping=0.0, background_damping=0.0, max_steps=20_000)
    assert "raise --max-steps" not in str(err.value) and "damping" in str(err.value)


# --------------------------------------------------------------------------- tall containers
def test_tall_lattice_200_diameters_time_domain():
    """231 rows (height 200 d) by velocity Verlet (no dense solve: on this loaded 2-core machine
    the 1386-dof dense check alone took 25 s with threaded OpenBLAS); the 31-row lattice is
    checked against its modal sum, and the peak speed between 31 and 231 rows is the
    long-wavelength speed."""
    lat = systems.triangular_lattice(rows=231, width=3, pressure=1e-4, friction=0.0)
    assert 199.0 < lat.height < 201.0
    c = _row_stiffness_speed(lat)
    system = linearize(lat, check=False)
    sig = time_domain_signal(system, ic="A", t_max=1.3 * lat.height / c, samples=3001)
    assert np.all(np.isfinite(sig.force))
    assert sig.attrs["modified_energy_max_rel_deviation"] < 1e-8
    ff = front_features(sig.time, sig.force)
    short = systems.triangular_lattice(rows=31, width=3, pressure=1e-4, friction=0.0)
    s_sys, _, t, force, ff_short = check_linear_pipeline(short, t_max=2.0 * short.height / c, samples=3001)
    s_sig = time_domain_signal(s_sys, ic="A", t_max=t[-1], samples=len(t))
    window = t <= ff_short.t_zero
    assert np.max(np.abs(s_sig.force - force)[window]) < 2e-3 * np.max(np.abs(force))
    assert front_features(t, s_sig.force).t_peak == pytest.approx(ff_short.t_peak, rel=1e-4)
    c_peak = (lat.height - short.height) / (ff.t_peak - ff_short.t_peak)
    assert c_peak == pytest.approx(c, rel=3e-3)


def test_tall_chain_200_balls():
    ch = systems.chain(n_balls=200, pressure=1e-4)
    K = ch.contacts.stiffness_normal[0]
    c = (1 - 1e-4 / K) * math.sqrt(K / ch.mass[0])
    *_, ff = check_linear_pipeline(ch, t_max=1.3 * ch.height / c, samples=4001)
    # docs/method.md §12: arrival at t0 = (N+1) l / c within the front width
    assert abs(ff.t_peak - 201 * (1 - 1e-4 / K) / c) < ff.width


# --------------------------------------------------------------------------- tiny systems
@pytest.mark.parametrize("grains", [1, 2])
def test_one_or_two_grains_refused_with_a_clear_message(grains):
    with pytest.raises(InputError, match="periodic length"):
        prepare_packing(PrepareParams(grains=grains, max_steps=1000))


def test_five_grains_refused_with_a_clear_message():
    # formerly a raw numpy ValueError from protocol.granular_gas (the row count rounded down)
    with pytest.raises(InputError, match="periodic length"):
        prepare_packing(PrepareParams(grains=5, max_steps=1000))


@pytest.mark.parametrize("kw", [dict(grains=96, aspect=0.67, seed=1), dict(dim=3, grains=60, seed=2)])
def test_ordinary_packing_is_prepared_for_every_seed(kw):
    """Formerly a raw numpy ValueError in protocol.granular_gas: int(height // dmax) rounded the
    needed row count down ((9 dmax) // dmax == 8), leaving fewer cells than grains."""
    with pytest.raises(ConvergenceError):  # gets past the gas and into the bounded run
        prepare_packing(PrepareParams(max_steps=1, **kw))


@pytest.mark.parametrize("aspect", [1e-300, 1e-3])
def test_container_wider_than_one_layer_is_refused(aspect):
    """12 grains cover ~12 d in one layer; aspect 1e-3 asks for a ~110 d wide wall (and 1e-300
    for more gas cells than an index can count, formerly an OverflowError): one clear refusal."""
    with pytest.raises(InputError, match="not a packing"):
        prepare_packing(PrepareParams(grains=12, aspect=aspect))


def test_single_row_packing():
    """6 grains, aspect 0.1: one layer; the piston rests on the largest grain."""
    pk = prepare_packing(PrepareParams(grains=6, aspect=0.1, max_steps=100_000))
    assert pk.attrs["converged"] and pk.height < 1.3
    with pytest.raises(InputError, match="leaves no bulk"):
        statics(pk)  # default layer 3 d: clear refusal
    system = linearize(pk)
    assert system.attrs["n_negative_modes"] == 0
    modes = eigensolve(system)
    t = np.linspace(0, 200.0, 2001)
    assert np.all(np.isfinite(modal_signal(modes, ic="A", times=t)))


def test_lattice_rows_one_refused_rows_two_runs():
    with pytest.raises(InputError, match="rows"):
        systems.triangular_lattice(rows=1, width=3, pressure=1e-4)
    lat = systems.triangular_lattice(rows=2, width=3, pressure=1e-4)
    *_, ff = check_linear_pipeline(lat, t_max=100.0)
    assert ff.t_peak > 0


def test_chain_of_one_ball_is_exact():
    """One ball, two wall springs K: omega^2 = 2K/m, IC A v0 = K/m, F = K^2/(m omega) sin(omega t)."""
    ch = systems.chain(n_balls=1, pressure=1e-4)
    K, m = ch.contacts.stiffness_normal[0], ch.mass[0]
    system, modes, t, force, _ = check_linear_pipeline(ch, t_max=50.0)
    omega = math.sqrt(2 * K / m)
    np.testing.assert_allclose(force, K * K / (m * omega) * np.sin(omega * t), atol=1e-12 * K * K / (m * omega))


# --------------------------------------------------------------------------- hand-built states
def column_with_side_grain(friction: float, side_force: float = 1e-12, side_stiffness: float | None = None):
    """Two unit grains stacked between the walls (0 on the bottom wall, 1 under the top wall)
    and grain 2 touching grain 0 sideways only: exactly one contact (force ``side_force``,
    a DEM-like residual), stiffness ``side_stiffness`` (default that of the other contacts)."""
    R, p, width = 0.5, 1e-4, 10.0
    kn, kt, dn = 0.05, 0.05, 1e-3
    y0 = R - dn
    y1 = y0 + 2 * R - dn
    H = y1 + R - dn
    position = np.array([[5.0, y0], [5.0, y1], [5.0 + 2 * R - dn, y0]])
    ks = kn if side_stiffness is None else side_stiffness
    f = p * width
    contacts = Contacts(
        i=np.array([0, 0, 0, 1]), j=np.array([1, 2, -1, -2]),
        normal=np.array([[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]]),
        overlap=np.full(4, dn), force_normal=np.array([f, side_force, f, f]),
        force_tangential=np.zeros((4, 2)),
        stiffness_normal=np.array([kn, ks, kn, kn]), stiffness_tangential=np.array([kt, ks, kt, kt]))
    mass = np.full(3, math.pi / 6)
    attrs = dict(kind="disordered", dim=2, pressure=p, friction=friction, poisson=0.0, seed=0,
                 converged=True, max_acceleration=0.0)
    return Packing(position=position, radius=np.full(3, R), mass=mass, inertia=mass / 10,
                   box=np.array([width, H]), contacts=contacts, attrs=attrs)


@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_one_contact_grain_rattler_and_zero_modes(friction):
    pk = column_with_side_grain(friction)
    s2 = statics(pk, layer=0.0)  # default rule: < 2 force-carrying contacts = rattler
    assert s2["n_rattlers_bulk"] == 1
    s1 = statics(pk, layer=0.0, min_contacts=1, force_tol=1e-15)  # literal rule keeps it
    assert s1["n_rattlers_bulk"] == 0
    # linearize keeps every grain with a contact of F_n > 0 (docs/linear.md): grain 2 is in D
    system = linearize(pk)
    assert system.attrs["n_rattlers"] == 0
    D = system.stiffness.toarray()
    n_zero_exact = system.n_dof - np.linalg.matrix_rank(D, tol=1e-10 * np.abs(D).max())
    # frictionless: lateral of grain 1, lateral of (0, 2), vertical of 2; frictional: rolling of 2
    # about grain 0 and the geared rolling of 0 and 1 between the walls
    assert n_zero_exact == (3 if friction == 0 else 2)
    assert system.attrs["n_zero_modes"] == n_zero_exact
    assert system.attrs["n_zero_modes"] > system.attrs["expected_zero_modes"]
    assert system.attrs["n_negative_modes"] == 0
    modes = eigensolve(system)
    assert modes.attrs["n_zero_modes"] == n_zero_exact and np.all(modes.omega2 >= 0)
    force = modal_signal(modes, ic="A", times=np.linspace(0, 100, 501))
    assert np.all(np.isfinite(force))


@pytest.mark.parametrize("ratio, zero", [(1e-13, True), (1e-6, False)])
def test_near_singular_floppy_grain(ratio, zero):
    """Grain 2 hangs on one contact of stiffness ratio x k: its mode is counted as zero below
    the threshold 1e-10 omega^2_max and kept (positive) above; never negative."""
    pk = column_with_side_grain(0.0, side_force=1e-4, side_stiffness=0.05 * ratio)
    system = linearize(pk)
    modes = eigensolve(system)
    base = 3  # lateral of grain 1, lateral of (0, 2), vertical of grain 2: exact zero modes
    assert modes.attrs["n_zero_modes"] == base + (1 if zero else 0)
    assert system.attrs["n_zero_modes"] == modes.attrs["n_zero_modes"]
    assert modes.attrs["n_negative_modes"] == 0 and np.all(modes.omega2 >= 0)
    if not zero:
        soft = modes.omega2[base]
        # the floppy mode: grain 2 against grain 0 (+ 1 stacked), omega^2 ~ k (1/m2 + 1/m0)
        assert soft == pytest.approx(0.05 * ratio * (1 / pk.mass[2] + 1 / pk.mass[0]), rel=1e-3)


def test_near_floppy_soft_packing_reports_its_modes():
    """Frictionless 30 grains at p = 1e-8: the spectrum's zero modes are counted consistently
    by linearize and eigensolve, none is negative, and the signal is finite."""
    pk = small(grains=30, pressure=1e-8, friction=0.0, seed=4)
    system = linearize(pk)
    modes = eigensolve(system)
    A = system.stiffness.toarray()
    s = 1 / np.sqrt(system.mass)
    w = np.linalg.eigvalsh(s[:, None] * A * s[None, :])
    n_zero_ref = int(np.sum(np.abs(w) <= 1e-10 * w[-1]))
    assert modes.attrs["n_zero_modes"] == system.attrs["n_zero_modes"] == n_zero_ref
    assert n_zero_ref >= system.attrs["expected_zero_modes"] == 1
    assert modes.attrs["n_negative_modes"] == 0 and np.all(modes.omega2 >= 0)
    assert np.all(np.isfinite(modes.amplitude_A))
    t = np.linspace(0, 3000.0, 1001)
    assert np.all(np.isfinite(modal_signal(modes, ic="A", times=t)))


# --------------------------------------------------------------------------- CLI
def _one_line_error(args, tmp_path):
    out = tmp_path / "p.h5"
    result = CliRunner().invoke(main, ["prepare-packing", "-q", "-o", str(out), *args])
    assert result.exit_code != 0
    lines = [ln for ln in result.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error:"), result.output
    assert "Traceback" not in result.output
    assert not out.exists()
    return lines[0]


def test_cli_too_few_grains(tmp_path):
    assert "periodic length" in _one_line_error(["--grains", "2"], tmp_path)


def test_cli_step_budget(tmp_path):
    assert "did not converge" in _one_line_error(["--grains", "40", "--max-steps", "10"], tmp_path)


def test_cli_five_grains(tmp_path):
    _one_line_error(["--grains", "5"], tmp_path)


def test_creeping_single_row_fails_with_a_specific_hint():
    """8 grains in one row (aspect 0.1) never settle: max |a| reaches ~1e-15 while the row keeps
    sliding at a steady ~2e-7 (Coulomb contacts against the background damping). The error must
    say so instead of suggesting more steps."""
    with pytest.raises(ConvergenceError, match="creeps") as info:
        prepare_packing(PrepareParams(grains=8, aspect=0.1, max_steps=60_000))
    assert "raise --max-steps" not in str(info.value)
