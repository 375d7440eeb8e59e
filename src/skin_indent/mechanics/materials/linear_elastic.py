"""Hooke's law in small strain (the paper's base law and the Hertz check)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import Material, ParameterInfo, check_elastic_constants, identity_like, lame_parameters


@dataclass(frozen=True)
class LinearElastic(Material):
    r"""Isotropic linear elasticity in small strain.

    .. math::

        \varepsilon = \mathrm{sym}(F - I),\qquad
        \sigma = \lambda\,\mathrm{tr}(\varepsilon) I + 2\mu\varepsilon

    The body's kinematics are linearised (no geometric stiffness); the contact
    with the sphere is still evaluated at the displaced positions.

    Parameters
    ----------
    E_kPa : float
        Young's modulus, kPa (> 0).
    nu : float
        Poisson's ratio, in (-1, 0.5).

    Notes
    -----
    Assumptions: isotropic, linear, small strains and rotations. This is the
    setting of Hertz's and Sneddon's solutions.
    """

    E_kPa: float
    nu: float

    name = "linear-elastic"
    small_strain = True
    parameter_info = (
        ParameterInfo("E_kPa", "kPa", 0.0, np.inf, "Young's modulus"),
        ParameterInfo("nu", "-", -1.0, 0.5, "Poisson's ratio"),
    )

    def __post_init__(self):
        check_elastic_constants(self.E_kPa, self.nu)

    @property
    def reference_modulus(self) -> float:
        return float(self.E_kPa)

    def _strain(self, H):
        return 0.5 * (H + np.swapaxes(H, 0, 1))

    def energy(self, H):
        mu, lam = lame_parameters(self.E_kPa, self.nu)
        eps = self._strain(H)
        tr = np.einsum("ii...->...", eps)
        return 0.5 * lam * tr**2 + mu * np.einsum("ij...,ij...->...", eps, eps)

    def stress(self, H):
        mu, lam = lame_parameters(self.E_kPa, self.nu)
        eps = self._strain(H)
        tr = np.einsum("ii...->...", eps)
        return lam * tr * identity_like(H) + 2.0 * mu * eps

    def stress_and_tangent(self, H):
        mu, lam = lame_parameters(self.E_kPa, self.nu)
        eye = np.eye(3)
        A = (
            lam * np.einsum("ij,kl->ijkl", eye, eye)
            + mu * (np.einsum("ik,jl->ijkl", eye, eye) + np.einsum("il,jk->ijkl", eye, eye))
        )
        A = np.broadcast_to(A[(Ellipsis,) + (None,) * (H.ndim - 2)], (3, 3, 3, 3) + H.shape[2:])
        return self.stress(H), A
