"""Checks on a stiffness matrix D: symmetry, positive semi-definiteness, zero modes, the top of
its spectrum (docs/linear.md, "Checks on D").

Up to ``DENSE_CHECK_MAX_DOF`` dofs every eigenvalue (dense LAPACK); above, the lowest few by
LOBPCG with an algebraic-multigrid preconditioner (pyamg), at a cost of the order of the
assembly's. ``linearize`` (:mod:`granwave.linear.assemble`) runs :func:`check_stiffness` on every
system it builds.
"""

from __future__ import annotations

import contextlib
import time
import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..model import LinearSystem

#: Relative threshold on omega^2 / omega^2_max below which a mode counts as a zero mode.
ZERO_MODE_THRESHOLD = 1e-10

#: Up to this many dofs the PSD check and zero-mode count use a dense eigenvalue solve.
DENSE_CHECK_MAX_DOF = 3000

#: Lowest eigenvalues computed by shift-invert Lanczos when LOBPCG does not converge.
SPARSE_CHECK_MODES = 12

#: Above DENSE_CHECK_MAX_DOF, LOBPCG computes ``expected_zero_modes`` + this many lowest modes.
CHECK_EXTRA_MODES = 2

#: LOBPCG stops when every residual ||A x - theta x|| <= CHECK_RESIDUAL x omega^2_max (and the
#: lowest non-zero Ritz value's residual is below half of it; :func:`lowest_modes`).
CHECK_RESIDUAL = 1e-6

#: At most this many LOBPCG iterations (one AMG cycle per vector each); 10-30 suffice on lattices.
CHECK_MAXITER = 50

#: ... and this many once a negative mode is proven: with an indefinite A the AMG cycle is no
#: longer positive definite and LOBPCG may stall; the verdict (not PSD) is already in.
NEGATIVE_MAXITER = 15

#: Unpreconditioned LOBPCG steps that look for a strongly negative (isolated) mode first.
PREPASS_ITER = 15

#: Unpreconditioned LOBPCG steps towards the top for omega^2_max (the thresholds' scale).
TOP_ITER = 10

#: An unconverged LOBPCG falls back to shift-invert Lanczos (a sparse LU) up to this many dofs.
SHIFT_INVERT_MAX_DOF = 200_000

#: Seconds between progress lines of the check.
PROGRESS_SECONDS = 5.0


def expected_zero_modes(dim: int, friction: float, spins: int = 0) -> int:
    """Zero modes of an ideal (well-connected) packing between flat walls, plus ``spins``.

    Without friction nothing resists a rigid translation parallel to the
    walls (the lateral directions are periodic and wall contacts have no
    tangential spring): ``dim - 1`` zero modes. With friction the tangential
    wall springs pin everything: none. A 1D chain has none. ``spins``: the
    free spins kept in the dofs (3D with friction, module docstring), one
    zero mode each. Floppy grains of a disordered packing add to this count
    (reported, not expected).
    """
    if dim == 1 or friction > 0.0:
        return int(spins)
    return dim - 1 + int(spins)


def symmetric_part(D: sp.spmatrix) -> sp.csr_matrix:
    """(D + D^T)/2 as CSR."""
    return ((D + D.T) * 0.5).tocsr()


def asymmetry(D: sp.spmatrix) -> float:
    """Relative asymmetry ||D - D^T||_F / ||D||_F."""
    norm = sp.linalg.norm(D)
    return float(sp.linalg.norm(D - D.T) / norm) if norm > 0 else 0.0


def check_stiffness(system: LinearSystem, *, threshold: float = ZERO_MODE_THRESHOLD,
                    dense_max: int | None = None, progress=None) -> dict:
    """Symmetry, positive semi-definiteness and zero modes of D (docs/linear.md, "Checks on D").

    Method: the relative asymmetry ||D - D^T||_F/||D||_F; then the eigenvalues
    of the symmetric part in the mass-weighted form A = M^-1/2 D M^-1/2. Up to
    ``dense_max`` dofs (default ``DENSE_CHECK_MAX_DOF``) all of them (dense
    LAPACK), so the zero-mode count is exact. Above, the lowest few by LOBPCG
    with a smoothed-aggregation AMG preconditioner (:func:`lowest_modes`), at
    a cost of the order of the assembly's; should LOBPCG not converge, systems
    up to ``SHIFT_INVERT_MAX_DOF`` dofs fall back to shift-invert Lanczos
    (``SPARSE_CHECK_MODES`` lowest, or the expected zero modes + ``CHECK_EXTRA_MODES`` when more),
    larger ones report the unconverged Ritz
    values (upper bounds of the eigenvalues, so a negative one is a proven
    negative mode) with ``psd_check_converged`` False; so do systems where the
    unconverged LOBPCG already shows a negative mode (shift-invert near zero
    would miss a strongly negative one). The zero-mode count is a lower bound when all computed modes are
    zero (``n_zero_modes_exact`` False). A mode is zero when |omega^2| <=
    threshold * omega^2_max, negative when omega^2 < -threshold * omega^2_max.

    ``progress`` (a callable taking one line of text) hears, above the dense
    limit, which check runs, its iterations about every 5 s and its duration.
    """
    t0 = time.perf_counter()
    say = progress if progress is not None else (lambda message: None)
    D, mass = system.stiffness, system.mass
    asym = asymmetry(D)
    Ds = symmetric_part(D) if asym > 0 else D
    s = 1.0 / np.sqrt(mass)
    A = (sp.diags(s) @ Ds @ sp.diags(s)).tocsr()
    n = A.shape[0]
    dense_max = DENSE_CHECK_MAX_DOF if dense_max is None else int(dense_max)
    residual, converged = 0.0, True
    if n <= dense_max:
        wmax = omega2_max(A, tol=1e-3)  # only sets the scale of the zero-mode threshold
        from .lapack import dense_eigh

        w = dense_eigh(A, vectors=False)  # in a child process: Ctrl-C and SIGTERM stop it at once
        exact = True
        wmax = max(wmax, float(w[-1]))
        method = "dense eigvalsh"
    else:
        k = max(1, min(int(system.attrs.get("expected_zero_modes", 0)) + CHECK_EXTRA_MODES, n // 5))
        say(f"check D ({n} dofs): the {k} lowest modes by LOBPCG with a smoothed-aggregation "
            "AMG preconditioner")
        with _one_blas_thread():
            res = lowest_modes(A, k, threshold=threshold, block=_node_block(system), progress=say)
        w, wmax, residual, converged = res["omega2"], res["omega2_max"], res["residual"], res["converged"]
        method = f"lobpcg + AMG, {len(w)} lowest"
        proven_negative = bool(np.any(w < -threshold * wmax))  # Ritz values bound eigenvalues from above
        if not converged and not proven_negative and n <= SHIFT_INVERT_MAX_DOF:
            say(f"check D: LOBPCG did not converge ({res['iterations']} iterations); "
                "falling back to shift-invert Lanczos")
            # past every expected zero mode (kept free spins: tens of them in a 3D column)
            k = min(max(SPARSE_CHECK_MODES, int(system.attrs.get("expected_zero_modes", 0))
                        + CHECK_EXTRA_MODES), n - 2)
            w = np.sort(spla.eigsh(A.tocsc(), k=k, sigma=-1e-6 * wmax, which="LM",
                                   return_eigenvectors=False, tol=1e-12))
            method = f"eigsh shift-invert, {len(w)} lowest (lobpcg did not converge)"
            residual, converged = 0.0, True
        elif not converged:
            method += ", not converged"
        exact = False
    tol = threshold * wmax
    n_zero = int(np.sum(np.abs(w) <= tol))
    n_neg = int(np.sum(w < -tol))
    lowest = w[(w > tol)]
    if n > dense_max:
        say(f"check D done in {time.perf_counter() - t0:.1f} s ({method}): "
            f"{n_neg} negative, {n_zero} zero modes, lowest omega^2 {w[0]:.4g}"
            f" = {w[0] / wmax:.3g} omega^2_max" + ("" if converged else " (NOT converged)"))
    return dict(
        asymmetry=asym,
        omega2_max=float(wmax),
        n_zero_modes=n_zero,
        n_zero_modes_exact=bool(exact or (converged and n_zero < len(w))),
        n_negative_modes=n_neg,
        min_omega2=float(w[0]),
        lowest_nonzero_omega2=float(lowest[0]) if len(lowest) else float("nan"),
        zero_mode_threshold=threshold,
        psd_check=method,
        psd_check_converged=bool(converged),
        psd_check_residual=float(residual),
    )


def _one_blas_thread():
    """BLAS on one thread (threadpoolctl, when installed): LOBPCG's dense work is on n x 3k
    blocks, memory-bound, and an idle OpenBLAS thread spins; with other work on the cores,
    a 10^4-dof check took 23.6 s with OpenBLAS's 2 threads against 0.6 s with one."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def _node_block(system: LinearSystem) -> int:
    """Dofs per grain when every grain has the same ones in the same order (else 1)."""
    axis = np.asarray(system.dof_axis)
    p = int(axis.max()) + 1 if len(axis) else 1
    if p > 1 and len(axis) % p == 0 and np.all(axis.reshape(-1, p) == np.arange(p)):
        return p
    return 1


def _amg_preconditioner(A: sp.csr_matrix, block: int, counter: list, progress):
    """A symmetric V-cycle of smoothed-aggregation AMG for A, as a LinearOperator on blocks of vectors.

    Per-grain blocks (BSR) so that the aggregates keep a grain's translations
    and rotations together and the candidates are the uniform translations and
    rotations. Forward Gauss-Seidel before, backward after: the cycle is a
    symmetric operator, positive definite for a positive semi-definite A (the
    zero modes are uniform translations, in the candidates, and reach the
    pseudo-inverse of the coarsest level). Column by column: pyamg's own
    multi-column path is much slower.
    """
    import pyamg

    M = A.tobsr(blocksize=(block, block)) if block > 1 else A
    ml = pyamg.smoothed_aggregation_solver(
        M, max_coarse=300, improve_candidates=None,
        presmoother=("block_gauss_seidel", {"sweep": "forward"}),
        postsmoother=("block_gauss_seidel", {"sweep": "backward"}))
    t0 = time.perf_counter()
    last = [t0]

    def apply(X):
        X = np.asarray(X)
        counter[0] += 1
        now = time.perf_counter()
        if now - last[0] >= PROGRESS_SECONDS:
            last[0] = now
            progress(f"  LOBPCG iteration {counter[0]} ({now - t0:.0f} s)")
        if X.ndim == 1:
            return ml.solve(X, maxiter=1, cycle="V", tol=1e-300)
        return np.column_stack([ml.solve(X[:, j], maxiter=1, cycle="V", tol=1e-300)
                                for j in range(X.shape[1])])

    return spla.LinearOperator(A.shape, matvec=apply, matmat=apply, dtype=float)


def _lobpcg(A, X, **kwargs):
    """scipy's lobpcg, quiet (convergence is judged from the residuals by the caller)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            w, V = spla.lobpcg(A, X, **kwargs)
        except (np.linalg.LinAlgError, ValueError):
            return None
    order = np.argsort(w)
    return w[order], V[:, order]


def lowest_modes(A: sp.csr_matrix, k: int, *, threshold: float = ZERO_MODE_THRESHOLD,
                 block: int = 1, progress=None, seed: int = 0) -> dict:
    """The ``k`` lowest eigenvalues of a large symmetric (mass-weighted) A, at about the cost of
    a few hundred products with A.

    1. omega^2_max (the scale of the zero-mode threshold) by a few unpreconditioned
       LOBPCG steps towards the top (a Ritz value: a lower bound, ample for a scale).
    2. A few unpreconditioned LOBPCG steps towards the bottom: an isolated, strongly
       negative mode (a localized instability) is at the far end of the spectrum,
       where the AMG cycle below damps instead of amplifying; plain LOBPCG finds it
       at once. Its vector seeds the block of step 3.
    3. LOBPCG on the standard form A (the mass is already in it: one matrix for AMG
       to coarsen, no B product per step) with a smoothed-aggregation AMG V-cycle
       as preconditioner, block ``k``, until every residual ||A x - theta x|| is
       below ``CHECK_RESIDUAL`` omega^2_max and that of the lowest non-zero Ritz
       value below half of it, so that an eigenvalue lies in [theta/2, 3 theta/2],
       clear of the zero band (one restart at the tighter tolerance if needed), at
       most ``CHECK_MAXITER`` iterations. AMG is built for A itself, unshifted:
       positive semi-definite in the normal case, and even for an indefinite A the
       V-cycle stays symmetric, which is what LOBPCG needs; the vector seeded from
       step 2 cannot leave the block (the Ritz values never increase). Shifting to
       A + 2|theta| I was tried: it makes the cycle a poor inverse near zero and
       LOBPCG then stalls on the positive modes of the block. Once step 2 proves
       a negative mode, at most ``NEGATIVE_MAXITER`` iterations (an indefinite
       cycle can stall LOBPCG; the verdict is in, the count a lower bound).

    Ritz values are upper bounds of the eigenvalues in order (Cauchy interlacing):
    a negative one proves a negative mode, whether converged or not.

    Returns dict(omega2 (k ascending), omega2_max, residual (max over the block,
    / omega^2_max), converged, iterations).
    """
    say = progress if progress is not None else (lambda message: None)
    n = A.shape[0]
    rng = np.random.default_rng(seed)
    t = time.perf_counter()
    top = _lobpcg(A, rng.standard_normal((n, 1)), largest=True, maxiter=TOP_ITER, tol=1e-4 * gershgorin_bound(A))
    wmax = float(top[0][-1]) if top is not None else gershgorin_bound(A)
    bottom = _lobpcg(A, rng.standard_normal((n, 1)), largest=False, maxiter=PREPASS_ITER, tol=1e-8 * wmax)
    say(f"  omega^2_max ~ {wmax:.4g}, lowest without preconditioner "
        f"{bottom[0][0] if bottom is not None else float('nan'):.4g} ({time.perf_counter() - t:.1f} s)")
    X = rng.standard_normal((n, k))
    maxiter = CHECK_MAXITER
    if bottom is not None:
        X[:, 0] = bottom[1][:, 0]
        if bottom[0][0] < -threshold * wmax:
            maxiter = NEGATIVE_MAXITER
            say(f"  a negative mode already: omega^2 <= {bottom[0][0]:.4g}")
    t = time.perf_counter()
    counter = [0]
    T = _amg_preconditioner(A, block, counter, say)
    say(f"  AMG set up in {time.perf_counter() - t:.1f} s")
    tol = CHECK_RESIDUAL * wmax
    w, r = None, np.full(k, np.inf)
    converged = False
    for _ in range(2):
        out = _lobpcg(A, X, M=T, largest=False, tol=tol, maxiter=max(1, maxiter - counter[0]))
        if out is None:
            break
        w, X = out
        r = np.linalg.norm(A @ X - X * w, axis=0)
        pos = np.flatnonzero(w > threshold * wmax)
        need = max(0.5 * w[pos[0]], threshold * wmax) if len(pos) else np.inf
        converged = bool(np.all(r <= 1.01 * tol) and (not len(pos) or r[pos[0]] <= 1.01 * need))
        if converged or counter[0] >= maxiter or need >= tol:
            break
        tol = need
    if w is None:  # LOBPCG broke down: the best Ritz values at hand (still upper bounds)
        w = bottom[0] if bottom is not None else np.array([np.nan])
    return dict(omega2=w, omega2_max=wmax, residual=float(np.max(r) / wmax), converged=converged,
                iterations=counter[0])


def gershgorin_bound(A: sp.spmatrix) -> float:
    """max_i sum_j |A_ij|: an instant upper bound on the largest eigenvalue of A."""
    return float(np.max(np.asarray(abs(A).sum(axis=1)).ravel(), initial=0.0))


def omega2_max(A: sp.spmatrix, *, tol: float = 1e-6) -> float:
    """Largest eigenvalue of the symmetric mass-weighted matrix A (Lanczos to relative ``tol``).

    Falls back to the Gershgorin bound if Lanczos fails.
    """
    n = A.shape[0]
    gersh = gershgorin_bound(A)
    if n < 3:
        return float(np.max(np.linalg.eigvalsh(A.toarray()))) if n else 0.0
    try:
        w = spla.eigsh(A, k=1, which="LA", return_eigenvectors=False, tol=tol,
                       maxiter=max(1000, 20 * n),
                       v0=np.random.default_rng(0).standard_normal(n))
        return float(w[0])
    except spla.ArpackNoConvergence:
        return gersh
