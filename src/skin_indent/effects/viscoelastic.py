"""``viscoelastic``: quasi-linear viscoelasticity with one Prony term (``g1``, ``tau1_s``).

Forward: every material relaxes (:class:`~skin_indent.mechanics.materials.Viscoelastic`,
E is the instantaneous modulus). Fitted: the Lee-Radok / Ting hereditary integral over
the elastic force (:mod:`skin_indent.effects.hereditary`), exact at small
strain and the QLV approximation at large strain: no extra finite-element runs.
"""

from __future__ import annotations

import numpy as np

from .base import HISTORY, Effect, EffectParameter, Evaluation, ForwardSpec
from .hereditary import exponential_weights, hereditary_force, prony_weights


class Viscoelastic(Effect):
    name = "viscoelastic"
    description = "rate-dependent (quasi-linear viscoelastic) response"
    parameters = (
        EffectParameter("g1", "-", 0.0, 0.95, 0.0, False, "relative modulus of the Prony term"),
        EffectParameter("tau1_s", "s", 1e-3, 1e4, None, True, "relaxation time of the Prony term", 1.0),
    )
    stage = HISTORY
    needs_history = True
    kind = "relaxation"  # the alternative kernel: viscoelastic_powerlaw (:mod:`.powerlaw`)

    def configure(self, spec: ForwardSpec, values: dict) -> None:
        if values["g1"] > 0:
            spec.prony.append((values["g1"], values["tau1_s"]))

    def fit_bounds(self, data, reach_mm=float("inf")):
        """g1 in [0, 0.95]; tau from the sampling step (or 1e-3 of the duration) to 10 durations."""
        if data.time_s is None:
            raise ValueError("a viscoelastic model needs the measurement's time_s")
        duration = float(data.time_s[-1] - data.time_s[0])
        dt = np.diff(data.time_s)
        step = float(np.median(dt[dt > 0])) if np.any(dt > 0) else duration * 1e-3
        return {"g1": (0.0, self.parameters[0].upper), "tau1_s": (max(step, duration * 1e-3), 10.0 * duration)}

    def starts(self, data, bounds):
        duration = float(data.time_s[-1] - data.time_s[0])
        return {"g1": (0.3,), "tau1_s": (duration / 20, duration / 4, duration)}

    def apply(self, ev: Evaluation, fit: dict) -> None:
        g, tau = float(fit["g1"]), float(fit["tau1_s"])
        # the term's exponential weights depend on tau alone (a step in g1 reuses them; 64 kept per model)
        exponential = ev.cache.setdefault("exponential_weights", {})
        if tau not in exponential:
            if len(exponential) > 64:
                exponential.clear()
            exponential[tau] = exponential_weights(ev.time_s, tau)
        weights = prony_weights(ev.time_s, g, exponential[tau])
        ev.force_mN = hereditary_force(ev.time_s, ev.h_mm, ev.force_mN, ((g, tau),), weights=weights)

    def visible(self, data, noise_mN):
        if data.time_s is None:
            return "the curve has no time column: rate effects cannot be told from elastic ones"
        if data.has("hold") or data.has("retract"):
            return None
        v = _loading_speeds(data)
        if v.size > 5 and np.percentile(v, 90) > 1.5 * np.percentile(v, 10):
            return None
        return ("a single constant-speed loading ramp: relaxation during it looks like an elastic nonlinearity; "
                "a hold or an unloading segment would show it")

    def visible_in(self, curves, noises_mN):
        """Also visible in ramps of one sample at loading speeds that differ by more than 1.5 times
        (medians): relaxation makes the faster ramp stiffer, an elastic law does not."""
        why = super().visible_in(curves, noises_mN)
        if why is None or any(c.time_s is None for c in curves):
            return why
        speeds = [float(np.median(v)) for v in map(_loading_speeds, curves) if v.size > 5]
        if len(speeds) > 1 and max(speeds) > 1.5 * min(speeds):
            return None
        return ("constant-speed loading ramps at one speed: relaxation during them looks like an elastic "
                "nonlinearity; a hold, an unloading segment or a ramp at another speed would show it")


def _loading_speeds(data) -> np.ndarray:
    """The positive loading speeds between consecutive approach points (mm/s)."""
    load = data.kind == "approach"
    v = np.diff(data.depth_mm[load]) / np.diff(data.time_s[load])
    return v[np.isfinite(v) & (v > 0)]
