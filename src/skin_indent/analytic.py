r"""Closed-form contact solutions: references for tests and first guesses for fits.

Hertz (paraboloid approximation of the sphere, small strain)

.. math::

    F = \frac{4}{3} \frac{E}{1 - \nu^2} \sqrt{R}\, h^{3/2}

and Sneddon's exact small-strain solution for a sphere, in terms of the contact
radius a:

.. math::

    h = \frac{a}{2} \ln\frac{R + a}{R - a}, \qquad
    F = \frac{E^*}{2}\left[(a^2 + R^2)\ln\frac{R + a}{R - a} - 2 a R\right].
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq


def reduced_modulus(E_kPa, nu):
    """E* = E / (1 - nu^2), kPa."""
    return E_kPa / (1.0 - np.asarray(nu) ** 2)


def hertz_force(depth_mm, E_kPa, nu, radius_mm):
    """Hertz force (mN) of a rigid sphere on an elastic half-space.

    Parameters
    ----------
    depth_mm : array_like
        Indentation depth h, mm (negative depths give zero force).
    E_kPa : float
        Young's modulus, kPa.
    nu : float
        Poisson's ratio.
    radius_mm : float
        Sphere radius R, mm.
    """
    h = np.maximum(np.asarray(depth_mm, dtype=float), 0.0)
    return 4.0 / 3.0 * reduced_modulus(E_kPa, nu) * np.sqrt(radius_mm) * h**1.5


def sneddon_sphere_force(depth_mm, E_kPa, nu, radius_mm):
    """Sneddon's exact small-strain force (mN) for a rigid sphere (not a paraboloid).

    Parameters are those of :func:`hertz_force`; valid for depths below R.
    """
    h = np.atleast_1d(np.asarray(depth_mm, dtype=float))
    R = radius_mm
    out = np.zeros_like(h)
    for i, hi in enumerate(h):
        if hi <= 0:
            continue
        a = brentq(lambda a: 0.5 * a * np.log((R + a) / (R - a)) - hi, 1e-12 * R, R * (1 - 1e-12))
        out[i] = 0.5 * reduced_modulus(E_kPa, nu) * ((a**2 + R**2) * np.log((R + a) / (R - a)) - 2 * a * R)
    return out if np.ndim(depth_mm) else float(out[0])


def hertz_contact_radius(depth_mm, radius_mm):
    """Hertz contact radius a = sqrt(R h), mm."""
    return np.sqrt(radius_mm * np.maximum(np.asarray(depth_mm, dtype=float), 0.0))
