"""What a diagnosis decides by: the BIC margins that name an effect, the noise allowance, the scores.

:func:`explained` (a rung explains the curve to the noise), :func:`settled` (the climb stops
there) and :class:`Scores` (the BIC of every model of one diagnosis, at one effective sample
size) are the criteria :func:`~.workflow.diagnose` applies; the constants are the margins it
applies them with (Kass & Raftery's scale of evidence for the BIC).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..fitting.multistart import Fitter
from ..fitting.result import FitResult
from ..fitting.rung import NO_STRUCTURE, evidence
from ..inverse.residuals import effective_sample_size
from ..models.composed import at_physical_limit

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


def unmoved(rung: FitResult) -> str | None:
    """Why a fitted candidate decides nothing, or None when it may be compared with its rivals.

    A fit that ended at its start values (:attr:`~skin_indent.fitting.FitResult.moved`; the fitter has tried its other starts
    already, :meth:`~skin_indent.fitting.multistart.Fitter.fit`) did not test the effect it adds: its
    RMS and BIC are those of the start, often the simpler model's optimum with the effect doing
    nothing. It is reported as not fitted (``"not fitted: ..."``), never ranked, so it can neither be
    named nor reject a rival.
    """
    if rung.moved:
        return None
    return (f"{NOT_FITTED}: the fit of {rung.model} ended at its start values (the simpler model's optimum, the "
            "added effect doing nothing), its other starts having found nothing lower: it tests nothing; fit it "
            "alone with a prior on what you know (--prior NAME=MEAN:SD), or with another measurement")




#: ``std_source`` of a standard deviation from the fit's own covariance (its model's Jacobian)
FROM_FIT = "fit"
#: ``std_source`` of a standard deviation from finite-element derivatives at the fitted values
#: (:func:`~.identifiability.assess`, the recorded measurement), which decide whether it is determined
FROM_FE = "finite-element derivatives"


def explained(rung: FitResult, fitter: Fitter) -> bool:
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


def settled(rung: FitResult, fitter: Fitter) -> bool:
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

    ``scores(rung)`` is the rung with its BIC (:attr:`~skin_indent.fitting.FitResult.BIC_FORMULA` at ``n_eff``), made once
    per model (set of effects): wherever a diagnosis holds a model, it holds that one rung.

    Parameters
    ----------
    n : int
        Points fitted.
    n_eff : float
        Their effective sample size (:func:`effective_size`).
    """

    def __init__(self, n: int, n_eff: float):
        self.n, self.n_eff = n, float(n_eff)
        #: ``{effects: rung with its BIC}``
        self.rungs: dict[tuple, FitResult] = {}

    def bic(self, f: FitResult) -> float:
        return evidence(f.chi2_weighted, f.n_parameters, self.n, self.n_eff)[1]

    def __call__(self, f: FitResult) -> FitResult:
        got = self.rungs.get(f.effects)
        if got is None:
            aic, bic = evidence(f.chi2_weighted, f.n_parameters, self.n, self.n_eff)
            got = self.rungs[f.effects] = dataclasses.replace(f, aic=aic, bic=bic, n_eff=self.n_eff)
        return got


def effective_size(fitter: Fitter, rungs) -> float:
    """AR(1) effective sample size of the best-fitting rung's residual (at least 2 k + 2, at most n)."""
    best = min(rungs, key=lambda f: f.chi2_weighted)
    n = fitter.data.n
    r = best.residual_mN * fitter.noise_mN / fitter.sigma(best.prediction_mN)
    return float(min(max(effective_sample_size(r), 2.0 * max(f.n_parameters for f in rungs) + 2), n))
