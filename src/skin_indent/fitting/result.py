"""What every fit's result adds to an identification: its score against the error model.

:class:`ScoredResult` is :class:`~skin_indent.inverse.IdentificationResult` with ``aic``, ``bic`` and
the effective sample size ``n_eff`` they are at (:func:`~skin_indent.fitting.error_model.score`):
the one meaning of ``bic`` in every result of a fit and of a diagnosis (a fit alone is scored at its
own residual's ``n_eff``; a diagnosis compares its models at one ``n_eff``, that of the best-fitting).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..inverse import IdentificationResult
from ..measurement.scale import Name, Quantity, UnitText
from ..runtime.json_io import jsonable
from .error_model import BIC_FORMULA, effective_n, score
from .knowledge import DETERMINED_BY


@dataclass(frozen=True, eq=False)
class ScoredResult(IdentificationResult):
    """An identification with its score: ``aic``, ``bic`` (:data:`BIC_FORMULA`) at ``n_eff``.

    ``chi2`` is the chi-square of the residual against the error model (sigma_i of each point).
    """

    BIC_FORMULA = BIC_FORMULA

    aic: float = math.nan
    bic: float = math.nan
    n_eff: float = math.nan

    def criteria(self) -> dict:
        return {"aic": self.aic, "bic": self.bic, "n_eff": self.n_eff, "bic_formula": self.BIC_FORMULA,
                "aic_ml": self.aic_ml, "bic_ml": self.bic_ml, "bic_ml_formula": self.BIC_ML_FORMULA}

    def at(self, n_eff: float) -> "ScoredResult":
        """This result scored at another effective sample size (a diagnosis's, to compare it with its models)."""
        aic, bic = score(self.chi2, self.n_free, self.n_points, n_eff)
        return dataclasses.replace(self, aic=aic, bic=bic, n_eff=float(n_eff))

    def criteria_line(self, digits: int = 5) -> str:
        return (f"    AIC        = {self.aic:.{digits}g}, BIC = {self.bic:.{digits}g} (against the error model, "
                f"n_eff = {self.n_eff:.4g})")


def scored(chi2: float, whitened_residual, k: int) -> dict:
    """``{"aic", "bic", "n_eff"}`` of a fit alone: its weighted chi-square ``chi2`` at the effective sample
    size of its own residual scaled to the noise (``whitened_residual``, :func:`effective_n`)."""
    n = len(whitened_residual)
    n_eff = effective_n(whitened_residual, k)
    aic, bic = score(chi2, k, n, n_eff)
    return {"aic": aic, "bic": bic, "n_eff": n_eff}


@dataclass(frozen=True, eq=False)
class FitResult(ScoredResult):
    """What every fit of a model reports, of one curve or of several curves of one sample.

    Everything of :class:`ScoredResult`, with the model, each curve's data treatment and misfit, how
    far the numbers can be trusted and what the user knew. :class:`~skin_indent.fitting.CurveFit` (one
    curve: its data treatment in full, Hertz, the quality) and
    :class:`~skin_indent.fitting.sample_fit.SampleFit` (several) add only what is theirs.

    Attributes
    ----------
    model : str
        ``neo-hooke`` plus ``+effect`` for each effect.
    curves : list of dict
        Per curve, in input order (one curve: one): ``data`` (its source), ``n_points``, ``radius_mm``,
        ``radius_source``, ``noise_mN``, ``noise_source``, ``rms_mN``, ``misfit`` (RMS over the noise),
        ``white``, ``contact_mode``, ``contact_point_mm`` and its sd (None where the curve starts in
        contact or the contact point is held), ``baseline_mN``.
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
    """

    model: str = "neo-hooke"
    curves: list = field(default_factory=list)
    flags: tuple = ()
    notes: list = field(default_factory=list)
    priors: dict = field(default_factory=dict)
    error_model: dict = field(default_factory=dict)
    provenance: dict = field(default_factory=dict, repr=False)
    correlations: tuple | None = None

    def correlation_pairs(self) -> list:
        """The correlations :meth:`report` lists, under the names ``parameters`` uses."""
        return super().correlation_pairs() if self.correlations is None else list(self.correlations)

    @property
    def trusted(self) -> bool:
        """Converged and no flag."""
        return self.success and not self.flags

    def to_dict(self) -> dict:
        """The identification's JSON summary, its score and what every fit reports (JSON-safe)."""
        out = super().to_dict()
        out.update({"model": self.model, "curves": [dict(c) for c in self.curves], "flags": list(self.flags),
                    "notes": [str(n) for n in self.notes], "priors": dict(self.priors),
                    "error_model": dict(self.error_model), "provenance": dict(self.provenance),
                    # under the names ``parameters`` uses (``covariance`` is in the fit's coordinates)
                    "correlations": [{"a": a, "b": b, "r": r} for a, b, r in self.correlation_pairs()]})
        return jsonable(out)


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
    flags = [f"{name}: the prior {s['prior_mean']:.4g} +- {s['prior_sd']:.2g} and the data disagree "
             f"({s['tension_sd']:.1f} combined sd apart)" for name, s in rung.priors.items() if s["in_tension"]]
    notes = [UnitText("{name} held at {value:g}", name=Name(name), value=Quantity(v, name))
             for name, v in fitter.fixed.items() if name in rung.parameters]
    for name, s in rung.priors.items():
        notes.append(UnitText("{name}: prior {mean:.4g} +- {sd:.2g}, posterior {post:.4g} +- {post_sd:.2g} (sd x "
                              "{narrowed:.2f}: {by})", name=Name(name), mean=Quantity(s["prior_mean"], name),
                              sd=Quantity(s["prior_sd"], name), post=Quantity(s["posterior"], name),
                              post_sd=Quantity(s["posterior_sd"], name), narrowed=s["narrowed"],
                              by=DETERMINED_BY[s["determined_by"]]))
    return flags, notes
