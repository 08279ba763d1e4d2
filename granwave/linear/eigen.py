"""Eigenmodes of D phi = omega^2 M phi and their part in the signal (docs/method.md §7).

The generalized problem is solved in the symmetric standard form
A = M^-1/2 D M^-1/2 (M is diagonal), A v = omega^2 v, phi = M^-1/2 v, so the
modes come out M-orthonormal (phi_n^T M phi_m = delta_nm). With prestress
and tangential forces D is not exactly symmetric (docs/linear.md); its
symmetric part is used and the relative asymmetry is recorded.

Dense solver: LAPACK ``syevd`` (divide and conquer) through
``scipy.linalg.eigh(driver="evd")``, several times faster on these matrices
than scipy's default ("evr"), "ev" or numpy.linalg.eigh (all eigenpairs are
wanted, which is what divide and conquer does best).
Memory: about 3 n^2 doubles (A, the vectors, workspace).

A tridiagonal A (a chain in its natural order) goes to LAPACK ``stemr``
(``scipy.linalg.eigh_tridiagonal``), O(n^2).

Partial solver (``k`` given): the k lowest modes by shift-invert Lanczos
(``scipy.sparse.linalg.eigsh``, sigma slightly below zero so that A - sigma I
is positive definite and factorizable); the signal from them is a low-pass
truncation of the full modal sum.

Zero modes: |omega^2| <= ``threshold`` x omega^2_max (default 1e-10; LAPACK's
backward error is ~n eps omega^2_max ~ 1e-13 omega^2_max at n ~ 1e3, while the
lowest physical mode of a 6400-ball chain sits at 6e-8 omega^2_max). They are
clipped to 0, get a_n = 0 for IC A (their contribution grows linearly in t;
its slope is recorded as ``zero_mode_drift_A``), and are counted. Eigenvalues
below -threshold x omega^2_max are counted as ``n_negative_modes`` and raise a
:class:`NegativeModesWarning`; they are kept negative in the output, never
clipped, and modal propagation refuses them.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError
from ..io.validate import asymmetry_limit
from ..model import LinearSystem, Modes
from ..resources import check_eigensolve
from ..provenance import FILE_ATTRS
from .lapack import dense_eigh
from .assemble import ZERO_MODE_THRESHOLD, asymmetry, omega2_max, symmetric_part

#: Above this many dofs a full dense solve is refused unless asked for explicitly (memory ~ 3 n^2 x 8 B).
DENSE_MAX_DOF = 20000




class NegativeModesWarning(RuntimeWarning):
    """D has eigenvalues clearly below zero: the state is not a stable equilibrium of the model."""


def mass_weighted(system: LinearSystem) -> tuple[sp.csr_matrix, float]:
    """(A = M^-1/2 D_sym M^-1/2, relative asymmetry of D)."""
    D = system.stiffness
    asym = asymmetry(D)
    if asym > 0:
        D = symmetric_part(D)
    s = 1.0 / np.sqrt(system.mass)
    return (sp.diags(s) @ D @ sp.diags(s)).tocsr(), asym


def _is_tridiagonal(A: sp.csr_matrix) -> bool:
    coo = A.tocoo()
    return A.shape[0] > 2 and bool(np.all(np.abs(coo.row - coo.col) <= 1))


def eigensolve(system: LinearSystem, *, vectors: bool = False, k: int | None = None,
               threshold: float = ZERO_MODE_THRESHOLD, dense_max_dof: int = DENSE_MAX_DOF) -> Modes:
    """Spectrum and signal projections of a linear system.

    Parameters
    ----------
    system : from :func:`granwave.linear.assemble.linearize`.
    vectors : keep the M-orthonormal eigenvectors (n, n_modes) in the result
        (units 1/sqrt(rho d^3)); by default only the spectrum and projections.
    k : compute only the k lowest modes (sparse shift-invert); None = all (dense).
    threshold : relative zero-mode threshold on omega^2 / omega^2_max.

    Returns
    -------
    Modes with omega2 ascending (1/t^2), amplitude_A / amplitude_B (a_n, in d
    times sqrt(rho d^3)) and coupling b_n = detector . phi_n; attrs carry the
    system's attributes plus the zero/negative mode counts and the solver.
    """
    n = system.n_dof
    A, asym = mass_weighted(system)
    if not asym <= asymmetry_limit(system.attrs):  # a file's reader refuses it the same way
        raise InputError(f"D is not symmetric: relative asymmetry ||D - D^T||/||D|| = {asym:.3g}, above "
                         f"the {asymmetry_limit(system.attrs):.3g} a linearization with these attributes "
                         "(prestress, friction) can give; its symmetric part is not this system's")
    check_eigensolve(n, k, _is_tridiagonal(A))  # refuse a spectrum that cannot fit in memory
    sqrt_m = np.sqrt(system.mass)
    if k is None or k >= n - 1:
        if n > dense_max_dof:
            raise InputError(f"{n} dofs is too many for a dense eigensolve (limit {dense_max_dof}; "
                             f"memory ~{3 * n * n * 8 / 1e9:.0f} GB): use --lowest K or the time domain")
        if _is_tridiagonal(A):
            # Chains: MRRR on the tridiagonal matrix, O(n^2) instead of O(n^3)
            # (measured 6400 dof: 5.8 s vs ~30 s for dense syevd).
            w, V = scipy.linalg.eigh_tridiagonal(A.diagonal(), A.diagonal(1), lapack_driver="stemr",
                                                 check_finite=False)
            solver = "tridiagonal LAPACK stemr (scipy.linalg.eigh_tridiagonal)"
        else:
            w, V = dense_eigh(A)
            solver = "dense LAPACK syevd (scipy.linalg.eigh driver=evd)"
        w2max = float(max(abs(w[0]), abs(w[-1])))
        partial = False
    else:
        if k < 1:
            raise InputError(f"--lowest must be at least 1 (got {k})")
        w2max = omega2_max(A)
        sigma = -1e-6 * w2max
        w, V = spla.eigsh(A.tocsc(), k=k, sigma=sigma, which="LM", tol=0.0,
                          v0=np.random.default_rng(0).standard_normal(n))
        order = np.argsort(w)
        w, V = w[order], V[:, order]
        solver = f"eigsh shift-invert, {k} lowest (sigma = {sigma:.3g})"
        partial = True
    tol = threshold * w2max
    zero = np.abs(w) <= tol
    negative = w < -tol
    omega2 = np.where(zero, 0.0, w)
    omega = np.sqrt(np.abs(omega2))
    proj_v = V.T @ (sqrt_m * system.source_velocity)  # phi^T M v0
    proj_u = V.T @ (sqrt_m * system.source_displacement)  # phi^T M u0
    coupling = V.T @ (system.detector / sqrt_m)  # detector . phi
    amp_A = np.divide(proj_v, omega, out=np.zeros_like(proj_v), where=~zero)
    shear_amp_A = shear_coupling = None
    if system.shear_source_velocity is not None and system.shear_detector is not None:
        shear_v = V.T @ (sqrt_m * system.shear_source_velocity)
        shear_coupling = V.T @ (system.shear_detector / sqrt_m)
        shear_amp_A = np.divide(shear_v, omega, out=np.zeros_like(shear_v), where=~zero)
    n_neg = int(negative.sum())
    if n_neg:
        warnings.warn(f"{n_neg} eigenvalue(s) below -{threshold:g} omega^2_max "
                      f"(lowest omega^2 = {w[0]:.3g}, omega^2_max = {w2max:.3g}): D is not "
                      "positive semi-definite; modal propagation will refuse these modes",
                      NegativeModesWarning, stacklevel=2)
    # The file-level keys belong to the file being written, not to this object.
    attrs = {k: v for k, v in system.attrs.items() if k not in FILE_ATTRS}
    attrs.update(
        n_dof=n, n_modes=int(len(w)), partial=partial, solver=solver,
        n_zero_modes=int(zero.sum()), n_negative_modes=n_neg,
        zero_mode_threshold=threshold, omega2_max=w2max,
        min_omega2=float(w[0]), stiffness_asymmetry=asym,
        zero_mode_drift_A=float(np.sum(proj_v[zero] * coupling[zero])),
    )
    if shear_amp_A is not None:
        attrs["shear_zero_mode_drift_A"] = float(np.sum(shear_v[zero] * shear_coupling[zero]))
    return Modes(omega2=omega2, amplitude_A=amp_A, amplitude_B=proj_u, coupling=coupling,
                 vectors=(V / sqrt_m[:, None]) if vectors else None, attrs=attrs,
                 shear_amplitude_A=shear_amp_A, shear_coupling=shear_coupling)
