r"""Penalty contact between a rigid sphere and the free surface: frictionless, or with friction and adhesion.

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
is exactly proportional to the moduli at fixed Poisson's ratio. Layers squeezed
against a rigid base are far stiffer than a half-space: there the frictionless
penalty is multiplied by a factor of the depth (:attr:`SphereContact.penalty_scale`,
see :class:`~skin_indent.mechanics.layers.ConfinedPenalty`).

Interface laws (:class:`~skin_indent.mechanics.contact_law.ContactLaw`)
-----------------------------------------------------------------------
The default law is the frictionless, non-adhesive penalty above, evaluated by
exactly the code it always was. Two options add physics, still integrated at the
facet quadrature points:

**Adhesion** (work of adhesion ``w``, range ``delta``). An attractive pressure is
added to the penalty pressure,

.. math::

    p(g) = \epsilon\langle -g\rangle + p_a(g),\qquad
    p_a(g) = -\frac{w}{\delta}\begin{cases} e^{-g/\delta} & g \ge 0\\ 1 & g < 0\end{cases}

so the interaction energy per unit reference area is
:math:`\phi(g) = \frac{\epsilon}{2}\langle -g\rangle^2 - w\,e^{-g/\delta}` for
:math:`g \ge 0` (:math:`-w + w g/\delta` for :math:`g < 0`): separating the
surfaces from contact costs exactly ``w`` per unit area (JKR/DMT). Its consistent
tangent is :math:`dp/dg = -\epsilon H(-g) + (w/\delta^2) e^{-g/\delta} H(g)`; the
second (negative-stiffness) term can make the tangent indefinite far from
equilibrium (the sphere moving away from a contact puts the whole contact zone in
the attractive tail; first touch): when the consistent tangent does not give a
descent direction of the energy, the solver retries the Newton step with the
tangent without it (``forces(..., tangent="convex")``, positive definite), and
the line search finds the adhered state.
``w`` is given in mJ/m^2 = 1e-3 N/m = 1e-3 mN/mm. The Tabor parameter
:math:`\mu_T = (R w^2 / (E^{*2}\delta^3))^{1/3}` says which classical limit applies:
JKR (pull-off :math:`\tfrac32\pi w R`) for :math:`\mu_T \gg 1`, DMT
(:math:`2\pi w R`) for :math:`\mu_T \ll 1`. The cohesive zone at the contact edge
is about :math:`0.4\,a_0/\mu_T^2` long (``a0`` the JKR contact radius at zero load):
the surface mesh must resolve it, so ``delta`` is a regularisation length, far
larger than molecular ranges.

**Coulomb friction** (coefficient ``mu``), a regularised penalty with a return
mapping. The sphere is rigid and moves only vertically, so a material point of
the sphere is labelled by its polar angle :math:`\theta = \operatorname{atan2}(d_r, -d_z)`,
:math:`d = x - c`, and the tangential slip coordinate of a skin point is the arc
length :math:`s = R\theta` of its projection onto the sphere (small-strain mode:
:math:`s = u_r`, the sphere surface does not move radially). With the
tangential traction variable ``q`` (kPa) and slip coordinate ``s_n`` committed at
the last converged state (per quadrature point),

.. math::

    q^{tr} = q_n + \epsilon_T (s - s_n),\qquad
    q = \begin{cases} q^{tr} & |q^{tr}| \le \mu p_c \quad\text{(stick)}\\
        \mu p_c\, \operatorname{sign} q^{tr} & \text{otherwise (slip)}\end{cases}

with the repulsive (penalty) pressure :math:`p_c = \epsilon\langle -g\rangle` as the
friction bound (a point out of contact carries no friction). The contact force
vector and its tangent (per quadrature point, :math:`\kappa = R/|d|`,
:math:`\tau = (-n_z, n_r) = \partial n/\partial\theta`) are

.. math::

    f_a = \int N_a\,\bigl[-p\,n + q\,\kappa\,\tau\bigr]\,dA,\qquad
    K_{ab} = \int N_a N_b \Bigl[-\frac{dp}{dg}\, n\otimes n - \frac{p}{|d|}(I - n\otimes n)
        + \kappa\,\tau\otimes\frac{\partial q}{\partial x}
        - \frac{q R}{|d|^2}(n\otimes\tau + \tau\otimes n)\Bigr] dA,

:math:`\partial q/\partial x = \epsilon_T\kappa\tau` when sticking and
:math:`\mu\,\operatorname{sign}(q^{tr})\,(dp_c/dg)\, n` when slipping: the slip
tangent is not symmetric (:attr:`SphereContact.symmetric_tangent` tells the
solver). The force on the sphere is the vertical resultant
:math:`F = \int (-p\,n_z + q\,\kappa\,\tau_z)\,dA`. The history (``q_n, s_n``)
changes only in :meth:`SphereContact.commit`, after an increment converged.
``eps_T = tangential_penalty * epsilon``. A point that touches the sphere during an
increment is loaded by its slip over the whole increment (its stick point is its
position at the start of the increment), so the stick force converges to the
continuum one at first order in the increment size (tests/test_friction.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact_law import ContactLaw, SphericalIndenter


@dataclass
class ContactState:
    """Contact quantities at the surface quadrature points of one state.

    ``pressure_kPa`` is the normal pressure (negative where adhesion pulls),
    ``shear_kPa`` the tangential traction variable q (None without friction),
    ``n_active`` the number of quadrature points penetrating the sphere.
    """

    force_mN: float
    pressure_kPa: np.ndarray
    max_penetration_mm: float
    n_active: int
    shear_kPa: np.ndarray | None = None


class SphereContact:
    """Penalty contact of a :class:`~skin_indent.mechanics.contact_law.SphericalIndenter` with the top surface.

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
    law : ContactLaw, optional
        Friction and adhesion (default: frictionless, non-adhesive).

    Notes
    -----
    With friction the contact keeps a history per quadrature point, like a
    history-dependent material: :meth:`begin_step` before an increment,
    :meth:`commit` once it converged (a failed, cut increment leaves the
    committed history intact). The history is not reset between solves.
    """

    def __init__(self, mesh, indenter: SphericalIndenter, max_depth_mm: float, penalty_per_area_kPa_per_mm: float,
                 element=None, intorder: int = 7, small_strain: bool = False, law: ContactLaw | None = None):
        R = indenter.radius_mm
        self.indenter = indenter
        self.epsilon = float(penalty_per_area_kPa_per_mm)
        self.law = ContactLaw() if law is None else law
        if not isinstance(self.law, ContactLaw):
            raise ValueError(f"contact must be a ContactLaw, got {type(self.law).__name__}")
        # facets that can come into contact: beyond the geometric reach of the sphere
        # the surface is never touched (margin for the surface sinking in).
        reach = np.sqrt(2.0 * R * max_depth_mm) * 1.6 + 1e-12
        if self.law.adhesive:
            # adhesion enlarges the contact and pulls the surface up beyond it: take the
            # whole surface under the sphere (far from it the attraction vanishes)
            reach = max(reach, R)
        top = mesh.boundaries["top"]
        mid_r = mesh.p[0, mesh.facets[:, top]].mean(axis=0)
        facets = top[mid_r < reach]
        from skfem import ElementTriP2, ElementVector, FacetBasis  # here: the sphere's data need no scikit-fem

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
        # interface law: the default keeps the original code path (bitwise)
        self._plain = not (self.law.frictional or self.law.adhesive)
        self.work_mN_per_mm = self.law.work_of_adhesion_mN_per_mm
        self.range_mm = self.law.range_mm(max_depth_mm)
        self.mu = float(self.law.friction)
        self.epsilon_t = self.law.tangential_penalty * self.epsilon
        #: False when the tangent may be non-symmetric (friction).
        self.symmetric_tangent = not self.law.frictional
        #: Optional factor of ``epsilon`` as a function of the depth (mm), for the frictionless,
        #: non-adhesive law only (:meth:`penalty`); None: 1.
        self.penalty_scale = None
        #: True when ``forces(..., tangent="convex")`` gives a different, positive-definite
        #: tangent for Newton steps that the consistent one does not make descend (adhesion).
        self.convex_fallback = self.law.adhesive
        # committed friction history per quadrature point (see begin_step / commit)
        self._q = np.zeros(X.shape[1:])  # tangential traction q_n, kPa
        self._s = np.zeros(X.shape[1:])  # slip coordinate s_n, mm
        self._initialised = False

    @property
    def path_independent(self) -> bool:
        return self.law.path_independent

    def penalty(self, depth: float) -> float:
        """The penalty per area at ``depth`` (mm), kPa/mm: ``epsilon`` times :attr:`penalty_scale`
        (frictionless, non-adhesive contact; with friction or adhesion always ``epsilon``)."""
        if self.penalty_scale is None or not self._plain:
            return self.epsilon
        return self.epsilon * self.penalty_scale(depth)

    def _kinematics(self, u, depth):
        """Normal, distance to the centre (inf when linearised) and gap at the facet quadrature points."""
        R = self.indenter.radius_mm
        ue = u[self.element_dofs]  # (nloc, nf)
        x = self.X.copy()
        for c in (0, 1) if not self.small_strain else (1,):
            x[c] += np.einsum("keq,ke->eq", self.N[self.comp == c], ue[self.comp == c])
        if self.small_strain:
            z_sphere = self.indenter.surface_z(x[0], depth)
            n = np.zeros_like(x)
            n[1] = -1.0
            return n, np.full(x.shape[1:], np.inf), z_sphere - x[1]
        d = x - np.array([0.0, R - depth])[:, None, None]
        dist = np.sqrt(d[0] ** 2 + d[1] ** 2)
        n = d / dist
        gap = dist - R
        return n, dist, gap

    # -- interface law -------------------------------------------------------------
    def _normal_law(self, gap, consistent=True):
        """Normal pressure p (kPa, compressive > 0), dp/dg (kPa/mm) and the repulsive part p_c.

        ``consistent=False`` leaves the negative stiffness of the attractive tail out of dp/dg.
        """
        pen = np.maximum(-gap, 0.0)
        p_c = self.epsilon * pen
        dp = -self.epsilon * (pen > 0)
        p = p_c
        if self.law.adhesive:
            w, delta = self.work_mN_per_mm, self.range_mm
            e = np.exp(-np.maximum(gap, 0.0) / delta)
            p = p_c - (w / delta) * e
            if consistent:  # the attractive tail softens: negative stiffness
                dp = dp + np.where(gap > 0, (w / delta**2) * e, 0.0)
        return p, dp, p_c

    def _slip_coordinate(self, u, n):
        """Tangent direction tau, kappa = d s / d(arc) and slip coordinate s (mm) at the quadrature points."""
        if self.small_strain:
            ue = u[self.element_dofs]
            s = np.einsum("keq,ke->eq", self.N[self.comp == 0], ue[self.comp == 0])  # u_r
            tau = np.zeros_like(n)
            tau[0] = 1.0
            return tau, 1.0, s
        tau = np.stack([-n[1], n[0]])
        s = self.indenter.radius_mm * np.arctan2(n[0], -n[1])  # R theta
        return tau, None, s

    def _return_mapping(self, s, p_c):
        """Tangential traction q and its derivatives dq/ds (stick) and dq/dp_c (slip).

        ``q_tr = q_n + eps_T (s - s_n)`` with the committed traction and slip
        coordinate, then ``q = q_tr`` if ``|q_tr| <= mu p_c`` (stick), else
        ``q = mu p_c sign(q_tr)`` (slip). A point out of contact carries no traction,
        and its slip before touching loads it like a slip in contact (so q stays
        continuous as points enter contact, and the stick point of a point that
        touches during an increment is its position at the start of the increment:
        a first-order error in the increment size, see tests/test_friction.py).
        """
        q_tr = self._q + self.epsilon_t * (s - self._s)
        touching = p_c > 0
        limit = self.mu * p_c
        stick = touching & (np.abs(q_tr) <= limit)
        slip = touching & ~stick
        sgn = np.sign(q_tr)
        q = np.where(stick, q_tr, np.where(slip, sgn * limit, 0.0))
        dq_ds = np.where(stick, self.epsilon_t, 0.0)
        dq_dp = np.where(slip, self.mu * sgn, 0.0)
        return q, dq_ds, dq_dp, stick

    def _general(self, u, depth, tangent):
        """Force vector, tangent and sphere force with adhesion and/or friction."""
        R = self.indenter.radius_mm
        n, dist, gap = self._kinematics(u, depth)
        p, dp, p_c = self._normal_law(gap, consistent=tangent != "convex")
        # t = -p n + q kappa tau per unit reference area: the sphere receives t, the body -t
        t = -p * n
        A = None
        if tangent:
            # A[i, j] such that K_ab,ij = int N_a N_b A_ij dA
            A = -dp * n[:, None] * n[None, :]
            if not self.small_strain:
                A = A - (p / dist) * (np.eye(2)[:, :, None, None] - n[:, None] * n[None, :])
        q = None
        if self.law.frictional:
            tau, kappa, s = self._slip_coordinate(u, n)
            if kappa is None:
                kappa = R / dist
            q, dq_ds, dq_dp, _ = self._return_mapping(s, p_c)
            t = t + q * kappa * tau
            if tangent:
                dpc = -self.epsilon * (p_c > 0)  # d p_c / d g
                dq_dx = dq_ds * kappa * tau + (dq_dp * dpc) * n  # d g / d x = n
                A = A + kappa * tau[:, None] * dq_dx[None, :]
                if not self.small_strain:  # q d^2 s / dx^2, s = R theta
                    A = A - (q * R / dist**2) * (n[:, None] * tau[None, :] + tau[:, None] * n[None, :])
        fe = np.einsum("keq,keq,eq->ke", self.N, t[self.comp], self.dA)
        f = np.bincount(self.element_dofs.ravel(), weights=fe.ravel(), minlength=u.size)
        force = float(np.sum(t[1] * self.dA))  # vertical resultant on the sphere (it receives +t)
        Ke = None
        if tangent:
            W = A[self.comp][:, self.comp] * self.dA  # (nloc, nloc, nf, nq)
            Ke = np.einsum("keq,leq,kleq->ekl", self.N, self.N, W)
        return f, Ke, force, p, q, gap

    # -- history (friction) ----------------------------------------------------------
    def begin_step(self, dt: float | None = None) -> None:
        """Start an increment from the committed history (friction is rate independent: ``dt`` is unused)."""
        if self.law.frictional and not self._initialised:
            # the undeformed surface with the sphere at depth 0: slip coordinate R theta of X
            # (small strain: u_r = 0), no traction
            u0 = np.zeros(self.basis.N)
            self._s = self._slip_coordinate(u0, self._kinematics(u0, 0.0)[0])[2]
            self._initialised = True

    def commit(self, u: np.ndarray, depth: float) -> None:
        """Store the friction history (traction, slip coordinate) of the converged state ``u`` at ``depth`` (mm)."""
        if not self.law.frictional:
            return
        self.begin_step()
        n, _, gap = self._kinematics(u, depth)
        s = self._slip_coordinate(u, n)[2]
        self._q = self._return_mapping(s, self.epsilon * np.maximum(-gap, 0.0))[0]
        self._s = s

    # -- evaluation ------------------------------------------------------------------
    def state(self, u: np.ndarray, depth: float) -> ContactState:
        """Force on the sphere (mN), pressure at the quadrature points (kPa), penetration."""
        if not self._plain:
            f, _, force, p, q, gap = self._general(u, depth, tangent=False)
            pen = np.maximum(-gap, 0.0)
            return ContactState(force, p, float(pen.max(initial=0.0)), int(np.count_nonzero(pen)), q)
        n, _, gap = self._kinematics(u, depth)
        pen = np.maximum(-gap, 0.0)
        p = self.penalty(depth) * pen
        force = float(np.sum(p * (-n[1]) * self.dA))
        return ContactState(force, p, float(pen.max(initial=0.0)), int(np.count_nonzero(pen)))

    def energy(self, u: np.ndarray, depth: float) -> float:
        """Penalty (and adhesion) energy (mN mm); frictional contact has none."""
        if self.law.frictional:
            raise ValueError("frictional contact is path dependent: it has no energy function")
        _, _, gap = self._kinematics(u, depth)
        if self.law.adhesive:
            w, delta = self.work_mN_per_mm, self.range_mm
            phi = 0.5 * self.epsilon * np.maximum(-gap, 0.0) ** 2 + np.where(
                gap >= 0, -w * np.exp(-np.maximum(gap, 0.0) / delta), -w + w * gap / delta)
            return float(np.sum(phi * self.dA))
        return float(0.5 * self.penalty(depth) * np.sum(np.maximum(-gap, 0.0) ** 2 * self.dA))

    def forces(self, u: np.ndarray, depth: float, tangent: bool | str = True):
        """Contact force vector (mN, the gradient of the penalty energy) and facet tangents.

        Returns
        -------
        f : ndarray, shape (n_dofs,)
        Ke : ndarray, shape (nf, nloc, nloc), or None
            The consistent tangent (``tangent=True``); not symmetric with friction
            (slip). ``tangent="convex"`` leaves out the negative stiffness of the
            adhesive tail (see :attr:`convex_fallback`).
        force : float
            Force on the sphere, mN.
        """
        if not self._plain:
            return self._general(u, depth, tangent)[:3]
        n, dist, gap = self._kinematics(u, depth)
        pen = np.maximum(-gap, 0.0)
        epsilon = self.penalty(depth)
        p = epsilon * pen
        Nn = self.N * n[self.comp]  # (nloc, nf, nq): N_a n_{i(a)}
        fe = -np.einsum("keq,eq,eq->ke", Nn, p, self.dA)
        f = np.bincount(self.element_dofs.ravel(), weights=fe.ravel(), minlength=u.size)
        force = float(np.sum(p * (-n[1]) * self.dA))
        if not tangent:
            return f, None, force
        active = (pen > 0).astype(float)
        w1 = epsilon * active * self.dA
        w2 = p / dist * self.dA
        same = (self.comp[:, None] == self.comp[None, :]).astype(float)  # delta_ij
        Ke = np.einsum("keq,leq,eq->ekl", Nn, Nn, w1 + w2) - np.einsum(
            "kl,keq,leq,eq->ekl", same, self.N, self.N, w2
        )
        return f, Ke, force
