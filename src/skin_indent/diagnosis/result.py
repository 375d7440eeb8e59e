"""The outcome of a diagnosis: :class:`Diagnosis`, its text, sentence and JSON.

A :class:`Diagnosis` is plain data computed by :func:`~.workflow.diagnose`: the ladder of
fitted rungs, the examinations of the climb (:class:`Step`), the verdict and what the
data do not determine. Every output reads the same rungs, one per model, in the units
:attr:`Diagnosis.units` decides once (:mod:`skin_indent.measurement.scale`); the HTML page
and the figures are drawn from it by :mod:`skin_indent.report`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..effects import EFFECTS
from ..measurement import PreparedCurve
from ..measurement.scale import PACKAGE_UNITS, DisplayUnits, display_units, shown_in
from ..fitting.bodies import bodies
from ..fitting.result import FitResult
from ..fitting.rung import MODEL_ERROR
from ..runtime.json_io import jsonable
from .criteria import FROM_FIT
from .segment_misfit import segments_sentence
from .result_text import report_text, verdict_sentence


# ----------------------------------------------------------------------------- result
@dataclass
class Diagnosis:
    """The outcome of :func:`~.workflow.diagnose` (``to_dict`` gives the JSON of ``skin-indent diagnose --json``).

    Plain data: :func:`~.workflow.diagnose` computes everything, and every output (:meth:`report`,
    :meth:`sentence`, :meth:`to_dict`, :func:`~.report.write_report`) reads the same rungs,
    one :class:`FitResult` per model (its parameters, standard deviations, RMS and BIC).

    The numbers are held in the package units (mm, mN, kPa). :attr:`units` decides, once, the
    units the text, the sentences, the HTML page and the figures show them in: um, nN and Pa for
    an AFM-scale curve, mm, mN and kPa for skin (:func:`~skin_indent.measurement.scale.display_units`
    of the first curve's sphere radius); :meth:`to_dict` (JSON) keeps the package units.

    Attributes
    ----------
    ladder : list of FitResult
        From the base model through the effects added by hand to those the climb added;
        ``current`` is the last.
    ranking, not_detectable : list, dict
        The first examination: the candidates on top of the given model.
    verdict : str
        What was missing from the given model: an effect (``"layer"``), several in the
        order they were added (``"offset+layer"``, ``"layer+layer"``); ``"none"`` when the
        given model explains the curve to the noise; ``"unexplained"`` when it does not and
        no effect fitted lowers the BIC by more than :data:`~.criteria.STRONG`; or ``"ambiguous"``
        when another set of effects explains the curve about as well (``confounded_with``
        names them, ``suggested_measurement`` says what separates them). ``provisional``
        says whether combinations were left untried.
    n_effective : float
        The effective sample size of every BIC of the diagnosis (one value).
    steps : list of Step
        Every examination of the climb.
    alternatives : list of FitResult
        The end rungs of the other explanations climbed (a beam of :data:`~.criteria.BEAM`).
    explained : bool
        The last rung explains the curve to the noise (:func:`~.criteria.explained`).
    std_source : dict
        Where each standard deviation of the last rung comes from: :data:`~.criteria.FROM_FIT` (the
        fit's covariance) or :data:`~.criteria.FROM_FE` (finite-element derivatives at the fitted
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
    explained: bool = False
    std_source: dict = field(default_factory=dict)
    not_determined: dict = field(default_factory=dict)
    untried: dict = field(default_factory=dict)
    #: the next measurement (:class:`~.outlook.Outlook`, plain data): every candidate measurement,
    #: what it would separate and determine, ranked; what ``not_determined``, ``suggested_measurement`` and
    #: :func:`~.planning.plan` read (None: nothing competes and nothing was left loose)
    outlook: object = field(default=None, repr=False)
    #: what the user knew: values held ``{name: value}`` and priors ``{name: (mean, sd)}``
    fixed: dict = field(default_factory=dict)
    priors: dict = field(default_factory=dict)
    #: mesh family member of the finite-element runs
    mesh: str = "coarse"
    #: the response surfaces (and finite-element cores) the fits used, as a provenance records them
    #: (:func:`skin_indent.runtime.provenance.surface_identity`)
    surfaces: list = field(default_factory=list, repr=False)
    #: the candidate effects examined (None: every registered effect)
    candidates: tuple | None = None
    #: how the diagnosis was made (:func:`skin_indent.runtime.provenance.provenance`): the API call
    #: of :func:`~.workflow.diagnose`, its arguments and the curve's data digest
    provenance: dict = field(default_factory=dict, repr=False)
    #: the curves diagnosed, in input order (one: ``[data]``), each curve's noise (mN) and its source
    curves: list = field(default_factory=list, repr=False)
    noises_mN: list = field(default_factory=list)
    noise_sources: list = field(default_factory=list)
    #: the instrument's effects named (drag, baselines: :attr:`~skin_indent.effects.Effect.instrument`), in
    #: the order they were added; they are in every rung from ``ladder[n_user + 1]`` on, and never in the
    #: sample's verdict
    instrument: tuple = ()
    #: the examinations that named them (:class:`Step`)
    instrument_steps: list = field(default_factory=list)
    #: what the last rung leaves on each segment of each curve (:class:`~.segment_misfit.SegmentMisfit`)
    segments: list = field(default_factory=list)
    #: effects the user added by hand (``add``); ``n_given`` counts the instrument's too
    n_user: int | None = None

    @property
    def sample_verdict(self) -> str:
        """What the sample misses: :attr:`verdict` (the instrument's effects are never in it)."""
        return self.verdict

    @property
    def instrument_verdict(self) -> str:
        """The instrument's effects named, ``"drag, baselines"``, or ``"none"``."""
        return ", ".join(self.instrument) if self.instrument else "none"

    def verdicts(self) -> str:
        """``"sample: viscoelastic; instrument: drag, baselines"``."""
        return f"sample: {self.verdict}; instrument: {self.instrument_verdict}"

    def segments_sentence(self, units: DisplayUnits | None = None) -> str:
        """What the last rung leaves on each segment (``"approach explained; retract 12x the noise ..."``)."""
        return shown_in(segments_sentence(self.segments, self.joint), self.units if units is None else units) \
            if self.segments else ""

    @property
    def current(self) -> FitResult:
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
    def base(self) -> FitResult:
        return self.ladder[0]

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

        Not determined: a standard deviation over :data:`~.outlook.DETERMINED`
        times the value (or not finite), by the fit and, where finite-element runs are
        allowed, by the finite-element derivatives at the fitted values (they decide, and
        they are the standard deviation the last rung reports: ``std_source``); the reason
        then says which other measurement, fitted with this curve, would determine it and to
        what standard deviation (the next measurement when it does; the numbers
        :func:`~.planning.plan` shows, from the one engine :func:`~.identifiability.weigh`;
        not computed when the diagnosis keeps to surfaces, ``in_loop=False``), or that none
        would. Also a fit parameter on a
        face of its range, unless the face is a physical limit
        (:func:`~skin_indent.models.composed.at_physical_limit`: a rigid base, the nearly
        incompressible end of nu). Computed by :func:`~.workflow.diagnose`.
        """
        return dict(self.not_determined)

    def next_measurement(self) -> dict | None:
        """The next measurement as JSON-safe data (None: nothing competes and nothing was left loose, or
        none could be predicted): the candidate ranked first by the engine (:attr:`outlook`), what it
        would separate (``separation``, noise units) and the standard deviations of the undetermined
        parameters when it is fitted with the recorded curve(s): what :func:`~.planning.plan` ranks first."""
        a = self.outlook.next if self.outlook is not None else None
        if a is None:
            return None
        c = a.candidate
        return {"label": str(c.label), "kind": c.kind, "value": c.value, "radius_mm": c.radius_mm,
                "max_depth_mm": c.max_depth_mm, "separation": a.separation if a.separations else None,
                "std": {k: a.std[k] for k in self.not_determined if k in a.std}, "determines": list(a.determines)}

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
        text = verdict_sentence(self, u)
        if self.instrument:
            text += (f" The instrument's effects ({self.instrument_verdict}) are in every model from "
                     f"{self.ladder[self.n_given].model} on; they are not the sample's.")
        if self.segments and not self.explained:
            text += f" Per segment: {self.segments_sentence(u)}."
        for reason in self.not_determined.values():
            text += f" {shown_in(reason, u)}."
        return text

    @property
    def joint(self) -> bool:
        """Several curves of one sample were diagnosed together."""
        return len(self.curves) > 1

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
        return report_text(self, self.units if units is None else units)

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
                    "priors": f.priors, "flags": list(f.flags)}

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
            "bic_formula": FitResult.BIC_FORMULA,
            "model_error": MODEL_ERROR,
            "n_effective": self.n_effective,
            **({} if self.joint else {"baseline_mN": self.data.baseline_mN, "contact_point_mm": float(contact)}),
            "fixed": dict(self.fixed),
            "priors": {k: list(v) for k, v in self.priors.items()},
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
            "sample": self.verdict,
            "instrument": list(self.instrument),
            "instrument_verdict": self.instrument_verdict,
            "instrument_steps": [{"model": st.rung.model, "bic": st.rung.bic, "verdict": st.verdict,
                                  "ranking": [{**candidate(st, f), "effect": "+".join(f.effects[len(st.rung.effects):])}
                                              for f in st.ranking],
                                  "not_detectable": dict(st.not_detectable)} for st in self.instrument_steps],
            "segments": [m.to_dict() for m in self.segments],
            "provisional": self.provisional,
            "untried": list(self.untried),
            "untried_reasons": dict(self.untried),
            "confounded_with": list(self.confounded_with),
            "suggested_measurement": self.suggested_measurement,
            "next_measurement": self.next_measurement(),
            "sentence": self.sentence(PACKAGE_UNITS),
            "ladder": [rung(f) for f in self.ladder],
            "final_model": bodies(cur),
            "notes": list(self.notes),
            "provenance": dict(self.provenance),
        })


@dataclass
class Step:
    """One examination of a rung: every candidate effect fitted on top of it and ranked.

    Attributes
    ----------
    rung : FitResult
        The model examined.
    ranking : list of FitResult
        The candidates, best BIC first (``effects[-1]`` is the one added).
    not_detectable : dict
        Candidates that cannot show in these data (or that no fitted model has), with why.
    verdict : str
        The effect named (its BIC lower by more than :data:`~.criteria.STRONG`, no rival within
        :data:`~.criteria.CLOSE`), ``"none"`` or ``"ambiguous"``.
    rivals : list of FitResult
        Candidates the data do not exclude (BIC within :data:`~.criteria.RIVAL` of the best).
    """

    rung: FitResult
    ranking: list
    not_detectable: dict
    verdict: str
    rivals: list
