"""The pre-contact baseline and a first guess of the contact point.

:func:`estimate_baseline` fits the pre-contact force line (:class:`Baseline`:
offset, tilt, noise); :func:`find_contact_point` returns the contact depth with
diagnostics (:class:`ContactPoint`) and :func:`estimate_contact_point` just the
depth. Both only report: the curve is changed only by an explicit
:meth:`Measurement.with_baseline_removed` or :meth:`Measurement.with_contact_at`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._errors import MeasurementError
from .core import Measurement

__all__ = [
    "Baseline",
    "ContactPoint",
    "estimate_baseline",
    "estimate_contact_point",
    "find_contact_point",
]

# Contact point: the Hertz-shaped fit F = b0 + a (d - d0)^1.5 uses the loading
# curve up to where the force has risen by this fraction of its total rise.
_HERTZ_EXPONENT = 1.5
# ... with a stiffening term c (d - d0)^2 (c >= 0) where the curve's shape beyond
# contact is not known: the first finite-thickness correction of Hertz for a layer
# bonded to a stiffer base (Dimitriadis et al., Biophys. J. 82 (2002) 2798) and the
# leading effect of strain stiffening. Without it, a curve that stiffens with depth
# (a 2 mm layer on a rigid base: 4.6x the half-space force at 0.6 mm) is fitted by
# moving d0 deep into the contact, and its first 0.07 mm in contact become a tilted
# "pre-contact baseline".
_STIFFENING_EXPONENT = 2.0
_CONTACT_FIT_FORCE_FRACTION = 0.3
_MIN_BASELINE_POINTS = 10  # approach samples before contact for a usable baseline
_CONTACT_THRESHOLD_SIGMA = 8.0  # "deviation from baseline", in noise std


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
    slope_std_mN_per_mm : float
        Standard error of the tilt (mN/mm): noise / sqrt(sum (d - mean d)^2).
    """

    offset_mN: float
    slope_mN_per_mm: float
    noise_mN: float
    n_points: int
    depth_range_mm: tuple[float, float] = (float("nan"), float("nan"))
    slope_std_mN_per_mm: float = float("nan")

    @property
    def tilt_significant(self) -> bool:
        """True if the tilt exceeds 3 standard errors (else the line is flat within noise)."""
        return bool(abs(self.slope_mN_per_mm) > 3.0 * self.slope_std_mN_per_mm)

    def flat(self) -> "Baseline":
        """The constant baseline (tilt 0) through the line's value at the middle of the fitted depths."""
        mid = 0.5 * (self.depth_range_mm[0] + self.depth_range_mm[1])
        return Baseline(float(self.force_at(mid)), 0.0, self.noise_mN, self.n_points, self.depth_range_mm, 0.0)

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
    spread = float(np.sqrt(np.sum((depth - depth.mean()) ** 2)))
    slope_std = noise / spread if spread > 0 else float("inf")
    return Baseline(offset, slope, noise, int(depth.size), (float(depth[0]), float(depth[-1])), slope_std)


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


def _hertz_sse(depth, force, d0, free_offset, stiffening: bool = False) -> float:
    """SSE of the least-squares ``force = b0 + a*max(depth - d0, 0)^1.5``, a >= 0
    (``+ c*max(depth - d0, 0)^2``, c >= 0, with ``stiffening``).

    ``b0`` is fitted if `free_offset`, else fixed at 0.
    """
    s = np.clip(depth - d0, 0.0, None)
    x = s**_HERTZ_EXPONENT
    if free_offset:
        force = force - force.mean()
    columns = [x - x.mean() if free_offset else x]
    if stiffening:
        z = s**_STIFFENING_EXPONENT
        columns.append(z - z.mean() if free_offset else z)
    sse = float(force @ force)
    best = sse
    for col in columns:  # one term alone (a >= 0 or c >= 0)
        sxx, sxy = float(col @ col), float(col @ force)
        if sxx > 0 and sxy > 0:
            best = min(best, sse - sxy * sxy / sxx)
    if len(columns) == 2:  # both terms, where both coefficients come out >= 0
        X = np.stack(columns)
        G, r = X @ X.T, X @ force
        det = G[0, 0] * G[1, 1] - G[0, 1] ** 2
        if det > 1e-12 * G[0, 0] * G[1, 1]:
            coef = np.array([G[1, 1] * r[0] - G[0, 1] * r[1], G[0, 0] * r[1] - G[0, 1] * r[0]]) / det
            if np.all(coef >= 0):
                best = min(best, sse - float(coef @ r))
    return best


_INV_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _golden_section(f, a: float, b: float, xatol: float) -> tuple[float, float]:
    """``(x, f(x))`` at the minimum of a unimodal ``f`` on [a, b], to ``xatol``.

    Golden-section search: ~20 evaluations for the two grid steps that
    :func:`_fit_contact` refines to 1e-6 of its range. numpy only, so that
    reading and preparing a curve does not import scipy.optimize (0.3 s).
    """
    c, d = b - _INV_GOLDEN * (b - a), a + _INV_GOLDEN * (b - a)
    fc, fd = f(c), f(d)
    while b - a > xatol:
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - _INV_GOLDEN * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + _INV_GOLDEN * (b - a)
            fd = f(d)
    return (c, fc) if fc <= fd else (d, fd)


def _fit_contact(depth, force, lo, hi, free_offset, stiffening: bool = False) -> float:
    """Contact depth in [lo, hi] that minimises the Hertz-shaped SSE (grid, then golden section)."""
    if not hi > lo:
        return float(lo)
    grid = np.linspace(lo, hi, 201)
    sse = [_hertz_sse(depth, force, d0, free_offset, stiffening) for d0 in grid]
    k = int(np.argmin(sse))
    x, fx = _golden_section(lambda d0: _hertz_sse(depth, force, d0, free_offset, stiffening),
                            float(grid[max(k - 1, 0)]), float(grid[min(k + 1, grid.size - 1)]), (hi - lo) * 1e-6)
    return float(x) if fx <= sse[k] else float(grid[k])


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
       total rise, fit ``F = b0 + a (d - d0)^1.5 + c (d - d0)^2``: a Hertz-shaped
       contact on a flat baseline, with the first correction of a curve that
       stiffens with depth (a layer on a stiffer base, strain stiffening);
       ``d0`` by a 1-D search no earlier than the first sample, ``b0``,
       ``a >= 0`` and ``c >= 0`` by linear least squares.
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
    d0 = _fit_contact(depth[part], force[part], depth[0], depth[end], free_offset=True, stiffening=True)
    if baseline is None and np.sum(depth < d0) < _MIN_BASELINE_POINTS:
        d0 = _fit_contact(depth[part], force[part], depth[0], depth[end], free_offset=False, stiffening=True)
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
