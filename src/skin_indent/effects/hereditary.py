r"""Viscoelastic force histories from an elastic response surface (Lee-Radok / Ting).

For a rigid sphere on a linearly viscoelastic half-space with constant Poisson's
ratio and relaxation function :math:`\psi(t) = g_\infty + \sum_i g_i e^{-t/\tau_i}`
(Prony series, :math:`g_\infty = 1 - \sum_i g_i`; E is the instantaneous modulus),
Lee & Radok (1960) and Ting (1966) give the force for any depth history h(t):

.. math::

    F(t) = \int_0^{t_1(t)} \psi(t - s)\, \frac{d F_e(h(s))}{ds}\, ds,

where :math:`F_e(h)` is the *elastic* force of the instantaneous material and
:math:`t_1(t) = t` while the contact grows (loading, holds). While it recedes
(unloading), :math:`t_1 < t` is the earlier time of equal contact radius, found from

.. math::

    \int_{t_1}^{t} \psi(t - s)\, \frac{d h}{ds}\, ds = 0,

and the contact is lost (F = 0) when no such :math:`t_1 \ge 0` exists. At small strain
:math:`F_e = \frac{4\sqrt R}{3(1-\nu^2)} E h^{3/2}` and this is exact; here
:math:`F_e` is the large-strain finite-element curve of a response surface, which
makes it the quasi-linear viscoelastic (QLV) approximation used for soft tissue
(Fung; Mattice et al. 2006). It differs from the finite-strain viscoelastic FE model
(:class:`skin_indent.mechanics.materials.Viscoelastic`) only through the large-strain
coupling of relaxation and contact size. On the independent finite-strain curve
v06 of the test data (E0 = 10 kPa, g1 = 0.4, tau1 = 5 s, nu = 0.45, 0.6 mm at
0.02 mm/s, loaded and unloaded) the true parameters give 0.7% at full depth
(RMS 0.06 mN of ~13 mN); refitted, the QLV model matches it to an RMS of 0.0014 mN
with g1 = 0.41 and tau1 = 5.1 s (nu absorbs the difference: 0.34; the recovery from
the noisy curve is tested in ``tests/test_diagnose.py``). The small-strain limits
(Ting's closed form for a ramp, fast and slow loading, holds, unloading) are tested
in ``tests/test_hereditary.py``.

The depth history is taken as piecewise linear in time, and the kernels are integrated
exactly over each step: a Prony series, or the power law of cells and tissues
(:class:`PowerLawKernel`, Fabry et al. 2001; Efremov et al. 2017),

.. math::

    \psi(t) = \Big(\frac{t + t_c}{t_0}\Big)^{-\beta}, \qquad 0 \le \beta < 1,

with E the modulus at :math:`t_0` = 1 s (the cell-rheology convention E(t) = E_0 (t/t_0)^{-\beta})
and a cut :math:`t_c` = :data:`CUT_S` = 10 us that makes the instantaneous modulus finite
(:math:`E(0) = E_0 (t_c/t_0)^{-\beta}`, 32 E_0 at beta = 0.3). The pure power law is integrable
(beta < 1); the cut lowers the force at time t by a fraction of about :math:`(t_c/t)^{1-\beta}`
(the part of the kernel's integral it removes): 4e-5 at beta = 0.3 after 30 s, 5e-4 after 0.5 s,
2.5e-3 at beta = 0.6 after 30 s (tested against Ting's closed form with the Beta function,
:func:`~skin_indent.mechanics.analytic.ting_power_law_force`, in ``tests/test_hereditary.py``).
The finite-element model relaxes with a Prony series fitted to the
same kernel (:func:`~skin_indent.mechanics.materials.viscoelastic.power_law_prony`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CUT_S", "PowerLawKernel", "exponential_weights", "hereditary_force", "log_lags", "prony_weights",
           "relaxation_weights", "start_time"]

#: cut of the power-law kernel at short times, s (its instantaneous modulus is finite)
CUT_S = 1e-5


@dataclass(frozen=True)
class PowerLawKernel:
    r"""Power-law relaxation :math:`\psi(t) = ((t + t_c)/t_0)^{-\beta}` (module docstring).

    Parameters
    ----------
    beta : float
        Exponent, in [0, 1) (0: elastic).
    t0_s : float
        Time at which the relaxation modulus is E, s (default 1 s).
    cut_s : float
        Cut at short times, s (> 0; default :data:`CUT_S`).
    """

    beta: float
    t0_s: float = 1.0
    cut_s: float = CUT_S

    def __post_init__(self):
        if not (math.isfinite(self.beta) and 0.0 <= self.beta < 1.0):
            raise ValueError(f"the power-law exponent beta must lie in [0, 1), got {self.beta}")
        for name in ("t0_s", "cut_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"the power-law kernel's {name} must be a finite time > 0 s, got {v}")

    def value(self, lag_s) -> np.ndarray:
        """psi at lags ``lag_s`` >= 0 (s)."""
        return ((np.asarray(lag_s, dtype=float) + self.cut_s) / self.t0_s) ** -self.beta

    def integral(self, lag_s) -> np.ndarray:
        """The integral of psi from 0 to ``lag_s`` (s)."""
        a = 1.0 - self.beta
        lag = np.asarray(lag_s, dtype=float)
        return self.t0_s**self.beta * ((lag + self.cut_s) ** a - self.cut_s**a) / a


def _check_prony(prony) -> tuple[np.ndarray, np.ndarray]:
    g = np.array([float(p[0]) for p in prony])
    tau = np.array([float(p[1]) for p in prony])
    if np.any(~np.isfinite(g)) or np.any(g < 0) or g.sum() >= 1.0:
        raise ValueError(f"Prony moduli g must be >= 0 with sum < 1, got {g.tolist()}")
    if np.any(~np.isfinite(tau)) or np.any(tau <= 0):
        raise ValueError(f"Prony times tau must be > 0 s, got {tau.tolist()}")
    return g, tau


def _step_means(prony, lag_start, lag_end, dt) -> np.ndarray:
    """Mean of psi over lags [lag_end, lag_start] (steps of length ``dt``; psi(lag_start) where dt = 0)."""
    lag_end, lag_start = np.maximum(lag_end, 0.0), np.maximum(lag_start, 0.0)
    if isinstance(prony, PowerLawKernel):
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(dt > 0, (prony.integral(lag_start) - prony.integral(lag_end)) / dt,
                            prony.value(lag_start))
    g, tau = _check_prony(prony)
    W = np.full(np.broadcast(lag_start, lag_end, dt).shape, 1.0 - g.sum())
    for gi, ti in zip(g, tau):
        e1 = np.exp(-lag_end / ti)
        e0 = np.exp(-lag_start / ti)
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = np.where(dt > 0, ti * (e1 - e0) / dt, e0)
        W += gi * mean
    return W


def _lower(n: int) -> np.ndarray:
    """The (n, n - 1) mask of the steps j that act on the time t_n (j < n)."""
    return np.tri(n, n - 1, -1, dtype=bool)


def exponential_weights(time_s, tau_s: float) -> np.ndarray:
    r"""E[n, j] = mean of exp(-(t_n - s) / tau) over step j (s in [t_j, t_{j+1}]), zero for j >= n.

    One exponential per entry: over a step the mean is the kernel at the step's end times
    :math:`\tau (1 - e^{-\Delta t_j/\tau}) / \Delta t_j` (``expm1``: exact for steps far shorter
    than tau), 1 for a step of no duration.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Non-decreasing times, s.
    tau_s : float
        Relaxation time, s (> 0).

    Returns
    -------
    ndarray, shape (n, n - 1)
    """
    t = np.asarray(time_s, dtype=float)
    dt = np.diff(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        step = np.where(dt > 0, -np.expm1(-dt / tau_s) * tau_s / dt, 1.0)
    lag_end = np.where(_lower(t.size), t[:, None] - t[None, 1:], np.inf)  # t_n - t_{j+1}; inf: no weight
    out = np.exp(lag_end * (-1.0 / tau_s))
    out *= step
    return out


def log_lags(time_s, cut_s: float = CUT_S) -> np.ndarray:
    """``L[n, k] = log(max(t_n - t_k, 0) + cut_s)`` (n, n): what the power-law weights of every exponent
    share (:func:`relaxation_weights`' ``log_lags``)."""
    t = np.asarray(time_s, dtype=float)
    return np.log(np.maximum(t[:, None] - t[None, :], 0.0) + cut_s)


def _power_law_weights(t: np.ndarray, kernel: PowerLawKernel, logs=None) -> np.ndarray:
    """:func:`relaxation_weights` of the power-law kernel: its integral at the lags to every time once
    (``P[n, k] = (t_n - t_k + t_c)^(1 - beta)``, a step's mean the difference of two neighbours)."""
    dt = np.diff(t)
    a = 1.0 - kernel.beta
    logs = log_lags(t, kernel.cut_s) if logs is None else logs
    with np.errstate(divide="ignore", invalid="ignore"):
        P = np.exp(a * logs)  # (n, n)
        means = (P[:, :-1] - P[:, 1:]) * (kernel.t0_s**kernel.beta / a) / dt
        if np.any(dt == 0):
            zero = np.flatnonzero(dt == 0)
            means[:, zero] = kernel.value(np.maximum(t[:, None] - t[None, zero], 0.0))
    means[~_lower(t.size)] = 0.0
    return means


def relaxation_weights(time_s, prony, *, log_lags=None) -> np.ndarray:
    r"""W[n, j] = mean of psi(t_n - s) over step j (s in [t_j, t_{j+1}]), zero for j >= n.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Non-decreasing times, s.
    prony : sequence of (g, tau_s), or PowerLawKernel
        The relaxation function: Prony terms (relative modulus, relaxation time in s), or a
        kernel with ``value(lag)`` and ``integral(lag)`` (:class:`PowerLawKernel`).
    log_lags : ndarray, optional
        :func:`log_lags` of ``time_s`` and the power law's cut (to reuse across exponents).

    Returns
    -------
    ndarray, shape (n, n - 1)
        So that :math:`\int_0^{t_n} \psi(t_n - s) \dot x(s) ds = \sum_j W_{nj} \Delta x_j`
        for any x piecewise linear in time.

    Notes
    -----
    A Prony series is :math:`g_\infty` on every acting step plus each term's
    :func:`exponential_weights` (one exponential per entry); the power law takes its integral at the
    lags to every time once (one exponential of a logarithm per entry).
    """
    t = np.asarray(time_s, dtype=float)
    if np.any(np.diff(t) < 0):
        raise ValueError("time_s must not decrease")
    if isinstance(prony, PowerLawKernel):
        return _power_law_weights(t, prony, log_lags)
    g, tau = _check_prony(prony)
    W = _lower(t.size) * (1.0 - g.sum())
    for gi, ti in zip(g, tau):
        W += gi * exponential_weights(t, ti)
    return W


def prony_weights(time_s, g: float, exponential: np.ndarray) -> np.ndarray:
    """The :func:`relaxation_weights` of one Prony term ``(g, tau)`` from its :func:`exponential_weights`
    (which do not depend on ``g``: a fit's step in ``g`` alone reuses them)."""
    n = np.asarray(time_s).size
    W = _lower(n) * (1.0 - g)
    W += g * exponential
    return W


def start_time(time_s) -> float:
    """When a history that begins in contact started from depth 0: one time step (the first) before
    the first time, not before 0 s when the times are >= 0 (the forward model's convention,
    :meth:`~skin_indent.mechanics.solver.IndentationProblem.solve`)."""
    t = np.asarray(time_s, dtype=float)
    dt0 = float(t[1] - t[0]) if t.size > 1 else 0.0
    return float(t[0] - dt0) if t[0] < 0 else max(float(t[0] - dt0), 0.0)


def hereditary_force(time_s, depth_mm, elastic_force_mN, prony, *, weights=None) -> np.ndarray:
    """Force history (mN) of the Lee-Radok / Ting solution for a depth history.

    Parameters
    ----------
    time_s : array_like, shape (n,)
        Non-decreasing times, s (any origin; before contact the elastic force is 0).
    depth_mm : array_like, shape (n,)
        Depth h(t) of the sphere, mm (h <= 0: no contact).
    elastic_force_mN : array_like, shape (n,)
        F_e(h(t)) of the instantaneous elastic material, mN (0 where h <= 0).
    prony : sequence of (g, tau_s), or PowerLawKernel
        The relaxation function (:func:`relaxation_weights`).
    weights : ndarray, optional
        :func:`relaxation_weights` of ``time_s`` and ``prony`` (to reuse).

    Returns
    -------
    ndarray, shape (n,)
        Force, mN; 0 once the contact is lost.

    Notes
    -----
    A history that begins in contact (``elastic_force_mN[0]`` not 0) is taken to have begun at
    depth 0 at :func:`start_time` (one time step before), with the elastic force linear in time
    from 0, as the forward model takes it; with no time before it (the first time is 0 s) the
    first state is a step.
    """
    t = np.asarray(time_s, dtype=float)
    h = np.asarray(depth_mm, dtype=float)
    fe = np.asarray(elastic_force_mN, dtype=float)
    W = relaxation_weights(t, prony) if weights is None else weights
    t_start = start_time(t)
    if fe[0] != 0 and t_start < t[0]:
        # a history that begins in contact: the elastic force grew from 0 at t_start (as in the forward model)
        first = _step_means(prony, t - t_start, t - t[0], t[0] - t_start)
        Wx = np.zeros((t.size + 1, t.size))
        Wx[1:, 1:], Wx[1:, 0] = W, first
        return _force(Wx, np.r_[0.0, h], np.r_[0.0, fe], np.zeros(t.size + 1))[1:]
    initial = fe[0] * _step_means(prony, t - t[0], t - t[0], 0.0)  # a step at t_0 (or nothing)
    return _force(W, h, fe, initial)


def _force(W, h, fe, initial) -> np.ndarray:
    """The force of the weights ``W`` (:func:`relaxation_weights`), depths and elastic forces."""
    dh, dfe = np.diff(h), np.diff(fe)
    force = initial + W @ dfe  # growing contact everywhere
    # receding contact: the contact radius of t_n was last seen at t_1 < t_n (all such n at once)
    rec = np.flatnonzero(np.r_[False, dh < 0])
    if rec.size:
        rows = np.arange(rec.size)
        Wr = W[rec]  # zero for steps j >= n
        A = np.cumsum((Wr * dh)[:, ::-1], axis=1)[:, ::-1]  # A[i, k] = int_{t_k}^{t_n} psi dh, n = rec[i]
        receding = A[rows, rec - 1] < 0
        nonneg = (A >= 0) & (np.arange(A.shape[1]) < rec[:, None])
        seen = nonneg.any(axis=1)
        k = A.shape[1] - 1 - np.argmax(nonneg[:, ::-1], axis=1)  # A[k] >= 0 > A[k + 1]: t_1 in step k
        k1 = np.minimum(k + 1, A.shape[1] - 1)
        fit = receding & seen
        with np.errstate(divide="ignore", invalid="ignore"):
            before = np.where(fit, A[rows, k] / (A[rows, k] - A[rows, k1]), 0.0)  # fraction of step k before t_1
        # W[n, :k] @ dfe[:k], over the steps where the elastic force changes (in contact) only
        acting = np.flatnonzero(dfe)
        done = np.cumsum(Wr[:, acting] * dfe[acting], axis=1)
        below = np.searchsorted(acting, k)  # acting steps before step k
        partial = np.where(below > 0, done[rows, np.maximum(below - 1, 0)] if acting.size else 0.0, 0.0)
        new = initial[rec] + partial + before * Wr[rows, k] * dfe[k]
        force[rec[fit]] = new[fit]
        force[rec[receding & ~seen]] = 0.0  # receded past first contact
    return np.maximum(force, 0.0) if np.all(fe >= 0) else force
