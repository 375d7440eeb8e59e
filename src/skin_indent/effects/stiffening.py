"""``stiffening``: strain stiffening of the tissue, W = W_NH + C20 (I1b - 3)^2 (Yeoh type).

Parameter ``C20_kPa``; in every material of a model it scales with the local modulus.
It is fitted on a response surface over ``C20_over_E`` = C20 / E.
"""

from __future__ import annotations

import math

from .base import ELASTIC, Effect, EffectParameter, ForwardSpec
from .base import EffectAxis


class Stiffening(Effect):
    name = "stiffening"
    description = "strain stiffening of the tissue"
    parameters = (EffectParameter("C20_kPa", "kPa", 0.0, math.inf, 0.0, False,
                                  "Yeoh-type stiffening: W = W_NH + C20 (I1b - 3)^2"),)
    stage = ELASTIC

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        spec.C20_over_E = values["C20_kPa"] / spec.E_kPa

    @property
    def fit_names(self):
        return ("C20_over_E",)

    def to_fit(self, values, E_kPa):
        return {"C20_over_E": float(values["C20_kPa"]) / E_kPa}

    def from_fit(self, fit, E_kPa):
        return {"C20_kPa": float(fit["C20_over_E"]) * E_kPa}

    def surface_axes(self, max_depth_mm):
        """C20 / E in [0, 10]."""
        return (EffectAxis("C20_over_E", (0.0, 0.3, 0.8, 1.6, 3.0, 5.5, 10.0), "linear"),)

    def starts(self, data, bounds):
        return {"C20_over_E": (0.5, 4.0)}
