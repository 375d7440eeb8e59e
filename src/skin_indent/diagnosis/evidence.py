"""Which measurement would separate two explanations that explain a curve about equally well.

The sentence of a diagnosis (``suggested_measurement``), made by the machinery of
:func:`~skin_indent.diagnosis.planning.plan` (:mod:`.measurements`: the same candidates,
the same finite-element predictions, the same separation), on the diagnosis' three
candidates only (:func:`weighed_candidates`), by the predicted forces alone (no
Jacobian): the diagnosis stays as cheap as two runs per candidate.
"""

from __future__ import annotations

import math

import numpy as np

from ..measurement.scale import Quantity, UnitText
from ..models import JointModel
from .measurements import (DEEPER, HOLD_S, Separation, acts_in_time, base_history, deeper, hold, model_of, predict,
                           separation, sphere)

__all__ = ["compare", "suggest_measurement", "weighed_candidates"]


def weighed_candidates(data, h_mm, rungs) -> list:
    """The measurements a diagnosis weighs: a sphere of half the radius to the same depth, an
    indentation :data:`~.measurements.DEEPER` times deeper with the same sphere, and, where an
    explanation acts along the time history and the curve has time, a
    :data:`~.measurements.HOLD_S` s hold at the deepest point.

    Parameters
    ----------
    data : PreparedCurve
        The recorded curve.
    h_mm : ndarray
        Its points' depth below the contact point in the diagnosis' choice (mm).
    rungs : sequence of Rung
        The explanations.

    Returns
    -------
    list of Candidate
        Those that can be made (a sphere the depth does not exceed).
    """
    base = base_history(data, h_mm)
    R, h = float(base.radius_mm), float(np.max(base.depth_mm))
    out = []
    for make in (lambda: sphere(base, R / 2), lambda: deeper(base, DEEPER * h)):
        try:
            out.append(make())
        except ValueError:  # deeper than the sphere: not a measurement to suggest
            continue
    if base.time_s is not None and any(acts_in_time(f.bound_model.effects) for f in rungs):
        out.append(hold(base, HOLD_S))
    return out


def compare(rungs, candidates, noise_mN: float, *, mesh: str, context=None) -> list[tuple]:
    """How far apart the first explanation and each other one predict each candidate.

    Parameters
    ----------
    rungs : sequence of Rung
        The explanations, the diagnosis' choice first.
    candidates : sequence of Candidate
    noise_mN : float
        The recorded curve's noise (mN).
    mesh : str
        Mesh of the finite-element runs.
    context : Context, optional
        Where the runs go (all at once).

    Returns
    -------
    list of (Candidate, dict, list of Separation)
        Per candidate whose runs all succeeded: the predicted forces ``{model: ndarray}``
        (mN at its points) and the separation of each other explanation from the first.
    """
    tasks = {}
    for f in rungs:
        effects, theta = model_of(f, jacobian=False)
        for k, c in enumerate(candidates):
            tasks[(f.model, k)] = (effects, theta, c.curve, mesh, False)
    got = predict(tasks, context=context)
    out = []
    for k, c in enumerate(candidates):
        values = [got.get((f.model, k)) for f in rungs]
        if any(not isinstance(v, tuple) for v in values):
            continue  # a measurement we cannot predict is not suggested
        forces = {f.model: v[0] for f, v in zip(rungs, values)}
        a = rungs[0].model
        out.append((c, forces, [separation(a, f.model, forces[a], forces[f.model], noise_mN) for f in rungs[1:]]))
    return out


def _names(a, b) -> tuple[str, str]:
    """How the sentence names two explanations: the effect each adds on one rung, else their sets of effects."""
    if len(a.effects) == len(b.effects) and a.effects[:-1] == b.effects[:-1]:
        return a.effects[-1], b.effects[-1]
    return "+".join(a.effects), "+".join(b.effects)


def sentence(candidate, s: Separation, ea: str, eb: str, noise_mN: float) -> str:
    """``"<measurement> would separate <ea> from <eb>: ..."`` with the separation's numbers.

    Parameters
    ----------
    candidate : Candidate
        The measurement (its ``label``: lengths in mm).
    s : Separation
        How far apart the two explanations predict it (the largest difference in mN).
    ea, eb : str
        How the sentence names the two explanations.
    noise_mN : float
        The recorded curve's noise (mN).

    Returns
    -------
    UnitText
        A ``str`` in package units (mm, mN: what JSON keeps) that keeps its numbers, so that the
        text of a diagnosis writes it in the units of the curve's scale
        (:func:`~skin_indent.measurement.scale.shown_in`: um and nN at AFM scale).
    """
    return UnitText("{label} would separate {ea} from {eb}: the fitted models differ there by up to {diff:.3g}, "
                    "{times:.1f} times the noise, and by {separation:.3g} noise units in root-sum-square over its "
                    "{points} points", label=candidate.label, ea=ea, eb=eb, diff=Quantity(s.max_difference_mN, "mN"),
                    times=s.max_difference_mN / noise_mN, separation=s.separation, points=s.points)


def suggest_measurement(fitter, a, b) -> str:
    """Which extra measurement separates two fitted explanations, with the predicted difference.

    The diagnosis' candidates (:func:`weighed_candidates`) are predicted by both fitted
    models (:func:`compare`: finite-element runs at the fitted values, all at once in the
    diagnosis' workers), and the one whose predicted curves lie furthest apart in
    root-sum-square noise units (:func:`~.measurements.separation`) is named, with the
    largest difference (mN, and over the noise).

    Parameters
    ----------
    fitter : Fitter
        The diagnosis' fits (the recorded curve, its noise, the mesh, the context); for several
        curves of one sample, the measurements are of the first curve (its sphere, its history,
        its noise).
    a, b : Rung
        The diagnosis' choice and its rival.

    Returns
    -------
    str
        One sentence (without a final full stop): a
        :class:`~skin_indent.measurement.scale.UnitText` (:func:`sentence`) in package units that
        reads in the units of the curve's scale, or a plain ``str`` when no measurement separates them.
    """
    ea, eb = _names(a, b)
    data, model, x = fitter.data, a.bound_model, a.x
    if isinstance(model, JointModel):  # several curves of one sample: measurements like the first curve
        data = fitter.curves[0]
        model, x = model.part(0, x)
    try:
        h = np.asarray(model.evaluate(x).h_mm, dtype=float)
        candidates = weighed_candidates(data, h, (a, b))
        rows = compare((a, b), candidates, fitter.noise_mN, mesh=fitter.mesh, context=getattr(fitter, "context", None))
    except ValueError:  # no measurement we can predict: none suggested
        rows = []
    rows = [(c, s[0]) for c, _, s in rows if math.isfinite(s[0].separation)]
    if not rows:
        return "no extra measurement computed here separates them"
    c, s = max(rows, key=lambda r: r[1].separation)
    return sentence(c, s, ea, eb, fitter.noise_mN)
