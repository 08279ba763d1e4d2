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


def test_network_and_roses(tmp_path, packing):
    out = plots.force_network(packing, tmp_path / "network.png", pdf=True)
    assert [p.name for p in out] == ["network.png", "network.pdf"]
    check_png(out[0], (12, 10))
    out = plots.contact_roses(packing, tmp_path / "roses.png")
    check_png(out[0], (13, 4.8))
    assert not list(tmp_path.glob(".*tmp"))


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
    sigs = [synthetic_signal(seed=s) for s in range(5)]
    check_png(plots.signals_overlay(sigs, tmp_path / "s.png")[0], (12, 4.8))
    others = [synthetic_signal(c=0.08, friction=0.0), synthetic_signal(c=0.06, dim=3, friction=0.0)]
    out = plots.signal_comparison([sigs[0]] + others, tmp_path / "c.png", speeds=[0.1, 0.08, 0.06])
    check_png(out[0], (8, 5))
    series = [{"height": L, "time": s.time, "mean": s.force, "rms": 0.1 * np.abs(s.force), "n": 3}
              for L in (5.0, 10.0, 20.0) for s in [synthetic_signal(height=L)]]
    check_png(plots.coherent_heights(series, tmp_path / "h.png")[0], (12, 4.8))
    damp = [synthetic_signal(seed=k, damping=z) for k, z in enumerate((0.3, 0.0, 0.1))]
    out = plots.damping_series(damp, tmp_path / "d.png", reference=sigs[0])
    check_png(out[0], (3.6 * 3 + 0.5, 3.2 + 0.4))
    with pytest.raises(plots.InputError, match="damping"):
        plots.damping_series(sigs, tmp_path / "d2.png")


def heights_data(gamma=0.6, alpha=0.35, c=0.1):
    L = np.array([5.0, 8.0, 12.0, 18.0, 25.0, 40.0])
    return {"height": L, "t_lead10": L / (1.05 * c) + 1, "t_peak": L / c + 3, "t_zero": L / c + 6,
            "amplitude": 2 * L ** -gamma, "width": 0.5 * L ** alpha}


def test_front_figures(tmp_path):
    d = heights_data()
    check_png(plots.arrival_times(d, tmp_path / "a.png")[0], (8, 5.5))
    series = {"2D disordered": d, "chain": heights_data(2 / 3, 1 / 3),
              "polydisperse chain": heights_data(0.8, 0.5)}
    check_png(plots.amplitude_width(series, tmp_path / "e.png")[0], (12, 8.5))
    Lm, e = plots.effective_exponents(d["height"], d["amplitude"])
    assert np.allclose(e, -0.6)


def test_speeds_spectrum_airy(tmp_path):
    p = np.array([1e-7, 1e-6, 1e-5, 1e-4])
    sweep = {"pressure": p, "c_tof": 0.5 * p ** 0.22, "c_tof_err": 0.01 * p ** 0.22,
             "c_l": 0.55 * p ** 0.2, "c_t": 0.3 * p ** 0.24}
    pts = [{"pressure": 1e-5, "speed": 0.5, "friction": 0.5}, {"pressure": 5e-7, "speed": 0.08,
                                                                "friction": 0.0}]
    out = plots.speeds_vs_pressure(sweep, tmp_path / "v.png", lattice_points=pts)
    check_png(out[0], (8, 6))
    rng = np.random.default_rng(0)
    modes = Modes(np.sort(np.r_[0.0, rng.uniform(0, 1, 200)]), rng.standard_normal(201),
                  rng.standard_normal(201), rng.standard_normal(201), attrs={"height": 10.0})
    check_png(plots.spectrum(modes, tmp_path / "w.png")[0], (9, 7))
    assert plots.select_modes(modes)["lowest nonzero"] == 1
    check_png(plots.chain_airy(tmp_path / "airy.png", n_balls=(20, 40))[0], (12, 5))


def test_bad_output_name(tmp_path, packing):
    with pytest.raises(plots.InputError, match=".png"):
        plots.contact_roses(packing, tmp_path / "roses.txt")
    with pytest.raises(plots.InputError, match="does not exist"):
        plots.contact_roses(packing, tmp_path / "nowhere" / "roses.png")


def test_caption_for():
    assert plots.caption_for("figures/speeds.png").startswith("Sound speeds")
    assert "p1e-4" in plots.caption_for("network_p1e-4.png")
