r"""Frictionless penalty contact between a rigid sphere and the free surface.

The sphere of radius R has its lowest point at depth h below the undeformed
surface: centre :math:`c = (0, R - h)`. For a surface point with current position
:math:`x = X + u` the gap is :math:`g = |x - c| - R` and the outward normal of the
sphere :math:`n = (x - c)/|x - c|`. The penalty energy

.. math::

    \Pi_c = \frac{\epsilon}{2} \int_{\Gamma_0} \langle -g \rangle^2 \, 2\pi r\, dS

is integrated with Gauss quadrature on the quadratic surface facets (not node
by node), so the force-depth curve is smooth. The contact pressure is
:math:`p = \epsilon \langle -g \rangle` (kPa), the force on the sphere
:math:`F = \int p\,(-n_z)\, dA` (mN), and the consistent tangent is

.. math::

    K_c = \epsilon \int \left[ H(-g)\, n \otimes n
          - \frac{\langle -g \rangle}{|x - c|} (I - n \otimes n) \right] N_a N_b \, dA .

The penalty is ``epsilon = penalty * E_ref / a`` (kPa/mm), with ``E_ref`` the
material's reference modulus and ``a`` the design contact radius, so the force
is exactly proportional to the moduli at fixed Poisson's ratio.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skfem import ElementTriP2, ElementVector, FacetBasis


@dataclass(frozen=True)
class SphericalIndenter:
    """A rigid sphere.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R, mm (the paper: 6.22 mm).
    """

    radius_mm: float = 6.22

    def __post_init__(self):
        r = self.radius_mm
        if not (isinstance(r, (int, float, np.floating)) and np.isfinite(r) and r > 0):
            raise ValueError(f"sphere radius must be a finite number > 0 mm, got {r!r}")


@dataclass
class ContactState:
    """Contact quantities at the surface quadrature points of one state."""

    force_mN: float
    pressure_kPa: np.ndarray
    max_penetration_mm: float
    n_active: int


class SphereContact:
    """Penalty contact of a :class:`SphericalIndenter` with the top surface.

    Parameters
    ----------
    mesh : skfem.MeshTri
        The body's mesh with a boundary named ``top``.
    indenter : SphericalIndenter
    max_depth_mm : float
        Largest depth; only surface facets that can touch the sphere are integrated.
    penalty_per_area_kPa_per_mm : float
        The penalty stiffness epsilon (kPa/mm).
    element : skfem element, optional
        Scalar element of the displacement field (default P2).
    intorder : int
        Facet quadrature order (default 7: four Gauss points per facet).
    small_strain : bool
        Linearised contact, as in Hertz's and Sneddon's solutions: the gap is
        measured vertically at the undeformed radius, ``g = z_s(X_r) - X_z - u_z``
        with the sphere's surface ``z_s(r) = R - h - sqrt(R^2 - r^2)``, and the
        pressure acts vertically. Used with small-strain materials.
    """

    def __init__(self, mesh, indenter: SphericalIndenter, max_depth_mm: float, penalty_per_area_kPa_per_mm: float,
                 element=None, intorder: int = 7, small_strain: bool = False):
        R = indenter.radius_mm
        self.indenter = indenter
        self.epsilon = float(penalty_per_area_kPa_per_mm)
        # facets that can come into contact: beyond the geometric reach of the sphere
        # the surface is never touched (margin for the surface sinking in).
        reach = np.sqrt(2.0 * R * max_depth_mm) * 1.6 + 1e-12
        top = mesh.boundaries["top"]
        mid_r = mesh.p[0, mesh.facets[:, top]].mean(axis=0)
        facets = top[mid_r < reach]
        self.basis = FacetBasis(mesh, ElementVector(element or ElementTriP2()), facets=facets, intorder=intorder)
        b = self.basis
        self.element_dofs = b.element_dofs  # (12, nf)
        X = np.asarray(b.global_coordinates())  # (2, nf, nq)
        self.X = X
        self.dA = 2.0 * np.pi * X[0] * b.dx  # (nf, nq)
        nloc = self.element_dofs.shape[0]
        N = np.zeros((nloc,) + X.shape[1:])
        comp = np.zeros(nloc, dtype=int)
        for k in range(nloc):
            v = np.asarray(b.basis[k][0])  # (2, nf, nq)
            comp[k] = 0 if np.any(v[0]) else 1
            N[k] = v[comp[k]]
        self.N = N
        self.comp = comp
        self.reach_mm = reach
        self.small_strain = small_strain

    def _kinematics(self, u, depth):
        """Normal, distance to the centre (inf when linearised) and gap at the facet quadrature points."""
        R = self.indenter.radius_mm
        ue = u[self.element_dofs]  # (nloc, nf)
        x = self.X.copy()
        for c in (0, 1) if not self.small_strain else (1,):
            x[c] += np.einsum("keq,ke->eq", self.N[self.comp == c], ue[self.comp == c])
        if self.small_strain:
            z_sphere = (R - depth) - np.sqrt(np.maximum(R**2 - x[0] ** 2, 0.0))
            n = np.zeros_like(x)
            n[1] = -1.0
            return n, np.full(x.shape[1:], np.inf), z_sphere - x[1]
        d = x - np.array([0.0, R - depth])[:, None, None]
        dist = np.sqrt(d[0] ** 2 + d[1] ** 2)
        n = d / dist
        gap = dist - R
        return n, dist, gap

    def state(self, u: np.ndarray, depth: float) -> ContactState:
        """Force on the sphere (mN), pressure at the quadrature points (kPa), penetration."""
        n, _, gap = self._kinematics(u, depth)
        pen = np.maximum(-gap, 0.0)
        p = self.epsilon * pen
        force = float(np.sum(p * (-n[1]) * self.dA))
        return ContactState(force, p, float(pen.max(initial=0.0)), int(np.count_nonzero(pen)))

    def energy(self, u: np.ndarray, depth: float) -> float:
        """Penalty energy (mN mm)."""
        _, _, gap = self._kinematics(u, depth)
        return float(0.5 * self.epsilon * np.sum(np.maximum(-gap, 0.0) ** 2 * self.dA))

    def forces(self, u: np.ndarray, depth: float, tangent: bool = True):
        """Contact force vector (mN, the gradient of the penalty energy) and facet tangents.

        Returns
        -------
        f : ndarray, shape (n_dofs,)
        Ke : ndarray, shape (nf, nloc, nloc), or None
        force : float
            Force on the sphere, mN.
        """
        n, dist, gap = self._kinematics(u, depth)
        pen = np.maximum(-gap, 0.0)
        p = self.epsilon * pen
        Nn = self.N * n[self.comp]  # (nloc, nf, nq): N_a n_{i(a)}
        fe = -np.einsum("keq,eq,eq->ke", Nn, p, self.dA)
        f = np.bincount(self.element_dofs.ravel(), weights=fe.ravel(), minlength=u.size)
        force = float(np.sum(p * (-n[1]) * self.dA))
        if not tangent:
            return f, None, force
        active = (pen > 0).astype(float)
        w1 = self.epsilon * active * self.dA
        w2 = p / dist * self.dA
        same = (self.comp[:, None] == self.comp[None, :]).astype(float)  # delta_ij
        Ke = np.einsum("keq,leq,eq->ekl", Nn, Nn, w1 + w2) - np.einsum(
            "kl,keq,leq,eq->ekl", same, self.N, self.N, w2
        )
        return f, Ke, force
