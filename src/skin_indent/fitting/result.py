"""What every fit's result adds to an identification: its score against the error model.

:class:`ScoredResult` is :class:`~skin_indent.inverse.IdentificationResult` with ``aic``, ``bic`` and
the effective sample size ``n_eff`` they are at (:func:`~skin_indent.fitting.error_model.score`):
the one meaning of ``bic`` in every result of a fit and of a diagnosis (a fit alone is scored at its
own residual's ``n_eff``; a diagnosis compares its models at one ``n_eff``, that of the best-fitting).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..inverse import IdentificationResult
from .error_model import BIC_FORMULA, effective_n, score


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
