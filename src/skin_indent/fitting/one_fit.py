"""One fit for every model, one curve or several: :func:`fit`.

Every fit is :func:`~skin_indent.fitting.model_fit.fit_model` (the multistart
:class:`~skin_indent.fitting.multistart.Fitter`, the error model): ``fit(m)`` is
``fit(m, model="neo-hooke")``, the diagnosis's first rung. The paper's identification
(:func:`~skin_indent.fitting.curve.fit_half_space`: its filters, its window, the loading points
weighed by the noise alone) is an option of it, as is the incompressible limit
(:func:`incompressible_limit`).
"""

from __future__ import annotations

import dataclasses
import math

from ..effects import model_name
from ..measurement.preparation import SKIN_RADIUS_MM
from ..measurement.scale import Quantity, UnitText, afm_scale
from ..runtime.provenance import records_call
from .curve import fit_half_space, with_scale_flags
from .identification import METHODS, NEARLY_INCOMPRESSIBLE_NU
from .model_fit import fit_model, is_several, parse_model
from .result import FitResult


@records_call("skin_indent.fit")
def fit(data, surface=None, method: str = "lsq", *, window=None, contact: str = "auto", fixed: dict | None = None,
        radius_mm: float | None = None, x0=None, tol: float | None = None, noise_mN: float | None = None,
        context=None, mesh: str | None = None, model=None, priors: dict | None = None, free=(),
        **options) -> FitResult:
    """Fit a recorded curve (or several of one sample): one fit for every model.

    Every fit is :func:`~skin_indent.fitting.model_fit.fit_model`, the fit the diagnosis makes
    of the model (``"neo-hooke"`` by default, ``"neo-hooke+layer+layer"``...): every segment, the
    multistart fitter, response surfaces or finite elements in the loop, the error model (noise
    and model error), least squares; ``fit(m)`` is ``fit(m, model="neo-hooke")``, the diagnosis's
    first rung, to the last digit and BIC included. The paper's identification is an option of it:
    a filter (``method="ekf-paper"`` or ``"ekf"``), a depth ``window``, a ``surface`` file, start
    values ``x0``, ``tol`` or a ``contact`` mode fit the neo-Hookean half-space to the loading
    segment on a response surface as the paper does (the noise alone, no model error), with
    Hertz for comparison.

    Parameters
    ----------
    data : Measurement or PreparedCurve, or a list of them
        The whole curve as recorded (approach, hold, retract; any baseline; contact
        anywhere), or a curve already prepared with :func:`skin_indent.measurement.prepare`.
        A list is several curves of one sample fitted together (the model path, default
        ``model="neo-hooke"``), one result as for one curve (each curve's in ``prepared`` and ``curves``).
    surface : ResponseSurface, optional
        A neo-Hookean surface (any radius: rescaled by similarity); default found in the
        cache or built (``context``, ``mesh``).
    method : {"ekf-paper", "ekf", "lsq"}
        ``"ekf-paper"`` or ``"ekf"``: the paper's identification (see above).
    window : (float, float), optional
        Indentation depths past the contact point (mm): the paper's identification.
    contact : {"auto", "fit", "origin"}
        See :func:`skin_indent.measurement.prepare`; other than ``"auto"``: the paper's identification.
    fixed : dict, optional
        ``{"E_kPa": ..., "nu": ..., "offset_mm": ...}`` held fixed (``offset_mm``: the
        contact point, recorded depth in mm). ``nu = 0.5`` is the incompressible limit
        of the compressible finite-element law (see :func:`incompressible_limit`). With a
        ``model``, any parameter it reports (``thickness_mm``, ``ratio``...). Default: nothing
        held at skin scale (nu fitted, as in the paper); ``nu = 0.5`` at AFM scale (sphere radius
        below 0.5 mm, :func:`skin_indent.measurement.scale.afm_scale`), the AFM field's convention.
    free : sequence of str
        Parameters fitted that the scale's default holds: ``("nu",)`` fits nu at AFM scale (the
        default holds it for the half-space fitted to one curve only).
    radius_mm : float, optional
        Sphere radius (mm); default the measurement's, else the skin default 6.22 mm.
    x0 : array_like, optional
        Start (E_kPa, nu); default a Hertz estimate.
    tol, noise_mN : float, optional
        Stop rule of the filters; a known noise level (mN).
    context : Context, optional
        Where surfaces are cached and built.
    mesh : str, optional
        Mesh of the finite-element runs behind a built surface (default ``"coarse"``, as the
        diagnosis; ``"medium"`` for the paper's identification).
    model : str, optional
        ``"neo-hooke"`` plus ``+effect`` per effect: fit that model (see above).
    priors : dict, optional
        ``{name: (mean, sd)}`` Gaussian priors on parameters.
    **options
        ``segments``, ``in_loop`` (see :func:`~skin_indent.fitting.model_fit.fit_model`).

    Returns
    -------
    FitResult
        The one result of every fit (the rung of the model a diagnosis's ladder holds, with its curves
        bound), with the scale checks' flags (:func:`~skin_indent.fitting.scale_checks.scale_flags`: a
        modulus no tissue or gel has, h/R below what instruments resolve, few points in contact, a
        parameter whose sd exceeds its value), each naming the likely slip.

    Raises
    ------
    MeasurementError
        Fewer points in contact than the parameters fitted need
        (:func:`~skin_indent.fitting.scale_checks.check_points`), and the preparation's refusals.

    Examples
    --------
    >>> import skin_indent as si
    >>> m = si.load_csv(si.bundled_path("forearm_like.csv"), radius_mm=6.22)
    >>> result = si.fit(m)                                            # doctest: +SKIP
    >>> paper = si.fit(m, method="ekf-paper", window=(0.05, 0.6))     # doctest: +SKIP
    >>> result.parameters["E_kPa"], result.quality["verdict"]          # doctest: +SKIP
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    free = tuple(free or ())
    if set(free) - {"nu"}:
        raise ValueError(f"free takes nu (held at 0.5 by default at AFM scale), got {', '.join(free)}")
    fixed = dict(fixed or {})
    if "nu" in fixed and "nu" in free:
        raise ValueError(f"nu is both held (at {fixed['nu']:g}) and freed: give one of them")
    paper = paper_identification(method, window=window, contact=contact, surface=surface, x0=x0, tol=tol)
    several = is_several(data)
    effects = parse_model("neo-hooke" if model is None else model)
    if paper:
        if effects or priors or several:
            what = ("the model " + str(model) if effects else "priors" if priors else "several curves")
            raise ValueError(f"the paper's identification ({_paper_options(method, window, contact, surface, x0, tol)})"
                             f" fits the neo-Hookean half-space to one curve's loading segment on a response surface; "
                             f"{what} need the fit without it (least squares, no window, start values, tol, surface "
                             "file or contact mode)")
        if options:
            raise TypeError(f"fit() got unexpected keyword arguments {', '.join(options)} (not taken with the paper's "
                            "identification)")
    if fixed.get("nu") == 0.5 and (effects or several or priors):
        raise ValueError(f"nu = 0.5 (the incompressible limit) is taken for the half-space fitted to one curve; "
                         f"hold nu = 0.49 for {model_name_of(effects, several)}" + (" with priors" if priors else ""))
    if not several and paper_needed(data, fixed=fixed, radius_mm=radius_mm, model=model, priors=priors):
        paper = True  # AFM scale, or nu held at 0.499 or 0.5: the paper's identification (paper_needed)
        if options:
            raise TypeError(f"fit() got unexpected keyword arguments {', '.join(options)} (not taken with the "
                            "paper's identification)")
    by_default = paper and "nu" not in fixed and "nu" not in free and afm_scale(_radius_of(data, radius_mm))
    if by_default:  # the AFM field's convention: nu = 0.5 held at AFM scale (one curve, the half-space)
        fixed["nu"] = 0.5
    if not paper:
        return fit_model(data, effects, fixed=fixed or None, priors=priors, noise_mN=noise_mN, radius_mm=radius_mm,
                         context=context, mesh=mesh or "coarse", **options)
    one = dict(surface=surface, method=method, window=window, contact=contact, radius_mm=radius_mm, x0=x0, tol=tol,
               noise_mN=noise_mN, context=context, mesh=mesh or "medium")
    if fixed.get("nu") != 0.5:
        return with_scale_flags(fit_half_space(data, fixed=fixed, **one))
    result = _incompressible(lambda nu: fit_half_space(data, fixed={**fixed, "nu": nu}, **one))
    if by_default:
        result = dataclasses.replace(result, notes=[*result.notes, NU_DEFAULT_NOTE])
    return result


def paper_needed(data, *, fixed=None, radius_mm=None, model=None, priors=None) -> bool:
    """:func:`fit` of one curve with these settings is the paper's identification without being asked:
    the half-space (no model, or ``"neo-hooke"``) and no prior, and an AFM-scale sphere (the field's fit of the approach segment,
    nu = 0.5 held by default) or nu held at 0.499 or 0.5 (the incompressible limit,
    :func:`incompressible_limit`: surfaces that reach nu = 0.499, the diagnosis's stop at 0.49)."""
    if parse_model("neo-hooke" if model is None else model) or priors:
        return False
    return (fixed or {}).get("nu", 0.0) >= NEARLY_INCOMPRESSIBLE_NU or afm_scale(_radius_of(data, radius_mm))


def model_name_of(effects, several: bool) -> str:
    """How an error names the model of ``effects`` (and several curves)."""
    name = model_name(effects)
    return name + (" fitted to several curves" if several else "")


def paper_identification(method: str = "lsq", *, window=None, contact: str = "auto", surface=None, x0=None,
                         tol=None) -> bool:
    """The options ask for the paper's identification (:func:`fit`): a filter (``"ekf-paper"``, ``"ekf"``),
    a depth window, a surface file, start values, a stop rule or a contact mode."""
    return bool(_paper_options(method, window, contact, surface, x0, tol))


def _paper_options(method, window, contact, surface, x0, tol) -> str:
    """The options given that ask for the paper's identification, in words ("" for none)."""
    given = [f"method {method}" if method != "lsq" else "", "a window" if window is not None else "",
             f"contact {contact}" if contact != "auto" else "", "a surface" if surface is not None else "",
             "start values" if x0 is not None else "", "tol" if tol is not None else ""]
    return ", ".join(g for g in given if g)


#: the note of a fit whose nu the AFM scale held
NU_DEFAULT_NOTE = ("nu = 0.5 held, the default at AFM scale (sphere radius < 0.5 mm: the field's convention); "
                   "--free nu (free=(\"nu\",)) fits it")


def _radius_of(data, radius_mm) -> float:
    """The sphere radius a fit of ``data`` uses (mm): given, the curve's, else the skin default."""
    for r in (radius_mm, getattr(data, "radius_mm", None)):
        if r is not None:
            try:
                return float(r)
            except (TypeError, ValueError):
                return math.nan  # refused in one line by the preparation
    return SKIN_RADIUS_MM


#: the two nu of the compressible law the incompressible limit is extrapolated from
LIMIT_NU = (0.49, NEARLY_INCOMPRESSIBLE_NU)


def incompressible_limit(data, surface=None, method: str = "lsq", **kwargs) -> FitResult:
    """:func:`fit` with nu = 0.5: the incompressible limit of the compressible finite-element law.

    The law needs nu < 0.5, but its force converges as nu -> 0.5 at fixed
    E* = E / (1 - nu^2) (the volumetric term only stiffens what is already nearly
    incompressible). The curve is fitted at nu = 0.49 and 0.499, E* is extrapolated
    linearly in nu to 0.5, and E = 0.75 E*. The result is the fit at 0.499 with E, its
    standard deviation and nu replaced, and a note giving the size of the extrapolation.
    Checked against Hertz at small depth and against nu = 0.499 in ``tests/test_api.py``.
    """
    fixed = dict(kwargs.pop("fixed", None) or {})
    return fit(data, surface, method, fixed={**fixed, "nu": 0.5}, **kwargs)


def _incompressible(fit_at) -> FitResult:
    """The nu = 0.5 limit from ``fit_at(nu)``, the fits at the nu of :data:`LIMIT_NU` (:func:`incompressible_limit`)."""
    fits = {nu: fit_at(nu) for nu in LIMIT_NU}
    lo, hi = LIMIT_NU
    e_lo, e_hi = fits[lo].e_star_kPa, fits[hi].e_star_kPa
    e_star = e_hi + (e_hi - e_lo) * (0.5 - hi) / (hi - lo)
    near = fits[hi]
    E = 0.75 * e_star
    scale = E / near.parameters["E_kPa"]
    parameters = {**near.parameters, "E_kPa": E, "nu": 0.5}
    std = {k: (v * scale if k == "E_kPa" else v) for k, v in near.std.items()}
    note = UnitText("nu = 0.5: the incompressible limit, E* extrapolated from nu = {lo:g} ({e_lo:.5g}) and {hi:g} "
                    "({e_hi:.5g}) to {e_star:.5g} ({moved:+.2g}% from nu = {hi:g})", lo=lo, hi=hi,
                    e_lo=Quantity(e_lo, "kPa"), e_hi=Quantity(e_hi, "kPa"), e_star=Quantity(e_star, "kPa"),
                    moved=100 * (e_star / e_hi - 1))
    notes = [n for n in near.notes if not n.startswith(("nu fixed", "nu held"))] + [note]
    return with_scale_flags(dataclasses.replace(near, parameters=parameters, std=std, e_star_kPa=e_star,
                                                e_star_std_kPa=near.e_star_std_kPa * e_star / e_hi, notes=notes))
