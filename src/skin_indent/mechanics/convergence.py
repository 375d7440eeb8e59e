"""Newton's convergence criterion: a relative residual with a floor at the attainable precision.

A relative residual cannot fall below the round-off with which the residual is evaluated.
:func:`newton_converged` takes the relative-residual criterion of
:class:`~.solver.IndentationProblem` and, for a tolerance below what float64 attains, accepts
an iterate whose residual is within its round-off floor (:func:`roundoff_floor`, derived from
the problem) and whose Newton increment is negligible. See "Newton convergence" in
docs/theory.rst. :class:`NewtonReport` counts what an incremental solution did, and
:class:`ConvergenceError` says where it failed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Unit round-off of the float64 arithmetic, the scale of :func:`newton_converged`'s floor.
EPS = float(np.finfo(float).eps)


def newton_converged(rel: float, rtol: float, floor: float = 0.0, increment: float | None = None) -> str | None:
    """Whether a Newton iterate is converged, and by which criterion.

    The residual criterion is ``rel <= rtol``. A tolerance below what float64 attains
    would never be met: the residual then stagnates at its round-off (the contact gap is a
    difference of lengths of the order of the sphere's radius), randomly, at a level that
    depends on the floating-point path. Such an iterate is accepted when its residual is
    within the round-off ``floor`` that the evaluation of the forces carries and the Newton
    increment computed from it is negligible: relative to the displacement, at most the
    larger of ``rtol`` and ``floor`` (a well-conditioned tangent maps a relative residual to
    a relative displacement of the same order; a soft mode, where a residual within the
    round-off still moves the state, is not accepted). A further iteration could only move
    the state within the round-off. The floor is estimated from the problem
    (:func:`roundoff_floor`), not tuned to a machine.

    Parameters
    ----------
    rel : float
        Norm of the residual on the free unknowns relative to its scale (the larger of the
        internal and contact force norms).
    rtol : float
        The relative tolerance.
    floor : float
        The residual's round-off floor, relative to the same scale (0: none).
    increment : float, optional
        Norm of the Newton increment computed at this iterate relative to the norm of the
        displacement (None: not computed yet, only the residual criterion applies).

    Returns
    -------
    str or None
        ``"residual"``, ``"round-off"`` or None (not converged).
    """
    if not rel <= rtol:  # also NaN
        if increment is not None and math.isfinite(rel) and rel <= floor and increment <= max(rtol, floor):
            return "round-off"
        return None
    return "residual"


def roundoff_floor(solid, contact, u: np.ndarray, depth: float, free: np.ndarray, active=None) -> float:
    r"""Norm of the round-off (mN) that the residual carries at ``u``, the floor of :func:`newton_converged`.

    Each nodal force is a sum of contributions that cancel; their rounding errors do not.
    The floor is :data:`EPS` times the norm, on the free unknowns, of the sums of their
    magnitudes: of the element forces :math:`|f_e|` (``solid.gross_force``, from its last
    force evaluation, which must be at ``u``), plus those of the contact forces with the
    pressure replaced by its round-off scale :math:`2 R \epsilon` (:math:`\epsilon` the
    penalty) at the touching quadrature points: the gap is the distance to the sphere's
    centre minus ``R``, so it is known to about ``EPS R`` however small the penetration.
    Measured on the coarse mesh (R = 6.22 mm, 0.04-0.6 mm deep): the contact forces' actual
    round-off, against extended precision, is 0.05-0.1 of this floor, and Newton's residual
    stagnates at 0.07-0.9 of it (relative residuals of 1e-11 to 1.5e-10).

    Parameters
    ----------
    solid : AxisymmetricSolid
        The body, after ``forces(u)``.
    contact : SphereContact
        The sphere's contact.
    u : ndarray
        Displacement field, mm.
    depth : float
        Depth of the sphere, mm.
    free : ndarray of bool
        The free unknowns.
    active : ndarray of bool, optional
        The touching contact quadrature points, if known (else from ``contact.state``).

    Returns
    -------
    float
        mN.
    """
    if active is None:
        active = contact.state(u, depth).pressure_kPa > 0
    total = solid.gross_force
    if np.any(active):
        w = (2.0 * contact.indenter.radius_mm * contact.penalty(depth)) * active * contact.dA  # (nf, nq)
        ge = np.einsum("keq,eq->ke", np.abs(contact.N), w)
        g = np.bincount(contact.element_dofs.ravel(), weights=ge.ravel(), minlength=u.size)
        total += float(np.linalg.norm(g[free]))
    return EPS * total


class ConvergenceError(RuntimeError):
    """Newton's method failed to converge at some depth, even after step cutting."""


@dataclass
class NewtonReport:
    """Statistics of one incremental solution.

    Attributes
    ----------
    increments : int
        Number of converged increments (including any cut steps).
    iterations : list of int
        Newton iterations of each converged increment.
    residuals : list of float
        Final relative residual of each increment (above ``rtol`` where it stopped at the
        round-off floor, see ``roundoff_stops``).
    step_cuts : int
        How often an increment was halved.
    line_search_backtracks : int
        Number of step-length reductions.
    max_penetration_ratio : float
        Largest penetration of the surface into the sphere relative to the depth.
    wall_time_s : float
        Wall time of the solve, s.
    tangents : int
        Tangent matrices evaluated and assembled.
    modified_steps : int
        Newton iterations that reused the previous iterate's tangent (modified Newton,
        near convergence).
    factorisations : int
        Sparse LU factorisations of a tangent.
    preconditioned_solves : int
        Linear solves done by a Krylov method preconditioned with an earlier factorisation.
    roundoff_stops : int
        Increments accepted at the residual's round-off floor rather than below ``rtol``
        (see :func:`~.convergence.newton_converged`).
    """

    increments: int = 0
    iterations: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    step_cuts: int = 0
    line_search_backtracks: int = 0
    max_penetration_ratio: float = 0.0
    wall_time_s: float = 0.0
    tangents: int = 0
    modified_steps: int = 0
    factorisations: int = 0
    preconditioned_solves: int = 0
    roundoff_stops: int = 0

    @property
    def total_iterations(self) -> int:
        return int(np.sum(self.iterations))

    @property
    def mean_iterations(self) -> float:
        return float(np.mean(self.iterations)) if self.iterations else 0.0

    def summary(self) -> str:
        return (
            f"{self.increments} increments, {self.total_iterations} Newton iterations "
            f"({self.mean_iterations:.2f} per increment), {self.step_cuts} step cuts, "
            f"{self.line_search_backtracks} backtracks, {self.factorisations} factorisations, "
            f"max penetration {self.max_penetration_ratio:.2e} x depth, {self.wall_time_s:.2f} s"
        )
