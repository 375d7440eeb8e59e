"""``offset``: a shifted contact point (depth origin), ``offset_mm``.

The recorded depth ``d`` starts at an arbitrary zero; contact begins at the recorded
depth ``offset_mm`` and the force is zero before it: F_rec(d) = F(d - offset_mm).
A nuisance parameter of fits; curves recorded from before contact (AFM) always fit it.
"""

from __future__ import annotations

import math

import numpy as np

from .base import DEPTH, Effect, EffectParameter, Evaluation, ForwardSpec


class Offset(Effect):
    name = "offset"
    description = "a shifted contact point (depth origin)"
    parameters = (EffectParameter("offset_mm", "mm", -math.inf, math.inf, 0.0, False,
                                  "recorded depth at which contact begins"),)
    stage = DEPTH
    linear_in_E = True
    per_curve = True  # each curve of a sample has its own contact point

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        spec.offset_mm = values["offset_mm"]

    def fit_bounds(self, data, reach_mm=math.inf):
        """Free over the data: from the first recorded depth (a curve that starts in contact:
        a quarter of the indentation before it) to where 3 points stay in contact, and no
        earlier than the elastic model reaches (``reach_mm``: the deepest indentation it covers)."""
        d = data.depth_mm
        first = float(d.min())
        if data.contact_mode == "origin":
            first -= 0.25 * data.max_indentation_mm
        last = float(np.sort(d)[-3]) if d.size >= 3 else float(d.max())
        if data.contact_mode == "origin":  # a skin curve starting in contact: a shift, not a new contact
            last = min(last, data.contact_guess_mm + 0.3 * data.max_indentation_mm)
        return {"offset_mm": (max(first, float(d.max()) - reach_mm), last)}

    #: starts, in units of the deepest indentation past the contact guess: the guess, a contact a
    #: little earlier and later (a fit from the guess alone can stop in a local minimum next to it)
    START_SHIFTS = (0.0, -0.1, 0.1, 0.2)

    def starts(self, data, bounds):
        """The contact guess first, then the guess moved by :data:`START_SHIFTS` of the deepest
        indentation, inside ``bounds``."""
        lo, hi = bounds["offset_mm"]
        guess, h = data.contact_guess_mm, float(getattr(data, "max_indentation_mm", 0.0))
        values = [min(max(guess + k * h, lo), hi) for k in self.START_SHIFTS] if h > 0 else [guess]
        return {"offset_mm": tuple(dict.fromkeys(values))}

    def apply(self, ev: Evaluation, fit: dict) -> None:
        ev.h_mm = ev.h_mm - float(fit["offset_mm"])

    def visible(self, data, noise_mN):
        if data.contact_mode != "origin":
            return "the contact point is already fitted (the curve starts before contact)"
        return None
