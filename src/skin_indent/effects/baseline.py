"""``baseline``: a constant force left after the pre-contact baseline is subtracted.

A nuisance parameter of fits over a whole approach (as AFM tools such as nanite fit
it: :func:`skin_indent.fitting.fit_hertz`). It has no finite-element form and is not in
the vocabulary that diagnosis names (not registered).
"""

from __future__ import annotations

import math

import numpy as np

from .base import FORCE, Effect, EffectParameter, Evaluation


class ForceBaseline(Effect):
    name = "baseline"
    description = "a constant force offset of the recorded curve (fitted jointly)"
    parameters = (EffectParameter("baseline_mN", "mN", -math.inf, math.inf, 0.0, False,
                                  "force added to the model everywhere"),)
    stage = FORCE
    linear_in_E = False
    per_curve = True  # a property of the recording, not of the sample

    def fit_bounds(self, data, reach_mm=math.inf):
        """At most a fifth of the peak force either way."""
        peak = float(np.max(np.abs(data.force_mN)))
        return {"baseline_mN": (-0.2 * peak, 0.2 * peak)}

    def starts(self, data, bounds):
        return {"baseline_mN": (0.0,)}

    def apply(self, ev: Evaluation, fit: dict) -> None:
        ev.force_mN = ev.force_mN + float(fit["baseline_mN"])
