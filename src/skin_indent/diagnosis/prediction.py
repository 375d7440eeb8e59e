"""The forces fitted models predict for a measurement, by finite-element runs in the workers.

Every finite-element run of a prediction of the engine of the next measurement
(:func:`~.identifiability.weigh`) goes through :func:`predicted_force` (the fitted model,
its elastic core made by the finite-element model,
:class:`~skin_indent.models.fe_core.FECore`, evaluated on a candidate's points,
:class:`~.measurements.Candidate`, with its Jacobian on request), and the independent runs
go to the workers together (:func:`predict`).
"""

from __future__ import annotations

import numpy as np

from ..effects import DEPTH, Model, instances
from ..models.joint import split_name
from ..models import ComposedModel
from ..models.fe_core import FECore
from ..response_surface.run_cache import RunCache
from ..runtime.executors import make_executor


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
