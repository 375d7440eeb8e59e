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

from ..inverse.noise import estimate_noise
from ..inverse.residuals import effective_sample_size

__all__ = ["BIC_FORMULA", "MODEL_ERROR", "curve_noise", "described", "effective_n", "per_curve", "point_sigma",
           "sample_noise", "score"]

#: relative accuracy of the forward model (FE + surface), added to the noise in quadrature
MODEL_ERROR = 0.003
#: how ``bic`` is computed, in every result of a fit and of a diagnosis
BIC_FORMULA = ("(n_eff / n) sum r_i^2 / sigma_i^2 + k ln n_eff, sigma_i^2 = noise^2 + (model_error F_i)^2 "
               "(model_error 0.003; 0 for the paper's identification), n_eff the AR(1) effective sample size")


#: the noise is estimated on at most this many points (a longer curve: on the means of bins of samples)
NOISE_POINTS = 400


def curve_noise(data, noise_mN: float | None = None) -> tuple[float, str]:
    """The noise level of a prepared curve's points (mN) and where it comes from.

    Given: per raw sample, divided by sqrt of the bin size of the points. Else estimated from the data
    (local cubic prediction, :meth:`~skin_indent.measurement.PreparedCurve.high_frequency_noise_mN`) on
    at most :data:`NOISE_POINTS` points: a longer curve (the paper's identification fits every sample)
    is estimated on the means of bins of ``b`` samples, in time order, and its noise per sample is that
    times sqrt(b). An oversampled instrument's noise is correlated from sample to sample, so that the
    prediction from the neighbours cancels most of it, and a fit's sd from it would be far too small:
    measured on the Chiaro curve of ``tests/data/real-data`` (3772 loading samples), 1.7e-9 mN from
    every sample, 2.5e-7 mN per sample from bins of 10 (its pre-contact baseline scatters by 7.9e-8 mN;
    the diagnosis, which fits every segment in bins of 35, finds 1.7e-8 mN per bin).
    """
    if noise_mN is None:
        source = "estimated from the data (local cubic prediction)"
        if data.binned > 1:
            source += f" after averaging bins of {data.binned} samples"
        b = -(-data.n // NOISE_POINTS)
        if b == 1:
            return data.high_frequency_noise_mN(), source
        return _binned_noise(data, b), source + f" on bins of {b} samples, per sample"
    if not (math.isfinite(noise_mN) and noise_mN > 0):
        raise ValueError(f"noise must be a positive number of mN, got {noise_mN}")
    return float(noise_mN) / math.sqrt(data.binned), "given"


def _binned_noise(data, b: int) -> float:
    """The local cubic noise estimate of the means of consecutive bins of ``b`` points, times sqrt(b) (mN)."""
    m = data.n // b
    force = np.asarray(data.force_mN[: m * b], dtype=float).reshape(m, b).mean(axis=1)
    sigma = estimate_noise(np.arange(m, dtype=float), force)
    if not sigma > 0:
        raise ValueError("cannot estimate the noise from a noise-free curve: give the noise level (--noise)")
    return float(sigma) * math.sqrt(b)


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
