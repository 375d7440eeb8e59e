"""The one result of every fit, :class:`FitResult`: one curve or several curves of one sample, a fit
of :func:`~skin_indent.fitting.fit` or a rung of a diagnosis's ladder.

It is :class:`~skin_indent.inverse.IdentificationResult` with its score, ``aic``, ``bic`` and the
effective sample size ``n_eff`` they are at (:func:`~skin_indent.fitting.error_model.score`): the one
meaning of ``bic`` in every result of a fit and of a diagnosis (a fit alone is scored at its own
residual's ``n_eff``; a diagnosis compares its models at one ``n_eff``, that of the best-fitting),
with the model, how the fit ended, each curve's data treatment and misfit, and what the user knew.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..inverse import IdentificationResult
from ..measurement.scale import Name, Quantity, UnitText, display_units, shown_in
from ..runtime.json_io import jsonable
from .error_model import BIC_FORMULA, effective_n, score
from .knowledge import DETERMINED_BY
from .result_text import curve_dict, report_lines


def scored(chi2: float, whitened_residual, k: int) -> dict:
    """``{"aic", "bic", "n_eff"}`` of a fit alone: its weighted chi-square ``chi2`` at the effective sample
    size of its own residual scaled to the noise (``whitened_residual``, :func:`effective_n`)."""
    n = len(whitened_residual)
    n_eff = effective_n(whitened_residual, k)
    aic, bic = score(chi2, k, n, n_eff)
    return {"aic": aic, "bic": bic, "n_eff": n_eff}


@dataclass(frozen=True, eq=False)
class FitResult(IdentificationResult):
    """The result of every fit of a model: one curve or several curves of one sample, a fit of
    :func:`~skin_indent.fitting.fit` or a rung of a diagnosis's ladder.

    Everything of :class:`~skin_indent.inverse.IdentificationResult` with its score: ``aic``, ``bic``
    (:data:`BIC_FORMULA`: ``chi2`` against the error model, sigma_i of each point) at the effective
    sample size ``n_eff`` (:func:`~skin_indent.fitting.error_model.score`; :meth:`at` another) (``parameters`` and ``std`` as users read them: ``ratio``,
    ``C20_kPa``..., the parameters shared and each curve's own, ``offset_mm[2]``; ``covariance`` and
    ``free_names`` in the fit coordinates ``fit_parameters``; the score ``bic``, :attr:`BIC_FORMULA`,
    at its own ``n_eff`` when fitted, at a diagnosis's common ``n_eff`` in a diagnosis), with the
    model, each curve's data treatment and misfit, how the fit ended, how far the numbers can be
    trusted and what the user knew. One curve is a sample of one: what is per curve is a sequence
    with one entry per curve (``prepared``, ``curves``, ``curve_rms_mN``); :attr:`data`,
    :attr:`radius_mm`, :attr:`contact_point_mm` read the one curve of a fit of one curve.
    ``fit(m, model=X)`` is the rung of ``X`` the :class:`~skin_indent.fitting.multistart.Fitter`
    makes (the same numbers) with its curves bound (:func:`~skin_indent.fitting.model_fit.bound`:
    ``prepared``, ``curves``, Hertz, the quality, the scale checks' flags).

    Attributes
    ----------
    model : str
        ``neo-hooke`` plus ``+effect`` for each effect.
    curves : list of dict
        Per curve, in input order (one curve: one; a rung of a ladder: none): ``data`` (its source),
        ``n_points``, ``radius_mm``, ``radius_source``, ``noise_mN``, ``noise_source``, ``rms_mN``,
        ``misfit`` (RMS over the noise), ``white``, ``contact_mode``, ``contact_point_mm`` and its sd
        (None where the curve starts in contact or the contact point is held), ``baseline_mN``.
    flags : tuple of str
        Why the numbers may not be trusted (how the fit ended, a misfit far above the noise, a prior in
        tension with the data, the scale checks'); empty when there is no such reason.
    notes : list of str
    priors : dict
        Per parameter given a prior: prior, posterior, how much the data narrowed it
        (:func:`~skin_indent.fitting.knowledge.prior_summary`).
    error_model : dict
        How the chi-square and BIC weigh each point (:func:`~skin_indent.fitting.error_model.described`).
    provenance : dict
        How the fit was made (:func:`skin_indent.runtime.provenance.provenance`).
    correlations : tuple or None
        ``((name, name, r), ...)`` under the names ``parameters`` uses (a fit whose parameters are not its
        coordinates: :func:`~skin_indent.fitting.rung.reported_correlations`); None: the fit's own.
    effects : tuple of str
    fit_parameters : dict
        The fitted coordinates (``compliance``, ``C20_over_E``...).
    prediction_mN : ndarray
        The model's force at every fitted point, the curves one after the other (mN;
        :meth:`per_curve` splits it).
    chi2_weighted : float
        Sum of squared residuals over sigma_i^2 (noise and model error).
    white : bool
        The residual passes the whiteness tests at the noise level.
    analysis : ResidualAnalysis
    structure : str
        Where the residual departs from the noise, in words
        (:func:`~skin_indent.fitting.rung.structure_sentence`).
    bound_model : ComposedModel
        The fitted force model, ``x`` its fitted vector.
    forward_runs : int
        Finite-element runs the fit made (the finite-element model in the loop; 0 on surfaces).
    at_bounds : tuple of str
        Fit parameters that ended on a face of their range.
    curve_rms_mN : tuple of float
        The RMS residual of each curve (mN), in input order (one curve: ``(rms_mN,)``).
    curve_white : tuple of bool
        Whether each curve's residual passes the whiteness tests on its own (several curves).
    ended : tuple of Ending
        How the fit ended where that is not a result (:func:`~skin_indent.fitting.ended.how_it_ended`:
        its evaluation budget, its start values, a parameter at the edge of its surface or at a bound);
        ``flags`` their texts, :attr:`moved` whether it left its start.
    reported_cov : tuple
        ``(names, V)``: the covariance of ``parameters`` by the names results report
        (:func:`~skin_indent.fitting.rung.reported_covariance`): the correlations reports list, and
        quantities derived from several parameters (:func:`~skin_indent.fitting.bodies.bodies`).
    prepared : tuple of PreparedCurve
        Each curve's segments, baseline, contact guess and fitted points, in input order (empty for a
        rung of a ladder, whose curves are the diagnosis's).
    e_star_kPa, e_star_std_kPa : float
        E* = E / (1 - nu^2) of the (top) material (kPa) and its standard error.
    hertz : dict
        Hertz's small-strain fit of the loading points of a fit of one curve: ``E_star_kPa``,
        ``E_star_std_kPa``, ``contact_point_mm``, ``rms_mN`` (empty for several curves).
    quality : dict
        Of a fit of one curve: ``noise_mN`` independent of the model and its ``noise_source``,
        ``misfit`` (RMS / noise), ``white``, ``verdict`` (:func:`~skin_indent.fitting.curve.quality`;
        several curves: each curve's in ``curves``).
    surface : dict or list of dict
        Identity of the response surfaces used (``hash``, ``settings``; a list for a model's fit: every
        elastic force model its fits used, :func:`~skin_indent.runtime.provenance.surface_identity`).
    """

    BIC_FORMULA = BIC_FORMULA

    aic: float = math.nan
    bic: float = math.nan
    n_eff: float = math.nan
    model: str = "neo-hooke"
    curves: list = field(default_factory=list)
    flags: tuple = ()
    notes: list = field(default_factory=list)
    priors: dict = field(default_factory=dict)
    error_model: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict, repr=False)
    correlations: tuple | None = None
    effects: tuple = ()
    fit_parameters: dict = field(default_factory=dict)
    prediction_mN: np.ndarray = None
    chi2_weighted: float = math.nan
    white: bool = False
    analysis: object = None
    structure: str = ""
    bound_model: object = field(default=None, repr=False)
    x: np.ndarray = None
    forward_runs: int = 0
    at_bounds: tuple = ()
    curve_rms_mN: tuple = ()
    curve_white: tuple = ()
    ended: tuple = ()
    reported_cov: tuple = ()
    prepared: tuple = ()
    e_star_kPa: float = math.nan
    e_star_std_kPa: float = math.nan
    hertz: dict = field(default_factory=dict)
    quality: dict = field(default_factory=dict)
    surface: dict | list = field(default_factory=dict)

    def criteria(self) -> dict:
        return {"aic": self.aic, "bic": self.bic, "n_eff": self.n_eff, "bic_formula": self.BIC_FORMULA,
                "aic_ml": self.aic_ml, "bic_ml": self.bic_ml, "bic_ml_formula": self.BIC_ML_FORMULA}

    def at(self, n_eff: float) -> "FitResult":
        """This result scored at another effective sample size (a diagnosis's, to compare it with its models)."""
        aic, bic = score(self.chi2, self.n_free, self.n_points, n_eff)
        return dataclasses.replace(self, aic=aic, bic=bic, n_eff=float(n_eff))

    def criteria_line(self, digits: int = 5) -> str:
        return (f"    AIC        = {self.aic:.{digits}g}, BIC = {self.bic:.{digits}g} (against the error model, "
                f"n_eff = {self.n_eff:.4g})")

    def correlation_pairs(self) -> list:
        """The correlations :meth:`report` lists, under the names ``parameters`` uses."""
        return super().correlation_pairs() if self.correlations is None else list(self.correlations)

    @property
    def trusted(self) -> bool:
        """Converged and no flag."""
        return self.success and not self.flags

    @property
    def moved(self) -> bool:
        """The fit left its start values (a fit that did not move decides nothing)."""
        return not any(e.kind == "start" for e in self.ended)

    @property
    def residual_mN(self) -> np.ndarray:
        return self.residuals_mN

    @property
    def n_parameters(self) -> int:
        return self.n_free

    # ------------------------------------------------------------------ per curve
    def per_curve(self, values) -> list:
        """``values`` at every fitted point (``residuals_mN``, ``prediction_mN``) split per curve, in
        input order (one curve: all of them, whatever points it fitted)."""
        values = np.asarray(values)
        if len(self.prepared) < 2:
            return [values]
        cuts = np.cumsum([p.n for p in self.prepared])
        if cuts[-1] != values.size:
            raise ValueError(f"the fit has {values.size} values for {cuts[-1]} prepared points")
        return np.split(values, cuts[:-1])

    def _one(self, what: str, key: str):
        """``key`` of the one curve's summary (a fit of several curves has one per curve, in ``curves``)."""
        if len(self.curves) != 1:
            raise ValueError(f"a fit of {len(self.curves)} curves has no one {what}: each curve's is "
                             f"curves[k][{key!r}]")
        return self.curves[0][key]

    @property
    def data(self):
        """The prepared curve of a fit of one curve (several curves: ``prepared``, one per curve)."""
        if len(self.prepared) != 1:
            raise ValueError(f"a fit of {len(self.prepared)} curves has no one curve: each is prepared[k]")
        return self.prepared[0]

    @property
    def radius_mm(self) -> float:
        """Sphere radius of a fit of one curve (mm)."""
        return self._one("sphere radius", "radius_mm")

    @property
    def contact_point_mm(self) -> float:
        """Contact point of a fit of one curve (recorded depth, mm)."""
        return self._one("contact point", "contact_point_mm")

    @property
    def contact_point_std_mm(self) -> float | None:
        """Its standard error (mm; None where it is not fitted)."""
        return self._one("contact point", "contact_point_std_mm")

    @property
    def max_depth_ratio(self) -> float:
        """Deepest indentation over the radius, h/R, at the fitted contact point (one curve)."""
        return float((self.data.depth_mm.max() - self.contact_point_mm) / self.radius_mm)

    @property
    def fe_vs_hertz_percent(self) -> float:
        """100 (E*_FE / E*_Hertz - 1): what small-strain Hertz misses at this depth (one curve)."""
        return 100.0 * (self.e_star_kPa / self.hertz["E_star_kPa"] - 1.0)

    @property
    def rms_of_curves(self):
        """The RMS residual (mN) as outputs report it: a number for one curve, a list in input order for
        several curves of one sample."""
        rms = self.curve_rms_mN or tuple(c["rms_mN"] for c in self.curves)
        return [float(v) for v in rms] if len(rms) > 1 else self.rms_mN

    # ------------------------------------------------------------------ outputs
    def summary(self) -> dict:
        """JSON-safe summary of the fit as a ladder lists it."""
        return jsonable({"model": self.model, "parameters": self.parameters, "std": self.std,
                         "rms_mN": self.rms_of_curves, "bic": self.bic, "white": self.white,
                         "n_parameters": self.n_parameters, "structure": self.structure, "priors": self.priors,
                         "flags": list(self.flags)})

    def to_dict(self) -> dict:
        """The identification's JSON summary, its score, what every fit reports and each curve's data
        treatment (one curve: in full, :func:`~skin_indent.fitting.result_text.curve_dict`) (JSON-safe)."""
        out = super().to_dict()
        out.update({"model": self.model, "curves": [dict(c) for c in self.curves], "flags": list(self.flags),
                    "notes": [str(n) for n in self.notes], "priors": dict(self.priors),
                    "error_model": dict(self.error_model), "provenance": dict(self.provenance),
                    # under the names ``parameters`` uses (``covariance`` is in the fit's coordinates)
                    "correlations": [{"a": a, "b": b, "r": r} for a, b, r in self.correlation_pairs()]})
        if len(self.prepared) == 1:
            out.update(curve_dict(self))
        elif self.prepared:
            out.update({"rms_mN": self.rms_of_curves, "rms_all_mN": self.rms_mN})
        return jsonable(out)

    def report(self, digits: int = 5, units=None) -> str:
        """Readable summary: each curve's data treatment, the fit and its parameters, each curve's
        quality, flags and notes.

        Lengths, forces and moduli are shown in ``units``
        (:class:`~skin_indent.measurement.scale.DisplayUnits`), default the units of the (first)
        curve's scale (:func:`~skin_indent.measurement.scale.display_units`: um, nN and Pa for an
        AFM-scale sphere, mm, mN and kPa for skin), notes and flags too; :meth:`to_dict` keeps the
        package units. A rung of a ladder (no curves bound): the identification's report.
        """
        if not self.prepared:
            return super().report(digits, units=units)
        u = units or display_units(self.curves[0]["radius_mm"])
        head, tail = report_lines(self, u)
        lines = [*head, super().report(digits, units=u), *tail]
        lines.extend(f"flag: {shown_in(f, u)}" for f in self.flags)
        lines.extend(f"note: {shown_in(n, u)}" for n in self.notes)
        return "\n".join(lines)

    __str__ = report


def curve_summaries(rung, fitter, noise_sources) -> list[dict]:
    """Each curve's summary (:attr:`FitResult.curves`) of a fitted rung, one curve or several, in input order."""
    out = []
    whites = rung.curve_white if fitter.joint else (rung.white,)
    for (k, c, noise, sl, params), white in zip(fitter.parts(rung), whites):
        r = np.asarray(rung.residuals_mN)[sl]
        rms = float(np.sqrt(np.mean(r**2)))
        contact = float(params.get("offset_mm", c.contact_guess_mm if c.contact_mode != "origin" else 0.0))
        sd = rung.std.get(f"offset_mm[{k + 1}]" if fitter.joint else "offset_mm")
        out.append({"data": c.source, "n_points": c.n, "radius_mm": float(c.radius_mm),
                    "radius_source": c.radius_source, "noise_mN": float(noise), "noise_source": noise_sources[k],
                    "rms_mN": rms, "misfit": rms / noise, "white": bool(white), "contact_mode": c.contact_mode,
                    "contact_point_mm": contact, "contact_point_std_mm": None if sd is None else float(sd),
                    "baseline_mN": c.baseline_mN})
    return out


def knowledge_of(rung, fitter) -> tuple[list, list]:
    """What the user knew, as every fit reports it: the flags of priors in tension with the data, and the
    notes of the values held and of each prior (prior, posterior, how much the data narrowed it)."""
    flags = [f"{name}: the prior {s['prior_mean']:.4g} +- {s['prior_sd']:.2g} and the data disagree ("
             + (f"the data alone: {s['data_alone']:.4g} +- {s['data_alone_sd']:.2g}, " if "data_alone" in s else "")
             + f"{s['tension_sd']:.1f} combined sd apart)" for name, s in rung.priors.items() if s["in_tension"]]
    notes = [UnitText("{name} held at {value:g}", name=Name(name), value=Quantity(v, name))
             for name, v in fitter.fixed.items() if name in rung.parameters]
    for name, s in rung.priors.items():
        notes.append(UnitText("{name}: prior {mean:.4g} +- {sd:.2g}, posterior {post:.4g} +- {post_sd:.2g} (sd x "
                              "{narrowed:.2f}: {by})", name=Name(name), mean=Quantity(s["prior_mean"], name),
                              sd=Quantity(s["prior_sd"], name), post=Quantity(s["posterior"], name),
                              post_sd=Quantity(s["posterior_sd"], name), narrowed=s["narrowed"],
                              by=DETERMINED_BY[s["determined_by"]]))
    return flags, notes
