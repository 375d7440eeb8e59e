"""The :class:`Measurement` data object and building one from arrays.

A :class:`Measurement` is an immutable force-depth curve in package units
(depth in mm, force in mN, time in s). Its methods only select rows or return
shifted copies; every problem with the data raises :class:`MeasurementError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from ._errors import MeasurementError, _quote
from .segments import Segment, find_segments

if TYPE_CHECKING:
    from .contact import Baseline

__all__ = ["Measurement", "measurement_from_arrays"]

_MIN_POINTS = 3  # fewest samples in a measurement (and in a selection of one)


def _as_array(values, name: str) -> np.ndarray:
    try:
        arr = np.array(values, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as err:
        raise MeasurementError(f"{name} cannot be converted to float numbers ({err})") from None
    if arr.ndim != 1:
        raise MeasurementError(f"{name} must be one-dimensional, got shape {arr.shape}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False, repr=False)
class Measurement:
    """An immutable force-depth curve in package units.

    Parameters
    ----------
    depth_mm : array_like
        Indenter displacement (mm), positive into the sample. Need not be
        monotone: a loading-unloading curve goes back.
    force_mN : array_like
        Indentation force (mN), same length.
    time_s : array_like or None
        Sample times (s), non-decreasing; None if the source had no time.
    source : str
        Where the data came from: a file name, or ``"array"``.
    columns : dict
        For ``"depth_mm"``, ``"force_mN"`` (and ``"time_s"``): the original
        column and the factor applied, e.g. ``{"depth_mm": {"column":
        "depth_um", "factor": 0.001}, ...}``. Derived curves add what was done
        to them (``"loading"``, ``"depth_shift_mm"``, ``"baseline_removed"``).
    radius_mm : float or None, optional
        Radius of the spherical indenter (mm), if known.

    Raises
    ------
    MeasurementError
        If the arrays are not 1-D or differ in length, hold NaN or inf (the
        message names the column and the first bad index), have fewer than 3
        points, if time decreases, or if the radius is not positive.

    Notes
    -----
    The arrays are float64 copies marked read-only. Instances compare by
    identity (``eq=False``): element-wise array equality has no truth value.
    """

    depth_mm: np.ndarray
    force_mN: np.ndarray
    time_s: np.ndarray | None
    source: str
    columns: dict = field(default_factory=dict)
    radius_mm: float | None = None

    def __post_init__(self):
        source = str(self.source)
        named = {"depth_mm": _as_array(self.depth_mm, "depth_mm"),
                 "force_mN": _as_array(self.force_mN, "force_mN")}
        if self.time_s is not None:
            named["time_s"] = _as_array(self.time_s, "time_s")
        lengths = {name: arr.size for name, arr in named.items()}
        if len(set(lengths.values())) != 1:
            detail = ", ".join(f"{k}={v}" for k, v in lengths.items())
            raise MeasurementError(f"{source}: columns differ in length ({detail})")
        for name, arr in named.items():
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise MeasurementError(
                    f"{source}: non-finite value {arr[bad[0]]} in {name} at index {bad[0]} "
                    f"({bad.size} non-finite values in total)"
                )
        if lengths["depth_mm"] < _MIN_POINTS:
            raise MeasurementError(
                f"{source}: {lengths['depth_mm']} points; at least {_MIN_POINTS} are needed"
            )
        time = named.get("time_s")
        if time is not None and np.any(np.diff(time) < 0):
            i = int(np.flatnonzero(np.diff(time) < 0)[0]) + 1
            raise MeasurementError(
                f"{source}: time_s decreases at index {i} ({time[i - 1]} -> {time[i]})"
            )
        radius = self.radius_mm
        if radius is not None:
            try:
                radius = float(radius)
            except (TypeError, ValueError):
                msg = f"radius_mm must be a number, got {_quote(radius)}"
                raise MeasurementError(msg) from None
            if not (np.isfinite(radius) and radius > 0):
                raise MeasurementError(f"radius_mm must be positive and finite, got {radius}")
        for name, value in (*named.items(), ("time_s", time), ("source", source),
                            ("columns", dict(self.columns)), ("radius_mm", radius)):
            object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        d, f = self.depth_mm, self.force_mN
        return (
            f"Measurement(source={self.source!r}, n_points={self.n_points}, "
            f"depth_mm=[{d.min():.6g}, {d.max():.6g}], force_mN=[{f.min():.6g}, {f.max():.6g}], "
            f"has_time={self.has_time}, radius_mm={self.radius_mm})"
        )

    @property
    def n_points(self) -> int:
        """Number of samples."""
        return int(self.depth_mm.size)

    @property
    def has_time(self) -> bool:
        """True if the measurement has a time column."""
        return self.time_s is not None

    def _derived(self, rows, note: dict | None = None, **changes) -> Measurement:
        """A new measurement of the given rows (slice or indices), `note` added to columns."""
        values = dict(
            depth_mm=self.depth_mm[rows],
            force_mN=self.force_mN[rows],
            time_s=None if self.time_s is None else self.time_s[rows],
            columns={**self.columns, **(note or {})},
        )
        return replace(self, **{**values, **changes})

    def select(self, segment: Segment) -> Measurement:
        """The rows ``segment.start:segment.stop`` (e.g. from :func:`find_segments`)."""
        if segment.stop > self.n_points:
            raise MeasurementError(
                f"{self.source}: segment rows {segment.start}:{segment.stop} exceed "
                f"the {self.n_points} points"
            )
        return self._derived(slice(segment.start, segment.stop))

    def window(self, min_depth_mm: float, max_depth_mm: float) -> Measurement:
        """The points with ``min_depth_mm <= depth <= max_depth_mm`` (mm), in order.

        Raises
        ------
        MeasurementError
            If fewer than 3 points remain.
        """
        inside = (self.depth_mm >= min_depth_mm) & (self.depth_mm <= max_depth_mm)
        if inside.sum() < _MIN_POINTS:
            raise MeasurementError(
                f"{self.source}: only {int(inside.sum())} points between depth "
                f"{min_depth_mm} and {max_depth_mm} mm; at least {_MIN_POINTS} are needed"
            )
        return self._derived(np.flatnonzero(inside))

    def loading(self) -> Measurement:
        """The first approach (loading) segment, strictly increasing in depth.

        The segment comes from :func:`find_segments`. A sample is kept only if
        its depth exceeds every earlier depth of the segment, so instrument
        depths with a little jitter come out strictly increasing.
        ``columns["loading"]`` records the segment rows and how many samples
        were dropped that way.

        Raises
        ------
        MeasurementError
            If there is no approach segment or fewer than 3 points remain.
        """
        approach = [s for s in find_segments(self) if s.kind == "approach"]
        if not approach:
            raise MeasurementError(f"{self.source}: no approach (increasing depth) segment found")
        seg = approach[0]
        depth = self.depth_mm[seg.start : seg.stop]
        keep = np.concatenate(([True], depth[1:] > np.maximum.accumulate(depth)[:-1]))
        rows = seg.start + np.flatnonzero(keep)
        if rows.size < _MIN_POINTS:
            raise MeasurementError(
                f"{self.source}: the approach segment has only {rows.size} increasing points"
            )
        note = {"loading": {"rows": (seg.start, seg.stop), "dropped": seg.n_points - rows.size}}
        return self._derived(rows, note)

    def unloading(self) -> Measurement:
        """The first retract (unloading) segment after the first approach, as recorded.

        Raises
        ------
        MeasurementError
            If there is no such segment.
        """
        segments = find_segments(self)
        approach = next((s for s in segments if s.kind == "approach"), None)
        after = 0 if approach is None else approach.stop
        retract = [s for s in segments if s.kind == "retract" and s.start >= after]
        if not retract:
            raise MeasurementError(f"{self.source}: no retract (decreasing depth) segment found")
        return self.select(retract[0])

    def require_monotone_loading(self) -> Measurement:
        """Check that the depth strictly increases over the whole curve; return `self`.

        Fitting code calls this on loading curves. A curve that also holds or
        retracts fails: take its approach with :meth:`loading` first.

        Raises
        ------
        MeasurementError
            Naming the first index where the depth does not increase.
        """
        bad = np.flatnonzero(np.diff(self.depth_mm) <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            raise MeasurementError(
                f"{self.source}: depth does not increase at index {i} "
                f"({float(self.depth_mm[i - 1])!r} -> {float(self.depth_mm[i])!r} mm); a loading curve "
                "must be strictly increasing in depth (use .loading() for the approach segment)"
            )
        return self

    def with_depth_shift(self, shift_mm: float) -> Measurement:
        """A copy with depth ``depth_mm + shift_mm`` (mm)."""
        shift = float(shift_mm)
        note = {"depth_shift_mm": self.columns.get("depth_shift_mm", 0.0) + shift}
        return self._derived(slice(None), note, depth_mm=self.depth_mm + shift)

    def with_contact_at(self, contact_depth_mm: float) -> Measurement:
        """A copy whose depth origin is the contact point: ``depth - contact_depth_mm``."""
        return self.with_depth_shift(-float(contact_depth_mm))

    def with_baseline_removed(self, baseline: Baseline) -> Measurement:
        """A copy with force ``force - baseline.force_at(depth)``; never done implicitly.

        The baseline line is evaluated at this measurement's depths, so use it
        in the depth coordinates it was fitted in.
        """
        note = {"baseline_removed": {"offset_mN": baseline.offset_mN,
                                     "slope_mN_per_mm": baseline.slope_mN_per_mm}}
        force = self.force_mN - baseline.force_at(self.depth_mm)
        return self._derived(slice(None), note, force_mN=force)

    def with_radius(self, radius_mm: float | None) -> Measurement:
        """A copy with the indenter radius (mm) set."""
        return replace(self, radius_mm=radius_mm)


def measurement_from_arrays(
    depth_mm, force_mN, time_s=None, source: str = "array", *, radius_mm: float | None = None
) -> Measurement:
    """Build a :class:`Measurement` from arrays already in mm, mN and s.

    Parameters
    ----------
    depth_mm, force_mN : array_like
        Depth (mm) and force (mN), equal lengths, at least 3 points.
    time_s : array_like, optional
        Times (s), non-decreasing.
    source : str, optional
        A label for messages.
    radius_mm : float, optional
        Indenter radius (mm).
    """
    names = ["depth_mm", "force_mN"] + ([] if time_s is None else ["time_s"])
    columns = {name: {"column": name, "factor": 1.0} for name in names}
    return Measurement(depth_mm, force_mN, time_s, source, columns, radius_mm)
