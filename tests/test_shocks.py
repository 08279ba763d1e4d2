"""From sound to shocks: the DEM pulse's kick size, drive and pulse field against exact results.

References (docs/method.md §12, "Solitary waves of the Hertzian chain"): the long-wave solitary
wave of the Hertzian chain (Nesterenko's speed against the crest force, its width), the
harmonic chain's amplitude-independent speed, the shock's jump conditions for the piston, and
energy conservation without damping. Every run goes through the production DEM pulse
(granwave.dem.pulse.propagate_dem) on chains made by granwave.systems.chain (run as a 2D column);
the front speed is the pulse field's own pick (granwave.analysis.shocks). Measured numbers are in
docs/shocks.md.
"""

import math

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from scipy import optimize

from granwave import contact, theory
from granwave.analysis.shocks import front_picks
from granwave.cli import main
from granwave.dem import pulse as P
from granwave.errors import InputError
from granwave.geometry import grain_mass
from granwave.systems import chain, chain_column

N_BALLS = 100
#: The chain's speed against its exact discrete solitary wave of the same crest force
#: (theory.hertz_chain_solitary_speed): the issue's 1 %. Measured (docs/shocks.md): uncompressed
#: +0.002 %, precompressed -0.63 % (F_m/F_0 = 1.6: the wave still forming), +0.07 %, +0.10 %.
SPEED_TOL = 0.01
#: The uncompressed chain's speed: measured +2e-5 against the exact wave; held at 1e-3.
UNCOMPRESSED_SPEED_TOL = 1e-3
#: The width at half maximum of the balls' velocity against the exact wave's: measured -0.1 %.
WIDTH_TOL = 0.01
ENERGY_TOL = 1e-3

R12, E12 = contact.effective_radius(2.0, 2.0), contact.effective_young(False)
KAPPA = contact.normal_force(1.0, R12, E12)  # F = kappa delta^(3/2) between two unit balls
MASS = float(grain_mass(np.array([0.5]))[0])


def hertz_chain(pressure):
    return chain(n_balls=N_BALLS, pressure=pressure, stiffness_model="hertz")


def interior(values):
    """The middle 60 % of a per-bin array (the fit range of the front speed)."""
    n = len(values)
    return values[int(0.2 * n):int(0.8 * n)]


def run(packing, t_max, samples=4001, **kick):
    return P.propagate_dem(packing, t_max=t_max, samples=samples, baseline=False, **kick)


def crest_and_speed(sig, pressure, exact=True):
    """(F_m, the speed of the exact discrete wave, or of the long-wave one, of that crest force)."""
    f_m = float(np.median(interior(sig.pulse["force_max"])))
    spacing = 1.0 - (pressure / KAPPA) ** (2.0 / 3.0)
    speed = theory.hertz_chain_solitary_speed if exact else theory.hertz_solitary_speed
    return f_m, speed(f_m, pressure, kappa=KAPPA, mass=MASS, spacing=spacing)


def fwhm(x, y):
    """Full width at half maximum of a single-peaked sampled profile (linear between samples)."""
    i = int(np.argmax(y))
    half = 0.5 * y[i]
    lo = i - np.flatnonzero(y[i::-1] < half)[0]
    hi = i + np.flatnonzero(y[i:] < half)[0]
    left = x[lo] + (half - y[lo]) * (x[lo + 1] - x[lo]) / (y[lo + 1] - y[lo])
    right = x[hi - 1] + (half - y[hi - 1]) * (x[hi] - x[hi - 1]) / (y[hi] - y[hi - 1])
    return right - left


# ------------------------------------------------------------------- solitary waves
@pytest.fixture(scope="module")
def uncompressed():
    """Hertz chain at a vanishing precompression (F_0 / F_m ~ 1e-5), kicked at two sizes."""
    p = hertz_chain(1e-9)
    return p, {v: run(p, t_max=1.3 * N_BALLS / 0.17 * (1e-3 / v) ** 0.2, velocity=v) for v in (1e-3, 1e-2)}


def test_uncompressed_solitary_wave_speed_against_the_exact_discrete_wave(uncompressed):
    p, sigs = uncompressed
    for v, sig in sigs.items():
        f_m, v_exact = crest_and_speed(sig, 1e-9)
        assert f_m > 1e4 * 1e-9  # strongly nonlinear: F_0 negligible
        assert sig.attrs["front_speed"] == pytest.approx(v_exact, rel=UNCOMPRESSED_SPEED_TOL)
        # Nesterenko's long-wave closed form is the discrete wave's limit of long waves: for a wave
        # five grains long it is slow by the discreteness (the 1.2 % once read as the measurement's)
        _, v_long = crest_and_speed(sig, 1e-9, exact=False)
        assert 0.01 < v_exact / v_long - 1 < 0.015
        assert abs(sig.attrs["energy_drift"]) < ENERGY_TOL
        assert sig.attrs["drive"] == "impulse" and sig.attrs["kick_velocity"] == pytest.approx(v, rel=1e-12)


def test_uncompressed_speed_scales_as_the_crest_force_to_the_sixth(uncompressed):
    """Without precompression the Hertz chain has no force scale: V ∝ F_m^(1/6) holds for the
    discrete chain exactly, not only in the long-wave limit."""
    _, sigs = uncompressed
    (f1, s1), (f2, s2) = [(float(np.median(interior(s.pulse["force_max"]))), s.attrs["front_speed"])
                          for s in sigs.values()]
    assert s2 / s1 == pytest.approx((f2 / f1) ** (1.0 / 6.0), rel=2e-3)


def test_uncompressed_solitary_wave_width(uncompressed):
    _, sigs = uncompressed
    wave = theory.hertz_chain_solitary_wave(1.0, 0.0, kappa=KAPPA, mass=MASS, spacing=1.0)
    exact = fwhm(wave["xi"], wave["velocity"])  # scale-free: one width at every amplitude
    # the long-wave wave's support 5 pi a / sqrt(10) ~ 5 d; the discrete wave is narrower
    assert theory.HERTZ_SOLITARY_SUPPORT == pytest.approx(5.0, rel=0.01)
    assert 0.8 < exact / theory.HERTZ_SOLITARY_FWHM < 0.95
    for sig in sigs.values():
        assert sig.attrs["front_width"] == pytest.approx(exact, rel=WIDTH_TOL)


def test_the_exact_discrete_wave_solves_the_chain():
    """The travelling wave of theory.hertz_chain_solitary_wave satisfies the chain's equation of
    motion m (V/a)^2 y'' = F(y(xi+1)) - 2 F(y(xi)) + F(y(xi-1)) on its grid (a grain is a whole number of
    points), and tends to the long-wave closed form as F_m -> F_0."""
    c0 = math.sqrt(1.5 * KAPPA * (1e-5 / KAPPA) ** (1 / 3) / MASS)
    for f0, speed in ((0.0, 0.3), (1e-5, 1.1 * c0)):
        w = theory.hertz_chain_solitary_wave(speed, f0, kappa=KAPPA, mass=MASS, spacing=1.0)
        d0 = (f0 / KAPPA) ** (2 / 3)
        y, n = w["y"], w["y"].size
        q = 2 * math.pi * np.fft.rfftfreq(n, d=w["xi"][1] - w["xi"][0])
        lhs = MASS * speed**2 * np.fft.irfft(-q**2 * np.fft.rfft(y), n)
        f = KAPPA * np.maximum(d0 + y, 0.0) ** 1.5
        per = round(1.0 / (w["xi"][1] - w["xi"][0]))
        rhs = np.roll(f, -per) - 2 * f + np.roll(f, per)
        assert np.max(np.abs(lhs - rhs)) < 1e-8 * np.max(np.abs(rhs))
    f0 = 1e-5
    kw = dict(kappa=KAPPA, mass=MASS, spacing=1.0)
    gap = [theory.hertz_chain_solitary_speed(r * f0, f0, **kw) / theory.hertz_solitary_speed(r * f0, f0, **kw) - 1
           for r in (1.6, 6.0)]
    assert 0 < gap[0] < 1e-3 and gap[0] < 0.2 * gap[1]  # measured 2e-4 and 2.6e-3


@pytest.mark.parametrize("velocity, ratio_range", [(3e-4, (1.3, 2.0)), (1e-3, (4.0, 8.0)), (1e-2, (60.0, 200.0))])
def test_precompressed_solitary_wave_speed_against_the_exact_discrete_wave(velocity, ratio_range):
    """F_m / F_0 from near the linear limit (1.6) to strongly nonlinear (~100)."""
    pressure = 1e-5
    p = hertz_chain(pressure)
    c0 = math.sqrt(1.5 * KAPPA * (pressure / KAPPA) ** (1 / 3) / MASS)  # sound speed a sqrt(k_0/m)
    sig = run(p, t_max=1.2 * N_BALLS / c0, velocity=velocity)
    f_m, v_theory = crest_and_speed(sig, pressure)
    assert ratio_range[0] < f_m / pressure < ratio_range[1]
    assert sig.attrs["front_speed"] == pytest.approx(v_theory, rel=SPEED_TOL)
    assert abs(sig.attrs["energy_drift"]) < ENERGY_TOL


def test_closed_form_limits():
    """The closed form's two ends: c_0 as F_m -> F_0 and sqrt(4/5) c xi_m^(1/4) without F_0."""
    f0 = 1e-5
    d0 = (f0 / KAPPA) ** (2 / 3)
    c0 = math.sqrt(1.5 * KAPPA * d0**0.5 / MASS)
    assert theory.hertz_solitary_speed(f0 * (1 + 1e-4), f0, kappa=KAPPA, mass=MASS, spacing=1.0) == \
        pytest.approx(c0, rel=1e-4)
    fm = 1e-3
    assert theory.hertz_solitary_speed(fm, 0.0, kappa=KAPPA, mass=MASS, spacing=1.0) == \
        pytest.approx(math.sqrt(0.8 * KAPPA / MASS) * (fm / KAPPA) ** (1 / 6), rel=1e-12)
    # and the force form of Nesterenko's precompressed formula
    fr = 20.0
    want = c0 / (fr ** (2 / 3) - 1) * math.sqrt(4 / 15 * (3 + 2 * fr ** (5 / 3) - 5 * fr ** (2 / 3)))
    assert theory.hertz_solitary_speed(fr * f0, f0, kappa=KAPPA, mass=MASS, spacing=1.0) == pytest.approx(want, rel=1e-12)


# ------------------------------------------------------------------- harmonic law
def test_harmonic_speed_is_independent_of_amplitude_until_contacts_open():
    p = chain(n_balls=60, pressure=1e-4, stiffness_model="law", contact_law="harmonic")
    c0 = math.sqrt(1.0 / MASS)  # a sqrt(k/m), k = harmonic_stiffness = 1
    runs = {eps: run(p, t_max=1.2 * 60 / c0, samples=2001, amplitude=eps) for eps in (1e-3, 0.3, 30.0)}
    small, large, opening = runs[1e-3], runs[0.3], runs[30.0]
    assert small.attrs["n_opened"] == 0 and large.attrs["n_opened"] == 0
    # equal to round-off: positions carry ~1e-16 x the height (60 d), the small kick moves grains
    # by ~1e-3 x the overlap (1e-4 d): relative errors up to ~1e-7 in the small run's forces
    assert large.attrs["front_speed"] == pytest.approx(small.attrs["front_speed"], rel=1e-6)
    # the signals per unit kick agree to 1e-5 of max|F| (measured: 8e-6 at the arrival's leading edge,
    # not round-off and not yet explained; the speed, what this test is about, agrees to 2e-9)
    np.testing.assert_allclose(large.force, small.force, rtol=0, atol=1e-5 * np.max(np.abs(small.force)))
    assert opening.attrs["n_opened"] > 0
    assert abs(opening.attrs["front_speed"] / small.attrs["front_speed"] - 1) > 1e-3


# ------------------------------------------------------------------- the piston
def _piston(pressure, v_p, damping):
    p = hertz_chain(pressure)
    d0 = (pressure / KAPPA) ** (2 / 3)
    a = 1.0 - d0
    jump = lambda vs: KAPPA * (d0 + a * v_p / vs) ** 1.5 - pressure - MASS * v_p * vs / a  # noqa: E731
    v_s = optimize.brentq(jump, 1e-3, 10.0)
    sig = P.propagate_dem(p, t_max=0.9 * N_BALLS / v_s, samples=4001, baseline=False, drive="piston",
                          velocity=v_p, damping=damping)
    return sig, v_s, a


def test_piston_shock_speed_obeys_the_jump_conditions():
    """A piston at v_p into the precompressed Hertz chain drives a shock whose speed V_s follows
    from mass and momentum across it (Gomez et al. 2012): the strain jump is v_p / V_s and the
    force jump m v_p V_s / a, so F(δ0 + a v_p / V_s) − F0 = m v_p V_s / a. The jump conditions hold
    for a steady shock, which needs dissipation: contact damping 0.1 (measured +0.10 %)."""
    v_p = 3e-3
    sig, v_s, _ = _piston(1e-5, v_p, 0.1)
    assert sig.attrs["drive"] == "piston" and sig.attrs["piston_velocity"] == v_p
    assert sig.attrs["front_pick"] == "crossing"
    assert sig.attrs["front_speed"] == pytest.approx(v_s, rel=SPEED_TOL)
    # the piston's own bin moves at v_p throughout (a constant velocity to round-off)
    assert np.max(np.abs(sig.pulse["velocity"][0, 1:] - v_p)) < 1e-9 * v_p


def test_undamped_piston_front_is_the_leading_solitary_wave():
    """Without dissipation the shock is dispersive: its front is a solitary wave of about twice
    the jump's force (the crest the crossing pick follows), faster than the jump conditions'
    speed (measured +3.2 %), and it travels at the exact discrete wave's speed of its crest force
    (measured -0.05 %)."""
    pressure, v_p = 1e-5, 3e-3
    sig, v_s, a = _piston(pressure, v_p, 0.0)
    f_m, v_exact = crest_and_speed(sig, pressure)
    f_jump = MASS * v_p * v_s / a  # F(behind) − F0
    assert (f_m - pressure) / f_jump > 1.8
    assert sig.attrs["front_speed"] / v_s - 1 > 0.02
    assert sig.attrs["front_speed"] == pytest.approx(v_exact, rel=SPEED_TOL)


# ------------------------------------------------------------------- sizes, steps, files
def test_kick_sizes_are_one_quantity_in_three_units():
    p = chain_column(hertz_chain(1e-5))
    by_eps = P.kick_size(p, amplitude=0.2)
    for key in ("strain", "velocity"):
        other = P.kick_size(p, **{key: by_eps[key]})
        assert other["amplitude"] == pytest.approx(0.2, rel=1e-12)
        assert other["scale"] == pytest.approx(by_eps["scale"], rel=1e-12)
    assert by_eps["scale"] == P.amplitude_scale(p, "A", 0.2)  # EPS: today's scale, bit for bit
    with pytest.raises(InputError, match="one kick size"):
        P.kick_size(p, amplitude=0.1, velocity=1e-3)
    with pytest.raises(InputError, match="displacement"):
        P.kick_size(p, ic="B", velocity=1e-3)


def test_time_step_follows_the_kick():
    """A strong kick on an almost unloaded chain collides on a stiffer contact than any stored:
    the step shrinks with the kick velocity as the Hertz contact time, v^(-1/5)."""
    p = chain_column(hertz_chain(1e-9))
    steps = []
    for v in (1e-3, 1e-1):
        size = P.kick_size(p, velocity=v)
        _, k = P.peak_overlap(p, ic="A", velocity=size["velocity"], displacement=0.0, drive="impulse")
        steps.append(P.default_time_step(p, 0.01, k))
    assert steps[1] / steps[0] == pytest.approx(100.0 ** -0.2, rel=1e-6)
    # a small kick keeps the stored stiffness's step (the default output unchanged)
    q = chain_column(hertz_chain(1e-4))
    size = P.kick_size(q)
    _, k = P.peak_overlap(q, ic="A", velocity=size["velocity"], displacement=0.0, drive="impulse")
    assert P.default_time_step(q, 0.01, k) == P.default_time_step(q, 0.01)


def test_record_length_follows_the_kick():
    """Without --t-max the record is RECORD_CROSSINGS crossings at the front speed bound of the closed
    forms: the measured front lies within 10 % below the bound (the bound is an upper estimate) and
    crosses the column early in the record, and a strong kick's shorter record and shorter step
    (both ∝ v^(-1/5) on an unloaded chain) leave the number of steps unchanged."""
    p = chain(n_balls=40, pressure=1e-9, stiffness_model="hertz")
    sigs = [P.propagate_dem(p, velocity=v, baseline=False) for v in (1e-3, 1e-1)]
    for sig in sigs:
        a = sig.attrs
        assert a["t_max_rule"].startswith(f"{P.RECORD_CROSSINGS:g} crossings")
        assert a["t_max"] == pytest.approx(P.RECORD_CROSSINGS * a["height"] / a["front_speed_bound"], rel=1e-12)
        assert 0.9 < a["front_speed"] / a["front_speed_bound"] < 1.0
        assert np.all(np.isfinite(sig.pulse["arrival"])) and np.max(sig.pulse["arrival"]) < 0.5 * a["t_max"]
    assert sigs[0].attrs["t_max"] / sigs[1].attrs["t_max"] == pytest.approx(100.0**0.2, rel=1e-3)
    assert sigs[0].attrs["n_steps"] == sigs[1].attrs["n_steps"]


def test_front_picks_on_a_field_of_known_speed():
    t = np.linspace(0.0, 100.0, 2001)
    z = np.arange(40) + 0.5
    speed, width = 0.7, 3.0
    s = (z[:, None] - speed * t[None, :]) / width
    field = np.where(np.abs(s) < 0.5 * math.pi, np.cos(s) ** 4, 0.0)
    picks = front_picks(t, z, field, column=40.0)
    assert picks["speed"] == pytest.approx(speed, rel=1e-4)
    assert picks["width"] == pytest.approx(2 * math.acos(2 ** -0.25) * width, rel=1e-3)
    step = 0.5 * (1 + np.tanh(-s))
    assert front_picks(t, z, step, pick="crossing", column=40.0)["speed"] == pytest.approx(speed, rel=1e-6)


# ------------------------------------------------------------------- contacts of the incoming front
def test_incoming_counts_are_read_before_the_front_reaches_the_far_wall():
    """The counts of the last sample before t0 + column / speed; the whole record's when the front
    does not reach the wall within it; NaN without a fitted front."""
    times = np.arange(11) * 10.0
    contacts = np.cumsum(np.ones((11, 3), np.int64), axis=0) * np.array([1, 10, 100])
    got = P.incoming_counts(times, contacts, t0=5.0, speed=0.5, column=20.0)  # reaches it at t = 45
    assert got["front_far_wall_time"] == 45.0
    assert (got["n_opened_incoming"], got["n_formed_incoming"], got["n_sliding_new_incoming"]) == (5, 50, 500)
    assert P.incoming_counts(times, contacts, t0=0.0, speed=0.5, column=40.0)["n_opened_incoming"] == 9  # t = 80
    assert P.incoming_counts(times, contacts, t0=0.0, speed=0.1, column=40.0)["n_opened_incoming"] == 11
    none = P.incoming_counts(times, contacts, t0=math.nan, speed=math.nan, column=40.0)
    assert all(math.isnan(v) for v in none.values())


def test_incoming_counts_are_those_of_the_push_stopped_there():
    """A strong push (ε = 30 δ0) into a frictional lattice: the counts of the incoming front are
    the counts of the same push stopped at that sample (the same steps, so the same state), and
    the reflection adds to them (measured: opened 6 of 1080 contacts before it, 93 over the
    record; newly sliding 708 and 915)."""
    from granwave.systems import triangular_lattice

    p = triangular_lattice(rows=60, width=6, pressure=1e-4, friction=0.5)
    delta0 = float(np.mean(p.contacts.overlap[p.contacts.j >= 0]))
    kw = dict(drive="piston", strain=30.0 * delta0, baseline=False, dt=0.1)
    full = P.propagate_dem(p, t_max=600.0, samples=301, **kw)
    a = full.attrs
    k = int(np.searchsorted(full.time, a["front_far_wall_time"], side="right")) - 1
    assert 0 < k < len(full.time) - 1
    stopped = P.propagate_dem(p, t_max=float(full.time[k]), samples=k + 1, **kw).attrs
    assert stopped["n_steps"] == a["n_steps"] * k // (len(full.time) - 1)
    for name in ("opened", "formed", "sliding_new"):
        assert a[f"n_{name}_incoming"] == stopped[f"n_{name}"], name
    assert 0 < a["n_opened_incoming"] < a["n_opened"] and 0 < a["n_sliding_new_incoming"] < a["n_sliding_new"]


def test_cli_piston_and_bad_input(tmp_path):
    runner = CliRunner()
    c = tmp_path / "c.h5"
    r = runner.invoke(main, ["chain", "--balls", "30", "--pressure", "1e-5", "--hertz", "-q", "-o", str(c)])
    assert r.exit_code == 0, r.output
    out = tmp_path / "s.h5"
    r = runner.invoke(main, ["propagate", str(c), "--method", "dem", "--drive", "piston", "--velocity", "1e-3",
                             "--t-max", "150", "--samples", "301", "-q", "-o", str(out)])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert f.attrs["drive"] == "piston" and f.attrs["piston_velocity"] == 1e-3
        assert f["pulse/velocity"].shape == (30, 301) and f.attrs["schema_version"] == "1.4"
        # the contact counts so far at every sample: never falling, the last sample's the run's
        for name, total in (("opened", "n_opened"), ("formed", "n_formed"), ("sliding_new", "n_sliding_new")):
            counts = f[f"pulse/{name}"][()]
            assert counts.shape == (301,) and np.all(np.diff(counts) >= 0) and counts[-1] == f.attrs[total]
    from granwave.io import files

    back = files.read_signal(out)
    assert set(back.pulse) >= {"opened", "formed", "sliding_new"} and back.pulse["opened"].dtype.kind == "i"
    # a pulse file of signal schema 1.3 (before the counts) still reads, without them
    with h5py.File(out, "r+") as f:
        for name in ("opened", "formed", "sliding_new"):
            del f[f"pulse/{name}"]
        f.attrs["schema_version"] = "1.3"
    older = files.read_signal(out)
    assert "opened" not in older.pulse and np.array_equal(older.pulse["velocity"], back.pulse["velocity"])
    for bad in (["--amplitude", "1e-3", "--velocity", "1e-3"], ["--drive", "piston", "--ic", "B"],
                ["--ic", "B", "--velocity", "1e-3"]):
        target = tmp_path / "bad.h5"
        r = runner.invoke(main, ["propagate", str(c), "--method", "dem", "--t-max", "10", "-q", "-o", str(target),
                                 *bad])
        assert r.exit_code == 2, (bad, r.output)
        assert not target.exists()
    # no --t-max: the dem default (docs/shocks.md); the linear methods still need it
    out = tmp_path / "d.h5"
    r = runner.invoke(main, ["propagate", str(c), "--method", "dem", "--velocity", "1e-2", "--samples", "301",
                             "-q", "-o", str(out)])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert f.attrs["t_max_rule"].startswith(f"{P.RECORD_CROSSINGS:g} crossings")
    lin = tmp_path / "l.h5"
    assert runner.invoke(main, ["linearize", str(c), "-q", "-o", str(lin)]).exit_code == 0
    r = runner.invoke(main, ["propagate", str(lin), "--velocity", "1e-3", "--t-max", "10", "-q",
                             "-o", str(tmp_path / "x.h5")])
    assert r.exit_code == 2 and "dem only" in r.output
    r = runner.invoke(main, ["propagate", str(lin), "--samples", "301", "-q", "-o", str(tmp_path / "x.h5")])
    assert r.exit_code == 2 and "needs --t-max" in r.output and not (tmp_path / "x.h5").exists()
