"""Reading instrument files: CSV, Optics11 Chiaro ``.txt`` and the afmformats formats.

:func:`load_curves` reads every curve of a file (all curves of a force map),
:func:`load_curve` one of them. CSV files go to
:func:`~skin_indent.measurement.load_csv`, Chiaro text exports to
:func:`~skin_indent.measurement.load_chiaro_txt` (neither needs an optional
package), any other file to the optional
`afmformats <https://pypi.org/project/afmformats/>`_ package (``pip install
afmformats`` or ``pip install 'skin_indent[afm]'``): JPK ``.jpk-force``,
``.jpk-force-map``, ``.jpk-qi-data``, Igor ``.ibw``, nanite ``.tab``, HDF5,
AFM Workshop, NT-MDT. Nothing else in the package needs afmformats.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ._errors import MeasurementError
from .core import Measurement
from .csv_io import load_csv
from .optics11 import is_chiaro_txt, load_chiaro_txt

__all__ = ["AFMFORMATS_MISSING", "load_curve", "load_curves"]

#: The one-line message when an instrument file needs afmformats and it is missing.
AFMFORMATS_MISSING = ("reading {name} needs the optional package afmformats: pip install afmformats "
                      "(or pip install 'skin_indent[afm]'), or export the curve as CSV "
                      "(time_s,depth_um,force_N ...)")

_CSV_SUFFIXES = (".csv", ".txt", ".tsv")
# afmformats metadata copied into columns["reader"] (SI units as afmformats gives them)
_CURVE_KEYS = {"enum": "enum", "curve id": "curve_id", "grid index x": "grid_index_x",
               "grid index y": "grid_index_y"}


def _import_afmformats():
    try:
        import afmformats
    except ImportError:
        return None
    return afmformats


def _reader_errors(afmformats) -> tuple:
    """The exceptions afmformats raises for a bad file (its own derive from BaseException)."""
    errors = getattr(afmformats, "errors", None)
    extra = (getattr(errors, "AFMFileFormatError", None), getattr(errors, "MissingMetaDataError", None))
    return (Exception, *(e for e in extra if isinstance(e, type) and issubclass(e, BaseException)))


def _why(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__


def _plain(value):
    """A JSON-friendly copy of one metadata value, or None to leave it out."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    return None


def _afm_curves(path: Path, name: str):
    """The afmformats curves of `path` and the afmformats module; one-line errors."""
    if not path.exists():
        raise MeasurementError(f"{path}: file not found")
    if path.is_dir():
        raise MeasurementError(f"{name}: is a directory, not an instrument file")
    afmformats = _import_afmformats()
    if afmformats is None:
        raise MeasurementError(AFMFORMATS_MISSING.format(name=name))
    try:
        curves = afmformats.load_data(path)
    except _reader_errors(afmformats) as err:  # any reader failure: one line naming the file
        raise MeasurementError(f"{name}: afmformats cannot read it ({_why(err)})") from None
    if len(curves) == 0:
        raise MeasurementError(f"{name}: afmformats finds no force-distance curve in it")
    return curves, afmformats


def _from_afmformats(data, name: str, index: int, n_curves: int, afmformats,
                     radius_mm: float | None) -> Measurement:
    """One afmformats curve as a :class:`Measurement` in mm, mN, s (afmformats reads lazily)."""
    source = name if n_curves == 1 else f"{name}[{index}]"
    try:
        return _convert(data, source, index, n_curves, afmformats, radius_mm)
    except MeasurementError:
        raise
    except _reader_errors(afmformats) as err:
        raise MeasurementError(f"{source}: afmformats cannot read this curve ({_why(err)})") from None


def _convert(data, source: str, index: int, n_curves: int, afmformats,
             radius_mm: float | None) -> Measurement:
    """The conversion of :func:`_from_afmformats`: tip position to depth, N to mN, metadata."""
    columns = list(getattr(data, "columns", []))
    if "force" not in columns:
        raise MeasurementError(f"{source}: no force column (columns: {', '.join(columns)}); "
                               "is the deflection calibrated?")
    meta = dict(getattr(data, "metadata", {}) or {})
    force_N = np.asarray(data["force"], dtype=float)
    if "tip position" in columns:
        tip_m, how = np.asarray(data["tip position"], dtype=float), "tip position"
    else:
        height = next((c for c in ("height (measured)", "height (piezo)") if c in columns), None)
        k = meta.get("spring constant")
        if height is None or not k:
            raise MeasurementError(f"{source}: neither a tip position nor a height with a spring constant "
                                   f"(columns: {', '.join(columns)})")
        tip_m, how = np.asarray(data[height], dtype=float) + force_N / float(k), f"{height} + force/k"
    time_s = np.asarray(data["time"], dtype=float) if "time" in columns else None
    depth_mm = -(tip_m - tip_m[0]) * 1e3 + 0.0  # + 0.0: no -0.0 at the first sample
    version = getattr(afmformats, "__version__", "?")
    reader = {"name": "afmformats", "version": version, "format": _plain(meta.get("format")),
              "index": index, "n_curves": n_curves}
    reader.update({key: _plain(meta[k]) for k, key in _CURVE_KEYS.items() if k in meta})
    if "position x" in meta and "position y" in meta:
        reader["position_mm"] = [float(meta["position x"]) * 1e3, float(meta["position y"]) * 1e3]
    cols = {"depth_mm": {"column": f"-({how}), from row 0", "factor": 1e3},
            "force_mN": {"column": "force", "factor": 1e3},
            "reader": reader,
            "metadata": {k: v for k, v in ((k, _plain(v)) for k, v in meta.items()) if v is not None}}
    if time_s is not None:
        cols["time_s"] = {"column": "time", "factor": 1.0}
    if radius_mm is not None:
        cols["radius_mm"] = {"from": "argument"}
    return Measurement(depth_mm, force_N * 1e3, time_s, source, cols, radius_mm)


def load_curves(path, *, radius_mm: float | None = None) -> list[Measurement]:
    """Read every curve of a CSV, Chiaro or instrument file.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file (see :func:`load_csv`), an Optics11 Chiaro text export (see
        :func:`load_chiaro_txt`), or an instrument file that afmformats reads
        (JPK ``.jpk-force``, ``.jpk-force-map``, ``.jpk-qi-data``, Igor ``.ibw``,
        nanite ``.tab``, ...).
    radius_mm : float, optional
        Indenter radius (mm) for every curve. It overrides a radius recorded in
        the file (a CSV radius comment, the Chiaro header's tip radius); the JPK
        and other afmformats formats record none.

    Returns
    -------
    list of Measurement
        One per curve, in file order: depth (mm) = tip position moved towards the
        sample since the curve's first sample (positive into the sample; contact
        is where it happens, not at 0), force (mN) as calibrated by the instrument
        (no baseline removed), time (s) if recorded. A CSV or Chiaro file gives
        one. ``columns["reader"]`` holds the reader, ``"index"`` (from 0) and
        ``"n_curves"``, and for force maps the instrument's curve number
        (``"enum"``), ``"grid_index_x"``/``"grid_index_y"`` and ``"position_mm"``
        (x, y of the map point, mm); ``columns["metadata"]`` the file's metadata
        (afmformats names, SI units). The source of a curve of a multi-curve file
        is ``"name[index]"``.

    Raises
    ------
    MeasurementError
        One line: afmformats missing (with the install command), the file not
        readable or not recognised, no curve in it, no force column, or no tip
        position (neither a height nor a spring constant); the CSV and Chiaro
        readers' own errors.

    Notes
    -----
    The tip position is afmformats' ``"tip position"`` column if present, else
    ``height (measured)`` (or ``height (piezo)``) plus force / k with the spring
    constant k stored in the file: the tip-sample separation of nanite.
    """
    path = Path(os.fspath(path))
    name = path.name or str(path)
    if path.suffix.lower() == ".txt" and is_chiaro_txt(path):
        return [load_chiaro_txt(path, radius_mm=radius_mm)]
    if path.suffix.lower() in _CSV_SUFFIXES:
        return [load_csv(path, radius_mm=radius_mm)]
    curves, afmformats = _afm_curves(path, name)
    return [_from_afmformats(data, name, i, len(curves), afmformats, radius_mm)
            for i, data in enumerate(curves)]


def load_curve(path, *, radius_mm: float | None = None, index: int = 0) -> Measurement:
    """Read one curve of a CSV, Chiaro or instrument file.

    Parameters
    ----------
    path : str or os.PathLike
        As for :func:`load_curves`.
    radius_mm : float, optional
        Indenter radius (mm); overrides a radius recorded in the file.
    index : int, optional
        Which curve of a multi-curve file (force maps), from 0; a CSV or Chiaro
        file has only curve 0.

    Returns
    -------
    Measurement
        As an element of :func:`load_curves`; only this curve is converted.

    Raises
    ------
    MeasurementError
        One line, as :func:`load_curves`, or for an index the file does not hold.
    """
    path = Path(os.fspath(path))
    name = path.name or str(path)
    if path.suffix.lower() in _CSV_SUFFIXES:
        curves = load_curves(path, radius_mm=radius_mm)
        if index != 0:
            raise MeasurementError(f"{name}: curve {index} requested, the file holds 1 (index 0)")
        return curves[0]
    curves, afmformats = _afm_curves(path, name)
    if not (isinstance(index, (int, np.integer)) and 0 <= index < len(curves)):
        raise MeasurementError(f"{name}: curve {index} requested, the file holds {len(curves)} "
                               f"(index 0 to {len(curves) - 1})")
    return _from_afmformats(curves[index], name, int(index), len(curves), afmformats, radius_mm)
