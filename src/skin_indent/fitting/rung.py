"""One fitted model of a curve, what the :class:`~skin_indent.fitting.multistart.Fitter` makes of each
set of effects it fits (a :class:`~skin_indent.fitting.result.FitResult`, ``Rung`` here by the name a
diagnosis's ladder gives it), and the residual in words.

:func:`evidence` scores a fit (AIC, BIC), :func:`structure_sentence` says where its residual departs
from the noise, :func:`reported_covariance` and :func:`reported_correlations` give its covariance
under the names results report. Every output of a fit or a diagnosis reads these.
"""

from __future__ import annotations

import math

import numpy as np

from ..inverse.residuals import describe_structure
from ..measurement.scale import Quantity, Unit, UnitText, joined
from .error_model import MODEL_ERROR, score as evidence  # noqa: F401 - their names here before error_model
from .result import FitResult
#: the structure sentence of a residual in which no range departs from the model
NO_STRUCTURE = "no range departs from the model beyond the noise"


#: what the :class:`~skin_indent.fitting.multistart.Fitter` makes of each model it fits: the one result
#: of every fit (:class:`~skin_indent.fitting.result.FitResult`), the name the diagnosis's imports use
Rung = FitResult


def reported_covariance(model, x, cov) -> tuple:
    """The covariance of a fit's parameters under the names results report (``ratio``, not the fit's
    ``compliance``), by the delta method: ``(names, V)`` for the finite parameters some coordinate
    with a variance moves (``((), empty)`` where ``cov``, the covariance of the whole vector ``x``, is
    not finite). Held values and infinite ones (a rigid base) are left out."""
    empty = ((), np.zeros((0, 0)))
    if model is None or x is None or cov is None or not hasattr(model, "model_parameters"):
        return empty
    x, C = np.asarray(x, dtype=float), np.asarray(cov, dtype=float)
    if C.shape != (x.size, x.size) or not np.all(np.isfinite(C)):
        return empty
    at = model.model_parameters(x)
    keys = [k for k, v in at.items() if math.isfinite(v)]
    G = np.zeros((len(keys), x.size))
    for j in np.flatnonzero(np.any(C != 0, axis=0)):
        step = 1e-6 * max(abs(x[j]), 1e-6)
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        try:
            with np.errstate(invalid="ignore", over="ignore"):
                a, b = model.model_parameters(up), model.model_parameters(down)
                diffs = [a[k] - b[k] for k in keys]
        except (ValueError, ZeroDivisionError, OverflowError):
            return empty
        G[:, j] = [d / (2 * step) if math.isfinite(d) else 0.0 for d in diffs]
    moving = [i for i in range(len(keys)) if np.any(G[i] != 0)]
    return tuple(keys[i] for i in moving), G[moving] @ C @ G[moving].T


def reported_correlations(rung) -> tuple:
    """The correlations of a rung's parameters under the names results report (``ratio``, not the fit's
    ``compliance``): ``((name, name, r), ...)`` for every pair with a variance, from
    :attr:`~skin_indent.fitting.result.FitResult.reported_cov` (a sign and a size the fit's coordinates need not share: ``ratio`` =
    1 / ``compliance``)."""
    names, V = rung.reported_cov or ((), np.zeros((0, 0)))
    sd = np.sqrt(np.clip(np.diag(V), 0.0, None))
    return tuple((names[p], names[q], float(np.clip(V[p, q] / (sd[p] * sd[q]), -1.0, 1.0)))
                 for p in range(len(names)) for q in range(p + 1, len(names)) if sd[p] > 0 and sd[q] > 0)


def structure_sentence(data, residual, sigma) -> str:
    """Where the residual departs from the noise, per segment, in words.

    Returns
    -------
    str
        :data:`NO_STRUCTURE`, or the ranges where the model is too soft or too stiff (depths, mm;
        times of a hold, s), a :class:`~skin_indent.measurement.scale.UnitText` when it holds
        depths: in package units as a ``str``, in the units of the curve's scale where a text
        shows it (:func:`~skin_indent.measurement.scale.shown_in`).
    """
    parts = []
    noise = float(np.median(sigma))
    for kind, label in (("approach", "loading"), ("hold", "hold"), ("retract", "unloading")):
        sel = data.kind == kind
        if np.count_nonzero(sel) < 5:
            continue
        if kind == "hold" and data.time_s is not None:
            ranges = describe_structure(data.time_s[sel], residual[sel], noise)
            text = [f"too {r['sign'].split()[1]} from {r['from_mm']:.3g} to {r['to_mm']:.3g} s" for r in ranges]
        else:
            ranges = describe_structure(data.depth_mm[sel], residual[sel], noise)
            text = [UnitText("too {sign} from {a:.3g} to {b:.3g} {unit}", sign=r["sign"].split()[1],
                             a=Quantity(r["from_mm"], "from_mm"), b=Quantity(r["to_mm"], "to_mm"), unit=Unit("mm"))
                    for r in ranges]
        if text:
            parts.append(joined("", [f"on {label}: model ", joined(", ", text)]))
    return joined("; ", parts) if parts else NO_STRUCTURE
