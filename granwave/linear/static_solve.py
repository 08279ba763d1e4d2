"""The static problem D u = f of a packing's linear model, with some dofs held (docs/method.md §5).

:class:`StaticSolver` solves it for the elastic moduli (:mod:`granwave.linear.moduli`): an imposed
strain, body force or set of displacements is a load ``f`` on the free dofs, the held dofs a
right-hand side of their own.

Without friction rigid lateral translations are zero modes of D. The
systems ``D u = f`` are consistent (f is orthogonal to every zero mode: a
zero mode does not stretch any spring), and the contact forces are the same
for every solution. We solve with a sparse LU factorization of D augmented
by one Lagrange constraint per lateral axis (the mean lateral displacement is
zero), used only when no degree of freedom along that axis is held fixed. If
the factorization fails or its residual is not small against the load
(``||D u - f|| > RESIDUAL_TOL ||f||``: a singular factorization returns a huge
u whose residual is small only against ``|D| ||u||``), we fall back to the
minimum-norm least-squares solution (dense up to ``DENSE_MAX_DOF`` free dofs: for a
symmetric D the pseudo-inverse from one eigendecomposition, reused for every load, else
LAPACK ``gelsd``; LSQR above). From ``SWEEPS_FIRST_DOF`` free dofs the minimum-norm
solution is first sought by iterated Tikhonov regularisation with one sparse LU of
``D + eps I`` (``eps`` = ``REGULARISATION`` times the mean diagonal of D): each sweep
``u += (D + eps I)^-1 (f - D u)`` from u = 0 shrinks the residual on a mode of stiffness
``lambda`` by ``eps / (lambda + eps)`` and adds nothing on the zero modes of a symmetric D.
LSQR, whose convergence goes as the square of the condition number, is used only when the
sweeps do not converge (a load with a part on a floppy mode). ``StaticSolver.unbalanced`` is the
fraction of the load a solution leaves unbalanced, ``||D u - f|| / ||f||``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError

#: Up to this many free dofs the least-squares fallback is a dense LAPACK solve.
DENSE_MAX_DOF = 6000

#: From this many free dofs a singular D is first solved by iterated Tikhonov sweeps, the dense
#: eigendecomposition kept for when they do not converge: the sweeps cost a sparse LU where the
#: eigendecomposition costs n^3 (decision 0020).
SWEEPS_FIRST_DOF = 2000

#: Regularisation of the iterated-Tikhonov solve of large singular systems, relative to the
#: mean diagonal of D, and its largest number of sweeps.
REGULARISATION = 1e-10
TIKHONOV_SWEEPS = 30

#: Relative residual ||D u - f|| / ||f|| accepted from the sparse solve (else least squares).
RESIDUAL_TOL = 1e-8

#: Largest unbalanced fraction ||D u - f|| / ||f|| accepted for a load no floppy mode may
#: absorb (global strains, imposed displacements); body forces only report it.
UNBALANCED_MAX = 1e-6


class StaticSolver:
    """Solves D u = f on the free dofs with the others held at given values.

    Lagrange constraints (zero mean displacement) remove the rigid lateral
    translations when the packing is frictionless and nothing along that axis
    is held. Falls back to minimum-norm least squares (module docstring).
    """

    def __init__(self, cell, fixed: np.ndarray):
        self.cell = cell
        self.fixed = fixed
        self.free = np.flatnonzero(~fixed)
        D = cell.stiffness
        self.D_ff = D[self.free][:, self.free].tocsc()
        self.D_fc = D[self.free][:, np.flatnonzero(fixed)].tocsc()
        cons = []
        if cell.friction <= 0.0:
            for a in range(cell.dim - 1):
                if not np.any(fixed & (cell.dof_axis == a)):
                    cons.append((cell.dof_axis[self.free] == a).astype(float))
        self.n_cons = len(cons)
        self.method = None
        self._lu = None
        self._lu_reg = None
        self._eig = None
        nf = len(self.free)
        if nf == 0:
            return
        if cons:
            C = sp.csc_matrix(np.array(cons).T)
            A = sp.bmat([[self.D_ff, C], [C.T, None]], format="csc")
        else:
            A = self.D_ff
        try:
            self._lu = spla.splu(A.tocsc())
        except RuntimeError:  # exactly singular
            self._lu = None

    def solve(self, rhs_free: np.ndarray, held: np.ndarray | None = None, *,
              consistent: bool = True) -> tuple[np.ndarray, str]:
        """Full dof vector u with u[fixed] = held and D_ff u_f = rhs_free - D_fc held.

        The sparse LU solution is accepted when its residual is small against
        the right-hand side, ||D_ff x - rhs|| <= RESIDUAL_TOL ||rhs|| (a singular
        factorization returns a huge x whose residual is small only against
        |D| ||x||); otherwise the minimum-norm least-squares solution is used.
        ``self.unbalanced`` = ||D_ff x - rhs|| / ||rhs|| of the solution returned:
        the fraction of the load left unbalanced (a load on floppy modes).
        ``consistent=True`` (a load that no floppy mode can absorb: strains,
        imposed displacements) raises when more than ``UNBALANCED_MAX`` is left.
        """
        self.unbalanced = 0.0
        cell = self.cell
        u = np.zeros(cell.n_dof)
        if held is not None and np.any(self.fixed):
            u[self.fixed] = held
            rhs = rhs_free - self.D_fc @ held
        else:
            rhs = np.array(rhs_free, float)
        nf = len(self.free)
        if nf == 0:
            return u, "none"
        method = "sparse LU" + (" + zero-mean constraint" if self.n_cons else "")
        x = None
        if self._lu is not None:
            sol = self._lu.solve(np.concatenate([rhs, np.zeros(self.n_cons)]))
            x = sol[:nf]
            if self._unbalanced(x, rhs) > RESIDUAL_TOL:
                x = None
        if x is None and (nf > DENSE_MAX_DOF or nf >= SWEEPS_FIRST_DOF):
            x = self._tikhonov(rhs)
            method = "iterated Tikhonov (sparse LU of D + eps I) minimum-norm solution"
        if x is None:
            if nf <= DENSE_MAX_DOF and self._symmetric():
                x = self._dense_min_norm(rhs)
                method = "dense minimum-norm least squares (eigendecomposition)"
            elif nf <= DENSE_MAX_DOF:
                x = scipy.linalg.lstsq(self.D_ff.toarray(), rhs, cond=1e-13,
                                       lapack_driver="gelsd", check_finite=False)[0]
                method = "dense minimum-norm least squares (gelsd)"
            else:
                x = spla.lsqr(self.D_ff, rhs, atol=1e-14, btol=1e-14, iter_lim=20 * nf)[0]
                method = "LSQR minimum-norm least squares"
        self.unbalanced = self._unbalanced(x, rhs)
        if consistent and not self.unbalanced <= UNBALANCED_MAX:
            raise InputError("the linear system D u = f could not be solved accurately: "
                             f"{self.unbalanced:.2g} of the load left unbalanced (a load on a "
                             "floppy mode?)")
        u[self.free] = x
        return u, method

    def _symmetric(self) -> bool:
        D = self.D_ff
        return abs(D - D.T).max() <= 1e-12 * abs(D).max()

    def _dense_min_norm(self, rhs: np.ndarray) -> np.ndarray:
        """The minimum-norm least-squares solution from D_ff's eigendecomposition, made once
        per solver and reused for every load (a global response solves three; one eigh costs
        less than one gelsd solve of the same matrix). D_ff is symmetric here, so
        its singular values are |eigenvalues| and dropping |w| <= 1e-13 max|w| is gelsd's
        cond=1e-13."""
        if self._eig is None:
            from .lapack import dense_eigh

            w, V = dense_eigh(self.D_ff)  # in a child process: Ctrl-C and SIGTERM stop it at once
            keep = np.abs(w) > 1e-13 * np.abs(w).max(initial=0.0)
            self._eig = (np.ascontiguousarray(V[:, keep]), 1.0 / w[keep])
        V, inverse = self._eig
        return V @ (inverse * (V.T @ rhs))

    def _tikhonov(self, rhs: np.ndarray) -> np.ndarray | None:
        """Iterated Tikhonov sweeps (module docstring); None unless the residual falls below
        RESIDUAL_TOL of the load within TIKHONOV_SWEEPS sweeps."""
        if self._lu_reg is None:
            D = self.D_ff
            eps = REGULARISATION * float(np.mean(np.abs(D.diagonal())))
            try:
                self._lu_reg = spla.splu((D + eps * sp.identity(D.shape[0], format="csc")).tocsc())
            except RuntimeError:
                self._lu_reg = False
        if self._lu_reg is False:
            return None
        x = np.zeros_like(rhs)
        for _ in range(TIKHONOV_SWEEPS):
            r = rhs - self.D_ff @ x
            x = x + self._lu_reg.solve(r)
            if self._unbalanced(x, rhs) <= RESIDUAL_TOL:
                return x
        return None

    def _unbalanced(self, x, rhs) -> float:
        """||D_ff x - rhs|| / ||rhs|| (inf for a non-finite x; 0 when rhs = 0 = D_ff x)."""
        if not np.all(np.isfinite(x)):
            return float("inf")
        r = float(np.linalg.norm(self.D_ff @ x - rhs))
        nr = float(np.linalg.norm(rhs))
        return r / nr if nr > 0 else (0.0 if r == 0 else float("inf"))
