r"""The next measurement: what to measure to settle what a diagnosis left open.

:func:`plan` takes a :class:`~skin_indent.diagnosis.Diagnosis` (or diagnoses the data)
and, for what it could not settle,

- **the explanations it could not separate** (:func:`explanations`: its choice and the
  rivals within :data:`~.workflow.RIVAL` of its BIC, or the first examination's rivals),
- **the parameters it could not determine** (``not_determined`` of its last rung),

ranks the measurements the user can make of the same sample (:mod:`.measurements`:
each sphere radius they own, a deeper indentation, a hold, another loading speed; the
recorded measurement made again is the yardstick) by

1. **the separation of the explanations** over the candidate's points, in noise units:
   :math:`S = (\sum_i (F_{b,i} - F_{a,i})^2 / \sigma_i^2)^{1/2}` between the predicted
   curves of the diagnosis' choice :math:`a` and its closest rival :math:`b`
   (:func:`~.measurements.separation`; :math:`\sigma_i` the error model of the fits), the
   rise of the chi-square of one explanation if the other is true, before refitting.
   Reported with it: the largest difference (mN, and over the noise), the statistic of
   the diagnosis' sentence. A diagnosis excludes a rival at a BIC gap of
   :data:`~.workflow.RIVAL`: a candidate with :math:`S^2` below it cannot separate them;
   above it, a joint fit (which refits both and absorbs part of :math:`S^2`) will tell;
2. **the expected standard deviation of each undetermined parameter** when the candidate
   is fitted together with the recorded curves (:func:`~.measurements.joint_std`: the
   information matrices summed, from finite-element Jacobians of the fitted model at its
   values, each curve with its own contact point where the model fits one, the priors'
   rows included); a parameter is then *determined* below
   :data:`~.identifiability.DETERMINED` times its value.

The order: the larger separation first (when explanations compete), then the candidates
that determine more of the undetermined parameters, then the smaller product of the
standard deviations relative to those of the recorded curves alone. Every finite-element
run goes through :func:`~.measurements.predicted_force`, all at once in the workers (the
rivals' forces alone; the Jacobians of the last rung where parameters are undetermined);
the predicted curves and a figure are written by :func:`skin_indent.report.write_plan`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from ..fitting.knowledge import prior_rows
from ..fitting.model_fit import prepare_curve
from ..measurement.scale import PACKAGE_UNITS
from ..models import JointModel
from ..runtime.json_io import jsonable
from ..runtime.provenance import data_identity, provenance
from .identifiability import DETERMINED
from .measurements import Separation
from .measurements import (DEEPER, HOLD_S, Block, Candidate, acts_in_time, base_history, deeper, error_model,
                           free_columns, hold, joint_std, model_of, predict, recorded_history, separation, speed,
                           sphere)
from .workflow import RIVAL, Diagnosis, diagnose

log = logging.getLogger(__name__)

__all__ = ["BEST", "TOO_CLOSE", "Assessment", "Plan", "explanations", "plan", "recorded"]

#: below this separation (noise units) a candidate cannot separate two explanations: its S^2, the
#: chi-square rise before refitting, is under :data:`~.workflow.RIVAL`, the gap at which a diagnosis
#: excludes a rival
TOO_CLOSE = math.sqrt(RIVAL)
#: candidates whose predicted curves :func:`skin_indent.report.write_plan` writes
BEST = 3


# ----------------------------------------------------------------------------- what a diagnosis left open
def recorded(diag) -> list[tuple]:
    """The recorded curves of a diagnosis and their noise: ``[(PreparedCurve, noise_mN), ...]`` in input order.

    A joint diagnosis of several curves holds them as ``curves`` and ``noises_mN``; a
    diagnosis of one curve as ``data`` and ``noise_mN``.
    """
    curves = getattr(diag, "curves", None)
    if curves is not None:
        return list(zip(curves, diag.noises_mN))
    return [(diag.data, float(diag.noise_mN))]


def explanations(diag) -> list:
    """The explanations a diagnosis could not separate, its choice first: the last rung and the
    other explanations within :data:`~.workflow.RIVAL` of its BIC, or, when nothing was added,
    the first examination's best candidate and its rivals. One rung when nothing competes."""
    cur = diag.current
    if diag.missing:
        rivals = sorted((f for f in diag.alternatives if f.bic - cur.bic < RIVAL), key=lambda f: f.bic)
        return [cur, *rivals]
    first = diag.steps[0] if diag.steps else None
    if first is not None and first.rivals:
        return [first.ranking[0], *first.rivals]
    return [cur]


def _indentation(rung, curve, i: int) -> np.ndarray:
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


# ----------------------------------------------------------------------------- results
@dataclass
class Assessment:
    """What one candidate measurement would bring.

    Attributes
    ----------
    candidate : Candidate
    forces : dict
        ``{model: ndarray}``: each explanation's predicted curve at the candidate's points (mN).
    separations : list of Separation
        The choice against each rival (:class:`~.measurements.Separation`).
    std : dict
        ``{parameter: standard deviation}`` of the undetermined parameters of the diagnosis'
        last rung when the candidate is fitted with the recorded curves.
    determines : list of str
        The undetermined parameters it would determine (sd below :data:`DETERMINED` times the value).
    error : str or None
        Why it could not be predicted (a run that did not converge...), else None.
    """

    candidate: Candidate
    forces: dict = field(default_factory=dict, repr=False)
    separations: list = field(default_factory=list)
    std: dict = field(default_factory=dict)
    determines: list = field(default_factory=list)
    error: str | None = None

    @property
    def closest(self) -> Separation | None:
        """The separation of the closest rival (None without rival)."""
        return min(self.separations, key=lambda s: s.separation, default=None)

    @property
    def separation(self) -> float:
        """S of the closest rival (noise units; NaN without rival)."""
        return math.nan if self.closest is None else self.closest.separation

    @property
    def too_close(self) -> bool:
        """S^2 of a rival stays below :data:`~.workflow.RIVAL`: this candidate cannot separate it."""
        return self.closest is not None and self.separation < TOO_CLOSE

    def score(self, recorded_std: dict) -> float:
        """Sum of log(sd with the candidate / sd of the recorded curves alone) over the undetermined
        parameters (lower is better; 0 without any)."""
        out = 0.0
        for k, sd in self.std.items():
            base = recorded_std.get(k, math.nan)
            if math.isfinite(sd) and math.isfinite(base) and sd > 0 and base > 0:
                out += math.log(sd / base)
        return out


@dataclass
class Plan:
    """The outcome of :func:`plan` (``to_dict`` is the JSON of ``skin-indent plan --json``).

    Attributes
    ----------
    diagnosis : Diagnosis
        What was planned for.
    explanations : list of Rung
        The explanations it could not separate, its choice first (one: nothing competes).
    undetermined : dict
        ``{parameter: value}`` of its last rung that it could not determine.
    recorded_std : dict
        Their standard deviations from the recorded curves alone by the plan's own route
        (finite-element Jacobians at the fitted values, the priors included): the yardstick
        of the candidates' ``std``. The diagnosis reports the same numbers where it computed
        them by finite elements (``std_source``); kept to surfaces (``in_loop=False``), it
        reports the fit's, and both are shown.
    noise_mN : float
        The noise of the first recorded curve, the noise of every candidate (mN).
    ranking : list of Assessment
        The candidates, best first; those that could not be predicted last.
    skipped : dict
        ``{measurement: why}``: measurements not weighed (a hold where no explanation acts
        along the time history...).
    notes : list of str
    provenance : dict
    """

    diagnosis: Diagnosis = field(repr=False)
    explanations: list
    undetermined: dict
    recorded_std: dict
    noise_mN: float
    ranking: list
    skipped: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    provenance: dict = field(default_factory=dict, repr=False)

    @property
    def nothing_to_plan(self) -> bool:
        """The diagnosis settled everything: one explanation, every parameter determined."""
        return len(self.explanations) < 2 and not self.undetermined

    @property
    def rivals(self) -> list:
        return self.explanations[1:]

    def best(self, n: int = BEST) -> list:
        """The first ``n`` candidates that could be predicted."""
        return [a for a in self.ranking if a.error is None][:n]

    def sentence(self) -> str:
        """What to measure next, in one sentence."""
        if self.nothing_to_plan:
            return ("Nothing to plan: the diagnosis names one explanation and determines every parameter "
                    f"({self.diagnosis.current.model}).")
        top = self.best(1)
        if not top:
            return "No candidate measurement could be predicted."
        a = top[0]
        parts = []
        s = a.closest
        if s is not None:
            parts.append(f"the predicted curves of {s.a} and {s.b} differ there by {s.separation:.3g} noise units in "
                         f"root-sum-square over its {s.points} points (up to {s.max_difference_mN:.3g} mN, "
                         f"{s.max_difference_noise:.1f} times the noise)"
                         + (", too little to separate them" if a.too_close else ""))
        if self.undetermined:
            if a.determines:
                parts.append("fitted with the recorded curve it would determine "
                             + ", ".join(f"{k} to +- {a.std[k]:.2g}" for k in a.determines))
            left = [k for k in self.undetermined if k not in a.determines]
            if left:
                parts.append("it would leave " + ", ".join(left) + " undetermined")
        return f"Measure next {a.candidate.label}: " + "; ".join(parts) + "."

    def report(self) -> str:
        """The plan as text (what ``skin-indent plan`` prints)."""
        d = self.diagnosis
        lines = []
        for curve, noise in recorded(d):
            lines.append(f"recorded: {curve.source} (sphere R = {curve.radius_mm:g} mm, {curve.n} points to "
                         f"{curve.max_indentation_mm:.3g} mm; noise {noise:.4g} mN)")
        lines.append(f"diagnosis: {d.verdict}" + (" (provisional)" if d.provisional else ""))
        if self.nothing_to_plan:
            lines.append(self.sentence())
            return "\n".join(lines)
        if self.rivals:
            choice = self.explanations[0]
            lines.append(f"explanations not separated: {choice.model} (the diagnosis' choice, BIC {choice.bic:.1f}), "
                         + ", ".join(f"{f.model} (BIC {f.bic:.1f})" for f in self.rivals))
        if self.undetermined:
            cur = d.current
            parts = []
            for k, v in self.undetermined.items():
                said, fe = cur.std.get(k, math.nan), self.recorded_std.get(k, math.nan)
                text = f"{k} = {v:.3g} +- {said:.2g}"
                if math.isfinite(fe) and not math.isclose(fe, said, rel_tol=1e-3):
                    text += f" (+- {fe:.2g} by finite-element derivatives)"
                parts.append(text)
            lines.append(f"not determined ({cur.model}): " + ", ".join(parts))
        lines.append("candidates, best first (S: root-sum-square difference of the predicted curves over the "
                     f"candidate's points, noise units, before refitting, too close below {TOO_CLOSE:.3g}; sd: fitted "
                     "with the recorded curves):")
        for i, a in enumerate(self.ranking, 1):
            ref = " [the recorded measurement again]" if a.candidate.reference else ""
            if a.error is not None:
                lines.append(f"  {i}. {a.candidate.label}{ref}: not predicted ({a.error})")
                continue
            parts = []
            for s in a.separations:
                parts.append(f"{s.b}: S = {s.separation:.3g}, up to {s.max_difference_mN:.3g} mN "
                             f"({s.max_difference_noise:.1f} x noise)" + (", too close" if s.separation < TOO_CLOSE
                                                                          else ""))
            for k, sd in a.std.items():
                parts.append(f"{k} +- {sd:.2g}" + (" (determined)" if k in a.determines else ""))
            lines.append(f"  {i}. {a.candidate.label}{ref}: " + "; ".join(parts))
        for what, why in self.skipped.items():
            lines.append(f"  not weighed: {what} ({why})")
        lines += [f"note: {n}" for n in self.notes]
        lines.append(self.sentence())
        return "\n".join(lines)

    def to_dict(self) -> dict:
        d = self.diagnosis
        choice = self.explanations[0] if self.explanations else d.current

        def assessment(rank, a):
            c = a.candidate
            return {"rank": rank, "kind": c.kind, "label": c.label, "value": c.value, "radius_mm": c.radius_mm,
                    "max_depth_mm": c.max_depth_mm, "points": c.n, "reference": c.reference,
                    "separation": a.separation if a.separations else None, "too_close": a.too_close,
                    "separations": [s.to_dict() for s in a.separations], "std": dict(a.std),
                    "determines": list(a.determines), "error": a.error}

        return jsonable({
            "data": [c.source for c, _ in recorded(d)],
            "radius_mm": [float(c.radius_mm) for c, _ in recorded(d)],
            "noise_mN": self.noise_mN,
            "verdict": d.verdict,
            "nothing_to_plan": self.nothing_to_plan,
            "explanations": [{"model": f.model, "effects": list(f.effects), "parameters": f.parameters,
                              "bic": f.bic, "delta_bic": f.bic - choice.bic} for f in self.explanations],
            "undetermined": {k: {"value": v, "sd": d.current.std.get(k), "sd_recorded": self.recorded_std.get(k)}
                             for k, v in self.undetermined.items()},
            "statistics": {
                "max_difference_mN": "max |F_b - F_a| over the candidate's points",
                "separation": "sqrt(sum (F_b - F_a)^2 / sigma_i^2) over the candidate's points, sigma_i^2 = "
                              "noise^2 + (model_error (F_a + F_b) / 2)^2",
                "too_close": f"separation < sqrt(RIVAL) = {TOO_CLOSE:.4g}: S^2, the chi-square rise before "
                             "refitting, is below the BIC gap at which a diagnosis excludes a rival",
                "std": "sd with the candidate fitted together with the recorded curves (information matrices "
                       "summed, finite-element Jacobians at the fitted values, priors included)",
                "sd_recorded": "the same from the recorded curves alone (the yardstick); sd: as the diagnosis "
                               "reports it"},
            "ranking": [assessment(i, a) for i, a in enumerate(self.ranking, 1)],
            "skipped": dict(self.skipped),
            "notes": list(self.notes),
            "sentence": self.sentence(),
            "diagnosis": d.sentence(PACKAGE_UNITS),
            "provenance": dict(self.provenance),
        })


# ----------------------------------------------------------------------------- the plan
def _candidates(base, *, radii, max_depth_mm, hold_s, speeds, not_in_time: str | None, given: set) -> tuple[list, dict]:
    """The candidates to weigh, and ``{measurement: why not}``. Settings the user gave that cannot be
    made raise ``ValueError``; defaults that cannot be made are skipped; a hold and other speeds are
    weighed unless ``not_in_time`` says why not."""
    R, h = float(base.radius_mm), float(np.max(base.depth_mm))
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


def _check_settings(radii, max_depth_mm, hold_s, speeds) -> None:
    for name, values in (("radii", radii), ("speeds_mm_per_s", speeds)):
        for v in values:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: every value must be a positive number, got {v!r}")
    for name, v in (("max_depth_mm", max_depth_mm), ("hold_s", hold_s)):
        bad = isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0)
        if v is not None and bad:
            raise ValueError(f"{name} must be a positive number, got {v!r}")


def plan(data, *, radii=None, max_depth_mm: float | None = None, hold_s: float | None = None,
         speeds_mm_per_s=(), context=None, **diagnose_options) -> Plan:
    """Rank the measurements that would settle what a diagnosis left open (module docstring).

    Parameters
    ----------
    data : Diagnosis, Measurement or PreparedCurve
        A diagnosis (:func:`~skin_indent.diagnosis.diagnose`), or a curve to diagnose first
        (with ``diagnose_options``).
    radii : sequence of float, optional
        Sphere radii the user owns (mm), each a candidate pressed to the recorded depths;
        default half and twice the recorded radius (of the first curve). The recorded radius
        is always weighed: the measurement made again, the yardstick.
    max_depth_mm : float, optional
        The deepest indentation the user can make with the recorded sphere (mm, deeper than
        the recorded one); default :data:`~.measurements.DEEPER` times the recorded depth.
    hold_s : float, optional
        A hold at the deepest point after the recorded loading (s); default
        :data:`~.measurements.HOLD_S`. Weighed only where an explanation acts along the time
        history (and the curve has time).
    speeds_mm_per_s : sequence of float
        Other loading speeds (mm/s), weighed as the hold.
    context : Context, optional
        Where the runs go; default the diagnosis' (or one made of ``diagnose_options``'
        ``workers``, ``client``, ``scheduler``, ``cache_dir``, ``progress``).
    **diagnose_options
        Passed to :func:`~skin_indent.diagnosis.diagnose` when ``data`` is a curve.

    Returns
    -------
    Plan

    Raises
    ------
    ValueError
        A setting that cannot be made (a radius that is not positive or that the recorded
        depth exceeds, a maximum depth not deeper than the recorded one, a hold or speed not
        positive), said in one line before any diagnosis.
    """
    given = {k for k, v in (("radii", radii), ("max_depth_mm", max_depth_mm), ("hold_s", hold_s)) if v is not None}
    radii = tuple(radii) if radii is not None else None
    speeds = tuple(speeds_mm_per_s or ())
    _check_settings(radii or (), max_depth_mm, hold_s, speeds)
    if isinstance(data, Diagnosis):
        if diagnose_options:
            raise ValueError(f"{', '.join(diagnose_options)}: options of a diagnosis, and a diagnosis was given")
        diag = data
    else:
        _check_reach(data, radii, max_depth_mm, diagnose_options)  # one line before minutes of diagnosis
        diag = diagnose(data, context=context, **diagnose_options)
        context = None
    fitter = diag.fitter
    context = context if context is not None else getattr(fitter, "context", None)
    mesh = getattr(fitter, "mesh", "coarse")
    curves = recorded(diag)
    noise = curves[0][1]
    rungs = explanations(diag)
    cur = diag.current
    undetermined = {k: float(cur.parameters[k]) for k in diag.not_determined
                    if k in cur.parameters and math.isfinite(cur.parameters[k])}
    notes = [f"{k}: {why}" for k, why in diag.not_determined.items() if k not in undetermined]
    if len(rungs) < 2 and not undetermined:
        return _recorded_plan(diag, rungs, {}, {}, noise, [], {}, notes, radii, max_depth_mm, hold_s, speeds)

    choice = rungs[0]
    R = float(curves[0][0].radius_mm)
    radii = (R / 2, 2 * R) if radii is None else radii
    base = base_history(curves[0][0], _indentation(choice, curves[0][0], 0))
    not_in_time = None
    if base.time_s is None:
        not_in_time = "the recorded curve has no time column"
    elif not any(acts_in_time(f.bound_model.effects) for f in rungs):
        not_in_time = "no explanation acts along the time history: their forces do not depend on it"
    candidates, skipped = _candidates(base, radii=radii, max_depth_mm=max_depth_mm, hold_s=hold_s, speeds=speeds,
                                      not_in_time=not_in_time, given=given)

    def force_key(f, k):  # the last rung's force comes with its Jacobian where that is computed
        return ("jacobian", "candidate", k) if undetermined and f is cur else (f.model, "force", k)

    tasks = {}
    for f in rungs:  # the explanations' forces
        if undetermined and f is cur:
            continue
        effects, theta = model_of(f, jacobian=False)
        for k, c in enumerate(candidates):
            tasks[(f.model, "force", k)] = (effects, theta, c.curve, mesh, False)
    if undetermined:  # the last rung's Jacobians: the recorded curves and each candidate
        effects, theta = model_of(cur, jacobian=True)
        for i, (curve, _) in enumerate(curves):
            tasks[("jacobian", "recorded", i)] = (effects, theta, recorded_history(curve, _indentation(cur, curve, i)),
                                                  mesh, True)
        for k, c in enumerate(candidates):
            tasks[("jacobian", "candidate", k)] = (effects, theta, c.curve, mesh, True)
    log.info("planning: %d explanation%s, %d undetermined parameter%s, %d candidates: %d finite-element predictions",
             len(rungs), "s" if len(rungs) != 1 else "", len(undetermined), "s" if len(undetermined) != 1 else "",
             len(candidates), len(tasks))
    got = predict(tasks, context=context)

    def block(key, n, own):
        v = got.get(key)
        return Block(v[1], v[2], error_model(v[0], n), own=own) if isinstance(v, tuple) else None

    terms = fitter.prior_terms(cur.bound_model) if fitter is not None and hasattr(fitter, "prior_terms") else ()
    recorded_std, blocks = {}, []
    if undetermined:
        blocks = [block(("jacobian", "recorded", i), n, i > 0) for i, (_, n) in enumerate(curves)]
        if any(b is None for b in blocks):
            notes.append("the finite-element Jacobian of the recorded curve failed: no standard deviation predicted")
            blocks = []
        else:
            sd = joint_std(cur, blocks, free_columns(cur), terms, prior_rows)
            recorded_std = {k: float(sd[k]) for k in undetermined if k in sd}

    def failure(values):
        err = next(v for v in values if not isinstance(v, tuple))
        return f"{type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''}"

    ranking = []
    for k, c in enumerate(candidates):
        values = [got.get(force_key(f, k)) for f in rungs]
        if any(not isinstance(v, tuple) for v in values):
            ranking.append(Assessment(c, error=failure(values)))
            continue
        a = Assessment(c, forces={f.model: v[0] for f, v in zip(rungs, values)})
        a.separations = [separation(choice.model, f.model, a.forces[choice.model], a.forces[f.model], noise)
                         for f in rungs[1:]]
        if blocks:
            extra = block(("jacobian", "candidate", k), noise, True)
            if extra is None:
                a.error = failure([got.get(("jacobian", "candidate", k))])
            else:
                sd = joint_std(cur, [*blocks, extra], free_columns(cur), terms, prior_rows)
                a.std = {n: float(sd[n]) for n in undetermined if n in sd}
                a.determines = [n for n, v in a.std.items() if v < DETERMINED * abs(undetermined[n])]
        ranking.append(a)
    return _recorded_plan(diag, rungs, undetermined, recorded_std, noise, ranking, skipped, notes, radii,
                          max_depth_mm, hold_s, speeds)


def _rank(ranking: list, recorded_std: dict) -> list:
    """Best first (module docstring); candidates not predicted last."""
    def key(a):
        sep = a.separation if a.separations else 0.0
        return (a.error is None, sep if math.isfinite(sep) else -math.inf, len(a.determines), -a.score(recorded_std))

    return sorted(ranking, key=key, reverse=True)


def _recorded_plan(diag, rungs, undetermined, recorded_std, noise, ranking, skipped, notes, radii, max_depth_mm,
                   hold_s, speeds) -> Plan:
    settings = {"radii_mm": list(radii) if radii is not None else None, "max_depth_mm": max_depth_mm,
                "hold_s": hold_s, "speeds_mm_per_s": list(speeds),
                "diagnosis": dict(diag.provenance.get("settings", {})) if diag.provenance else None}
    prov = provenance(inputs=[data_identity(c) for c, _ in recorded(diag)], settings=settings, api="skin_indent.plan")
    return Plan(diag, list(rungs), dict(undetermined), dict(recorded_std), float(noise), _rank(ranking, recorded_std),
                dict(skipped), list(notes), prov)


def _check_reach(data, radii, max_depth_mm, options) -> None:
    """Settings the recorded depth rules out, said before a diagnosis (its preparation only)."""
    if isinstance(data, (list, tuple)):
        data = data[0]
    prepared = prepare_curve(data, radius_mm=options.get("radius_mm"),
                             segments=options.get("segments", ("approach", "hold", "retract")))
    h, R = float(prepared.max_indentation_mm), float(prepared.radius_mm)
    if max_depth_mm is not None:
        if not max_depth_mm > h * (1 + 1e-9):
            raise ValueError(f"max_depth_mm = {max_depth_mm:g} mm is not deeper than the recorded indentation "
                             f"({h:.3g} mm)")
        if max_depth_mm > R:
            raise ValueError(f"max_depth_mm = {max_depth_mm:g} mm is deeper than the sphere's radius ({R:g} mm)")
    for r in radii or ():
        if h > r:
            raise ValueError(f"radii: the recorded indentation ({h:.3g} mm) is deeper than a sphere of R = {r:g} mm")
