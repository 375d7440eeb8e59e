"""Sparse linear solves for Newton's method, reusing factorisations.

Consecutive tangents of an incremental solution differ little, so the LU
factorisation of an earlier tangent is an excellent preconditioner for the
current one: :class:`TangentSolver` first tries conjugate gradients
preconditioned with the stored factorisation (a few triangular solves), and
refactorises with SuperLU only when that does not converge quickly. Tangents
that are not symmetric (frictional slip) use GMRES and a general LU instead.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.linalg import LinearOperator, cg, gmres, splu


class TangentSolver:
    """Solve ``K x = b`` for a sequence of similar symmetric tangents ``K``.

    Parameters
    ----------
    rtol : float
        Relative residual required of the preconditioned CG solution.
    max_cg : int
        CG iterations allowed before the tangent is refactorised.
    symmetric : bool
        False for tangents that may be non-symmetric: then GMRES (restarted
        after ``max_cg`` iterations, one cycle) and an LU with partial pivoting.
    stale_after : int, optional
        When a preconditioned solve needed more than this many applications of the
        stored factorisation, the next solve refactorises at once (default None:
        only when the Krylov method fails within ``max_cg`` iterations).

    Attributes
    ----------
    factorisations, cg_solves, preconditioner_applications : int
        Counters: LU factorisations, successful preconditioned Krylov solves, and
        triangular solves with a stored factorisation inside them.
    """

    def __init__(self, rtol: float = 1e-10, max_cg: int = 12, symmetric: bool = True, stale_after: int | None = None):
        self.rtol = rtol
        self.max_cg = max_cg
        self.symmetric = symmetric
        self.stale_after = stale_after
        self._stale = False
        self._lu = None
        self.factorisations = 0
        self.cg_solves = 0
        self.preconditioner_applications = 0

    def _apply_lu(self, b):
        self.preconditioner_applications += 1
        return self._lu.solve(b)

    def _factorise(self, K):
        if not self.symmetric:
            self._lu = splu(K.tocsc(), permc_spec="COLAMD")
            self.factorisations += 1
            return
        self._lu = splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                        options={"SymmetricMode": True})
        self.factorisations += 1

    def solve(self, K, b: np.ndarray, rtol: float | None = None) -> np.ndarray:
        """Solution of ``K x = b``; raises ``RuntimeError`` if K is singular.

        ``rtol`` overrides the CG tolerance for this solve (an inexact Newton
        method needs only a loose solve while its own residual is large).
        """
        if self._lu is not None and not self._stale:
            M = LinearOperator(K.shape, matvec=self._apply_lu, dtype=float)
            before = self.preconditioner_applications
            if self.symmetric:
                x, info = cg(K, b, rtol=self.rtol if rtol is None else rtol, atol=0.0, maxiter=self.max_cg, M=M)
            else:
                x, info = gmres(K, b, rtol=self.rtol if rtol is None else rtol, atol=0.0, restart=self.max_cg,
                                maxiter=1, M=M)
            if info == 0 and np.all(np.isfinite(x)):
                self.cg_solves += 1
                # a slow solve: the stored factorisation has aged, replace it at the next solve
                slow = self.preconditioner_applications - before
                self._stale = self.stale_after is not None and slow > self.stale_after
                return x
        self._factorise(K)
        self._stale = False
        return self._lu.solve(b)
