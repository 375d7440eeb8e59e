r"""One engine for "which measurement next, and what would it settle".

The diagnosis' identifiability sentences ("thickness_mm = 1.11 +- 0.9: not determined by this
curve; ... would determine it to +- ..."), its "would separate them" sentence
(:func:`~.evidence.suggest_measurement`) and :func:`~.planning.plan` read ONE computation,
:func:`weigh`, on ONE candidate set (:func:`candidates`), ranked by ONE rule (:func:`rank`):
they cannot disagree. A :func:`~.workflow.diagnose` keeps its outcome (an :class:`~.outlook.Outlook`,
plain data) and :func:`~.planning.plan` with its default settings reads it back.

**The candidates** (:mod:`.measurements`): the recorded history replayed as another
measurement of the same sample would record it: the same sphere again (the yardstick), a
sphere of half and of twice the radius to the same depths, an indentation
:data:`~.measurements.DEEPER` times deeper at the same speed, and, where an explanation acts
along the time history and the curve has time, a :data:`~.measurements.HOLD_S` s hold at the
deepest point (``plan`` takes the radii, depth, hold and speeds a user owns).

**What a candidate would determine.** The standard deviation of a parameter is predicted for
the candidate fitted TOGETHER with the recorded curve(s): that is the fit a user makes once the
new curve is measured (``fit A B --sample``, ``diagnose --sample``), so its standard deviation
is the number that answers "how well would it determine the parameter". The information
matrices of the curves add (the shared parameters; each curve keeps its own contact point where
the fitted model fits one), with the priors' rows,

.. math::

    \mathrm{cov}(\theta) = \Big(\sum_k J_k^T W_k J_k + P^T P\Big)^{-1}, \qquad
    W_k = \mathrm{diag}(1 / \sigma_{k,i}^2), \quad
    \sigma_{k,i}^2 = \sigma_k^2 + (\varepsilon F_{k,i})^2,

(:func:`~.information.joint_std`) with :math:`J_k` the finite-element Jacobian of the fitted
model at its values on curve :math:`k`'s points (:func:`~.prediction.predicted_force`:
direct-differentiation sensitivities, one run per thickness), :math:`\sigma_k` the recorded
noise and :math:`\varepsilon` = :data:`~skin_indent.fitting.error_model.MODEL_ERROR`
(:func:`~skin_indent.fitting.error_model.point_sigma`, the error model of every fit). The candidate
alone would overstate what it leaves undetermined: its correlations differ from the recorded
curve's, and fitted together the two break each other's (on the forearm-like curve a sphere of
twice the radius alone leaves the thickness at +- 0.28 mm, fitted with the recorded curve at
+- 0.06 mm). The recorded curves alone give :attr:`~.outlook.Outlook.recorded_std`, the standard
deviations the diagnosis reports for the parameters its fit leaves loose (a response surface's
interpolated slopes can inflate the fit's). A parameter is *determined* when its standard
deviation is below :data:`~.outlook.DETERMINED` times its value.

**What a candidate would separate**: the predicted curves of the diagnosis' choice and each
rival over the candidate's points (:func:`~.separation.separation`, :math:`S` in noise units).
The same sphere again is the exception: both explanations were fitted to that very curve, so a
repeat adds, in expectation, the chi-square gap the recorded curve already gives, less what the
extra parameters gained by fitting its noise (:func:`~.separation.repeated`), not the difference of
curves each fitted in its own way.

**The order** (:func:`rank`): the larger separation from the closest rival first (when
explanations compete), then the more undetermined parameters determined, then the smaller
product of the standard deviations relative to the recorded curves'. The first is *the next
measurement*, named by the diagnosis and by the plan.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from ..fitting.error_model import point_sigma
from ..fitting.knowledge import prior_rows
from ..measurement.scale import Name, Quantity, UnitText
from ..models import JointModel
from ..models.composed import at_physical_limit
from .criteria import FROM_FE, FROM_FIT
from .information import Block, free_columns, joint_std
from .measurements import (DEEPER, HOLD_S, acts_in_time, base_history, deeper, hold, recorded_history,
                           speed, sphere)
from .prediction import model_of, predict
from .outlook import DETERMINED, Assessment, Outlook
from .separation import repeated, separation

log = logging.getLogger(__name__)

# ----------------------------------------------------------------------------- the candidates
def candidates(base, *, radii=None, max_depth_mm=None, hold_s=None, speeds=(), not_in_time: str | None = None,
               given=frozenset()) -> tuple[list, dict]:
    """The candidates to weigh, and ``{measurement: why not}``.

    Parameters
    ----------
    base : PreparedCurve
        :func:`~.measurements.base_history` of the first recorded curve.
    radii : sequence of float, optional
        Sphere radii (mm); default half and twice the recorded one. The recorded radius is always
        weighed (the yardstick).
    max_depth_mm : float, optional
        Default :data:`~.measurements.DEEPER` times the recorded depth.
    hold_s : float, optional
        Default :data:`~.measurements.HOLD_S`.
    speeds : sequence of float
        Other loading speeds (mm/s).
    not_in_time : str, optional
        Why a hold and other speeds are not weighed (None: they are).
    given : set
        The settings the user gave (``"radii"``, ``"max_depth_mm"``, ``"hold_s"``): those that cannot
        be made raise ``ValueError``; defaults that cannot be made are skipped.
    """
    R, h = float(base.radius_mm), float(np.max(base.depth_mm))
    radii = (R / 2, 2 * R) if radii is None else tuple(radii)
    out, skipped = [], {}

    def add(what, make, strict):
        try:
            c = make()
        except ValueError as err:
            if strict:
                raise
            skipped[what] = str(err)
            return
        if not any(o.kind == c.kind and math.isclose(o.value, c.value, rel_tol=1e-6) for o in out):
            out.append(c)

    for r in [R, *radii]:
        add(f"a sphere of R = {r:g} mm", lambda r=r: sphere(base, r), "radii" in given and r != R)
    depth = DEEPER * h if max_depth_mm is None else max_depth_mm
    add(f"an indentation to {depth:.3g} mm", lambda: deeper(base, depth), "max_depth_mm" in given)
    wanted_hold = HOLD_S if hold_s is None else hold_s
    if not_in_time is None:
        add(f"a {wanted_hold:g} s hold", lambda: hold(base, wanted_hold), "hold_s" in given)
        for v in speeds:
            add(f"a loading speed of {v:g} mm/s", lambda v=v: speed(base, v), True)
    else:
        if "hold_s" in given:
            skipped[f"a {wanted_hold:g} s hold"] = not_in_time
        for v in speeds:
            skipped[f"a loading speed of {v:g} mm/s"] = not_in_time
    return out, skipped


def indentation(rung, curve, i: int) -> np.ndarray:
    """Depth below the contact point (mm) of the points of the ``i``-th recorded curve in the fitted
    rung: its model's own depth stage for the curve it is bound to; for another curve of a joint
    fit, the recorded depth past the curve's contact point as prepared (origin, or first guess)."""
    model = rung.bound_model
    if isinstance(model, JointModel):  # a joint fit: the curve's own model, with its own fitted contact point
        part, x = model.part(i, rung.x)
        return np.asarray(part.evaluate(x).h_mm, dtype=float)
    if getattr(model, "data", None) is curve:
        return np.asarray(model.evaluate(np.asarray(rung.x, dtype=float)).h_mm, dtype=float)
    origin = 0.0 if curve.contact_mode == "origin" else float(curve.contact_guess_mm)
    return np.asarray(curve.depth_mm, dtype=float) - origin


def prior_terms(priors: dict, model) -> list:
    """The priors ``{name: (mean, sd)}`` on reported parameters of ``model`` as ``(g, mean, sd)`` terms
    (:func:`~skin_indent.fitting.knowledge.prior_rows` reads them), ``g(theta)`` the reported parameter."""
    names = model.model_parameters(0.5 * (model.bounds[0] + np.minimum(model.bounds[1], 1e6)))
    return [(lambda theta, k=k: float(model.model_parameters(theta)[k]), float(m), float(sd))
            for k, (m, sd) in (priors or {}).items() if k in names]


def explanations(current, missing: bool, rivals, first) -> list:
    """The explanations a diagnosis could not separate, its choice first.

    Parameters
    ----------
    current : FitResult
        The last rung.
    missing : bool
        The climb added effects to the given model.
    rivals : sequence of FitResult
        The other explanations within :data:`~.criteria.RIVAL` of its BIC, best first.
    first : Step or None
        The first examination.

    Returns
    -------
    list of FitResult
        ``[current, *rivals]`` when the climb added effects; else the first examination's best
        candidate and its rivals when it named any; else ``[current]`` (nothing competes).
    """
    if missing:
        return [current, *rivals]
    if first is not None and first.rivals:
        return [first.ranking[0], *first.rivals]
    return [current]


# ----------------------------------------------------------------------------- the computation
def _failure(values) -> str:
    err = next(v for v in values if not isinstance(v, tuple))
    return f"{type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''}"


def recorded_chi2(rung, noise_mN: float) -> float:
    """The weighted chi-square of ``rung`` on the first recorded curve (the one the candidates replay),
    against the one error model (:func:`~skin_indent.fitting.error_model.point_sigma`)."""
    if rung.prediction_mN is None or rung.residuals_mN is None:
        return float(rung.chi2) if len(rung.prepared) < 2 else math.nan
    r, f = rung.per_curve(rung.residuals_mN)[0], rung.per_curve(rung.prediction_mN)[0]
    return float(np.sum((np.asarray(r) / point_sigma(noise_mN, np.asarray(f))) ** 2))


def weigh(rungs, current, curves, noises, *, with_std: bool, priors=None, mesh: str = "coarse", context=None,
          radii=None, max_depth_mm=None, hold_s=None, speeds=(), given=frozenset()) -> Outlook:
    """Every candidate measurement predicted by the fitted models: separations and standard deviations.

    Parameters
    ----------
    rungs : sequence of FitResult
        The explanations, the choice first (one: only standard deviations are predicted).
    current : FitResult
        The model whose standard deviations are predicted (the diagnosis' last rung).
    curves, noises : sequence
        The recorded curves (PreparedCurve) and their noise (mN), in input order.
    with_std : bool
        Compute the finite-element Jacobians (the standard deviations).
    priors : dict, optional
        ``{name: (mean, sd)}``: the priors of the fits.
    mesh : str
        Mesh of the finite-element runs.
    context : Context, optional
        Where the runs go and are kept (all at once: :func:`~.prediction.predict`).
    radii, max_depth_mm, hold_s, speeds, given
        The candidate settings (:func:`candidates`).

    Returns
    -------
    Outlook
        Its ``ranking`` not yet ranked (:func:`rank` orders it once the undetermined parameters are known).
    """
    choice = rungs[0]
    base = base_history(curves[0], indentation(choice, curves[0], 0))
    not_in_time = None
    if base.time_s is None:
        not_in_time = "the recorded curve has no time column"
    elif not any(acts_in_time(f.bound_model.effects) for f in rungs):
        not_in_time = "no explanation acts along the time history: their forces do not depend on it"
    cands, skipped = candidates(base, radii=radii, max_depth_mm=max_depth_mm, hold_s=hold_s, speeds=speeds,
                                not_in_time=not_in_time, given=given)
    noise = float(noises[0])

    def force_key(f, k):  # the current rung's force comes with its Jacobian where that is computed
        return ("jacobian", "candidate", k) if with_std and f is current else (f.model, "force", k)

    tasks = {}
    for f in rungs:  # the explanations' forces (the predicted curves a plan writes)
        if with_std and f is current:
            continue
        effects, theta = model_of(f, jacobian=False)
        for k, c in enumerate(cands):
            tasks[(f.model, "force", k)] = (effects, theta, c.curve, mesh, False)
    if with_std:  # the current rung's Jacobians: the recorded curves and each candidate
        effects, theta = model_of(current, jacobian=True)
        for i, curve in enumerate(curves):
            tasks[("jacobian", "recorded", i)] = (effects, theta, recorded_history(curve, indentation(current, curve, i)),
                                                  mesh, True)
        for k, c in enumerate(cands):
            tasks[("jacobian", "candidate", k)] = (effects, theta, c.curve, mesh, True)
    log.info("the next measurement: %d explanation%s, %d candidates: %d finite-element predictions", len(rungs),
             "s" if len(rungs) != 1 else "", len(cands), len(tasks))
    got = predict(tasks, context=context)

    def block(key, n, own):
        v = got.get(key)
        return Block(v[1], v[2], point_sigma(n, v[0]), own=own) if isinstance(v, tuple) else None

    terms = prior_terms(priors, current.bound_model) if with_std else ()
    free = free_columns(current) if with_std else []
    notes, recorded_std, blocks = [], {}, []
    if with_std:
        blocks = [block(("jacobian", "recorded", i), n, i > 0) for i, n in enumerate(noises)]
        if any(b is None for b in blocks):
            notes.append("the finite-element Jacobian of the recorded curve failed: no standard deviation predicted")
            blocks = []
        else:
            recorded_std = {k: float(v) for k, v in joint_std(current, blocks, free, terms, prior_rows).items()}
    ranking = []
    for k, c in enumerate(cands):
        values = [got.get(force_key(f, k)) for f in rungs]
        if any(not isinstance(v, tuple) for v in values):
            ranking.append(Assessment(c, error=_failure(values)))
            continue
        a = Assessment(c, forces={f.model: v[0] for f, v in zip(rungs, values)})
        a.separations = [separation(choice.model, f.model, a.forces[choice.model], a.forces[f.model], noise)
                         for f in rungs[1:]]
        if c.reference:  # the recorded curve made again: what it already told apart (separation.repeated)
            a.separations = [repeated(s, recorded_chi2(choice, noise), recorded_chi2(f, noise), choice.n_free, f.n_free)
                             for s, f in zip(a.separations, rungs[1:])]
        if blocks:
            extra = block(("jacobian", "candidate", k), noise, True)
            if extra is None:
                a.error = _failure([got.get(("jacobian", "candidate", k))])
            else:
                sd = joint_std(current, [*blocks, extra], free, terms, prior_rows)
                a.std = {n: float(v) for n, v in sd.items()}
        ranking.append(a)
    settings = {"radii_mm": None if radii is None else list(radii), "max_depth_mm": max_depth_mm, "hold_s": hold_s,
                "speeds_mm_per_s": list(speeds)}
    return Outlook([f.model for f in rungs], current.model, recorded_std, noise, ranking, skipped, notes, settings)


def rank(outlook: Outlook, undetermined: dict) -> Outlook:
    """Order ``outlook.ranking`` (module docstring) for the parameters ``undetermined`` (``{name: value}``),
    each assessment's ``determines`` set; in place, and returned."""
    for a in outlook.ranking:
        a.determines = [n for n, v in undetermined.items()
                        if a.std.get(n, math.inf) < DETERMINED * abs(v)] if a.error is None else []

    def key(a):
        sep = a.separation if a.separations else 0.0
        return (a.error is None, sep if math.isfinite(sep) else -math.inf, len(a.determines),
                -a.score(outlook.recorded_std, undetermined))

    outlook.ranking = sorted(outlook.ranking, key=key, reverse=True)
    return outlook


# ----------------------------------------------------------------------------- what the diagnosis says
def loose(rung, fixed) -> list:
    """Parameters of ``rung`` whose fitted standard deviation is not below :data:`~.outlook.DETERMINED` times the
    value (a value held, ``fixed``, is known, not determined)."""
    return [k for k, v in rung.parameters.items()
            if k not in fixed and math.isfinite(v) and not rung.std.get(k, math.nan) <= DETERMINED * abs(v)]


def suggestion(name: str, value: float, outlook: Outlook | None) -> str:
    """What would determine the parameter ``name`` (value ``value``), as a clause to append.

    Returns
    -------
    str
        ``"; fitted with this curve, <measurement> would determine it to +- <sd>"``: the next
        measurement (``outlook.next``) when it determines the parameter, else the candidate with the
        smallest standard deviation that does (a :class:`~skin_indent.measurement.scale.UnitText`);
        ``"; none of the measurements weighed (...) would determine it"`` when none does; ``""``
        when nothing was computed.
    """
    if outlook is None or not outlook.with_std:
        return ""
    done = [a for a in outlook.ranking if a.error is None and name in a.std]
    if not done:
        return ""
    limit = DETERMINED * abs(value)
    top = outlook.next
    pick = top if top is not None and top.std.get(name, math.inf) < limit else \
        min(done, key=lambda a: a.std[name] if math.isfinite(a.std[name]) else math.inf)
    if pick.std[name] < limit:
        return UnitText("; fitted with this curve, {label} would determine it to +- {sd:.2g}",
                        label=pick.candidate.label, sd=Quantity(pick.std[name], name))
    kinds = {"sphere": "another sphere", "deeper": "a deeper indentation", "hold": "a hold", "speed": "another speed"}
    weighed = list(dict.fromkeys(kinds[a.candidate.kind] for a in done if not a.candidate.reference))
    what = ", ".join(weighed[:-1]) + " or " + weighed[-1] if len(weighed) > 1 else "".join(weighed)
    return f"; fitted with this curve, none of the measurements weighed ({what or 'the same again'}) would determine it"


def determine(rung, fixed, outlook: Outlook | None) -> tuple[dict, dict, dict, dict]:
    """What the curve determines of a fitted rung, from the fit and the engine's :class:`~.outlook.Outlook`.

    Parameters
    ----------
    rung : FitResult
        The diagnosis' last rung (the fit's ``std``, ``at_bounds``).
    fixed : dict
        The values held (known, not determined).
    outlook : Outlook or None
        :func:`weigh` of this rung (None: no finite-element run was allowed or needed).

    Returns
    -------
    std : dict
        The rung's standard deviations, those of the parameters the fit leaves loose replaced by the
        finite-element ones of the recorded curves (``outlook.recorded_std``: they decide).
    std_source : dict
        ``{name: FROM_FIT or FROM_FE}``.
    reasons : dict
        ``{name: why not determined}`` (:class:`~skin_indent.measurement.scale.UnitText`).
    undetermined : dict
        ``{name: value}`` of the parameters not determined (loose, or at the edge of their range)
        that have a finite value: what the outlook is ranked for, what ``plan`` plans for.
    """
    std = dict(rung.std)
    source = {k: FROM_FIT for k in std}
    names = loose(rung, fixed)
    recorded = outlook.recorded_std if outlook is not None else {}
    if recorded:  # the finite-element derivatives decide (a surface's slopes can inflate an sd)
        for k in names:
            if k in recorded:
                std[k], source[k] = float(recorded[k]), FROM_FE
        names = [k for k in names if not std[k] <= DETERMINED * abs(rung.parameters[k])]
    edge = [k for k in rung.at_bounds if k not in names and not at_physical_limit(rung.bound_model, rung.x, k)]
    undetermined = {k: float(rung.parameters[k]) for k in (*names, *edge)
                    if k in rung.parameters and math.isfinite(rung.parameters[k])}
    if outlook is not None:
        rank(outlook, undetermined)
    reasons = {k: UnitText("{name} = {value:.3g} +- {sd:.2g}: not determined by this curve{how}", name=Name(k),
                           value=Quantity(rung.parameters[k], k), sd=Quantity(std.get(k, math.nan), k),
                           how=suggestion(k, rung.parameters[k], outlook)) for k in names}
    for k in edge:
        reasons.setdefault(k, UnitText("{name} = {value:.4g} at the edge of its range: refitted from other starts and "
                                       "still there", name=Name(k), value=Quantity(rung.fit_parameters.get(k, math.nan),
                                                                                   k)))
    return std, source, reasons, undetermined
