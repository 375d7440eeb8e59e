"""Identification of (E, nu) on a response surface: Hertz start, checks, method dispatch.

:func:`identify` is the paper's step: a loading curve (depth from the contact point),
a response surface, one of the methods of :mod:`skin_indent.inverse`. The user's path
from a recorded curve (baseline, contact point, Hertz comparison, fit quality) is
:func:`skin_indent.fitting.fit`.
"""

from __future__ import annotations

import numpy as np

from ..mechanics.analytic import hertz_force
from .. import inverse
from ..measurement import MeasurementError
from .surfaces import check_inside

METHODS = ("ekf-paper", "ekf", "lsq")
#: The paper's in vivo stop rule.
PAPER_TOLERANCE = 1e-5
#: The nu the finite-element surfaces offer next to incompressibility (the law needs nu < 0.5);
#: nu = 0.5 itself is its limit (:func:`skin_indent.fitting.one_fit.incompressible_limit`).
NEARLY_INCOMPRESSIBLE_NU = 0.499


def hertz_modulus(depth_mm, force_mN, radius_mm: float) -> float:
    """Reduced modulus E* = E / (1 - nu^2) (kPa) of the least-squares Hertz fit through the origin."""
    shape = hertz_force(depth_mm, 1.0, 0.0, radius_mm)  # 4/3 sqrt(R) h^1.5
    denom = float(shape @ shape)
    if denom <= 0:
        raise ValueError("cannot estimate a modulus: all depths are <= 0")
    with np.errstate(over="ignore", invalid="ignore"):
        e_star = float(shape @ np.asarray(force_mN)) / denom
    if not e_star > 0:
        raise ValueError("cannot estimate a modulus: the force does not increase with depth")
    return e_star


def start_values(surface, depth_mm, force_mN, radius_mm: float, nu: float = 0.4) -> np.ndarray:
    """Hertz first guess (E, nu) clipped into the surface's box."""
    lo, hi = surface.bounds
    nu = float(np.clip(nu, lo[1], hi[1]))
    E = hertz_modulus(depth_mm, force_mN, radius_mm) * (1 - nu**2)
    return np.array([float(np.clip(E, lo[0], hi[0])), nu])


def check_fixed(fixed: dict, surface) -> None:
    """One-line errors for fixed values the surface cannot take (nu = 0.5 is taken as a limit by ``fit``)."""
    lo, hi = surface.bounds
    nu = fixed.get("nu")
    if nu is not None and nu > 0.5:
        raise ValueError(f"nu = {nu:g} is above 0.5, the incompressible limit")
    if nu == 0.5:
        raise ValueError("nu = 0.5 is the incompressible limit of the finite-element law: skin_indent.fitting.fit "
                         f"takes it as such; here fix nu={NEARLY_INCOMPRESSIBLE_NU} instead")
    for k, name in enumerate(("E_kPa", "nu")):
        v = fixed.get(name)
        if v is not None and not lo[k] * (1 - 1e-9) <= v <= hi[k] * (1 + 1e-9):
            raise ValueError(f"fixed {name} = {v:g} is outside the response surface [{lo[k]:g}, {hi[k]:g}]")


def check_modulus_range(e_star_kPa: float, surface, nu: float = 0.4) -> None:
    """One-line error when the Hertz estimate of E lies far outside the surface's E range."""
    lo, hi = surface.bounds
    E = e_star_kPa * (1 - nu**2)
    if not (np.isfinite(E) and lo[0] / 3 <= E <= 3 * hi[0]):
        raise ValueError(f"the data need E ~ {E:.3g} kPa (Hertz estimate), far outside the surface's "
                         f"{lo[0]:g}-{hi[0]:g} kPa: build a surface whose E range covers it")


def run_method(model, depth, force, x0, method: str = "lsq", *, fixed=None, tol=None, noise_mN=None):
    """One identification method of :mod:`skin_indent.inverse` by name (``"ekf-paper"``, ``"ekf"``, ``"lsq"``)."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    kwargs = {"fixed": fixed}
    if method == "lsq":
        return inverse.fit_least_squares(model, depth, force, x0, noise_mN=noise_mN, **kwargs)
    if tol is not None:
        kwargs["tol"] = tol
    if method == "ekf":
        return inverse.fit_ekf(model, depth, force, x0, noise_mN=noise_mN, **kwargs)
    return inverse.fit_ekf_paper(model, depth, force, x0, **kwargs)


def identify(data, surface, method: str = "lsq", *, x0=None, fixed=None, tol: float | None = None,
             radius_mm: float | None = None, noise_mN: float | None = None):
    """Identify (E, nu) from a loading curve with a response surface.

    Parameters
    ----------
    data : PreparedCurve or Measurement
        Increasing loading data, depth from the contact point (mm) and force (mN):
        ``prepare(measurement, window=..., contact="origin")``.
    surface : ResponseSurface
        The forward model (``force``/``jacobian`` over (E_kPa, nu)).
    method : {"ekf-paper", "ekf", "lsq"}
        The paper's filter with global stabilisation, the better-conditioned filter,
        or least squares.
    x0 : array_like, optional
        Start (E_kPa, nu); default a Hertz estimate at nu = 0.4.
    fixed : dict, optional
        Parameters held fixed, e.g. ``{"nu": 0.499}``.
    tol : float, optional
        Stop rule C of the filters (default 1e-6 as in the paper's blind tests).
    radius_mm : float, optional
        Sphere radius for the Hertz start (default the data's, else the surface's).
    noise_mN : float, optional
        Noise level; default estimated from the data.

    Returns
    -------
    skin_indent.inverse.IdentificationResult
    """
    depth, force = np.asarray(data.depth_mm, float), np.asarray(data.force_mN, float)
    if depth.size < 3:
        raise MeasurementError(f"{data.source}: fewer than 3 points to fit")

    check_inside(surface, depth)
    if fixed:
        check_fixed(dict(fixed), surface)
    radius = radius_mm or getattr(data, "radius_mm", None) or float(surface.settings.get("radius_mm", 6.22))
    e_star = hertz_modulus(depth, force, radius)
    check_modulus_range(e_star, surface)
    if x0 is None:
        x0 = start_values(surface, depth, force, radius)
    return run_method(surface, depth, force, x0, method, fixed=fixed, tol=tol, noise_mN=noise_mN)
