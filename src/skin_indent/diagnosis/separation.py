r"""How far the predicted curves of two explanations lie apart, in noise units, over a candidate's points.

:func:`separation` (a part of the engine of the next measurement,
:func:`~.identifiability.weigh`):

.. math::

    D_\infty = \max_i |F_{b,i} - F_{a,i}| / \sigma, \qquad
    S = \Big(\sum_i (F_{b,i} - F_{a,i})^2 / \sigma_i^2\Big)^{1/2},
    \qquad \sigma_i^2 = \sigma^2 + \big(\varepsilon \tfrac{F_{a,i} + F_{b,i}}{2}\big)^2,

with :math:`\sigma` the noise of the recorded curve and :math:`\varepsilon` =
:data:`~skin_indent.fitting.error_model.MODEL_ERROR`, the error model of every fit
(:func:`~skin_indent.fitting.error_model.point_sigma`).
:math:`S^2` is how much the chi-square of one explanation rises over the candidate's
points if the other is true and neither is refitted: an upper bound of what a joint fit
of the recorded curves and the candidate would show (refitting absorbs part of it; a
linearised refit is no estimate of how much: on the forearm-like curve at R = 3.11 mm it
left S = 5.7 where a nonlinear refit of layer and stiffening to the curve of two layers
left 56).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..fitting.error_model import point_sigma


def error_model(force, noise_mN: float) -> np.ndarray:
    """sigma_i (mN) of predicted forces: the one error model of every fit,
    :func:`~skin_indent.fitting.error_model.point_sigma` (the noise and the model error in quadrature)."""
    return point_sigma(noise_mN, force)


@dataclass(frozen=True)
class Separation:
    """How far the predicted curves of two explanations lie apart over a candidate's points.

    Attributes
    ----------
    a, b : str
        The two models (``a`` the diagnosis' choice).
    max_difference_mN : float
        The largest difference of the predicted curves, max abs(F_b - F_a) (mN).
    max_difference_noise : float
        The same over the noise.
    separation : float
        S = sqrt(sum (F_b - F_a)^2 / sigma_i^2), sigma_i the error model at (F_a + F_b) / 2.
    points : int
        Points of the candidate.
    repeat : bool
        The candidate is the recorded measurement made again: ``separation`` is what the recorded curve
        already told apart (:func:`repeated`), not the predicted curves' difference.
    """

    a: str
    b: str
    max_difference_mN: float
    max_difference_noise: float
    separation: float
    points: int
    repeat: bool = False

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def separation(a: str, b: str, fa, fb, noise_mN: float) -> Separation:
    """:class:`Separation` of the predicted curves ``fa``, ``fb`` (mN) of the models ``a``, ``b``."""
    fa, fb = np.asarray(fa, dtype=float), np.asarray(fb, dtype=float)
    d = fb - fa
    top = float(np.max(np.abs(d)))
    s = float(np.sqrt(np.sum((d / point_sigma(noise_mN, 0.5 * (fa + fb))) ** 2)))
    return Separation(a, b, top, top / noise_mN, s, int(d.size))


def repeated(s: Separation, chi2_a: float, chi2_b: float, k_a: int, k_b: int) -> Separation:
    r"""``s`` for the recorded measurement made again, whose curve the two explanations have already met.

    Both models were fitted to the recorded curve, so their predicted curves differ there by what each
    absorbed of it, and ``s.separation`` (the rise before refitting) overstates what a repeat would tell
    apart. Fitted together with the recorded curve, a repeat leaves the values where they are and adds,
    in expectation, the systematic part of the recorded chi-square gap: the gap
    :math:`\chi^2_b - \chi^2_a` (``chi2_a``, ``chi2_b``: the two fits on the recorded curve) less what
    the model with more fitted parameters gained by fitting the noise, one per parameter
    (:math:`E[\chi^2] = n - k` at the truth; a new curve's noise is not the recorded one's). Its
    separation is :math:`S = \sqrt{|\chi^2_b - \chi^2_a - (k_a - k_b)|}` (``k_a``, ``k_b``: the fitted
    parameters).
    """
    gap = abs(float(chi2_b) - float(chi2_a) - (int(k_a) - int(k_b)))
    return dataclasses.replace(s, separation=math.sqrt(gap) if math.isfinite(gap) else math.nan, repeat=True)
