r"""``body_drag``: hydrodynamic drag on the probe's body (cantilever, fibre), an effect of the instrument.

The sphere is not the only part of a probe that moves through the liquid: the cantilever (or the
optical fibre and ferrule of an interferometric probe) above it is tens to hundreds of times
larger. Its drag rises as the probe nears the surface as well, but over the body's size, not the
sphere's. Alcaraz et al. (*Langmuir* 18, 716, 2002) measured it on AFM cantilevers and
described it by the drag of an effective sphere of radius :math:`a_\mathrm{eff}` whose gap to
the surface is the tip-sample distance :math:`s` plus an effective height :math:`h_\mathrm{eff}`:

.. math:: F = b(s)\,v, \qquad b(s) = \frac{6 \pi \eta\, a_\mathrm{eff}^2}{s + h_\mathrm{eff}},

with :math:`a_\mathrm{eff}` up to the cantilever's size (hundreds of um) and :math:`h_\mathrm{eff}`
fitted. Far from the surface (:math:`s \gg h_\mathrm{eff}`) the force falls as
:math:`6 \pi \eta a_\mathrm{eff}^2 v / s`; with :math:`h_\mathrm{eff}` much larger than the
distances travelled it is a constant coefficient, the far field of :mod:`.drag`.

**The body moves with the cantilever's base, not with the tip.** The base (the piezo) sits at
:math:`z = d + F/k`, the tip's recorded depth :math:`d` plus the cantilever's deflection (the
baseline-free force over the spring constant :math:`k`,
:attr:`~skin_indent.measurement.PreparedCurve.deflection_mm`). The body's velocity is the base's,
:math:`v = \dot z = \dot d + \dot F / k`, and its gap to the surface shrinks by the base's travel past
the contact point, before contact and in it alike:

.. math:: s_\mathrm{body} = h_\mathrm{eff} - (d - c_0) - F/k,

:math:`c_0` the tip's recorded depth at contact: out of contact this is Alcaraz et al.'s
:math:`s + h_\mathrm{eff}` (with the small deflection the drag itself gives); in contact the body
keeps descending with the base by the indentation and the deflection. At the start of a retract the
tip is held in contact while the force falls: the base, and the body, already move out at the
piezo's speed, and the body's drag pulls the cantilever down with them (the Chiaro curve: 43 nN
in 40 ms, the recorded depth staying put). Where no cantilever shows (no spring constant in the file
and none estimated from the ramps: a depth recorded at the actuator), the base is the tip.
:math:`h_\mathrm{eff}` is at least the base's deepest travel past the contact guess (the body
never reaches the surface); the gap is held at :data:`H_EFF_MIN_MM` or more (the fitted contact
point may move a little past the guess).

Only :math:`\eta\,a_\mathrm{eff}^2` shows in a force: the parameter ``a_eff_mm`` is the effective
radius in a liquid of water's viscosity, :data:`ETA_BODY_MPA_S` (water at 20 C; culture media
are water-like, 0.7-1 mPa s at 20-37 C). It is fitted as the drag area ``a_eff2_mm2`` =
:math:`a_\mathrm{eff}^2`, in which the force is linear.

Like :mod:`.drag`, it acts before contact, in contact and after pull-off with the same
parameters, so the parts out of contact determine it; the preparation's baseline took what the
line fitted to the approach's pre-contact part holds of it (:func:`~.drag.baseline_part`). The
velocity is the base's (:func:`~.drag.probe_velocity` of :math:`z`).

Physical bounds: :math:`a_\mathrm{eff} \le` :data:`A_EFF_MAX_MM` (the longest common
cantilevers), :math:`h_\mathrm{eff}` in [:data:`H_EFF_MIN_MM` + the base's deepest travel past the
contact guess, :data:`H_EFF_MAX_MM`]. A fit that
ends on the small face of :math:`h_\mathrm{eff}` is a pull concentrated at the surface (adhesion,
tethers), one that ends on its far face wants a force that does not change with the distance
(the far field of :mod:`.drag`, or a baseline): the diagnosis does not name it then
(:func:`~skin_indent.diagnosis.instrument.at_physical_range`).
"""

from __future__ import annotations

import math

import numpy as np

from .base import EffectParameter, Evaluation
from .drag import LENGTH_MAX_MM, MPA_S, Drag, probe_velocity

#: the viscosity at which ``a_eff_mm`` is stated (mPa s): water at 20 C
ETA_BODY_MPA_S = 1.0
#: the largest effective radius of the body (mm): the longest common cantilevers (:data:`~.drag.LENGTH_MAX_MM`)
A_EFF_MAX_MM = LENGTH_MAX_MM
#: the smallest effective height (mm): 0.1 um, far below the depth resolution of a curve
H_EFF_MIN_MM = 1e-4
#: the largest effective height (mm): the body's size; beyond it the drag no longer changes over a curve
H_EFF_MAX_MM = LENGTH_MAX_MM


def body_drag_coefficient(eta_kPa_s, a_eff_mm, separation_mm, h_eff_mm):
    """Alcaraz et al.'s drag coefficient of the probe's body, b(s) = 6 pi eta a_eff^2 / (s + h_eff) (mN s/mm).

    Parameters
    ----------
    eta_kPa_s : float
        Viscosity of the liquid (kPa s; water at 20 C: 1e-6).
    a_eff_mm : float
        Effective radius of the body (mm).
    separation_mm : array_like
        The base's distance from where it was when the tip touched (mm; negative once it has travelled
        past it). The gap s + h_eff is held at :data:`H_EFF_MIN_MM` or more.
    h_eff_mm : float
        Effective height (mm, > 0): the body's gap when the tip touches the surface.
    """
    gap = np.maximum(np.asarray(separation_mm, dtype=float) + h_eff_mm, H_EFF_MIN_MM)
    return 6.0 * math.pi * eta_kPa_s * a_eff_mm**2 / gap


def base_travel(depth_mm, deflection_mm) -> np.ndarray:
    """The base's (piezo's) recorded travel, tip depth plus the cantilever's deflection (mm; the depth alone
    where ``deflection_mm`` is None)."""
    d = np.asarray(depth_mm, dtype=float)
    return d if deflection_mm is None else d + np.asarray(deflection_mm, dtype=float)


class BodyDrag(Drag):
    name = "body_drag"
    description = "hydrodynamic drag on the probe's body (instrument: cantilever or fibre, Alcaraz et al. 2002)"
    parameters = (
        EffectParameter("a_eff_mm", "mm", 0.0, A_EFF_MAX_MM, 0.0, False,
                        f"effective radius of the probe's body in its drag 6 pi eta a_eff^2 v / (s + h_eff), "
                        f"at eta = {ETA_BODY_MPA_S:g} mPa s"),
        EffectParameter("h_eff_mm", "mm", H_EFF_MIN_MM, H_EFF_MAX_MM, None, True,
                        "effective height of the body's drag above the tip-sample distance", 0.01),
    )

    @property
    def fit_names(self):
        return ("a_eff2_mm2", "h_eff_mm")

    def to_fit(self, values, E_kPa):
        return {"a_eff2_mm2": float(values["a_eff_mm"]) ** 2, "h_eff_mm": float(values["h_eff_mm"])}

    def from_fit(self, fit, E_kPa):
        return {"a_eff_mm": math.sqrt(max(float(fit["a_eff2_mm2"]), 0.0)), "h_eff_mm": float(fit["h_eff_mm"])}

    def fit_bounds(self, data, reach_mm=math.inf):
        """The physical bounds: :data:`A_EFF_MAX_MM`; :math:`h_\\mathrm{eff}` from the base's deepest travel past
        the contact guess (the body does not reach the surface) plus :data:`H_EFF_MIN_MM`, to :data:`H_EFF_MAX_MM`."""
        if data.time_s is None:
            raise ValueError("body_drag needs the measurement's time_s (the probe's velocity)")
        guess = float(getattr(data, "contact_guess_mm", math.nan))
        travel = float(np.max(base_travel(data.depth_mm, getattr(data, "deflection_mm", None)))) - guess
        lo = H_EFF_MIN_MM + (travel if math.isfinite(travel) and travel > 0 else 0.0)
        return {"a_eff2_mm2": (0.0, A_EFF_MAX_MM**2), "h_eff_mm": (min(lo, 0.5 * H_EFF_MAX_MM), H_EFF_MAX_MM)}

    def starts(self, data, bounds):
        """A body of a tenth of the largest; heights of a tenth of and all the travel out of contact."""
        lo, hi = bounds["h_eff_mm"]
        travel = float(getattr(data, "contact_guess_mm", math.nan) - np.min(data.depth_mm))
        heights = (0.1 * travel, travel) if math.isfinite(travel) and travel > 0 else (math.sqrt(lo * hi),)
        return {"a_eff2_mm2": (0.01 * bounds["a_eff2_mm2"][1],),
                "h_eff_mm": tuple(sorted({float(min(max(h, lo), hi)) for h in heights}))}

    def velocity(self, ev: Evaluation) -> np.ndarray:
        """The base's velocity (mm/s), that of the tip's depth plus the cantilever's deflection (cached per model)."""
        v = ev.cache.get("body_velocity")
        if v is None:
            v = ev.cache["body_velocity"] = probe_velocity(ev.time_s, base_travel(ev.depth_mm, ev.deflection_mm),
                                                           ev.kind)
        return v

    def force(self, ev: Evaluation, fit: dict, velocity_mm_s: np.ndarray) -> np.ndarray:
        """The body's drag (mN) at the base's velocity and gap: h_eff less the base's travel past contact."""
        a = math.sqrt(max(float(fit["a_eff2_mm2"]), 0.0))
        past = ev.h_mm if ev.deflection_mm is None else ev.h_mm + ev.deflection_mm
        return body_drag_coefficient(ETA_BODY_MPA_S * MPA_S, a, -past, float(fit["h_eff_mm"])) * velocity_mm_s
