"""The error model of every fit: one noise rule, the model-error term, each point's sigma, the score.

- :func:`curve_noise`: the noise level of a prepared curve, given or estimated from the data
  (the high-frequency part: local cubic prediction, :func:`skin_indent.inverse.estimate_noise`),
  the one rule of :func:`~skin_indent.fitting.fit`, the diagnosis and the plan;
- :data:`MODEL_ERROR` and :func:`point_sigma`: sigma_i = sqrt(noise^2 + (MODEL_ERROR F_i)^2),
  the noise and the forward model's relative error in quadrature (the paper's identification,
  an option of :func:`~skin_indent.fitting.fit`, weighs by the noise alone: ``model_error=0``);
- :func:`score`: AIC and BIC of a fit from its weighted chi-square at an effective sample size
  (:data:`BIC_FORMULA`); ``bic`` means this in every result (the Gaussian criterion with the
  noise estimated by maximum likelihood that the inverse methods also give is ``bic_ml``).
"""

from __future__ import annotations

import math

import numpy as np

from ..inverse.residuals import effective_sample_size

__all__ = ["BIC_FORMULA", "MODEL_ERROR", "curve_noise", "described", "effective_n", "per_curve", "point_sigma",
           "sample_noise", "score"]

#: relative accuracy of the forward model (FE + surface), added to the noise in quadrature
MODEL_ERROR = 0.003
#: how ``bic`` is computed, in every result of a fit and of a diagnosis
BIC_FORMULA = ("(n_eff / n) sum r_i^2 / sigma_i^2 + k ln n_eff, sigma_i^2 = noise^2 + (model_error F_i)^2 "
               "(model_error 0.003; 0 for the paper's identification), n_eff the AR(1) effective sample size")


def curve_noise(data, noise_mN: float | None = None) -> tuple[float, str]:
    """The noise level of a prepared curve (mN) and where it comes from: given (per raw sample,
    divided by sqrt of the bin size), or estimated from the data (local cubic prediction)."""
    if noise_mN is None:
        source = "estimated from the data (local cubic prediction)"
        if data.binned > 1:
            source += f" after averaging bins of {data.binned} samples"
        return data.high_frequency_noise_mN(), source
    if not (math.isfinite(noise_mN) and noise_mN > 0):
        raise ValueError(f"noise must be a positive number of mN, got {noise_mN}")
    return float(noise_mN) / math.sqrt(data.binned), "given"


def per_curve(value, n: int, what: str) -> list:
    """``value`` for each of ``n`` curves: one value for all, or a sequence of ``n`` (one line otherwise)."""
    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) != n:
            raise ValueError(f"{what}: {len(value)} values for {n} curves (give one, or one per curve)")
        return list(value)
    return [value] * n


def sample_noise(curves, noise_mN=None) -> tuple[list, list]:
    """Each curve's noise level (mN) and where it comes from (:func:`curve_noise`); ``noise_mN`` one for
    all curves, one per curve, or None (each estimated from its own data)."""
    out = [curve_noise(c, s) for c, s in zip(curves, per_curve(noise_mN, len(curves), "noise_mN"))]
    return [s for s, _ in out], [w for _, w in out]


def point_sigma(noise_mN, force_mN, model_error: float = MODEL_ERROR) -> np.ndarray:
    """sigma_i (mN) of each point: its noise (a number, or one per point) and the model error in quadrature."""
    return np.sqrt(np.asarray(noise_mN, dtype=float) ** 2 + (model_error * np.abs(np.asarray(force_mN, float))) ** 2)


def described(noise_mN, model_error: float = MODEL_ERROR, joint: bool = False) -> dict:
    """The error model in words and numbers (the ``error_model`` of a result)."""
    return {"noise_mN": noise_mN, "model_error": model_error,
            "sigma": ("sqrt(noise^2 + (model_error * F)^2)" if model_error else "noise")
            + (", noise of each point's curve" if joint else "")}


def effective_n(whitened_residual, k: int) -> float:
    """AR(1) effective sample size of a residual (scaled to the noise), at least ``2 k + 2``, at most n."""
    r = np.asarray(whitened_residual, dtype=float)
    return float(min(max(effective_sample_size(r), 2.0 * k + 2), r.size))


def score(chi2_weighted: float, k: int, n: int, n_eff: float | None = None) -> tuple[float, float]:
    """AIC and BIC of a fit from its weighted chi-square (:data:`BIC_FORMULA`).

    ``chi2_weighted`` is the sum of r_i^2 / sigma_i^2 (:func:`point_sigma`), ``k`` the fitted
    parameters, ``n`` the points; with ``n_eff`` (an effective sample size) the chi-square counts
    ``n_eff / n`` of its value and the penalty ``ln n_eff`` per parameter.
    """
    m = float(n if n_eff is None else n_eff)
    chi2 = chi2_weighted * m / n
    return chi2 + 2.0 * k, chi2 + k * math.log(m)
