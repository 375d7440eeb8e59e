"""The material protocol shared by every constitutive law.

A material maps a batch of displacement gradients ``H`` (shape ``(3, 3, ...)``,
cylindrical components ordered ``(r, z, theta)``; the deformation gradient is
``F = I + H``) to the strain energy density, the first Piola-Kirchhoff stress and
its consistent tangent ``dP/dF``. Stress is in kPa, energy density in kPa
(= mN mm / mm^3).

Why H and not F: on a mesh reaching 1000 mm the far-field strains are ~1e-7, and
forming ``F = I + H`` before evaluating ``mu (F - F^-T)`` loses half the digits of
the stress there, which stalls Newton's method near 1e-7. Every law therefore
evaluates its stress in a cancellation-free form from ``H``
(e.g. ``F - F^-T = H + F^-T H^T`` and ``ln J = log1p(J - 1)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np


@dataclass(frozen=True)
class ParameterInfo:
    """Metadata of one material parameter.

    Parameters
    ----------
    name : str
        Name as used in the API, CLI and JSON (e.g. ``"E_kPa"``).
    unit : str
        Unit of the value (``"kPa"``, ``"-"``, ...).
    lower, upper : float
        Admissible open interval of the value.
    description : str
        One line for reports.
    """

    name: str
    unit: str
    lower: float
    upper: float
    description: str


def lame_parameters(E_kPa: float, nu: float) -> tuple[float, float]:
    """Lame parameters ``(mu, lam)`` in kPa from Young's modulus and Poisson's ratio."""
    mu = E_kPa / (2.0 * (1.0 + nu))
    lam = E_kPa * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    return mu, lam


def lame_parameter_derivatives(E_kPa: float, nu: float) -> dict[str, tuple[float, float]]:
    """Derivatives of the Lame parameters ``(mu, lam)`` of :func:`lame_parameters`.

    Returns
    -------
    dict
        ``{"E_kPa": (dmu/dE, dlam/dE), "nu": (dmu/dnu, dlam/dnu)}``: per kPa of E
        (dimensionless) and per unit of nu (kPa).
    """
    q = (1.0 + nu) * (1.0 - 2.0 * nu)
    return {
        "E_kPa": (1.0 / (2.0 * (1.0 + nu)), nu / q),
        "nu": (-E_kPa / (2.0 * (1.0 + nu) ** 2), E_kPa * (1.0 + 2.0 * nu**2) / q**2),
    }


def check_elastic_constants(E_kPa: float, nu: float) -> None:
    """Raise ``ValueError`` with a one-line message for inadmissible (E, nu)."""
    if not (isinstance(E_kPa, (int, float, np.floating)) and math.isfinite(E_kPa)):
        raise ValueError(f"E must be a finite number in kPa, got {E_kPa!r}")
    if not (isinstance(nu, (int, float, np.floating)) and math.isfinite(nu)):
        raise ValueError(f"nu must be a finite number, got {nu!r}")
    if E_kPa <= 0:
        raise ValueError(f"E must be > 0 kPa, got {E_kPa}")
    if not -1.0 < nu < 0.5:
        raise ValueError(f"nu must lie in (-1, 0.5), got {nu}")


def identity_like(F: np.ndarray) -> np.ndarray:
    """Identity tensor broadcast to the shape of ``F`` (3, 3, ...)."""
    eye = np.zeros_like(F)
    for i in range(3):
        eye[i, i] = 1.0
    return eye


def _cofactors(F: np.ndarray) -> np.ndarray:
    """Cofactor matrix of a batch of 3x3 matrices (3, 3, ...), closed form."""
    C = np.empty_like(F)
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            C[i, j] = F[i1, j1] * F[i2, j2] - F[i1, j2] * F[i2, j1]
    return C


def inverse_and_det(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched inverse and determinant of ``F`` with shape (3, 3, ...) (closed form)."""
    C = _cofactors(F)
    J = F[0, 0] * C[0, 0] + F[0, 1] * C[0, 1] + F[0, 2] * C[0, 2]
    return np.swapaxes(C, 0, 1) / J, J


def det_minus_one(H: np.ndarray) -> np.ndarray:
    """``det(I + H) - 1`` without cancellation (exact 3x3 identity)."""
    tr = H[0, 0] + H[1, 1] + H[2, 2]
    tr2 = np.einsum("ij...,ji...->...", H, H)
    C = _cofactors(H)
    detH = H[0, 0] * C[0, 0] + H[0, 1] * C[0, 1] + H[0, 2] * C[0, 2]
    return tr + 0.5 * (tr**2 - tr2) + detH


def kinematics(H: np.ndarray):
    """``(F, F^-1, ln J, J)`` from the displacement gradient, with ``ln J`` accurate."""
    F = identity_like(H) + H
    Finv, _ = inverse_and_det(F)
    jm1 = det_minus_one(H)
    return F, Finv, np.log1p(jm1), 1.0 + jm1


def cauchy_stress(P: np.ndarray, H: np.ndarray, small_strain: bool = False) -> np.ndarray:
    """Cauchy stress ``P F^T / J`` (kPa) from the first Piola stress; ``P`` itself in small strain."""
    if small_strain:
        return P
    return np.einsum("iJ...,kJ...->ik...", P, identity_like(H) + H) / (1.0 + det_minus_one(H))


class Material:
    """Base class of the constitutive laws.

    Subclasses are frozen dataclasses holding their parameters, and implement
    :meth:`energy`, :meth:`stress` and :meth:`stress_and_tangent`.
    ``reference_modulus`` (kPa) scales the contact penalty, so that the
    force of every law is exactly proportional to its moduli.
    """

    name: str = "material"
    parameter_info: tuple[ParameterInfo, ...] = ()
    #: True when stress depends only on the current deformation (no history).
    path_independent: bool = True
    #: True when the law is written in small-strain (linearised) kinematics.
    small_strain: bool = False
    #: Parameters (dataclass field names) whose stress derivative
    #: :meth:`stress_parameter_derivative` provides (direct differentiation of the
    #: force curve, :mod:`skin_indent.mechanics.sensitivity`); empty: none.
    sensitivity_parameters: tuple[str, ...] = ()

    @property
    def reference_modulus(self) -> float:
        """A modulus in kPa that scales the contact penalty."""
        raise NotImplementedError

    def parameters(self) -> dict[str, float]:
        """The law's parameters as a name -> value dict (names carry units)."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}  # type: ignore[arg-type]

    def energy(self, H: np.ndarray) -> np.ndarray:
        """Strain energy density W in kPa, shape ``H.shape[2:]``, of ``F = I + H``."""
        raise NotImplementedError

    def stress(self, H: np.ndarray) -> np.ndarray:
        """First Piola-Kirchhoff stress P = dW/dF in kPa, shape of ``H``."""
        return self.stress_and_tangent(H)[0]

    def stress_and_tangent(self, H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(P, A)`` with ``A[i, J, k, L] = dP[i, J] / dF[k, L]`` in kPa."""
        raise NotImplementedError

    def tangent_components(self, H: np.ndarray, pairs) -> tuple[np.ndarray, np.ndarray]:
        """Stress and tangent restricted to the components ``pairs`` of F.

        Parameters
        ----------
        H : ndarray, shape (3, 3, ...)
        pairs : sequence of (i, J)
            The components of F that can be non-zero (five in axisymmetry).

        Returns
        -------
        P : ndarray, shape (len(pairs), ...)
        A : ndarray, shape (len(pairs), len(pairs), ...)
        """
        P, A = self.stress_and_tangent(H)
        rows = [i for i, _ in pairs]
        cols = [j for _, j in pairs]
        P_red = P[rows, cols]
        A_red = A[rows, cols][:, rows, cols]
        return P_red, A_red

    def stress_parameter_derivative(self, H: np.ndarray, name: str) -> np.ndarray:
        """Partial derivative dP/dp of the first Piola stress at fixed ``H``.

        Parameters
        ----------
        H : ndarray, shape (3, 3, ...)
            Displacement gradient.
        name : str
            One of :attr:`sensitivity_parameters`.

        Returns
        -------
        ndarray, shape of ``H``
            kPa per unit of the parameter.
        """
        raise NotImplementedError(f"{self.name} has no parameter derivatives")

    def reference_modulus_derivative(self, name: str) -> float:
        """d(reference_modulus)/dp for a parameter of :attr:`sensitivity_parameters` (kPa per unit of p)."""
        raise NotImplementedError(f"{self.name} has no parameter derivatives")

    def cauchy(self, H: np.ndarray) -> np.ndarray:
        """Cauchy stress sigma = P F^T / J in kPa (true stress)."""
        return cauchy_stress(self.stress(H), H, self.small_strain)
