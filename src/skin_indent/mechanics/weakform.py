r"""The axisymmetric large-strain weak form, written as scikit-fem forms.

This is the readable statement of the mechanics; :class:`~.axisymmetric.AxisymmetricSolid`
evaluates the same integrals with a vectorised kernel into a fixed sparsity
pattern (the tests check that both agree to round-off). With ``H`` the
displacement gradient in cylindrical components,

.. math::

    H = \begin{pmatrix} u_{r,r} & u_{r,z} & 0\\ u_{z,r} & u_{z,z} & 0\\ 0 & 0 & u_r/r\end{pmatrix},
    \qquad F = I + H,

the residual and the tangent are

.. math::

    R(u; v) = \int P(F) : \delta F(v)\; 2\pi r\, dA, \qquad
    K(u; \Delta u, v) = \int \delta F(v) : \mathbb{A}(F) : \delta F(\Delta u)\; 2\pi r\, dA .
"""

from __future__ import annotations

import numpy as np
from skfem import BilinearForm, LinearForm

from .materials import Material


def displacement_gradient(field, r) -> np.ndarray:
    """H (3, 3, ...) of a vector field (a scikit-fem DiscreteField) at radius ``r`` (mm)."""
    value = np.asarray(field)
    H = np.zeros((3, 3) + value.shape[1:])
    H[0, 0] = field.grad[0][0]
    H[0, 1] = field.grad[0][1]
    H[1, 0] = field.grad[1][0]
    H[1, 1] = field.grad[1][1]
    H[2, 2] = value[0] / r
    return H


def residual_form(material: Material) -> LinearForm:
    """Internal virtual work ``R(u; v)`` (mN mm); assemble with ``u=basis.interpolate(u)``."""

    @LinearForm
    def residual(v, w):
        r = w.x[0]
        P = material.stress(displacement_gradient(w["u"], r))
        dF = displacement_gradient(v, r)
        return 2.0 * np.pi * r * np.einsum("ij...,ij...->...", P, dF)

    return residual


def tangent_form(material: Material) -> BilinearForm:
    """Consistent tangent ``K(u; du, v)``; assemble with ``u=basis.interpolate(u)``."""

    @BilinearForm
    def tangent(du, v, w):
        r = w.x[0]
        _, A = material.stress_and_tangent(displacement_gradient(w["u"], r))
        return 2.0 * np.pi * r * np.einsum(
            "ijkl...,ij...,kl...->...", A, displacement_gradient(v, r), displacement_gradient(du, r)
        )

    return tangent
