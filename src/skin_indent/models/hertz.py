"""Hertz's sphere as a force model of E* (kPa), for comparison with the large-strain fit."""

from __future__ import annotations

import numpy as np

from ..mechanics.analytic import hertz_force
from ..response_surface import SurfaceCore


class HertzModel(SurfaceCore):
    """Hertz's sphere F = 4/3 E* sqrt(R) h^1.5 as a force model of E* (kPa).

    Parameters
    ----------
    radius_mm : float
        Sphere radius R (mm).
    bounds : (float, float)
        Admissible E* (kPa).
    depth_range : (float, float), optional
        Depth range (mm) it is used over.
    """

    parameter_names = ("E_star_kPa",)

    def __init__(self, radius_mm: float, bounds: tuple[float, float], depth_range=(0.0, np.inf)):
        self.radius_mm = float(radius_mm)
        self.bounds = (np.array([bounds[0]], float), np.array([bounds[1]], float))
        self.depth_range = depth_range

    def _shape(self, depth_mm):
        return hertz_force(np.clip(np.asarray(depth_mm, float), 0, None), 1.0, 0.0, self.radius_mm)

    def force(self, depth_mm, theta) -> np.ndarray:
        return float(np.asarray(theta)[0]) * self._shape(depth_mm)

    def jacobian(self, depth_mm, theta) -> np.ndarray:
        return self._shape(depth_mm)[:, None]
