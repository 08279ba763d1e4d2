"""Figures (granwave.figures and `granwave plot`): each one is drawn from small
synthetic inputs and checked to be a PNG of the expected size with a
meaningful number of non-background pixels; the numbers a figure shows
(local exponents, the pulse's energy map, shared scales, labels) are checked
against exact values."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from click.testing import CliRunner  # noqa: E402

from granwave import io as gio  # noqa: E402  (import io before model: import cycle)
from granwave import figures  # noqa: E402
from granwave.errors import InputError  # noqa: E402
from granwave.model import Contacts, Modes, Packing, Signal  # noqa: E402


# ---------------------------------------------------------------- synthetic inputs
def small_packing(nx: int = 6, ny: int = 6, seed: int = 1) -> Packing:
    """Jittered square grid of grains in a periodic-x box with walls; contacts by overlap."""
    rng = np.random.default_rng(seed)
    width, height = float(nx), float(ny)
    xs, ys = np.meshgrid(np.arange(nx) + 0.5, np.arange(ny) + 0.5)
    pos = np.stack([xs.ravel(), ys.ravel()], 1) + rng.uniform(-0.04, 0.04, (nx * ny, 2))
    pos[:, 0] %= width
    radius = np.full(nx * ny, 0.53)
    i_l, j_l, n_l, d_l = [], [], [], []
    for a in range(len(pos)):
        for b in range(a + 1, len(pos)):
            d = pos[b] - pos[a]
            d[0] -= width * np.round(d[0] / width)
            r = np.hypot(*d)
            if r < radius[a] + radius[b]:
                i_l.append(a), j_l.append(b), n_l.append(d / r), d_l.append(radius[a] + radius[b] - r)
        for wall, ny_, dist in ((-1, -1.0, pos[a, 1]), (-2, 1.0, height - pos[a, 1])):
            if dist < radius[a]:
                i_l.append(a), j_l.append(wall), n_l.append([0.0, ny_]), d_l.append(radius[a] - dist)
    overlap = np.array(d_l)
    kn = 2 * np.sqrt(0.5) * 0.5 * np.sqrt(overlap)
    fn = (4 / 3) * np.sqrt(0.5) * 0.5 * overlap ** 1.5
    m = len(overlap)
    contacts = Contacts(np.array(i_l), np.array(j_l), np.array(n_l), overlap, fn,
                        np.zeros((m, 2)), kn, kn.copy())
    mass = np.pi * (2 * radius) ** 3 / 6
    return Packing(pos, radius, mass, mass * (2 * radius) ** 2 / 10, np.array([width, height]),
                   contacts, {"dim": 2, "pressure": 1e-4, "friction": 0.5, "poisson": 0.0,
                              "seed": seed, "converged": True, "max_acceleration": 0.0,
                              "kind": "test"})


def pulse(t, t0, width, amp=1.0):
    return amp * -np.gradient(np.exp(-((t - t0) / width) ** 2), t) * width


def synthetic_signal(height=10.0, c=0.1, seed=0, snapshots=False, n=36, **attrs) -> Signal:
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 3 * height / c, 600)
    f = pulse(t, height / c, 0.1 * height / c * (height / 10) ** (1 / 3), height ** (-2 / 3))
    f = f + 0.05 * np.max(np.abs(f)) * rng.standard_normal(t.size) * (t > height / c)
    sig = Signal(t, f, {"ic": "A", "method": "modal", "height": height, "pressure": 1e-4,
                        "dim": 2, "friction": 0.5, **attrs})
    if snapshots:
        dof_grain = np.repeat(np.arange(n), 3)
        dof_axis = np.tile(np.arange(3), n)
        sig.snapshot_time = np.array([10.0, 20.0, 40.0])
        sig.snapshot_displacement = rng.standard_normal((3, 3 * n))
        sig.dof_grain, sig.dof_axis = dof_grain, dof_axis
    return sig


def check_png(path, size, min_fraction=0.01):
    img = mpimg.imread(path)
    w, h = size
    assert img.shape[:2] == (round(h * figures.DPI), round(w * figures.DPI))
    rgb = img[..., :3]
    background = np.all(rgb > 0.98, axis=-1)
    assert (~background).mean() > min_fraction, "figure is nearly empty"


@pytest.fixture(scope="module")
def packing():
    return small_packing()


# ---------------------------------------------------------------- library
def test_segments_wrap_periodic_contacts(packing):
    segs, owner = figures.contact_segments(packing)
    c = packing.contacts
    assert set(owner) == set(range(len(c)))
    # a contact across the periodic boundary is drawn twice, and no segment is longer than a contact
    lengths = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
    assert lengths.max() < 1.1
    assert len(segs) > len(c)


def test_snapshot_and_modes(tmp_path, packing):
    sig = synthetic_signal(snapshots=True)
    out = figures.displacement_snapshot(sig, tmp_path / "snap.png", packing=packing, index=[0, 2])
    check_png(out[0], (12, 5.5))
    vecs = np.random.default_rng(0).standard_normal((sig.dof_grain.size, 3))
    out = figures.mode_shapes(vecs, sig.dof_grain, sig.dof_axis, packing.position,
                            tmp_path / "modes.png", omega=[0.1, 0.2, 0.3], radius=packing.radius,
                            box=packing.box)
    check_png(out[0], (4.2 * 3 + 0.8, 5.5))
    with pytest.raises(InputError, match="no grain positions"):
        figures.displacement_snapshot(sig, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_signal_figures(tmp_path):
    # drawing is covered by the CLI tests below; here the library-only behaviour
    sigs = [synthetic_signal(seed=s) for s in range(3)]
    with pytest.raises(InputError, match="^b.h5: no 'damping' attribute"):
        figures.damping_series(sigs, tmp_path / "d2.png", labels=["b.h5", "c.h5", "d.h5"])
    with pytest.raises(InputError, match="speed for every signal or for none"):
        figures.signal_comparison(sigs[:2], tmp_path / "c.png", speeds=[0.1, None])
    assert not list(tmp_path.iterdir())


def heights_data(gamma=0.6, alpha=0.35, c=0.1):
    L = np.array([5.0, 8.0, 12.0, 18.0, 25.0, 40.0])
    return {"height": L, "t_lead10": L / (1.05 * c) + 1, "t_peak": L / c + 3, "t_zero": L / c + 6,
            "amplitude": 2 * L ** -gamma, "width": 0.5 * L ** alpha}


def test_front_figures(tmp_path):
    d = heights_data()
    series = {"2D disordered": d, "chain": heights_data(2 / 3, 1 / 3),
              "polydisperse chain": heights_data(0.8, 0.5)}
    check_png(figures.amplitude_width(series, tmp_path / "e.png")[0], (12, 8.5))


def jittered_series(gamma=0.6, alpha=0.35, seed=0):
    """`analyze heights` output for disordered packings: 4 packings at each of 3 nominal heights,
    each packing's L jittered by ±1 % (so that some are nearly equal), A and W with 5 % noise."""
    from granwave.analysis.heights import height_series_from_features

    rng = np.random.default_rng(seed)
    L = np.repeat([8.0, 16.0, 25.0], 4) * (1 + 0.01 * rng.uniform(-1, 1, 12))
    noise = 1 + 0.05 * rng.standard_normal((2, 12))
    feats = [{"t_lead10": h / 0.1, "t_peak": h / 0.09, "t_zero": h / 0.08,
              "amplitude": 2 * h ** -gamma * noise[0, i], "width": 0.5 * h ** alpha * noise[1, i]}
             for i, h in enumerate(L)]
    return json.loads(json.dumps(height_series_from_features(L, feats, edge_heights=(8, 25)),
                                 default=lambda a: np.asarray(a).tolist()))


def test_local_exponents_between_ensemble_means():
    """The exponents figure's points: between ensemble means at distinct nominal heights, with
    the two standard errors propagated (not between single packings at nearly equal L)."""
    from granwave.analysis.ensemble import local_exponents_of_means
    from granwave.report import heights_means

    obj = jittered_series()
    d = heights_means(obj)
    assert d["height"].size == 3 and np.all(d["count"] == 4)
    ph = obj["per_height"]
    np.testing.assert_allclose(d["amplitude_sem"], np.array(ph["amplitude_std"]) / 2)
    loc = local_exponents_of_means(d["height"], d["amplitude"], d["amplitude_sem"])
    L, A, e = d["height"], d["amplitude"], d["amplitude_sem"]
    expect = np.log(A[1:] / A[:-1]) / np.log(L[1:] / L[:-1])
    np.testing.assert_allclose(loc["exponent"], expect, rtol=1e-12)
    np.testing.assert_allclose(loc["exponent_err"],
                               np.hypot(e[1:] / A[1:], e[:-1] / A[:-1]) / np.log(L[1:] / L[:-1]),
                               rtol=1e-12)
    # the true exponent (-0.6) lies within three standard errors of each local value
    assert np.all(np.abs(loc["exponent"] + 0.6) < 3 * loc["exponent_err"])
    # the old way, between single packings at nearly equal heights, swings far more
    s = sorted(obj["samples"], key=lambda r: r["height"])
    single = [np.log(b["amplitude"] / a["amplitude"]) / np.log(b["height"] / a["height"])
              for a, b in zip(s, s[1:]) if b["height"] > a["height"]]
    assert np.max(np.abs(single)) > 5 * np.max(np.abs(loc["exponent"]))
    with pytest.raises(InputError, match="distinct heights"):
        local_exponents_of_means([8.0, 8.0, 25.0], [1.0, 1.1, 0.5])


def test_damping_and_compare_labels():
    from granwave.figures.damping import DEM_F_LABEL, _reference_label

    # the DEM signal divided by the kick's scale s: the linear signal's normalization, E* d̄²
    assert "/s" in DEM_F_LABEL and "E^*" in DEM_F_LABEL
    assert _reference_label(synthetic_signal()) == "linear model (modal), same packing"
    from granwave.figures.signals import with_height

    assert with_height("frictionless2d", synthetic_signal(height=25.04)) == "frictionless2d, L = 25"


def test_snapshots_share_one_scale():
    from granwave.figures.fields import snapshot_panels

    sig = synthetic_signal(snapshots=True)
    sig.snapshot_displacement[1] *= 100.0  # one loud snapshot
    panels, scale = snapshot_panels(sig, [0, 1, 2], 36, 2)
    mags = np.concatenate([np.linalg.norm(u[has], axis=1) for u, has in panels])
    # one scale for all panels: the 95th percentile of |u| over them, not the loudest grain's
    assert scale == pytest.approx(np.quantile(mags[mags > 0], 0.95))
    assert scale < np.max(mags) and len(panels) == 3


# ---------------------------------------------------------------- the pulse's fields
@pytest.fixture(scope="module")
def lattice_pulse():
    from granwave.linear.assemble import linearize
    from granwave.linear.check import reference_lattice
    from granwave.linear.eigen import eigensolve

    lat = reference_lattice(12, 5, pressure=1e-4, friction=0.5)
    system = linearize(lat)
    return lat, system, eigensolve(system, vectors=True)


@pytest.mark.parametrize("ic", ["A", "B"])
def test_row_energy_is_conserved_and_starts_at_the_source(lattice_pulse, ic):
    """Σ_rows E(y, t) Δy = 1 at every time (energy of the nonzero modes), and at t = 0 the
    kick's energy sits in the rows next to the bottom wall (all of it, for A: v(0) = source)."""
    from granwave.analysis.front import front_features
    from granwave.analysis.pulse_field import row_fields
    from granwave.linear.propagate import modal_signal

    lat, system, modes = lattice_pulse
    f = row_fields(system, modes, lat.position, ic=ic, n_times=200)
    np.testing.assert_allclose(f.energy.sum(axis=0) * f.attrs["row_width"], 1.0, atol=1e-12)
    assert f.energy.shape == (int(np.ceil(system.height)), 200)
    if ic == "A":
        kicked = np.unique(lat.contacts.i[lat.contacts.is_bottom])
        rows = np.unique((lat.position[kicked, 1] // 1).astype(int))
        assert f.energy[rows, 0].sum() == pytest.approx(1.0, abs=1e-12)
    # the arrival lines are the detector signal's own front features
    t = np.linspace(0, 3 * f.attrs["t_peak"], 6000)
    ref = front_features(t, modal_signal(modes, ic=ic, times=t))
    assert f.attrs["t_peak"] == pytest.approx(ref.t_peak, rel=1e-3)
    assert f.attrs["t_lead10"] == pytest.approx(ref.t_lead10, rel=1e-3)


def test_low_pass_keeps_the_modes_below_the_front_band(lattice_pulse):
    from granwave.analysis.pulse_field import row_fields

    lat, system, modes = lattice_pulse
    low = row_fields(system, modes, lat.position, n_times=50, cutoff_factor=2.0)
    omega = np.sqrt(np.maximum(modes.omega2, 0))
    nonzero = modes.omega2 > 1e-9 * modes.omega2.max()
    assert low.attrs["omega_cut"] == pytest.approx(2 * np.pi / low.attrs["width"])
    assert low.attrs["modes_below_cut"] == int(np.sum(nonzero & (omega < low.attrs["omega_cut"])))
    assert 0 < low.attrs["modes_below_cut"] < low.attrs["modes_nonzero"]
    # with the cut above every mode the low-pass field is the full row-mean displacement
    full = row_fields(system, modes, lat.position, n_times=50, cutoff_factor=1e9)
    from granwave.analysis.pulse_field import _modal_state

    u, _ = _modal_state(modes, "A", full.time, nonzero)
    vert = system.dof_axis == 1
    row = (lat.position[system.dof_grain[vert], 1] // 1).astype(int)
    expect = np.array([u[:, vert][:, row == r].mean(axis=1) if np.any(row == r)
                       else np.full(full.time.size, np.nan) for r in range(full.row_y.size)])
    np.testing.assert_allclose(full.displacement_low, expect, atol=1e-14)
    with pytest.raises(InputError, match="eigenvectors"):
        row_fields(system, Modes(modes.omega2, modes.amplitude_A, modes.amplitude_B,
                                 modes.coupling, attrs=modes.attrs), lat.position)


def test_select_modes():
    rng = np.random.default_rng(0)
    n = 12
    vecs = np.eye(n)[:, rng.permutation(n)] * 0.5 + 0.1  # columns: one grain dominates each
    vecs[:, 0] = 1.0  # mode 0: spread over every grain
    a = np.r_[np.ones(5), 3.0, np.ones(n - 6)]
    modes = Modes(np.r_[0.0, np.linspace(0.1, 1, n - 1)], a, np.ones(n), np.ones(n), vectors=vecs,
                  attrs={"height": 1.0})
    sel = figures.select_modes(modes, dof_grain=np.arange(n))
    assert sel["lowest nonzero"] == 1 and sel["strongest |a_n b_n|"] == 5
    assert sel["most localized"] != 0


def test_bad_output_name(tmp_path, packing):
    with pytest.raises(InputError, match=".png"):
        figures.contact_roses(packing, tmp_path / "roses.txt")
    with pytest.raises(InputError, match="does not exist"):
        figures.contact_roses(packing, tmp_path / "nowhere" / "roses.png")


def test_caption_for():
    assert figures.caption_for("figures/speeds.png").startswith("Sound speeds")
    assert "p1e-4" in figures.caption_for("network_p1e-4.png")


# ---------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def files(tmp_path_factory, packing):
    """Small input files for every `granwave plot` subcommand."""
    import scipy.sparse as sp

    from granwave.analysis.ensemble import Ensemble, write_ensemble
    from granwave.model import LinearSystem

    d = tmp_path_factory.mktemp("plotin")
    gio.write_packing(d / "packing.h5", packing)
    n = packing.n_grains
    sig = synthetic_signal(snapshots=True, n=n)
    sig.attrs["height"] = float(packing.box[-1])  # drawn on this packing: plot snapshot checks it
    gio.write_signal(d / "signal.h5", sig)
    for k in range(3):
        gio.write_signal(d / f"s{k}.h5", synthetic_signal(seed=k + 1))
        gio.write_signal(d / f"damp{k}.h5", synthetic_signal(seed=k, damping=0.1 * k))
    gio.write_signal(d / "tall.h5", synthetic_signal(height=20.0))
    s = synthetic_signal()
    write_ensemble(d / "ens.h5", Ensemble(s.time, s.force, 0.1 * np.abs(s.force),
                                          {"n_signals": 3, "height_mean": 10.0}))
    ndof = 3 * n
    rng = np.random.default_rng(2)
    omega2 = np.sort(rng.uniform(0.01, 1, ndof))
    vecs = np.linalg.qr(rng.standard_normal((ndof, ndof)))[0]
    gio.write_modes(d / "modes.h5", Modes(omega2, rng.standard_normal(ndof), rng.standard_normal(ndof),
                                          rng.standard_normal(ndof), vectors=vecs,
                                          attrs={"dim": 2, "pressure": 1e-4, "height": 6.0,
                                                 "n_zero_modes": 0}))
    lin = LinearSystem(sp.identity(ndof, format="csr"), np.ones(ndof), sig.dof_grain, sig.dof_axis,
                       np.zeros(ndof), np.zeros(ndof), np.zeros(ndof),
                       {"dim": 2, "pressure": 1e-4, "friction": 0.5, "height": 6.0, "prestress": False})
    gio.write_linear(d / "linear.h5", lin)
    (d / "heights.json").write_text(json.dumps({**jittered_series(), "pressure": 1e-4}))
    # a real small system for the pulse figure: lattice, linear system, modes with vectors
    from granwave.linear.assemble import linearize
    from granwave.linear.check import reference_lattice
    from granwave.linear.eigen import eigensolve
    from granwave.linear.propagate import modal_propagate

    lat = reference_lattice(10, 5, pressure=1e-4, friction=0.5)
    lsys = linearize(lat)
    lmodes = eigensolve(lsys, vectors=True)
    gio.write_packing(d / "lat_packing.h5", lat)
    gio.write_linear(d / "lat_linear.h5", lsys)
    gio.write_modes(d / "lat_modes.h5", lmodes)
    gio.write_signal(d / "lat_signal.h5", modal_propagate(
        lmodes, ic="A", t_max=80.0, samples=400, snapshots=[10.0, 20.0, 30.0, 40.0],
        dof_grain=lsys.dof_grain, dof_axis=lsys.dof_axis))
    (d / "lat.json").write_text(json.dumps({"pressure": 1e-5, "c_tof": 0.2, "c_peak": 0.19}))
    p = [1e-7, 1e-6, 1e-5, 1e-4]
    (d / "sweep.json").write_text(json.dumps({"pressures": [
        {"pressure": q, "c_tof": 0.5 * q ** 0.22, "c_l": {"mean": 0.55 * q ** 0.2, "std": 0.001},
         "c_t": 0.3 * q ** 0.24} for q in p]}))
    return d


CLI_CASES = [
    ("network", ["packing.h5"], (12, 10)),
    ("roses", ["packing.h5"], (13, 4.8)),
    ("snapshot", ["signal.h5", "--packing", "packing.h5", "--index", "1"], (12, 5.5)),
    ("snapshot", ["lat_signal.h5", "--packing", "lat_packing.h5", "--modes", "lat_modes.h5",
                  "--linear", "lat_linear.h5"], (17.6, 11)),
    ("signals", ["s0.h5", "s1.h5", "s2.h5"], (12, 4.8)),
    ("signals", ["s0.h5", "s1.h5", "--ensemble", "ens.h5"], (12, 4.8)),
    ("compare", ["s0.h5", "tall.h5", "--speed", "0.1", "--speed", "0.1"], (8, 5)),
    ("coherent", ["ens.h5", "tall.h5"], (12, 4.8)),
    ("arrivals", ["heights.json"], (8, 5.5)),
    ("exponents", ["heights.json", "--chain", "20,40"], (12, 8.5)),
    ("speeds", ["sweep.json", "--lattice-frictional", "lat.json"], (8, 6)),
    ("spectrum", ["modes.h5"], (9, 7)),
    ("modes", ["modes.h5", "linear.h5", "packing.h5"], (4.2 * 3 + 0.8, 5.5)),
    ("damping", ["damp0.h5", "damp1.h5", "damp2.h5", "--reference", "s0.h5"], (3.6 * 3 + 0.5, 3.6)),
    ("airy", ["--n", "10", "--n", "20", "--ic", "B"], (12, 5)),
]


#: What each figure's title must give besides its scene (p, L, n): not the chain's pressure or
#: height (it has N), not the sweep's one height (it pools several)
TITLE_PARTS = {"airy": (False, False, False), "speeds": (False, False, True)}


@pytest.mark.parametrize("name,args,size", CLI_CASES, ids=[c[0] for c in CLI_CASES])
def test_cli_plot(files, tmp_path, name, args, size, monkeypatch):
    """Each figure from tiny inputs: the PNG, and the figure's rules (tests/figure_rules.py:
    title with scene, p, L, n; units on every axis; no empty panel; legend numbers by the
    number rule; every symbol defined)."""
    from figure_rules import capture, check

    from granwave.cli import main

    figs = capture(monkeypatch)
    args = [str(files / a) if a.endswith((".h5", ".json")) else a for a in args]
    out = tmp_path / f"{name}.png"
    pdf = name == "speeds" or args[0].endswith("/signal.h5")  # PDFs are slow: two cases check it
    res = CliRunner().invoke(main, ["plot", name, *args, "--scene", "tinyscene", "-o", str(out)]
                             + (["--pdf"] if pdf else []))
    assert res.exit_code == 0, res.output
    check_png(out, size)
    assert len(figs) == 1
    p, L, n = TITLE_PARTS.get(name, (True, True, True))
    check(figs[0], scene="tinyscene", pressure=p, height=L, count=n)
    assert out.with_suffix(".pdf").exists() == pdf
    if pdf:
        assert out.with_suffix(".pdf").stat().st_size > 1000


def test_cli_plot_bad_input(files, tmp_path):
    from granwave.cli import main

    out = tmp_path / "x.png"
    for args in (["network", str(files / "signal.h5")],          # a signal, not a packing
                 ["damping", str(files / "s0.h5")],               # no damping attribute
                 ["snapshot", str(files / "lat_signal.h5"), "--modes", str(files / "lat_modes.h5")],
                 ["snapshot", str(files / "s0.h5")],              # no snapshots
                 ["arrivals", str(files / "packing.h5")],         # not JSON
                 ["compare", str(files / "s0.h5"), "--speed", "0.1", "--speed", "0.2"]):
        res = CliRunner().invoke(main, ["plot", *args, "-o", str(out)])
        assert res.exit_code != 0, args
        assert res.output.strip().count("\n") <= 2 and "Traceback" not in res.output, res.output
        assert not out.exists()
        if args[0] == "damping":
            assert "s0.h5: no 'damping' attribute" in res.output  # names the file
