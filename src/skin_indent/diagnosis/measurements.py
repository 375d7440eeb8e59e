r"""Measurements of the same sample that a user can make next, and what fitted models predict for them.

The parts of the one engine of the next measurement (:func:`~.identifiability.weigh`, which
the diagnosis' sentences and :func:`~skin_indent.diagnosis.planning.plan` read):

- **Candidates** (:class:`Candidate`): the recorded history replayed as another
  measurement would record it: a sphere of another radius to the same depths
  (:func:`sphere`), an indentation deeper at the same speed (:func:`deeper`), a hold at
  the deepest point after the recorded loading (:func:`hold`), the history at another
  loading speed (:func:`speed`). A candidate's points are depths below its own contact
  point (mm), at their times (s).
- **Predictions**: every finite-element run of a prediction goes through
  :func:`predicted_force` (the fitted model, its elastic core made by the finite-element
  model, :class:`~skin_indent.models.fe_core.FECore`, evaluated on the candidate's points,
  with its Jacobian on request), and the independent runs go to the workers together
  (:func:`predict`).
- **Separation** (:func:`separation`): how far the predicted curves of two explanations
  lie apart, in noise units, over a candidate's points:

  .. math::

      D_\infty = \max_i |F_{b,i} - F_{a,i}| / \sigma, \qquad
      S = \Big(\sum_i (F_{b,i} - F_{a,i})^2 / \sigma_i^2\Big)^{1/2},
      \qquad \sigma_i^2 = \sigma^2 + \big(\varepsilon \tfrac{F_{a,i} + F_{b,i}}{2}\big)^2,

  with :math:`\sigma` the noise of the recorded curve and :math:`\varepsilon` =
  :data:`~skin_indent.fitting.error_model.MODEL_ERROR`, the error model of every fit
  (:func:`~skin_indent.fitting.error_model.point_sigma`).
  :math:`S^2` is how much the chi-square of one explanation rises over the candidate's
  points if the other is true and neither is refitted: an upper bound of what a joint fit
  of the recorded curves and the candidate would show (refitting absorbs part of it; a
  linearised refit is no estimate of how much: on the forearm-like curve at R = 3.11 mm it
  left S = 5.7 where a nonlinear refit of layer and stiffening to the curve of two layers
  left 56).
- **What a candidate would determine** (:func:`joint_std`): the standard deviations of
  the parameters when the candidate is fitted together with what was recorded: the
  information matrices of the curves summed (the shared parameters; each curve keeps its
  own contact point where the fitted model fits one), with the priors' rows,
  :math:`\mathrm{cov} = (\sum_k J_k^T W_k J_k + P^T P)^{-1}`.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass

import numpy as np

from ..effects import DEPTH, HISTORY, Model, instances
from ..fitting.error_model import point_sigma
from ..inverse.result import jacobian_covariance
from ..measurement.preparation import MAX_DEPTH_RATIO
from ..measurement.scale import Quantity, UnitText
from ..models.joint import split_name
from ..models import ComposedModel
from ..models.fe_core import FECore
from ..response_surface.run_cache import RunCache
from ..runtime.executors import make_executor

#: duration (s) of the hold a diagnosis weighs where an explanation acts along the time history
HOLD_S = 30.0
#: points recorded during a hold
HOLD_POINTS = 30
#: how many times deeper the indentation a diagnosis weighs is
DEEPER = 1.5


# ----------------------------------------------------------------------------- candidates
@dataclass(frozen=True, eq=False)
class Candidate:
    """A measurement of the same sample, as its points would be recorded.

    Attributes
    ----------
    kind : str
        ``"sphere"``, ``"deeper"``, ``"hold"`` or ``"speed"``.
    label : str
        The measurement in words, with its numbers (mm, s, mm/s); a
        :class:`~skin_indent.measurement.scale.UnitText` where it holds lengths (a sphere, a
        deeper indentation, a hold), which reads in the units of the curve's scale.
    curve : PreparedCurve
        Its points: ``depth_mm`` the depth below its own contact point (mm, > 0),
        ``time_s`` (s, or None when the recorded curve has no time), ``kind`` per point,
        ``radius_mm`` the sphere radius (mm), contact at depth 0 (``contact_mode`` ``"origin"``).
    value : float
        The setting that makes it: the sphere radius (mm), the deepest indentation (mm),
        the hold (s) or the loading speed (mm/s).
    reference : bool
        The recorded measurement made again (the same sphere to the same depth): what
        repeating it would add, the yardstick of every other candidate.
    """

    kind: str
    label: str
    curve: object
    value: float
    reference: bool = False

    @property
    def radius_mm(self) -> float:
        return float(self.curve.radius_mm)

    @property
    def max_depth_mm(self) -> float:
        return float(np.max(self.curve.depth_mm))

    @property
    def n(self) -> int:
        return int(self.curve.depth_mm.size)

    @property
    def slug(self) -> str:
        """A file-name part: ``sphere-R3.11mm``, ``deeper-0.9mm``, ``hold-30s``, ``speed-0.1mm_per_s``."""
        unit = {"sphere": "mm", "deeper": "mm", "hold": "s", "speed": "mm_per_s"}[self.kind]
        prefix = "R" if self.kind == "sphere" else ""
        return re.sub(r"[^A-Za-z0-9._-]", "_", f"{self.kind}-{prefix}{self.value:.4g}{unit}")

    @property
    def in_time(self) -> bool:
        """Its points are best read against time (a hold, another speed) rather than depth."""
        return self.kind in ("hold", "speed")


def recorded_history(curve, h_mm):
    """A recorded curve's points as depths below the contact point of a fitted model.

    Parameters
    ----------
    curve : PreparedCurve
        The recorded curve.
    h_mm : ndarray
        Depth below the contact point (mm) of each of its points in the fitted model
        (:meth:`~skin_indent.models.ComposedModel.evaluate`: the recorded depth less the
        fitted contact point).

    Returns
    -------
    PreparedCurve
        Every point (those before contact too), at depth ``h_mm``, with its time, kind and
        force; the recorded radius; contact at depth 0.
    """
    return _points(curve, np.asarray(h_mm, dtype=float),
                   None if curve.time_s is None else np.asarray(curve.time_s, dtype=float), np.asarray(curve.kind),
                   float(curve.radius_mm), np.asarray(curve.force_mN, dtype=float))


def base_history(curve, h_mm):
    """The recorded points in contact, as depths below the contact point: what the candidates replay.

    Parameters
    ----------
    curve, h_mm
        As :func:`recorded_history`.

    Returns
    -------
    PreparedCurve
        The points with ``h_mm > 0``.
    """
    h = np.asarray(h_mm, dtype=float)
    keep = h > 0
    if np.count_nonzero(keep) < 3:
        raise ValueError("fewer than 3 recorded points are in contact in the fitted model")
    full = recorded_history(curve, h)
    return dataclasses.replace(full, depth_mm=full.depth_mm[keep], force_mN=full.force_mN[keep],
                               time_s=None if full.time_s is None else full.time_s[keep], kind=full.kind[keep])


def _points(template, depth, time, kind, radius_mm, force=None):
    """A prepared curve of the points given, contact at depth 0 (``force_mN``: only the effects'
    fit bounds read it, never a prediction: the recorded peak force at every point by default)."""
    if force is None:
        force = np.full(depth.size, float(np.max(np.abs(template.force_mN))))
    return dataclasses.replace(template, depth_mm=np.asarray(depth, dtype=float),
                               force_mN=np.asarray(force, dtype=float),
                               time_s=None if time is None else np.asarray(time, dtype=float),
                               kind=np.asarray(kind), radius_mm=float(radius_mm), radius_source="plan",
                               contact_mode="origin", contact_guess_mm=0.0, contact=None, baseline=None,
                               baseline_fitted=None)


def _check_depth(depth_mm: float, radius_mm: float, what: str) -> None:
    if depth_mm > MAX_DEPTH_RATIO * radius_mm:
        raise ValueError(f"{what}: an indentation of {depth_mm:.3g} mm is deeper than the sphere's radius "
                         f"({radius_mm:.3g} mm), beyond what the model handles (h/R <= {MAX_DEPTH_RATIO:g})")


def _moving(depth_mm) -> np.ndarray:
    """Per time step of a history: the sphere moves (its depth changes by more than 1e-9 of the deepest)."""
    d = np.asarray(depth_mm, dtype=float)
    return np.abs(np.diff(d)) > 1e-9 * float(np.max(np.abs(d)))


def sphere(base, radius_mm: float) -> Candidate:
    """A sphere of radius ``radius_mm`` (mm) pressed to the recorded depths at the recorded times.

    ``base`` is :func:`base_history` of the recorded curve; the same radius is the
    reference candidate (the measurement made again).
    """
    if not (math.isfinite(radius_mm) and radius_mm > 0):
        raise ValueError(f"a sphere radius must be a positive number of mm, got {radius_mm:g}")
    R, h = float(base.radius_mm), float(np.max(base.depth_mm))
    _check_depth(h, radius_mm, f"a sphere of R = {radius_mm:g} mm")
    ratio = radius_mm / R
    depth = Quantity(h, "mm")
    if math.isclose(ratio, 1.0, rel_tol=1e-6):
        label = UnitText("the same sphere again (R = {R:.3g}, to {h:.3g})", R=Quantity(R, "mm"), h=depth)
        reference = True
    else:
        size = {0.5: "half the radius", 2.0: "twice the radius"}.get(round(ratio, 6), None)
        label = UnitText("a sphere of " + ("{size} (R = {R:.3g})" if size else "R = {R:.3g}") + " to the same depth "
                         "({h:.3g})", size=size, R=Quantity(radius_mm, "mm"), h=depth)
        reference = False
    curve = dataclasses.replace(base, radius_mm=float(radius_mm))
    return Candidate("sphere", label, curve, float(radius_mm), reference)


def deeper(base, max_depth_mm: float) -> Candidate:
    """The recorded history to ``max_depth_mm`` (mm) with the same sphere at the same speed.

    Every depth is scaled by ``max_depth_mm`` over the recorded deepest one; the time
    steps in which the sphere moves by the same factor (the speed stays), those in which
    it stands still (a hold) are kept.
    """
    h = float(np.max(base.depth_mm))
    if not (math.isfinite(max_depth_mm) and max_depth_mm > h * (1 + 1e-9)):
        raise ValueError(f"a deeper indentation must go beyond the recorded {h:.4g} mm, got {max_depth_mm:g} mm")
    _check_depth(max_depth_mm, float(base.radius_mm), "a deeper indentation")
    k = max_depth_mm / h
    t = base.time_s
    if t is not None:
        dt = np.diff(t) * np.where(_moving(base.depth_mm), k, 1.0)
        t = t[0] * k + np.r_[0.0, np.cumsum(dt)]
    curve = _points(base, k * base.depth_mm, t, base.kind, base.radius_mm)
    return Candidate("deeper", UnitText("an indentation to {h:.3g} ({k:.3g} times deeper) with the same sphere",
                                        h=Quantity(max_depth_mm, "mm"), k=k), curve, float(max_depth_mm))


def hold(base, hold_s: float = HOLD_S, points: int = HOLD_POINTS) -> Candidate:
    """The recorded loading, then ``hold_s`` seconds at its deepest point (``points`` samples).

    Raises
    ------
    ValueError
        The recorded curve has no time, or ``hold_s`` is not positive.
    """
    if base.time_s is None:
        raise ValueError("the recorded curve has no time column: a hold cannot follow its history")
    if not (math.isfinite(hold_s) and hold_s > 0):
        raise ValueError(f"a hold must last a positive number of seconds, got {hold_s:g}")
    end = int(np.argmax(base.depth_mm)) + 1  # the loading: up to the first deepest point
    if end < 2:
        raise ValueError("the recorded curve has no loading to hold after")
    t_end, h_end = float(base.time_s[end - 1]), float(base.depth_mm[end - 1])
    time = np.r_[base.time_s[:end], t_end + hold_s * np.arange(1, points + 1) / points]
    curve = _points(base, np.r_[base.depth_mm[:end], np.full(points, h_end)], time,
                    np.r_[base.kind[:end], np.full(points, "hold")], base.radius_mm)
    return Candidate("hold", UnitText("a {t:.3g} s hold at the deepest point ({h:.3g}) after the recorded loading",
                                      t=hold_s, h=Quantity(h_end, "mm")), curve, float(hold_s))


def loading_speed(curve) -> float:
    """Median speed (mm/s) of the loading points of a curve (NaN without time)."""
    if curve.time_s is None:
        return math.nan
    load = np.flatnonzero(curve.kind == "approach")
    dt, dh = np.diff(curve.time_s[load]), np.diff(curve.depth_mm[load])
    ok = dt > 0
    return float(np.median(dh[ok] / dt[ok])) if np.any(ok) else math.nan


def speed(base, speed_mm_per_s: float) -> Candidate:
    """The recorded history at another loading speed (mm/s): the time steps in which the sphere
    moves scaled by the recorded speed over ``speed_mm_per_s``, those in which it stands still kept."""
    if base.time_s is None:
        raise ValueError("the recorded curve has no time column: its speed is unknown")
    if not (math.isfinite(speed_mm_per_s) and speed_mm_per_s > 0):
        raise ValueError(f"a loading speed must be a positive number of mm/s, got {speed_mm_per_s:g}")
    v = loading_speed(base)
    if not (math.isfinite(v) and v > 0):
        raise ValueError("the recorded loading has no positive speed")
    k = v / speed_mm_per_s
    dt = np.diff(base.time_s) * np.where(_moving(base.depth_mm), k, 1.0)
    t = base.time_s[0] * k + np.r_[0.0, np.cumsum(dt)]
    curve = _points(base, base.depth_mm, t, base.kind, base.radius_mm)
    return Candidate("speed", f"a loading speed of {speed_mm_per_s:.3g} mm/s (recorded: {v:.3g} mm/s)", curve,
                     float(speed_mm_per_s))


def acts_in_time(effects) -> bool:
    """An effect of ``effects`` acts along the time history (a hold or another speed changes its force)."""
    return any(e.stage == HISTORY or e.needs_history for e in instances(effects))


# ----------------------------------------------------------------------------- predictions
def _widen(bounds, x) -> tuple:
    lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    return np.minimum(lo, x), np.maximum(hi, x)


def predicted_force(effects: tuple, theta: dict, history, mesh: str = "coarse", jacobian: bool = False,
                    cache_dir=None) -> tuple:
    """The force of a fitted model on the points of a measurement, by one finite-element run.

    The one function through which every finite-element run of a planned measurement
    goes (a worker task). The model is the fitted one (its effects act on the elastic
    force as in the fit: :class:`~skin_indent.models.ComposedModel`) with the
    finite-element model as its elastic core (:class:`~skin_indent.models.fe_core.FECore`:
    one unit-modulus run to the deepest point, with direct-differentiation
    sensitivities when the Jacobian is asked for, plus one run per parameter that moves
    the geometry, such as a thickness).

    Parameters
    ----------
    effects : tuple of str
        The model's effects (those of the :data:`~skin_indent.effects.DEPTH` stage, a
        contact point, included only with their parameter in ``theta``).
    theta : dict
        ``{fit coordinate: value}`` of every parameter of the model (``E_kPa``, ``nu``,
        ``thickness_mm``, ``compliance``...: a fitted rung's ``fit_parameters``).
    history : PreparedCurve
        The points: depth (mm), time (s), kind, and the sphere radius (mm).
    mesh : str
        Mesh family member of the run.
    jacobian : bool
        Also return dF/dtheta.
    cache_dir : path, optional
        Where the run is read from or kept (the run cache,
        :class:`~skin_indent.response_surface.RunCache`, of this cache folder; default
        ``$SKIN_INDENT_CACHE`` or ``~/.cache/skin_indent``): the same prediction asked
        again, by this diagnosis or a later one, solves nothing.

    Returns
    -------
    force : ndarray (n,)
        mN at the history's points.
    J : ndarray (n, p) or None
        dF/dtheta (mN per unit of each coordinate), None unless ``jacobian``.
    names : tuple of str
        The coordinates of the columns of ``J``, in order.

    Raises
    ------
    ValueError
        A run did not converge, or ``theta`` does not hold the model's parameters or puts one
        outside its physical range (a negative stiffening...).
    """
    objs = instances(effects)
    h = np.asarray(history.depth_mm, dtype=float)
    E, nu = float(theta["E_kPa"]), float(theta["nu"])
    core = FECore(objs, radius_mm=float(history.radius_mm), max_depth_mm=float(np.max(h)),
                  e_star_kPa=E / (1.0 - nu**2), mesh=mesh, workers=1, run_cache=RunCache(cache_dir))
    try:
        try:
            xc = np.array([float(theta[n]) for n in core.parameter_names])
            core.bounds = _widen(core.bounds, xc)
            model = ComposedModel(core, objs, history)
            x = np.array([float(theta[n]) for n in model.parameter_names])
        except KeyError as err:
            raise ValueError(f"no value of {err.args[0]} for {'+'.join(('neo-hooke', *effects))}") from None
        Model(tuple(e.name for e in objs), float(history.radius_mm)).check(model.model_parameters(x))  # in range
        model.bounds = _widen(model.bounds, x)
        if not jacobian:
            core.prefetch([xc])  # the run without sensitivities: the force only
        force = model.force(model.depth_mm, x)
        J = model.jacobian(model.depth_mm, x) if jacobian else None
    finally:
        core.close()
    if not np.all(np.isfinite(force)) or (J is not None and not np.all(np.isfinite(J))):
        raise ValueError("the prediction is not finite")
    return force, J, model.parameter_names


def model_of(rung, *, jacobian: bool) -> tuple[tuple, dict]:
    """``(effects, theta)`` of a fitted rung for :func:`predicted_force` on points given as depths
    below their own contact point.

    The force alone leaves the :data:`~skin_indent.effects.DEPTH` effects out (the points
    are past contact already); with the Jacobian they stay, at 0, so that the points
    carry their own contact-point column (each curve of a joint fit has its own).
    """
    objs = rung.bound_model.effects
    names = tuple(e.name for e in objs if jacobian or e.stage != DEPTH)
    # a fit of several curves holds each curve's own contact point (offset_mm[2]): not the model's
    theta = {k: v for k, v in rung.fit_parameters.items() if split_name(k)[1] is None}
    for e in objs:
        if e.stage == DEPTH:
            for k in e.fit_names:
                theta[k] = 0.0
    return names, theta


def executor_options(context) -> dict:
    """The keywords of :func:`~skin_indent.runtime.executors.make_executor` of a context (its
    local workers, or its Dask client or scheduler)."""
    if context is None:
        return {}
    if getattr(context, "client", None) is not None or getattr(context, "scheduler", None) is not None:
        return {"client": context.client, "scheduler": context.scheduler}
    return {"workers": context.workers}


def predict(tasks: dict, *, context=None) -> dict:
    """Run :func:`predicted_force` for every task at once, in the context's workers.

    Parameters
    ----------
    tasks : dict
        ``{tag: (effects, theta, history, mesh, jacobian)}``.
    context : Context, optional
        Where the runs go (its ``workers``, ``client`` or ``scheduler``; default the
        available cores) and are kept (its ``cache_dir``'s run cache).

    Returns
    -------
    dict
        ``{tag: (force, J, names)}``, or ``{tag: exception}`` for a task whose run failed.
    """
    out = {}
    if not tasks:
        return out
    cache_dir = getattr(context, "cache_dir", None)
    work = [(tag, (*args, cache_dir)) for tag, args in tasks.items()]
    with make_executor(tasks=len(tasks), **executor_options(context)) as executor:
        for tag, value, error in executor.imap_unordered(predicted_force, work):
            out[tag] = error if error is not None else value
    return out


# ----------------------------------------------------------------------------- separation
def error_model(force, noise_mN: float) -> np.ndarray:
    """sigma_i (mN) of predicted forces: the one error model of every fit,
    :func:`~skin_indent.fitting.error_model.point_sigma` (the noise and the model error in quadrature)."""
    return point_sigma(noise_mN, force)


@dataclass(frozen=True)
class Separation:
    """How far the predicted curves of two explanations lie apart over a candidate's points.

    Attributes
    ----------
    a, b : str
        The two models (``a`` the diagnosis' choice).
    max_difference_mN : float
        The largest difference of the predicted curves, max abs(F_b - F_a) (mN).
    max_difference_noise : float
        The same over the noise.
    separation : float
        S = sqrt(sum (F_b - F_a)^2 / sigma_i^2), sigma_i the error model at (F_a + F_b) / 2.
    points : int
        Points of the candidate.
    repeat : bool
        The candidate is the recorded measurement made again: ``separation`` is what the recorded curve
        already told apart (:func:`repeated`), not the predicted curves' difference.
    """

    a: str
    b: str
    max_difference_mN: float
    max_difference_noise: float
    separation: float
    points: int
    repeat: bool = False

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def separation(a: str, b: str, fa, fb, noise_mN: float) -> Separation:
    """:class:`Separation` of the predicted curves ``fa``, ``fb`` (mN) of the models ``a``, ``b``."""
    fa, fb = np.asarray(fa, dtype=float), np.asarray(fb, dtype=float)
    d = fb - fa
    top = float(np.max(np.abs(d)))
    s = float(np.sqrt(np.sum((d / point_sigma(noise_mN, 0.5 * (fa + fb))) ** 2)))
    return Separation(a, b, top, top / noise_mN, s, int(d.size))


def repeated(s: Separation, chi2_a: float, chi2_b: float, k_a: int, k_b: int) -> Separation:
    """``s`` for the recorded measurement made again, whose curve the two explanations have already met.

    Both models were fitted to the recorded curve, so their predicted curves differ there by what each
    absorbed of it, and ``s.separation`` (the rise before refitting) overstates what a repeat would tell
    apart. Fitted together with the recorded curve, a repeat leaves the values where they are and adds,
    in expectation, the systematic part of the recorded chi-square gap: the gap
    :math:`\chi^2_b - \chi^2_a` (``chi2_a``, ``chi2_b``: the two fits on the recorded curve) less what
    the model with more fitted parameters gained by fitting the noise, one per parameter
    (:math:`E[\chi^2] = n - k` at the truth; a new curve's noise is not the recorded one's). Its
    separation is :math:`S = \sqrt{|\chi^2_b - \chi^2_a - (k_a - k_b)|}` (``k_a``, ``k_b``: the fitted
    parameters).
    """
    gap = abs(float(chi2_b) - float(chi2_a) - (int(k_a) - int(k_b)))
    return dataclasses.replace(s, separation=math.sqrt(gap) if math.isfinite(gap) else math.nan, repeat=True)


# ----------------------------------------------------------------------------- information
@dataclass(frozen=True)
class Block:
    """One curve's rows of a joint fit: its Jacobian and error model.

    Attributes
    ----------
    J : ndarray (n, p)
        dF/dtheta at the fitted values (mN per unit).
    names : tuple of str
        The coordinates of the columns.
    sigma : ndarray (n,)
        Standard deviation of each point (mN).
    own : bool
        The curve's :data:`~skin_indent.effects.DEPTH` coordinates (its contact point)
        are its own, not the model's (every curve but the one the model was fitted to).
    """

    J: np.ndarray
    names: tuple
    sigma: np.ndarray
    own: bool = True


def _stack(rung, blocks, free) -> tuple[np.ndarray, list]:
    """Whitened rows of ``blocks`` over the columns: the rung's ``free`` coordinates, then each block's
    own depth coordinates; and the index (in the rung's vector) of each rung column."""
    depth = {k for e in rung.bound_model.effects if e.stage == DEPTH for k in e.fit_names}
    names = list(rung.bound_model.parameter_names)
    joint = any(split_name(n)[1] is not None for n in names)  # fitted to several curves: offset_mm[2]...
    if joint:  # every curve's contact point is its own column; the shared coordinates are the rung's
        free = [i for i in free if split_name(names[i])[1] is None]
    columns = [names[i] for i in free]
    extra = []
    for k, b in enumerate(blocks):
        if b.own or joint:
            extra += [(k, n) for n in b.names if n in depth and (joint or names.index(n) in free)]
    width = len(columns) + len(extra)
    rows = []
    for k, b in enumerate(blocks):
        R = np.zeros((b.J.shape[0], width))
        for j, n in enumerate(b.names):
            if (k, n) in extra:
                R[:, len(columns) + extra.index((k, n))] = b.J[:, j]
            elif n in columns:
                R[:, columns.index(n)] = b.J[:, j]
        rows.append(R / np.asarray(b.sigma, dtype=float)[:, None])
    return np.vstack(rows), [names.index(n) for n in columns]


def joint_std(rung, blocks, free, prior_terms=(), prior_rows=None) -> dict:
    """Standard deviations of the reported parameters of ``rung`` fitted to every block together.

    Parameters
    ----------
    rung : FitResult
        The fitted model (``bound_model``, ``x``).
    blocks : sequence of Block
        The curves fitted together.
    free : sequence of int
        Indices of the rung's fit coordinates that are fitted (the others held).
    prior_terms : sequence
        The priors ``(g, mean, sd)`` on the model (:meth:`Fitter.prior_terms`).
    prior_rows : callable, optional
        :func:`skin_indent.fitting.knowledge.prior_rows`, needed with priors.

    Returns
    -------
    dict
        ``{reported parameter: standard deviation}`` from cov = (sum_k J_k^T W_k J_k + priors)^-1
        (``inf`` where the information is rank deficient).
    """
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    rows, index = _stack(rung, blocks, free)
    if prior_terms:
        lo, hi = model.bounds
        P = np.zeros((len(prior_terms), rows.shape[1]))
        P[:, :len(index)] = prior_rows(list(prior_terms), x, index, lo, hi)
        rows = np.vstack([rows, P])
    cov_all, _ = jacobian_covariance(rows)
    cov = np.zeros((x.size, x.size))
    cov[np.ix_(index, index)] = cov_all[: len(index), : len(index)]
    return model.reported(x, cov)[1]


def free_columns(rung) -> list[int]:
    """Indices of the fit coordinates a rung's covariance treats as fitted: its free ones,
    without those on a face of their range when its covariance with them free is not finite
    (held there, as :meth:`~skin_indent.fitting.multistart.Fitter.fit` does)."""
    names = list(rung.bound_model.parameter_names)
    cov = getattr(rung, "covariance", None)
    held = set() if cov is not None and np.all(np.isfinite(cov)) else set(getattr(rung, "at_bounds", ()))
    return [names.index(n) for n in rung.free_names if n not in held and n in names]
