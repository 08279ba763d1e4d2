"""Exact references of docs/method.md §12 against independent numerics."""

import numpy as np
import pytest
from scipy import integrate, linalg, special

from granwave import contact, theory
from granwave.errors import InputError


def chain_by_eigh(t, n, *, ic, stiffness, mass, spacing):
    """Wall force of the chain from scipy's eigen-decomposition of its tridiagonal matrix."""
    d = np.full(n, 2.0 * stiffness / mass)
    e = np.full(n - 1, -stiffness / mass)
    w2, phi = linalg.eigh_tridiagonal(d, e)
    w = np.sqrt(w2)
    c = spacing * np.sqrt(stiffness / mass)
    if ic == "A":
        coef = phi[0] * c / w  # projection of u'(0) = c e_1
        u_last = np.sin(np.outer(t, w)) @ (coef * phi[-1])
    else:
        coef = phi[0] * spacing
        u_last = np.cos(np.outer(t, w)) @ (coef * phi[-1])
    return stiffness * u_last


def test_chain_modes_match_tridiagonal_spectrum():
    n, k, m, ell = 17, 2.3, 0.7, 0.9
    kn, wn = theory.chain_modes(n, stiffness=k, mass=m, spacing=ell)
    w2 = linalg.eigvalsh_tridiagonal(np.full(n, 2 * k / m), np.full(n - 1, -k / m))
    np.testing.assert_allclose(wn**2, w2, rtol=1e-12)
    np.testing.assert_allclose(kn * ell, np.arange(1, n + 1) * np.pi / (n + 1), rtol=1e-14)
    assert theory.chain_speed(stiffness=k, mass=m, spacing=ell) == pytest.approx(ell * np.sqrt(k / m), rel=1e-15)
    assert theory.chain_travel_time(n, stiffness=k, mass=m, spacing=ell) == pytest.approx(
        (n + 1) * ell / (ell * np.sqrt(k / m)), rel=1e-15)


@pytest.mark.parametrize("ic", ["A", "B"])
def test_chain_wall_force_equals_eigh_modal_sum(ic):
    n, k, m, ell = 23, 2.3, 0.7, 0.9
    t = np.linspace(0, 4 * theory.chain_travel_time(n, stiffness=k, mass=m, spacing=ell), 700)
    exact = theory.chain_wall_force(t, n, ic=ic, stiffness=k, mass=m, spacing=ell)
    ref = chain_by_eigh(t, n, ic=ic, stiffness=k, mass=m, spacing=ell)
    assert np.max(np.abs(exact - ref)) <= 1e-10 * np.max(np.abs(ref))


def test_chain_wall_force_equals_direct_integration():
    # An independent route: integrate m u'' = K (u_{j+1} - 2u_j + u_{j-1}) with walls at rest.
    n, k, m, ell = 6, 1.7, 1.3, 1.1
    c = ell * np.sqrt(k / m)
    t = np.linspace(0, 30.0, 301)

    def rhs(_, y):
        u, v = y[:n], y[n:]
        up = np.r_[0.0, u, 0.0]
        return np.r_[v, k / m * (up[2:] - 2 * u + up[:-2])]

    for ic, y0 in (("A", np.r_[np.zeros(n), c, np.zeros(n - 1)]), ("B", np.r_[ell, np.zeros(2 * n - 1)])):
        sol = integrate.solve_ivp(rhs, (0, t[-1]), y0, t_eval=t, method="DOP853", rtol=1e-12, atol=1e-14)
        ref = k * sol.y[n - 1]
        got = theory.chain_wall_force(t, n, ic=ic, stiffness=k, mass=m, spacing=ell)
        assert np.max(np.abs(got - ref)) <= 1e-9 * np.max(np.abs(ref))


def test_chain_B_is_derivative_of_A_and_chunking_is_exact(monkeypatch):
    n = 40
    t = np.linspace(1.0, 80.0, 2001)
    fa = theory.chain_wall_force(t, n, ic="A")
    fb = theory.chain_wall_force(t, n, ic="B")
    h = 1e-4
    dfa = (theory.chain_wall_force(t + h, n, ic="A") - theory.chain_wall_force(t - h, n, ic="A")) / (2 * h)
    # (l/c) dF_A/dt with l = c = 1; central difference error ~ h^2 |F'''| ~ 1e-9
    assert np.max(np.abs(fb - dfa)) <= 1e-7 * np.max(np.abs(fb))
    monkeypatch.setattr(theory, "_CHUNK_ELEMENTS", 97)  # many tiny chunks, odd sizes
    np.testing.assert_allclose(theory.chain_wall_force(t.reshape(3, -1)[..., :], n, ic="A").ravel(),
                               fa, rtol=0, atol=1e-14 * np.max(np.abs(fa)))


@pytest.mark.parametrize("ic", ["A", "B"])
def test_airy_form_converges_to_exact_sum(ic):
    # Window around the front: x = -2 c tau / (l M^{1/3}) from +3 down to -6 (first three lobes).
    # The neglected terms are O(M^{-2/3}); measured max error / max|F| = 6.2 ... 6.8 N^{-2/3}.
    errors = []
    sizes = (100, 1000, 8000)
    for n in sizes:
        w = n ** (1.0 / 3.0)
        t = theory.chain_travel_time(n) + np.linspace(-1.5 * w, 3.0 * w, 401)
        exact = theory.chain_wall_force(t, n, ic=ic)
        airy = theory.chain_wall_force_airy(t, n, ic=ic)
        err = np.max(np.abs(exact - airy)) / np.max(np.abs(exact))
        assert err <= 8.0 * n ** (-2.0 / 3.0), (n, err)
        errors.append(err)
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.02


def test_airy_scalings_at_arrival():
    # Known results (docs/method.md §12): F_A(t0) ~ N^{-2/3} and the B main lobe ~ 1/N, with the
    # prefactors of the derivation: -8 Ai'(0) and 16 min(x Ai(x)) (x in (a1, 0)).
    n = 4000
    t0 = theory.chain_travel_time(n)
    fa0 = theory.chain_wall_force(np.array([t0]), n, ic="A")[0]
    assert fa0 * (n + 1) ** (2 / 3) == pytest.approx(-8 * special.airy(0.0)[1], rel=8 * n ** (-2 / 3))
    w = n ** (1 / 3)
    t = t0 + np.linspace(0.0, 1.5 * w, 1501)
    fb_min = theory.chain_wall_force(t, n, ic="B").min()
    x = np.linspace(special.ai_zeros(1)[0][0], 0.0, 20001)
    assert fb_min * (n + 1) == pytest.approx(16 * np.min(x * special.airy(x)[0]), rel=8 * n ** (-2 / 3))


def test_airy_form_is_finite_far_ahead_of_the_front():
    f = theory.chain_wall_force_airy(np.array([1e-9, 1e-3, 1.0]), 1000, ic="A")
    assert np.all(np.isfinite(f)) and np.all(np.abs(f) < 1e-300)


def test_chain_input_errors():
    with pytest.raises(InputError):
        theory.chain_wall_force([1.0], 10, ic="C")
    with pytest.raises(InputError):
        theory.chain_wall_force([1.0], 0)
    with pytest.raises(InputError):
        theory.chain_modes(5, stiffness=-1.0)


@pytest.mark.parametrize("friction,poisson", [(False, 0.0), (True, 0.0), (True, 0.5), (True, 0.3)])
def test_lattice_speed_follows_from_row_to_chain_mapping(friction, poisson):
    for p in (1e-7, 1e-5, 1e-4):
        # Contact force p/sqrt(3) between two unit balls; invert Hertz with contact.py.
        f = p / np.sqrt(3.0)
        r12, e12 = contact.effective_radius(2.0, 2.0), contact.effective_young(False)
        overlap = (f / contact.normal_force(1.0, r12, e12)) ** (2.0 / 3.0)
        assert contact.normal_force(overlap, r12, e12) == pytest.approx(f, rel=1e-13)
        kn = contact.normal_stiffness(overlap, r12, e12)
        kt = contact.tangential_stiffness(overlap, r12, contact.effective_shear(poisson, False))
        # A row moving across the rows stretches two inclined contacts (60 deg) per ball:
        # 2 (sin^2 60 kn + cos^2 60 kt) = (3/2) kn (1 + eta/3) with eta = kt/kn.
        k_row = 2 * (0.75 * kn + (0.25 * kt if friction else 0.0))
        c_chain = theory.chain_speed(stiffness=k_row, mass=np.pi / 6, spacing=np.sqrt(3) / 2)
        c_formula = theory.lattice_speed(p, friction=friction, poisson=poisson)
        assert c_formula == pytest.approx(c_chain, rel=1e-12)
    eta = contact.stiffness_ratio(poisson)
    assert kt / kn == pytest.approx(eta, rel=1e-13)


def test_lattice_speed_vectorized_and_checked():
    p = np.array([1e-7, 1e-6, 1e-5, 1e-4])
    c = theory.lattice_speed(p)
    np.testing.assert_allclose(np.diff(np.log(c)) / np.diff(np.log(p)), 1 / 6, rtol=1e-12)
    with pytest.raises(InputError):
        theory.lattice_speed(-1.0)
