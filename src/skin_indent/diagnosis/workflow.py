r"""Diagnose a measured curve: fit, find where the model fails, name the missing effect.

The workflow of :func:`diagnose`:

1. **Compare.** Fit the current model (the neo-Hookean half-space, plus effects
   already added with ``add``) to every segment of the curve (loading, hold,
   unloading: hysteresis, creep and pull-off are evidence).
2. **Where it fails.** Judge the residual against the noise (runs test, Ljung-Box,
   chi-square; :mod:`.residuals`) and describe its structure per segment in words.
3. **Which effect is missing.** Refit the model with each candidate effect added
   (every fit runs on cached response surfaces, so no screening shortcut is needed)
   and rank them by

   .. math::

       \mathrm{BIC} = \frac{n_\mathrm{eff}}{n} \sum_i \frac{r_i^2}{\sigma_i^2} + k \ln n_\mathrm{eff},
       \qquad \sigma_i^2 = \sigma^2 + (\varepsilon F_i)^2,

   where :math:`\sigma` is the noise, :math:`\varepsilon` = :data:`MODEL_ERROR` the
   relative accuracy of the forward model itself (independent FE codes agree with ours
   to 0.08-0.22%), :math:`k` the number of fitted parameters and :math:`n_\mathrm{eff}`
   the AR(1) effective sample size of the residual of the best-fitting model of the
   first examination (the given model and each candidate on top of it). It is computed
   once: every BIC a diagnosis reports, and every comparison it makes (the ladder, the
   candidates, the explanations climbed side by side), uses that one value. An effect
   is named when it lowers the BIC by more than :data:`STRONG` (Kass & Raftery's "very
   strong" evidence); ``ambiguous`` when the runner-up is within :data:`CLOSE` of the
   winner. A runner-up within :data:`RIVAL` is not excluded by the data: it is reported
   in ``confounded_with``, with the measurement that would separate the two,
   quantified from the two fitted models.
4. **Add it.** ``add`` refits with the named effects and reports the ladder: RMS,
   BIC and whiteness at every rung.
5. **Say what was not tried.** When nothing named is missing, the verdict is ``none``
   if the model explains the curve to the noise and ``unexplained`` if it does not.
   Combinations that were not fitted (no response surface covers them and the
   finite-element model in the loop is switched off, a fit that failed, a rung the climb
   reached at ``max_rungs`` and did not examine) are listed in ``untried``, and the
   verdict is then ``provisional``.

The candidates are the registered effects (:data:`skin_indent.effects.EFFECTS`): each
says whether it can show in the data (:meth:`~skin_indent.effects.Effect.visible`: a
viscoelastic effect needs time and a change of rate, adhesion tensile forces...), and
those that cannot are reported as "not detectable here" with the reason; an effect that
is weighed rather than fitted (friction) says what it could change.

Everything is computed by :func:`diagnose`, finite-element runs included (the
standard deviations that decide whether a parameter is determined, the measurement
that would determine it, the measurement that separates two explanations): a
:class:`Diagnosis` is plain data, and its text, sentence, JSON and HTML page show one
set of numbers per model.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import re
from dataclasses import dataclass, field

import numpy as np

from ..effects import EFFECTS, WEIGHED, effect, instances
from ..measurement import SEGMENTS, CurveSet, PreparedCurve
from ..measurement.scale import PACKAGE_UNITS, DisplayUnits, Name, Quantity, UnitText, display_units, shown_in
from .evidence import suggest_measurement
from ..fitting.model_fit import curve_noise, is_several, prepare_curve, prepare_sample, sample_noise
from ..fitting.knowledge import DETERMINED_BY
from ..fitting.scale_checks import contact_points, points_flags
from ..fitting.multistart import MODEL_ERROR, NO_STRUCTURE, Fitter, Rung, evidence
from ..models.composed import at_physical_limit
from .identifiability import ALTERNATIVES, DETERMINED, RECORDED, assess, suggestion
from ..inverse.residuals import effective_sample_size
from ..runtime.context import context_of
from ..runtime.json_io import jsonable
from ..runtime.provenance import records_call

log = logging.getLogger(__name__)

#: BIC drop that names an effect
STRONG = 10.0
#: BIC difference under which two candidates explain the data equally well: ``ambiguous``
#: (Kass & Raftery: less is "not worth more than a bare mention")
CLOSE = 2.0
#: BIC difference under which the runner-up is not excluded: named in ``confounded_with``,
#: with the measurement that would separate it from the winner
RIVAL = 10.0
#: a rung explains the curve when its residual is white and its RMS is within this factor
#: of the noise (noise and model error in quadrature)
ALLOWANCE = 1.3
#: explanations climbed side by side: the best first candidate and the runner-up when it too
#: lowers the BIC by more than :data:`STRONG` (one effect may stand in for two), each up to ``max_rungs``
BEAM = 2
#: how an examination marks a candidate it could not fit (in ``not_detectable``)
NOT_FITTED = "not fitted"




#: ``std_source`` of a standard deviation from the fit's own covariance (its model's Jacobian)
FROM_FIT = "fit"
#: ``std_source`` of a standard deviation from finite-element derivatives at the fitted values
#: (:func:`~.identifiability.assess`, the recorded measurement), which decide whether it is determined
FROM_FE = "finite-element derivatives"


def _fmt_params(f: Rung, units: DisplayUnits) -> str:
    """A rung's parameters as the text of a diagnosis shows them, ``name = value +- sd``, in ``units``
    (names and values as :meth:`~skin_indent.measurement.scale.DisplayUnits.name` and ``factor`` make
    them: ``E_Pa = 203.9 +- 1.9`` at AFM scale for ``E_kPa = 0.2039 +- 0.0019``)."""
    parts = []
    for k, v in f.parameters.items():
        s = f.std.get(k, math.nan)
        name, c = units.name(k), units.factor(k)
        if math.isinf(v):
            parts.append(f"{name} = inf (rigid)")
        else:
            parts.append(f"{name} = {v * c:.4g}" + ("" if not math.isfinite(s) else f" +- {s * c:.2g}"))
    return ", ".join(parts)


def _listed(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


# ----------------------------------------------------------------------------- result
@dataclass
class Diagnosis:
    """The outcome of :func:`diagnose` (``to_dict`` gives the JSON of ``skin-indent diagnose --json``).

    Plain data: :func:`diagnose` computes everything, and every output (:meth:`report`,
    :meth:`sentence`, :meth:`to_dict`, :func:`~.report.write_report`) reads the same rungs,
    one :class:`Rung` per model (its parameters, standard deviations, RMS and BIC).

    The numbers are held in the package units (mm, mN, kPa). :attr:`units` decides, once, the
    units the text, the sentences, the HTML page and the figures show them in: um, nN and Pa for
    an AFM-scale curve, mm, mN and kPa for skin (:func:`~skin_indent.measurement.scale.display_units`
    of the first curve's sphere radius); :meth:`to_dict` (JSON) keeps the package units.

    Attributes
    ----------
    ladder : list of Rung
        From the base model through the effects added by hand to those the climb added;
        ``current`` is the last.
    ranking, not_detectable : list, dict
        The first examination: the candidates on top of the given model.
    verdict : str
        What was missing from the given model: an effect (``"layer"``), several in the
        order they were added (``"offset+layer"``, ``"layer+layer"``); ``"none"`` when the
        given model explains the curve to the noise; ``"unexplained"`` when it does not and
        no effect fitted lowers the BIC by more than :data:`STRONG`; or ``"ambiguous"``
        when another set of effects explains the curve about as well (``confounded_with``
        names them, ``suggested_measurement`` says what separates them). ``provisional``
        says whether combinations were left untried.
    n_effective : float
        The effective sample size of every BIC of the diagnosis (one value).
    steps : list of Step
        Every examination of the climb.
    alternatives : list of Rung
        The end rungs of the other explanations climbed (a beam of :data:`BEAM`).
    explained : bool
        The last rung explains the curve to the noise (:func:`explained`).
    std_source : dict
        Where each standard deviation of the last rung comes from: :data:`FROM_FIT` (the
        fit's covariance) or :data:`FROM_FE` (finite-element derivatives at the fitted
        values, which replace the fit's where they decide whether the parameter is
        determined).
    not_determined : dict
        :meth:`undetermined`.
    notes : list of str
        What the verdict rests on that a reader should know: fewer points in contact than the
        last rung's parameters need to be judged (five per fitted parameter,
        :func:`~skin_indent.fitting.scale_checks.points_flags`); each is also a flag of the
        curve's row in a batch (:func:`~skin_indent.diagnosis.diagnose_many`). A given model with
        more parameters than the points in contact can determine (fewer than ``n_free + 2``) is
        refused (:class:`~skin_indent.measurement.MeasurementError`), and a candidate that has them
        is not fitted (``untried``, with the reason).
    untried : dict
        Combinations of effects (``"layer+layer"``) that were not fitted, with why: every
        examination's candidates that could not be fitted, in every explanation climbed,
        and the candidates on top of a last rung the climb reached at ``max_rungs``
        without examining it.
    """

    data: PreparedCurve
    noise_mN: float
    noise_source: str
    radius_mm: float
    ladder: list
    ranking: list
    not_detectable: dict
    verdict: str
    confounded_with: list
    suggested_measurement: str | None
    n_effective: float
    notes: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    alternatives: list = field(default_factory=list)
    n_given: int = 0
    fitter: object = field(default=None, repr=False)
    explained: bool = False
    std_source: dict = field(default_factory=dict)
    not_determined: dict = field(default_factory=dict)
    untried: dict = field(default_factory=dict)
    #: the finite-element predictions behind ``not_determined`` (:func:`~.identifiability.assess`)
    predictions: list = field(default_factory=list, repr=False)
    #: the candidate effects examined (None: every registered effect)
    candidates: tuple | None = None
    #: how the diagnosis was made (:func:`skin_indent.runtime.provenance.provenance`): the API call
    #: of :func:`diagnose`, its arguments and the curve's data digest
    provenance: dict = field(default_factory=dict, repr=False)
    #: the curves diagnosed, in input order (one: ``[data]``), each curve's noise (mN) and its source
    curves: list = field(default_factory=list, repr=False)
    noises_mN: list = field(default_factory=list)
    noise_sources: list = field(default_factory=list)

    @property
    def current(self) -> Rung:
        return self.ladder[-1]

    @property
    def units(self) -> DisplayUnits:
        """The units the text, sentences, page and figures of the diagnosis are read in: those of the
        scale of its (first) curve's sphere (:func:`~skin_indent.measurement.scale.display_units`: um,
        nN and Pa below a radius of 0.5 mm, else mm, mN and kPa). For several curves of one sample,
        the first curve's scale decides."""
        first = self.curves[0] if self.curves else self.data
        return display_units(float(first.radius_mm))

    @property
    def base(self) -> Rung:
        return self.ladder[0]

    @property
    def surfaces(self) -> tuple:
        """The response surfaces (and finite-element cores) the fits of the diagnosis used, as its
        provenance records them (:func:`~skin_indent.runtime.provenance.surface_identity`)."""
        return self.fitter.cores if self.fitter is not None else ()

    @property
    def missing(self) -> tuple:
        """The effects the climb added to the given model."""
        return tuple(self.current.effects[self.n_given:])

    @property
    def provisional(self) -> bool:
        """Combinations were left untried (``untried``): the verdict holds for what was fitted."""
        return bool(self.untried)

    def undetermined(self) -> dict:
        """Parameters of the last rung the curve does not determine: ``{name: reason}``.

        Not determined: a standard deviation over :data:`~.identifiability.DETERMINED`
        times the value (or not finite), by the fit and, where finite-element runs are
        allowed, by the finite-element derivatives at the fitted values (they decide, and
        they are the standard deviation the last rung reports: ``std_source``); the reason
        then says which other measurement (a larger or smaller sphere to the same depth, a
        deeper indentation) would determine it and to what standard deviation, predicted
        from the fitted model (:func:`~.identifiability.assess`; not made when the diagnosis
        keeps to surfaces, ``in_loop=False``), or that none would. Also a fit parameter on a
        face of its range, unless the face is a physical limit
        (:func:`~skin_indent.models.composed.at_physical_limit`: a rigid base, the nearly
        incompressible end of nu). Computed by :func:`diagnose`.
        """
        return dict(self.not_determined)

    def _tested(self) -> str:
        """``"of the vocabulary"``, or which effects were tested when the candidates were restricted."""
        if self.candidates is None or set(EFFECTS) <= set(self.candidates):
            return "of the vocabulary"
        return f"tested ({', '.join(self.candidates) or 'no candidate was given'})"

    def _untried_clause(self) -> str:
        """``"not tried: a and b (why)[; c (why)]"`` (empty when everything was tried)."""
        groups: dict = {}
        for combo, why in self.untried.items():
            groups.setdefault(why, []).append(combo)
        return "; ".join(f"not tried: {_listed(combos)} ({why})" for why, combos in groups.items())

    def sentence(self, units: DisplayUnits | None = None) -> str:
        """The diagnosis in a few sentences: what is missing, whether the last rung explains the curve,
        what was not tried, and what the curve does not determine (with the standard deviations the
        last rung reports).

        Parameters
        ----------
        units : DisplayUnits, optional
            The units of its numbers and parameter names; default :attr:`units` (the curve's scale).
            :meth:`to_dict` gives the package units
            (:data:`~skin_indent.measurement.scale.PACKAGE_UNITS`).
        """
        u = self.units if units is None else units
        text = self._verdict_sentence(u)
        for reason in self.not_determined.values():
            text += f" {shown_in(reason, u)}."
        return text

    @property
    def joint(self) -> bool:
        """Several curves of one sample were diagnosed together."""
        return len(self.curves) > 1

    @property
    def _these(self) -> str:
        return f"these {len(self.curves)} curves" if self.joint else "this curve"

    def _rms(self, f: Rung, units: DisplayUnits, digits: int = 3) -> str:
        """A rung's RMS as the sentences show it, in ``units.force`` (the unit is not written): each
        curve's, in input order, for several."""
        k = units.per_mN
        if self.joint and len(f.curve_rms_mN) > 1:
            return "(" + ", ".join(f"{v * k:.{digits}g}" for v in f.curve_rms_mN) + ")"
        return f"{f.rms_mN * k:.{digits}g}"

    def _noise(self, units: DisplayUnits, digits: int = 3) -> str:
        """The noise as the sentences show it, in ``units.force`` (each curve's for several)."""
        k = units.per_mN
        if self.joint:
            return "(" + ", ".join(f"{v * k:.{digits}g}" for v in self.noises_mN) + ")"
        return f"{self.noise_mN * k:.{digits}g}"

    def _verdict_sentence(self, u: DisplayUnits) -> str:
        """The verdict in words, its numbers in the units ``u``."""
        cur, base = self.current, self.ladder[self.n_given]
        first = self.steps[0] if self.steps else None
        untried = self._untried_clause()
        structure, suggested = shown_in(cur.structure, u), shown_in(self.suggested_measurement, u)
        F = u.force
        provisional = f" The verdict is provisional: {untried}." if untried else ""
        if not self.missing:
            if self.verdict == "ambiguous" and first is not None:
                effects = [first.ranking[0].effects[-1]] + [f.effects[-1] for f in first.rivals]
                return (f"The {cur.model} model fails ({structure}); {' and '.join(effects)} explain it "
                        f"about equally well: {suggested}" + provisional)
            if self.verdict not in ("none", "unexplained") and first is not None:  # named, not added (max_rungs = 0)
                top = first.ranking[0]
                return (f"The {cur.model} model fails ({structure}); the missing effect is {self.verdict}: "
                        f"adding it lowers the RMS from {self._rms(cur, u)} to {self._rms(top, u)} {F} (noise "
                        f"{self._noise(u)} {F}) and the BIC by {first.rung.bic - top.bic:.1f}." + provisional)
            if self.explained:
                return (f"The {cur.model} model explains {self._these} to the noise level ({self._rms(cur, u)} {F} RMS "
                        f"against {self._noise(u)} {F} noise): no missing effect is needed." + provisional)
            text = (f"The {cur.model} model does not explain {self._these} ({self._rms(cur, u)} {F} RMS against "
                    f"{self._noise(u)} {F} noise; {structure})")
            if untried:
                return (text + f"; of the effects fitted, none lowers the BIC by more than {STRONG:g}, and the verdict "
                        f"is provisional: {untried}.")
            outside = ("outside the vocabulary" if self._tested() == "of the vocabulary"
                       else "not among the effects tested")
            return (text + f", and no effect {self._tested()} lowers the BIC by more than {STRONG:g}: what is "
                    f"missing is {outside}.")
        rms = " -> ".join(self._rms(f, u) for f in self.ladder[self.n_given:])
        what = " and ".join(_plural(self.missing))
        text = f"What the {base.model} model misses: {what} (RMS {rms} {F} against {self._noise(u)} {F} noise)"
        if self.explained:
            text += f"; the {cur.model} model explains {'the curve' if not self.joint else 'every curve'} to the noise."
        elif untried and not any(s.rung.effects == cur.effects for s in self.steps):  # stopped at max_rungs
            text += (f"; the {cur.model} model still leaves a structured residual ({structure}) and was not "
                     f"examined further, so the verdict is provisional: {untried}.")
            untried = ""
        elif untried:
            text += (f"; the {cur.model} model still leaves a structured residual ({structure}); of the effects "
                     f"fitted on top of it, none lowers the BIC by more than {STRONG:g}, and the verdict is "
                     f"provisional: {untried}.")
            untried = ""
        else:
            text += (f"; the {cur.model} model still leaves a structured residual ({structure}) and no further "
                     f"effect {self._tested()} lowers the BIC by more than {STRONG:g}.")
        if self.verdict == "ambiguous" or len(self.confounded_with) > 1:
            others = self.confounded_with[1:]
            text += (f" {' or '.join(others).capitalize()} explains it "
                     f"{'about equally well' if self.verdict == 'ambiguous' else 'nearly as well'}: "
                     f"{suggested}.")
        if untried:
            text += f" The verdict is provisional: {untried}."
        return text

    def report(self, units: DisplayUnits | None = None) -> str:
        """The diagnosis as text (what ``skin-indent diagnose`` prints).

        Parameters
        ----------
        units : DisplayUnits, optional
            The units of its lengths, forces and moduli, and of the parameters' names (``E_Pa``,
            ``offset_um``: :meth:`~skin_indent.measurement.scale.DisplayUnits.name`); default
            :attr:`units`: um, nN and Pa for an AFM-scale curve, mm, mN and kPa for skin. Notes,
            the structure of the residuals and the suggested measurement are written in them too
            (:func:`~skin_indent.measurement.scale.shown_in`).
        """
        u = self.units if units is None else units
        F = u.force
        curves = self.curves or [self.data]
        noises = self.noises_mN or [self.noise_mN]
        sources = self.noise_sources or [self.noise_source]
        lines = [f"{len(curves)} curves of one sample, diagnosed together (the material shared, each curve its own "
                 "sphere, contact point and noise):"] if self.joint else []
        for k, (d, noise, source) in enumerate(zip(curves, noises, sources)):
            head = f"curve {k + 1}: " if self.joint else "data: "
            lines.append(f"{head}{d.source} ({d.n} points" + (f", bins of {d.binned}" if d.binned > 1 else "") + "; "
                         + ", ".join(f"{kind} {np.count_nonzero(d.kind == kind)}"
                                     for kind in ("approach", "hold", "retract") if np.any(d.kind == kind))
                         + f"), sphere R = {d.radius_mm * u.per_mm:g} {u.length}")
            if self.joint:
                lines.append(f"  noise: {noise * u.per_mN:.4g} {F}, {source}")
            if d.baseline is not None:
                lines.append(f"{'  ' if self.joint else ''}baseline force subtracted: {d.baseline_mN * u.per_mN:.4g} "
                             f"{F} at the contact point (pre-contact part)")
            lines += [f"{'  ' if self.joint else ''}note: {shown_in(n, u)}" for n in d.notes]
        errors = (f"model error {100 * MODEL_ERROR:g}% of the force added in quadrature; effective sample size "
                  f"{self.n_effective:.1f} (every BIC below")
        if self.joint:
            lines.append(errors + ", all curves together)")
        else:
            lines.insert(1, f"noise: {self.noise_mN * u.per_mN:.4g} {F}, {self.noise_source}; {errors})")
        lines.append("ladder:" + (" (RMS of each curve, in input order)" if self.joint else ""))
        for f in self.ladder:
            how = f", finite elements in the loop ({f.forward_runs} runs)" if f.forward_runs else ""
            lines.append(f"  {f.model:<28} RMS {self._rms(f, u, 4)} {F}  BIC {f.bic:9.1f}  "
                         f"{'white' if f.white else 'structured'}  {_fmt_params(f, u)}{how}")
        for f in self.alternatives:
            lines.append(f"  (other explanation) {f.model:<20} RMS {self._rms(f, u, 4)} {F}  BIC {f.bic:9.1f}  "
                         f"{'white' if f.white else 'structured'}  {_fmt_params(f, u)}")
        for name, k in self.current.priors.items():
            c = u.factor(name)
            lines.append(f"  what you know, {u.name(name)}: prior {k['prior_mean'] * c:.4g} +- "
                         f"{k['prior_sd'] * c:.2g}, with the data {k['posterior'] * c:.4g} +- "
                         f"{k['posterior_sd'] * c:.2g} ({DETERMINED_BY[k['determined_by']]})"
                         + (f"; IN TENSION with the data ({k['tension_sd']:.1f} combined sd apart)"
                            if k["in_tension"] else ""))
        for name, v in (self.fitter.fixed.items() if self.fitter is not None else ()):
            if name in self.current.parameters:
                lines.append(f"  what you know, {u.name(name)}: held at {v * u.factor(name):g}")
        fe = [u.name(k) for k, v in self.std_source.items() if v == FROM_FE]
        if fe:
            lines.append(f"  standard deviations of {_listed(fe)} ({self.current.model}): {FROM_FE} at the fitted "
                         "values (the others: the fit's covariance)")
        for i, step in enumerate(self.steps):
            lines.append(f"where {step.rung.model} fails: {shown_in(step.rung.structure, u)}")
            lines.append("candidates (delta BIC > 0: better than that model):")
            for f in step.ranking:
                lines.append(f"  +{f.effects[-1]:<13} dBIC {step.rung.bic - f.bic:8.1f}  RMS {self._rms(f, u, 4)} {F}  "
                             f"{'white' if f.white else 'structured'}  {_fmt_params(f, u)}")
            for k, v in step.not_detectable.items():
                if v.startswith("not fitted"):
                    lines.append(f"  +{k:<13} {shown_in(v, u)}")
                elif i == 0:  # what the data cannot show does not change up the ladder
                    lines.append(f"  {k:<14} not detectable here: {shown_in(v, u)}")
        lines.append(f"verdict: {self.verdict}" + (" (provisional)" if self.provisional else ""))
        if self.provisional:
            lines.append(f"provisional: {self._untried_clause()}")
        lines.append(self.sentence(u))
        lines += [f"note: {shown_in(n, u)}" for n in self.notes]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The diagnosis as JSON-safe data (what ``skin-indent diagnose --json`` prints).

        Every number, name and text is in the package units whatever the curve's scale (mm, mN,
        kPa, in the names: ``radius_mm``, ``noise_mN``, ``rms_mN``, ``E_kPa``, ``offset_mm``), so
        that the JSON of AFM-scale and skin-scale curves reads back the same way: the
        ``"sentence"`` is :meth:`sentence` in the package units
        (:data:`~skin_indent.measurement.scale.PACKAGE_UNITS`), and the texts that hold numbers
        (``suggested_measurement``, ``undetermined``, each rung's ``structure``) are written in
        them too, while :meth:`report`, the HTML page and the figures show an AFM-scale curve in
        um, nN and Pa (:attr:`units`) from the same numbers.

        Returns
        -------
        dict
        """
        base, cur = self.base, self.current
        contact = cur.parameters.get("offset_mm", 0.0)

        def sources(f):
            return {k: self.std_source.get(k, FROM_FIT) if f is cur else FROM_FIT for k in f.std}

        def rung(f):
            return {"model": f.model, "effects": list(f.effects), "parameters": f.parameters, "std": f.std,
                    "std_source": sources(f), "rms_mN": f.rms_of_curves, "bic": f.bic, "white": f.white,
                    "structure": f.structure, "forward_runs": f.forward_runs, "at_bounds": list(f.at_bounds),
                    "priors": f.priors}

        def candidate(step, f):
            return {"effect": f.effects[-1], "delta_bic": step.rung.bic - f.bic, **f.summary(),
                    "std_source": sources(f)}

        curves = [{"data": c.source, "n_points": c.n, "binned": c.binned, "radius_mm": c.radius_mm,
                   "noise_mN": s, "noise_source": w, "baseline_mN": c.baseline_mN}
                  for c, s, w in zip(self.curves, self.noises_mN, self.noise_sources)]
        if self.joint:
            head = {"data": [c["data"] for c in curves], "n_points": self.data.n, "curves": curves,
                    "radius_mm": [c["radius_mm"] for c in curves], "noise_mN": list(self.noises_mN),
                    "noise_source": list(self.noise_sources)}
        else:
            head = {"data": self.data.source, "n_points": self.data.n, "binned": self.data.binned,
                    "radius_mm": self.radius_mm, "noise_mN": self.noise_mN, "noise_source": self.noise_source}
        return jsonable({
            **head,
            "bic_formula": Rung.BIC_FORMULA,
            "model_error": MODEL_ERROR,
            "n_effective": self.n_effective,
            **({} if self.joint else {"baseline_mN": self.data.baseline_mN, "contact_point_mm": float(contact)}),
            "fixed": dict(self.fitter.fixed) if self.fitter is not None else {},
            "priors": ({k: list(v) for k, v in self.fitter.priors.items()} if self.fitter is not None else {}),
            "base": rung(base),
            "current": rung(cur),
            "explained": self.explained,
            "missing": list(self.missing),
            "undetermined": self.undetermined(),
            "ranking": [candidate(self.steps[0], f) for f in self.ranking] if self.steps else [],
            "steps": [{"model": st.rung.model, "bic": st.rung.bic, "verdict": st.verdict,
                       "ranking": [candidate(st, f) for f in st.ranking],
                       "not_detectable": dict(st.not_detectable)} for st in self.steps],
            "alternatives": [rung(f) for f in self.alternatives],
            "not_detectable": dict(self.not_detectable),
            "candidates": list(EFFECTS) if self.candidates is None else list(self.candidates),
            "verdict": self.verdict,
            "provisional": self.provisional,
            "untried": list(self.untried),
            "untried_reasons": dict(self.untried),
            "confounded_with": list(self.confounded_with),
            "suggested_measurement": self.suggested_measurement,
            "sentence": self.sentence(PACKAGE_UNITS),
            "ladder": [rung(f) for f in self.ladder],
            "notes": list(self.notes),
            "provenance": dict(self.provenance),
        })


def _contains(big, small) -> bool:
    """Every effect of ``small`` is in ``big`` (as often)."""
    rest = list(big)
    for e in small:
        if e not in rest:
            return False
        rest.remove(e)
    return True


def _plural(effects) -> list[str]:
    """``("layer", "layer", "offset")`` -> ``["2 layers", "offset"]``, in order of first appearance."""
    counts: dict = {}
    for e in effects:
        counts[e] = counts.get(e, 0) + 1
    return [f"{n} {e}s" if n > 1 else e for e, n in counts.items()]


# ----------------------------------------------------------------------------- the workflow
@dataclass
class Step:
    """One examination of a rung: every candidate effect fitted on top of it and ranked.

    Attributes
    ----------
    rung : Rung
        The model examined.
    ranking : list of Rung
        The candidates, best BIC first (``effects[-1]`` is the one added).
    not_detectable : dict
        Candidates that cannot show in these data (or that no fitted model has), with why.
    verdict : str
        The effect named (its BIC lower by more than :data:`STRONG`, no rival within
        :data:`CLOSE`), ``"none"`` or ``"ambiguous"``.
    rivals : list of Rung
        Candidates the data do not exclude (BIC within :data:`RIVAL` of the best).
    """

    rung: Rung
    ranking: list
    not_detectable: dict
    verdict: str
    rivals: list


def explained(rung: Rung, fitter: Fitter) -> bool:
    """A rung explains the curve to the noise: a residual without structure (runs test and
    Ljung-Box at the noise level) and an RMS within :data:`ALLOWANCE` of the noise (noise and
    model error in quadrature). The chi-square part of the whiteness test is this allowance:
    an estimated noise level is itself uncertain by ~12% for 100 points. A borderline test
    (p between alpha / 10 and alpha: 2 tests at alpha = 0.01 flag one clean curve in 50)
    counts only when a range of the curve departs from the model beyond the noise."""
    a = rung.analysis
    p = min(a.runs_p, a.ljung_box_p)
    # borderline tests (alpha / 10 < p <= alpha) count as structure only where a range departs
    structureless = p > a.alpha or (p > a.alpha / 10 and rung.structure == NO_STRUCTURE)
    sigma = fitter.sigma(rung.prediction_mN)
    if not fitter.joint:
        allowed = ALLOWANCE * float(np.sqrt(np.mean(sigma**2)))
        return bool(structureless and rung.rms_mN <= allowed)
    # several curves of one sample: every curve to its own noise (with the model error)
    within = all(rms <= ALLOWANCE * float(np.sqrt(np.mean(sigma[sl] ** 2)))
                 for rms, sl in zip(rung.curve_rms_mN, fitter.data.slices))
    return bool(structureless and within)


def settled(rung: Rung, fitter: Fitter) -> bool:
    """The climb stops at this rung: it explains the curve to the noise (:func:`explained`) and
    no fitted parameter stops at the edge of its range short of a physical limit (e.g. a layer
    as thin as the model solves: a model that explains the curve only from there may stand in
    for another, so the candidates on top of it are examined too, and climbed only when one
    lowers the BIC by :data:`STRONG`)."""
    if not explained(rung, fitter):
        return False
    return all(at_physical_limit(rung.bound_model, rung.x, k) for k in rung.at_bounds)


class Scores:
    """The BIC of every model of one diagnosis, at one effective sample size.

    ``scores(rung)`` is the rung with its BIC (:attr:`Rung.BIC_FORMULA` at ``n_eff``), made once
    per model (set of effects): wherever a diagnosis holds a model, it holds that one rung.

    Parameters
    ----------
    n : int
        Points fitted.
    n_eff : float
        Their effective sample size (:func:`_effective_size`).
    """

    def __init__(self, n: int, n_eff: float):
        self.n, self.n_eff = n, float(n_eff)
        #: ``{effects: rung with its BIC}``
        self.rungs: dict[tuple, Rung] = {}

    def bic(self, f: Rung) -> float:
        return evidence(f.chi2_weighted, f.n_parameters, self.n, self.n_eff)[1]

    def __call__(self, f: Rung) -> Rung:
        got = self.rungs.get(f.effects)
        if got is None:
            got = self.rungs[f.effects] = dataclasses.replace(f, bic=self.bic(f))
        return got


def _examine(fitter: Fitter, key: tuple, candidates, scores: Scores) -> Step:
    """Fit every candidate on top of the rung ``key`` and rank them by BIC."""
    current = fitter.fit(key)
    not_detectable: dict[str, str] = {}
    tried, weighed, wanted = [], [], []
    for name in candidates:
        e = effect(name)
        if name in key and not e.repeatable:
            continue
        why = fitter.visible(e)
        if why is not None:
            not_detectable[name] = why
            continue
        if e.stage == WEIGHED:
            weighed.append(e)  # at the nu of the best-fitting model, below
            continue
        wanted.append(name)
    log.info("examining %s: %d candidate%s on top (%s)", "+".join(("neo-hooke",) + key), len(wanted),
             "s" if len(wanted) != 1 else "", ", ".join(wanted) or "none")
    fitted = fitter.fit_all([key + (name,) for name in wanted])  # the finite-element fits side by side
    for name in wanted:
        f = fitted[key + (name,)]
        if isinstance(f, ValueError):
            not_detectable[name] = f"{NOT_FITTED}: {f}"
        else:
            tried.append(f)
    best = min([current, *tried], key=lambda f: f.chi2_weighted)
    for e in weighed:
        not_detectable[e.name] = e.weigh(fitter, best)
    current = scores(current)
    ranking = sorted((scores(f) for f in tried), key=lambda f: f.bic)
    verdict, rivals = "none", []
    if ranking and current.bic - ranking[0].bic > STRONG:
        top = ranking[0]
        rivals = [f for f in ranking[1:] if f.bic - top.bic < RIVAL and current.bic - f.bic > STRONG]
        verdict = "ambiguous" if any(f.bic - top.bic < CLOSE for f in rivals) else top.effects[-1]
    return Step(current, ranking, not_detectable, verdict, rivals)


def _effective_size(fitter: Fitter, rungs) -> float:
    """AR(1) effective sample size of the best-fitting rung's residual (at least 2 k + 2, at most n)."""
    best = min(rungs, key=lambda f: f.chi2_weighted)
    n = fitter.data.n
    r = best.residual_mN * fitter.noise_mN / fitter.sigma(best.prediction_mN)
    return float(min(max(effective_sample_size(r), 2.0 * max(f.n_parameters for f in rungs) + 2), n))


def _climb(fitter: Fitter, key: tuple, candidates, scores: Scores, rungs_left: int, steps: list) -> tuple:
    """Greedy climb from ``key``: add the named effect while the rung is not :func:`settled`."""
    while rungs_left > 0 and not settled(fitter.fit(key), fitter):
        step = _examine(fitter, key, candidates, scores)
        steps.append(step)
        if step.verdict in ("none", "ambiguous"):
            if step.verdict == "ambiguous":  # the best of the close ones; the comparison is reported
                key = key + (step.ranking[0].effects[-1],)
                rungs_left -= 1
                continue
            break
        key = key + (step.verdict,)
        rungs_left -= 1
    return key


def _fittable(fitter: Fitter, key: tuple, candidates) -> list[str]:
    """The candidates an examination of ``key`` would fit on top of it (visible, fitted, not there unless repeatable)."""
    out = []
    for name in candidates:
        e = effect(name)
        if e.stage != WEIGHED and (name not in key or e.repeatable) and fitter.visible(e) is None:
            out.append(name)
    return out


def _untried(fitter: Fitter, examined, unexamined: tuple | None, candidates, max_rungs: int) -> dict:
    """``{"layer+layer": why}``: the combinations not fitted by the examinations ``examined`` (every
    explanation climbed), and those on top of the last rung ``unexamined`` that the climb reached at
    ``max_rungs`` without examining it (None: none such)."""
    out: dict[str, str] = {}
    for step in examined:
        for name, why in step.not_detectable.items():
            if not why.startswith(NOT_FITTED):
                continue
            why = why[len(NOT_FITTED):].lstrip(": ")
            why = re.sub(r"^the model \S+ could not be fitted$", "the fit failed from every start", why)
            # fewer points in contact than the model's parameters need (Fitter.check_points): one reason for all
            why = re.sub(r"^.*?: (\d+) point\(s\) in contact for \d+ fitted parameter\(s\) of \S+, at least \d+ "
                         r"needed.*$", r"too few points: \1 in contact, fewer than each model's fitted parameters + 2",
                         why)
            if not fitter.in_loop and "in the loop" in why:
                why = ("no response surface combines these effects, and in_loop=False (--surfaces-only) switches "
                       "off the finite-element model in the loop")
            out.setdefault("+".join(step.rung.effects + (name,)), why)
    if unexamined is not None:
        for name in _fittable(fitter, unexamined, candidates):
            out.setdefault("+".join(unexamined + (name,)),
                           f"the climb stopped at max_rungs = {max_rungs} before examining "
                           f"{'+'.join(unexamined) or 'the given model'}")
    return out


def determine(fitter: Fitter, rung: Rung) -> tuple[dict, dict, dict, list]:
    """What the curve determines of a fitted rung (:meth:`Diagnosis.undetermined` of the last one).

    Finite-element runs (:func:`~.identifiability.assess`) are made when ``fitter.in_loop`` allows
    them and a parameter is loose by the fit's own standard deviation; :func:`diagnose` calls this
    once, for the last rung.

    Returns
    -------
    std : dict
        The rung's standard deviations, those of the parameters the fit leaves loose replaced
        by the finite-element ones where these were computed (they decide).
    std_source : dict
        ``{name: FROM_FIT or FROM_FE}``.
    reasons : dict
        ``{name: why not determined}``: :class:`~skin_indent.measurement.scale.UnitText`, in the
        package units as a ``str``, in any units with :func:`~skin_indent.measurement.scale.shown_in`.
    predictions : list of Prediction
        The alternative measurements' predicted standard deviations (:func:`~.identifiability.assess`;
        empty when no finite-element run was allowed or needed).
    """
    std = dict(rung.std)
    source = {k: FROM_FIT for k in std}
    loose = [k for k, v in rung.parameters.items()
             if math.isfinite(v) and not std.get(k, math.nan) <= DETERMINED * abs(v)]
    predictions = []
    if loose and fitter.in_loop and rung.bound_model is not None and rung.x is not None:
        log.info("what the curve determines of %s: %s loose; finite-element sensitivities of %d measurements",
                 rung.model, ", ".join(loose), 1 + len(ALTERNATIVES))
        predictions = assess(fitter, rung, (RECORDED, *ALTERNATIVES))
        recorded = predictions.pop(0).std
        if recorded:  # the finite-element derivatives decide (a surface's slopes can inflate an sd)
            for k in loose:
                if k in recorded:
                    std[k], source[k] = float(recorded[k]), FROM_FE
            loose = [k for k in loose if not std[k] <= DETERMINED * abs(rung.parameters[k])]
    reasons = {k: UnitText("{name} = {value:.3g} +- {sd:.2g}: not determined by this curve{how}", name=Name(k),
                           value=Quantity(rung.parameters[k], k), sd=Quantity(std.get(k, math.nan), k),
                           how=suggestion(k, rung.parameters[k], predictions)) for k in loose}
    for k in rung.at_bounds:
        if at_physical_limit(rung.bound_model, rung.x, k):
            continue
        reasons.setdefault(k, UnitText("{name} = {value:.4g} at the edge of its range: refitted from other starts and "
                                       "still there", name=Name(k), value=Quantity(rung.fit_parameters.get(k, math.nan),
                                                                                   k)))
    return std, source, reasons, predictions


@records_call("skin_indent.diagnose", data="measurement",
              leave_out=("context", "cache_dir", "workers", "client", "scheduler", "progress"))
def diagnose(measurement, *, radius_mm=None, candidates=None, add=(), noise_mN=None,
             segments=SEGMENTS, max_rungs: int = 3, in_loop: bool = True, context=None, mesh: str = "coarse",
             fixed: dict | None = None, priors: dict | None = None, **build) -> Diagnosis:
    """Compare the model with a measured curve, name the effects it misses and add them.

    Parameters
    ----------
    measurement : Measurement or PreparedCurve, or a list of them
        Depth (mm), force (mN) and, if recorded, time (s): every segment is used. A list
        is several curves of ONE sample (two spheres, two depths, two speeds, a ramp and a
        ramp-hold), diagnosed together: the material's and the effects' parameters are
        shared, each curve keeps its own sphere radius, contact point, baseline and noise,
        and every residual is weighed by its own curve's noise; the ladder, the BIC and the
        verdict are computed on all curves together (each rung also reports every curve's
        RMS: :attr:`Rung.curve_rms_mN`).
    radius_mm : float or list of float, optional
        Sphere radius, mm; default the measurement's (else the skin default 6.22 mm). For
        several curves, one per curve (or one for all).
    candidates : sequence of str, optional
        Effects to test (default: every registered effect).
    add : sequence of str
        Effects added to the base model by hand, in order: each is a rung of the
        ladder (``("layer", "layer")``: two layers), and the diagnosis goes on from the last.
    noise_mN : float or list of float, optional
        Noise standard deviation, mN (one per curve for several); default estimated from the data.
    segments : sequence of str
        Kinds of motion to diagnose (default all: ``approach``, ``hold``, ``retract``);
        only trailing ones can be left out.
    max_rungs : int
        Effects the automatic climb may add on top of ``add`` (0: examine the last rung
        and stop). The climb adds the named effect, diagnoses again on top, and stops
        when the rung explains the curve to the noise (:func:`explained`), or no
        candidate lowers the BIC by more than :data:`STRONG`. When the first examination
        names a runner-up too (BIC lower than the model's by more than :data:`STRONG`),
        its branch is climbed as well (a beam of :data:`BEAM`) and the two explanations
        are compared (``alternatives``): within :data:`CLOSE` of each other the verdict
        is ``ambiguous``; within :data:`RIVAL`, the other is named with the measurement
        that would separate them.
    in_loop : bool
        Fit combinations of elastic effects that no response surface covers (two layers,
        layer and stiffening) with the finite-element model in the loop
        (:class:`~skin_indent.models.fe_core.FECore`; tens of forward runs, minutes on 2
        cores each). ``False``: such candidates are reported as not fitted, with the reason.
    context : Context, optional
        Where the response surfaces are cached and built (or the keywords ``cache_dir``,
        ``workers``, ``client``, ``scheduler``, ``progress`` of a :class:`~skin_indent.Context`).
    mesh : str
        Mesh family member of the forward runs. Default ``"coarse"``: it is within
        0.03% of ``"medium"`` at 0.6 mm (the mesh-convergence study of
        ``examples/ex03``), ten times below :data:`MODEL_ERROR`, and layered runs cost
        a third.
    fixed : dict, optional
        What the user knows exactly, by the names results report (``{"thickness_mm": 1.2}``,
        ``{"nu": 0.45}``): held in every model that has the parameter.
    priors : dict, optional
        What the user knows with an uncertainty, ``{name: (mean, sd)}`` (a dermis thickness
        from ultrasound: ``{"thickness_mm": (1.2, 0.1)}``): a Gaussian prior in every model that
        has the parameter (:func:`~skin_indent.fitting.fit_model`); each rung's ``priors`` says
        whether the data or the prior determined it, and whether they agree.

    Returns
    -------
    Diagnosis
    """
    context = context_of(context, **build)
    candidates = tuple(EFFECTS) if candidates is None else tuple(candidates)
    for name in (*candidates, *add):
        effect(name)  # one line naming the vocabulary for an unknown name
    add = tuple(effect(a).name for a in add)
    candidates = tuple(effect(c).name for c in candidates)
    instances(add)  # one line for an effect given twice that cannot repeat
    for name in add:
        if effect(name).stage == WEIGHED:
            raise ValueError(f"add {name}: it is weighed, not fitted; no fitted model has it yet")
    if isinstance(max_rungs, bool) or not isinstance(max_rungs, int) or max_rungs < 0:
        raise ValueError(f"max_rungs must be an integer >= 0, got {max_rungs!r}")
    if is_several(measurement):
        curves = prepare_sample(measurement, radius_mm=radius_mm, segments=segments)
        sigmas, sources = sample_noise(curves, noise_mN)
        data, sigma, source = CurveSet(tuple(curves)), sigmas[0], sources[0]
    else:
        data = prepare_curve(measurement, radius_mm=radius_mm, segments=segments)
        sigma, source = curve_noise(data, noise_mN)
        curves, sigmas, sources = [data], [sigma], [source]
    check_known(fixed, priors, (*candidates, *add), len(curves))
    fitter = Fitter(curves, sigmas, noise_known=noise_mN is not None, context=context, mesh=mesh, in_loop=in_loop,
                    fixed=fixed, priors={k: tuple(v) for k, v in (priors or {}).items()})
    for c, s in zip(curves, sigmas):
        log.info("diagnosing %d points of %s (%s), noise %.3g mN, sphere R = %g mm, mesh %s; finite elements in the "
                 "loop %s", c.n, c.source, ", ".join(segments), s, c.radius_mm, mesh, "allowed" if in_loop else "off")
    for i in range(len(add) + 1):
        fitter.fit(add[:i])

    # the first examination: the candidates on top of the given model; the effective sample size of
    # the best fit there is that of every BIC of the diagnosis (each decision and each number reported)
    fits = [fitter.fit(add)]
    keys = [add + (name,) for name in _fittable(fitter, add, candidates)]
    fits += [f for f in fitter.fit_all(keys).values() if not isinstance(f, ValueError)]
    n_eff = _effective_size(fitter, fits)
    scores = Scores(data.n, n_eff)
    first = _examine(fitter, add, candidates, scores)
    steps = [first]
    examined = [first]  # every examination, in every explanation climbed
    branches = []
    if first.verdict != "none" and max_rungs > 0:
        named = [f for f in first.ranking[1:] if first.rung.bic - f.bic > STRONG]
        heads = [first.ranking[0]] + named[:BEAM - 1]
        for head in heads:
            log.info("climbing from %s (at most %d more rung%s)", head.model, max_rungs - 1,
                     "s" if max_rungs != 2 else "")
            branch_steps = []
            key = _climb(fitter, head.effects, candidates, scores, max_rungs - 1, branch_steps)
            branches.append((key, branch_steps))
            examined += branch_steps
    notes = []
    alternatives = []
    if branches:
        finals = sorted(((scores(fitter.fit(k)), k, st) for k, st in branches), key=lambda t: t[0].bic)
        best_rung, key, more = finals[0]
        steps += more
        # another explanation is a set of effects that neither contains the chosen one nor is
        # contained in it (the same set in another order, or one effect more, is the same explanation)
        alternatives = [f for f, k, _ in finals[1:] if not (_contains(k, key) or _contains(key, k))]
    else:
        key = add
    ladder = [scores(fitter.fit(key[:i])) for i in range(len(key) + 1)]
    missing = key[len(add):]
    verdict, confounded, suggestion = first.verdict, [], None
    if missing and len(steps) > 1:
        # the rivals of the rung that added the last effect (e.g. layer+stiffening against
        # layer+layer on top of one layer): other explanations the data do not exclude
        last = next((s for s in reversed(steps[1:]) if s.ranking and s.ranking[0].effects == key), None)
        if last is not None:
            seen = {tuple(sorted(f.effects)) for f in alternatives} | {tuple(sorted(key))}
            alternatives = alternatives + [scores(f) for f in last.rivals if tuple(sorted(f.effects)) not in seen]
    if missing and explained(ladder[-1], fitter) and not settled(ladder[-1], fitter):
        # the last rung explains the curve only from the edge of a range (a layer as thin as the
        # model solves): a candidate on top of it that explains the curve as well from inside its
        # ranges is another explanation, though it holds the same effects and one more
        top = next((s for s in reversed(steps) if s.rung.effects == key), None)
        if top is not None:
            seen = {tuple(sorted(f.effects)) for f in alternatives}
            alternatives = alternatives + [f for f in top.ranking if settled(f, fitter)
                                           and tuple(sorted(f.effects)) not in seen]
    close = [f for f in alternatives if f.bic - ladder[-1].bic < CLOSE]
    rival_sets = sorted((f for f in alternatives if f.bic - ladder[-1].bic < RIVAL), key=lambda f: f.bic)
    if missing:
        verdict = "ambiguous" if close else "+".join(missing)
    if rival_sets:
        confounded = ["+".join(ladder[-1].effects[len(add):])] + ["+".join(f.effects[len(add):]) for f in rival_sets]
        suggestion = suggest_measurement(fitter, ladder[-1], rival_sets[0])
    elif first.rivals and not missing:
        confounded = [first.ranking[0].effects[-1]] + [f.effects[-1] for f in first.rivals]
        suggestion = suggest_measurement(fitter, first.ranking[0], first.rivals[0])
    is_explained = explained(ladder[-1], fitter)
    if verdict == "none" and not is_explained:
        verdict = "unexplained"  # nothing fitted helps, and the model does not explain the curve
    # what was not tried: candidates not fitted, and those on top of a last rung the climb reached
    # at max_rungs without examining it
    final = ladder[-1]
    unexamined = None
    if not any(s.rung.effects == key for s in examined) and not settled(fitter.fit(key), fitter):
        unexamined = key
    untried = _untried(fitter, examined, unexamined, candidates, max_rungs)

    # the last rung's standard deviations, as they decide what the curve determines (finite-element
    # derivatives where the fit leaves a parameter loose): its one set of numbers everywhere
    std, std_source, not_determined, predictions = determine(fitter, final)
    # fewer points in contact than the last rung's parameters need to be judged (5 each): said in a note
    notes += points_flags(contact_points(data), final.n_free)
    if std != final.std:
        scores.rungs[key] = dataclasses.replace(final, std=std)

    def one(f):  # every rung the diagnosis holds is its model's one scored rung
        return scores.rungs[f.effects]

    steps = [dataclasses.replace(s, rung=one(s.rung), ranking=[one(f) for f in s.ranking],
                                 rivals=[one(f) for f in s.rivals]) for s in steps]
    return Diagnosis(data, sigma, source, data.radius_mm, [one(f) for f in ladder], steps[0].ranking,
                     first.not_detectable, verdict, confounded, suggestion, n_eff, notes, steps=steps,
                     alternatives=[one(f) for f in alternatives], n_given=len(add), fitter=fitter,
                     explained=is_explained, std_source=std_source, not_determined=not_determined,
                     untried=untried, predictions=predictions, candidates=candidates, curves=list(curves),
                     noises_mN=list(sigmas), noise_sources=list(sources))


def check_known(fixed, priors, effects, n_curves: int) -> None:
    """Every name held (``fixed``) or given a prior is a parameter of the base model or of one of the
    ``effects`` (or a curve's own parameter, ``offset_mm[2]``): one line naming the vocabulary otherwise."""
    from ..effects import BASE_PARAMETERS
    from ..effects import numbered
    from ..models.joint import split_name

    names = {p.name for p in BASE_PARAMETERS}
    for e in instances(tuple(dict.fromkeys(effects))):
        for k in range(1, 4):  # up to a third occurrence of a repeatable effect (thickness3_mm)
            names |= {numbered(p.name, k) if k > 1 else p.name for p in e.parameters}
            if not e.repeatable:
                break
    for name in (*(fixed or {}), *(priors or {})):
        base, curve = split_name(name)
        if base not in names or (curve is not None and curve >= n_curves):
            raise ValueError(f"{name}: not a parameter of any model this diagnosis fits (parameters: "
                             f"{', '.join(sorted(names))}" + ("; a curve's own as offset_mm[2]" if n_curves > 1
                                                               else "") + ")")
