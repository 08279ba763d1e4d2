"""The Hertz-Mindlin law of granwave.contact and the engine's per-contact routine.

Checks: stiffness = finite difference of force, force = finite difference of
energy, tangential stick (F_t = k_t s) then slide (mu F_n), and the unloading
rule's energy argument on a closed loading/unloading/shear loop.
"""

import math

import numpy as np
import pytest

from granwave import contact as C
from granwave import contact_models as CM
from granwave.dem import kernels as K


@pytest.mark.parametrize("wall", [False, True])
@pytest.mark.parametrize("overlap", [1e-5, 3e-3, 5e-2])
def test_stiffness_and_force_are_finite_differences(wall, overlap):
    # central differences, step 1e-4 of the overlap: truncation ~1e-8 relative; tolerance 1e-6
    r12 = C.effective_radius(1 / 0.45, 0.0 if wall else 1 / 0.55)
    e12 = C.effective_young(wall)
    g12 = C.effective_shear(0.3, wall)
    h = 1e-4 * overlap
    fd_k = (C.normal_force(overlap + h, r12, e12) - C.normal_force(overlap - h, r12, e12)) / (2 * h)
    assert C.normal_stiffness(overlap, r12, e12) == pytest.approx(fd_k, rel=1e-6)
    fd_f = (C.normal_energy(overlap + h, r12, e12) - C.normal_energy(overlap - h, r12, e12)) / (2 * h)
    assert C.normal_force(overlap, r12, e12) == pytest.approx(fd_f, rel=1e-6)
    # Mindlin/Hertz stiffness ratio eta = 2(1-nu)/(2-nu), for grain pairs and walls alike
    eta = C.tangential_stiffness(overlap, r12, g12) / C.normal_stiffness(overlap, r12, e12)
    assert eta == pytest.approx(C.stiffness_ratio(0.3), rel=1e-12)
    assert C.normal_force(0.0, r12, e12) == 0.0 and C.normal_stiffness(-1e-3, r12, e12) == 0.0


def test_stick_then_slide_in_engine_contact_routine():
    """Growing tangential displacement at fixed overlap: F_t = k_t s while |F_t| < mu F_n,
    then F_t = mu F_n (relative 1e-12)."""
    n = np.array([1.0, 0.0, 0.0])
    delta, r12, e12, g12, mu = 4e-3, 0.25, 0.5, C.effective_shear(0.0, False), 0.5
    ft = np.zeros(3)
    fvec = np.zeros(3)
    v = np.array([0.0, 1.0, 0.0])  # j moves along +y relative to i
    dt = 1e-5
    kt = C.tangential_stiffness(delta, r12, g12)
    fel = C.normal_force(delta, r12, e12)
    s_slide = mu * fel / kt
    s = 0.0
    for _ in range(int(2 * s_slide / dt)):
        K.contact_force(n, delta, r12, e12, g12, 1.0, v, ft, delta, dt, CM.damping_model(0.0), CM.tangential_model(mu),
                        fvec)
        s += dt
        expected = min(kt * s, mu * fel)
        assert fvec[1] == pytest.approx(expected, rel=1e-9)
        assert fvec[0] == pytest.approx(-fel, rel=1e-12)
    assert ft[1] == pytest.approx(mu * fel, rel=1e-12)


def _loop_work(rescale: bool, mu: float = 10.0, steps: int = 400):
    """Work done on the tangential spring over the closed loop
    (n0, 0) -> (n1, 0) -> (n1, s1) -> (n0, s1) -> (n0, 0) (load, shear, unload, shear back)."""
    r12, e12, g12 = 0.25, 0.5, C.effective_shear(0.0, False)
    n0, n1, s1 = 1e-3, 4e-3, 2e-4
    path = np.concatenate([
        np.column_stack([np.linspace(n0, n1, steps), np.zeros(steps)]),
        np.column_stack([np.full(steps, n1), np.linspace(0, s1, steps)]),
        np.column_stack([np.linspace(n1, n0, steps), np.full(steps, s1)]),
        np.column_stack([np.full(steps, n0), np.linspace(s1, 0, steps)]),
    ])
    ft = np.zeros(2)
    work = 0.0
    for (na, sa), (nb, sb) in zip(path[:-1], path[1:]):
        old = ft[1]
        slip = np.array([0.0, sb - sa])
        C.update_tangential(ft, slip, na if rescale else nb, nb, C.tangential_stiffness(nb, r12, g12),
                            C.normal_force(nb, r12, e12), mu)
        work += 0.5 * (old + ft[1]) * (sb - sa)  # trapezoid: exact for the linear legs
    return work, ft[1], C.tangential_stiffness(n1, r12, g12) * s1**2


def test_closed_loop_creates_no_energy():
    """With the unloading rescale the loop dissipates (W >= 0) and ends at F_t = 0; without it
    the same loop delivers energy (W ~ -(k1 - k0) s1^2 / 2), so the test can fail."""
    work, ft_end, scale = _loop_work(rescale=True)
    assert work >= -1e-9 * scale
    assert abs(ft_end) < 1e-12 * scale / 2e-4
    bad_work, bad_end, _ = _loop_work(rescale=False)
    assert bad_work < -0.1 * scale and abs(bad_end) > 0
    # with sliding (small mu) the loop only dissipates more
    slid_work, _, _ = _loop_work(rescale=True, mu=0.05)
    assert slid_work >= -1e-9 * scale


def test_projection_keeps_magnitude_and_is_tangent():
    ft = np.array([0.3, -0.2, 0.1])
    n = np.array([1.0, 1.0, 0.5]) / math.sqrt(2.25)
    mag = np.linalg.norm(ft)
    C.project_tangential(ft, n)
    assert abs(ft @ n) < 1e-15 and np.linalg.norm(ft) == pytest.approx(mag, rel=1e-14)


def _small_loop_work(rescale: bool, a: float, steps: int = 200):
    """Work on the tangential spring over the loop (n0, 0) -> (n0(1+a), 0) -> (n0(1+a), a n0)
    -> (n0, a n0) -> (n0, 0) of relative size a, from a prestressed state F_t = 0.3 mu F_n
    (a stored force, as in a packing), with update_tangential's rescale on or off."""
    r12, e12, g12, mu = 0.25, 0.5, C.effective_shear(0.0, False), 0.5
    n0 = 1e-3
    n1, s1 = n0 * (1 + a), a * n0
    path = np.concatenate([
        np.column_stack([np.linspace(n0, n1, steps), np.zeros(steps)]),
        np.column_stack([np.full(steps, n1), np.linspace(0, s1, steps)]),
        np.column_stack([np.linspace(n1, n0, steps), np.full(steps, s1)]),
        np.column_stack([np.full(steps, n0), np.linspace(s1, 0, steps)]),
    ])
    ft = np.array([0.0, 0.3 * mu * C.normal_force(n0, r12, e12)])
    work = 0.0
    for (na, sa), (nb, sb) in zip(path[:-1], path[1:]):
        old = ft[1]
        C.update_tangential(ft, np.array([0.0, sb - sa]), na, nb, C.tangential_stiffness(nb, r12, g12),
                            C.normal_force(nb, r12, e12), mu, rescale)
        work += 0.5 * (old + ft[1]) * (sb - sa)
    # energy the contact delivers over the closed displacement loop: minus the work done on it
    return -work, C.tangential_stiffness(n0, r12, g12) * n0**2


def test_plain_incremental_law_creates_energy_only_at_third_order():
    """The pulses' plain incremental law (rescale_on_unloading=False) on a closed loop of
    relative size a from a prestressed contact: the energy it delivers, -(work done on it), is
    at most C a^3 k_t n0^2 (measured 0.25 a^3; halving a divides it by 8), i.e. ~1e-10 of
    k_t n0^2 at the pulses' a ~ 1e-3 (k_t' dn ds^2 / 2); with the rescale the loop dissipates."""
    created = {}
    for a in (0.04, 0.02, 0.01):
        e, scale = _small_loop_work(False, a)
        created[a] = e / scale
        e_rescale, _ = _small_loop_work(True, a)
        assert e_rescale <= 1e-12, (a, e_rescale / scale)
    assert all(0.0 < v <= 0.5 * a**3 for a, v in created.items()), created
    assert 6.0 < created[0.04] / created[0.02] < 10.0, created
    assert 6.0 < created[0.02] / created[0.01] < 10.0, created
