"""Every curve of files and folders, each with where it came from: what a batch reads.

:func:`expand_paths` turns files and folders into the files to read; :func:`read_curves` reads
every curve of them (all curves of a force map, or the one at ``index``), each with its
:class:`CurveLocation` (file, index in it, map grid indices and position), or the one-line error
of a file that cannot be read: a bad file is one row of a batch, never its end. Batches of fits
(:func:`skin_indent.batch.fit_many`) and of diagnoses
(:func:`skin_indent.diagnosis.diagnose_many`) read their curves here.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..runtime.batch import one_line
from ._files import folder_files
from .instrument import load_curve, load_curves

__all__ = ["OUTPUT_MARK", "READABLE_SUFFIXES", "CurveLocation", "expand_paths", "read_curves"]

#: file suffixes a folder is searched for (CSV and Chiaro text without optional packages;
#: the others need afmformats, and give a row with the install command without it)
READABLE_SUFFIXES = (".csv", ".tsv", ".txt", ".jpk-force", ".jpk-force-map", ".jpk-qi-data", ".jpk-qi-series",
                     ".ibw", ".tab", ".h5", ".zip")

#: the first bytes of every table and curve file the package writes (its provenance line)
OUTPUT_MARK = b"# written by skin_indent"


@dataclass(frozen=True)
class CurveLocation:
    """Where a curve of a batch comes from: the first fields of every batch row.

    Attributes
    ----------
    file : str
        The file, as found (a folder's files as ``folder/name``).
    index : int or None
        Curve in the file, from 0 (None: the file could not be read).
    grid_x, grid_y : int or None
        Grid indices of a force-map curve.
    x_mm, y_mm : float or None
        Position of a force-map curve (mm).
    """

    file: str
    index: int | None = None
    grid_x: int | None = None
    grid_y: int | None = None
    x_mm: float | None = None
    y_mm: float | None = None

    @property
    def label(self) -> str:
        """``name`` or ``name[index]`` (the file's name only)."""
        name = Path(self.file).name
        return name if self.index is None else f"{name}[{self.index}]"

    def short_label(self, width: int = 28) -> str:
        """:attr:`label` cut in the middle to at most ``width`` characters."""
        text = self.label
        if len(text) <= width:
            return text
        keep = (width - 3) // 2
        return f"{text[:keep]}...{text[-(width - 3 - keep):]}"

    @property
    def plot_name(self) -> str:
        """The name of the curve's own outputs: ``name`` or ``name_index`` (the file's name with its suffix)."""
        stem = Path(self.file).name
        return stem if self.index is None else f"{stem}_{self.index}"

    @property
    def location(self) -> dict:
        """The location fields alone, as keywords of a row."""
        return {"file": self.file, "index": self.index, "grid_x": self.grid_x, "grid_y": self.grid_y,
                "x_mm": self.x_mm, "y_mm": self.y_mm}


def _written_by_us(path: Path) -> bool:
    """True for an output of this package (a TSV table or fit CSV starts with its provenance line)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(len(OUTPUT_MARK)) == OUTPUT_MARK
    except OSError:
        return False


def expand_paths(paths, *, recursive: bool = False) -> list[Path]:
    """Files to read: a file as given, a folder's files with a readable suffix (sorted).

    Parameters
    ----------
    paths : path or iterable of paths
        Files and folders. A folder's hidden files and folders and the package's own outputs
        (a results table or fit CSV written there, recognised by their first line
        ``# written by skin_indent``) are left out.
    recursive : bool
        Search the folders' subfolders too, at every depth (default: only the files directly
        in each folder, so results and plot folders written inside it stay out of the way).

    Returns
    -------
    list of Path
        In the order given, each file once. A path that does not exist is kept (its row
        will say so).
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    out, seen = [], set()
    for p in paths:
        p = Path(os.fspath(p))
        found = (folder_files(p, READABLE_SUFFIXES, recursive=recursive, skip=_written_by_us) if p.is_dir()
                 else [p])
        for q in found:
            key = os.path.abspath(q)
            if key not in seen:
                seen.add(key)
                out.append(q)
    return out


def _where(path, measurement, i: int) -> CurveLocation:
    reader = measurement.columns.get("reader", {}) if isinstance(measurement.columns, dict) else {}
    pos = reader.get("position_mm") or (None, None)
    return CurveLocation(os.fspath(path), reader.get("index", i), reader.get("grid_index_x"),
                         reader.get("grid_index_y"), pos[0], pos[1])


def read_curves(files, *, index: int | None = None, radius_mm: float | None = None) -> list[tuple]:
    """Every curve of ``files``: ``(CurveLocation, Measurement, None)``, or ``(CurveLocation, None,
    error)`` for a file that cannot be read (one line; its location has only the file and ``index``).

    Parameters
    ----------
    files : iterable of path
        From :func:`expand_paths`.
    index : int, optional
        Only this curve of each file (from 0); default every curve (all curves of a force map).
    radius_mm : float, optional
        Sphere radius (mm) of every curve (:func:`~skin_indent.measurement.load_curves`).

    Returns
    -------
    list of tuple
        In file and curve order.
    """
    out = []
    for path in files:
        try:
            curves = (load_curves(path, radius_mm=radius_mm) if index is None
                      else [load_curve(path, radius_mm=radius_mm, index=index)])
        except Exception as err:  # noqa: BLE001 - a bad file is one row
            out.append((CurveLocation(os.fspath(path), index), None, one_line(err)))
            continue
        for i, m in enumerate(curves):
            out.append((_where(path, m, i if index is None else index), m, None))
    return out
