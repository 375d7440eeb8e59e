r"""Is a residual noise or structure, and where is the structure?

Residuals are ``measured - model`` (mN), ordered as measured. Three tests ask
whether they are white noise of the stated level ``sigma``:

- the Wald-Wolfowitz **runs test** on their signs (too few sign changes: a smooth
  misfit);
- the **Ljung-Box** test of their autocorrelation over the first lags;
- the **chi-square** of ``sum(r^2) / sigma^2`` against ``n - p`` degrees of freedom
  (too large: misfit beyond the noise, even if it looks white).

A residual passes ("white") when no test rejects at level ``alpha``.
:func:`describe_structure` turns a structured residual into words: smoothed
over a window, the depth ranges where the model is significantly too stiff
(negative residual) or too soft (positive residual).

Correlated residuals carry less information than their count suggests; the
effective sample size of an AR(1) sequence, ``n (1 - rho) / (1 + rho)``, is what
a BIC comparison of models should use (:func:`effective_sample_size`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Default significance level of the whiteness tests.
ALPHA = 0.01


@dataclass(frozen=True)
class ResidualAnalysis:
    """Whiteness of a residual.

    Attributes
    ----------
    n : int
        Number of residuals.
    noise_mN : float
        The noise level the residual is judged against, mN.
    rms_mN : float
    chi2, chi2_dof, chi2_p : float
        ``sum(r^2)/sigma^2``, its degrees of freedom and upper-tail p-value.
    runs, runs_expected, runs_p : float
        Sign runs observed and expected, and the two-sided p-value (too few runs
        means structure).
    lag1 : float
        Lag-1 autocorrelation.
    ljung_box_p : float
        p-value of the Ljung-Box statistic over the first lags.
    white : bool
        No test rejects at ``alpha``.
    n_effective : float
        Effective sample size under AR(1) correlation.
    """

    n: int
    noise_mN: float
    rms_mN: float
    chi2: float
    chi2_dof: int
    chi2_p: float
    runs: int
    runs_expected: float
    runs_p: float
    lag1: float
    ljung_box_p: float
    white: bool
    n_effective: float
    alpha: float = ALPHA

    def summary(self) -> str:
        verdict = "white (noise)" if self.white else "structured"
        return (f"residual {verdict}: rms {self.rms_mN:.3g} mN vs noise {self.noise_mN:.3g} mN "
                f"(chi2/dof {self.chi2 / max(self.chi2_dof, 1):.2f}, p = {self.chi2_p:.2g}); "
                f"{self.runs} sign runs vs {self.runs_expected:.1f} expected (p = {self.runs_p:.2g}); "
                f"lag-1 autocorrelation {self.lag1:+.2f} (Ljung-Box p = {self.ljung_box_p:.2g})")

    def to_dict(self) -> dict:
        return {k: (float(v) if isinstance(v, (np.floating, float)) else v)
                for k, v in self.__dict__.items()}


def effective_sample_size(residuals) -> float:
    """``n (1 - rho) / (1 + rho)`` with rho the lag-1 autocorrelation (clipped to [0, 0.99])."""
    r = np.asarray(residuals, dtype=float)
    rho = float(np.clip(_autocorrelation(r, 1)[0], 0.0, 0.99)) if r.size > 2 else 0.0
    return r.size * (1 - rho) / (1 + rho)


def _autocorrelation(r, max_lag):
    r = r - r.mean()
    denom = float(r @ r)
    if denom == 0:
        return np.zeros(max_lag)
    return np.array([float(r[:-k] @ r[k:]) / denom for k in range(1, max_lag + 1)])


def analyse_residuals(residuals, noise_mN: float, n_parameters: int = 0, *, alpha: float = ALPHA,
                      max_lag: int | None = None, noise_dof: float | None = None) -> ResidualAnalysis:
    """Test whether ``residuals`` (mN) are white noise of standard deviation ``noise_mN``.

    Parameters
    ----------
    residuals : array_like
        Measured minus model, in measurement order.
    noise_mN : float
        Noise standard deviation, mN (> 0).
    n_parameters : int
        Fitted parameters (degrees of freedom of the chi-square: n - p).
    alpha : float
        Significance level.
    max_lag : int, optional
        Lags of the Ljung-Box test (default ``min(10, n // 5)``).
    noise_dof : float, optional
        Degrees of freedom of the noise level when it was *estimated* (from the same
        curve): the misfit test is then the F test of ``(chi2 / dof)`` against
        ``F(dof, noise_dof)``, since an estimated noise level is itself uncertain
        (about 12% for 100 points, i.e. ~35 degrees of freedom). Default: the
        noise level is known (chi-square test).
    """
    # the survival functions of scipy.stats.chi2, f and norm are these scipy.special functions
    # (the same numbers), without importing scipy.stats (0.4-0.8 s of a process's start)
    from scipy.special import chdtrc, fdtrc, ndtr

    r = np.asarray(residuals, dtype=float)
    if r.ndim != 1 or r.size < 5 or not np.all(np.isfinite(r)):
        raise ValueError("residuals must be at least 5 finite numbers")
    if not (np.isfinite(noise_mN) and noise_mN > 0):
        raise ValueError(f"noise level must be a finite number > 0 mN, got {noise_mN}")
    n = r.size
    dof = max(n - int(n_parameters), 1)
    chi2 = float(r @ r) / noise_mN**2
    if noise_dof is None:
        chi2_p = float(chdtrc(dof, chi2))  # chi2.sf(chi2, dof)
    else:
        chi2_p = float(fdtrc(dof, max(float(noise_dof), 1.0), chi2 / dof))  # f.sf(chi2 / dof, dof, noise_dof)
    # runs test on signs (zeros dropped)
    s = np.sign(r[r != 0])
    n_pos, n_neg = int(np.sum(s > 0)), int(np.sum(s < 0))
    runs = int(1 + np.count_nonzero(s[1:] != s[:-1])) if s.size else 0
    m = n_pos + n_neg
    if n_pos and n_neg:
        expected = 1 + 2 * n_pos * n_neg / m
        var = 2 * n_pos * n_neg * (2 * n_pos * n_neg - m) / (m**2 * (m - 1))
        z = (runs - expected) / np.sqrt(var) if var > 0 else 0.0
        runs_p = float(2 * ndtr(-abs(z)))  # 2 norm.sf(|z|)
    else:  # all of one sign: as structured as it gets
        expected, runs_p = 1 + m / 2, 0.0
    lags = max_lag or max(1, min(10, n // 5))
    acf = _autocorrelation(r, lags)
    q = n * (n + 2) * float(np.sum(acf**2 / (n - np.arange(1, lags + 1))))
    lb_p = float(chdtrc(lags, q))  # chi2.sf(q, lags)
    white = chi2_p > alpha and runs_p > alpha and lb_p > alpha
    return ResidualAnalysis(n, float(noise_mN), float(np.sqrt(r @ r / n)), chi2, dof, chi2_p, runs, float(expected),
                            runs_p, float(acf[0]), lb_p, bool(white), effective_sample_size(r), alpha)


def describe_structure(depth_mm, residuals, noise_mN: float, *, window: int | None = None,
                       level: float = 3.0) -> list[dict]:
    """Depth ranges where the model is significantly too stiff or too soft.

    The residual is averaged over a moving window of ``window`` points (default
    ``max(5, n // 10)``); where the average exceeds ``level`` standard errors of a
    window mean (``noise / sqrt(window)``) the model misses force there.

    Returns
    -------
    list of dict
        ``{"from_mm", "to_mm", "sign": "too soft"|"too stiff", "mean_mN"}`` per
        contiguous range, in depth order; ``[]`` when nothing stands out.
    """
    d = np.asarray(depth_mm, dtype=float)
    r = np.asarray(residuals, dtype=float)
    order = np.argsort(d, kind="stable")
    d, r = d[order], r[order]
    w = window or max(5, d.size // 10)
    w = min(w, d.size)
    kernel = np.ones(w) / w
    smooth = np.convolve(r, kernel, mode="same")
    edge = np.convolve(np.ones_like(r), kernel, mode="same")
    smooth = smooth / edge
    threshold = level * noise_mN / np.sqrt(w)
    flag = np.where(smooth > threshold, 1, np.where(smooth < -threshold, -1, 0))
    runs = []  # [sign, start, stop)
    for i, f in enumerate(flag):
        if f and runs and runs[-1][0] == f and i - runs[-1][2] < w:  # merge across short gaps
            runs[-1][2] = i + 1
        elif f:
            runs.append([f, i, i + 1])
    out = []
    for f, start, stop in runs:
        if stop - start < max(2, w // 2):  # shorter than half a window: not a range
            continue
        out.append({"from_mm": float(d[start]), "to_mm": float(d[stop - 1]),
                    "sign": "too soft" if f > 0 else "too stiff", "mean_mN": float(np.mean(r[start:stop]))})
    return out


def sentence(ranges: list[dict]) -> str:
    """The output of :func:`describe_structure` as one sentence."""
    if not ranges:
        return "no depth range departs from the model beyond the noise"
    parts = [f"too {r['sign'].split()[1]} from {r['from_mm']:.3g} to {r['to_mm']:.3g} mm "
             f"(mean residual {r['mean_mN']:+.3g} mN)" for r in ranges]
    return "model " + ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "") + parts[-1]
