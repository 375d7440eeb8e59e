"""One model fitted once: the fit of its effects in another order, under the name asked for.

``layer+stiffening`` and ``stiffening+layer`` are one model (:func:`~skin_indent.effects.order.canonical`:
the same force at the same parameters, of the same names). A diagnosis that climbs two explanations
side by side asks for both (issue 39: 144 and 142 finite-element runs for the two fits of the
forearm-like curve, which could end at two optima of one model). The
:class:`~skin_indent.fitting.multistart.Fitter` fits the order it is asked for first, and gives
every other order that fit's numbers, relabelled by :func:`relabelled`: the name and the effects as
asked, its bound model the same elastic cores with the effects in that order, the fitted vector and
every parameter in that model's order. One model and one curve give one set of numbers.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..effects import model_name
from ..models import ComposedModel, JointModel

__all__ = ["relabelled"]


def relabelled(fitter, rung, key: tuple):
    """The fitted ``rung`` under the effects ``key``, the same model in another order.

    Parameters
    ----------
    fitter : Fitter
        Its curves and the effects of each curve's model (:meth:`~.multistart.Fitter.full`).
    rung : FitResult
        The fit of an order of the same effects (:func:`~skin_indent.effects.order.same_model`).
    key : tuple of str
        The effects in the order asked for.

    Returns
    -------
    FitResult or None
        The same numbers (chi-square, residual, parameters and standard deviations, covariance) with
        ``model``, ``effects``, ``bound_model``, ``x``, ``fit_parameters``, ``parameters``, ``std`` and
        ``reported_cov`` in the order of ``key``; ``forward_runs`` those of the fit that gave the numbers
        (relabelling makes none) and ``info["same_fit_as"]`` its model. None when the two models do not
        have the same parameters (then they are not one model: fitted on their own).
    """
    old = rung.bound_model
    if old is None or rung.x is None:
        return None
    parts = old.parts if isinstance(old, JointModel) else [old]
    new = [ComposedModel(p.core, fitter.full(key, k), c) for k, (p, c) in enumerate(zip(parts, fitter.curves))]
    model = new[0] if len(new) == 1 else JointModel(new)
    names = list(model.parameter_names)
    if sorted(names) != sorted(old.parameter_names):
        return None
    x = np.asarray(rung.x, dtype=float)[[old.parameter_names.index(n) for n in names]]
    order = list(model.model_parameters(x))
    if sorted(order) != sorted(rung.parameters):
        return None
    reported, V = rung.reported_cov or ((), np.zeros((0, 0)))
    shown = [k for k in order if k in reported]
    at = [list(reported).index(k) for k in shown]
    return dataclasses.replace(
        rung, model=model_name(key), effects=tuple(key), bound_model=model, x=x,
        fit_parameters={n: rung.fit_parameters[n] for n in names if n in rung.fit_parameters},
        parameters={k: rung.parameters[k] for k in order}, std={k: rung.std[k] for k in order if k in rung.std},
        reported_cov=(tuple(shown), np.asarray(V)[np.ix_(at, at)]),
        info={**(rung.info or {}), "same_fit_as": rung.model})
