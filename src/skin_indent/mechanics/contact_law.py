"""The rigid sphere and the law of its interface with the skin: frictionless, or with friction and adhesion.

What a simulation is told about the contact (:class:`SphericalIndenter`, :class:`ContactLaw`);
how the penalty contact integrates it, with the formulas of each law, is
:class:`~skin_indent.mechanics.contact.SphereContact`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: 1 mJ/m^2 = 1e-3 N/m = 1e-3 mN/mm (the model's energy per area unit).
MJ_PER_M2_IN_MN_PER_MM = 1e-3
#: Default adhesion range as a fraction of the largest depth of the problem.
DEFAULT_ADHESION_RANGE_FRACTION = 0.1


@dataclass(frozen=True)
class SphericalIndenter:
    """A rigid sphere.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R, mm (the paper: 6.22 mm).
    """

    radius_mm: float = 6.22

    def __post_init__(self):
        r = self.radius_mm
        if not (isinstance(r, (int, float, np.floating)) and np.isfinite(r) and r > 0):
            raise ValueError(f"sphere radius must be a finite number > 0 mm, got {r!r}")

    def surface_z(self, r_mm, depth_mm: float):
        """Height (mm) of the sphere's lower surface at radius ``r_mm`` (mm, ``<= R``) when its tip
        is ``depth_mm`` below the undeformed surface ``z = 0``: ``R - h - sqrt(R^2 - r^2)``."""
        R = self.radius_mm
        return (R - depth_mm) - np.sqrt(np.maximum(R**2 - r_mm**2, 0.0))


@dataclass(frozen=True)
class ContactLaw:
    """Interface law between the sphere and the skin (the formulas: :mod:`~skin_indent.mechanics.contact`).

    The default, ``ContactLaw()``, is the frictionless, non-adhesive penalty contact
    and runs exactly the code (and gives exactly the numbers) of the model without
    this option.

    Parameters
    ----------
    friction : float
        Coulomb friction coefficient mu (-), finite and >= 0. ``0`` is frictionless
        (the friction code is skipped entirely); a large value (e.g. 10) sticks
        wherever the surface touches. Friction makes the model path dependent:
        simulations need a protocol (time and depth), even for elastic materials.
    adhesion_mJ_per_m2 : float
        Work of adhesion w, mJ/m^2 (= 1e-3 mN/mm), >= 0. ``0`` is no adhesion.
    adhesion_range_mm : float, optional
        Range delta of the attraction, mm (> 0): the attractive pressure is
        ``(w/delta) exp(-g/delta)`` at a gap ``g``. The default (None) is
        ``DEFAULT_ADHESION_RANGE_FRACTION`` (10%) of the problem's largest depth.
        It sets the Tabor parameter ``mu_T = (R w^2 / (E*^2 delta^3))^(1/3)``: the
        pull-off force goes from DMT's ``2 pi w R`` (mu_T << 1) to JKR's
        ``1.5 pi w R`` (mu_T >> 1). The range is a regularisation: the cohesive
        zone (about ``0.4 a0 / mu_T^2``, ``a0`` the JKR contact radius at zero load)
        must span a few surface elements, and beyond mu_T ~ 1 the depth-controlled
        path has jumps (snap into contact, snap off after the pull-off) that
        Newton's method cannot follow.
    tangential_penalty : float
        Tangential penalty relative to the normal one, eps_T / eps (default 0.03:
        the elastic slip before sliding is about 1e-3 of the depth; stiffer
        penalties make Newton's method slow where points switch between stick and
        slip, and change the stick force by less than the increment error).

    Examples
    --------
    >>> ContactLaw(friction=0.3)                                   # doctest: +SKIP
    >>> ContactLaw(adhesion_mJ_per_m2=50.0, adhesion_range_mm=0.01)  # doctest: +SKIP
    """

    friction: float = 0.0
    adhesion_mJ_per_m2: float = 0.0
    adhesion_range_mm: float | None = None
    tangential_penalty: float = 0.03

    def __post_init__(self):
        def number(x):
            return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)

        if not (number(self.friction) and math.isfinite(self.friction) and self.friction >= 0):
            raise ValueError(f"friction coefficient must be a finite number >= 0, got {self.friction!r}")
        w = self.adhesion_mJ_per_m2
        if not (number(w) and math.isfinite(w) and w >= 0):
            raise ValueError(f"work of adhesion must be a finite number >= 0 mJ/m^2, got {w!r}")
        d = self.adhesion_range_mm
        if d is not None and not (number(d) and math.isfinite(d) and d > 0):
            raise ValueError(f"adhesion range must be a finite number > 0 mm, got {d!r}")
        t = self.tangential_penalty
        if not (number(t) and math.isfinite(t) and t > 0):
            raise ValueError(f"tangential penalty factor must be a finite number > 0, got {t!r}")

    @property
    def frictional(self) -> bool:
        return self.friction > 0

    @property
    def adhesive(self) -> bool:
        return self.adhesion_mJ_per_m2 > 0

    @property
    def path_independent(self) -> bool:
        """False with friction: the traction depends on the slip history."""
        return not self.frictional

    @property
    def work_of_adhesion_mN_per_mm(self) -> float:
        """w in the model's units, mN/mm (= mN mm / mm^2)."""
        return self.adhesion_mJ_per_m2 * MJ_PER_M2_IN_MN_PER_MM

    def range_mm(self, max_depth_mm: float) -> float:
        """The adhesion range delta (mm) for a problem whose largest depth is ``max_depth_mm``."""
        if self.adhesion_range_mm is not None:
            return float(self.adhesion_range_mm)
        return DEFAULT_ADHESION_RANGE_FRACTION * float(max_depth_mm)
