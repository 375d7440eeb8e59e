"""One preparation of a recorded curve, for fits, diagnosis and the Python API alike.

:func:`prepare` turns a :class:`~skin_indent.measurement.Measurement` as an instrument
recorded it into the points a model is compared with (:class:`PreparedCurve`):

1. **radius**: the one given, else the measurement's, else the skin default
   (:data:`SKIN_RADIUS_MM`, said so in ``radius_source``);
2. **segments**: approach / hold / retract (:func:`find_segments`); a fit of the
   loading curve keeps the approach (depth jitter dropped), a diagnosis keeps the whole
   history up to the last kept segment (a viscoelastic force depends on it);
3. **contact point and baseline** (:func:`find_contact_point`): with ``contact="auto"``
   a curve with a pre-contact part gets its contact point fitted later (``"fit"``) and
   its baseline line subtracted (its tilt only where it exceeds 3 standard errors);
   a curve that starts in contact keeps its depth origin (``"origin"``);
4. **window** of indentation depths past the contact point, and **binning** of long
   curves within segments;
5. **scale checks** before any finite-element work: an indentation deeper than the
   sphere's radius (depth in um labelled mm? a radius in mm given in um?), nN forces with
   the skin default radius. A depth that is a vanishing fraction of the radius (radius in
   um typed as mm?) and the checks that need a fit (a modulus no tissue has, too few points,
   undetermined parameters) are flags of the fit: :mod:`skin_indent.fitting.scale_checks`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ._errors import MeasurementError
from .cantilever import spring_constant
from .contact import Baseline, ContactPoint, find_contact_point
from .core import Measurement
from .scale import Quantity, UnitText
from .segments import find_segments
from ..inverse.noise import estimate_noise, noise_min_points

#: kinds of motion of a curve
SEGMENTS = ("approach", "hold", "retract")
#: ways to place the contact point
CONTACT_MODES = ("auto", "fit", "origin")
#: the sphere of the in vivo skin test (Delalleau et al. 2006), mm: the default radius
SKIN_RADIUS_MM = 6.22
#: deepest indentation over radius the package handles (h/R; the surfaces reach 0.5 by similarity)
MAX_DEPTH_RATIO = 1.0
#: shallowest h/R that looks like a real indentation (smaller: a radius in the wrong unit; a flag of the
#: fit, see :mod:`skin_indent.fitting.scale_checks`)
MIN_DEPTH_RATIO = 1e-3


@dataclass(frozen=True, eq=False)
class PreparedCurve:
    """A recorded curve made ready for a model (nothing fitted yet; see :func:`prepare`).

    Attributes
    ----------
    measurement : Measurement
        The whole curve, as read.
    segments : list of Segment
        Approach/hold/retract rows of the whole curve.
    depth_mm, force_mN : ndarray
        The points to compare with a model: recorded depth (mm), force with the
        baseline removed (mN), in time order.
    time_s : ndarray or None
    kind : ndarray of str
        ``"approach"``, ``"hold"`` or ``"retract"`` per point.
    radius_mm : float
        Sphere radius (mm).
    radius_source : str
        Where the radius came from (``"given"``, ``"measurement"``, ``"default"``).
    contact_mode : {"fit", "fixed", "origin"}
        Contact point to be fitted jointly, fixed by the user, or at recorded depth 0.
    contact_guess_mm : float
        First guess (or fixed value) of the contact point, recorded depth (mm).
    contact : ContactPoint or None
        The first-guess diagnostics.
    baseline : Baseline or None
        The line subtracted from the force (None: nothing subtracted).
    baseline_fitted : Baseline or None
        The line as fitted (its tilt dropped from ``baseline`` if not significant).
    binned : int
        Samples averaged per point (1: none).
    rows : (int, int)
        Rows of the measurement the points come from.
    notes : tuple of str
        Warnings about the data (scale, radius).
    """

    measurement: Measurement
    segments: list
    depth_mm: np.ndarray
    force_mN: np.ndarray
    time_s: np.ndarray | None
    kind: np.ndarray
    radius_mm: float
    radius_source: str
    contact_mode: str
    contact_guess_mm: float
    contact: ContactPoint | None = None
    baseline: Baseline | None = None
    baseline_fitted: Baseline | None = None
    binned: int = 1
    rows: tuple = (0, 0)
    notes: tuple = field(default_factory=tuple)

    @property
    def source(self) -> str:
        return self.measurement.source

    @property
    def n(self) -> int:
        return self.depth_mm.size

    def has(self, kind: str) -> bool:
        return bool(np.any(self.kind == kind))

    @property
    def baseline_mN(self) -> float:
        """The baseline force at the contact guess (mN; 0 when nothing was subtracted)."""
        return 0.0 if self.baseline is None else float(self.baseline.force_at(self.contact_guess_mm))

    @cached_property
    def spring_constant(self) -> tuple[float | None, str]:
        """The probe's cantilever: its spring constant (N/m = mN/mm, or None) and where it comes from
        (:func:`~skin_indent.measurement.cantilever.spring_constant`: the file's, else estimated from the ramps)."""
        raw = self.force_mN if self.baseline is None else self.force_mN + self.baseline.force_at(self.depth_mm)
        return spring_constant(self.measurement, self.time_s, self.depth_mm, raw, self.kind)

    @cached_property
    def deflection_mm(self) -> np.ndarray | None:
        """The cantilever's deflection from its baseline, force / k (mm, positive as the tip is pushed back), at
        every point: the base (piezo) sits at ``depth_mm + deflection_mm`` from where it was at the baseline.
        None where no cantilever shows (:attr:`spring_constant`)."""
        k = self.spring_constant[0]
        return None if k is None else np.asarray(self.force_mN, dtype=float) / k

    @property
    def max_indentation_mm(self) -> float:
        """Deepest depth past the contact guess (mm)."""
        return float(np.max(self.depth_mm) - self.contact_guess_mm)

    @property
    def data(self) -> Measurement:
        """The points as a :class:`Measurement` (depth, force, time; the radius)."""
        return Measurement(self.depth_mm, self.force_mN, self.time_s, self.source,
                           {"prepared": {"rows": self.rows, "binned": self.binned}}, self.radius_mm)

    def loading(self) -> tuple[np.ndarray, np.ndarray]:
        """Indentation (mm, past the contact guess) and force (mN) of the approach points in contact."""
        sel = (self.kind == "approach") & (self.depth_mm > self.contact_guess_mm)
        return self.depth_mm[sel] - self.contact_guess_mm, self.force_mN[sel]

    def noise_mN(self) -> tuple[float, str]:
        """Noise level independent of any model (mN) and where it comes from.

        The scatter of the pre-contact baseline when there is one (averaged bins: divided
        by sqrt(binned)), else the high-frequency part of the data (local cubic prediction
        along time, :func:`skin_indent.inverse.estimate_noise`).
        """
        b = self.baseline_fitted
        if b is not None and b.noise_mN > 0 and b.n_points >= 10:
            return float(b.noise_mN) / math.sqrt(self.binned), f"pre-contact baseline ({b.n_points} points)"
        return self.high_frequency_noise_mN(), "high-frequency part of the data (local cubic prediction)"

    def high_frequency_noise_mN(self) -> float:
        """Noise (mN) from the data: local cubic prediction along time (or point) order.

        Raises
        ------
        MeasurementError
            One line naming the cause when the data cannot give it: fewer points than the local
            cubic needs (:func:`~skin_indent.inverse.noise.noise_min_points`, 7), or a noise-free
            curve; both say to give the noise level.
        """
        if self.n < noise_min_points():
            raise MeasurementError(
                f"{self.source}: {self.n} points are too few to estimate the noise from the data (the local cubic "
                f"prediction needs at least {noise_min_points()}): give the noise level (--noise, noise_mN=...)")
        t = self.time_s
        x = t if t is not None and np.all(np.diff(t) > 0) else np.arange(self.n, dtype=float)
        sigma = estimate_noise(x, self.force_mN)
        if not sigma > 0:
            raise ValueError("cannot estimate the noise from a noise-free curve: give the noise level (--noise)")
        return float(sigma)


def prepare(measurement: Measurement, *, segments=("approach",), window: tuple[float, float] | None = None,
            contact: str = "auto", contact_mm: float | None = None, radius_mm: float | None = None,
            max_points: int | None = None) -> PreparedCurve:
    """Prepare a recorded curve for a model (see the module docstring).

    Parameters
    ----------
    measurement : Measurement
        The whole curve (any scale: only ratios of its own numbers set tolerances).
    segments : sequence of str
        Kinds of motion to keep. ``("approach",)`` (a fit of the loading curve) keeps
        the strictly increasing approach; otherwise the history is kept whole up to the
        last kept point (only trailing segments can be left out).
    window : (float, float), optional
        Indentation depths (mm) past the contact point, ``MIN:MAX`` (approach only).
        With a fitted contact point and ``MIN = 0``, pre-contact points down to one
        indentation extent before the contact are kept (they anchor the contact point).
    contact : {"auto", "fit", "origin"}
        ``"auto"``: fitted if the curve has a pre-contact baseline, else at recorded
        depth 0 (skin curves start in contact, force tared).
    contact_mm : float, optional
        A fixed contact point (recorded depth, mm).
    radius_mm : float, optional
        Sphere radius (mm); default the measurement's, else :data:`SKIN_RADIUS_MM`.
    max_points : int, optional
        Average longer curves in bins within segments down to at most this many points.

    Returns
    -------
    PreparedCurve

    Raises
    ------
    MeasurementError
        Bad input or a scale that does not fit (one line naming the likely cause).
    """
    if contact not in CONTACT_MODES:
        raise ValueError(f"contact must be one of {', '.join(CONTACT_MODES)}, got {contact!r}")
    segments = tuple(segments)
    bad = set(segments) - set(SEGMENTS)
    if bad or not segments:
        raise ValueError(f"segments must be among {', '.join(SEGMENTS)}, got {', '.join(segments) or 'none'}")
    m = measurement
    radius, radius_source = _radius(m, radius_mm)
    found = find_segments(m)
    loading_only = segments == ("approach",)
    approach = m.loading().require_monotone_loading() if m.has_time else m
    if loading_only:
        approach = approach.require_monotone_loading()
    elif window is not None:
        raise ValueError("a depth window applies to the loading curve only (segments=('approach',))")
    cp = None
    if contact != "origin" or contact_mm is not None:
        try:
            cp = find_contact_point(approach)
        except MeasurementError:
            if contact == "fit":
                raise
    if contact_mm is not None:
        mode, c0 = "fixed", float(contact_mm)
    elif contact == "fit" or (contact == "auto" and cp is not None and cp.has_baseline):
        mode, c0 = "fit", float(cp.depth_mm)
    else:
        mode, c0 = "origin", 0.0
    baseline = fitted = None
    if mode != "origin" and cp is not None and cp.has_baseline:
        fitted = cp.baseline
        baseline = fitted if fitted.tilt_significant else fitted.flat()
    if loading_only:
        depth, force, time, kinds, rows = _loading_points(approach, baseline, mode, c0, window, m.source)
    else:
        depth, force, time, kinds, rows = _history_points(m, found, segments, baseline)
    if mode != "origin" and not np.any(depth > c0):
        raise MeasurementError(f"{m.source}: no loading point beyond the contact point {c0:.6g} mm")
    notes = _check_scale(m, depth, force, c0, radius, radius_source)
    k = 1
    if max_points is not None and depth.size > max_points:
        depth, force, time, kinds, k = _binned(depth, force, time, kinds, max_points)
    return PreparedCurve(m, found, depth, force, time, kinds, radius, radius_source, mode, c0, cp, baseline, fitted,
                         k, rows, tuple(notes))


def _radius(m: Measurement, radius_mm) -> tuple[float, str]:
    if radius_mm is not None:
        r, source = radius_mm, "given"
    elif m.radius_mm is not None:
        r, source = m.radius_mm, "measurement"
    else:
        r, source = SKIN_RADIUS_MM, "default"
    try:
        r = float(r)
    except (TypeError, ValueError):
        raise MeasurementError(f"sphere radius must be a number of mm, got {r!r}") from None
    if not (math.isfinite(r) and r > 0):
        raise MeasurementError(f"sphere radius must be a positive number of mm, got {r:g}")
    return r, source


def _loading_points(approach: Measurement, baseline, mode, c0, window, source):
    if baseline is not None:
        approach = approach.with_baseline_removed(baseline)
    lo = 0.0 if window is None else window[0]
    hi = np.inf if window is None else window[1]
    d = approach.depth_mm
    if mode == "origin":  # depths <= 0 (the contact row h = 0, F = 0) say nothing about the material
        data = approach.window(max(lo, np.nextafter(0.0, 1.0)), hi)
    else:
        if not np.any(d > c0):
            raise MeasurementError(f"{source}: no loading point beyond the contact point {c0:.6g} mm")
        extent = float(min(d.max(), c0 + hi) - c0)
        data = approach.window(c0 + lo if lo > 0 else c0 - extent, c0 + hi)
        if np.sum(data.depth_mm > c0) < 3:
            raise MeasurementError(f"{source}: fewer than 3 points in contact inside the window")
    rows = tuple(data.columns.get("loading", {}).get("rows", (0, data.n_points)))
    kinds = np.full(data.n_points, "approach", dtype=object).astype(str)
    return data.depth_mm, data.force_mN, data.time_s, kinds, rows


def _history_points(m: Measurement, found, segments, baseline):
    kinds = np.empty(m.n_points, dtype=object)
    if m.has_time:
        for seg in found:
            kinds[seg.start:seg.stop] = seg.kind
    else:
        kinds[:] = "approach"
    keep = np.isin(kinds.astype(str), list(segments))
    if not np.any(keep):
        raise ValueError(f"{m.source}: no {' or '.join(segments)} segment in this curve")
    last = int(np.flatnonzero(keep)[-1]) + 1
    dropped = sorted(set(kinds[:last].astype(str)) - set(segments))
    if dropped:
        raise ValueError(f"leaving out {', '.join(dropped)} would cut the history before a kept segment: "
                         "only trailing segments can be left out")
    depth = np.array(m.depth_mm[:last])
    force = np.array(m.force_mN[:last])
    if baseline is not None:
        force = force - baseline.force_at(depth)
    time = None if m.time_s is None else np.array(m.time_s[:last])
    return depth, force, time, kinds[:last].astype(str), (0, last)


def _binned(depth, force, time, kinds, max_points):
    """Average in bins within segments (a bin never straddles a turn)."""
    n = depth.size
    k = max(1, math.ceil(n / max_points))
    rows, start = [], 0
    for i in range(1, n + 1):
        if i == n or kinds[i] != kinds[start] or i - start == k:
            rows.append((start, i))
            start = i
    depth = np.array([depth[a:b].mean() for a, b in rows])
    force = np.array([force[a:b].mean() for a, b in rows])
    time = None if time is None else np.array([time[a:b].mean() for a, b in rows])
    kinds = np.array([kinds[a] for a, _ in rows]).astype(str)
    return depth, force, time, kinds, k


def _check_scale(m: Measurement, depth, force, c0, radius, radius_source) -> list[str]:
    """One-line errors for scales that cannot be right, notes for doubtful ones."""
    h = float(np.max(depth) - c0)
    ratio = h / radius
    peak = float(np.max(np.abs(force)))
    unit = m.columns.get("depth_mm", {}).get("column", "depth_mm")
    where = "the default skin sphere" if radius_source == "default" else "this sphere"
    if radius_source == "default" and peak < 1e-3 and h < 0.05:
        raise MeasurementError(
            f"{m.source}: forces of {peak:.3g} mN (nN to uN) and {1e3 * h:.3g} um of indentation with the skin "
            f"default radius {SKIN_RADIUS_MM:g} mm: give the sphere radius in mm (--radius, e.g. 0.0275 for 27.5 um)")
    if ratio > MAX_DEPTH_RATIO:  # the contact radius a = sqrt(R h) would exceed the sphere's
        hint = f"is depth in um (column {unit!r})?" if ratio / 1e3 <= MAX_DEPTH_RATIO else "is the depth in mm?"
        wrong = "is the radius a value in mm labelled um (R 1000 x too small)?" if ratio / 1e3 <= 0.5 else \
            "is the radius wrong?"
        raise MeasurementError(f"{m.source}: h/R = {ratio:.3g} (indentation {h:.4g} mm, sphere R = {radius:g} mm, "
                               f"{where}): deeper than the sphere's radius; {hint} or {wrong}")
    notes = []
    if radius_source == "default":
        notes.append(UnitText("sphere radius not given: the skin default R = {R:g} is used",
                              R=Quantity(SKIN_RADIUS_MM, "mm")))
    return notes
