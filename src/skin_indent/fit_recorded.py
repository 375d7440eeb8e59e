"""Fitting a curve as an instrument recorded it (AFM, nanoindenters).

Real curves have their contact well past depth 0, a force baseline, and
approach/hold/retract segments. :func:`fit_curve` (= :func:`prepare_fit` then
:func:`fit_prepared`) keeps the approach segment, fits the pre-contact baseline
(reported and subtracted explicitly), fits the contact point jointly with the
material (:class:`~skin_indent.identify.ShiftedModel`), holds parameters fixed by
name, and fits Hertz to the same data for comparison (:class:`CurveFit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .analytic import hertz_force
from .identify import (CONTACT_MODES, METHODS, ShiftedModel, check_fixed, check_inside, hertz_modulus,
                       start_values)
from .measurement import Baseline, ContactPoint, Measurement, MeasurementError, find_contact_point, find_segments

class HertzModel:
    """Hertz's sphere F = 4/3 E* sqrt(R) h^1.5 as a force model of E* (kPa), for comparison.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R (mm).
    bounds : (float, float)
        Admissible E* (kPa).
    depth_range : (float, float), optional
        Reported depth range (mm), for :class:`ShiftedModel`.
    """

    parameter_names = ("E_star_kPa",)

    def __init__(self, radius_mm: float, bounds: tuple[float, float], depth_range=(0.0, np.inf)):
        self.radius_mm = float(radius_mm)
        self.bounds = (np.array([bounds[0]], float), np.array([bounds[1]], float))
        self.depth_range = depth_range

    def _shape(self, depth_mm):
        return hertz_force(np.clip(np.asarray(depth_mm, float), 0, None), 1.0, 0.0, self.radius_mm)

    def force(self, depth_mm, theta) -> np.ndarray:
        return float(np.asarray(theta)[0]) * self._shape(depth_mm)

    def jacobian(self, depth_mm, theta) -> np.ndarray:
        return self._shape(depth_mm)[:, None]


@dataclass(frozen=True, eq=False)
class PreparedFit:
    """A real curve made ready for fitting by :func:`prepare_fit` (nothing fitted yet).

    Attributes
    ----------
    measurement : Measurement
        The whole curve, as read.
    segments : list of Segment
        Approach/hold/retract rows of the whole curve.
    data : Measurement
        The points to fit: approach segment, baseline removed (if any), window applied,
        recorded depths (mm) and forces (mN).
    mode : {"fit", "fixed", "origin"}
        Contact point fitted jointly, fixed by the user, or at recorded depth 0.
    contact_guess_mm : float
        First guess (or fixed value) of the contact point, recorded depth (mm); 0 for "origin".
    contact : ContactPoint or None
        The first-guess diagnostics (:func:`find_contact_point`).
    baseline : Baseline or None
        The line subtracted from the force (None: nothing subtracted).
    baseline_fitted : Baseline or None
        The line as fitted (its tilt is dropped from ``baseline`` if not significant).
    max_indentation_mm : float
        Deepest fitted depth past the first-guess contact (mm).
    """

    measurement: Measurement
    segments: list
    data: Measurement
    mode: str
    contact_guess_mm: float
    contact: ContactPoint | None
    baseline: Baseline | None
    baseline_fitted: Baseline | None
    max_indentation_mm: float


def prepare_fit(measurement: Measurement, window: tuple[float, float] | None = None, *, contact: str = "auto",
                fixed: dict | None = None) -> PreparedFit:
    """Approach segment, baseline and contact first guess of a measured curve.

    Parameters
    ----------
    measurement : Measurement
        The whole curve (any scale: only ratios of its own numbers set tolerances).
    window : (float, float), optional
        Indentation depths (mm) past the contact point to fit, ``MIN:MAX``. With a
        fitted contact point, ``MIN = 0`` keeps pre-contact points down to one
        indentation extent before the contact (they anchor the contact point).
    contact : {"auto", "fit", "origin"}
        ``"auto"``: fit the contact point jointly if the curve has a pre-contact
        baseline (:func:`find_contact_point`), else contact is at recorded depth 0
        (skin curves that start in contact, force tared). ``"fit"``/``"origin"`` force
        either. A fixed ``offset_mm`` in ``fixed`` fixes the contact point.
    fixed : dict, optional
        Model names -> values (see :func:`parse_fix`).

    Returns
    -------
    PreparedFit

    Notes
    -----
    The baseline F = offset + tilt d is fitted robustly on the first 40% of the
    approach before the contact guess; the tilt is kept only if it exceeds 3
    standard errors. The line is subtracted from the forces explicitly and
    reported (:class:`CurveFit`), never silently.
    """
    if contact not in CONTACT_MODES:
        raise ValueError(f"contact must be one of {', '.join(CONTACT_MODES)}, got {contact!r}")
    fixed = dict(fixed or {})
    segments = find_segments(measurement)
    if measurement.has_time:
        approach = measurement.loading().require_monotone_loading()
    else:
        approach = measurement.require_monotone_loading()
    cp = None
    if contact != "origin" or "offset_mm" in fixed:
        try:
            cp = find_contact_point(approach)
        except MeasurementError:
            if contact == "fit":
                raise
    if "offset_mm" in fixed:
        mode, c0 = "fixed", float(fixed["offset_mm"])
    elif contact == "fit" or (contact == "auto" and cp is not None and cp.has_baseline):
        mode, c0 = "fit", float(cp.depth_mm)
    else:
        mode, c0 = "origin", 0.0
    baseline = fitted = None
    if mode != "origin" and cp is not None and cp.has_baseline:
        fitted = cp.baseline
        baseline = fitted if fitted.tilt_significant else fitted.flat()
        approach = approach.with_baseline_removed(baseline)
    lo = 0.0 if window is None else window[0]
    hi = np.inf if window is None else window[1]
    d = approach.depth_mm
    if mode == "origin":  # depths <= 0 (the contact row h = 0, F = 0) say nothing about the material
        data = approach.window(max(lo, np.nextafter(0.0, 1.0)), hi)
        return PreparedFit(measurement, segments, data, mode, 0.0, cp, None, None, float(data.depth_mm.max()))
    if not np.any(d > c0):
        raise MeasurementError(f"{measurement.source}: no loading point beyond the contact point {c0:.6g} mm")
    extent = float(min(d.max(), c0 + hi) - c0)
    start = c0 + lo if lo > 0 else c0 - extent
    data = approach.window(start, c0 + hi)
    if np.sum(data.depth_mm > c0) < 3:
        raise MeasurementError(f"{measurement.source}: fewer than 3 points in contact inside the window")
    return PreparedFit(measurement, segments, data, mode, c0, cp, baseline, fitted,
                       float(data.depth_mm.max() - c0))


@dataclass(frozen=True, eq=False)
class CurveFit:
    """A fitted real curve: the identification plus what was done to the data.

    Attributes
    ----------
    result : skin_indent.inverse.IdentificationResult
        The large-strain (response surface) fit; with a fitted contact point its
        parameters include ``offset_mm`` (= the contact point).
    prepared : PreparedFit
        Segments, baseline, contact guess and the fitted points.
    radius_mm : float
        Sphere radius (mm).
    contact_point_mm, contact_point_std_mm : float
        Contact point (recorded depth, mm) and its standard error (None if not fitted).
    e_star_kPa, e_star_std_kPa : float
        E* = E / (1 - nu^2) of the large-strain fit (kPa) and its standard error.
    hertz : dict
        Hertz's small-strain fit of the same points: ``E_star_kPa``, ``E_star_std_kPa``,
        ``contact_point_mm``, ``rms_mN``.
    notes : list of str
    """

    result: object
    prepared: PreparedFit
    radius_mm: float
    contact_point_mm: float
    contact_point_std_mm: float | None
    e_star_kPa: float
    e_star_std_kPa: float
    hertz: dict
    notes: list = field(default_factory=list)

    @property
    def success(self) -> bool:
        return self.result.success

    @property
    def max_depth_ratio(self) -> float:
        """Deepest indentation over the radius, h/R, at the fitted contact point."""
        return float((self.prepared.data.depth_mm.max() - self.contact_point_mm) / self.radius_mm)

    @property
    def fe_vs_hertz_percent(self) -> float:
        """100 (E*_FE / E*_Hertz - 1): what small-strain Hertz misses at this depth."""
        return 100.0 * (self.e_star_kPa / self.hertz["E_star_kPa"] - 1.0)

    def to_dict(self) -> dict:
        """The result's JSON summary plus the data treatment (JSON-safe)."""
        from .inverse.result import _jsonable

        p = self.prepared
        b = p.baseline
        out = self.result.to_dict()
        out.update({
            "radius_mm": self.radius_mm,
            "segments": [{"kind": s.kind, "start": s.start, "stop": s.stop} for s in p.segments],
            "loading_rows": list(p.data.columns.get("loading", {}).get("rows", (0, p.measurement.n_points))),
            "baseline_mN": b.offset_mN if b is not None else 0.0,
            "baseline_tilt_mN_per_mm": b.slope_mN_per_mm if b is not None else 0.0,
            "baseline": None if b is None else {
                "subtracted": True, "offset_mN": b.offset_mN, "tilt_mN_per_mm": b.slope_mN_per_mm,
                "fitted_tilt_mN_per_mm": p.baseline_fitted.slope_mN_per_mm,
                "fitted_tilt_std_mN_per_mm": p.baseline_fitted.slope_std_mN_per_mm,
                "noise_mN": b.noise_mN, "n_points": b.n_points, "depth_range_mm": list(b.depth_range_mm)},
            "contact_mode": p.mode,
            "contact_point_mm": self.contact_point_mm,
            "contact_point_std_mm": self.contact_point_std_mm,
            "contact_point_guess_mm": p.contact_guess_mm,
            "max_depth_ratio": self.max_depth_ratio,
            "E_star_kPa": self.e_star_kPa,
            "E_star_std_kPa": self.e_star_std_kPa,
            "hertz": dict(self.hertz),
            "fe_vs_hertz_percent": self.fe_vs_hertz_percent,
            "notes": list(self.notes),
        })
        return _jsonable(out)

    def report(self) -> str:
        """Readable summary: segments, baseline, contact point, fit, Hertz comparison."""
        p = self.prepared
        seg = ", ".join(f"{s.kind} rows {s.start}-{s.stop}" for s in p.segments)
        lines = [f"segments: {seg}; fitting the approach"]
        b = p.baseline
        if b is None:
            why = "contact at recorded depth 0" if p.mode == "origin" else "no pre-contact part"
            lines.append(f"baseline: none subtracted ({why}; the force is taken as tared)")
        else:
            tilt = (f"tilt {b.slope_mN_per_mm:.4g} mN/mm" if b.slope_mN_per_mm else
                    f"tilt 0 (fitted {p.baseline_fitted.slope_mN_per_mm:.3g} +/- "
                    f"{p.baseline_fitted.slope_std_mN_per_mm:.2g} mN/mm, not significant)")
            lines.append(f"baseline: subtracted F = offset + tilt * depth: offset {b.offset_mN:.4g} mN, {tilt} "
                         f"(robust fit of {b.n_points} pre-contact points, noise {b.noise_mN:.3g} mN)")
        if p.mode == "fit":
            lines.append(f"contact point: {self.contact_point_mm:.6g} +/- {self.contact_point_std_mm:.2g} mm "
                         f"(fitted jointly; first guess {p.contact_guess_mm:.6g} mm from the deviation from "
                         "the baseline)")
        elif p.mode == "fixed":
            lines.append(f"contact point: {self.contact_point_mm:.6g} mm (fixed)")
        else:
            lines.append("contact point: recorded depth 0 (the curve starts in contact)")
        lines.append(self.result.report())
        h = self.hertz
        lines.append(f"E* = E/(1-nu^2): large-strain FE {self.e_star_kPa:.5g} +/- {self.e_star_std_kPa:.2g} kPa, "
                     f"Hertz (small strain, same points) {h['E_star_kPa']:.5g} +/- {h['E_star_std_kPa']:.2g} kPa: "
                     f"FE differs from Hertz by {self.fe_vs_hertz_percent:+.1f}% at h/R up to "
                     f"{self.max_depth_ratio:.3g}")
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)

    __str__ = report


class _ForceScaled:
    """A force model divided by a constant force unit ``scale_mN`` (same parameters)."""

    def __init__(self, model, scale_mN: float):
        self.model, self.scale = model, float(scale_mN)
        self.parameter_names = tuple(model.parameter_names)
        self.bounds = model.bounds
        self.depth_range = getattr(model, "depth_range", (0.0, np.inf))

    def force(self, depth_mm, theta):
        return np.asarray(self.model.force(depth_mm, theta)) / self.scale

    def jacobian(self, depth_mm, theta):
        return np.asarray(self.model.jacobian(depth_mm, theta)) / self.scale


def fit_in_force_units(model, depth, force, x0, method, *, fixed=None, tol=None, noise_mN=None):
    """Run an inversion method with the forces in units of a tenth of the peak force.

    The inversion methods carry absolute tolerances and defaults set for skin
    (forces ~ 10 mN: scipy's ``gtol`` on the gradient of the cost, the paper's
    0.05 mN measurement noise). An AFM curve (~1e-5 mN) would stop at its start.
    Fitting ``F / s`` with ``s = max|F| / 10`` gives every curve skin-like numbers;
    the parameters do not depend on the force unit, and the result (residuals,
    noise, covariance) is rebuilt in mN at the solution.
    """
    from . import inverse
    from .inverse._problem import make_problem
    from .inverse.result import build_result

    scale = float(np.max(np.abs(force))) / 10.0
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError("cannot fit: the force is zero everywhere")
    scaled = _ForceScaled(model, scale)
    Fs = np.asarray(force, float) / scale
    noise_s = None if noise_mN is None else noise_mN / scale
    kwargs = {"fixed": fixed}
    if method == "lsq":
        r = inverse.fit_least_squares(scaled, depth, Fs, x0, noise_mN=noise_s, **kwargs)
    else:
        if tol is not None:
            kwargs["tol"] = tol
        if method == "ekf":
            r = inverse.fit_ekf(scaled, depth, Fs, x0, noise_mN=noise_s, **kwargs)
        else:
            r = inverse.fit_ekf_paper(scaled, depth, Fs, x0, **kwargs)
    theta = np.array([r.parameters[n] for n in model.parameter_names])
    problem = make_problem(model, depth, force, theta, fixed)
    x = np.array([r.parameters[n] for n in problem.free_names])
    filt = r.covariance_source == "filter"
    info = {k: v for k, v in r.info.items() if k not in ("covariance_jacobian", "residual_sigma_mN")}
    info["force_unit_mN"] = scale
    return build_result(problem, x, method=r.method, iterations=r.iterations, status=r.status, message=r.message,
                        noise_mN=r.noise_mN * scale, covariance=r.covariance if filt else None,
                        covariance_source=r.covariance_source, history=r.history, info=info)


def _e_star(result) -> tuple[float, float]:
    """E / (1 - nu^2) and its delta-method standard error from the free-parameter covariance."""
    E, nu = result.parameters["E_kPa"], result.parameters["nu"]
    grad = {"E_kPa": 1 / (1 - nu**2), "nu": 2 * E * nu / (1 - nu**2) ** 2}
    g = np.array([grad.get(n, 0.0) for n in result.free_names])
    var = float(g @ np.asarray(result.covariance) @ g)
    return E / (1 - nu**2), math.sqrt(var) if var >= 0 else math.nan


def fit_prepared(prepared: PreparedFit, surface, method: str = "lsq", *, radius_mm: float | None = None,
                 fixed: dict | None = None, x0=None, tol: float | None = None,
                 noise_mN: float | None = None) -> CurveFit:
    """Fit a :class:`PreparedFit` with a response surface (and Hertz, for comparison).

    Parameters
    ----------
    prepared : PreparedFit
        From :func:`prepare_fit`.
    surface : ResponseSurface
        A neo-Hookean surface; rescaled to ``radius_mm`` by similarity if it was
        built for another radius.
    method : {"ekf-paper", "ekf", "lsq"}
    radius_mm : float, optional
        Sphere radius (mm); default the measurement's, else the surface's.
    fixed : dict, optional
        Model names -> values (:func:`parse_fix`), e.g. ``{"nu": 0.499}``.
    x0 : array_like, optional
        Start (E_kPa, nu); default a Hertz estimate.
    tol, noise_mN : float, optional
        As in :func:`identify`.

    Returns
    -------
    CurveFit
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    fixed = dict(fixed or {})
    radius = radius_mm or prepared.measurement.radius_mm or float(surface.settings.get("radius_mm", 6.22))
    r_surface = surface.settings.get("radius_mm")
    if r_surface is not None and abs(r_surface / radius - 1) > 1e-9:
        surface = surface.at_radius(radius)
    check_fixed(fixed, surface)
    data, c0, mode = prepared.data, prepared.contact_guess_mm, prepared.mode
    d, F = data.depth_mm, data.force_mN
    h = d - c0
    touching = h > 0
    hmax = surface.depth_range[1]
    check_inside(surface, h[touching])
    e_star0 = hertz_modulus(h[touching], F[touching], radius)
    lo, hi = surface.bounds
    nu0 = fixed.get("nu", 0.4)
    if not (np.isfinite(e_star0) and lo[0] / 3 <= e_star0 * (1 - nu0**2) <= 3 * hi[0]):
        raise ValueError(f"the data need E ~ {e_star0 * (1 - nu0**2):.3g} kPa (Hertz estimate), far outside the "
                         f"surface's {lo[0]:g}-{hi[0]:g} kPa: build a surface that covers it (surface build --E)")
    if x0 is None:
        x0 = start_values(surface, h[touching], F[touching], radius, nu=nu0)
    x0 = np.asarray(x0, dtype=float)
    extent = float(h.max())
    notes = []
    if mode == "fit":
        off_lo = max(c0 - extent, float(d.max()) - hmax * (1 - 1e-9))
        off_hi = c0 + 0.5 * extent
        model = ShiftedModel(surface, (off_lo, off_hi))
        hertz_base = HertzModel(radius, (e_star0 * 1e-3, e_star0 * 1e3), surface.depth_range)
        hertz_model = ShiftedModel(hertz_base, (off_lo, off_hi))
        x0 = np.r_[x0[:2], c0]
        hertz_x0 = np.array([e_star0, c0])
        depth = d
        if off_lo > c0 - 0.5 * extent:
            notes.append(f"the contact point may move at most {1e3 * (c0 - off_lo):.3g} um before its first guess "
                         f"(the surface reaches h = {hmax:.4g} mm); a deeper surface would widen this")
    else:
        model = surface
        hertz_model = HertzModel(radius, (e_star0 * 1e-3, e_star0 * 1e3))
        depth, F = h[touching], F[touching]
        hertz_x0 = np.array([e_star0])
        fixed.pop("offset_mm", None)
    result = fit_in_force_units(model, depth, F, x0, method, fixed=fixed, tol=tol, noise_mN=noise_mN)
    hz = fit_in_force_units(hertz_model, depth, F, hertz_x0, "lsq")
    if mode == "fit":
        contact, contact_sd = result.parameters["offset_mm"], result.std.get("offset_mm")
    else:
        contact, contact_sd = c0, None
    e_star, e_star_sd = _e_star(result)
    hertz = {"E_star_kPa": hz.parameters["E_star_kPa"], "E_star_std_kPa": hz.std["E_star_kPa"],
             "contact_point_mm": hz.parameters.get("offset_mm", c0), "rms_mN": hz.rms_mN}
    if "nu" in fixed:
        notes.append(f"nu fixed at {fixed['nu']:g}; E = {result.parameters['E_kPa']:.5g} kPa")
    return CurveFit(result, prepared, float(radius), float(contact),
                    None if contact_sd is None else float(contact_sd), e_star, e_star_sd, hertz, notes)


def fit_curve(measurement: Measurement, surface, method: str = "lsq", *, window=None, contact: str = "auto",
              fixed: dict | None = None, radius_mm: float | None = None, x0=None, tol: float | None = None,
              noise_mN: float | None = None) -> CurveFit:
    """Fit a measured curve as it comes from an instrument: :func:`prepare_fit` + :func:`fit_prepared`.

    Parameters
    ----------
    measurement : Measurement
        The whole curve (approach, hold, retract; any baseline; contact anywhere).
    surface : ResponseSurface
        The neo-Hookean response surface (any radius: rescaled by similarity).
    method, window, contact, fixed, radius_mm, x0, tol, noise_mN
        See :func:`prepare_fit` and :func:`fit_prepared`.

    Returns
    -------
    CurveFit

    Examples
    --------
    >>> fit = fit_curve(load_csv("afm.csv"), surface, fixed={"nu": 0.499}, radius_mm=0.0275)  # doctest: +SKIP
    >>> fit.contact_point_mm, fit.e_star_kPa, fit.hertz["E_star_kPa"]  # doctest: +SKIP
    """
    prepared = prepare_fit(measurement, window, contact=contact, fixed=fixed)
    return fit_prepared(prepared, surface, method, radius_mm=radius_mm, fixed=fixed, x0=x0, tol=tol,
                        noise_mN=noise_mN)
