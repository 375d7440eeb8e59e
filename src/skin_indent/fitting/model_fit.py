"""Fit the model the user chose: the half-space with any effects, values held, priors.

:func:`fit_model` is the path of :func:`skin_indent.fitting.fit` with ``model=...``:
the curve is prepared as the diagnosis prepares it (every segment, at most
:data:`MAX_POINTS` points), its noise is the diagnosis's (:func:`~.error_model.curve_noise`), and the
model is fitted by the same multistart fitter (:class:`~skin_indent.fitting.multistart.Fitter`:
response surfaces where they cover the model, finite elements in the loop where they do
not), so a model fitted here and the same model on a diagnosis's ladder are one fit with
one set of numbers (the rungs below it are fitted first, as the ladder climbs, so the
warm starts are the same). What the user knows enters as values held fixed and Gaussian priors,
both by the names results report (``thickness_mm``, ``ratio``, ``thickness2_mm``...).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..effects import parse_effects
from ..measurement import SEGMENTS, CurveSet, MeasurementError, PreparedCurve, prepare
from .curve import quality, with_scale_flags
from .ended import limit_notes
from .error_model import NOISE_POINTS, curve_noise, per_curve, sample_noise  # noqa: F401 - the diagnosis reads them here
from .identification import hertz_modulus, run_method
from .multistart import Fitter
from .result import FitResult, curve_summaries, knowledge_of
from .rung import reported_correlations
from .scale_checks import MISFIT_FLAG
from .surfaces import interpolation_flags
from ..models import HertzModel
from ..runtime.context import context_of
from ..runtime.provenance import surface_identity

#: at most this many points are fitted (longer curves are averaged in bins, in time order)
MAX_POINTS = NOISE_POINTS  # the noise rule estimates on at most as many (error_model)


def parse_model(model) -> tuple[str, ...]:
    """The effects of a fitted model (:func:`skin_indent.effects.parse_effects`, the one parser)."""
    return parse_effects(model)


def prepare_curve(data, *, radius_mm: float | None = None, segments=SEGMENTS) -> PreparedCurve:
    """A recorded curve prepared for any model and for the diagnosis: every segment kept (or
    ``segments``), longer curves averaged in bins down to :data:`MAX_POINTS`; a prepared curve
    is taken as it is."""
    if isinstance(data, PreparedCurve):
        return data
    if radius_mm is not None and not (math.isfinite(radius_mm) and radius_mm > 0):
        raise ValueError(f"radius must be a positive number of mm, got {radius_mm}")
    return prepare(data, segments=tuple(segments), radius_mm=radius_mm, max_points=MAX_POINTS)


def is_several(data) -> bool:
    """``data`` holds several curves of one sample (a list or tuple of curves, or a CurveSet)."""
    return isinstance(data, (list, tuple, CurveSet))


def prepare_sample(data, *, radius_mm=None, segments=SEGMENTS) -> list[PreparedCurve]:
    """Several recorded curves of one sample prepared as :func:`prepare_curve` prepares one, each with
    its own sphere radius (``radius_mm``: one for all, one per curve, or None: each curve's own)."""
    curves = list(data.curves if isinstance(data, CurveSet) else data)
    if len(curves) < 2:
        raise ValueError("several curves of one sample: give at least two")
    radii = per_curve(radius_mm, len(curves), "radius_mm")
    return [prepare_curve(c, radius_mm=r, segments=segments) for c, r in zip(curves, radii)]


def _hertz(prepared: PreparedCurve) -> dict:
    """Hertz's small-strain fit of the loading points in contact (E* only, contact at the guess)."""
    h, F = prepared.loading()
    e0 = hertz_modulus(h, np.maximum(F, 0.0), prepared.radius_mm)
    model = HertzModel(prepared.radius_mm, (e0 * 1e-3, e0 * 1e3), (0.0, 2.0 * float(h.max())))
    hz = run_method(model, h, F, np.array([e0]), "lsq")
    return {"E_star_kPa": hz.parameters["E_star_kPa"], "E_star_std_kPa": hz.std["E_star_kPa"],
            "contact_point_mm": prepared.contact_guess_mm, "rms_mN": hz.rms_mN}


def fit_model(data, model="neo-hooke", *, fixed: dict | None = None, priors: dict | None = None,
              noise_mN: float | None = None, radius_mm: float | None = None, segments=SEGMENTS,
              in_loop: bool = True, context=None, mesh: str = "coarse") -> FitResult:
    """Fit ``model`` to a recorded curve, holding ``fixed`` and weighing ``priors``.

    Parameters
    ----------
    data : Measurement or PreparedCurve, or a list of them
        The curve as recorded (every segment: loading, hold, unloading), or prepared. A list
        is several curves of ONE sample (two spheres, two speeds...), fitted together: the
        material's and effects' parameters shared, each curve with its own sphere radius,
        contact point (``offset_mm[2]``...) and noise, each residual weighed by its own
        curve's noise (:class:`~skin_indent.models.JointModel`).
    model : str or sequence of str
        ``"neo-hooke"`` plus ``+effect`` for each effect (``"neo-hooke+layer+layer"``: two
        bonded layers over a half-space or a rigid base), or the effects' names.
    fixed : dict, optional
        ``{name: value}`` held, by the names the result reports: ``E_kPa``, ``nu``,
        ``thickness_mm`` (the top layer, mm), ``ratio``, ``thickness2_mm``, ``offset_mm``
        (the contact point, recorded depth, mm), ``C20_kPa``, ``g1``, ``tau1_s``...
    priors : dict, optional
        ``{name: (mean, sd)}``: Gaussian priors from independent measurements (a dermis
        thickness from ultrasound, ``{"thickness_mm": (1.2, 0.1)}``), each one more residual
        of the least squares. The result's ``priors`` says, per parameter, how much the data
        narrowed it and whether data and prior agree.
    noise_mN : float or list of float, optional
        Noise standard deviation of a raw sample (mN; one per curve for several); default
        estimated from the data.
    radius_mm : float or list of float, optional
        Sphere radius (mm; one per curve for several); default the measurement's, else 6.22 mm.
    segments : sequence of str
        Kinds of motion fitted (default all).
    in_loop : bool
        Allow the finite-element model in the loop for combinations no surface covers.
    context : Context, optional
    mesh : str
        Mesh of the finite-element runs (default ``"coarse"``, as the diagnosis).

    Returns
    -------
    FitResult
        The rung of ``model`` the diagnosis's ladder holds, its curves bound (:func:`bound`), of one
        curve or several. ``model`` names the model; ``chi2`` weighs the residuals by the error model (noise and
        model error in quadrature), so ``redchi`` is about 1 when the model explains the curve;
        ``bic`` the rung's (:data:`~skin_indent.fitting.error_model.BIC_FORMULA`, at its own ``n_eff``);
        ``flags`` with the scale checks' (:func:`~skin_indent.fitting.scale_checks.scale_flags`).

    Raises
    ------
    MeasurementError
        Fewer points in contact than the model's free parameters need
        (:func:`~skin_indent.fitting.scale_checks.check_points`).

    Examples
    --------
    >>> import skin_indent as si
    >>> m = si.load_csv(si.bundled_path("forearm_like.csv"), radius_mm=6.22)
    >>> r = si.fit(m, model="neo-hooke+layer", priors={"thickness_mm": (1.2, 0.1)})  # doctest: +SKIP
    >>> r.priors["thickness_mm"]["determined_by"]                                    # doctest: +SKIP
    """
    effects = parse_model(model)
    context = context_of(context)
    if is_several(data):
        curves = prepare_sample(data, radius_mm=radius_mm, segments=segments)
    else:
        curves = [prepare_curve(data, radius_mm=radius_mm, segments=segments)]
    try:
        sigmas, sources = sample_noise(curves, noise_mN)
        no_noise = None
    except MeasurementError as err:  # too few points to estimate it: said after the count of points, which comes first
        sigmas, sources, no_noise = [math.nan] * len(curves), [""] * len(curves), err
    fitter = Fitter(curves, sigmas, noise_known=noise_mN is not None, context=context, mesh=mesh, in_loop=in_loop,
                    fixed=fixed, priors={k: tuple(v) for k, v in (priors or {}).items()})
    fitter.check_points_before_building(effects)  # a curve too short for the model builds nothing
    target = fitter.model(effects)
    fitter.check_names(target)
    _check_held(fitter, target)
    fitter.check_points(target)
    if no_noise is not None:
        raise no_noise
    for i in range(len(effects)):  # the rungs below, as a diagnosis climbs to it: the same warm starts
        try:
            fitter.fit(effects[:i])
        except ValueError:
            pass  # a simpler model that cannot be fitted: the model is started from its own values
    return bound(fitter.fit(effects), fitter, noise_sources=sources)


def _check_held(fitter: Fitter, model) -> None:
    """One line for a value held outside what the model covers (its fit coordinates' ranges)."""
    lo, hi = model.bounds
    for name, v in fitter.held(model).items():
        i = model.parameter_names.index(name)
        if not lo[i] * (1 - 1e-9) <= v <= hi[i] * (1 + 1e-9):
            raise ValueError(f"{name} = {v:g} is held outside what {model.name} covers ({lo[i]:g} to {hi[i]:g})"
                             + ("; nu = 0.499 or 0.5 (the incompressible limit) are taken by the half-space, "
                                "the paper's identification" if name == "nu" else ""))


def bound(rung, fitter: Fitter, *, noise_sources) -> FitResult:
    """``rung`` (the fitter's result of a model: the numbers the ladder shows) with its curves bound: each
    curve's data treatment and misfit, E*, Hertz's fit and the quality of a fit of one curve, the flags
    (how the fit ended, a misfit far above a curve's noise, priors in tension, the surfaces' edges, the
    scale checks', :func:`~skin_indent.fitting.curve.with_scale_flags`) and the notes."""
    curves = curve_summaries(rung, fitter, noise_sources)
    several = len(fitter.curves) > 1
    flags, notes = list(rung.flags), []  # how the fit ended (fitting.ended), as the ladder shows it
    for k, (c, cv) in enumerate(zip(fitter.curves, curves)):
        where = f"curve {k + 1} ({c.source}): " if several else ""
        if cv["misfit"] > MISFIT_FLAG:
            flags.append(f"{where}misfit {cv['misfit']:.3g} x the noise ({cv['noise_source']}): the model does not "
                         "describe this curve and its parameters are not to be trusted")
        notes += [f"{where}{n}" if where else n for n in c.notes]
    known_flags, known_notes = knowledge_of(rung, fitter)
    flags += known_flags + interpolation_flags(rung.bound_model, rung.x)
    notes += known_notes + limit_notes(rung, rung.bound_model, rung.x)
    one = {}
    if not several:  # Hertz's fit of the loading points and the verdict of one curve
        one = {"hertz": _hertz(fitter.data),
               "quality": quality(fitter.data, rung.residuals_mN, rung.n_free, noise=(fitter.noise_mN, noise_sources[0]),
                                  white=None if rung.analysis is None else rung.white, ended=rung.ended)}
    result = dataclasses.replace(rung, prepared=tuple(fitter.curves), curves=curves, flags=tuple(dict.fromkeys(flags)),
                                 notes=notes, surface=surface_identity(fitter.cores) or [],
                                 correlations=reported_correlations(rung), **_e_star_of(rung), **one)
    ended = tuple(n for e in rung.ended for n in e.parameters)  # by the names results report (ratio)
    return with_scale_flags(result, at_bounds=tuple(rung.at_bounds) + ended)


def _e_star_of(rung) -> dict:
    """E* = E / (1 - nu^2) of the (top) material and its sd, from E, nu, their sd and correlation."""
    p = rung.parameters
    E, nu = p["E_kPa"], p["nu"]
    sd_E, sd_nu = rung.std.get("E_kPa", 0.0), rung.std.get("nu", 0.0)
    rho = 0.0
    if "E_kPa" in rung.free_names and "nu" in rung.free_names:
        i, j = rung.free_names.index("E_kPa"), rung.free_names.index("nu")
        rho = float(rung.correlation[i, j]) if np.isfinite(rung.correlation[i, j]) else 0.0
    g = np.array([1 / (1 - nu**2), 2 * E * nu / (1 - nu**2) ** 2])
    C = np.array([[sd_E**2, rho * sd_E * sd_nu], [rho * sd_E * sd_nu, sd_nu**2]])
    var = float(g @ C @ g)
    return {"e_star_kPa": E / (1 - nu**2), "e_star_std_kPa": math.sqrt(var) if var >= 0 else math.nan}
