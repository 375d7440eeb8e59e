r"""Neo-Hookean solids with or without strain stiffening, evaluated on the five components of
an axisymmetric deformation gradient, with parameters per quadrature point.

In axisymmetry the deformation gradient has five non-zero components,

.. math::

    F = \begin{pmatrix} F_{rr} & F_{rz} & 0 \\ F_{zr} & F_{zz} & 0 \\ 0 & 0 & F_{\theta\theta}
        \end{pmatrix},

so its inverse, its determinant and every contraction of the laws of
:class:`~.neo_hooke.NeoHooke` and :class:`~.stiffening.NeoHookeStiffening` reduce to a few
products of those components. :class:`AxisymmetricStiffening` evaluates the stress and the
tangent of a body whose regions (bonded layers) are any of the two laws, in one pass over all
quadrature points with the Lame parameters and ``C20`` given per point (``C20 = 0``: the
neo-Hookean law). It gives the same numbers as the laws' own 3 x 3 code up to round-off
(checked in the tests) at a fraction of the cost: the finite-element model of a layer with
stiffening evaluates the stress some 200 times per curve.
"""

from __future__ import annotations

import numpy as np

#: (row, column) of the five non-zero components of F, the order of
#: :data:`skin_indent.mechanics.axisymmetric.F_COMPONENTS`
COMPONENTS = ((0, 0), (0, 1), (1, 0), (1, 1), (2, 2))
_ROWS = np.array([i for i, _ in COMPONENTS])
_COLS = np.array([j for _, j in COMPONENTS])


class AxisymmetricStiffening:
    r"""The law :math:`W = W_\mathrm{NH}(\mu, \lambda) + C_{20}(\bar I_1 - 3)^2` with its parameters
    per quadrature point, on the components :data:`COMPONENTS` of an axisymmetric ``H = F - I``.

    The formulas are those of :class:`~.stiffening.NeoHookeStiffening` (its docstring), with
    the inverse of F from its in-plane block, :math:`\ln J` from
    :math:`J - 1 = (j_2 - 1)(1 + H_{\theta\theta}) + H_{\theta\theta}` and
    :math:`j_2 - 1 = H_{rr} + H_{zz} + H_{rr}H_{zz} - H_{rz}H_{zr}` (no cancellation).

    Parameters
    ----------
    mu, lam : ndarray
        Lame parameters of the neo-Hookean part (kPa) at the quadrature points, shape ``H.shape[2:]``.
    c20 : ndarray
        Stiffening modulus C20 (kPa) at the quadrature points, same shape (0 where a region is
        neo-Hookean).
    """

    path_independent = True
    small_strain = False

    def __init__(self, mu: np.ndarray, lam: np.ndarray, c20: np.ndarray):
        self.mu, self.lam, self.c20 = (np.asarray(a, dtype=float) for a in (mu, lam, c20))
        self.stiffening = bool(np.any(self.c20 != 0))

    @staticmethod
    def _check(pairs) -> None:
        if tuple(map(tuple, pairs)) != COMPONENTS:
            raise ValueError(f"the axisymmetric evaluation takes the components {COMPONENTS}, got {pairs}")

    def _kinematics(self, H):
        """``(G, v, lnJ, x)``: G = F - F^-T and v = F^-T at the components (5, ...), ln J, x = I1 - 3."""
        h00, h01, h10, h11, h22 = (H[i, j] for i, j in COMPONENTS)
        j2m1 = h00 + h11 + h00 * h11 - h01 * h10
        lnJ = np.log1p(j2m1 + h22 + j2m1 * h22)
        inv = 1.0 / (1.0 + j2m1)
        v = np.stack([(1.0 + h11) * inv, -h10 * inv, -h01 * inv, (1.0 + h00) * inv, 1.0 / (1.0 + h22)])
        # F - F^-T = H + F^-T H^T, component by component (the in-plane block and the hoop term)
        G = np.stack([h00 + v[0] * h00 + v[1] * h01,
                      h01 + v[0] * h10 + v[1] * h11,
                      h10 + v[2] * h00 + v[3] * h01,
                      h11 + v[2] * h10 + v[3] * h11,
                      h22 + v[4] * h22])
        x = 2.0 * (h00 + h11 + h22) + (h00 * h00 + h01 * h01 + h10 * h10 + h11 * h11 + h22 * h22)
        return G, v, lnJ, x

    def _isochoric(self, G, v, lnJ, x):
        """``(b, j, D)``: b = I1b - 3, j = J^(-2/3), D = dI1b/dF at the components."""
        jm1 = np.expm1(-2.0 / 3.0 * lnJ)
        j = 1.0 + jm1
        return (3.0 + x) * jm1 + x, j, j * (2.0 * G - (2.0 / 3.0) * x * v)

    def _stress(self, G, v, lnJ, x):
        """``(P, (b, j, D) or None)``: the stress at the components and, with stiffening, the isochoric terms."""
        P = self.mu * G + (self.lam * lnJ) * v
        if not self.stiffening:
            return P, None
        b, j, D = self._isochoric(G, v, lnJ, x)
        return P + (2.0 * self.c20 * b) * D, (b, j, D)

    def stress_components(self, H, pairs=COMPONENTS) -> np.ndarray:
        """First Piola stress (kPa) at the components ``pairs`` (:data:`COMPONENTS`), shape (5, ...)."""
        self._check(pairs)
        return self._stress(*self._kinematics(H))[0]

    def tangent_components(self, H, pairs=COMPONENTS) -> tuple[np.ndarray, np.ndarray]:
        """``(P, A)``: the stress (5, ...) and the tangent dP/dF (5, 5, ...) at the components."""
        self._check(pairs)
        G, v, lnJ, x = self._kinematics(H)
        P, isochoric = self._stress(G, v, lnJ, x)
        mu, lam = self.mu, self.lam
        # M[p, q] = F^-T[k, J] F^-T[i, L] for p = (i, J), q = (k, L): from the 3 x 3 F^-T (zeros off the blocks)
        full = np.zeros((3, 3) + v.shape[1:])
        full[_ROWS, _COLS] = v
        M = full[_ROWS[None, :], _COLS[:, None]] * full[_ROWS[:, None], _COLS[None, :]]
        diagonal = mu
        A = (lam * v)[:, None] * v[None, :]
        if isochoric is not None:
            c = 2.0 * self.c20
            b, j, D = isochoric
            s = c * b * j
            I1 = 3.0 + x
            f = np.stack([1.0 + H[0, 0], H[0, 1], H[1, 0], 1.0 + H[1, 1], 1.0 + H[2, 2]])  # F at the components
            u = (-4.0 / 3.0) * s * f
            w = (4.0 / 9.0) * s * I1 * v + u
            A += D[:, None] * (c * D)[None, :] + w[:, None] * v[None, :] + v[:, None] * u[None, :]
            A += (mu - lam * lnJ + (2.0 / 3.0) * s * I1) * M
            diagonal = mu + 2.0 * s
        else:
            A += (mu - lam * lnJ) * M
        same = np.arange(len(COMPONENTS))
        A[same, same] += diagonal
        return P, A
