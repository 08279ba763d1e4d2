"""The bulk slab's moduli and sound speeds (granwave.linear.moduli, keys ``*_slab``) and the
lowest longitudinal standing modes (granwave.linear.standing) that check them.

Exact references, derived here:

* Triangular lattice (rows parallel to the walls): under the vertical strain the rows are
  springs in series, per ball K = 2 k_n (3/4) + 2 k_t (1/4) between rows (spacing h,
  horizontal spacing l) and k_wall at the walls. Every link between rows carries the same
  force, so the rows' displacements are exactly linear in y away from the walls and the slab
  modulus is the bulk's, C22_slab = K h / l, whatever the wall springs; the whole cell's is
  H / (l ((N - 1)/K + 2/k_wall)). Mass density m / (l h) with m = pi/6: c_l = sqrt(6 K h^2 / pi)
  (docs/method.md §12's lattice speed, up to the overlap's share in h and K).
* A chain of N rows with end springs k_w: the standing modes are u_j = sin(k x_j + phi) with
  tan phi = (K / k_w) sin(k h) / (1 - cos(k h) ...) ~ k h K / k_w, so k_n (H_eff) = n pi with
  H_eff = (N - 1) h + 2 h K / k_w = H C22_slab / C22 (both sides written out in
  granwave/linear/standing.py); omega = 2 sqrt(K/m) sin(k h / 2) adds -(k h)^2 / 24.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from granwave.cli import main
from granwave.io.files import write_packing
from granwave.linear.assemble import linearize
from granwave.linear.moduli import moduli, slab_density
from granwave.linear.standing import longitudinal_modes, mode_speeds
from test_moduli import lattice, simple_cubic

SQ3 = math.sqrt(3.0)


def _bulk(par):
    """C22 of the infinite lattice, K h / l, and its mass density m / (l h)."""
    K = 2 * par["kn"] * 0.75 + 2 * par["kt"] * 0.25
    return K * par["h"] / par["ell"], (math.pi / 6) / (par["ell"] * par["h"])


@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_lattice_slab_C22_is_the_bulk_value_exactly(friction):
    pk, par = lattice(24, 4, pressure=1e-5, friction=friction)
    res = moduli(pk)
    C22_bulk, _ = _bulk(par)
    assert res["C22_slab"] == pytest.approx(C22_bulk, rel=1e-9)
    assert res["slab"] == pytest.approx([3.0, par["H"] - 3.0], rel=1e-12)
    # the wall springs are softer than a row link: the whole cell is softer than its bulk
    N, H = par["rows"], par["H"]
    K = 2 * par["kn"] * 0.75 + 2 * par["kt"] * 0.25
    assert res["C22"] == pytest.approx(H / (par["ell"] * ((N - 1) / K + 2 / par["knw"])), rel=1e-9)
    assert res["C22_slab_strain_factor"] == pytest.approx(res["C22"] / C22_bulk, rel=1e-9)
    assert res["C22_slab_fit_err"] < 1e-9  # the rows lie exactly on a line
    if friction == 0:  # no-slip wall rows: the frictionless lattice shears affinely, slab = cell
        assert res["C33_slab"] == pytest.approx(SQ3 / 4 * par["kn"], rel=1e-9)


def test_systems_lattice_slab_C22_and_layer():
    systems = pytest.importorskip("granwave.systems")
    pk = systems.triangular_lattice(rows=20, width=4, pressure=1e-5, friction=0.5)
    c = pk.contacts
    pair = c.j >= 0
    kn, kt = c.stiffness_normal[pair][0], c.stiffness_tangential[pair][0]
    ell = pk.box[0] / 4
    h = ell * SQ3 / 2
    for layer in (2.0, 5.0):
        res = moduli(pk, layer=layer)
        assert res["C22_slab"] == pytest.approx((1.5 * kn + 0.5 * kt) * h / ell, rel=1e-9)
        assert res["slab"] == pytest.approx([layer, pk.box[1] - layer], rel=1e-12)
    thin = moduli(pk, layer=0.5 * pk.box[1] - 0.4)  # a slab thinner than 1 d: no slab moduli
    assert thin["slab"] is None and math.isnan(thin["c_l_slab"]) and math.isnan(thin["C22_slab"])
    assert thin["C22"] == pytest.approx(res["C22"], rel=1e-12)


def test_lattice_slab_speed_against_lattice_theory():
    """c_l_slab against the exact bulk speed sqrt(C22_bulk / rho). The only difference is the
    slab's density: the sphere volume between two planes of discrete rows ripples with the
    planes' position, by ~0.05 h / (slab thickness) (0.36 % at 24 rows, 0.15 % at 48)."""
    from granwave import theory

    for rows, tol in ((24, 5e-3), (48, 2e-3)):
        pk, par = lattice(rows, 4, pressure=1e-5, friction=0.0)
        res = moduli(pk)
        C22_bulk, rho = _bulk(par)
        assert res["phi3_star_slab"] == pytest.approx(rho, rel=tol)
        assert res["c_l_slab"] == pytest.approx(math.sqrt(C22_bulk / rho), rel=tol / 2)
        # docs/method.md §12 (its small-overlap form: the overlaps shift h and K by ~p^(2/3))
        assert res["c_l_slab"] == pytest.approx(theory.lattice_speed(1e-5), rel=tol / 2 + 3e-3)


def test_slab_density_of_uniform_rows_is_exact_over_whole_periods():
    """Over a slab of whole row periods the sphere volumes of the rows add up exactly."""
    pk, par = lattice(24, 4, pressure=1e-5)
    from granwave.linear.moduli import _cell

    cell = _cell(pk, False)
    _, rho = _bulk(par)
    lo = par["y"][5] - 0.3
    assert slab_density(cell, lo, lo + 10 * par["h"]) == pytest.approx(rho, rel=1e-12)


@pytest.mark.parametrize("friction", [0.0, 0.5])
def test_lowest_longitudinal_modes_travel_at_the_slab_speed_on_the_lattice(friction):
    """omega_n H_eff / (n pi) of the modes picked by their projection on sin(n pi y / H)
    against c_l_slab: they differ by the rows' dispersion (k h)^2 / 24 (7e-4 n^2 at 24 rows)
    and the slab density's ripple (below 0.2 % in c at 24 rows). The naive k_n = n pi / H
    (no wall correction) is off by several times more."""
    pk, par = lattice(24, 4, pressure=1e-5, friction=friction)
    res = moduli(pk)
    modes = longitudinal_modes(linearize(pk), pk, n_max=3)
    assert min(modes["overlap"]) > 0.99  # the uniform rows' modes are the profile's
    c = mode_speeds(modes, res["C22"], res["C22_slab"])
    C22_bulk, rho = _bulk(par)
    exact = math.sqrt(C22_bulk / rho)
    n = np.arange(1, 4)
    kh = n * np.pi * par["h"] / (par["H"] * res["C22_slab"] / res["C22"])
    # the modes against the chain's exact dispersion, to its next order
    assert c / exact == pytest.approx(np.sin(kh / 2) / (kh / 2), abs=2e-4)
    assert c[0] == pytest.approx(res["c_l_slab"], rel=3e-3)
    naive = np.asarray(modes["omega"]) * par["H"] / (n * np.pi)
    assert abs(naive[0] / res["c_l_slab"] - 1) > 2 * abs(c[0] / res["c_l_slab"] - 1)


def test_3d_simple_cubic_slab_moduli():
    """Linear springs k between layers (spacing l), kw to the walls: C33 of the bulk = k / l."""
    pk, par = simple_cubic(8, 3)
    res = moduli(pk, layer=1.5)
    assert res["C33_slab"] == pytest.approx(par["k"] / par["ell"], rel=1e-9)
    assert res["C33"] < res["C33_slab"]  # kw = 2k at half the spacing: softer per length
    for key in ("C44_slab", "C55_slab", "c_t_slab", "c_l_slab", "phi3_star_slab"):
        assert math.isfinite(res[key]) and res[key] > 0


def test_cli_reports_the_slab(tmp_path):
    pk, par = lattice(16, 4, pressure=1e-4, friction=0.5)
    path = tmp_path / "lattice.h5"
    write_packing(path, pk)
    runner = CliRunner()
    r = runner.invoke(main, ["analyze", "moduli", str(path), "--json"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    C22_bulk, _ = _bulk(par)
    assert d["C22_slab"] == pytest.approx(C22_bulk, rel=1e-9)
    assert d["c_l_slab"] == pytest.approx(math.sqrt(d["C22_slab"] / d["phi3_star_slab"]), rel=1e-12)
    table = runner.invoke(main, ["analyze", "moduli", str(path)])
    assert table.exit_code == 0, table.output
    assert "c_l_slab" in table.output and "slab" in table.output


def test_disordered_columns_modes_against_the_slab_speed():
    """Small frictionless columns (160 grains, about 7 x 21 d, six seeds): the lowest three
    longitudinal standing waves, each at the weighted median of its spectral weight, against
    c_l_slab. In one packing the profile spreads over several modes (overlap of the largest
    0.2-0.7) and each n scatters by ~5 %; over the six packings and n = 1..3 the mean ratio is
    0.99 (measured over eight seeds: 0.996 ± 0.008; n = 1 alone 0.958 ± 0.015, the wall layers
    of a 21 d column being more than a first-order correction for the mode whose strain is
    largest there). Tolerance 3 %: about three standard errors of the mean."""
    from granwave.dem.protocol import prepare_packing
    from granwave.params import PrepareParams

    ratios = []
    for seed in range(1, 7):
        pk = prepare_packing(PrepareParams(dim=2, grains=160, aspect=3.0, pressure=1e-4,
                                           friction=0.0, seed=seed))
        res = moduli(pk)
        modes = longitudinal_modes(linearize(pk), pk, n_max=3)
        assert min(modes["overlap_total"]) == pytest.approx(1.0, abs=1e-9)  # every mode computed
        c = mode_speeds(modes, res["C22"], res["C22_slab"])
        assert np.all(np.abs(c / res["c_l_slab"] - 1) < 0.2)
        ratios.append(c / res["c_l_slab"])
    assert float(np.mean(ratios)) == pytest.approx(1.0, abs=0.03)


def test_continuum_uses_the_slab_c_l_by_default(tmp_path):
    """`analyze continuum` reads c_l_slab (default) or c_l (--c-l cell) from the moduli files,
    reports both, and refuses a file without c_l_slab unless told to use the cell's."""
    from granwave.io.files import write_signal
    from test_attenuation import synthetic

    paths, mods = [], []
    for L in (10, 20, 40, 80):
        for s in range(2):
            p = tmp_path / f"h{L}_s{s}.h5"
            write_signal(p, synthetic(L))
            m = tmp_path / f"h{L}_s{s}.json"
            m.write_text(json.dumps({"c_l": 0.75, "c_t": 0.45, "c_l_slab": 0.8, "c_t_slab": 0.5}))
            paths.append(str(p))
            mods.append(str(m))
    runner = CliRunner()
    args = ["analyze", "continuum", *paths, "--bootstrap", "0", "--json"]
    for m in mods:
        args += ["--moduli", m]
    slab = json.loads(runner.invoke(main, args).stdout)
    cell = json.loads(runner.invoke(main, args + ["--c-l", "cell"]).stdout)
    assert slab["c_l_kind"] == "slab" and slab["c_l"]["mean"] == pytest.approx(0.8)
    assert slab["c_t"]["mean"] == pytest.approx(0.5)
    assert cell["c_l_kind"] == "cell" and cell["c_l"]["mean"] == pytest.approx(0.75)
    for res in (slab, cell):
        assert res["c_l_by_kind"]["slab"]["mean"] == pytest.approx(0.8)
        assert res["c_l_by_kind"]["cell"]["mean"] == pytest.approx(0.75)
        assert res["samples"][0]["c_l_cell"] == 0.75 and res["samples"][0]["c_l_slab"] == 0.8
    assert np.allclose(np.asarray(slab["local"]["ratio"]) * 0.8,
                       np.asarray(cell["local"]["ratio"]) * 0.75, rtol=1e-12)
    table = runner.invoke(main, [a for a in args if a != "--json"])
    assert table.exit_code == 0 and "c_l = slab" in table.output
    # a moduli file from before the slab: refused by default, read with --c-l cell
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"c_l": 0.75, "c_t": 0.45}))
    args_old = [a if a != mods[0] else str(old) for a in args]
    bad = runner.invoke(main, args_old)
    assert bad.exit_code == 2 and "no c_l_slab" in bad.output and len(bad.output.splitlines()) == 1
    assert runner.invoke(main, args_old + ["--c-l", "cell"]).exit_code == 0
    # a batch's failed moduli solve (c_l null): that packing has no speed of either kind
    failed = tmp_path / "failed.json"
    failed.write_text(json.dumps({"c_l": None, "c_t": None, "error": "floppy"}))
    res = json.loads(runner.invoke(main, [a if a != mods[0] else str(failed) for a in args]).stdout)
    assert res["c_l"]["count"] == 7
