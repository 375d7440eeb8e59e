"""Splitting a curve into approach, hold and retract segments.

:func:`find_segments` labels every row by the sign of the median-smoothed
depth speed and returns consecutive :class:`Segment` objects (half-open row
ranges) in time order; :meth:`Measurement.select` turns one back into a curve.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._errors import MeasurementError

if TYPE_CHECKING:
    from .core import Measurement

__all__ = ["Segment", "find_segments"]

# A sample whose median-smoothed depth speed is below this fraction of
# the approach speed belongs to a hold; the median window is this fraction of n.
_HOLD_SPEED_FRACTION = 0.15
_SPEED_WINDOW_FRACTION = 0.01

# Up to this many window values (samples x window) the moving median is computed with
# numpy, faster than importing scipy.ndimage (0.2-0.5 s); longer curves use scipy.
_NUMPY_MEDIAN_MAX = 100_000

_KINDS = ("approach", "hold", "retract")
_LABEL = {1: "approach", 0: "hold", -1: "retract"}


@dataclass(frozen=True)
class Segment:
    """Rows ``start:stop`` (half-open) of one kind of motion.

    Attributes
    ----------
    kind : {"approach", "hold", "retract"}
        Depth increasing, roughly constant (or creeping slowly), decreasing.
    start, stop : int
        Row indices, half-open.
    """

    kind: str
    start: int
    stop: int

    def __post_init__(self):
        if self.kind not in _KINDS:
            raise MeasurementError(f"segment kind must be one of {_KINDS}, got {self.kind!r}")
        if not 0 <= self.start < self.stop:
            raise MeasurementError(
                f"segment rows must satisfy 0 <= start < stop, got {self.start}:{self.stop}"
            )

    @property
    def n_points(self) -> int:
        """Number of rows."""
        return self.stop - self.start


def _moving_median(x: np.ndarray, window: int) -> np.ndarray:
    """Moving median over an odd ``window``, the ends extended by their values.

    The same numbers as ``scipy.ndimage.median_filter(x, size=window, mode="nearest")``,
    which is used for long curves; short ones (skin curves: 100 samples) need no scipy.
    """
    if x.size * window > _NUMPY_MEDIAN_MAX:
        from scipy.ndimage import median_filter

        return median_filter(x, size=window, mode="nearest")
    padded = np.pad(x, window // 2, mode="edge")
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, window), axis=-1)


def _runs(labels: np.ndarray) -> list[list[int]]:
    """``[[label, start, stop], ...]`` for the runs of equal labels."""
    edges = np.flatnonzero(np.diff(labels)) + 1
    starts, stops = np.r_[0, edges], np.r_[edges, labels.size]
    return [[int(labels[a]), int(a), int(b)] for a, b in zip(starts, stops)]


def _merge_short(runs: list[list[int]], min_len: int) -> list[list[int]]:
    """Absorb runs shorter than `min_len` into a neighbour, shortest first."""
    runs = [r[:] for r in runs]
    while len(runs) > 1:
        lengths = [stop - start for _, start, stop in runs]
        i = int(np.argmin(lengths))
        if lengths[i] >= min_len:
            break
        if i == 0:
            runs[i][0] = runs[1][0]
        elif i == len(runs) - 1 or runs[i - 1][0] == runs[i + 1][0]:
            runs[i][0] = runs[i - 1][0]
        else:  # the longer neighbour wins
            runs[i][0] = max(runs[i - 1], runs[i + 1], key=lambda r: r[2] - r[1])[0]
        merged = [runs[0]]
        for run in runs[1:]:
            if run[0] == merged[-1][0]:
                merged[-1][2] = run[2]
            else:
                merged.append(run)
        runs = merged
    return runs


def _refine_boundary(depth, force, speed, a, b, window) -> int:
    """Move the boundary between runs `a` and `b` onto the physical transition."""
    start, split, stop = a[1], b[1], b[2]
    if (a[0], b[0]) == (-1, 1):
        return int(start + np.argmin(depth[start:stop]) + 1)
    if (a[0], b[0]) == (1, -1):
        # Just after the force peak among the `window` samples up to the depth
        # maximum: the force falls as soon as the instrument reverses, while the
        # measured depth may rise a little longer (e.g. as a cantilever relaxes).
        top = start + int(np.argmax(depth[start:stop]))
        first = max(start, top - window)
        return int(first + np.argmax(force[first : top + 1]) + 1)
    # To or from a hold: the median-smoothed speed keeps the step edge, so the
    # boundary is where it crosses halfway between the two segments' speeds.
    level = 0.5 * (np.median(speed[start:split]) + np.median(speed[split:stop]))
    above = speed[start:stop] > level
    flips = np.flatnonzero(above[1:] != above[:-1]) + 1 + start
    return int(flips[np.argmin(np.abs(flips - split))]) if flips.size else split


def find_segments(measurement: Measurement) -> list[Segment]:
    """Split a curve into approach, hold and retract segments.

    Parameters
    ----------
    measurement : Measurement

    Returns
    -------
    list of Segment
        Consecutive, covering every row, in time order.

    Notes
    -----
    1. The depth speed (per second if time is present and strictly
       increasing, else per sample) is smoothed by a moving median over 1% of
       the samples (at least 5), which removes noise but keeps step edges.
    2. The approach speed is the 90th percentile of the positive smoothed
       speeds. Faster than 15% of it is approach, slower than -15% is retract,
       in between is hold. A force-controlled creep hold, whose depth still
       creeps slowly, is a hold; a slower but steady approach is not.
    3. Runs shorter than the median window join a neighbour, so a hold must
       last a meaningful time.
    4. Boundaries are refined. Approach to retract: just after the force peak
       within one median window before the depth maximum. Retract to
       approach: just after the depth minimum. To or from a hold: where the
       smoothed speed crosses halfway between the speeds on either side.
    """
    depth = measurement.depth_mm
    n = depth.size
    time = measurement.time_s
    timed = time is not None and np.all(np.diff(time) > 0)
    speed = np.gradient(depth, time) if timed else np.gradient(depth)
    window = max(5, int(n * _SPEED_WINDOW_FRACTION) | 1)
    smooth = _moving_median(speed, window)
    positive = smooth[smooth > 0]
    v_ref = np.percentile(positive if positive.size >= min(window, n) else np.abs(smooth), 90)
    if not v_ref > 0:
        return [Segment("hold", 0, n)]
    threshold = _HOLD_SPEED_FRACTION * v_ref
    labels = np.where(smooth > threshold, 1, np.where(smooth < -threshold, -1, 0))
    runs = _merge_short(_runs(labels), min(window, n))
    bounds = [0]
    for a, b in zip(runs[:-1], runs[1:]):
        bounds.append(_refine_boundary(depth, measurement.force_mN, smooth, a, b, window))
    bounds.append(n)
    if any(b <= a for a, b in zip(bounds[:-1], bounds[1:])):
        bounds = [r[1] for r in runs] + [n]  # refining would reorder them: keep the rough ones
    return [Segment(_LABEL[r[0]], a, b) for r, a, b in zip(runs, bounds[:-1], bounds[1:])]
