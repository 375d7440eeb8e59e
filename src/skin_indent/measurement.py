"""Where data enters: force-depth curves, their segments, baseline and contact point.

A :class:`Measurement` is an immutable force-depth curve in package units (depth
in mm, force in mN, time in s). Read it from a CSV file with :func:`load_csv`,
build it from arrays with :func:`measurement_from_arrays`, write it with
:func:`save_csv`.

Three functions describe a raw curve without changing it:

- :func:`find_segments`: approach, hold and retract segments, from the depth
  (and time) history;
- :func:`estimate_baseline`: the pre-contact force line (offset, tilt, noise);
- :func:`find_contact_point` / :func:`estimate_contact_point`: a first guess
  of the contact depth, which a later joint fit refines.

Nothing is subtracted silently: removing a baseline or moving the depth origin
is an explicit call (:meth:`Measurement.with_baseline_removed`,
:meth:`Measurement.with_contact_at`) that returns a new :class:`Measurement`.

Every problem with the input raises :class:`MeasurementError`, whose message is
one line naming the problem (and the file, line and column where that applies),
so a command-line tool can print ``str(err)`` as it is.
"""

from __future__ import annotations

import csv
import io
import os
import re
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.ndimage import median_filter
from scipy.optimize import minimize_scalar

__all__ = [
    "DEPTH_COLUMNS",
    "FORCE_COLUMNS",
    "TIME_COLUMN",
    "Baseline",
    "ContactPoint",
    "Measurement",
    "MeasurementError",
    "Segment",
    "estimate_baseline",
    "estimate_contact_point",
    "find_contact_point",
    "find_segments",
    "load_csv",
    "measurement_from_arrays",
    "save_csv",
]

#: Accepted depth column names and the factor that converts each to mm.
DEPTH_COLUMNS = {"depth_mm": 1.0, "depth_um": 1e-3, "depth_m": 1e3}
#: Accepted force column names and the factor that converts each to mN.
FORCE_COLUMNS = {"force_mN": 1.0, "force_N": 1e3, "force_uN": 1e-3}
#: The optional time column (s).
TIME_COLUMN = "time_s"

_DELIMITERS = (",", ";", "\t")  # tried in this order on the header line
_MIN_POINTS = 3
_NUMBER = re.compile(
    r"[+-]?(?:(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)", re.IGNORECASE
)

# Segments: a sample whose median-smoothed depth speed is below this fraction of
# the approach speed belongs to a hold; the median window is this fraction of n.
_HOLD_SPEED_FRACTION = 0.15
_SPEED_WINDOW_FRACTION = 0.01

# Contact point: the Hertz-shaped fit F = b0 + a (d - d0)^1.5 uses the loading
# curve up to where the force has risen by this fraction of its total rise.
_HERTZ_EXPONENT = 1.5
_CONTACT_FIT_FORCE_FRACTION = 0.3
_MIN_BASELINE_POINTS = 10  # approach samples before contact for a usable baseline
_CONTACT_THRESHOLD_SIGMA = 8.0  # "deviation from baseline", in noise std


class MeasurementError(ValueError):
    """A force-depth measurement (file or arrays) cannot be used as given.

    The message is always a single line that names the problem and, where it
    applies, the file, line and column, so it can be shown to a user as it is.
    """

    def __init__(self, message: str):
        super().__init__(str(message).replace("\r", "\\r").replace("\n", "\\n"))


def _quote(value: object, limit: int = 40) -> str:
    """Quote a piece of user input for a one-line error message."""
    text = repr(str(value))
    return text if len(text) <= limit else text[: limit - 4] + "...'"


# ----------------------------------------------------------------- Measurement


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
                f"({self.depth_mm[i - 1]!r} -> {self.depth_mm[i]!r} mm); a loading curve "
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


# ------------------------------------------------------------- CSV input/output


def _read_text(path: Path) -> str:
    name = path.name or str(path)
    if path.is_dir():
        raise MeasurementError(f"{name}: is a directory, not a CSV file")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise MeasurementError(f"{path}: file not found") from None
    except PermissionError:
        raise MeasurementError(f"{path}: permission denied") from None
    except OSError as err:
        raise MeasurementError(f"{path}: cannot be read ({err.strerror or err})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise MeasurementError(
            f"{name}: not UTF-8 text (byte 0x{raw[err.start]:02x} at offset {err.start}); "
            "save the file as UTF-8 CSV"
        ) from None
    if "\x00" in text:
        raise MeasurementError(f"{name}: contains NUL bytes; this is not a text CSV file")
    return text


def _split_header(line: str, delimiter: str) -> list[str]:
    try:
        return [cell.strip() for cell in next(csv.reader([line], delimiter=delimiter), [])]
    except csv.Error:
        return [line]


def _choose_columns(name: str, header: str):
    """Delimiter, number of fields and {key: (index, original name, factor)} from the header."""
    for delimiter in _DELIMITERS:
        fields = _split_header(header, delimiter)
        depth = [c for c in fields if c in DEPTH_COLUMNS]
        force = [c for c in fields if c in FORCE_COLUMNS]
        if depth and force:
            break
    else:
        fields = max((_split_header(header, d) for d in _DELIMITERS), key=len)
        found = ", ".join(_quote(c, 30) for c in fields[:20])
        if all(_NUMBER.fullmatch(c) for c in fields):
            raise MeasurementError(
                f"{name}: the first line holds numbers ({found}); a header row naming the "
                "columns is required (e.g. time_s,depth_mm,force_mN)"
            )
        depth = [c for c in fields if c in DEPTH_COLUMNS]
        missing, accepted = ("force", FORCE_COLUMNS) if depth else ("depth", DEPTH_COLUMNS)
        hint = "; the delimiter must be a comma, semicolon or tab" if len(fields) == 1 else ""
        raise MeasurementError(
            f"{name}: no {missing} column in the header (expected one of "
            f"{', '.join(accepted)}; columns found: {found}{hint})"
        )
    found = ", ".join(_quote(c, 30) for c in fields[:20])
    for kind, hits in (("depth", depth), ("force", force)):
        if len(hits) > 1:
            raise MeasurementError(
                f"{name}: ambiguous {kind} columns {', '.join(map(_quote, hits))}; keep "
                f"exactly one (columns found: {found})"
            )
    if fields.count(TIME_COLUMN) > 1:
        raise MeasurementError(f"{name}: column {TIME_COLUMN!r} appears more than once")
    wanted = {"depth_mm": (depth[0], DEPTH_COLUMNS[depth[0]]),
              "force_mN": (force[0], FORCE_COLUMNS[force[0]])}
    if TIME_COLUMN in fields:
        wanted["time_s"] = (TIME_COLUMN, 1.0)
    return delimiter, len(fields), {k: (fields.index(c), c, f) for k, (c, f) in wanted.items()}


def _parse_cell(cell: str, where: str) -> float:
    cell = cell.strip()
    if not _NUMBER.fullmatch(cell):
        what = "empty cell" if not cell else f"{_quote(cell)} is not a number"
        hint = " (decimal comma? use '.')" if re.fullmatch(r"[+-]?\d+,\d+", cell) else ""
        raise MeasurementError(f"{where}: {what}{hint}")
    number = float(cell)
    if not np.isfinite(number):
        raise MeasurementError(f"{where}: non-finite value {_quote(cell)}")
    return number


def load_csv(path, *, radius_mm: float | None = None) -> Measurement:
    """Read a force-depth curve from a CSV file with a header row.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file (UTF-8, a byte-order mark is allowed).
    radius_mm : float, optional
        Indenter radius (mm) to store in the measurement.

    Returns
    -------
    Measurement
        Depth in mm, force in mN, time in s (if present).

    Raises
    ------
    MeasurementError
        With a one-line message for: a missing file, a directory, non-UTF-8
        or NUL bytes, an empty file, a header without data rows, a missing or
        ambiguous depth/force column (listing the columns found), a row with
        the wrong number of fields, an empty, non-numeric or non-finite cell
        (line and column named), fewer than 3 rows, or a decreasing time.

    Notes
    -----
    - The header needs exactly one depth column (``depth_mm``, ``depth_um``,
      ``depth_m``) and exactly one force column (``force_mN``, ``force_N``,
      ``force_uN``); ``time_s`` is optional. Names are case-sensitive. Other
      columns are ignored, not even parsed. Values are converted to mm and mN
      and the conversion is recorded in :attr:`Measurement.columns`.
    - Delimiter: the first of comma, semicolon and tab that splits the header
      into names including a depth and a force column is used for the whole
      file. The choice is driven by the column names, so data cannot fool it.
      Numbers need a ``.`` decimal point (a decimal comma is reported).
    - Blank lines are skipped; every other line is a data row: none is dropped.
    """
    path = Path(os.fspath(path))
    name = path.name or str(path)
    lines = io.StringIO(_read_text(path), newline="")
    header, header_no = "", 0
    for header_no, line in enumerate(lines, start=1):
        if line.strip():
            header = line.rstrip("\r\n")
            break
    if not header:
        raise MeasurementError(f"{name}: file is empty")
    delimiter, n_fields, wanted = _choose_columns(name, header)

    values = {key: [] for key in wanted}
    line_numbers = []
    reader = csv.reader(lines, delimiter=delimiter)
    try:
        for row in reader:
            line_no = header_no + reader.line_num
            if not row or (len(row) == 1 and not row[0].strip()):
                continue  # a blank line
            if len(row) != n_fields:
                hint = " (check the delimiter)" if len(row) == 1 else ""
                raise MeasurementError(
                    f"{name}: line {line_no} has {len(row)} fields, the header has "
                    f"{n_fields}{hint}"
                )
            for key, (col, original, factor) in wanted.items():
                where = f"{name}: line {line_no}, column {original!r}"
                values[key].append(_parse_cell(row[col], where) * factor)
            line_numbers.append(line_no)
    except csv.Error as err:
        line_no = header_no + reader.line_num
        raise MeasurementError(f"{name}: line {line_no}: malformed CSV ({err})") from None

    n_rows = len(line_numbers)
    if n_rows == 0:
        raise MeasurementError(f"{name}: header only, no data rows")
    if n_rows < _MIN_POINTS:
        raise MeasurementError(f"{name}: {n_rows} data rows; at least {_MIN_POINTS} are needed")
    back = np.flatnonzero(np.diff(values.get("time_s", [])) < 0)
    if back.size:
        t, i = values["time_s"], int(back[0])
        raise MeasurementError(
            f"{name}: line {line_numbers[i + 1]}, column 'time_s': time decreases "
            f"({t[i]!r} -> {t[i + 1]!r})"
        )
    columns = {key: {"column": original, "factor": factor}
               for key, (_, original, factor) in wanted.items()}
    return Measurement(values["depth_mm"], values["force_mN"], values.get("time_s"), name,
                       columns, radius_mm)


def save_csv(measurement: Measurement, path) -> Path:
    """Write ``time_s,depth_mm,force_mN`` (or ``depth_mm,force_mN``) atomically.

    The text goes to a temporary file in the same directory, which is then
    moved into place with :func:`os.replace`, so no reader sees a partial
    file. Values are written with full float64 precision (``repr``):
    :func:`load_csv` reads back identical numbers. Returns the path written.
    """
    path = Path(os.fspath(path))
    header = ["depth_mm", "force_mN"]
    cols = [measurement.depth_mm, measurement.force_mN]
    if measurement.has_time:
        header.insert(0, "time_s")
        cols.insert(0, measurement.time_s)
    lines = [",".join(header)] + [",".join(repr(float(v)) for v in row) for row in zip(*cols)]
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
            handle.write("\n".join(lines) + "\n")
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


# -------------------------------------------------------------------- Segments

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
    smooth = median_filter(speed, size=window, mode="nearest")
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


# -------------------------------------------------------------------- Baseline


@dataclass(frozen=True)
class Baseline:
    """The pre-contact force line ``F = offset_mN + slope_mN_per_mm * depth``.

    Attributes
    ----------
    offset_mN : float
        Force of the line at depth 0 (mN).
    slope_mN_per_mm : float
        Tilt of the baseline (mN/mm), e.g. from drag or optical interference.
    noise_mN : float
        Robust standard deviation of the residuals, 1.4826 x MAD (mN).
    n_points : int
        Number of samples fitted.
    depth_range_mm : tuple of float
        First and last depth (mm) of those samples.
    """

    offset_mN: float
    slope_mN_per_mm: float
    noise_mN: float
    n_points: int
    depth_range_mm: tuple[float, float] = (float("nan"), float("nan"))

    def force_at(self, depth_mm):
        """Baseline force (mN) at `depth_mm` (mm)."""
        return self.offset_mN + self.slope_mN_per_mm * np.asarray(depth_mm, dtype=float)


def _mad_std(residual: np.ndarray) -> float:
    return 1.4826 * float(np.median(np.abs(residual - np.median(residual))))


def _robust_line(x: np.ndarray, y: np.ndarray, iterations: int = 30):
    """Line fit by Tukey-biweight IRLS; returns (intercept, slope, robust noise std)."""
    design = np.column_stack((np.ones_like(x), x - x.mean()))
    weights = np.ones_like(y)
    for _ in range(iterations):
        root = np.sqrt(weights)
        coef = np.linalg.lstsq(design * root[:, None], y * root, rcond=None)[0]
        scale = _mad_std(y - design @ coef)
        if not scale > 0:
            break
        u = (y - design @ coef) / (4.685 * scale)
        new = np.where(np.abs(u) < 1, (1 - u**2) ** 2, 0.0)
        if np.allclose(new, weights, atol=1e-6):
            break
        weights = new
    noise = _mad_std(y - design @ coef)
    return float(coef[0] - coef[1] * x.mean()), float(coef[1]), noise


def estimate_baseline(
    measurement: Measurement, fraction: float = 0.4, *, max_depth_mm: float | None = None
) -> Baseline:
    """Fit the pre-contact baseline on the first part of the approach.

    Parameters
    ----------
    measurement : Measurement
        The whole curve; its :meth:`~Measurement.loading` segment is used.
    fraction : float, optional
        Fraction, in (0, 1], of the approach samples to fit, from the start.
    max_depth_mm : float, optional
        Also leave out samples deeper than this (mm), e.g. a contact estimate.

    Returns
    -------
    Baseline
        Offset (mN), tilt (mN/mm), robust noise std (mN) and sample count.

    Raises
    ------
    MeasurementError
        If `fraction` is out of range or fewer than 5 samples are left.

    Notes
    -----
    A straight line fitted by iteratively reweighted least squares (Tukey
    biweight), so spikes and a few contact samples barely pull it. The
    baseline is only reported: subtract it with
    :meth:`Measurement.with_baseline_removed`. It only means something if the
    curve has a pre-contact part, which :func:`find_contact_point` checks.
    """
    return _fit_baseline(measurement.loading(), fraction, max_depth_mm)


def _fit_baseline(approach: Measurement, fraction: float, max_depth_mm: float | None):
    if not 0 < fraction <= 1:
        raise MeasurementError(f"baseline fraction must be in (0, 1], got {fraction}")
    n_use = max(1, int(round(fraction * approach.n_points)))
    depth, force = approach.depth_mm[:n_use], approach.force_mN[:n_use]
    if max_depth_mm is not None:
        depth, force = depth[depth <= max_depth_mm], force[depth <= max_depth_mm]
    if depth.size < 5:
        raise MeasurementError(
            f"{approach.source}: only {depth.size} approach points for the baseline; "
            "at least 5 are needed"
        )
    offset, slope, noise = _robust_line(depth, force)
    return Baseline(offset, slope, noise, int(depth.size), (float(depth[0]), float(depth[-1])))


# --------------------------------------------------------------- Contact point


@dataclass(frozen=True)
class ContactPoint:
    """A first guess of the contact point of the loading curve.

    Attributes
    ----------
    depth_mm : float
        Contact depth (mm), in the depth coordinates of the data.
    has_baseline : bool
        False if the curve has no usable pre-contact part (the force rises
        from the first samples, as in skin curves that start in contact).
    baseline : Baseline or None
        The baseline used (fitted or given); None without a baseline.
    threshold_depth_mm : float or None
        The last loading depth (mm) where the baseline-corrected force is
        below 8 baseline noise std: certainly in contact beyond it. None
        without a baseline.
    fit_end_depth_mm : float
        Deepest point (mm) of the Hertz-shaped fit.
    """

    depth_mm: float
    has_baseline: bool
    baseline: Baseline | None
    threshold_depth_mm: float | None
    fit_end_depth_mm: float


def _hertz_sse(depth, force, d0, free_offset) -> float:
    """SSE of the least-squares ``force = b0 + a*max(depth - d0, 0)^1.5``, a >= 0.

    ``b0`` is fitted if `free_offset`, else fixed at 0.
    """
    x = np.clip(depth - d0, 0.0, None) ** _HERTZ_EXPONENT
    if free_offset:
        force, x = force - force.mean(), x - x.mean()
    sxx, sxy, sse = float(x @ x), float(x @ force), float(force @ force)
    return sse - sxy * sxy / sxx if sxx > 0 and sxy > 0 else sse


def _fit_contact(depth, force, lo, hi, free_offset) -> float:
    """Contact depth in [lo, hi] that minimises the Hertz-shaped SSE (grid, then Brent)."""
    if not hi > lo:
        return float(lo)
    grid = np.linspace(lo, hi, 201)
    sse = [_hertz_sse(depth, force, d0, free_offset) for d0 in grid]
    k = int(np.argmin(sse))
    res = minimize_scalar(
        lambda d0: _hertz_sse(depth, force, d0, free_offset),
        bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]),
        method="bounded",
        options={"xatol": (hi - lo) * 1e-6},
    )
    return float(res.x) if res.fun <= sse[k] else float(grid[k])


def _first_part_end(force, base_level) -> int | None:
    """Index of the first sample that rose by 30% of the total force rise (None: no rise)."""
    rise = force - base_level
    if not rise.max() > 0:
        return None
    return int(np.argmax(rise >= _CONTACT_FIT_FORCE_FRACTION * rise.max()))


def find_contact_point(
    measurement: Measurement, baseline: Baseline | None = None, *, fraction: float = 0.4
) -> ContactPoint:
    """Estimate the contact point of the loading curve, with diagnostics.

    Parameters
    ----------
    measurement : Measurement
        The whole curve; its :meth:`~Measurement.loading` segment is used.
    baseline : Baseline, optional
        A baseline to use instead of fitting one; giving one means the curve
        is taken to have a pre-contact part.
    fraction : float, optional
        Passed to :func:`estimate_baseline`.

    Returns
    -------
    ContactPoint
        The depth, the ``has_baseline`` flag and the baseline used.

    Raises
    ------
    MeasurementError
        If there is no loading segment or its force never rises.

    Notes
    -----
    Only ratios of the curve's own forces and depths enter (no absolute
    tolerance), so it works for AFM curves (nN, um) as for skin (mN, mm).

    1. On the loading curve up to where the force has risen by 30% of its
       total rise, fit ``F = b0 + a (d - d0)^1.5``: a Hertz-shaped contact on a
       flat baseline; ``d0`` by a 1-D search no earlier than the first sample,
       ``b0`` and ``a >= 0`` by linear least squares.
    2. If fewer than 10 samples lie before that ``d0`` there is no usable
       baseline (skin curves that start in contact). The force offset cannot
       then be told apart from the contact depth, so the force is taken as
       zero at contact (a tared instrument, as in the bundled skin curves):
       ``d0`` is refitted with ``b0 = 0`` and returned with
       ``has_baseline=False``. For a curve that starts at contact this is
       within a few depth steps of the first sample; a curve that starts
       under preload gives its first sample.
    3. Otherwise fit the baseline line (offset, tilt, noise) on the first
       `fraction` of the approach, no deeper than that ``d0``, and subtract
       it. The threshold depth is the last sample whose corrected force is
       below 8 noise std ("deviation from baseline", as in nanite). ``d0`` is
       refitted with ``b0 = 0`` on a local window (the contact part of step 1
       and twice its depth extent before it), searched no later than the
       threshold depth: the fit can only move the estimate earlier.

    The power 1.5 is that of a sphere at small depth, and fitting only the
    first 30% of the force rise stays close to that regime. A toe that rises
    more gradually than a power 1.5 (surface forces, roughness) gives the
    threshold depth. A later joint fit should refine the contact point.
    """
    approach = measurement.loading()
    depth, force = approach.depth_mm, approach.force_mN
    end = _first_part_end(force, np.median(force[: max(3, depth.size // 20)]))
    if end is None:
        raise MeasurementError(f"{measurement.source}: the force does not rise during loading")
    end = max(end, min(depth.size - 1, 2))
    part = slice(0, end + 1)
    d0 = _fit_contact(depth[part], force[part], depth[0], depth[end], free_offset=True)
    if baseline is None and np.sum(depth < d0) < _MIN_BASELINE_POINTS:
        d0 = _fit_contact(depth[part], force[part], depth[0], depth[end], free_offset=False)
        return ContactPoint(d0, False, None, None, float(depth[end]))
    if baseline is None:
        baseline = _fit_baseline(approach, fraction, max_depth_mm=d0)
    corrected = force - baseline.force_at(depth)
    noise = max(baseline.noise_mN, np.finfo(float).eps * float(np.abs(corrected).max()))
    below = np.flatnonzero(corrected < _CONTACT_THRESHOLD_SIGMA * noise)
    i_thr = int(below[-1]) if below.size else 0
    end = _first_part_end(corrected, 0.0)
    if end is None or end <= i_thr:
        end = min(depth.size - 1, i_thr + max(2, (depth.size - i_thr) // 3))
    extent = max(depth[end] - d0, 0.0)
    start = min(int(np.searchsorted(depth, d0 - 2.0 * extent)), max(i_thr - 2, 0))
    local = slice(start, end + 1)
    d0 = _fit_contact(depth[local], corrected[local], depth[start], depth[i_thr], False)
    return ContactPoint(d0, True, baseline, float(depth[i_thr]), float(depth[end]))


def estimate_contact_point(measurement: Measurement, baseline: Baseline | None = None) -> float:
    """Contact depth (mm) of the loading curve: ``find_contact_point(...).depth_mm``.

    See :func:`find_contact_point` for the method and for the ``has_baseline``
    flag, False when the curve starts in contact as skin curves usually do.
    """
    return find_contact_point(measurement, baseline).depth_mm
