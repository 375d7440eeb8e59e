"""``adhesion``: an attractive traction between sphere and skin, work of adhesion ``w_mJ_per_m2``.

One physics, the work of adhesion w (mJ/m^2 = 1e-3 mN/mm), in two forms:

- forward, the finite-element traction-gap law of
  :class:`~skin_indent.mechanics.contact_law.ContactLaw` with range :data:`RANGE_MM`;
- fitted, its Derjaguin-Muller-Toporov limit: the force is lowered by 2 pi w R while
  the sphere is below the contact point. DMT is the limit of that law for a small
  Tabor parameter (R w^2 / (E*^2 z0^3))^(1/3) < ~0.3 (skin, R = 6 mm, w ~ 1 mJ/m^2,
  E* ~ 10 kPa, z0 = 0.06 mm: 0.07; the finite-element pull-off is checked against
  DMT and JKR in ``tests/test_adhesion.py``).
"""

from __future__ import annotations

import math

import numpy as np

from .base import FORCE, Effect, EffectParameter, Evaluation, ForwardSpec

#: range of the adhesive traction law, mm (see :class:`~skin_indent.mechanics.contact_law.ContactLaw`)
RANGE_MM = 0.06


class Adhesion(Effect):
    name = "adhesion"
    description = "adhesion between sphere and skin (pull-off on unloading)"
    parameters = (EffectParameter("w_mJ_per_m2", "mJ/m2", 0.0, math.inf, 0.0, False, "work of adhesion"),)
    stage = FORCE
    linear_in_E = False

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        spec.contact["adhesion_mJ_per_m2"] = values["w_mJ_per_m2"]
        spec.contact["adhesion_range_mm"] = RANGE_MM

    def relative(self, values, E_kPa):
        """w / E: the adhesive force scales with the work of adhesion, the elastic one with E."""
        return {"w_mJ_per_m2": float(values["w_mJ_per_m2"]) / E_kPa}

    def fit_bounds(self, data, reach_mm=math.inf):
        """w from 0 to the value whose DMT pull-off equals the peak force."""
        peak = float(np.max(np.abs(data.force_mN)))
        return {"w_mJ_per_m2": (0.0, peak / (2e-3 * math.pi * data.radius_mm))}

    def starts(self, data, bounds):
        return {"w_mJ_per_m2": (0.1 * bounds["w_mJ_per_m2"][1],)}

    def apply(self, ev: Evaluation, fit: dict) -> None:
        w = float(fit["w_mJ_per_m2"])  # mJ/m^2 = 1e-3 mN/mm
        ev.force_mN = ev.force_mN - 2e-3 * math.pi * w * ev.radius_mm * (ev.h_mm > 0)

    def visible(self, data, noise_mN):
        if np.count_nonzero(data.force_mN < -3.0 * noise_mN) >= 3:  # not a stray noise sample
            return None
        if data.has("retract"):
            return "no tensile (negative) force beyond the noise on unloading: no pull-off to explain"
        return "no retract segment and no tensile force: adhesion shows as a pull-off on unloading"
