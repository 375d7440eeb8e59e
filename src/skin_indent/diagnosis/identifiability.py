r"""What the data determine, and which measurement would determine the rest.

A parameter of a fitted rung is *not determined* by the curve when its standard
deviation exceeds :data:`DETERMINED` times its value. This module predicts, from the
fitted model itself, the standard deviation every parameter would have under another
measurement of the same sample (the alternatives of :data:`ALTERNATIVES`: a sphere of
twice the radius to the same depth, an indentation 1.5 times deeper with the same
sphere, a sphere of half the radius to the same depth):

.. math::

    \mathrm{cov}(\theta) = (J^T W J)^{-1}, \qquad W = \mathrm{diag}(1 / \sigma_i^2),

with :math:`J` the Jacobian of the model at the fitted parameters evaluated for the
alternative measurement (the finite-element model,
:class:`~skin_indent.models.fe_core.FECore`: direct-differentiation sensitivities for the
material parameters, finite differences for the thicknesses; one Jacobian per
alternative, on the diagnosis' mesh), the same points (the recorded history with its
indentation scaled, at the recorded times) and the same noise model :math:`\sigma_i`
(``Fitter.sigma``: noise and model error in quadrature). The reported parameters'
standard deviations follow by the rung's own transformation
(:meth:`~skin_indent.models.ComposedModel.reported`).

It also says when a fit parameter on a face of its range stands at a physical limit
(:func:`~skin_indent.models.composed.at_physical_limit`: a rigid base, a nearly incompressible material) rather than
at the edge of what the fit could reach.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..effects import ELASTIC
from ..inverse.result import jacobian_covariance
from ..measurement.scale import Quantity, UnitText
from ..models import ComposedModel, JointModel
from ..fitting.rung import MODEL_ERROR
from ..models.fe_core import FECore
from ..response_surface import RunCache
from ..runtime.executors import available_cpus

#: a parameter is determined when its standard deviation is below this fraction of its value
DETERMINED = 0.5


@dataclass(frozen=True)
class Alternative:
    """A measurement of the same sample other than the recorded one.

    Attributes
    ----------
    key : str
        ``"larger sphere"``, ``"deeper"``, ``"smaller sphere"``.
    radius_factor : float
        Sphere radius over the recorded one.
    depth_factor : float
        Indentation (depth below the contact point) over the recorded one, point by point.
    short : str
        How a sentence names it among others (``"a larger sphere"``).
    """

    key: str
    radius_factor: float
    depth_factor: float
    short: str

    def describe(self, radius_mm: float, depth_mm: float) -> str:
        """The measurement in words.

        Parameters
        ----------
        radius_mm : float
            Sphere radius of the recorded curve (mm).
        depth_mm : float
            Its deepest indentation (mm).

        Returns
        -------
        str
            E.g. ``"an indentation 1.5 times deeper (0.9 mm)"``: a
            :class:`~skin_indent.measurement.scale.UnitText`, which reads in the units of the
            curve's scale (``"(0.9 um)"``...).
        """
        h = Quantity(self.depth_factor * depth_mm, "mm")
        if self.depth_factor != 1.0 and self.radius_factor == 1.0:
            return UnitText("an indentation {k:g} times deeper ({h:.3g})", k=self.depth_factor, h=h)
        size = {2.0: "twice the radius", 0.5: "half the radius"}.get(self.radius_factor,
                                                                     f"{self.radius_factor:g} times the radius")
        depth = ("the same depth" if self.depth_factor == 1.0
                 else f"{self.depth_factor:g} times the depth")
        return UnitText("a sphere of {size} ({R:.3g}) to {depth} ({h:.3g})", size=size,
                        R=Quantity(self.radius_factor * radius_mm, "mm"), depth=depth, h=h)


#: the recorded measurement itself: its finite-element standard deviations check the fit's own
#: (a surface's interpolated slopes can inflate the standard deviation of correlated parameters)
RECORDED = Alternative("recorded", 1.0, 1.0, "this measurement")
#: the alternatives :func:`assess` evaluates, in this order
ALTERNATIVES = (Alternative("larger sphere", 2.0, 1.0, "a larger sphere"),
                Alternative("deeper", 1.0, 1.5, "a deeper indentation"),
                Alternative("smaller sphere", 0.5, 1.0, "a smaller sphere"))


@dataclass(frozen=True)
class Prediction:
    """The predicted uncertainty of a fitted model's parameters under one alternative measurement.

    Attributes
    ----------
    alternative : Alternative
    label : str
        The measurement in words, with its sphere radius and depth (mm; :meth:`Alternative.describe`).
    std : dict or None
        ``{reported parameter: standard deviation}`` in the parameters' units; None when
        the computation failed.
    error : str or None
        Why it failed (a finite-element run that did not converge, a parameter outside
        the range of the finite-element model...), else None.
    forward_runs : int
        Finite-element runs it made.
    """

    alternative: Alternative
    label: str
    std: dict | None
    error: str | None = None
    forward_runs: int = 0


# ----------------------------------------------------------------------------- the measurement
def _indentation(model, x) -> np.ndarray:
    """Depth below the contact point (mm) of the model's recorded points at the fit vector ``x``."""
    return np.asarray(model.evaluate(x).h_mm, dtype=float)


def alternative_data(data, h_mm, radius_factor: float, depth_factor: float, force_mN=None):
    """The recorded history as another measurement would record it.

    Parameters
    ----------
    data : PreparedCurve
        The recorded points.
    h_mm : ndarray
        Their depth below the contact point (mm) in the fitted model.
    radius_factor, depth_factor : float
        Sphere radius and indentation over the recorded ones.
    force_mN : ndarray, optional
        Forces (mN) to store with the points (what the effects' fit bounds depend on,
        e.g. adhesion's); default the recorded ones.

    Returns
    -------
    PreparedCurve
        The same points and times; each depth moved so that its indentation is
        ``depth_factor`` times the recorded one (the contact point stays), the radius
        ``radius_factor`` times the recorded one (mm).
    """
    depth = np.asarray(data.depth_mm, dtype=float) + (depth_factor - 1.0) * h_mm
    contact = float(np.median(np.asarray(data.depth_mm, dtype=float) - h_mm))
    guess = contact + depth_factor * (float(data.contact_guess_mm) - contact)
    force = np.asarray(data.force_mN if force_mN is None else force_mN, dtype=float)
    return dataclasses.replace(data, depth_mm=depth, force_mN=force, radius_mm=float(data.radius_mm) * radius_factor,
                               contact_guess_mm=guess)


def _widen(bounds, x) -> tuple:
    """Bounds ``(lo, hi)`` widened to contain ``x`` (a Jacobian at the fit, not a fit, is evaluated)."""
    lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    return np.minimum(lo, x), np.maximum(hi, x)


def alternative_model(rung, h_mm, radius_factor: float, depth_factor: float, *, mesh: str, workers=None,
                      run_cache=None):
    """The rung's model bound to an alternative measurement, with the finite-element model as its core.

    Parameters
    ----------
    rung : Rung
        The fitted rung (``bound_model``, ``x``, ``prediction_mN``).
    h_mm : ndarray
        Indentation (mm) of the recorded points in the fitted model.
    radius_factor, depth_factor : float
        Sphere radius and indentation over the recorded ones.
    mesh : str
        Mesh family member of the runs (the diagnosis' ``fitter.mesh``).
    workers : int, optional
        Local processes for the finite-difference runs.
    run_cache : RunCache, optional
        Where the runs are kept (:class:`~skin_indent.response_surface.RunCache`).

    Returns
    -------
    ComposedModel
        Its ``bounds`` (and its core's) widened to contain the fitted vector.

    Raises
    ------
    ValueError
        The alternative's model does not have the rung's parameters.
    """
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    data = alternative_data(model.data, h_mm, radius_factor, depth_factor, force_mN=rung.prediction_mN)
    reach = depth_factor * float(np.max(h_mm))
    E, nu = float(x[0]), float(x[1])
    core = FECore([e for e in model.effects if e.stage == ELASTIC], radius_mm=float(data.radius_mm),
                  max_depth_mm=reach, e_star_kPa=E / (1.0 - nu**2), mesh=mesh, workers=workers,
                  run_cache=run_cache)
    n_core = len(core.parameter_names)
    core.bounds = _widen(core.bounds, x[:n_core])
    new = ComposedModel(core, model.effects, data)
    if new.parameter_names != model.parameter_names:
        core.close()
        raise ValueError(f"the alternative model has parameters {new.parameter_names}, not {model.parameter_names}")
    new.bounds = _widen(new.bounds, x)
    return new


# ----------------------------------------------------------------------------- the covariance
def _held(rung) -> set:
    """Fit parameters the rung's covariance holds at their value: those on a face of their range when
    the covariance with them free is not finite (as :meth:`Fitter.fit` does)."""
    cov = getattr(rung, "covariance", None)
    if cov is not None and np.all(np.isfinite(cov)):
        return set()
    return set(getattr(rung, "at_bounds", ()))


def reported_std(model, x, J, sigma, free) -> dict:
    """Standard deviations of the reported parameters from a Jacobian.

    Parameters
    ----------
    model : ComposedModel
        Gives the reported parameters of the fit vector (:meth:`ComposedModel.reported`).
    x : ndarray
        Fit vector.
    J : ndarray (n, p)
        Jacobian dF/dx at ``x`` (mN per unit of each fit parameter).
    sigma : ndarray (n,)
        Standard deviation of each point's force (mN).
    free : sequence of int
        Columns fitted; the others are held at their value (no variance).

    Returns
    -------
    dict
        ``{reported parameter: standard deviation}`` from cov = (J^T W J)^-1, W = diag(1 / sigma^2)
        (``inf`` where the Jacobian is rank deficient).
    """
    free = list(free)
    unscaled, _ = jacobian_covariance(np.asarray(J, dtype=float)[:, free] / np.asarray(sigma, dtype=float)[:, None])
    cov = np.zeros((x.size, x.size))
    cov[np.ix_(free, free)] = unscaled
    return model.reported(x, cov)[1]


def predicted_std(fitter, rung, *, radius_factor: float = 1.0, depth_factor: float = 1.0,
                  error_model: bool = True, in_workers: bool = False, bound: tuple | None = None) -> tuple[dict, int]:
    """Standard deviation every reported parameter of ``rung`` would have under another measurement.

    The fitted model at its fitted parameters, with the finite-element model as its
    elastic core, is bound to the recorded history with the sphere radius scaled by
    ``radius_factor`` and the indentation of every point (depth below the contact point)
    scaled by ``depth_factor``, at the recorded times (same number of points; a deeper
    indentation is then also faster). Its Jacobian (one finite-element run with
    direct-differentiation sensitivities, plus one run per thickness) gives
    cov = (J^T W J)^-1 with W = diag(1 / sigma_i^2) at the predicted forces, and the
    reported parameters' standard deviations by the rung's transformation.

    With history effects (``viscoelastic``) the relaxation is the model's hereditary
    integral over that history: a larger or smaller sphere keeps the recorded history, a
    deeper indentation scales its depths (the rates by the same factor).

    Parameters
    ----------
    fitter : Fitter
        The diagnosis' fits: the recorded points, the noise model ``sigma(force)`` (mN),
        the mesh and the context (its ``workers``).
    rung : Rung
        A fitted model (``bound_model``, ``x``, ``free_names``, ``prediction_mN``).
    radius_factor, depth_factor : float
        The alternative measurement (1, 1: the recorded one).
    error_model : bool
        ``True`` (default): sigma_i of ``fitter.sigma`` (noise and model error in
        quadrature); ``False``: the noise ``fitter.noise_mN`` alone, as the rung's own
        covariance (``noise^2 (J^T J)^-1``).
    in_workers : bool
        Make the runs in worker processes (:func:`assess` computes several at once).
    bound : tuple, optional
        Passed to :func:`alternative_jacobian`.

    Returns
    -------
    std : dict
        ``{reported parameter: standard deviation}`` in its unit (kPa, mm, -...).
    runs : int
        Finite-element runs made.

    Raises
    ------
    ValueError
        A finite-element run failed, or the indentation leaves the model's range.
    """
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    J, force, runs = alternative_jacobian(fitter, rung, radius_factor, depth_factor, in_workers=in_workers,
                                          bound=bound)
    sigma = fitter.sigma(force) if error_model else np.full(force.shape, float(fitter.noise_mN))
    held = _held(rung)
    names = model.parameter_names
    free = [names.index(n) for n in rung.free_names if n not in held]
    return reported_std(model, x, J, sigma, free), runs


def _bind(fitter, rung, radius_factor: float, depth_factor: float) -> tuple:
    """``(alternative_model, indentation h (mm))`` of the rung for another measurement."""
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    h = _indentation(model, x)
    if not np.any(h > 0):
        raise ValueError("no recorded point is in contact in the fitted model")
    context = getattr(fitter, "context", None)
    cache = None if context is None else RunCache(context.cache_dir)  # the runs kept with the fits'
    return alternative_model(rung, h, radius_factor, depth_factor, mesh=fitter.mesh,
                             workers=getattr(context, "workers", None), run_cache=cache), h


def alternative_jacobian(fitter, rung, radius_factor: float = 1.0, depth_factor: float = 1.0, *,
                         in_workers: bool = False, bound: tuple | None = None) -> tuple:
    """Jacobian of the rung's model at its fitted vector for another measurement, by finite elements.

    With ``radius_factor = depth_factor = 1`` it is the finite-element Jacobian of the
    recorded measurement itself (what a covariance of the fit free of a response
    surface's interpolation error would use).

    Parameters
    ----------
    fitter : Fitter
        The recorded points, the mesh and the context (its ``workers``).
    rung : Rung
        A fitted model (``bound_model``, ``x``, ``prediction_mN``).
    radius_factor, depth_factor : float
        Sphere radius and indentation (point by point) over the recorded ones.
    in_workers : bool
        Make the runs in worker processes, this thread only waiting for them
        (:meth:`~skin_indent.models.fe_core.FECore.in_workers`).
    bound : tuple, optional
        ``(model, h)`` of this measurement made before (by :func:`assess`, in the main
        thread, its workers started there); default: made here.

    Returns
    -------
    J : ndarray (n, p)
        Derivatives dF/dx (mN per unit of each fit parameter, ``rung.bound_model.parameter_names``).
    force : ndarray (n,)
        The predicted forces of that measurement (mN).
    runs : int
        Finite-element runs made.

    Raises
    ------
    ValueError
        A finite-element run failed, or the indentation leaves the model's range.
    """
    x = np.asarray(rung.x, dtype=float)
    new, h = bound if bound is not None else _bind(fitter, rung, radius_factor, depth_factor)
    core = new.core
    try:
        n_core = len(core.parameter_names)
        touch = depth_factor * h > 0
        with core.in_workers() if in_workers else contextlib.nullcontext():
            core.jacobian(depth_factor * h[touch], x[:n_core])  # the runs, sensitivities included, made once
        J = new.jacobian(new.depth_mm, x)
        force = new.force(new.depth_mm, x)
    finally:
        runs = core.runs
        core.close()
    if not np.all(np.isfinite(J)):
        raise ValueError("the Jacobian of the alternative measurement is not finite")
    return J, force, runs


def assess(fitter, rung, alternatives=ALTERNATIVES) -> list[Prediction]:
    """Every alternative measurement's predicted standard deviations (:func:`predicted_std`).

    A computation that fails (a run that does not converge, a parameter outside a
    range) is a :class:`Prediction` with ``std`` None and the reason, never an exception.

    Parameters
    ----------
    fitter : Fitter
        The diagnosis' fits (recorded points, noise model, mesh, context).
    rung : Rung
        A fitted model.
    alternatives : sequence of Alternative
        The measurements to assess (default :data:`ALTERNATIVES`).

    Returns
    -------
    list of Prediction
        One per alternative, in order.
    """
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    if isinstance(model, JointModel):
        return assess_sample(fitter, rung, alternatives)
    try:
        h_max = float(np.max(_indentation(model, x)))
    except Exception as err:  # noqa: BLE001 - nothing to assess: no alternative is suggested
        return [Prediction(a, a.short, None, f"{type(err).__name__}: {err}") for a in alternatives]
    radius = float(model.data.radius_mm)
    workers = getattr(getattr(fitter, "context", None), "workers", None)
    if workers is None:  # the context's default, as the cores' own: at most 2 local processes
        workers = min(2, available_cpus())
    concurrent = workers > 1 and len(alternatives) > 1

    def failed(a, err):
        first = str(err).splitlines()[0] if str(err) else ""
        return Prediction(a, a.describe(radius, h_max), None, f"{type(err).__name__}: {first}")

    def predict(a, bound=None):
        if isinstance(bound, Exception):
            return failed(a, bound)
        try:
            std, runs = predicted_std(fitter, rung, radius_factor=a.radius_factor, depth_factor=a.depth_factor,
                                      in_workers=concurrent, bound=bound)
        except Exception as err:  # noqa: BLE001 - a failed alternative is not suggested
            return failed(a, err)
        return Prediction(a, a.describe(radius, h_max), std, None, runs)

    if not concurrent:
        return [predict(a) for a in alternatives]
    from concurrent.futures import ThreadPoolExecutor

    # the alternatives side by side, as many as there are workers: each thread waits for its runs,
    # made by workers forked here, in the main thread, before the threads start
    bound = []
    for a in alternatives:
        made = None
        try:
            made = _bind(fitter, rung, a.radius_factor, a.depth_factor)
            made[0].core.start_workers()
            bound.append(made)
        except Exception as err:  # noqa: BLE001 - reported as that alternative's failure
            if made is not None:
                made[0].core.close()
            bound.append(err)
    with ThreadPoolExecutor(max_workers=min(workers, len(alternatives))) as pool:
        return list(pool.map(predict, alternatives, bound))


def suggestion(name: str, value: float, predictions) -> str:
    """What would determine the parameter ``name`` (value ``value``), as a clause to append.

    Parameters
    ----------
    name : str
        A reported parameter.
    value : float
        Its fitted value (in its unit).
    predictions : sequence of Prediction
        From :func:`assess`.

    Returns
    -------
    str
        ``"; <measurement> would determine it to +- <sd>"`` for the alternative with the
        smallest predicted standard deviation, when it is below :data:`DETERMINED` times
        the value (a :class:`~skin_indent.measurement.scale.UnitText`: the measurement's
        lengths and the standard deviation, in the parameter's unit, read in any units);
        ``"; none of <the alternatives> would determine it"`` when none is; ``""`` when no
        alternative could be evaluated.
    """
    done = [p for p in predictions if p.std is not None and name in p.std]
    if not done:
        return ""
    sds = [p.std[name] if math.isfinite(p.std[name]) else math.inf for p in done]
    best = int(np.argmin(sds))
    if sds[best] < DETERMINED * abs(value):
        return UnitText("; {label} would determine it to +- {sd:.2g}", label=done[best].label,
                        sd=Quantity(sds[best], name))
    keys = [p.alternative.key for p in done]
    if sorted(keys) == sorted(a.key for a in ALTERNATIVES):
        return "; none of a larger/smaller sphere or a deeper indentation would determine it"
    shorts = [p.alternative.short for p in done]
    if len(shorts) == 1:
        return f"; {shorts[0]} would not determine it either"
    return f"; none of {', '.join(shorts[:-1])} or {shorts[-1]} would determine it"


# ----------------------------------------------------------------------------- physical limits


# ----------------------------------------------------------------------------- several curves
def curve_rung(rung, k: int):
    """Curve ``k``'s part of a rung fitted to several curves of one sample: its composed model, fit
    vector and predicted forces (what :func:`alternative_jacobian` takes)."""
    model = rung.bound_model
    part, x = model.part(k, rung.x)
    return dataclasses.replace(rung, bound_model=part, x=x, prediction_mN=np.asarray(rung.prediction_mN)[model.slices[k]],
                               covariance=None, at_bounds=())


def assess_sample(fitter, rung, alternatives=ALTERNATIVES) -> list[Prediction]:
    """:func:`assess` of a rung fitted to several curves of one sample.

    The recorded measurement (:data:`RECORDED`) is every curve (the finite-element Jacobian of
    each curve in its rows); another measurement is ADDED to them: the first curve as that
    alternative would record it (a sphere of twice the radius...), its information summed with
    the recorded curves' (the user fits them all together).
    """
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    names = model.parameter_names
    held = _held(rung)
    free = [names.index(n) for n in rung.free_names if n not in held]
    first = curve_rung(rung, 0)
    radius = float(first.bound_model.data.radius_mm)

    def jacobian(k, a):
        """Rows of curve ``k`` as ``a`` would record it, in the joint columns; its sigma and its runs."""
        J, force, runs = alternative_jacobian(fitter, curve_rung(rung, k), a.radius_factor, a.depth_factor)
        rows = np.zeros((J.shape[0], x.size))
        rows[:, model.index(k)] = J
        sigma = np.sqrt(fitter.noises_mN[k] ** 2 + (MODEL_ERROR * np.abs(force)) ** 2)
        return rows, sigma, runs

    try:
        h_max = float(np.max(_indentation(first.bound_model, first.x)))
        recorded = [jacobian(k, RECORDED) for k in range(len(model.parts))]
    except Exception as err:  # noqa: BLE001 - nothing to assess: no alternative is suggested
        return [Prediction(a, a.short, None, f"{type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''}")
                for a in alternatives]
    J0 = np.vstack([r for r, _, _ in recorded])
    s0 = np.concatenate([s for _, s, _ in recorded])
    runs0 = sum(n for _, _, n in recorded)
    out = []
    for a in alternatives:
        label = a.describe(radius, h_max) if a is not RECORDED else "these measurements"
        if a is RECORDED:
            out.append(Prediction(a, label, reported_std(model, x, J0, s0, free), None, runs0))
            continue
        try:
            J, sigma, runs = jacobian(0, a)
        except Exception as err:  # noqa: BLE001 - a failed alternative is not suggested
            out.append(Prediction(a, "adding " + label, None, f"{type(err).__name__}: {str(err).splitlines()[0]}"))
            continue
        std = reported_std(model, x, np.vstack([J0, J]), np.concatenate([s0, sigma]), free)
        out.append(Prediction(a, "adding " + label, std, None, runs))
    return out

