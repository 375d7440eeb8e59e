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
distances travelled it is a constant coefficient, the far field of :mod:`.drag`. In contact the
separation is held at 0: :math:`b(0) = 6 \pi \eta a_\mathrm{eff}^2 / h_\mathrm{eff}`, the value
Alcaraz et al. use to correct measurements in contact (the body's distance changes by the
indentation only, a small part of its height above the surface).

Only :math:`\eta\,a_\mathrm{eff}^2` shows in a force: the parameter ``a_eff_mm`` is the effective
radius in a liquid of water's viscosity, :data:`ETA_BODY_MPA_S` (water at 20 C; culture media
are water-like, 0.7-1 mPa s at 20-37 C). It is fitted as the drag area ``a_eff2_mm2`` =
:math:`a_\mathrm{eff}^2`, in which the force is linear.

Like :mod:`.drag`, it acts before contact, in contact and after pull-off with the same
parameters, so the parts out of contact determine it; the preparation's baseline took what the
line fitted to the approach's pre-contact part holds of it (:func:`~.drag.baseline_part`). The
velocity is the probe's (:func:`~.drag.probe_velocity`), that of the recorded depth.

Physical bounds: :math:`a_\mathrm{eff} \le` :data:`A_EFF_MAX_MM` (the longest common
cantilevers), :math:`h_\mathrm{eff}` in [:data:`H_EFF_MIN_MM`, :data:`H_EFF_MAX_MM`]. A fit that
ends on the small face of :math:`h_\mathrm{eff}` is a pull concentrated at the surface (adhesion,
tethers), one that ends on its far face wants a force that does not change with the distance
(the far field of :mod:`.drag`, or a baseline): the diagnosis does not name it then
(:func:`~skin_indent.diagnosis.instrument.at_physical_range`).
"""

from __future__ import annotations

import math

import numpy as np

from .base import EffectParameter, Evaluation
from .drag import LENGTH_MAX_MM, MPA_S, Drag

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
        Tip-sample distance (mm); held at 0 in contact (values below 0 count as 0).
    h_eff_mm : float
        Effective height (mm, > 0).
    """
    s = np.maximum(np.asarray(separation_mm, dtype=float), 0.0)
    return 6.0 * math.pi * eta_kPa_s * a_eff_mm**2 / (s + h_eff_mm)


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
        """The physical bounds, the same for every curve (:data:`A_EFF_MAX_MM`, :data:`H_EFF_MIN_MM`,
        :data:`H_EFF_MAX_MM`)."""
        if data.time_s is None:
            raise ValueError("body_drag needs the measurement's time_s (the probe's velocity)")
        return {"a_eff2_mm2": (0.0, A_EFF_MAX_MM**2), "h_eff_mm": (H_EFF_MIN_MM, H_EFF_MAX_MM)}

    def starts(self, data, bounds):
        """A body of a tenth of the largest; heights of a tenth of and all the travel out of contact."""
        lo, hi = bounds["h_eff_mm"]
        travel = float(getattr(data, "contact_guess_mm", math.nan) - np.min(data.depth_mm))
        heights = (0.1 * travel, travel) if math.isfinite(travel) and travel > 0 else (math.sqrt(lo * hi),)
        return {"a_eff2_mm2": (0.01 * bounds["a_eff2_mm2"][1],),
                "h_eff_mm": tuple(sorted({float(min(max(h, lo), hi)) for h in heights}))}

    def force(self, ev: Evaluation, fit: dict, velocity_mm_s: np.ndarray) -> np.ndarray:
        a = math.sqrt(max(float(fit["a_eff2_mm2"]), 0.0))
        return body_drag_coefficient(ETA_BODY_MPA_S * MPA_S, a, -ev.h_mm, float(fit["h_eff_mm"])) * velocity_mm_s
