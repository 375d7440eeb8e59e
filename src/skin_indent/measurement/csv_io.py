"""Reading and writing force-depth curves as CSV files with a header row.

:func:`load_csv` accepts the depth and force columns named in
:data:`DEPTH_COLUMNS` and :data:`FORCE_COLUMNS` (plus the optional
:data:`TIME_COLUMN`) and converts them to mm and mN; :func:`save_csv` writes
``time_s,depth_mm,force_mN`` atomically, with full float64 precision.
"""

from __future__ import annotations

import csv
import io
import os
import re
from pathlib import Path

import numpy as np

from .._atomic import atomic_write

from ._errors import MeasurementError, _quote
from .core import _MIN_POINTS, Measurement

__all__ = ["DEPTH_COLUMNS", "FORCE_COLUMNS", "TIME_COLUMN", "load_csv", "save_csv"]

#: Accepted depth column names and the factor that converts each to mm.
DEPTH_COLUMNS = {"depth_mm": 1.0, "depth_um": 1e-3, "depth_m": 1e3}
#: Accepted force column names and the factor that converts each to mN.
FORCE_COLUMNS = {"force_mN": 1.0, "force_N": 1e3, "force_uN": 1e-3}
#: The optional time column (s).
TIME_COLUMN = "time_s"

_DELIMITERS = (",", ";", "\t")  # tried in this order on the header line
_NUMBER = re.compile(
    r"[+-]?(?:(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?|nan|inf|infinity)", re.IGNORECASE
)


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
            f"({float(t[i])!r} -> {float(t[i + 1])!r})"
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
    return atomic_write(path, lambda fh: fh.write(("\n".join(lines) + "\n").encode("utf-8")))
