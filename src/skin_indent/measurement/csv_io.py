"""Reading and writing force-depth curves as CSV files with a header row.

:func:`load_csv` accepts the depth and force columns named in
:data:`DEPTH_COLUMNS` and :data:`FORCE_COLUMNS` (plus the optional
:data:`TIME_COLUMN`) and converts them to mm and mN; :func:`save_csv` writes
``time_s,depth_mm,force_mN`` atomically, with full float64 precision.

Lines starting with ``#`` are comments, before the header and between data rows;
a ``# radius_um: 18.64``-style comment (see :func:`parse_radius_comment`) gives the
indenter radius.
"""

from __future__ import annotations

import csv
import io
import os
import re
from pathlib import Path

import numpy as np

from ..runtime.atomic import atomic_write

from ._errors import MeasurementError, _quote
from ._files import read_bytes
from .core import _MIN_POINTS, Measurement

__all__ = ["DEPTH_COLUMNS", "FORCE_COLUMNS", "TIME_COLUMN", "load_csv", "parse_radius_comment",
           "save_csv"]

#: Accepted depth column names and the factor that converts each to mm.
DEPTH_COLUMNS = {"depth_mm": 1.0, "depth_um": 1e-3, "depth_nm": 1e-6, "depth_m": 1e3}
#: Accepted force column names and the factor that converts each to mN.
FORCE_COLUMNS = {"force_mN": 1.0, "force_N": 1e3, "force_uN": 1e-3, "force_nN": 1e-6}
#: The optional time column (s).
TIME_COLUMN = "time_s"

_DELIMITERS = (",", ";", "\t")  # tried in this order on the header line
_NUMBER = re.compile(
    r"[+-]?(?:(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)", re.IGNORECASE
)

#: Length units a radius comment may use, and the factor to mm.
RADIUS_UNITS = {"nm": 1e-6, "um": 1e-3, "\u00b5m": 1e-3, "\u03bcm": 1e-3, "micron": 1e-3,
                "microns": 1e-3, "mm": 1.0, "m": 1e3}
_UNIT = r"(?:nm|um|\u00b5m|\u03bcm|microns?|mm|m)"
# "# radius_um: 18.64", "# tip radius (um)\t27.5", "# Sphere radius = 18.64 um", ...
_RADIUS_KEY = re.compile(
    r"\s*(?:(?:tip|sphere|indenter|probe|bead)[ _-]?)?radius"
    rf"(?:[ _]?\(?\s*(?P<unit>{_UNIT})(?![a-z])\s*\)?)?\s*",
    re.IGNORECASE)
_RADIUS_VALUE = re.compile(rf"\s*(?P<value>[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)"
                           rf"\s*(?P<unit>{_UNIT})?\s*$", re.IGNORECASE)


def parse_radius_comment(line: str) -> float | None:
    """The indenter radius (mm) a metadata line states, or None if it states none.

    Parameters
    ----------
    line : str
        A comment line such as ``# radius_um: 18.64``, ``# tip radius (um)\t27.5``,
        ``# Sphere radius = 0.5 mm`` or ``# radius: 18.64 um`` (the leading ``#`` is
        optional). The unit (nm, um, µm, micron, mm, m) goes in the name or after the
        number; names are ``radius`` with an optional ``tip``, ``sphere``,
        ``indenter``, ``probe`` or ``bead`` in front, in any case.

    Returns
    -------
    float or None
        The radius in mm; None if the line is not a radius statement (any other
        comment).

    Raises
    ------
    ValueError
        One line, if the line names a radius but its value is not a positive number
        with exactly one unit.
    """
    text = line.strip()
    text = text[1:] if text.startswith("#") else text
    key = _RADIUS_KEY.match(text)
    if key is None:
        return None
    rest, declared = text[key.end():], False
    if rest[:1] in (":", "=", ","):
        rest, declared = rest[1:], True
    elif text[key.end() - 1 : key.end()] == "\t":
        declared = True
    value = _RADIUS_VALUE.match(rest)
    if value is None:
        if declared:
            raise ValueError(f"radius {_quote(rest.strip())} is not a number with a unit")
        return None  # prose that happens to start with "radius"
    units = {u.lower().replace("\u03bc", "\u00b5") for u in (key["unit"], value["unit"]) if u}
    if not units:
        raise ValueError("radius without a unit (write e.g. '# radius_um: 18.64')")
    if len(units) > 1:
        raise ValueError(f"radius with two units ({', '.join(sorted(units))})")
    radius = float(value["value"]) * RADIUS_UNITS[units.pop()]
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be positive, got {value['value']}")
    return radius


def _read_text(path: Path) -> str:
    raw = read_bytes(path, "CSV file")
    name = path.name or str(path)
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


def _column_list(fields: list[str]) -> str:
    """The first 20 header names, quoted, for an error message."""
    return ", ".join(_quote(c, 30) for c in fields[:20])


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
        found = _column_list(fields)
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
    found = _column_list(fields)
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
        Indenter radius (mm) to store in the measurement. It overrides a radius
        comment in the file.

    Returns
    -------
    Measurement
        Depth in mm, force in mN, time in s (if present); ``radius_mm`` from the
        argument, else from a radius comment, else None. ``columns["comments"]``
        holds the comment lines (without ``#``), ``columns["radius_mm"]`` where
        the radius came from.

    Raises
    ------
    MeasurementError
        With a one-line message for: a missing file, a directory, non-UTF-8
        or NUL bytes, an empty file, a header without data rows, a missing or
        ambiguous depth/force column (listing the columns found), a row with
        the wrong number of fields, an empty, non-numeric or non-finite cell
        (line and column named), fewer than 3 rows, a decreasing time, or a
        radius comment without a positive number and a unit, or two radius
        comments that disagree.

    Notes
    -----
    - The header needs exactly one depth column (``depth_mm``, ``depth_um``,
      ``depth_nm``, ``depth_m``) and exactly one force column (``force_mN``,
      ``force_N``, ``force_uN``, ``force_nN``); ``time_s`` is optional. Names are case-sensitive. Other
      columns are ignored, not even parsed. Values are converted to mm and mN
      and the conversion is recorded in :attr:`Measurement.columns`.
    - Delimiter: the first of comma, semicolon and tab that splits the header
      into names including a depth and a force column is used for the whole
      file. The choice is driven by the column names, so data cannot fool it.
      Numbers need a ``.`` decimal point (a decimal comma is reported).
    - Blank lines are skipped, and so are comment lines, whose first non-blank
      character is ``#`` (before the header and between data rows); every other
      line is a data row: none is dropped. Line numbers in messages count every
      line of the file.
    - A comment such as ``# radius_um: 18.64``, ``# tip radius (um): 18.64`` or
      ``# radius: 0.5 mm`` sets the indenter radius (see
      :func:`parse_radius_comment`).
    """
    path = Path(os.fspath(path))
    name = path.name or str(path)
    lines = io.StringIO(_read_text(path), newline="")
    comments, radii = [], {}
    current = [0]  # the number of the last line handed to the CSV reader

    def data_lines():
        for line_no, line in enumerate(lines, start=1):
            text = line.strip()
            if text.startswith("#"):
                comments.append(text[1:].strip())
                try:
                    radius = parse_radius_comment(text)
                except ValueError as err:
                    raise MeasurementError(f"{name}: line {line_no}: {err}") from None
                if radius is not None:
                    radii[line_no] = radius
                continue
            current[0] = line_no
            yield line

    feed = data_lines()
    header = ""
    for line in feed:
        if line.strip():
            header = line.rstrip("\r\n")
            break
    if not header:
        only = " (only comment lines)" if comments else ""
        raise MeasurementError(f"{name}: file is empty{only}")
    delimiter, n_fields, wanted = _choose_columns(name, header)

    values = {key: [] for key in wanted}
    line_numbers = []
    reader = csv.reader(feed, delimiter=delimiter)
    try:
        for row in reader:
            line_no = current[0]
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
        line_no = current[0]
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
            f"({float(t[i])!r} -> {float(t[i + 1])!r})"
        )
    columns = {key: {"column": original, "factor": factor}
               for key, (_, original, factor) in wanted.items()}
    if len(set(radii.values())) > 1:
        stated = ", ".join(f"line {n}: {r!r} mm" for n, r in radii.items())
        raise MeasurementError(f"{name}: radius comments disagree ({stated})")
    if comments:
        columns["comments"] = comments
    if radius_mm is not None:
        columns["radius_mm"] = {"from": "argument"}
        if radii:
            columns["radius_mm"]["in_file_mm"] = next(iter(radii.values()))
    elif radii:
        line_no, radius_mm = next(iter(radii.items()))
        columns["radius_mm"] = {"from": f"comment, line {line_no}"}
    return Measurement(values["depth_mm"], values["force_mN"], values.get("time_s"), name,
                       columns, radius_mm)


def save_csv(measurement: Measurement, path) -> Path:
    """Write ``time_s,depth_mm,force_mN`` (or ``depth_mm,force_mN``) atomically, after a
    ``# radius_mm: R`` line when the measurement knows its sphere's radius.

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
    radius = getattr(measurement, "radius_mm", None)
    if radius is not None:  # the sphere's radius travels with the curve (read back by load_csv)
        lines.insert(0, f"# radius_mm: {float(radius)!r}")
    return atomic_write(path, lambda fh: fh.write(("\n".join(lines) + "\n").encode("utf-8")))
