"""Reading the text export of the Optics11 Chiaro nanoindenter (``.txt``).

A Chiaro export is Latin-1 text: a header of tab-separated ``name<TAB>value``
lines (date, stage position, ``k (N/m)``, ``Tip radius (um)``, the instrument's
own Hertz fit, ...), then a tab-separated table whose first row names the
columns with their units::

    Time (s)  Load (uN)  Indentation (nm)  Cantilever (nm)  Piezo (nm)  Auxiliary

:func:`load_chiaro_txt` reads it without any optional package. The depth is the
tip travel, piezo minus cantilever bending, from the first sample (the
convention of ``tests/data/real-data``); the force is the calibrated load; the
tip radius of the header becomes ``radius_mm``. The unit conversions and the
depth difference are done in exact decimal arithmetic on the text, then rounded
once to float64. afmformats (0.18.5 and later)
reads the same files; it is not needed here, and the tests check that both
agree.
"""

from __future__ import annotations

import os
import re
from decimal import Context, Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from ._errors import MeasurementError, _quote
from ._files import read_bytes
from .core import Measurement
from .csv_io import parse_radius_comment

__all__ = ["is_chiaro_txt", "load_chiaro_txt"]

_LENGTH_TO_MM = {"nm": Decimal("1e-6"), "um": Decimal("1e-3"), "mm": Decimal(1), "m": Decimal("1e3")}
_FORCE_TO_MN = {"nn": Decimal("1e-6"), "un": Decimal("1e-3"), "mn": Decimal(1), "n": Decimal("1e3")}
_EXACT = Context(prec=60)  # unit conversion and differences in exact decimal arithmetic
_COLUMN = re.compile(r"\s*(?P<name>[^()]*?)\s*\(\s*(?P<unit>[^()]*?)\s*\)\s*")
_SNIFF_LINES = 200  # the column row comes after about 40 header lines


def _unit(unit: str) -> str:
    """Lower case, micro sign and Greek mu as ``u``."""
    return unit.replace("\u00b5", "u").replace("\u03bc", "u").lower()


def _column_row(lines) -> int | None:
    """Index of the ``Time (s)<TAB>Load (..)`` row among the first lines, or None."""
    for i, line in enumerate(lines[:_SNIFF_LINES]):
        cells = [c.strip() for c in line.split("\t")]
        if len(cells) > 1 and cells[0].lower().startswith("time (") and cells[1].lower().startswith("load ("):
            return i
    return None


def _read_lines(path: Path) -> list[str]:
    raw = read_bytes(path, "Chiaro text file")
    if b"\x00" in raw:
        raise MeasurementError(f"{path.name or path}: contains NUL bytes; this is not a Chiaro text export")
    text = raw.decode("utf-8-sig") if raw.startswith(b"\xef\xbb\xbf") else raw.decode("latin-1")
    return text.splitlines()  # the exports mix \r\n, \n and lone \r


def is_chiaro_txt(path) -> bool:
    """True if `path` looks like a Chiaro text export (its ``Time (s)<TAB>Load`` column row).

    Parameters
    ----------
    path : str or os.PathLike
        Any file; unreadable files give False.
    """
    path = Path(os.fspath(path))
    try:
        with path.open("rb") as fh:
            head = fh.read(64 * 1024)
    except OSError:
        return False
    return _column_row(head.decode("latin-1").splitlines()) is not None


def _header_notes(header: list[str]) -> dict:
    """``name -> value`` strings of the header lines (pairs of tab-separated cells)."""
    notes = {}
    for line in header:
        cells = [c.strip() for c in line.split("\t")]
        while cells and not cells[-1]:
            cells.pop()
        if len(cells) == 1 and ":" in cells[0]:
            key, _, value = cells[0].partition(":")
            notes[key.strip()] = value.strip()
        elif len(cells) == 1:
            notes.setdefault("other lines", []).append(cells[0])  # e.g. the sample label
        elif len(cells) >= 2:
            for key, value in zip(cells[::2], cells[1::2]):
                if key:
                    notes[key.rstrip(":").strip()] = value
    return notes


def _find_column(name: str, cells: list[str], wanted: str, table: dict, what: str):
    """(index, header cell, factor to package units) of the column called `wanted`."""
    for i, cell in enumerate(cells):
        match = _COLUMN.fullmatch(cell)
        if match and match["name"].lower() == wanted.lower():
            unit = _unit(match["unit"])
            if unit not in table:
                raise MeasurementError(
                    f"{name}: column {_quote(cell)} has unit {_quote(match['unit'])}, not a {what} "
                    f"unit ({', '.join(table)})")
            return i, cell, table[unit]
    raise MeasurementError(f"{name}: no {_quote(wanted + ' (...)')} column (columns: "
                           f"{', '.join(_quote(c, 30) for c in cells[:12])})")


def _column_values(name: str, rows: list[list[str]], line_nos: list[int], col: int, cell: str,
                   factor: Decimal) -> list[Decimal]:
    """The column's cells times `factor`, exact (the text's decimals, no rounding)."""
    values = []
    for row, line_no in zip(rows, line_nos):
        try:
            value = Decimal(row[col].strip())
        except InvalidOperation:
            value = None
        if value is None or not value.is_finite():
            raise MeasurementError(f"{name}: line {line_no}, column {_quote(cell)}: "
                                   f"{_quote(row[col])} is not a finite number")
        values.append(_EXACT.multiply(value, factor))
    return values


def load_chiaro_txt(path, *, radius_mm: float | None = None) -> Measurement:
    """Read an Optics11 Chiaro text export.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.txt`` file as the Chiaro software exports it.
    radius_mm : float, optional
        Indenter radius (mm); overrides the header's ``Tip radius (um)``.

    Returns
    -------
    Measurement
        ``depth_mm`` = (Piezo - Cantilever) - (Piezo - Cantilever) of the first
        row (mm; positive into the sample, contact well past 0), ``force_mN`` =
        Load (mN, as calibrated, no baseline removed), ``time_s`` = Time (s),
        ``radius_mm`` from the argument or the header. ``columns["metadata"]``
        holds the header's name/value strings, ``columns["reader"]`` the format.

    Raises
    ------
    MeasurementError
        One line: the file missing or not a Chiaro export, a missing Time, Load,
        Piezo or Cantilever column, a unit that is not a length (nm, um, mm, m) or
        a force (nN, uN, mN, N), a row with the wrong number of fields, a
        non-numeric cell (line and column named), a bad tip radius, fewer than 3
        rows or time going back.
    """
    path = Path(os.fspath(path))
    name = path.name or str(path)
    lines = _read_lines(path)
    start = _column_row(lines)
    if start is None:
        raise MeasurementError(f"{name}: not a Chiaro text export (no 'Time (s)<TAB>Load (uN)' "
                               f"column row in the first {_SNIFF_LINES} lines)")
    header, cells = lines[:start], [c.strip() for c in lines[start].strip().split("\t")]
    time_col = _find_column(name, cells, "Time", {"s": Decimal(1)}, "time")
    load_col = _find_column(name, cells, "Load", _FORCE_TO_MN, "force")
    piezo_col = _find_column(name, cells, "Piezo", _LENGTH_TO_MM, "length")
    cant_col = _find_column(name, cells, "Cantilever", _LENGTH_TO_MM, "length")

    rows, line_nos = [], []
    for line_no, line in enumerate(lines[start + 1:], start=start + 2):
        if not line.strip():
            continue
        row = line.strip().split("\t")
        if len(row) != len(cells):
            raise MeasurementError(f"{name}: line {line_no} has {len(row)} fields, the column row has "
                                   f"{len(cells)}")
        rows.append(row)
        line_nos.append(line_no)
    if len(rows) < 3:
        raise MeasurementError(f"{name}: {len(rows)} data rows; at least 3 are needed")
    t, f, p, c = (_column_values(name, rows, line_nos, col, cell, factor)
                  for col, cell, factor in (time_col, load_col, piezo_col, cant_col))
    travel0 = _EXACT.subtract(p[0], c[0])
    depth = np.array([float(_EXACT.subtract(_EXACT.subtract(pi, ci), travel0)) for pi, ci in zip(p, c)])
    force, time = np.array([float(v) for v in f]), np.array([float(v) for v in t])

    notes = _header_notes(header)
    in_file = None
    for line_no, line in enumerate(header, start=1):
        try:
            stated = parse_radius_comment(line)
        except ValueError as err:
            raise MeasurementError(f"{name}: line {line_no}: {err}") from None
        in_file = stated if stated is not None and in_file is None else in_file
    columns = {
        "depth_mm": {"column": f"{piezo_col[1]} - {cant_col[1]}, from row 0", "factor": float(piezo_col[2])},
        "force_mN": {"column": load_col[1], "factor": float(load_col[2])},
        "time_s": {"column": time_col[1], "factor": 1.0},
        "reader": {"name": "skin_indent.measurement.optics11", "format": "Optics11 Chiaro text export",
                   "index": 0, "n_curves": 1},
        "metadata": notes,
    }
    if radius_mm is not None:
        columns["radius_mm"] = {"from": "argument", **({"in_file_mm": in_file} if in_file else {})}
    elif in_file is not None:
        radius_mm = in_file
        columns["radius_mm"] = {"from": "file header (Tip radius)"}
    return Measurement(depth, force, time, name, columns, radius_mm)
