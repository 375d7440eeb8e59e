"""Scale checks of a fit: results no soft tissue or gel can give, and the slip that likely made them.

:func:`skin_indent.measurement.prepare` refuses scales that cannot be right before any
finite-element work (an indentation deeper than the sphere's radius, nN forces with the skin
default radius). The checks here need the fit, or the number of parameters it fits; each
message names the likely slip, as the preparation's do:

- **refusal** (:func:`check_points`, a one-line :class:`~skin_indent.measurement.MeasurementError`):
  fewer points in contact than :func:`min_points` for the parameters fitted;
- **flags** (:func:`scale_flags`: warnings on stderr, ``flags`` in JSON, exit status 3 with
  ``--strict``):

  * a Young's modulus outside :data:`MODULUS_RANGE_KPA`, 10 Pa to 100 MPa. The softest
    materials indented are dilute gels and cells: reconstituted basement membrane
    (Matrigel) about 0.1-0.5 kPa (Soofi et al. 2009, *J. Struct. Biol.* 167:216), brain and
    glial cells 0.1-1 kPa (Lu et al. 2006, *PNAS* 103:17759; Levental, Georges and Janmey
    2007, *Soft Matter* 3:299, whose survey of tissue moduli starts at ~100 Pa), the softest
    polyacrylamide and collagen gels of mechanobiology some tens of Pa. The stiffest soft
    tissues, articular cartilage (0.1-10 MPa in indentation) and tendon or ligament (up to
    ~100 MPa; Guimaraes et al. 2020, *Nat. Rev. Mater.* 5:351), stay below 100 MPa; bone
    (GPa) is not a soft tissue. The limits lie a factor of about 10 outside the softest and
    the stiffest, so a real sample never crosses them, while the common slips move a modulus
    by 1000 (forces in N in a column labelled mN, or mN labelled N) or by about 30 (a radius in
    um typed as mm: E ~ 1/sqrt(R) at a given curve);
  * an indentation below :data:`MIN_DEPTH_RATIO` = 1e-3 of the radius. Instruments resolve
    depth to about 1e-4 of their spheres' radii (AFM: 1-2 nm on colloidal probes of 10-30 um;
    skin indenters: about 1 um on spheres of a few mm), so a curve must span at least 10
    resolution steps, h/R >= 1e-3, to carry a shape; real curves reach 0.01-0.5. A radius in
    um typed as mm puts h/R 1000 times lower; the opposite slip (mm as um) gives h > R, a
    contact radius a = sqrt(R h) larger than the sphere, which the preparation refuses;
  * fewer points in contact than :func:`soft_min_points` (5 per free parameter);
  * a positive parameter whose standard deviation exceeds its value: the curve does not
    determine it.

No check changes a fitted number.
"""

from __future__ import annotations

import math
import re

import numpy as np

from ..measurement import MeasurementError
from ..measurement.preparation import MIN_DEPTH_RATIO
from ..measurement.scale import Name, Quantity, UnitText, format_modulus

__all__ = ["MODULUS_RANGE_KPA", "POINTS_PER_PARAMETER", "check_points", "check_scale", "contact_points",
           "curve_scale_flags", "depth_ratio_flags", "min_points", "modulus_flags", "points_flags", "scale_flags",
           "soft_min_points", "undetermined_flags"]

#: Young's moduli (kPa) a soft tissue or gel can have: 10 Pa to 100 MPa (see the module docstring)
MODULUS_RANGE_KPA = (1e-2, 1e5)
#: points in contact per free parameter below which the fit is flagged (the soft minimum)
POINTS_PER_PARAMETER = 5
#: a misfit above this many times the independent noise: the modulus itself is not to be trusted (a flag)
MISFIT_FLAG = 10.0
#: parameters that are positions or offsets, not sizes: their sd is never compared with their value
SIGNED = ("offset_mm", "baseline_mN")


def min_points(n_free: int) -> int:
    """The hard minimum of points in contact for ``n_free`` fitted parameters: ``n_free + 2``.

    ``n_free`` points are interpolated exactly and one more leaves a single residual degree of
    freedom: neither misfit nor standard deviations then mean anything. For E alone (Hertz,
    nu and the contact point held) this is the 3 points the preparation already asks for.
    """
    return int(n_free) + 2


def soft_min_points(n_free: int) -> int:
    """The soft minimum: :data:`POINTS_PER_PARAMETER` (5) points in contact per free parameter.

    Below it the residual-whiteness test that judges the fit (runs and autocorrelation of a
    dozen residuals or fewer) has no power and the large-strain shape that separates E from nu
    is sampled by a handful of points: the fit runs, and is flagged.
    """
    return POINTS_PER_PARAMETER * int(n_free)


def contact_points(prepared, contact_mm: float | None = None) -> int:
    """Prepared points deeper than the contact point (default the preparation's guess); for several
    curves of one sample (a :class:`~skin_indent.measurement.CurveSet`), every curve's beyond its own guess."""
    if contact_mm is None and hasattr(prepared, "curves"):
        return sum(contact_points(c) for c in prepared.curves)
    c = prepared.contact_guess_mm if contact_mm is None else contact_mm
    return int(np.count_nonzero(np.asarray(prepared.depth_mm) > c))


def check_points(prepared, n_free: int, model: str | None = None) -> None:
    """Refuse a curve with fewer points in contact than :func:`min_points` for ``n_free`` parameters.

    Parameters
    ----------
    prepared : PreparedCurve or CurveSet
    n_free : int
        Parameters fitted.
    model : str, optional
        The model fitted (``neo-hooke+layer``), named in the message.

    Raises
    ------
    MeasurementError
        One line: the count, what the parameters need and the likely cause.
    """
    n = contact_points(prepared)
    if n < min_points(n_free):
        raise MeasurementError(
            f"{prepared.source}: {n} point(s) in contact for {n_free} fitted parameter(s)"
            + (f" of {model}" if model else "") + f", at least {min_points(n_free)} needed: a window that cuts the "
            "curve, a decimated export, or hold more parameters fixed (--fix nu=0.5)")


def _signed(name: str) -> bool:
    """A position or offset (``offset_mm``, ``baseline_mN``, their numbered repeats and each curve's
    own, ``offset_mm[2]``)."""
    return re.sub(r"\d+(?=_)", "", re.sub(r"\[\d+\]$", "", name)) in SIGNED


def scale_flags(result, *, free_names=None, at_bounds=()) -> list[str]:
    """The scale flags of a fit (see the module docstring), each curve's own; empty for a plausible one.

    Parameters
    ----------
    result : FitResult
        The fit (``parameters``, ``std``, ``prepared`` and ``curves``: each curve's points and its
        ``contact_point_mm``, ``n_free``), of one curve or several (their flags name the curve).
    free_names : sequence of str, optional
        The fitted parameters by the names ``parameters`` reports (default those in ``std``).
    at_bounds : sequence of str
        Parameters that ended at a face of their range: flagged already, or a physical limit
        (no adhesion, a rigid base), so their sd is not compared with their value.

    Returns
    -------
    list of str
    """
    flags = modulus_flags(result.parameters.get("E_kPa", math.nan))
    several = len(result.curves) > 1
    for k, (p, c) in enumerate(zip(result.prepared, result.curves)):
        ratio = float((np.max(p.depth_mm) - c["contact_point_mm"]) / p.radius_mm)
        flags += depth_ratio_flags(ratio, float(p.radius_mm), f"curve {k + 1} ({p.source}): " if several else "")
    n_contact = sum(contact_points(p, c["contact_point_mm"]) for p, c in zip(result.prepared, result.curves))
    flags += points_flags(n_contact, int(result.n_free))
    names = list(result.std) if free_names is None else list(free_names)
    flags += undetermined_flags(result.parameters, result.std, names, at_bounds)
    return flags


def curve_scale_flags(prepared) -> list[str]:
    """The scale flags a curve earns before any fit: :func:`modulus_flags` of its Hertz modulus and
    :func:`depth_ratio_flags` of its depth, the same checks :func:`scale_flags` makes of a fit.

    The modulus is Hertz's through the approach points past the preparation's contact guess, at
    nu = 0.5 (E = 0.75 E*): nu anywhere in [0.2, 0.5] moves it by less than 30 %, while the slips the
    checks name move it by 30 to 1000 times. Costs one least-squares product: no surface, no finite
    element.

    Parameters
    ----------
    prepared : PreparedCurve or CurveSet
        A prepared curve (:func:`skin_indent.measurement.prepare`), or several of one sample (each
        checked; flags name the curve).

    Returns
    -------
    list of str
        Empty for a curve at a plausible scale.
    """
    from .identification import hertz_modulus

    if hasattr(prepared, "curves"):
        return [f"{c.source}: {f}" for c in prepared.curves for f in curve_scale_flags(c)]
    flags = depth_ratio_flags(prepared.max_indentation_mm / prepared.radius_mm, prepared.radius_mm)
    h, F = prepared.loading()
    if h.size >= 3:
        try:
            flags += modulus_flags(0.75 * hertz_modulus(h, F, prepared.radius_mm))
        except ValueError:
            pass  # no increasing force: the fits say so in their own words
    return flags


def check_scale(prepared, what: str = "the diagnosis") -> None:
    """Refuse a curve whose scale cannot be right (:func:`curve_scale_flags`), before any finite-element work.

    A model fitted at a wrong scale names effects for the slip (a layer, adhesion, relaxation for a
    radius typed in um as mm), at minutes of finite-element work: ``diagnose`` and ``plan`` (and each
    curve of a batch) stop here with the flags ``fit`` would raise after its fit.

    Raises
    ------
    MeasurementError
        One line: the flags, each naming the likely slip.
    """
    flags = curve_scale_flags(prepared)
    if flags:
        raise MeasurementError(("" if hasattr(prepared, "curves") else f"{prepared.source}: ") + "; ".join(flags) + f"; {what} stops before any "
                               "finite-element work (fix the units or the radius; `skin-indent fit` shows the "
                               "numbers with these flags)")


def modulus_flags(E: float) -> list[str]:
    """A Young's modulus (kPa) outside :data:`MODULUS_RANGE_KPA`, with the likely slip."""
    lo, hi = MODULUS_RANGE_KPA
    if math.isfinite(E) and E < lo:
        return [f"E = {format_modulus(E)} is softer than any tissue or gel ({format_modulus(lo)} to "
                f"{format_modulus(hi)}): forces in N in a column labelled mN (E 1000 x too small), or a sphere "
                "radius in um typed as mm (E ~30 x too small)?"]
    if math.isfinite(E) and E > hi:
        return [f"E = {format_modulus(E)} is stiffer than any soft tissue or gel ({format_modulus(lo)} to "
                f"{format_modulus(hi)}): forces in mN in a column labelled N or uN (E 1000 x too large), or "
                "depths in mm labelled um?"]
    return []


def depth_ratio_flags(ratio: float, radius_mm: float, where: str = "") -> list[str]:
    """An indentation below :data:`MIN_DEPTH_RATIO` of the sphere radius (``where``: which curve)."""
    if not (math.isfinite(ratio) and 0 < ratio < MIN_DEPTH_RATIO):
        return []
    hint = (f" (a radius in um typed as mm? --radius takes mm: {radius_mm / 1e3:g} for {radius_mm:g} um)"
            if ratio * 1e3 <= 0.5 else "")
    return [f"{where}h/R = {ratio:.2g}: the indentation is below 1e-3 of the sphere radius R = "
            f"{radius_mm:g} mm, under what instruments resolve{hint}"]


def points_flags(n: int, n_free: int) -> list[str]:
    """Fewer points in contact than :func:`soft_min_points` for ``n_free`` parameters."""
    if n_free and n < soft_min_points(n_free):
        return [f"{n} points in contact for {n_free} fitted parameters (fewer than {POINTS_PER_PARAMETER} per "
                "parameter): too few to judge the fit; a window that cuts the curve or a decimated export?"]
    return []


def undetermined_flags(parameters: dict, std: dict, names, at_bounds=()) -> list[str]:
    """Positive parameters of ``names`` whose standard deviation exceeds their value."""
    flags = []
    for name in names:
        value, sd = parameters.get(name, math.nan), std.get(name, math.nan)
        if _signed(name) or name in at_bounds or not (math.isfinite(value) and value > 0 and math.isfinite(sd)):
            continue
        if sd > value:
            flags.append(UnitText("{name} is not determined by this curve (sd {sd:.3g} > value {value:.3g}): {why}",
                                  name=Name(name), sd=Quantity(sd, name), value=Quantity(value, name),
                                  why="hold it fixed if it is known (--fix)" if name != "E_kPa" else
                                  "too few points, too shallow a curve, or E and nu both free at small h/R "
                                  "(--fix nu=0.5)"))
    return flags
