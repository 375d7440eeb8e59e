"""Reading instrument files (JPK ``.jpk-force`` and the other afmformats formats).

:func:`load_curve` reads a CSV with :func:`~skin_indent.measurement.load_csv` and
any other file with the optional `afmformats <https://pypi.org/project/afmformats/>`_
package (``pip install afmformats`` or ``pip install 'skin_indent[afm]'``). CSV stays
the common format: nothing else in the package needs afmformats.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ._errors import MeasurementError
from .core import Measurement
from .csv_io import load_csv

__all__ = ["AFMFORMATS_MISSING", "load_curve"]

#: The one-line message when an instrument file needs afmformats and it is missing.
AFMFORMATS_MISSING = ("reading {name} needs the optional package afmformats: pip install afmformats "
                      "(or pip install 'skin_indent[afm]'), or export the curve as CSV "
                      "(time_s,depth_um,force_N ...)")

_CSV_SUFFIXES = (".csv", ".txt", ".tsv")


def _import_afmformats():
    try:
        import afmformats
    except ImportError:
        return None
    return afmformats


def load_curve(path, *, radius_mm: float | None = None, index: int = 0) -> Measurement:
    """Read a force-depth curve from a CSV or an instrument file.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file (see :func:`load_csv`), or an instrument file that afmformats
        reads (JPK ``.jpk-force``, ``.jpk-force-map``, ``.jpk-qi-data``, Igor
        ``.ibw``, nanite ``.tab``, ...).
    radius_mm : float, optional
        Indenter radius (mm) to store in the measurement.
    index : int, optional
        Which curve of a multi-curve file (force maps), from 0.

    Returns
    -------
    Measurement
        Depth (mm) = tip position moved towards the sample since the first sample
        (positive into the sample; contact is where it happens, not at 0), force (mN)
        as calibrated by the instrument (no baseline removed), time (s).

    Raises
    ------
    MeasurementError
        One line: afmformats missing (with the install command), the file not
        readable, no such curve, or missing columns.

    Notes
    -----
    The tip position is afmformats' ``"tip position"`` column if present, else
    ``height (measured)`` (or ``height (piezo)``) plus force / k with the spring
    constant k stored in the file: the tip-sample separation of nanite.
    """
    path = Path(os.fspath(path))
    if path.suffix.lower() in _CSV_SUFFIXES:
        return load_csv(path, radius_mm=radius_mm)
    name = path.name or str(path)
    if not path.exists():
        raise MeasurementError(f"{path}: file not found")
    afmformats = _import_afmformats()
    if afmformats is None:
        raise MeasurementError(AFMFORMATS_MISSING.format(name=name))
    try:
        curves = afmformats.load_data(path)
    except Exception as err:  # noqa: BLE001 - any reader failure: one line naming the file
        why = " ".join(str(err).split()) or type(err).__name__
        raise MeasurementError(f"{name}: afmformats cannot read it ({why})") from None
    if not 0 <= index < len(curves):
        raise MeasurementError(f"{name}: curve {index} requested, the file holds {len(curves)}")
    data = curves[index]
    columns = list(getattr(data, "columns", []))
    if "force" not in columns:
        raise MeasurementError(f"{name}: no force column (columns: {', '.join(columns)})")
    force_N = np.asarray(data["force"], dtype=float)
    if "tip position" in columns:
        tip_m, how = np.asarray(data["tip position"], dtype=float), "tip position"
    else:
        height = next((c for c in ("height (measured)", "height (piezo)") if c in columns), None)
        k = getattr(data, "metadata", {}).get("spring constant")
        if height is None or not k:
            raise MeasurementError(f"{name}: neither a tip position nor a height with a spring constant "
                                   f"(columns: {', '.join(columns)})")
        tip_m, how = np.asarray(data[height], dtype=float) + force_N / float(k), f"{height} + force/k"
    time_s = np.asarray(data["time"], dtype=float) if "time" in columns else None
    depth_mm = -(tip_m - tip_m[0]) * 1e3
    cols = {"depth_mm": {"column": how, "factor": -1e3}, "force_mN": {"column": "force", "factor": 1e3},
            "reader": {"afmformats": getattr(afmformats, "__version__", "?"), "index": index}}
    if time_s is not None:
        cols["time_s"] = {"column": "time", "factor": 1.0}
    return Measurement(depth_mm, force_N * 1e3, time_s, name, cols, radius_mm)
