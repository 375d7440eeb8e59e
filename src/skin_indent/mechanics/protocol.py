"""Loading protocols: the depth history of a test, with time.

History-dependent models (viscoelasticity, friction, adhesion) depend on how the
sphere moves, not only on how deep it is. A :class:`Protocol` holds the recorded
depth (mm) against time (s): a constant-speed ramp with an optional hold and
unloading, or the history replayed from a measurement's ``time_s`` column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Protocol:
    """Depth against time.

    Attributes
    ----------
    time_s : ndarray
        Times, s, non-decreasing.
    depth_mm : ndarray
        Depth of the sphere below the undeformed surface at those times, mm.
    """

    time_s: np.ndarray
    depth_mm: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.time_s, dtype=float)
        d = np.asarray(self.depth_mm, dtype=float)
        if t.ndim != 1 or t.shape != d.shape or t.size < 2:
            raise ValueError("a protocol needs at least 2 (time, depth) pairs of equal length")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(d))):
            raise ValueError("protocol times and depths must be finite")
        if np.any(np.diff(t) < 0) or t[0] < 0:
            raise ValueError("protocol times must be >= 0 and non-decreasing")
        if d.max() <= 0:
            raise ValueError("the protocol never presses the sphere in (all depths <= 0)")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "depth_mm", d)

    @property
    def max_depth_mm(self) -> float:
        return float(self.depth_mm.max())

    @classmethod
    def ramp(cls, depth_mm: float, points: int = 100, speed_mm_per_s: float = 0.02, *, hold_s: float = 0.0,
             hold_points: int = 0, unload: bool = False) -> "Protocol":
        """Load at constant speed to ``depth_mm`` (``points`` samples), optionally hold, then unload.

        Parameters
        ----------
        depth_mm : float
            Largest depth, mm.
        points : int
            Samples of the loading ramp (the unloading has as many).
        speed_mm_per_s : float
            Loading and unloading speed, mm/s (default 0.02, the hidden-effects cases').
        hold_s, hold_points : float, int
            Duration (s) and samples of a hold at the largest depth.
        unload : bool
            Unload back to depth 0 after the hold.
        """
        if not (math.isfinite(depth_mm) and depth_mm > 0):
            raise ValueError(f"depth must be a finite number > 0 mm, got {depth_mm}")
        if not (math.isfinite(speed_mm_per_s) and speed_mm_per_s > 0):
            raise ValueError(f"speed must be a finite number > 0 mm/s, got {speed_mm_per_s}")
        if points < 2:
            raise ValueError(f"points must be >= 2, got {points}")
        d = depth_mm * np.arange(1, points + 1) / points
        t = d / speed_mm_per_s
        if hold_s > 0 and hold_points > 0:
            th = t[-1] + hold_s * np.arange(1, hold_points + 1) / hold_points
            t, d = np.r_[t, th], np.r_[d, np.full(hold_points, depth_mm)]
        if unload:
            du = depth_mm * np.arange(points - 1, -1, -1) / points
            t, d = np.r_[t, t[-1] + (depth_mm - du) / speed_mm_per_s], np.r_[d, du]
        return cls(t, d)

    @classmethod
    def from_measurement(cls, measurement, offset_mm: float = 0.0) -> "Protocol":
        """The depth history of a measurement with a ``time_s`` column (depth shifted by ``-offset_mm``)."""
        if not measurement.has_time:
            raise ValueError(f"{measurement.source}: the measurement has no time_s column to replay")
        return cls(np.asarray(measurement.time_s), np.asarray(measurement.depth_mm) - offset_mm)

    def is_monotone_loading(self) -> bool:
        """True for a pure loading ramp (strictly increasing depth)."""
        return bool(np.all(np.diff(self.depth_mm) > 0))
