"""Compressible neo-Hookean solid."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import (Material, ParameterInfo, check_elastic_constants, kinematics, lame_parameter_derivatives,
                   lame_parameters)


@dataclass(frozen=True)
class NeoHooke(Material):
    r"""Compressible neo-Hookean solid (the reference law of the project).

    .. math::

        W = \frac{\mu}{2}(I_1 - 3 - 2\ln J) + \frac{\lambda}{2}(\ln J)^2,
        \qquad \mu = \frac{E}{2(1+\nu)},\quad
        \lambda = \frac{E\nu}{(1+\nu)(1-2\nu)}

    with :math:`I_1 = \mathrm{tr}(F^T F)` and :math:`J = \det F`. At small strain it
    reduces to Hooke's law with the same E and nu.

    Parameters
    ----------
    E_kPa : float
        Young's modulus at small strain, kPa (> 0).
    nu : float
        Poisson's ratio at small strain, in (-1, 0.5).

    Notes
    -----
    Assumptions: isotropic, hyperelastic (no rate or history dependence), compressible.
    The stress and tangent are homogeneous of degree one in (mu, lambda), so the
    indentation force is exactly proportional to E at fixed nu.
    """

    E_kPa: float
    nu: float

    name = "neo-hooke"
    sensitivity_parameters = ("E_kPa", "nu")
    parameter_info = (
        ParameterInfo("E_kPa", "kPa", 0.0, np.inf, "Young's modulus at small strain"),
        ParameterInfo("nu", "-", -1.0, 0.5, "Poisson's ratio at small strain"),
    )

    def __post_init__(self):
        check_elastic_constants(self.E_kPa, self.nu)

    @property
    def reference_modulus(self) -> float:
        return float(self.E_kPa)

    @property
    def lame(self) -> tuple[float, float]:
        """``(mu, lam)`` in kPa."""
        return lame_parameters(self.E_kPa, self.nu)

    def stress_parameter_derivative(self, H, name):
        """dP/dp at fixed ``H`` (kPa per unit of p), p = ``"E_kPa"`` or ``"nu"``.

        P is linear in (mu, lambda): dP/dp is the stress with the Lame parameters
        replaced by their derivatives (:func:`~.base.lame_parameter_derivatives`).
        """
        if name not in self.sensitivity_parameters:
            raise ValueError(f"{self.name} has no parameter {name!r}")
        dmu, dlam = lame_parameter_derivatives(self.E_kPa, self.nu)[name]
        return PointwiseNeoHooke(dmu, dlam).stress(H)

    def reference_modulus_derivative(self, name):
        """1 for ``"E_kPa"`` (the reference modulus is E), else 0."""
        return 1.0 if name == "E_kPa" else 0.0

    def energy(self, H):
        mu, lam = self.lame
        _, _, lnJ, _ = kinematics(H)
        i1m3 = 2.0 * np.einsum("ii...->...", H) + np.einsum("iJ...,iJ...->...", H, H)  # I1 - 3
        return 0.5 * mu * (i1m3 - 2.0 * lnJ) + 0.5 * lam * lnJ**2

    def stress(self, H):
        return self._stress(H, *kinematics(H))

    def _stress(self, H, F, Finv, lnJ, J):
        # mu (F - F^-T) + lam ln J F^-T, with F - F^-T = H + F^-T H^T (no cancellation)
        mu, lam = self.lame
        FinvT = np.swapaxes(Finv, 0, 1)
        return mu * (H + np.einsum("iK...,JK...->iJ...", FinvT, H)) + lam * lnJ * FinvT

    def stress_and_tangent(self, H):
        mu, lam = self.lame
        F, Finv, lnJ, J = kinematics(H)
        P = self._stress(H, F, Finv, lnJ, J)
        FinvT = np.swapaxes(Finv, 0, 1)
        # A_iJkL = mu d_ik d_JL + lam Finv_Ji Finv_Lk + (mu - lam ln J) Finv_Jk Finv_Li
        A = lam * FinvT[:, :, None, None] * FinvT[None, None, :, :] + (mu - lam * lnJ) * (
            Finv[None, :, :, None] * FinvT[:, None, None, :]
        )
        for i in range(3):
            for j in range(3):
                A[i, j, i, j] += mu
        return P, A

    def tangent_components(self, H, pairs):
        # Same tangent as stress_and_tangent, evaluated only on the non-zero components
        # of F (25 of 81 in axisymmetry): this is the hot path of every Newton iteration.
        return self._tangent_components(H, pairs, kinematics(H))

    def _tangent_components(self, H, pairs, kin):
        """:meth:`tangent_components` from the kinematics ``(F, F^-1, ln J, J)`` of ``H``."""
        mu, lam = self.lame
        F, Finv, lnJ, J = kin
        rows = np.array([i for i, _ in pairs])
        cols = np.array([j for _, j in pairs])
        FinvT = np.swapaxes(Finv, 0, 1)
        P = self._stress(H, F, Finv, lnJ, J)[rows, cols]
        v = FinvT[rows, cols]
        A = lam * v[:, None] * v[None, :] + (mu - lam * lnJ) * (
            Finv[cols[:, None], rows[None, :]] * Finv[cols[None, :], rows[:, None]]
        )
        same = np.arange(len(pairs))
        A[same, same] += mu
        return P, A


class PointwiseNeoHooke:
    """The neo-Hookean law with Lame parameters given per quadrature point (or replaced by their
    derivatives: :meth:`NeoHooke.stress_parameter_derivative`), on the full 3 x 3 ``H``.

    The formulas of :class:`NeoHooke` broadcast over parameter arrays shaped like the
    quadrature points. (A body's regions are evaluated together on the axisymmetric
    components by :class:`~.axisymmetric_hyperelastic.AxisymmetricStiffening`.)

    Parameters
    ----------
    mu, lam : ndarray
        Lame parameters (kPa) at the quadrature points, shape ``H.shape[2:]``.
    """

    path_independent = True
    small_strain = False

    def __init__(self, mu: np.ndarray, lam: np.ndarray):
        self.lame = (mu, lam)

    stress = NeoHooke.stress
    _stress = NeoHooke._stress
    tangent_components = NeoHooke.tangent_components
    _tangent_components = NeoHooke._tangent_components
