r"""Predictors for the first Newton iterate of an increment.

For a sphere on an elastic half-space the small-strain (Hertz) displacement field
is self-similar: :math:`u(X; h) = h\, U(X / a)` with :math:`a = \sqrt{R h}`. Going
from depth :math:`h_n` to :math:`h_{n+1} = q h_n`, the map

.. math::

    (S u)(X) = q\, u\!\left(X / \sqrt{q}\right)

therefore moves the edge of the contact zone to where it will be, which a linear
extrapolation in depth cannot do. :class:`SimilarityPredictor` applies
``S u_n + (u_n - S u_{n-1})`` (the second term carries the large-strain and
finite-domain departures from self-similarity over from the last increment);
with geometrically spaced depths ``q`` is constant, so the interpolation matrix
of ``S`` is built once.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree
from skfem import Basis, ElementTriP2


def p2_interpolation_matrix(mesh, points: np.ndarray, candidates: int = 12) -> sparse.csr_matrix:
    """Matrix mapping P2 nodal values (scikit-fem order) to values at ``points`` (2, n).

    Points are located with a k-d tree of element centroids and barycentric
    coordinates; a point outside every candidate element gets the nearest one
    (clipped barycentric coordinates).
    """
    p, t = mesh.p, mesh.t
    basis = Basis(mesh, ElementTriP2(), intorder=1)
    centroids = p[:, t].mean(axis=1).T
    _, cand = cKDTree(centroids).query(points.T, k=min(candidates, t.shape[1]))
    x0, x1, x2 = (p[:, t[i]][:, cand] for i in range(3))  # (2, n, k)
    det = (x1[0] - x0[0]) * (x2[1] - x0[1]) - (x2[0] - x0[0]) * (x1[1] - x0[1])
    dx = points[0][:, None] - x0[0]
    dy = points[1][:, None] - x0[1]
    l1 = (dx * (x2[1] - x0[1]) - dy * (x2[0] - x0[0])) / det
    l2 = ((x1[0] - x0[0]) * dy - (x1[1] - x0[1]) * dx) / det
    l0 = 1.0 - l1 - l2
    outside = np.maximum(0.0, -np.minimum(np.minimum(l0, l1), l2))
    best = np.argmin(outside, axis=1)
    rows = np.arange(points.shape[1])
    lam = np.clip(np.stack([l0[rows, best], l1[rows, best], l2[rows, best]]), 0.0, 1.0)
    lam /= lam.sum(axis=0)
    elem = cand[rows, best]
    # P2 shape functions: vertices l_i (2 l_i - 1), edges (0,1), (1,2), (0,2): 4 l_i l_j
    N = np.stack([
        lam[0] * (2 * lam[0] - 1), lam[1] * (2 * lam[1] - 1), lam[2] * (2 * lam[2] - 1),
        4 * lam[0] * lam[1], 4 * lam[1] * lam[2], 4 * lam[0] * lam[2],
    ])
    cols = basis.element_dofs[:, elem]
    return sparse.csr_matrix((N.ravel(), (np.tile(rows, 6), cols.ravel())), shape=(points.shape[1], basis.N))


class SimilarityPredictor:
    """Predict the displacement at depth ``q h`` from the states at ``h`` and ``h / q``.

    Parameters
    ----------
    solid : AxisymmetricSolid
        The body (its vector P2 basis defines the dof layout).
    ratio : float
        Depth ratio ``q > 1`` between consecutive increments.
    free : ndarray of bool
        Free dofs; Dirichlet dofs of the prediction are set to zero.
    """

    def __init__(self, solid, ratio: float, free: np.ndarray):
        mesh = solid.basis.mesh
        vb = solid.basis
        self.ratio = float(ratio)
        scalar = Basis(mesh, ElementTriP2(), intorder=1)
        self.P = p2_interpolation_matrix(mesh, scalar.doflocs / np.sqrt(self.ratio))
        self.comp = [np.r_[vb.nodal_dofs[c], vb.facet_dofs[c]] for c in (0, 1)]
        self.free = free

    def scale(self, u: np.ndarray) -> np.ndarray:
        """``S u``: the self-similar image of ``u`` one increment deeper."""
        out = np.zeros_like(u)
        for c in self.comp:
            out[c] = self.ratio * (self.P @ u[c])
        out[~self.free] = 0.0
        return out

    def __call__(self, u: np.ndarray, u_previous: np.ndarray | None) -> np.ndarray:
        trial = self.scale(u)
        if u_previous is not None:
            trial += u - self.scale(u_previous)
        return trial
