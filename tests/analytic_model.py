"""Analytic stand-in for the finite-element response surface (tests only).

Implements the ``ForceModel`` protocol of :mod:`skin_indent.inverse`::

    F(h; E, nu) = 4/3 * E / (1 - nu^2) * sqrt(R) * h**1.5 * (1 - c(nu) * h / R),
    c(nu) = 0.15 + 0.3 * (0.5 - nu),

with R = 6.22 mm (the paper's sphere). The first factor is Hertz, which depends on
``E* = E / (1 - nu^2)`` only; the ``c(nu)`` term is a weak, large-strain-like
dependence on nu that breaks the E-nu tie, as the paper claims the FE model does.

Units: depth in mm, E in kPa, force in mN (kPa mm^2 = mN).
"""

from __future__ import annotations

import numpy as np


class HertzLikeModel:
    """Hertz-like sphere indentation force with a weak nu dependence.

    Parameters
    ----------
    radius_mm : float, optional
        Sphere radius R (mm). Default 6.22 mm.
    lower, upper : sequence of float, optional
        Valid box for ``(E_kPa, nu)``. ``force`` raises ``ValueError`` outside it,
        like the interpolated response surface does.
    """

    parameter_names: tuple[str, ...] = ("E_kPa", "nu")

    nu_coefficient: float = 0.3  # d c / d(0.5 - nu); 0 gives pure Hertz in E* (nu not identifiable)

    def __init__(self, radius_mm=6.22, lower=(1.0, 0.2), upper=(100.0, 0.49)):
        self.radius_mm = float(radius_mm)
        self.bounds = (np.asarray(lower, float), np.asarray(upper, float))

    def _check(self, theta):
        theta = np.asarray(theta, float)
        if theta.shape != (2,):
            raise ValueError(f"theta must have shape (2,), got {theta.shape}")
        E, nu = float(theta[0]), float(theta[1])
        (elo, nlo), (ehi, nhi) = self.bounds
        if not (elo <= E <= ehi and nlo <= nu <= nhi):  # also rejects NaN
            raise ValueError(f"theta {theta} outside the model bounds {self.bounds[0]}..{self.bounds[1]}")
        return E, nu

    def _parts(self, depth_mm, theta):
        E, nu = self._check(theta)
        h = np.maximum(np.asarray(depth_mm, float), 0.0)
        R = self.radius_mm
        g = (4.0 / 3.0 * np.sqrt(R)) * h**1.5
        c = 0.15 + self.nu_coefficient * (0.5 - nu)
        k = 1.0 / (1.0 - nu * nu)
        s = 1.0 - (c / R) * h
        return E, nu, h, R, g, k, s

    def force(self, depth_mm, theta):
        """Force (mN) at depths ``depth_mm`` (mm) for ``theta = (E_kPa, nu)``."""
        E, nu, h, R, g, k, s = self._parts(depth_mm, theta)
        return (E * k) * g * s

    def jacobian(self, depth_mm, theta):
        """dF/dtheta, shape (n, 2): columns dF/dE (mN/kPa) and dF/dnu (mN)."""
        E, nu, h, R, g, k, s = self._parts(depth_mm, theta)
        out = np.empty(h.shape + (2,))
        out[..., 0] = k * g * s
        out[..., 1] = E * g * ((2.0 * nu * k * k) * s + (k * self.nu_coefficient / R) * h)
        return out


class PureHertzModel(HertzLikeModel):
    """Same, but the correction does not depend on nu: F depends on E* only."""

    nu_coefficient = 0.0
