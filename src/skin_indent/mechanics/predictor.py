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

The first increment has no earlier state: :func:`hertz_start` gives it the linear
response of the undeformed body to Hertz's pressure shape, which puts the contact
edge near its place (2-3 Newton iterations instead of 8-9 from a zero field).

On loading steps, :class:`SurfaceFit` then keeps the contact zone of the last converged
state against the sphere where an extrapolation lifts it off (a layer confined by a
rigid base, whose bulge the extrapolation carries into the sphere).

The interpolation matrix of ``S`` locates each scaled node by walking from its own
triangle towards the origin (:func:`locate`): a few triangles on a graded mesh, and no
k-d tree (``scipy.spatial`` alone took 0.08 s of a 1 s process to import).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import sparse
from skfem import Basis, ElementTriP2


#: Steps of the walk from element to element allowed before the remaining points are
#: located by testing every element (see :func:`locate`).
MAX_WALK = 200


def _barycentric(p, t, elem, points):
    """Barycentric coordinates (3, n) of ``points`` (2, n) in the triangles ``elem`` (n,)."""
    x0, x1, x2 = (p[:, t[i, elem]] for i in range(3))
    det = (x1[0] - x0[0]) * (x2[1] - x0[1]) - (x2[0] - x0[0]) * (x1[1] - x0[1])
    dx, dy = points[0] - x0[0], points[1] - x0[1]
    l1 = (dx * (x2[1] - x0[1]) - dy * (x2[0] - x0[0])) / det
    l2 = ((x1[0] - x0[0]) * dy - (x1[1] - x0[1]) * dx) / det
    return np.stack([1.0 - l1 - l2, l1, l2])


def locate(mesh, points: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangles holding ``points`` (2, n) and the points' barycentric coordinates (3, n).

    A walk from each ``start`` triangle (n,) to the neighbour across the edge of the most
    negative barycentric coordinate, all points at once; a point outside the mesh gets the
    boundary triangle where its walk ends, with clipped coordinates (the nearest point of
    the mesh, roughly). Points still walking after :data:`MAX_WALK` steps are located by
    testing every triangle.
    """
    p, t = mesh.p, mesh.t
    # the neighbour across the edge opposite vertex i: edges are (0,1), (1,2), (0,2) in t2f
    f2t = mesh.f2t
    facet = mesh.t2f[[1, 2, 0]]  # (3, nt): the facet opposite vertex i
    elem = np.asarray(start, dtype=np.int64).copy()
    lam = _barycentric(p, t, elem, points)
    todo = np.flatnonzero(lam.min(axis=0) < -1e-12)
    for _ in range(MAX_WALK):
        if todo.size == 0:
            break
        worst = np.argmin(lam[:, todo], axis=0)
        f = facet[worst, elem[todo]]
        a, b = f2t[0, f], f2t[1, f]
        nxt = np.where(a == elem[todo], b, a)
        stuck = nxt < 0  # the walk leaves the mesh: the point is outside, keep this triangle
        elem[todo[~stuck]] = nxt[~stuck]
        lam[:, todo] = _barycentric(p, t, elem[todo], points[:, todo])
        todo = todo[~stuck]
        todo = todo[lam[:, todo].min(axis=0) < -1e-12]
    for k in todo:  # the walk cycled (a badly shaped triangulation): test every triangle
        every = _barycentric(p, t, np.arange(t.shape[1]), np.repeat(points[:, k : k + 1], t.shape[1], axis=1))
        elem[k] = int(np.argmax(every.min(axis=0)))
        lam[:, k] = every[:, elem[k]]
    lam = np.clip(lam, 0.0, 1.0)
    return elem, lam / lam.sum(axis=0)


def p2_interpolation_matrix(mesh, points: np.ndarray, start: np.ndarray) -> sparse.csr_matrix:
    """Matrix mapping P2 nodal values (scikit-fem order) to values at ``points`` (2, n).

    The points are located by :func:`locate`, walking from the triangles ``start`` (n,)
    (e.g. triangles near each point); a point outside the mesh gets the nearest
    boundary triangle's values at clipped barycentric coordinates.
    """
    basis = Basis(mesh, ElementTriP2(), intorder=1)
    elem, lam = locate(mesh, points, start)
    rows = np.arange(points.shape[1])
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
        # each node's image lies a few triangles towards the origin: walk there from its own triangle
        own = np.empty(scalar.N, dtype=np.int64)
        own[scalar.element_dofs] = np.arange(mesh.t.shape[1])
        self.P = p2_interpolation_matrix(mesh, scalar.doflocs / np.sqrt(self.ratio), own)
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


def hertz_start(problem, depth_mm: float) -> np.ndarray:
    r"""First iterate of the first increment (from the undeformed body) at ``depth_mm``.

    A zero first iterate lets every surface point within the geometric intersection
    radius :math:`\sqrt{2 R h}` penetrate, twice the contact area of Hertz's solution,
    and Newton then spends 8-9 line-searched iterations finding the contact edge. This
    iterate is instead the linear response of the undeformed body (its tangent) to
    Hertz's pressure shape :math:`\sqrt{1 - r^2/a^2}` on :math:`r < a = \sqrt{R h}`,
    scaled so that the surface on the axis sits at the sphere's tip (a homogeneous
    body, for which the shape is Hertz's), or, for a body of several materials
    (layers), to fit the sphere over :math:`r < a` in the least-squares sense over the
    facet quadrature points (measured on the default mesh: 2-3 Newton iterations
    instead of 8-9 for a half-space; 4 instead of 9 for a stiff layer on a soft one).
    The amplitude does not need the material's moduli.
    The factorisation of the undeformed tangent stays in the problem's linear solver
    (it preconditions the first Newton iterations).

    Parameters
    ----------
    problem : IndentationProblem
    depth_mm : float
        Depth of the first increment, mm (> 0).

    Returns
    -------
    ndarray
        Displacement field (mm), zero on the Dirichlet dofs.
    """
    solid, contact, free = problem.solid, problem.contact, problem.free
    u = np.zeros(solid.n_dofs)
    a = np.sqrt(problem.indenter.radius_mm * depth_mm)
    r = contact.X[0]  # (nf, nq) reference radius of the facet quadrature points
    p = np.sqrt(np.maximum(1.0 - (r / a) ** 2, 0.0))  # pressure shape
    vertical = contact.comp == 1
    # nodal forces of a downward traction p on the body: f_a = -int N_a p dA (u_z dofs)
    fe = -np.einsum("keq,eq->ke", contact.N[vertical], p * contact.dA)
    f = np.bincount(contact.element_dofs[vertical].ravel(), weights=fe.ravel(), minlength=u.size)
    solid.forces(u, tangent=False)
    K = problem.pattern.assemble([(solid.element_dofs, solid.tangent(u))])
    u[free] = problem.linear_solver.solve(K, f[free])
    tip = problem.axis_top_dof
    if len(solid.regions) == 1:
        return u * (-depth_mm / u[tip]) if np.isfinite(u[tip]) and u[tip] < 0 else np.zeros_like(u)
    # u_z at the facet quadrature points, and the sphere's surface there
    uz = np.einsum("keq,ke->eq", contact.N[vertical], u[contact.element_dofs[vertical]])
    inside = r < a
    z_sphere = problem.indenter.surface_z(r[inside], depth_mm)
    w = contact.dA[inside] * uz[inside]
    scale = float(np.sum(w * z_sphere) / np.sum(w * uz[inside])) if np.any(inside) else np.nan
    if not (np.isfinite(scale) and scale > 0):
        return np.zeros_like(u)
    return u * scale


class SurfaceFit:
    r"""Keep the contact zone of a predicted state against the sphere.

    Under monotonic frictionless loading the contact zone only grows, but an
    extrapolated first iterate (linear in depth, or the self-similar map on a body
    that is not self-similar) can lift part of it off the sphere: on a 1 mm layer on
    a rigid base, where the confined layer bulges around the sphere, the first
    iterate touched the sphere at 16-94 of the 87-140 contact points of the converged
    state. Newton's first step then sees no contact stiffness there, pushes the
    bulge into the sphere, and line-searched steps of a few thousandths follow while
    the contact zone is found again, 30-40 points per iteration (measured, default
    mesh: 140 Newton iterations, 7 step cuts and 50 factorisations per curve; 63, 1
    and 25 with this correction).

    On a loading step from the converged state at depth :math:`h` to :math:`h' > h`,
    each surface node inside the sphere at :math:`h` (vertical penetration
    :math:`p_c > 0`) that the prediction puts outside it is moved up to the
    penetration :math:`p_c h'/h`. The vertical corrections are carried into the body
    with the decay :math:`\exp(Z / a)` below the surface (:math:`Z \le 0` the
    reference depth, :math:`a = \sqrt{R h'}`), so the top elements are not distorted;
    predictions that keep the contact zone are not changed (a homogeneous half-space
    with the self-similar map). Penetrations are not clipped: a prediction pushed out
    of the sphere where it penetrates too deep cost a nearly incompressible body
    (nu = 0.499) 50 % more Newton iterations.

    Parameters
    ----------
    solid : AxisymmetricSolid
        The body (its vector P2 basis defines the dof layout; the surface is ``top``).
    indenter : SphericalIndenter
    free : ndarray of bool
        Free dofs; the Dirichlet dofs are not corrected.
    small_strain : bool
        Linearised contact kinematics: the gap is measured at the reference radius.
    """

    def __init__(self, solid, indenter, free: np.ndarray, small_strain: bool = False):
        b = solid.basis
        top = b.get_dofs("top")
        ur, uz = top.all("u^1"), top.all("u^2")
        order = np.argsort(b.doflocs[0, ur])
        self._top_r, self._top_z = ur[order], uz[order]
        self._r0 = b.doflocs[0, self._top_r]
        self._indenter = indenter
        self._small_strain = small_strain
        uz = np.r_[b.nodal_dofs[1], b.facet_dofs[1]]
        self._uz = uz[free[uz]]  # every free u_z dof
        self._X = b.doflocs[:, self._uz]

    def _penetration(self, u: np.ndarray, depth: float) -> np.ndarray:
        """Vertical distance (mm) of each surface node inside the sphere at ``depth`` (< 0 outside)."""
        r = self._r0 if self._small_strain else self._r0 + u[self._top_r]
        return np.where(r < self._indenter.radius_mm, u[self._top_z] - self._indenter.surface_z(r, depth), -np.inf)

    def __call__(self, trial: np.ndarray, u: np.ndarray, depth: float, new_depth: float) -> np.ndarray:
        """Correct ``trial`` (the prediction at ``new_depth`` mm, modified in place) from the
        converged state ``u`` at ``depth`` mm; returns ``trial``."""
        if not 0 < depth < new_depth:
            return trial
        scale = new_depth / depth
        before = np.maximum(self._penetration(u, depth), 0.0)
        if not np.any(before > 0):
            return trial
        pen = self._penetration(trial, new_depth)
        lifted = (before > 0) & np.isfinite(pen) & (pen < 0)
        if not np.any(lifted):
            return trial
        delta = np.where(lifted, scale * before - pen, 0.0)
        a = math.sqrt(self._indenter.radius_mm * new_depth)
        r, z = self._X
        trial[self._uz] += np.interp(r, self._r0, delta, right=0.0) * np.exp(np.minimum(z, 0.0) / a)
        return trial
