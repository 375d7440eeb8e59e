r"""Parameter sensitivities of the sphere force by direct differentiation.

For a path-independent body (hyperelastic materials, frictionless non-adhesive
penalty contact) the converged state :math:`u(h; p)` at depth :math:`h` satisfies
:math:`R(u, p) = f_\mathrm{int}(u, p) + f_c(u, p) = 0` on the free dofs. Differentiating,

.. math::

    K \, \frac{du}{dp} = -\frac{\partial R}{\partial p}\Big|_u, \qquad
    \frac{dF}{dp} = \frac{\partial F}{\partial u}\cdot\frac{du}{dp}
                    + \frac{\partial F}{\partial p}\Big|_u ,

with :math:`K = \partial R/\partial u` the consistent tangent at the converged
state (assembled anew there). Only the force is wanted, so one adjoint solve per depth
serves every parameter: with :math:`K \lambda = (\partial F/\partial u)^T` (K is
symmetric for frictionless contact), :math:`dF/dp = -\lambda \cdot \partial R/\partial p
+ \partial F/\partial p`. The solve reuses the factorisation of the Newton iterations
(conjugate gradients preconditioned with it, :class:`~.linear.TangentSolver`; a new
factorisation only when that does not converge), so a depth costs an assembly and a few
triangular solves, not a factorisation (on two layers over a half-space: 1.47 -> ~1.2 s
per 20-depth run, measured).

* :math:`\partial f_\mathrm{int}/\partial p = \int \partial P/\partial p : \delta F\, dV`
  over the region of the material that owns ``p``; the stress derivative comes from
  :meth:`~.materials.Material.stress_parameter_derivative` (neo-Hooke: P is linear
  in the Lame parameters, so dP/dp is the stress with (mu, lambda) replaced by their
  derivatives; stiffening: dP/dC20 = 2 b dI1b/dF).
* The penalty is :math:`\epsilon = \mathrm{penalty}\, E_\mathrm{ref} / a` with
  :math:`E_\mathrm{ref}` the largest ``reference_modulus`` of the body's materials;
  the contact forces and the sphere force are proportional to it, so
  :math:`\partial f_c/\partial p = f_c\, (\partial E_\mathrm{ref}/\partial p)/E_\mathrm{ref}`
  and :math:`\partial F/\partial p|_u = F\,(\partial E_\mathrm{ref}/\partial p)/E_\mathrm{ref}`,
  non-zero for the modulus of the arg-max material only (at a tie, every tied
  material gets the derivative: the right derivative of the max).
  Layers on a rigid base where the penalty follows their confined modulus
  :math:`M_s` (:class:`~.layers.ConfinedPenalty` above 1 at that depth) get
  :math:`(\partial M_s/\partial p)/M_s` instead (:math:`E_\mathrm{ref}` cancels there),
  with :math:`M_s` depending on the layers' moduli and Poisson's ratios.
* The sphere force is the vertical resultant of the contact force vector,
  :math:`F = \sum_{a \in z} f_{c,a}` (the shape functions sum to one), so
  :math:`\partial F/\partial u = e_z^T K_c` with :math:`K_c` the contact tangent.

Used by :func:`skin_indent.simulate.simulate` (``sensitivities=True``) through the
``on_converged`` hook of :meth:`~.solver.IndentationProblem.solve`.
"""

from __future__ import annotations

import numpy as np

from .axisymmetric import F_COMPONENTS
from .layers import LayeredSample


def sample_materials(sample) -> list:
    """The materials of a sample in the order of the sensitivity keys.

    Parameters
    ----------
    sample : Material or LayeredSample

    Returns
    -------
    list of Material
        ``[sample]`` for one material; the layers top first, then the substrate
        unless it is rigid, for a :class:`~.layers.LayeredSample`.
    """
    return list(sample.materials) if isinstance(sample, LayeredSample) else [sample]


def check_differentiable(sample, contact=None) -> None:
    """Raise a one-line ``ValueError`` unless :class:`DirectSensitivity` supports the problem.

    Parameters
    ----------
    sample : Material or LayeredSample
        Every material must be path independent and provide parameter derivatives
        (:class:`~.materials.NeoHooke`, :class:`~.materials.NeoHookeStiffening`).
    contact : ContactLaw, optional
        Must be frictionless and non-adhesive.
    """
    for law in sample_materials(sample):
        if not law.path_independent or not law.sensitivity_parameters:
            raise ValueError(f"sensitivities are available for neo-Hookean (and stiffening) elastic "
                             f"materials only, not {law.name}")
    if contact is not None and (contact.frictional or contact.adhesive):
        raise ValueError("sensitivities need frictionless, non-adhesive contact")


#: relative residual of the adjoint solves (conjugate gradients; the derivatives are checked
#: against finite differences to 1e-6)
ADJOINT_RTOL = 1e-12


class DirectSensitivity:
    """Derivatives dF/dp of the sphere force at the converged states of an incremental solve.

    Pass an instance as ``on_converged`` to :meth:`~.solver.IndentationProblem.solve`;
    after the solve, :attr:`values` holds one derivative per requested depth.

    Parameters
    ----------
    problem : IndentationProblem
        The problem being solved (its body built from ``sample``).
    sample : Material or LayeredSample
        The sample the body was built from (for the keys ``(k, name)``).
    n_depths : int
        Number of requested depths of the solve.
    refine : int
        Steps of iterative refinement of the adjoint solve (default 0: the conjugate
        gradients already reach :data:`ADJOINT_RTOL`).

    Attributes
    ----------
    keys : list of (int, str)
        ``(k, name)``: material index in :func:`sample_materials` and parameter name.
    values : dict
        ``(k, name) -> ndarray`` of dF/dp at the requested depths, mN per unit of p.
    """

    def __init__(self, problem, sample, n_depths: int, refine: int = 0):
        check_differentiable(sample, problem.contact.law)
        self.problem = problem
        self.refine = refine
        materials = sample_materials(sample)
        solid = problem.solid
        # the body's regions in the order of the materials (regions without quadrature
        # points are absent, so walk both lists; the same object may own several layers)
        owner, k = [], 0
        for _, law in solid.regions:
            while k < len(materials) and materials[k] is not law:
                k += 1
            if k == len(materials):
                raise ValueError("the body's regions do not follow the sample's materials")
            owner.append(k)
            k += 1
        # the penalty's reference modulus, as IndentationProblem computes it
        moduli = [law.reference_modulus for _, law in solid.regions]
        self.e_ref = max(moduli)
        tied = {k for k, m in zip(owner, moduli) if m == self.e_ref}
        self.keys = [(k, name) for k, law in enumerate(materials) for name in law.sensitivity_parameters]
        self._selectors = {k: [sel for (sel, _), o in zip(solid.regions, owner) if o == k]
                           for k in range(len(materials))}
        self._materials = materials
        #: d(E_ref)/dp / E_ref for each key (1/kPa per unit of p)
        self._penalty_rate = np.array([materials[k].reference_modulus_derivative(name) / self.e_ref
                                       if k in tied else 0.0 for k, name in self.keys])
        #: d(M_s)/dp / M_s for each key, where the penalty follows the layers' confined modulus
        confined = problem.penalty_scale
        self._confined = confined
        self._confined_rate = None if confined is None else np.array(
            [sample.confined_modulus_derivative(k, name) / confined.modulus_kPa for k, name in self.keys])
        self.values = {key: np.zeros(n_depths) for key in self.keys}
        self.factorisations = 0

    def _parameter_forces(self, H: np.ndarray) -> np.ndarray:
        """dR/dp at fixed u of the internal forces, one column per key (n_dofs, n_keys), mN per unit of p."""
        solid = self.problem.solid
        out = np.zeros((solid.n_dofs, len(self.keys)))
        for j, (k, name) in enumerate(self.keys):
            sels = self._selectors[k]
            if not sels:
                continue
            P5 = np.zeros((5,) + H.shape[2:])
            for sel in sels:
                dP = self._materials[k].stress_parameter_derivative(H[:, :, sel], name)
                for a, (i, J) in enumerate(F_COMPONENTS):
                    P5[a][sel] = dP[i, J]
            out[:, j] = solid.assemble_stress(P5)
        return out

    def derivatives(self, u: np.ndarray, depth: float) -> np.ndarray:
        """dF/dp (mN per unit of p) for every key at the converged state ``u`` (mm) at ``depth`` (mm).

        Assembles the consistent tangent at ``u``, factorises it once and solves
        for all parameters together.
        """
        pb = self.problem
        free = pb.free
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            _, Ke, f_c, Kc, force = pb._evaluate(u, depth, tangent=True)
            H = pb.solid.displacement_gradient(u)
            dR = self._parameter_forces(H)
        K = pb.pattern.assemble([(pb.solid.element_dofs, Ke), (pb.contact.element_dofs, Kc)])
        confined = self._confined is not None and self._confined.active(depth)
        rate = self._confined_rate if confined else self._penalty_rate
        dR += f_c[:, None] * rate[None, :]
        b = -dR[free]
        # dF/du = e_z^T K_c (F is the sum of the vertical contact forces)
        c = pb.contact
        ez = (c.comp == 1).astype(float)
        g_e = np.einsum("k,ekl->el", ez, Kc)
        g = np.bincount(c.element_dofs.T.ravel(), weights=g_e.ravel(), minlength=u.size)[free]
        # the adjoint K lam = g (K symmetric), preconditioned by the Newton iterations' factorisation
        solver = pb.linear_solver
        before = solver.factorisations
        lam = solver.solve(K, g, rtol=ADJOINT_RTOL)
        for _ in range(self.refine):
            lam += solver.solve(K, g - K @ lam, rtol=ADJOINT_RTOL)
        self.factorisations += solver.factorisations - before
        return lam @ b + force * rate

    def __call__(self, i: int, u: np.ndarray, depth: float) -> None:
        """The ``on_converged`` hook: store dF/dp at the ``i``-th requested depth."""
        d = self.derivatives(u, depth)
        for j, key in enumerate(self.keys):
            self.values[key][i] = d[j]
