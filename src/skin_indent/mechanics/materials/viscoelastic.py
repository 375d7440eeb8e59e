r"""Finite-strain quasi-linear viscoelasticity with a Prony series.

The whole second Piola-Kirchhoff stress of an elastic base law (neo-Hooke)
relaxes with one reduced relaxation function (Simo 1987; the hereditary integral
of Fung's quasi-linear viscoelasticity):

.. math::

    S(t) = \int_0^t g(t - s)\, \frac{d S_e(C(s))}{ds}\, ds, \qquad
    g(t) = g_\infty + \sum_i g_i e^{-t/\tau_i},\quad g_\infty = 1 - \sum_i g_i .

Because the whole stress relaxes, Poisson's ratio stays constant in time, the
setting of the Lee-Radok / Ting solution. Prony convention as in Abaqus: E of
the base law is the instantaneous modulus, the relaxation modulus is
``E(t) = E (1 - sum g_i (1 - exp(-t/tau_i)))``, the long-term modulus ``E g_inf``.

Time integration (exact for a stress varying linearly over a step): with
:math:`e_i = e^{-\Delta t/\tau_i}` and :math:`\gamma_i = (1 - e_i)\tau_i/\Delta t`,

.. math::

    h_i^{n+1} = e_i h_i^n + g_i \gamma_i (S_e^{n+1} - S_e^n), \qquad
    S^{n+1} = g_\infty S_e^{n+1} + \sum_i h_i^{n+1}
            = \alpha\, S_e^{n+1} + \beta,

with :math:`\alpha = g_\infty + \sum g_i \gamma_i` and the history
:math:`\beta = \sum_i (e_i h_i^n - g_i \gamma_i S_e^n)` frozen during the step, so
:math:`P = \alpha P_e + F\beta` and :math:`\mathbb{A} = \alpha \mathbb{A}_e + \delta_{ik}\beta_{JL}`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .base import Material, ParameterInfo, identity_like, inverse_and_det


@dataclass(frozen=True)
class PronyTerm:
    """One term of a Prony series: relative modulus ``g`` (0..1) and time constant ``tau_s`` (s)."""

    g: float
    tau_s: float

    def __post_init__(self):
        if not (math.isfinite(self.g) and 0.0 < self.g < 1.0):
            raise ValueError(f"Prony relative modulus g must lie in (0, 1), got {self.g}")
        if not (math.isfinite(self.tau_s) and self.tau_s > 0):
            raise ValueError(f"Prony time constant tau must be a finite number > 0 s, got {self.tau_s}")


@dataclass(frozen=True)
class Viscoelastic(Material):
    """Quasi-linear viscoelastic version of an elastic law (see the module docstring).

    Parameters
    ----------
    base : Material
        The instantaneous elastic law (e.g. ``NeoHooke(E_kPa=10, nu=0.45)``).
    prony : tuple of PronyTerm
        At least one term; ``sum(g) < 1``.
    """

    base: Material
    prony: tuple

    name = "viscoelastic"
    path_independent = False

    def __post_init__(self):
        terms = tuple(self.prony)
        if not terms or not all(isinstance(t, PronyTerm) for t in terms):
            raise ValueError("a viscoelastic law needs at least one PronyTerm(g, tau_s)")
        if sum(t.g for t in terms) >= 1.0:
            raise ValueError(f"the Prony moduli must sum to < 1, got {sum(t.g for t in terms):g}")
        if not isinstance(self.base, Material) or not self.base.path_independent:
            raise ValueError("the base of a viscoelastic law must be an elastic Material")
        object.__setattr__(self, "prony", terms)

    @property
    def small_strain(self) -> bool:  # type: ignore[override]
        return self.base.small_strain

    @property
    def parameter_info(self):  # type: ignore[override]
        info = list(self.base.parameter_info)
        for i, _ in enumerate(self.prony, 1):
            info += [ParameterInfo(f"g{i}", "-", 0.0, 1.0, f"relative modulus of Prony term {i}"),
                     ParameterInfo(f"tau{i}_s", "s", 0.0, np.inf, f"time constant of Prony term {i}")]
        return tuple(info)

    def parameters(self) -> dict[str, float]:
        out = self.base.parameters()
        for i, t in enumerate(self.prony, 1):
            out[f"g{i}"], out[f"tau{i}_s"] = t.g, t.tau_s
        return out

    @property
    def E_kPa(self) -> float:
        return self.base.E_kPa

    @property
    def nu(self) -> float:
        return self.base.nu

    @property
    def reference_modulus(self) -> float:
        return self.base.reference_modulus

    @property
    def g_infinity(self) -> float:
        """Long-term relative modulus ``1 - sum g_i``."""
        return 1.0 - sum(t.g for t in self.prony)

    def relaxation_modulus(self, t_s) -> np.ndarray:
        """E(t) in kPa."""
        t = np.asarray(t_s, dtype=float)
        return self.E_kPa * (self.g_infinity + sum(p.g * np.exp(-t / p.tau_s) for p in self.prony))

    # -- elastic limits (used when the law is asked for an instantaneous response)
    def energy(self, H):
        return self.base.energy(H)

    def stress_and_tangent(self, H):
        return self.base.stress_and_tangent(H)

    def tangent_components(self, H, pairs):
        return self.base.tangent_components(H, pairs)

    # -- history
    def _elastic_pk2(self, H):
        P = self.base.stress(H)
        if self.small_strain:
            return P
        Finv, _ = inverse_and_det(identity_like(H) + H)
        return np.einsum("Ik...,kJ...->IJ...", Finv, P)

    def initial_state(self, shape) -> dict:
        """History at rest: no elastic stress, no viscous stress (3x3 per quadrature point)."""
        return {"S_e": np.zeros((3, 3) + tuple(shape)), "h": np.zeros((len(self.prony), 3, 3) + tuple(shape))}

    def _factors(self, dt):
        e = np.array([math.exp(-dt / p.tau_s) if dt > 0 else 1.0 for p in self.prony])
        gamma = np.array([(1 - ei) * p.tau_s / dt if dt > 0 else 1.0 for ei, p in zip(e, self.prony)])
        g = np.array([p.g for p in self.prony])
        return e, gamma, g

    def step(self, state: dict, dt: float) -> "_ViscoelasticStep":
        """The law over one time step of ``dt`` seconds from the committed ``state``."""
        e, gamma, g = self._factors(dt)
        alpha = self.g_infinity + float(np.sum(g * gamma))
        shape = (-1,) + (1,) * (state["h"].ndim - 1)
        beta = np.sum(e.reshape(shape) * state["h"] - (g * gamma).reshape(shape) * state["S_e"][None], axis=0)
        return _ViscoelasticStep(self.base, alpha, beta)

    def commit(self, H: np.ndarray, state: dict, dt: float) -> dict:
        """History after the converged step to the displacement gradient ``H``."""
        e, gamma, g = self._factors(dt)
        S_new = self._elastic_pk2(H)
        shape = (-1,) + (1,) * (state["h"].ndim - 1)
        h = e.reshape(shape) * state["h"] + (g * gamma).reshape(shape) * (S_new - state["S_e"])[None]
        return {"S_e": S_new, "h": h}


#: times over which :func:`power_law_prony` matches the power law: from 0 to 1e4 s (about 3 hours)
POWER_LAW_SPAN_S = 1e4
#: Prony times per decade of :func:`power_law_prony`
POWER_LAW_PER_DECADE = 2


@functools.lru_cache(maxsize=64)
def power_law_prony(beta: float, t0_s: float = 1.0, cut_s: float = 1e-5, span_s: float = POWER_LAW_SPAN_S,
                    per_decade: int = POWER_LAW_PER_DECADE) -> tuple[float, tuple, float]:
    r"""A Prony series of the power law :math:`\psi(t) = ((t + t_c)/t_0)^{-\beta}`, for the finite-element model.

    The relaxation times are spaced ``per_decade`` per decade from a tenth of ``cut_s`` to ten
    times ``span_s``; the moduli are the non-negative least-squares fit of the relative error on
    [0, ``span_s``] (the collocation of Park & Schapery 1999). With the defaults (23 times from
    1e-6 to 1e5 s, 20-21 with a modulus > 0) the series matches the kernel to 2.5e-5 at beta = 0.05,
    5.5e-5 at 0.1, 2.4e-4 at 0.3, 5.8e-4 at 0.5 and 1.9e-3 at 0.9 (largest relative error on
    [0, 1e4 s]); beyond ``span_s`` it levels off.

    Parameters
    ----------
    beta : float
        Exponent, in (0, 1).
    t0_s, cut_s : float
        Reference time and short-time cut of the kernel, s
        (:class:`~skin_indent.effects.hereditary.PowerLawKernel`).
    span_s : float
        Longest time matched, s.
    per_decade : int
        Relaxation times per decade.

    Returns
    -------
    instantaneous : float
        psi(0) of the series: the instantaneous modulus relative to the modulus at ``t0_s``.
    terms : tuple of PronyTerm
        Relative to the instantaneous modulus (the convention of :class:`Viscoelastic`).
    error : float
        The largest relative error of the series on [0, ``span_s``].
    """
    from scipy.optimize import nnls

    if not (math.isfinite(beta) and 0.0 < beta < 1.0):
        raise ValueError(f"the power-law exponent beta must lie in (0, 1), got {beta}")
    lo, hi = math.log10(cut_s) - 1.0, math.log10(span_s) + 1.0
    tau = np.logspace(lo, hi, int(round(per_decade * (hi - lo))) + 1)

    def kernel(t):
        return ((t + cut_s) / t0_s) ** -beta

    def series(t, a):
        return a[0] + np.exp(-t[:, None] / tau[None, :]) @ a[1:]

    t = np.r_[0.0, np.logspace(math.log10(cut_s) - 2.0, math.log10(span_s), 40 * tau.size)]
    A = np.c_[np.ones_like(t), np.exp(-t[:, None] / tau[None, :])] / kernel(t)[:, None]
    a, _ = nnls(A, np.ones_like(t))
    a[0] = max(a[0], 1e-3 * kernel(span_s))  # a long-term modulus > 0 (sum of g < 1), off by < 1e-3 at span_s
    check = np.r_[0.0, np.logspace(math.log10(cut_s) - 3.0, math.log10(span_s), 20000)]
    error = float(np.max(np.abs(series(check, a) / kernel(check) - 1.0)))
    instantaneous = float(a.sum())
    terms = tuple(PronyTerm(float(ai / instantaneous), float(ti)) for ai, ti in zip(a[1:], tau) if ai > 0)
    return instantaneous, terms, error


class _ViscoelasticStep:
    """``P = alpha P_e(F) + F beta`` for one time step (beta: frozen history)."""

    def __init__(self, base: Material, alpha: float, beta: np.ndarray):
        self.base, self.alpha, self.beta = base, alpha, beta
        self.small_strain = base.small_strain

    def _history_stress(self, H, beta):
        if self.small_strain:
            return beta
        return np.einsum("iK...,KJ...->iJ...", identity_like(H) + H, beta)

    def stress(self, H):
        return self.alpha * self.base.stress(H) + self._history_stress(H, self.beta)

    def tangent_components(self, H, pairs):
        beta = self.beta
        P, A = self.base.tangent_components(H, pairs)
        rows = [i for i, _ in pairs]
        cols = [j for _, j in pairs]
        P = self.alpha * P + self._history_stress(H, beta)[rows, cols]
        A = self.alpha * A
        if not self.small_strain:  # d(F beta)_iJ / dF_kL = delta_ik beta_LJ
            for a, (i, J) in enumerate(pairs):
                for c, (k, L) in enumerate(pairs):
                    if i == k:
                        A[a, c] = A[a, c] + beta[L, J]
        return P, A
