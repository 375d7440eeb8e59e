r"""``baselines``: a baseline of each segment after the approach, an effect of the instrument.

The preparation subtracts one line, fitted to the approach's pre-contact part, from the
whole curve (:func:`~skin_indent.measurement.prepare`): the virtual deflection of the
cantilever as a function of the piezo position and the offset of the approach. What that
one line misses is what drifts during the later segments (thermal drift of the
cantilever, the laser, the piezo's creep): the baseline of the hold and of the retract
each have a tilt of their own.

A baseline does not jump: each segment's baseline starts where the one before ended
(continuous in time), and tilts by its own rate,

.. math:: b(t) = b(t_k) + \beta_k\,(t - t_k), \qquad t_k \le t < t_{k+1},

with :math:`b = 0` on the approach (the subtracted line). Its offset at the start of each
segment is thus set by the segments before; a step where the motion turns is the drag's
(:mod:`.drag`), which flips with the velocity. That is what tells the two apart in the data.

Two effects, one per segment kind after the approach, each visible where its segment is:
``baselines`` (the retract's tilt ``retract_drift_mN_per_s``) and ``hold_baseline`` (the
hold's, ``hold_drift_mN_per_s``).
"""

from __future__ import annotations

import math

import numpy as np

from .base import FORCE, Effect, EffectParameter, Evaluation

#: fewest points of a segment whose baseline is fitted
MIN_POINTS = 10
#: the most a baseline drifts during one segment, as a fraction of the peak force
MAX_DRIFT = 0.1


class SegmentBaseline(Effect):
    """The drift of the baseline during one segment kind (continuous with the segments before)."""

    stage = FORCE
    linear_in_E = False
    per_curve = True  # each recording's own drift
    instrument = True

    def __init__(self, kind: str, name: str):
        self.kind = kind
        self.name = name
        self.description = f"baseline drift during the {kind} (instrument; continuous from the segment before)"
        self.parameters = (EffectParameter(f"{kind}_drift_mN_per_s", "mN/s", -math.inf, math.inf, 0.0, False,
                                           f"rate of change of the force baseline during the {kind}"),)

    @property
    def _key(self) -> str:
        return self.parameters[0].name

    def _span(self, time_s, kind) -> tuple[float, float]:
        """First and last time (s) of the segment (the first run of that kind)."""
        t = np.asarray(time_s, dtype=float)[np.asarray(kind) == self.kind]
        return (float(t[0]), float(t[-1])) if t.size else (math.inf, math.inf)

    def fit_bounds(self, data, reach_mm=math.inf):
        """A drift of at most :data:`MAX_DRIFT` of the peak force over the segment, either way: a
        baseline that moves more than that during one segment is not a baseline (an adhesive pull on
        the retract, the sample's creep in a hold)."""
        if data.time_s is None:
            raise ValueError(f"{self.name} needs the measurement's time_s")
        a, b = self._span(data.time_s, data.kind)
        peak = float(np.max(np.abs(data.force_mN)))
        rate = MAX_DRIFT * peak / max(b - a, 1e-9) if math.isfinite(a) else MAX_DRIFT * peak
        return {self._key: (-rate, rate)}

    def starts(self, data, bounds):
        return {self._key: (0.0,)}

    def apply(self, ev: Evaluation, fit: dict) -> None:
        if ev.time_s is None or ev.kind is None:
            raise ValueError(f"{self.name} needs the measurement's time_s and segments")
        key = f"baseline_span_{self.kind}"
        if key not in ev.cache:
            ev.cache[key] = self._span(ev.time_s, ev.kind)
        a, b = ev.cache[key]
        if not math.isfinite(a):
            return
        elapsed = np.clip(ev.time_s, a, b) - a  # 0 before the segment, held after it (continuous)
        ev.force_mN = ev.force_mN + float(fit[self._key]) * elapsed

    def visible(self, data, noise_mN):
        if data.time_s is None:
            return "the curve has no time column: a drift cannot be placed in time"
        if data.contact_mode != "fit":
            return "the curve starts in contact: no baseline was subtracted to correct"
        if np.count_nonzero(data.kind == self.kind) < MIN_POINTS:
            return f"no {self.kind} segment of {MIN_POINTS} points or more"
        return None
