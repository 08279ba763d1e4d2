"""Figures (granwave.plots and `granwave plot`): each one is drawn from small
synthetic inputs and checked to be a PNG of the expected size with a
meaningful number of non-background pixels."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from click.testing import CliRunner  # noqa: E402

from granwave import io as gio  # noqa: E402  (import io before model: import cycle)
from granwave import plots  # noqa: E402
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
    assert img.shape[:2] == (round(h * plots.DPI), round(w * plots.DPI))
    rgb = img[..., :3]
    background = np.all(rgb > 0.98, axis=-1)
    assert (~background).mean() > min_fraction, "figure is nearly empty"


@pytest.fixture(scope="module")
def packing():
    return small_packing()


# ---------------------------------------------------------------- library
def test_segments_wrap_periodic_contacts(packing):
    segs, owner = plots.contact_segments(packing)
    c = packing.contacts
    assert set(owner) == set(range(len(c)))
    # a contact across the periodic boundary is drawn twice, and no segment is longer than a contact
    lengths = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
    assert lengths.max() < 1.1
    assert len(segs) > len(c)


def test_snapshot_and_modes(tmp_path, packing):
    sig = synthetic_signal(snapshots=True)
    out = plots.displacement_snapshot(sig, tmp_path / "snap.png", packing=packing, index=[0, 2])
    check_png(out[0], (4.2 * 2 + 0.8, 5.5))
    vecs = np.random.default_rng(0).standard_normal((sig.dof_grain.size, 3))
    out = plots.mode_shapes(vecs, sig.dof_grain, sig.dof_axis, packing.position,
                            tmp_path / "modes.png", omega=[0.1, 0.2, 0.3], radius=packing.radius,
                            box=packing.box)
    check_png(out[0], (4.2 * 3 + 0.8, 5.5))
    with pytest.raises(plots.InputError, match="no grain positions"):
        plots.displacement_snapshot(sig, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_signal_figures(tmp_path):
    # drawing is covered by the CLI tests below; here the library-only behaviour
    sigs = [synthetic_signal(seed=s) for s in range(3)]
    ens = plots.ensemble_stats(sigs)
    F = np.stack([s.force for s in sigs])
    assert ens["n"] == 3 and np.allclose(ens["mean"], F.mean(0)) and np.allclose(ens["rms"], F.std(0))
    with pytest.raises(plots.InputError, match="damping"):
        plots.damping_series(sigs, tmp_path / "d2.png")
    with pytest.raises(plots.InputError, match="speed for every signal or for none"):
        plots.signal_comparison(sigs[:2], tmp_path / "c.png", speeds=[0.1, None])
    assert not list(tmp_path.iterdir())


def heights_data(gamma=0.6, alpha=0.35, c=0.1):
    L = np.array([5.0, 8.0, 12.0, 18.0, 25.0, 40.0])
    return {"height": L, "t_lead10": L / (1.05 * c) + 1, "t_peak": L / c + 3, "t_zero": L / c + 6,
            "amplitude": 2 * L ** -gamma, "width": 0.5 * L ** alpha}


def test_front_figures(tmp_path):
    d = heights_data()
    series = {"2D disordered": d, "chain": heights_data(2 / 3, 1 / 3),
              "polydisperse chain": heights_data(0.8, 0.5)}
    check_png(plots.amplitude_width(series, tmp_path / "e.png")[0], (12, 8.5))
    Lm, e = plots.effective_exponents(d["height"], d["amplitude"])
    assert np.allclose(e, -0.6)


def test_select_modes():
    rng = np.random.default_rng(0)
    n = 12
    vecs = np.eye(n)[:, rng.permutation(n)] * 0.5 + 0.1  # columns: one grain dominates each
    vecs[:, 0] = 1.0  # mode 0: spread over every grain
    a = np.r_[np.ones(5), 3.0, np.ones(n - 6)]
    modes = Modes(np.r_[0.0, np.linspace(0.1, 1, n - 1)], a, np.ones(n), np.ones(n), vectors=vecs,
                  attrs={"height": 1.0})
    sel = plots.select_modes(modes, dof_grain=np.arange(n))
    assert sel["lowest nonzero"] == 1 and sel["strongest |a_n b_n|"] == 5
    assert sel["most localized"] != 0


def test_bad_output_name(tmp_path, packing):
    with pytest.raises(plots.InputError, match=".png"):
        plots.contact_roses(packing, tmp_path / "roses.txt")
    with pytest.raises(plots.InputError, match="does not exist"):
        plots.contact_roses(packing, tmp_path / "nowhere" / "roses.png")


def test_caption_for():
    assert plots.caption_for("figures/speeds.png").startswith("Sound speeds")
    assert "p1e-4" in plots.caption_for("network_p1e-4.png")


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
    h = heights_data()
    h_json = {"pressure": 1e-4, "ic": "A", "gamma": 0.6, "c_tof": 0.1,
              "samples": [{k: float(v[i]) for k, v in h.items()} for i in range(h["height"].size)]}
    (d / "heights.json").write_text(json.dumps(h_json))
    (d / "lat.json").write_text(json.dumps({"pressure": 1e-5, "c_tof": 0.2, "c_peak": 0.19}))
    p = [1e-7, 1e-6, 1e-5, 1e-4]
    (d / "sweep.json").write_text(json.dumps({"pressures": [
        {"pressure": q, "c_tof": 0.5 * q ** 0.22, "c_l": {"mean": 0.55 * q ** 0.2, "std": 0.001},
         "c_t": 0.3 * q ** 0.24} for q in p]}))
    return d


CLI_CASES = [
    ("network", ["packing.h5"], (12, 10)),
    ("roses", ["packing.h5"], (13, 4.8)),
    ("snapshot", ["signal.h5", "--packing", "packing.h5", "--index", "1"], (5.0, 5.5)),
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


@pytest.mark.parametrize("name,args,size", CLI_CASES, ids=[c[0] for c in CLI_CASES])
def test_cli_plot(files, tmp_path, name, args, size):
    from granwave.cli import main

    args = [str(files / a) if a.endswith((".h5", ".json")) else a for a in args]
    out = tmp_path / f"{name}.png"
    pdf = name in ("snapshot", "speeds")  # PDFs are slow: two cases check the --pdf twin
    res = CliRunner().invoke(main, ["plot", name, *args, "-o", str(out)] + (["--pdf"] if pdf else []))
    assert res.exit_code == 0, res.output
    check_png(out, size)
    assert out.with_suffix(".pdf").exists() == pdf
    if pdf:
        assert out.with_suffix(".pdf").stat().st_size > 1000


def test_cli_plot_bad_input(files, tmp_path):
    from granwave.cli import main

    out = tmp_path / "x.png"
    for args in (["network", str(files / "signal.h5")],          # a signal, not a packing
                 ["damping", str(files / "s0.h5")],               # no damping attribute
                 ["snapshot", str(files / "s0.h5")],              # no snapshots
                 ["arrivals", str(files / "packing.h5")],         # not JSON
                 ["compare", str(files / "s0.h5"), "--speed", "0.1", "--speed", "0.2"]):
        res = CliRunner().invoke(main, ["plot", *args, "-o", str(out)])
        assert res.exit_code != 0, args
        assert res.output.strip().count("\n") <= 2 and "Traceback" not in res.output, res.output
        assert not out.exists()
