"""The paper's identification of one recorded curve, the quality of a fit and its scale flags.

:func:`fit_half_space` is the paper's identification, an option of :func:`~skin_indent.fitting.fit`
(:mod:`.one_fit`): it prepares the curve (:func:`skin_indent.measurement.prepare`: approach
segment, baseline, contact-point guess, window, radius, scale checks), fits the
neo-Hookean half-space on a response surface with the contact point as a parameter
where the curve starts before contact, fits Hertz to the same points for comparison,
and judges the fit against the noise (:func:`quality`). Its result is that of every fit,
a :class:`~skin_indent.fitting.result.FitResult` of one curve; :func:`with_scale_flags` adds the
scale checks' flags to any fit's, each curve's own.
"""

from __future__ import annotations

import dataclasses
import math

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
from ..measurement.scale import Quantity, UnitText
from .scale_checks import MISFIT_FLAG, check_points, scale_flags
from .ended import how_it_ended, verdict as ended_verdict
from ..models import ComposedModel, HertzModel

#: a misfit above this many times the independent noise: the model does not describe the curve
MISFIT_LIMIT = 3.0
#: a misfit below this fraction of the independent noise: the residual's pattern is not judged
MISFIT_FLOOR = 0.5


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


def with_scale_flags(result: FitResult, at_bounds=None) -> FitResult:
    """``result`` with the scale checks' flags appended (:func:`~skin_indent.fitting.scale_checks.scale_flags`,
    each curve's own; ``at_bounds``: parameters at a face of their range, default the fit's)."""
    bounds = result.info.get("active_bounds", ()) if at_bounds is None else at_bounds
    extra = [f for f in dict.fromkeys(scale_flags(result, at_bounds=bounds)) if f not in result.flags]
    return dataclasses.replace(result, flags=(*result.flags, *extra)) if extra else result


def _n_free(prepared, fixed) -> int:
    """Parameters of the half-space fit: E, nu, and the contact point where it is fitted."""
    return sum(k not in fixed for k in ("E_kPa", "nu")) + int(prepared.contact_mode == "fit"
                                                               and "offset_mm" not in fixed)


def fit_half_space(data, surface, method, *, window, contact, fixed, radius_mm, x0, tol, noise_mN, context,
                    mesh) -> FitResult:
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
    return FitResult(**base, **score, curves=[summary], prepared=(prepared,), e_star_kPa=e_star, e_star_std_kPa=e_star_sd,
                     hertz=hertz, quality=q, flags=tuple(flags), notes=notes, surface=surface_identity(surface) or {},
                     error_model=described(result.noise_mN, 0.0) if independent else {}, ended=ended,
                     white=bool(q.get("white", False)), prediction_mN=F - result.residuals_mN,
                     fit_parameters=dict(result.parameters), curve_rms_mN=(result.rms_mN,),
                     at_bounds=tuple(result.info.get("active_bounds", ())))
