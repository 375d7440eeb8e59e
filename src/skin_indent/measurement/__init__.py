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

Import everything from here (``from skin_indent.measurement import load_csv``);
the modules, in the order data flows through them, are:

- :mod:`._errors`: :class:`MeasurementError`;
- :mod:`.core`: :class:`Measurement`, :func:`measurement_from_arrays`;
- :mod:`.csv_io`: :func:`load_csv`, :func:`save_csv` and the accepted column
  names :data:`DEPTH_COLUMNS`, :data:`FORCE_COLUMNS`, :data:`TIME_COLUMN`;
- :mod:`.optics11`: :func:`load_chiaro_txt`, Optics11 Chiaro text exports;
- :mod:`.instrument`: :func:`load_curves` (every curve of a file, e.g. a force
  map) and :func:`load_curve`: CSV, Chiaro ``.txt`` or (with the optional
  afmformats package) JPK and other instrument files;
- :mod:`.segments`: :class:`Segment`, :func:`find_segments`;
- :mod:`.contact`: :class:`Baseline`, :func:`estimate_baseline`,
  :class:`ContactPoint`, :func:`find_contact_point`,
  :func:`estimate_contact_point`;
- :mod:`.cantilever`: the probe's spring constant, the file's or estimated from the ramps (where the
  cantilever's base, and the probe's body with it, sits: depth + force / k);
- :mod:`.preparation`: :func:`prepare` and :class:`PreparedCurve`, the one way a
  recorded curve is made ready for fits and diagnosis (segments, baseline, contact
  point, window, binning, radius, scale checks);
- :mod:`.curve_set`: :class:`CurveSet`, several prepared curves of one sample (two
  spheres, two speeds...), fitted and diagnosed together;
- :mod:`.curve_files` (imported from there): every curve of files, folders and force maps
  with where it comes from, what batches of fits and diagnoses read.
"""

from ._errors import MeasurementError
from .contact import (
    Baseline,
    ContactPoint,
    estimate_baseline,
    estimate_contact_point,
    find_contact_point,
)
from .core import Measurement, measurement_from_arrays
from .csv_io import DEPTH_COLUMNS, FORCE_COLUMNS, TIME_COLUMN, load_csv, save_csv
from .instrument import AFMFORMATS_MISSING, load_curve, load_curves
from .optics11 import load_chiaro_txt
from .segments import Segment, find_segments
from .preparation import CONTACT_MODES, SEGMENTS, SKIN_RADIUS_MM, PreparedCurve, prepare
from .curve_set import CurveSet

__all__ = [
    "CONTACT_MODES",
    "SEGMENTS",
    "SKIN_RADIUS_MM",
    "PreparedCurve",
    "CurveSet",
    "prepare",
    "AFMFORMATS_MISSING",
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
    "load_chiaro_txt",
    "load_csv",
    "load_curve",
    "load_curves",
    "measurement_from_arrays",
    "save_csv",
]
