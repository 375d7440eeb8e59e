r"""Measurements of the same sample that a user can make next, as their points would be recorded.

The candidates of the one engine of the next measurement (:func:`~.identifiability.weigh`,
which the diagnosis' sentences and :func:`~skin_indent.diagnosis.planning.plan` read;
the other parts: :mod:`~.prediction`, the forces fitted models predict for them,
:mod:`~.separation`, how far two explanations lie apart over them, and
:mod:`~.information`, what they would determine):

**Candidates** (:class:`Candidate`): the recorded history replayed as another
measurement would record it: a sphere of another radius to the same depths
(:func:`sphere`), an indentation deeper at the same speed (:func:`deeper`), a hold at
the deepest point after the recorded loading (:func:`hold`), the history at another
loading speed (:func:`speed`). A candidate's points are depths below its own contact
point (mm), at their times (s).
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

import numpy as np

from ..effects import HISTORY, instances
from ..measurement.preparation import MAX_DEPTH_RATIO
from ..measurement.scale import Quantity, UnitText

#: duration (s) of the hold a diagnosis weighs where an explanation acts along the time history
HOLD_S = 30.0
#: points recorded during a hold
HOLD_POINTS = 30
#: how many times deeper the indentation a diagnosis weighs is
DEEPER = 1.5


@dataclass(frozen=True, eq=False)
class Candidate:
    """A measurement of the same sample, as its points would be recorded.

    Attributes
    ----------
    kind : str
        ``"sphere"``, ``"deeper"``, ``"hold"`` or ``"speed"``.
    label : str
        The measurement in words, with its numbers (mm, s, mm/s); a
        :class:`~skin_indent.measurement.scale.UnitText` where it holds lengths (a sphere, a
        deeper indentation, a hold), which reads in the units of the curve's scale.
    curve : PreparedCurve
        Its points: ``depth_mm`` the depth below its own contact point (mm, > 0),
        ``time_s`` (s, or None when the recorded curve has no time), ``kind`` per point,
        ``radius_mm`` the sphere radius (mm), contact at depth 0 (``contact_mode`` ``"origin"``).
    value : float
        The setting that makes it: the sphere radius (mm), the deepest indentation (mm),
        the hold (s) or the loading speed (mm/s).
    reference : bool
        The recorded measurement made again (the same sphere to the same depth): what
        repeating it would add, the yardstick of every other candidate.
    """

    kind: str
    label: str
    curve: object
    value: float
    reference: bool = False

    @property
    def radius_mm(self) -> float:
        return float(self.curve.radius_mm)

    @property
    def max_depth_mm(self) -> float:
        return float(np.max(self.curve.depth_mm))

    @property
    def n(self) -> int:
        return int(self.curve.depth_mm.size)

    @property
    def slug(self) -> str:
        """A file-name part: ``sphere-R3.11mm``, ``deeper-0.9mm``, ``hold-30s``, ``speed-0.1mm_per_s``."""
        unit = {"sphere": "mm", "deeper": "mm", "hold": "s", "speed": "mm_per_s"}[self.kind]
        prefix = "R" if self.kind == "sphere" else ""
        return re.sub(r"[^A-Za-z0-9._-]", "_", f"{self.kind}-{prefix}{self.value:.4g}{unit}")

    @property
    def in_time(self) -> bool:
        """Its points are best read against time (a hold, another speed) rather than depth."""
        return self.kind in ("hold", "speed")


def recorded_history(curve, h_mm):
    """A recorded curve's points as depths below the contact point of a fitted model.

    Parameters
    ----------
    curve : PreparedCurve
        The recorded curve.
    h_mm : ndarray
        Depth below the contact point (mm) of each of its points in the fitted model
        (:meth:`~skin_indent.models.ComposedModel.evaluate`: the recorded depth less the
        fitted contact point).

    Returns
    -------
    PreparedCurve
        Every point (those before contact too), at depth ``h_mm``, with its time, kind and
        force; the recorded radius; contact at depth 0.
    """
    return _points(curve, np.asarray(h_mm, dtype=float),
                   None if curve.time_s is None else np.asarray(curve.time_s, dtype=float), np.asarray(curve.kind),
                   float(curve.radius_mm), np.asarray(curve.force_mN, dtype=float))


def base_history(curve, h_mm):
    """The recorded points in contact, as depths below the contact point: what the candidates replay.

    Parameters
    ----------
    curve, h_mm
        As :func:`recorded_history`.

    Returns
    -------
    PreparedCurve
        The points with ``h_mm > 0``.
    """
    h = np.asarray(h_mm, dtype=float)
    keep = h > 0
    if np.count_nonzero(keep) < 3:
        raise ValueError("fewer than 3 recorded points are in contact in the fitted model")
    full = recorded_history(curve, h)
    return dataclasses.replace(full, depth_mm=full.depth_mm[keep], force_mN=full.force_mN[keep],
                               time_s=None if full.time_s is None else full.time_s[keep], kind=full.kind[keep])


def _points(template, depth, time, kind, radius_mm, force=None):
    """A prepared curve of the points given, contact at depth 0 (``force_mN``: only the effects'
    fit bounds read it, never a prediction: the recorded peak force at every point by default)."""
    if force is None:
        force = np.full(depth.size, float(np.max(np.abs(template.force_mN))))
    return dataclasses.replace(template, depth_mm=np.asarray(depth, dtype=float),
                               force_mN=np.asarray(force, dtype=float),
                               time_s=None if time is None else np.asarray(time, dtype=float),
                               kind=np.asarray(kind), radius_mm=float(radius_mm), radius_source="plan",
                               contact_mode="origin", contact_guess_mm=0.0, contact=None, baseline=None,
                               baseline_fitted=None)


def _check_depth(depth_mm: float, radius_mm: float, what: str) -> None:
    if depth_mm > MAX_DEPTH_RATIO * radius_mm:
        raise ValueError(f"{what}: an indentation of {depth_mm:.3g} mm is deeper than the sphere's radius "
                         f"({radius_mm:.3g} mm), beyond what the model handles (h/R <= {MAX_DEPTH_RATIO:g})")


def _moving(depth_mm) -> np.ndarray:
    """Per time step of a history: the sphere moves (its depth changes by more than 1e-9 of the deepest)."""
    d = np.asarray(depth_mm, dtype=float)
    return np.abs(np.diff(d)) > 1e-9 * float(np.max(np.abs(d)))


def sphere(base, radius_mm: float) -> Candidate:
    """A sphere of radius ``radius_mm`` (mm) pressed to the recorded depths at the recorded times.

    ``base`` is :func:`base_history` of the recorded curve; the same radius is the
    reference candidate (the measurement made again).
    """
    if not (math.isfinite(radius_mm) and radius_mm > 0):
        raise ValueError(f"a sphere radius must be a positive number of mm, got {radius_mm:g}")
    R, h = float(base.radius_mm), float(np.max(base.depth_mm))
    _check_depth(h, radius_mm, f"a sphere of R = {radius_mm:g} mm")
    ratio = radius_mm / R
    depth = Quantity(h, "mm")
    if math.isclose(ratio, 1.0, rel_tol=1e-6):
        label = UnitText("the same sphere again (R = {R:.3g}, to {h:.3g})", R=Quantity(R, "mm"), h=depth)
        reference = True
    else:
        size = {0.5: "half the radius", 2.0: "twice the radius"}.get(round(ratio, 6), None)
        label = UnitText("a sphere of " + ("{size} (R = {R:.3g})" if size else "R = {R:.3g}") + " to the same depth "
                         "({h:.3g})", size=size, R=Quantity(radius_mm, "mm"), h=depth)
        reference = False
    curve = dataclasses.replace(base, radius_mm=float(radius_mm))
    return Candidate("sphere", label, curve, float(radius_mm), reference)


def deeper(base, max_depth_mm: float) -> Candidate:
    """The recorded history to ``max_depth_mm`` (mm) with the same sphere at the same speed.

    Every depth is scaled by ``max_depth_mm`` over the recorded deepest one; the time
    steps in which the sphere moves by the same factor (the speed stays), those in which
    it stands still (a hold) are kept.
    """
    h = float(np.max(base.depth_mm))
    if not (math.isfinite(max_depth_mm) and max_depth_mm > h * (1 + 1e-9)):
        raise ValueError(f"a deeper indentation must go beyond the recorded {h:.4g} mm, got {max_depth_mm:g} mm")
    _check_depth(max_depth_mm, float(base.radius_mm), "a deeper indentation")
    k = max_depth_mm / h
    t = base.time_s
    if t is not None:
        dt = np.diff(t) * np.where(_moving(base.depth_mm), k, 1.0)
        t = t[0] * k + np.r_[0.0, np.cumsum(dt)]
    curve = _points(base, k * base.depth_mm, t, base.kind, base.radius_mm)
    return Candidate("deeper", UnitText("an indentation to {h:.3g} ({k:.3g} times deeper) with the same sphere",
                                        h=Quantity(max_depth_mm, "mm"), k=k), curve, float(max_depth_mm))


def hold(base, hold_s: float = HOLD_S, points: int = HOLD_POINTS) -> Candidate:
    """The recorded loading, then ``hold_s`` seconds at its deepest point (``points`` samples).

    Raises
    ------
    ValueError
        The recorded curve has no time, or ``hold_s`` is not positive.
    """
    if base.time_s is None:
        raise ValueError("the recorded curve has no time column: a hold cannot follow its history")
    if not (math.isfinite(hold_s) and hold_s > 0):
        raise ValueError(f"a hold must last a positive number of seconds, got {hold_s:g}")
    end = int(np.argmax(base.depth_mm)) + 1  # the loading: up to the first deepest point
    if end < 2:
        raise ValueError("the recorded curve has no loading to hold after")
    t_end, h_end = float(base.time_s[end - 1]), float(base.depth_mm[end - 1])
    time = np.r_[base.time_s[:end], t_end + hold_s * np.arange(1, points + 1) / points]
    curve = _points(base, np.r_[base.depth_mm[:end], np.full(points, h_end)], time,
                    np.r_[base.kind[:end], np.full(points, "hold")], base.radius_mm)
    return Candidate("hold", UnitText("a {t:.3g} s hold at the deepest point ({h:.3g}) after the recorded loading",
                                      t=hold_s, h=Quantity(h_end, "mm")), curve, float(hold_s))


def loading_speed(curve) -> float:
    """Median speed (mm/s) of the loading points of a curve (NaN without time)."""
    if curve.time_s is None:
        return math.nan
    load = np.flatnonzero(curve.kind == "approach")
    dt, dh = np.diff(curve.time_s[load]), np.diff(curve.depth_mm[load])
    ok = dt > 0
    return float(np.median(dh[ok] / dt[ok])) if np.any(ok) else math.nan


def speed(base, speed_mm_per_s: float) -> Candidate:
    """The recorded history at another loading speed (mm/s): the time steps in which the sphere
    moves scaled by the recorded speed over ``speed_mm_per_s``, those in which it stands still kept."""
    if base.time_s is None:
        raise ValueError("the recorded curve has no time column: its speed is unknown")
    if not (math.isfinite(speed_mm_per_s) and speed_mm_per_s > 0):
        raise ValueError(f"a loading speed must be a positive number of mm/s, got {speed_mm_per_s:g}")
    v = loading_speed(base)
    if not (math.isfinite(v) and v > 0):
        raise ValueError("the recorded loading has no positive speed")
    k = v / speed_mm_per_s
    dt = np.diff(base.time_s) * np.where(_moving(base.depth_mm), k, 1.0)
    t = base.time_s[0] * k + np.r_[0.0, np.cumsum(dt)]
    curve = _points(base, base.depth_mm, t, base.kind, base.radius_mm)
    return Candidate("speed", f"a loading speed of {speed_mm_per_s:.3g} mm/s (recorded: {v:.3g} mm/s)", curve,
                     float(speed_mm_per_s))


def acts_in_time(effects) -> bool:
    """An effect of ``effects`` acts along the time history (a hold or another speed changes its force)."""
    return any(e.stage == HISTORY or e.needs_history for e in instances(effects))
