"""Newton's convergence criterion: a relative residual with a floor at the attainable precision.

A relative residual cannot fall below the round-off with which the residual is evaluated.
:func:`newton_converged` takes the relative-residual criterion of
:class:`~.solver.IndentationProblem` and, for a tolerance below what float64 attains, accepts
an iterate whose residual is within its round-off floor (:func:`roundoff_floor`, derived from
the problem) and whose Newton increment is negligible. See "Newton convergence" in
docs/theory.rst.
"""

from __future__ import annotations

import math

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
