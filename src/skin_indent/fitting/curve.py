"""The result of a fit of one recorded curve, :class:`CurveFit`, and the paper's identification.

:func:`fit_half_space` is the paper's identification, an option of :func:`~skin_indent.fitting.fit`
(:mod:`.one_fit`): it prepares the curve (:func:`skin_indent.measurement.prepare`: approach
segment, baseline, contact-point guess, window, radius, scale checks), fits the
neo-Hookean half-space on a response surface with the contact point as a parameter
where the curve starts before contact, fits Hertz to the same points for comparison,
and judges the fit against the noise (:func:`quality`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..inverse import IdentificationResult
from .error_model import curve_noise, described
from .result import FitResult, scored
from ..runtime.provenance import surface_identity
from .identification import check_fixed, check_modulus_range, hertz_modulus, run_method, start_values
from .surfaces import SIMILARITY_RATIOS, check_inside, surface_for
from ..effects import CONTACT_POINT
from ..inverse.residuals import analyse_residuals
from ..measurement import PreparedCurve, prepare
from ..measurement.scale import Quantity, UnitText, display_units, shown_in
from .scale_checks import MISFIT_FLAG, check_points, scale_flags  # noqa: F401 - MISFIT_FLAG read here
from .ended import how_it_ended, verdict as ended_verdict
from ..models import ComposedModel, HertzModel
from ..runtime.json_io import jsonable

#: a misfit above this many times the independent noise: the model does not describe the curve
MISFIT_LIMIT = 3.0
#: a misfit below this fraction of the independent noise: the residual's pattern is not judged
MISFIT_FLOOR = 0.5


@dataclass(frozen=True, eq=False)
class CurveFit(FitResult):
    """A fitted recorded curve: the identification (all of :class:`IdentificationResult`) plus
    what was done to the data, Hertz's fit of the same points, and the fit's quality.

    Attributes
    ----------
    prepared : PreparedCurve
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
    quality : dict
        ``noise_mN`` independent of the model and its ``noise_source``, ``misfit``
        (RMS / noise), ``white`` (residual whiteness as in diagnosis), ``verdict``.
    surface : dict or list of dict
        Identity of the response surface used (``hash``, ``settings``); of a chosen model's fit
        (``model=...``), a list: every elastic force model its fits used (the model's and those of
        the rungs below it, which give its starts; :func:`~skin_indent.runtime.provenance.surface_identity`).

    The model, the curve's summary (``curves``, one), flags, notes, priors, error model, provenance and
    correlations are those of every fit (:class:`~skin_indent.fitting.result.FitResult`).
    """

    prepared: object = None
    radius_mm: float = math.nan
    contact_point_mm: float = 0.0
    contact_point_std_mm: float | None = None
    e_star_kPa: float = math.nan
    e_star_std_kPa: float = math.nan
    hertz: dict = field(default_factory=dict)
    quality: dict = field(default_factory=dict)
    surface: dict | list = field(default_factory=dict)

    @property
    def max_depth_ratio(self) -> float:
        """Deepest indentation over the radius, h/R, at the fitted contact point."""
        return float((self.prepared.depth_mm.max() - self.contact_point_mm) / self.radius_mm)

    @property
    def fe_vs_hertz_percent(self) -> float:
        """100 (E*_FE / E*_Hertz - 1): what small-strain Hertz misses at this depth."""
        return 100.0 * (self.e_star_kPa / self.hertz["E_star_kPa"] - 1.0)

    def to_dict(self) -> dict:
        """The identification's JSON summary plus the data treatment and quality (JSON-safe)."""
        p = self.prepared
        b = p.baseline
        out = super().to_dict()
        out.update({
            "radius_mm": self.radius_mm,
            "radius_source": p.radius_source,
            "segments": [{"kind": s.kind, "start": s.start, "stop": s.stop} for s in p.segments],
            "loading_rows": list(p.rows),
            "depth_mm": p.depth_mm,
            "baseline_mN": b.offset_mN if b is not None else 0.0,
            "baseline_tilt_mN_per_mm": b.slope_mN_per_mm if b is not None else 0.0,
            "baseline": None if b is None else {
                "subtracted": True, "offset_mN": b.offset_mN, "tilt_mN_per_mm": b.slope_mN_per_mm,
                "fitted_tilt_mN_per_mm": p.baseline_fitted.slope_mN_per_mm,
                "fitted_tilt_std_mN_per_mm": p.baseline_fitted.slope_std_mN_per_mm,
                "noise_mN": b.noise_mN, "n_points": b.n_points, "depth_range_mm": list(b.depth_range_mm)},
            "contact_mode": p.contact_mode,
            "contact_point_mm": self.contact_point_mm,
            "contact_point_std_mm": self.contact_point_std_mm,
            "contact_point_guess_mm": p.contact_guess_mm,
            "max_depth_ratio": self.max_depth_ratio,
            "E_star_kPa": self.e_star_kPa,
            "E_star_std_kPa": self.e_star_std_kPa,
            "hertz": dict(self.hertz),
            "fe_vs_hertz_percent": self.fe_vs_hertz_percent,
            "quality": dict(self.quality),
            "surface": self.surface,
        })
        return jsonable(out)

    def report(self, digits: int = 5, units=None) -> str:
        """Readable summary: segments, baseline, contact point, fit, Hertz comparison, quality.

        Lengths, forces and moduli are shown in ``units``
        (:class:`~skin_indent.measurement.scale.DisplayUnits`), default the units of the curve's
        scale (:func:`~skin_indent.measurement.scale.display_units`: um, nN and Pa for an AFM-scale
        sphere, mm, mN and kPa for skin), notes and flags too (:func:`~skin_indent.measurement.scale.shown_in`);
        :meth:`to_dict` keeps the package units.
        """
        u = units or display_units(self.radius_mm)
        L, F, M = u.length, u.force, u.modulus
        kL, kF, kM = u.per_mm, u.per_mN, u.per_kPa
        p = self.prepared
        seg = ", ".join(f"{s.kind} rows {s.start}-{s.stop}" for s in p.segments)
        kinds = [k for k in ("approach", "hold", "retract") if np.any(p.kind == k)]
        lines = [f"model: {self.model}", f"segments: {seg}; fitting the {' and '.join(kinds) or 'approach'}"
                 + (f" ({p.n} points, bins of {p.binned})" if p.binned > 1 else "")]
        b = p.baseline
        if b is None:
            why = "contact at recorded depth 0" if p.contact_mode == "origin" else "no pre-contact part"
            lines.append(f"baseline: none subtracted ({why}; the force is taken as tared)")
        else:
            kT = kF / kL
            tilt = (f"tilt {b.slope_mN_per_mm * kT:.4g} {F}/{L}" if b.slope_mN_per_mm else
                    f"tilt 0 (fitted {p.baseline_fitted.slope_mN_per_mm * kT:.3g} +/- "
                    f"{p.baseline_fitted.slope_std_mN_per_mm * kT:.2g} {F}/{L}, not significant)")
            lines.append(f"baseline: subtracted F = offset + tilt * depth: offset {b.offset_mN * kF:.4g} {F}, {tilt} "
                         f"(robust fit of {b.n_points} pre-contact points, noise {b.noise_mN * kF:.3g} {F})")
        if p.contact_mode == "fit" and self.contact_point_std_mm is None:  # a chosen model's, held (--fix offset_mm)
            lines.append(f"contact point: {self.contact_point_mm * kL:.6g} {L} (held)")
        elif p.contact_mode == "fit":
            lines.append(f"contact point: {self.contact_point_mm * kL:.6g} +/- {self.contact_point_std_mm * kL:.2g} {L} "
                         f"(fitted jointly; first guess {p.contact_guess_mm * kL:.6g} {L} from the deviation from "
                         "the baseline)")
        elif p.contact_mode == "fixed":
            lines.append(f"contact point: {self.contact_point_mm * kL:.6g} {L} (fixed)")
        else:
            lines.append("contact point: recorded depth 0 (the curve starts in contact)")
        lines.append(super().report(digits, units=u))
        h = self.hertz
        if self.model == "neo-hooke":
            lines.append(f"E* = E/(1-nu^2): large-strain FE {self.e_star_kPa * kM:.5g} +/- "
                         f"{self.e_star_std_kPa * kM:.2g} {M}, Hertz (small strain, same points) "
                         f"{h['E_star_kPa'] * kM:.5g} +/- {h['E_star_std_kPa'] * kM:.2g} {M}: "
                         f"FE differs from Hertz by {self.fe_vs_hertz_percent:+.1f}% at h/R up to "
                         f"{self.max_depth_ratio:.3g}")
        else:
            lines.append(f"E* = E/(1-nu^2) of the top material {self.e_star_kPa * kM:.5g} +/- "
                         f"{self.e_star_std_kPa * kM:.2g} {M}; Hertz's homogeneous small-strain fit of the loading "
                         f"points {h['E_star_kPa'] * kM:.5g} +/- {h['E_star_std_kPa'] * kM:.2g} {M}")
        if self.error_model and self.error_model["model_error"]:
            lines.append(f"error model: chi-square and BIC weigh each point by sqrt(noise^2 + "
                         f"({self.error_model['model_error']:g} F)^2), the noise and the forward model's relative "
                         "error (the fit itself is unweighted least squares)")
        elif self.error_model:
            lines.append("error model: chi-square and BIC weigh each point by the noise alone (the paper's "
                         "identification: no model error)")
        q = self.quality
        if q:
            lines.append(f"quality: {q['verdict']} (RMS {self.rms_mN * kF:.3g} {F} = {q['misfit']:.2g} x the noise "
                         f"{q['noise_mN'] * kF:.3g} {F}, {q['noise_source']}; residual "
                         f"{'white' if q['white'] else 'structured'})")
        lines.extend(f"flag: {shown_in(f, u)}" for f in self.flags)
        lines.extend(f"note: {shown_in(n, u)}" for n in self.notes)
        return "\n".join(lines)

    __str__ = report


def _e_star(result) -> tuple[float, float]:
    """E / (1 - nu^2) and its delta-method standard error from the free-parameter covariance."""
    E, nu = result.parameters["E_kPa"], result.parameters["nu"]
    grad = {"E_kPa": 1 / (1 - nu**2), "nu": 2 * E * nu / (1 - nu**2) ** 2}
    g = np.array([grad.get(n, 0.0) for n in result.free_names])
    var = float(g @ np.asarray(result.covariance) @ g)
    return E / (1 - nu**2), math.sqrt(var) if var >= 0 else math.nan


def quality(prepared, residual_mN, n_free: int, *, noise=None, white: bool | None = None, ended=()) -> dict:
    """The fit's misfit against a noise level independent of the model, and its whiteness.

    ``noise`` = ``(noise_mN, source)`` where the fit already has one (default the curve's,
    :func:`~skin_indent.fitting.error_model.curve_noise`); ``white`` where the fit already
    judged its residual (default judged here at that noise). ``ended``: how the fit ended where
    that is not a result (:func:`~skin_indent.fitting.ended.how_it_ended`): the verdict then says
    so (:func:`~skin_indent.fitting.ended.verdict`), whatever the misfit.
    """
    if noise is None:
        try:
            noise = curve_noise(prepared)
        except ValueError:
            return {}
    noise, source = noise
    r = np.asarray(residual_mN, dtype=float)
    rms = float(np.sqrt(np.mean(r**2)))
    if white is None:
        try:
            white = analyse_residuals(r, noise, n_free).white
        except ValueError:  # too few points to test the residual (4 points, nu held): no evidence of structure
            white = True
    misfit = rms / noise
    if misfit > MISFIT_LIMIT:
        verdict = "misfit far above the noise: the model does not describe this curve; try `skin-indent diagnose`"
    elif misfit < MISFIT_FLOOR:
        # a residual well under the data's own noise level carries no evidence of a missing effect,
        # whatever its pattern (noise-free or smoothed data: the pattern is round-off or interpolation)
        verdict = "fits below the noise level"
    elif not white:
        verdict = "structured misfit: try `skin-indent diagnose`"
    else:
        verdict = "fits to the noise"
    stopped = ended_verdict(ended)  # how the fit ended says first that its values are not a result
    if stopped:
        verdict = stopped if verdict in ("fits to the noise", "fits below the noise level") else f"{stopped}; {verdict}"
    return {"noise_mN": noise, "noise_source": source, "misfit": misfit, "white": bool(white),
            "verdict": verdict}


def with_scale_flags(result: CurveFit, at_bounds=None) -> CurveFit:
    """``result`` with the scale checks' flags appended (:func:`~skin_indent.fitting.scale_checks.scale_flags`)."""
    bounds = result.info.get("active_bounds", ()) if at_bounds is None else at_bounds
    extra = [f for f in scale_flags(result, at_bounds=bounds) if f not in result.flags]
    return dataclasses.replace(result, flags=(*result.flags, *extra)) if extra else result


def _n_free(prepared, fixed) -> int:
    """Parameters of the half-space fit: E, nu, and the contact point where it is fitted."""
    return sum(k not in fixed for k in ("E_kPa", "nu")) + int(prepared.contact_mode == "fit"
                                                               and "offset_mm" not in fixed)


def fit_half_space(data, surface, method, *, window, contact, fixed, radius_mm, x0, tol, noise_mN, context,
                    mesh) -> CurveFit:
    """The paper's identification (an option of :func:`~skin_indent.fitting.fit`) at the values held in
    ``fixed`` (nu < 0.5), without the scale flags: the loading points (of ``window``), a response surface,
    ``method``, the noise alone (no model error), Hertz for comparison."""
    if isinstance(data, PreparedCurve):
        prepared = data
    else:
        prepared = prepare(data, window=window, contact=contact, contact_mm=fixed.get("offset_mm"),
                           radius_mm=radius_mm)
    radius = prepared.radius_mm
    check_points(prepared, _n_free(prepared, fixed))
    if surface is None:
        depth = prepared.max_indentation_mm
        if prepared.contact_mode == "fit":  # room for the contact point to move earlier than its first guess
            depth = max(depth, min(1.5 * depth, SIMILARITY_RATIOS[-1] * radius))
        surface = surface_for(radius, depth, context=context, mesh=mesh)
    r_surface = surface.settings.get("radius_mm")
    if r_surface is not None and abs(r_surface / radius - 1) > 1e-9:
        surface = surface.at_radius(radius)
    check_fixed(fixed, surface)
    mode, c0 = prepared.contact_mode, prepared.contact_guess_mm
    h_load, F_load = prepared.loading()
    check_inside(surface, h_load)
    nu0 = fixed.get("nu", 0.4)
    e_star0 = hertz_modulus(h_load, F_load, radius)
    check_modulus_range(e_star0, surface, nu0)
    if x0 is None:
        x0 = start_values(surface, h_load, F_load, radius, nu=nu0)
    x0 = np.asarray(x0, dtype=float)
    hertz_base = HertzModel(radius, (e_star0 * 1e-3, e_star0 * 1e3), surface.depth_range)
    if mode == "fit":  # the contact point is fitted with the material
        model = ComposedModel(surface, (CONTACT_POINT,), prepared)
        hertz_model = ComposedModel(hertz_base, (CONTACT_POINT,), prepared)
        x0, hertz_x0 = np.r_[x0[:2], c0], np.array([e_star0, c0])
        depth, F = prepared.depth_mm, prepared.force_mN
    else:
        model, hertz_model = surface, hertz_base
        depth, F, hertz_x0 = h_load, F_load, np.array([e_star0])
        fixed.pop("offset_mm", None)
    # one noise per curve, independent of the model: the uncertainties, chi-square and reduced
    # chi-square are against it (a model that misses the curve shows as a reduced chi-square >> 1)
    # (the paper's identification: the noise alone, no model error, the error model's noise rule)
    try:
        independent = curve_noise(prepared, noise_mN)
    except ValueError:
        independent = None
    sigma = independent[0] if independent else None
    result = run_method(model, depth, F, x0, method, fixed=fixed, tol=tol,
                        noise_mN=sigma if method == "lsq" else noise_mN)
    if sigma is not None and method != "lsq":  # the filters' covariance is their own; the statistics use the noise
        rss = float(result.residuals_mN @ result.residuals_mN)
        result = dataclasses.replace(result, noise_mN=sigma, chi2=rss / sigma**2)
    score = scored(result.chi2, result.residuals_mN / result.noise_mN, result.n_free)
    hz = run_method(hertz_model, depth, F, hertz_x0, "lsq")
    contact_sd = None
    if mode == "fit":
        contact, contact_sd = result.parameters["offset_mm"], result.std.get("offset_mm")
    else:
        contact = c0
    e_star, e_star_sd = _e_star(result)
    hertz = {"E_star_kPa": hz.parameters["E_star_kPa"], "E_star_std_kPa": hz.std["E_star_kPa"],
             "contact_point_mm": hz.parameters.get("offset_mm", c0), "rms_mN": hz.rms_mN}
    notes = list(prepared.notes)
    if "nu" in fixed:
        notes.append(UnitText("nu fixed at {nu:g}; E = {E:.5g}", nu=fixed["nu"],
                              E=Quantity(result.parameters["E_kPa"], "kPa")))
    # every face of the half-space's ranges is its surface's edge (nu at the top of its nodes too: the
    # paper's path flags it, as it always has)
    ended = how_it_ended(result, model, limits=False)
    flags = [e.text for e in ended]
    q = quality(prepared, result.residuals_mN, result.n_free, noise=independent, ended=ended)
    if q and q["misfit"] > MISFIT_FLAG:
        flags.append(f"misfit {q['misfit']:.3g} x the noise ({q['noise_source']}): the model does not describe "
                     "this curve and its modulus is not to be trusted")
    base = {f.name: getattr(result, f.name) for f in dataclasses.fields(IdentificationResult)}
    summary = {"data": prepared.source, "n_points": prepared.n, "radius_mm": float(radius),
               "radius_source": prepared.radius_source, "noise_mN": q.get("noise_mN"),
               "noise_source": q.get("noise_source"), "rms_mN": result.rms_mN, "misfit": q.get("misfit"),
               "white": q.get("white"), "contact_mode": mode, "contact_point_mm": float(contact),
               "contact_point_std_mm": None if contact_sd is None else float(contact_sd),
               "baseline_mN": prepared.baseline_mN}
    return CurveFit(**base, **score, curves=[summary], prepared=prepared, radius_mm=float(radius), contact_point_mm=float(contact),
                    contact_point_std_mm=None if contact_sd is None else float(contact_sd), e_star_kPa=e_star,
                    e_star_std_kPa=e_star_sd, hertz=hertz, quality=q, flags=tuple(flags), notes=notes,
                    surface=surface_identity(surface) or {},
                    error_model=described(result.noise_mN, 0.0) if independent else {})
