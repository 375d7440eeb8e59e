"""What a fit's text and JSON say of its curves: each curve's data treatment and quality.

:func:`report_lines` gives the lines of :meth:`~skin_indent.fitting.result.FitResult.report`
before and after the identification's own: one curve's segments, baseline and contact point
in full, or each curve of a sample in one line; then the modulus E*, the error model and each
curve's quality. :func:`curve_dict` is the JSON of one curve's data treatment.
"""

from __future__ import annotations

import numpy as np


def curve_dict(result) -> dict:
    """The JSON keys of a fit of one curve beyond every fit's: the data treatment in full (segments,
    baseline, contact point), E*, Hertz, the quality and the surfaces (package units)."""
    p = result.data
    b = p.baseline
    return {
        "radius_mm": result.radius_mm,
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
        "contact_point_mm": result.contact_point_mm,
        "contact_point_std_mm": result.contact_point_std_mm,
        "contact_point_guess_mm": p.contact_guess_mm,
        "max_depth_ratio": result.max_depth_ratio,
        "E_star_kPa": result.e_star_kPa,
        "E_star_std_kPa": result.e_star_std_kPa,
        "hertz": dict(result.hertz),
        "fe_vs_hertz_percent": result.fe_vs_hertz_percent,
        "quality": dict(result.quality),
        "surface": result.surface,
    }


def report_lines(result, u) -> tuple[list[str], list[str]]:
    """The lines of a fit's report before and after the identification's, in the display units ``u``."""
    if len(result.prepared) == 1:
        return _curve_head(result, u), _curve_tail(result, u)
    return _sample_head(result, u), _sample_tail(result, u)


def _curve_head(result, u) -> list[str]:
    """One curve: the model, the segments fitted, the baseline and the contact point."""
    L, F, kL, kF = u.length, u.force, u.per_mm, u.per_mN
    p = result.data
    seg = ", ".join(f"{s.kind} rows {s.start}-{s.stop}" for s in p.segments)
    kinds = [k for k in ("approach", "hold", "retract") if np.any(p.kind == k)]
    lines = [f"model: {result.model}", f"segments: {seg}; fitting the {' and '.join(kinds) or 'approach'}"
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
    c, sd = result.contact_point_mm, result.contact_point_std_mm
    if p.contact_mode == "fit" and sd is None:  # a chosen model's, held (--fix offset_mm)
        lines.append(f"contact point: {c * kL:.6g} {L} (held)")
    elif p.contact_mode == "fit":
        lines.append(f"contact point: {c * kL:.6g} +/- {sd * kL:.2g} {L} (fitted jointly; first guess "
                     f"{p.contact_guess_mm * kL:.6g} {L} from the deviation from the baseline)")
    elif p.contact_mode == "fixed":
        lines.append(f"contact point: {c * kL:.6g} {L} (fixed)")
    else:
        lines.append("contact point: recorded depth 0 (the curve starts in contact)")
    return lines


def _curve_tail(result, u) -> list[str]:
    """One curve: E* against Hertz's, the error model and the quality."""
    F, M, kF, kM = u.force, u.modulus, u.per_mN, u.per_kPa
    h, lines = result.hertz, []
    if result.model == "neo-hooke":
        lines.append(f"E* = E/(1-nu^2): large-strain FE {result.e_star_kPa * kM:.5g} +/- "
                     f"{result.e_star_std_kPa * kM:.2g} {M}, Hertz (small strain, same points) "
                     f"{h['E_star_kPa'] * kM:.5g} +/- {h['E_star_std_kPa'] * kM:.2g} {M}: "
                     f"FE differs from Hertz by {result.fe_vs_hertz_percent:+.1f}% at h/R up to "
                     f"{result.max_depth_ratio:.3g}")
    else:
        lines.append(f"E* = E/(1-nu^2) of the top material {result.e_star_kPa * kM:.5g} +/- "
                     f"{result.e_star_std_kPa * kM:.2g} {M}; Hertz's homogeneous small-strain fit of the loading "
                     f"points {h['E_star_kPa'] * kM:.5g} +/- {h['E_star_std_kPa'] * kM:.2g} {M}")
    em = result.error_model
    if em and em["model_error"]:
        lines.append(f"error model: chi-square and BIC weigh each point by sqrt(noise^2 + ({em['model_error']:g} F)^2), "
                     "the noise and the forward model's relative error (the fit itself is unweighted least squares)")
    elif em:
        lines.append("error model: chi-square and BIC weigh each point by the noise alone (the paper's "
                     "identification: no model error)")
    q = result.quality
    if q:
        lines.append(f"quality: {q['verdict']} (RMS {result.rms_mN * kF:.3g} {F} = {q['misfit']:.2g} x the noise "
                     f"{q['noise_mN'] * kF:.3g} {F}, {q['noise_source']}; residual "
                     f"{'white' if q['white'] else 'structured'})")
    return lines


def _sample_head(result, u) -> list[str]:
    """Several curves: the model, and each curve's source, points, sphere and contact point."""
    L = u.length
    lines = [f"model: {result.model}, fitted to {len(result.curves)} curves of one sample (the material shared, each "
             "curve its own sphere, contact point and noise)"]
    for k, c in enumerate(result.curves, 1):
        contact = ("contact at recorded depth 0 (starts in contact)" if c["contact_point_std_mm"] is None
                   and c["contact_mode"] == "origin" else
                   f"contact point {c['contact_point_mm'] * u.per_mm:.6g} {L} (offset_mm[{k}])")
        lines.append(f"curve {k}: {c['data']} ({c['n_points']} points), sphere R = {c['radius_mm'] * u.per_mm:g} "
                     f"{L} ({c['radius_source']}); {contact}")
    return lines


def _sample_tail(result, u) -> list[str]:
    """Several curves: each curve's quality, and the error model."""
    F = u.force
    lines = [f"quality of curve {k}: RMS {c['rms_mN'] * u.per_mN:.3g} {F} = {c['misfit']:.2g} x its noise "
             f"{c['noise_mN'] * u.per_mN:.3g} {F} ({c['noise_source']}); residual "
             f"{'white' if c['white'] else 'structured'}" for k, c in enumerate(result.curves, 1)]
    if result.error_model:
        lines.append(f"error model: each point weighed by sqrt(noise^2 + ({result.error_model['model_error']:g} F)^2), "
                     "the noise of its own curve and the forward model's relative error")
    return lines
