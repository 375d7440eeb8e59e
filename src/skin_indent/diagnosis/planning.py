r"""The next measurement: what to measure to settle what a diagnosis left open.

:func:`plan` takes a :class:`~skin_indent.diagnosis.Diagnosis` (or diagnoses the data) and,
for what it could not settle,

- **the explanations it could not separate** (:func:`explanations`: its choice and the
  rivals within :data:`~.workflow.RIVAL` of its BIC, or the first examination's rivals),
- **the parameters it could not determine** (``not_determined`` of its last rung),

ranks the measurements the user can make of the same sample (each sphere radius they own,
a deeper indentation, a hold, another loading speed; the recorded measurement made again is
the yardstick) by what they would separate and determine. It is the diagnosis' own engine
(:mod:`.identifiability`: :func:`~.identifiability.weigh`, :func:`~.identifiability.rank`):
with its default settings the plan reads the :class:`~.outlook.Outlook` the diagnosis
computed (the same next measurement, the same standard deviations, no run made); with other
radii, depths, holds or speeds, or where the diagnosis kept to surfaces and computed no
standard deviation, the same functions weigh them. The statistics:

1. **the separation of the explanations** over the candidate's points, in noise units:
   :math:`S = (\sum_i (F_{b,i} - F_{a,i})^2 / \sigma_i^2)^{1/2}` between the predicted
   curves of the diagnosis' choice :math:`a` and its closest rival :math:`b`
   (:func:`~.separation.separation`; :math:`\sigma_i` the error model of the fits), the
   rise of the chi-square of one explanation if the other is true, before refitting. A
   diagnosis excludes a rival at a BIC gap of :data:`~.workflow.RIVAL`: a candidate with
   :math:`S^2` below it cannot separate them; above it, a joint fit (which refits both and
   absorbs part of :math:`S^2`) will tell;
2. **the expected standard deviation of each undetermined parameter** when the candidate
   is fitted together with the recorded curves (the information matrices summed, from
   finite-element Jacobians of the fitted model at its values, the priors' rows included:
   :mod:`.identifiability`); a parameter is then *determined* below
   :data:`~.outlook.DETERMINED` times its value.

The predicted curves and a figure are written by :func:`skin_indent.report.write_plan`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from ..fitting.model_fit import prepare_curve
from ..measurement.scale import PACKAGE_UNITS
from ..runtime.context import context_of
from ..runtime.json_io import jsonable
from ..runtime.provenance import data_identity, provenance
from . import identifiability
from .identifiability import rank, weigh
from .outlook import TOO_CLOSE, Assessment, Outlook
from .workflow import RIVAL, Diagnosis, diagnose

log = logging.getLogger(__name__)

#: the keywords of a diagnosis that make its context (:func:`~skin_indent.runtime.context.context_of`)
_CONTEXT = ("cache_dir", "workers", "client", "scheduler", "progress")

__all__ = ["BEST", "TOO_CLOSE", "Assessment", "Plan", "explanations", "plan", "recorded"]

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
    """The explanations a diagnosis could not separate, its choice first
    (:func:`~.identifiability.explanations` of its last rung, its rivals within :data:`~.workflow.RIVAL`
    of its BIC, and its first examination). One rung when nothing competes."""
    cur = diag.current
    rivals = sorted((f for f in diag.alternatives if f.bic - cur.bic < RIVAL), key=lambda f: f.bic)
    return identifiability.explanations(cur, bool(diag.missing), rivals, diag.steps[0] if diag.steps else None)


# ----------------------------------------------------------------------------- results
@dataclass
class Plan:
    """The outcome of :func:`plan` (``to_dict`` is the JSON of ``skin-indent plan --json``).

    Attributes
    ----------
    diagnosis : Diagnosis
        What was planned for.
    explanations : list of FitResult
        The explanations it could not separate, its choice first (one: nothing competes).
    undetermined : dict
        ``{parameter: value}`` of its last rung that it could not determine.
    noise_mN : float
        The noise of the first recorded curve, the noise of every candidate (mN).
    outlook : Outlook or None
        What the candidates would separate and determine (:class:`~.outlook.Outlook`): the
        diagnosis' own with the default settings; None when there is nothing to plan.
    notes : list of str
    provenance : dict

    The candidates, best first, are :attr:`ranking` (:func:`~.identifiability.rank`; those that could
    not be predicted last); :attr:`recorded_std` the undetermined parameters' standard deviations from
    the recorded curves alone (finite-element Jacobians at the fitted values, the priors included),
    the yardstick of the candidates' ``std``: the diagnosis reports the same numbers where it
    computed them by finite elements (``std_source``); kept to surfaces (``in_loop=False``), it reports
    the fit's, and both are shown.
    """

    diagnosis: Diagnosis = field(repr=False)
    explanations: list
    undetermined: dict
    noise_mN: float
    outlook: Outlook | None = None
    notes: list = field(default_factory=list)
    provenance: dict = field(default_factory=dict, repr=False)

    @property
    def ranking(self) -> list:
        """The candidates (:class:`~.outlook.Assessment`), best first."""
        return list(self.outlook.ranking) if self.outlook is not None else []

    @property
    def skipped(self) -> dict:
        """``{measurement: why}``: measurements not weighed (a hold where no explanation acts along the
        time history...)."""
        return dict(self.outlook.skipped) if self.outlook is not None else {}

    @property
    def recorded_std(self) -> dict:
        """``{undetermined parameter: sd}`` from the recorded curves alone."""
        got = self.outlook.recorded_std if self.outlook is not None else {}
        return {k: got[k] for k in self.undetermined if k in got}

    @property
    def nothing_to_plan(self) -> bool:
        """The diagnosis settled everything: one explanation, every parameter determined."""
        return len(self.explanations) < 2 and not self.undetermined

    @property
    def rivals(self) -> list:
        return self.explanations[1:]

    def std_of(self, a: Assessment) -> dict:
        """``{undetermined parameter: sd}`` of a candidate fitted with the recorded curves."""
        return {k: a.std[k] for k in self.undetermined if k in a.std}

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
        if s is not None and s.repeat:
            parts.append(f"made again it would add the systematic part of the chi-square gap the recorded curve "
                         f"gives between {s.a} and {s.b}, {s.separation:.3g} noise units"
                         + (", too little to separate them" if a.too_close else ""))
        elif s is not None:
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
                     f"candidate's points, noise units, before refitting; the same sphere again: the systematic "
                     f"part of the recorded chi-square gap; too close below {TOO_CLOSE:.3g}; sd: fitted "
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
            for k, sd in self.std_of(a).items():
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
                    "separations": [s.to_dict() for s in a.separations], "std": self.std_of(a),
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
        Where the runs go and are kept; default one made of ``diagnose_options``' ``workers``,
        ``client``, ``scheduler``, ``cache_dir``, ``progress`` (a diagnosis holds no context: pass
        the one it was made with to plan other settings with its runs' cache).
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
        context = context_of(context, **{k: diagnose_options.pop(k) for k in _CONTEXT if k in diagnose_options})
        diag = diagnose(data, context=context, **diagnose_options)
    curves = recorded(diag)
    noise = curves[0][1]
    rungs = explanations(diag)
    cur = diag.current
    undetermined = {k: float(cur.parameters[k]) for k in diag.not_determined
                    if k in cur.parameters and math.isfinite(cur.parameters[k])}
    notes = [f"{k}: {why}" for k, why in diag.not_determined.items() if k not in undetermined]
    if len(rungs) < 2 and not undetermined:
        return _plan(diag, rungs, {}, None, noise, notes, radii, max_depth_mm, hold_s, speeds)
    outlook = diag.outlook
    defaults = radii is None and max_depth_mm is None and hold_s is None and not speeds
    if not (defaults and outlook is not None and outlook.explanations == [f.model for f in rungs]
            and (outlook.with_std or not undetermined)):  # else: the diagnosis' own outlook, as it ranked it
        if any(f.bound_model is None for f in rungs):
            raise ValueError("this diagnosis holds no fitted models (a batch's light copy): diagnose the curve "
                             "again to plan other measurements")
        outlook = rank(weigh(rungs, cur, [c for c, _ in curves], [n for _, n in curves],
                             with_std=bool(undetermined), priors=diag.priors, mesh=diag.mesh,
                             context=context_of(context), radii=radii, max_depth_mm=max_depth_mm, hold_s=hold_s,
                             speeds=speeds, given=given), undetermined)
    return _plan(diag, rungs, undetermined, outlook, noise, notes, radii, max_depth_mm, hold_s, speeds)


def _plan(diag, rungs, undetermined, outlook, noise, notes, radii, max_depth_mm, hold_s, speeds) -> Plan:
    settings = {"radii_mm": list(radii) if radii is not None else None, "max_depth_mm": max_depth_mm,
                "hold_s": hold_s, "speeds_mm_per_s": list(speeds),
                "diagnosis": dict(diag.provenance.get("settings", {})) if diag.provenance else None}
    prov = provenance(inputs=[data_identity(c) for c, _ in recorded(diag)], settings=settings, api="skin_indent.plan")
    return Plan(diag, list(rungs), dict(undetermined), float(noise), outlook,
                [*notes, *(outlook.notes if outlook else ())], prov)


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
