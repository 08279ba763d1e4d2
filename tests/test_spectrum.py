"""Spectrum statistics (docs/method.md §7): chain modes (exact PR), a hand-made spectrum, CLI."""

import json
import math

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from click.testing import CliRunner

from granwave.io import files
from granwave.analysis.spectrum import carried_fractions, participation_ratio, spectrum_summary
from granwave.cli.analyze_spectrum import spectrum as spectrum_cmd
from granwave.model import LinearSystem, Modes, Signal

N = 20  # N + 1 = 21 is odd: no mode hits the special cases of the sin^4 sum below


def chain_system(n=N):
    """Chain of n unit masses, unit springs, both ends tied to walls (docs/method.md §12); 1 dof per ball."""
    D = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    e1, en = np.zeros(n), np.zeros(n)
    e1[0], en[-1] = 1.0, 1.0
    return LinearSystem(stiffness=D, mass=np.ones(n), dof_grain=np.arange(n), dof_axis=np.ones(n, int),
                        source_velocity=e1, source_displacement=e1, detector=en,
                        attrs=dict(dim=2, pressure=0.0, friction=0.0, height=n + 1.0, prestress=False))


def chain_modes(system, vectors=True):
    w2, V = scipy.linalg.eigh(system.stiffness.toarray())
    w = np.sqrt(w2)
    return Modes(omega2=w2, amplitude_A=(V.T @ system.source_velocity) / w,
                 amplitude_B=V.T @ system.source_displacement, coupling=V.T @ system.detector,
                 vectors=V if vectors else None,
                 attrs=dict(dim=2, pressure=0.0, height=system.height, n_zero_modes=0))


def test_chain_participation_ratio_is_exact():
    # phi_n(j) = sqrt(2/(N+1)) sin(j theta_n), theta_n = n pi/(N+1). With sin^4 x = 3/8 - cos(2x)/2
    # + cos(4x)/8, and sums of cos(2 j theta_n), cos(4 j theta_n) over a full period vanishing
    # unless 2n or 4n is a multiple of N+1 (never, N+1 odd): sum_j phi^4 = (4/(N+1)^2) 3(N+1)/8,
    # so PR = 1 / (N sum phi^4) = 2(N+1)/(3N) for every mode.
    modes = chain_modes(chain_system())
    pr = participation_ratio(modes.vectors)
    np.testing.assert_allclose(pr, 2 * (N + 1) / (3 * N), rtol=1e-12)
    res = spectrum_summary(modes, ic="B")
    assert res["n_modes"] == N and res["n_zero_modes"] == 0
    assert res["lowest_nonzero_omega2"] == pytest.approx(4 * math.sin(math.pi / (2 * (N + 1))) ** 2,
                                                        rel=1e-12)
    # F_B(0) = K u_N(0) = 0 and F_B = sum w_n cos(w_n t): the weights sum to zero.
    assert abs(res["sum_weights"]) < 1e-14
    # Weights against the closed form (granwave.theory docstring): (2/(N+1)) (-1)^(n+1) sin^2 theta_n.
    n = np.arange(1, N + 1)
    theta = n * np.pi / (N + 1)
    np.testing.assert_allclose(res["weights"], 2 / (N + 1) * (-1.0) ** (n + 1) * np.sin(theta) ** 2,
                               atol=1e-14)


def test_participation_ratio_over_grains_with_rotations():
    # 3 grains in 2D with rotations: dofs (x, y, theta) per grain; rotations are left out.
    dof_grain = np.repeat(np.arange(3), 3)
    dof_axis = np.tile([0, 1, 2], 3)
    v = np.array([0.1, 0.2, 5.0, 0.3, -0.4, -7.0, 0.0, 0.6, 1.0])
    site = np.array([0.1**2 + 0.2**2, 0.3**2 + 0.4**2, 0.6**2])
    expect = site.sum() ** 2 / (3 * np.sum(site**2))
    pr = participation_ratio(v[:, None], dof_grain=dof_grain, dof_axis=dof_axis, dim=2)
    assert pr[0] == pytest.approx(expect, rel=1e-14)
    # A mode on one grain only: PR = 1/N; a uniform one: PR = 1.
    loc = np.zeros((9, 1))
    loc[3:5] = 1.0
    assert participation_ratio(loc, dof_grain=dof_grain, dof_axis=dof_axis, dim=2)[0] == pytest.approx(1 / 3)
    uni = np.tile([1.0, 0.0, 3.0], 3)[:, None]
    assert participation_ratio(uni, dof_grain=dof_grain, dof_axis=dof_axis, dim=2)[0] == pytest.approx(1.0)


def hand_made(n_nonzero=100):
    omega2 = np.concatenate([[0.0, 0.0], np.arange(1.0, n_nonzero + 1)])
    a = np.concatenate([[0.0, 0.0], np.ones(n_nonzero)])
    b = np.concatenate([[3.0, -1.0], (-1.0) ** np.arange(n_nonzero) * np.arange(1.0, n_nonzero + 1)])
    return Modes(omega2=omega2, amplitude_A=a, amplitude_B=a, coupling=b,
                 attrs=dict(dim=2, pressure=1e-4, height=25.0, n_zero_modes=2,
                            zero_mode_threshold=1e-10))


def test_hand_made_spectrum_fractions():
    res = spectrum_summary(hand_made())
    assert res["n_modes"] == 102 and res["n_zero_modes"] == 2 and res["lowest_nonzero_omega2"] == 1.0
    assert "participation_ratio_note" in res and "pr_mean" not in res
    n = np.arange(1, 101)
    # |w_n| = n: the top 1%, 10%, 50% are the 1, 10, 50 largest n.
    for q, k in (("0.01", 1), ("0.1", 10), ("0.5", 50)):
        top = n[-k:]
        assert res["n_strongest"][q] == k
        assert res["carried_power"][q] == pytest.approx(np.sum(top**2) / np.sum(n**2), rel=1e-14)
        assert res["carried_abs"][q] == pytest.approx(np.sum(top) / np.sum(n), rel=1e-14)
    # The fewest strongest modes whose power reaches 50% / 90%: count down from the top.
    for level in (0.5, 0.9):
        k, acc = 0, 0.0
        while acc < level * np.sum(n**2):
            acc += (100 - k) ** 2
            k += 1
        assert res["modes_for_power"][f"{level:g}"] == k
    assert res["strongest_mode"] == 101 and res["strongest_mode_omega2"] == 100.0
    # 7 nonzero modes: 1% and 10% round up to one mode, 50% to four.
    small = carried_fractions([1.0, 2, 3, 4, 5, 6, 7])
    assert small["n_strongest"] == {"0.01": 1, "0.1": 1, "0.5": 4}


def test_cli(tmp_path):
    system = chain_system()
    files.write_linear(tmp_path / "lin.h5", system)
    files.write_modes(tmp_path / "m.h5", chain_modes(system))
    files.write_modes(tmp_path / "nov.h5", chain_modes(system, vectors=False))
    r = CliRunner().invoke(spectrum_cmd, [str(tmp_path / "m.h5"), "--linear", str(tmp_path / "lin.h5"),
                                          "--json", "--arrays"])
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    assert res["pr_sites"] == "grains" and res["pr_mean"] == pytest.approx(2 * (N + 1) / (3 * N))
    assert len(res["participation_ratio"]) == N and len(res["weights"]) == N
    r = CliRunner().invoke(spectrum_cmd, [str(tmp_path / "nov.h5")])
    assert r.exit_code == 0 and "eigensolve --vectors" in r.output and "carried_power[0.1]" in r.output
    # bad input: a foreign file, a missing file, a linear file of another system
    files.write_signal(tmp_path / "s.h5", Signal(np.arange(3.0), np.zeros(3), attrs=dict(ic="A", method="x", height=1.0)))
    files.write_linear(tmp_path / "lin5.h5", chain_system(5))
    for args, match in (([str(tmp_path / "s.h5")], "expected a granwave.modes file"),
                        ([str(tmp_path / "none.h5")], "no such file"),
                        ([str(tmp_path / "m.h5"), "--linear", str(tmp_path / "lin5.h5")], "not the same system")):
        r = CliRunner().invoke(spectrum_cmd, args)
        assert r.exit_code != 0 and match in r.output and len(r.output.strip().splitlines()) == 1, r.output
