"""Neo-Hookean solid with Yeoh-type strain stiffening (hidden-effect case v04)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .base import Material, ParameterInfo, check_elastic_constants, kinematics, lame_parameters
from .neo_hooke import NeoHooke


def check_stiffening_constant(C20_kPa: float) -> None:
    """Raise ``ValueError`` with a one-line message for an inadmissible C20."""
    if not (isinstance(C20_kPa, (int, float, np.floating)) and math.isfinite(C20_kPa)):
        raise ValueError(f"C20 must be a finite number in kPa, got {C20_kPa!r}")
    if C20_kPa < 0:
        raise ValueError(f"C20 must be >= 0 kPa, got {C20_kPa}")


@dataclass(frozen=True)
class NeoHookeStiffening(Material):
    r"""Compressible neo-Hookean solid plus a Yeoh-type stiffening term.

    .. math::

        W = \underbrace{\frac{\mu}{2}(I_1 - 3 - 2\ln J)
            + \frac{\lambda}{2}(\ln J)^2}_{W_\mathrm{NH}(E,\,\nu)}
            + C_{20}\,(\bar I_1 - 3)^2,
        \qquad \bar I_1 = J^{-2/3} I_1

    with :math:`I_1 = \mathrm{tr}(F^T F)`, :math:`J = \det F` and the Lame
    parameters of :class:`NeoHooke`. For :math:`J = 1` it is the Yeoh law with
    :math:`C_{10} = \mu/2` and :math:`C_{20}`.

    Parameters
    ----------
    E_kPa : float
        Young's modulus at small strain, kPa (> 0).
    nu : float
        Poisson's ratio at small strain, in (-1, 0.5).
    C20_kPa : float
        Stiffening modulus, kPa (finite, >= 0). ``C20_kPa = 0`` gives
        :class:`NeoHooke` exactly (the same floating-point results).

    Notes
    -----
    Assumptions: isotropic, hyperelastic, compressible; the stiffening acts on the
    isochoric invariant only. :math:`\bar I_1 - 3` vanishes to second order in the
    strain, so the extra term is of fourth order: E and nu at small strain are
    exactly those of the neo-Hookean part.

    The energy is homogeneous of degree one in (E, C20) at fixed nu, and
    ``reference_modulus`` is E, so the indentation force satisfies
    F(2E, 2C20) = 2 F(E, C20) (exactly, up to the Newton tolerance).

    Evaluation from H without cancellation, with :math:`x = I_1 - 3 = 2\,\mathrm{tr}H + H:H`:

    * :math:`\bar I_1 - 3 = (3 + x)\,\mathrm{expm1}(-\tfrac23\ln J) + x`
      (absolute error ~ machine epsilon times ``|H|``, so the stiffening stress, of
      order :math:`C_{20}|H|^3`, is accurate far below the neo-Hookean roundoff);
    * :math:`\partial\bar I_1/\partial F = J^{-2/3}(2F - \tfrac23 I_1 F^{-T})
      = J^{-2/3}\,(2(H + F^{-T}H^T) - \tfrac23 x F^{-T})`.

    Stress and tangent, with :math:`b = \bar I_1 - 3`, :math:`D = \partial\bar I_1/\partial F`:

    .. math::

        P = P_\mathrm{NH} + 2C_{20}\,b\,D,\qquad
        A = A_\mathrm{NH} + 2C_{20}\,(D\otimes D + b\,\partial D/\partial F),

        \frac{\partial D_{iJ}}{\partial F_{kL}} = J^{-2/3}\Big[2\delta_{ik}\delta_{JL}
        - \tfrac43(F_{iJ}F^{-1}_{Lk} + F^{-1}_{Ji}F_{kL})
        + \tfrac49 I_1 F^{-1}_{Ji}F^{-1}_{Lk} + \tfrac23 I_1 F^{-1}_{Jk}F^{-1}_{Li}\Big].
    """

    E_kPa: float
    nu: float
    C20_kPa: float

    name = "neo-hooke-stiffening"
    sensitivity_parameters = ("E_kPa", "nu", "C20_kPa")
    parameter_info = (
        ParameterInfo("E_kPa", "kPa", 0.0, np.inf, "Young's modulus at small strain"),
        ParameterInfo("nu", "-", -1.0, 0.5, "Poisson's ratio at small strain"),
        ParameterInfo("C20_kPa", "kPa", 0.0, np.inf, "Yeoh stiffening modulus C20 (>= 0; 0 is neo-Hooke)"),
    )

    def __post_init__(self):
        check_elastic_constants(self.E_kPa, self.nu)
        check_stiffening_constant(self.C20_kPa)

    @property
    def reference_modulus(self) -> float:
        return float(self.E_kPa)

    @property
    def lame(self) -> tuple[float, float]:
        """``(mu, lam)`` in kPa of the neo-Hookean part."""
        return lame_parameters(self.E_kPa, self.nu)

    @cached_property
    def _nh(self) -> NeoHooke:
        """The neo-Hookean part (its code evaluates W_NH, P_NH and A_NH)."""
        return NeoHooke(self.E_kPa, self.nu)

    # -- the isochoric invariant ------------------------------------------------
    @staticmethod
    def _scalars(H, lnJ):
        """``(x, b, j)``: x = I1 - 3, b = I1b - 3, j = J^(-2/3), all from H and ln J."""
        x = 2.0 * np.einsum("ii...->...", H) + np.einsum("iJ...,iJ...->...", H, H)
        jm1 = np.expm1(-2.0 / 3.0 * lnJ)
        return x, (3.0 + x) * jm1 + x, 1.0 + jm1

    @classmethod
    def _invariants(cls, H, Finv, lnJ, F_minus_FinvT=None):
        """``(x, b, j, D, FinvT)`` with D = dI1b/dF (3, 3, ...); ``F_minus_FinvT`` = F - F^-T
        if already computed."""
        x, b, j = cls._scalars(H, lnJ)
        FinvT = np.swapaxes(Finv, 0, 1)
        if F_minus_FinvT is None:
            F_minus_FinvT = H + np.einsum("iK...,JK...->iJ...", FinvT, H)
        D = j * (2.0 * F_minus_FinvT - (2.0 / 3.0) * x * FinvT)
        return x, b, j, D, FinvT

    # -- the Material interface -------------------------------------------------
    def energy(self, H):
        W = self._nh.energy(H)
        if self.C20_kPa == 0:
            return W
        _, _, lnJ, _ = kinematics(H)
        _, b, _ = self._scalars(H, lnJ)
        return W + self.C20_kPa * b**2

    def stress(self, H):
        if self.C20_kPa == 0:
            return self._nh.stress(H)
        _, Finv, lnJ, _ = kinematics(H)
        # F - F^-T once for both parts: P_NH = mu (F - F^-T) + lam ln J F^-T
        FinvT = np.swapaxes(Finv, 0, 1)
        F_minus_FinvT = H + np.einsum("iK...,JK...->iJ...", FinvT, H)
        _, b, _, D, _ = self._invariants(H, Finv, lnJ, F_minus_FinvT)
        mu, lam = self.lame
        return mu * F_minus_FinvT + lam * lnJ * FinvT + (2.0 * self.C20_kPa * b) * D

    def stress_parameter_derivative(self, H, name):
        """dP/dp at fixed ``H`` (kPa per unit of p), p = ``"E_kPa"``, ``"nu"`` or ``"C20_kPa"``.

        E and nu enter only the neo-Hookean part (linear in the Lame parameters);
        the stiffening stress ``2 C20 b D`` is linear in C20: dP/dC20 = 2 b D
        (dimensionless).
        """
        if name == "C20_kPa":
            _, Finv, lnJ, _ = kinematics(H)
            _, b, _, D, _ = self._invariants(H, Finv, lnJ)
            return (2.0 * b) * D
        return self._nh.stress_parameter_derivative(H, name)

    def reference_modulus_derivative(self, name):
        """1 for ``"E_kPa"`` (the reference modulus is E), else 0."""
        return 1.0 if name == "E_kPa" else 0.0

    def stress_and_tangent(self, H):
        P, A = self._nh.stress_and_tangent(H)
        if self.C20_kPa == 0:
            return P, A
        c = 2.0 * self.C20_kPa
        F, Finv, lnJ, _ = kinematics(H)
        x, b, j, D, FinvT = self._invariants(H, Finv, lnJ)
        I1 = 3.0 + x
        cb = c * b
        cbj = cb * j
        # 2C20 (D x D + b dD/dF), dD/dF from the docstring
        A_iso = c * D[:, :, None, None] * D[None, None, :, :]
        A_iso += (cbj * (-4.0 / 3.0)) * (F[:, :, None, None] * FinvT[None, None, :, :]
                                         + FinvT[:, :, None, None] * F[None, None, :, :])
        A_iso += (cbj * I1 * (4.0 / 9.0)) * (FinvT[:, :, None, None] * FinvT[None, None, :, :])
        A_iso += (cbj * I1 * (2.0 / 3.0)) * (Finv[None, :, :, None] * FinvT[:, None, None, :])
        for i in range(3):
            for J in range(3):
                A_iso[i, J, i, J] += 2.0 * cbj
        return P + cb * D, A + A_iso

    def tangent_components(self, H, pairs):
        # The hot path of every Newton iteration: only the len(pairs) x len(pairs)
        # components (5 x 5 in axisymmetry), with the outer products of the
        # docstring grouped as d x (c d) + w x v + v x u + g G.
        if self.C20_kPa == 0:
            return self._nh.tangent_components(H, pairs)
        kin = kinematics(H)
        P, A = self._nh._tangent_components(H, pairs, kin)
        c = 2.0 * self.C20_kPa
        _, Finv, lnJ, _ = kin
        x, b, j = self._scalars(H, lnJ)
        rows = np.array([i for i, _ in pairs])
        cols = np.array([k for _, k in pairs])
        v = Finv[cols, rows]  # F^-T at the pairs
        f = H[rows, cols] + (rows == cols).reshape((-1,) + (1,) * (H.ndim - 2))  # F at the pairs
        # D = j (2 (H + F^-T H^T) - 2/3 x F^-T) at the pairs
        F_minus_FinvT = H[rows, cols] + np.einsum("aK...,aK...->a...", Finv[:, rows].swapaxes(0, 1), H[cols])
        d = j * (2.0 * F_minus_FinvT - (2.0 / 3.0) * x * v)
        cb = c * b
        s = cb * j
        I1 = 3.0 + x
        u = (-4.0 / 3.0) * s * f
        w = (4.0 / 9.0) * s * I1 * v + u
        A += d[:, None] * (c * d)[None, :]
        A += w[:, None] * v[None, :]
        A += v[:, None] * u[None, :]
        A += ((2.0 / 3.0) * s * I1) * (Finv[cols[:, None], rows[None, :]] * Finv[cols[None, :], rows[:, None]])
        same = np.arange(len(pairs))
        A[same, same] += 2.0 * s
        return P + cb * d, A
