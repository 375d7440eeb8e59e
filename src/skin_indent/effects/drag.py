r"""``drag``: hydrodynamic drag on the probe, an effect of the instrument (not of the sample).

A probe moving through the liquid above the sample feels a force against its velocity
:math:`v = \mathrm{d}(\mathrm{depth})/\mathrm{d}t` (mm/s, positive into the sample). Two terms:

- **near the surface**, the sphere squeezes the liquid out of the gap: the lubrication
  (Reynolds) limit of a sphere approaching a plane wall at separation :math:`s`,

  .. math:: F_\mathrm{near} = \frac{6 \pi \eta R^2 v}{s + s_0},

  the leading term of Brenner's exact solution (Brenner 1961, *Chem. Eng. Sci.* 16, 242) for
  :math:`s \ll R` (checked in ``tests/test_instrument.py``), bounded as :math:`s \to 0` by
  :math:`s_0` = :data:`GAP_FRACTION` R (roughness and slip of real surfaces); in contact the
  separation is held at 0 (:math:`F = 6 \pi \eta R^2 v / s_0`);
- **far field**, the cantilever (beam and tip) moving through the liquid:
  :math:`F_\mathrm{far} = c\,v`, a constant coefficient.

The separation is read from the fitted contact point (``offset``): :math:`s = \max(c_0 - d, 0)`
with :math:`c_0` the recorded depth of contact. The recorded force is positive in
compression, so drag adds to it on approach (it pushes the probe back) and takes from it on
retract (it pulls the probe towards the sample): the retract lies below the approach.

What the preparation subtracted already: the baseline line fitted to the approach's
pre-contact part (:class:`~skin_indent.measurement.contact.Baseline`, over its depths
``depth_range_mm``, flat where its tilt was not significant) was taken from the whole curve,
and it holds the drag of those points (the far field at the approach speed, the start of the
near-wall rise). The fitted drag is therefore the drag less the same line fitted to the
drag itself over the same points (:func:`baseline_part`): what the recorded, baseline-free
force holds of it, a step where the motion turns, the rise near the surface.

Drag acts before contact, in contact and after pull-off alike with the same two
parameters, so the parts out of contact (where the sample gives no force) determine it;
a per-segment baseline (:mod:`.segment_baseline`) is continuous in time, so the data
tell the two apart: drag steps with the velocity at a turn and grows as :math:`1/s` near
the surface, a baseline drifts linearly in time.
"""

from __future__ import annotations

import math

import numpy as np

from .base import FORCE, Effect, EffectParameter, Evaluation

#: the gap that bounds the lubrication force as the separation goes to 0, over the sphere radius
GAP_FRACTION = 0.05
#: viscosity unit of the parameter: 1 mPa s = 1e-6 kPa s (kPa x mm^2 x mm/s / mm = mN)
MPA_S = 1e-6
#: the most viscous liquid a probe is taken to move in (mPa s): ten times water (0.7-1 mPa s at 20-37 C;
#: culture media are water-like)
ETA_MAX_MPA_S = 10.0
#: the longest probe (cantilever) whose far-field drag is allowed (mm): 0.5 mm, the longest common cantilevers
LENGTH_MAX_MM = 0.5
#: the largest far-field coefficient (N s/m = mN s/mm): the Stokes drag of a sphere of radius
#: :data:`LENGTH_MAX_MM` in a liquid of :data:`ETA_MAX_MPA_S`, 6 pi eta L (9.4e-5 N s/m; a 200 um
#: cantilever in water has 1e-6 to 1e-5)
DRAG_MAX_N_S_PER_M = 6.0 * math.pi * ETA_MAX_MPA_S * MPA_S * LENGTH_MAX_MM


def probe_velocity(time_s: np.ndarray, depth_mm: np.ndarray, kind: np.ndarray | None) -> np.ndarray:
    """The probe's velocity (mm/s) at every point, smoothed within each run of one kind of motion.

    A local quadratic (Savitzky-Golay) derivative over a window of 5 % of the run (at least 5
    points), so that the recorded depth's noise does not enter the drag, taken along the samples
    of depth and of time alike (exact on a ramp where the samples are not evenly spaced in time:
    a last bin of fewer samples); a run shorter than 5 points takes its mean speed.

    Parameters
    ----------
    time_s, depth_mm : ndarray
        Times (s) and recorded depths (mm), in time order.
    kind : ndarray of str or None
        The segment of each point (``approach``, ``hold``, ``retract``); None: one run.
    """
    from scipy.signal import savgol_filter

    t = np.asarray(time_s, dtype=float)
    d = np.asarray(depth_mm, dtype=float)
    labels = np.zeros(d.size, dtype=int) if kind is None else np.unique(np.asarray(kind), return_inverse=True)[1]
    edges = np.r_[0, np.flatnonzero(np.diff(labels)) + 1, d.size]
    v = np.zeros_like(d)
    for a, b in zip(edges[:-1], edges[1:]):
        n = b - a
        if n < 2:
            continue
        if n < 5:
            v[a:b] = (d[b - 1] - d[a]) / (t[b - 1] - t[a])
            continue
        w = max(5, int(0.05 * n) | 1)
        w = min(w, n if n % 2 else n - 1)
        # the derivatives of depth and time along the samples, by the same linear smoother: their ratio is
        # exact on a ramp however the samples are spaced in time (a segment's last bin of fewer samples)
        v[a:b] = savgol_filter(d[a:b], w, 2, deriv=1, mode="interp") / savgol_filter(t[a:b], w, 2, deriv=1,
                                                                                     mode="interp")
    return v


def lubrication_force(eta_kPa_s, radius_mm, velocity_mm_s, separation_mm, gap_mm):
    """The lubrication drag of a sphere near a plane, 6 pi eta R^2 v / (s + s0) (mN).

    Parameters
    ----------
    eta_kPa_s : float
        Viscosity of the liquid (kPa s; water at 20 C: 1e-6).
    radius_mm : float
    velocity_mm_s, separation_mm : array_like
        Towards the plane (mm/s) and the gap (mm, >= 0).
    gap_mm : float
        The bound s0 as the gap closes (mm).
    """
    s = np.maximum(np.asarray(separation_mm, dtype=float), 0.0)
    return 6.0 * math.pi * eta_kPa_s * radius_mm**2 * np.asarray(velocity_mm_s, dtype=float) / (s + gap_mm)


def baseline_part(force_mN, depth_mm, kind, baseline) -> np.ndarray:
    """What the preparation's baseline subtraction took of a force: the line (flat where the
    subtracted one is flat) fitted to ``force_mN`` over the approach points in the baseline's
    depths, at every depth (mN). Zero when no baseline was subtracted or fewer than 2 points are there.

    Parameters
    ----------
    force_mN, depth_mm : ndarray
    kind : ndarray of str or None
    baseline : Baseline or None
        :attr:`~skin_indent.measurement.PreparedCurve.baseline`.
    """
    f = np.asarray(force_mN, dtype=float)
    d = np.asarray(depth_mm, dtype=float)
    if baseline is None:
        return np.zeros_like(f)
    a, b = baseline.depth_range_mm
    rows = (d >= a) & (d <= b)
    if kind is not None:
        rows &= np.asarray(kind) == "approach"
    if np.count_nonzero(rows) < 2:
        return np.zeros_like(f)
    if baseline.slope_mN_per_mm == 0.0:
        return np.full_like(f, float(np.mean(f[rows])))
    slope, offset = np.polyfit(d[rows], f[rows], 1)
    return offset + slope * d


class Drag(Effect):
    name = "drag"
    description = "hydrodynamic drag on the probe (instrument: near-wall lubrication and cantilever far field)"
    parameters = (
        EffectParameter("eta_mPa_s", "mPa_s", 0.0, math.inf, 0.0, False,
                        "viscosity of the liquid in the lubrication drag of the sphere near the surface"),
        EffectParameter("drag_N_s_per_m", "N_s/m", 0.0, math.inf, 0.0, False,
                        "far-field drag coefficient of the cantilever (force per probe speed; = mN s/mm)"),
    )
    stage = FORCE
    linear_in_E = False
    per_curve = True  # each curve's probe and speeds
    instrument = True

    def _speeds(self, data) -> float:
        """The fastest |speed| (mm/s) of a prepared curve."""
        return float(np.max(np.abs(probe_velocity(data.time_s, data.depth_mm, data.kind))))

    def fit_bounds(self, data, reach_mm=math.inf):
        """Physical bounds, the same for every curve: the viscosity up to :data:`ETA_MAX_MPA_S`, the
        far-field coefficient up to :data:`DRAG_MAX_N_S_PER_M`; and each term at most the peak force
        at the fastest speed (the near one at the bounding gap). A force the data want beyond them
        is not drag (tethers pulled on the retract, the sample's own relaxation)."""
        if data.time_s is None:
            raise ValueError("drag needs the measurement's time_s (the probe's velocity)")
        peak = float(np.max(np.abs(data.force_mN)))
        vmax = max(self._speeds(data), 1e-300)
        R = float(data.radius_mm)
        eta_hi = peak * GAP_FRACTION * R / (6.0 * math.pi * R**2 * vmax) / MPA_S
        return {"eta_mPa_s": (0.0, min(eta_hi, ETA_MAX_MPA_S)),
                "drag_N_s_per_m": (0.0, min(peak / vmax, DRAG_MAX_N_S_PER_M))}

    def starts(self, data, bounds):
        return {"eta_mPa_s": (1e-3 * bounds["eta_mPa_s"][1],),
                "drag_N_s_per_m": (1e-3 * bounds["drag_N_s_per_m"][1],)}

    def force(self, ev: Evaluation, fit: dict, velocity_mm_s: np.ndarray) -> np.ndarray:
        """The drag (mN) at every point of ``ev`` at the probe's velocity, before the baseline's part is taken."""
        separation = np.maximum(-ev.h_mm, 0.0)  # 0 in contact: held at the contact value
        return (lubrication_force(float(fit["eta_mPa_s"]) * MPA_S, ev.radius_mm, velocity_mm_s, separation,
                                  GAP_FRACTION * ev.radius_mm)
                + float(fit["drag_N_s_per_m"]) * velocity_mm_s)

    def velocity(self, ev: Evaluation) -> np.ndarray:
        """The velocity (mm/s) the drag acts against: the tip's, of the recorded depth (cached per model)."""
        v = ev.cache.get("drag_velocity")
        if v is None:
            v = ev.cache["drag_velocity"] = probe_velocity(ev.time_s, ev.depth_mm, ev.kind)
        return v

    def apply(self, ev: Evaluation, fit: dict) -> None:
        if ev.time_s is None:
            raise ValueError(f"{self.name} needs the measurement's time_s")
        drag = self.force(ev, fit, self.velocity(ev))
        ev.force_mN = ev.force_mN + drag - baseline_part(drag, ev.depth_mm, ev.kind, ev.baseline)

    def visible(self, data, noise_mN):
        if data.time_s is None:
            return "the curve has no time column: no velocity, no drag"
        if data.contact_mode != "fit":
            return "the curve starts in contact: no part out of contact determines drag"
        if not (data.has("retract") or data.has("hold")):
            return "a single approach at one speed: its drag is a constant in the subtracted baseline"
        return None
