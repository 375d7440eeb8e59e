"""The outcome of an identification, as data (estimate, uncertainty, fit statistics).

Every method (``"ekf-paper"``, ``"ekf"``, ``"lsq"``) returns an
:class:`IdentificationResult` built by :func:`build_result`, so the fit statistics
(chi2, AIC, BIC) are computed identically and can be compared across methods and
across models.

Information criteria
--------------------
Gaussian likelihood with the noise variance estimated by maximum likelihood,
``sigma^2 = RSS / n``. With ``k`` = number of free model parameters plus one (for
sigma)::

    -2 ln L_max = n * ln(2 pi RSS / n) + n
    AIC = -2 ln L_max + 2 k
    BIC = -2 ln L_max + k ln(n)

``RSS = sum((F_measured - F_model)^2)`` (mN^2). To keep a perfect (noise-free) fit
finite, RSS is floored at ``n * (eps * max|F|)^2`` with ``eps`` the float64
machine epsilon. Only differences of AIC/BIC between models fitted to the *same*
data are meaningful.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from ..runtime.json_io import jsonable

__all__ = ["IdentificationResult", "build_result", "information_criteria", "jacobian_covariance"]

METHODS = ("ekf-paper", "ekf", "lsq")


def information_criteria(rss: float, n: int, n_free: int, scale: float = 1.0) -> tuple[float, float]:
    """AIC and BIC of a Gaussian fit with estimated noise (see module notes).

    Parameters
    ----------
    rss : float
        Residual sum of squares (mN^2).
    n : int
        Number of points.
    n_free : int
        Number of fitted model parameters (sigma is added internally).
    scale : float
        Force scale (mN) for the RSS floor, typically ``max|F|``.
    """
    floor = n * (np.finfo(float).eps * max(abs(scale), 1e-300)) ** 2
    rss = max(float(rss), floor)
    k = n_free + 1
    m2lnl = n * math.log(2.0 * math.pi * rss / n) + n
    return m2lnl + 2.0 * k, m2lnl + k * math.log(n)


def jacobian_covariance(J: np.ndarray) -> tuple[np.ndarray, int]:
    """Unscaled covariance ``(J^T J)^-1`` by SVD with a rank cut (as ``curve_fit``).

    Returns
    -------
    cov : ndarray (p, p)
        Pseudo-inverse; directions below the rank cut get ``inf`` variance.
    rank : int
    """
    J = np.atleast_2d(J)
    p = J.shape[1]
    if J.size == 0 or not np.all(np.isfinite(J)):
        return np.full((p, p), np.nan), 0
    _, s, VT = np.linalg.svd(J, full_matrices=False)
    threshold = np.finfo(float).eps * max(J.shape) * (s[0] if s.size else 0.0)
    keep = s > threshold
    VTk = VT[keep]
    cov = (VTk.T / s[keep] ** 2) @ VTk
    rank = int(keep.sum())
    if rank < p:
        cov = cov.copy()
        cov[:] = np.inf
    return cov, rank


def _correlation(cov: np.ndarray, fallback: np.ndarray | None = None) -> np.ndarray:
    d = np.diag(cov)
    if np.all(np.isfinite(d)) and np.all(d > 0):
        sd = np.sqrt(d)
        c = cov / np.outer(sd, sd)
        np.fill_diagonal(c, 1.0)
        return np.clip(c, -1.0, 1.0)
    if fallback is not None:
        return _correlation(fallback)
    return np.full_like(cov, np.nan)


def _jsonable(obj):
    """JSON-safe objects: the package's one encoder (:func:`skin_indent.runtime.json_io.jsonable`)."""
    return jsonable(obj)


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    """Estimate, uncertainty and diagnostics of one identification.

    Attributes
    ----------
    parameters : dict[str, float]
        All parameters (free and fixed), model order, in their units (kPa, -, ...).
    std : dict[str, float]
        Standard errors of the free parameters: ``sqrt(diag(covariance))``.
    covariance : ndarray (p, p)
        Covariance of the free parameters (order ``free_names``); its source is
        ``covariance_source``.
    free_names : tuple of str
        Names of the fitted parameters.
    correlation : ndarray (p, p)
        Correlation matrix of the free parameters.
    residuals_mN : ndarray (n,)
        Measured minus model force (mN).
    rms_mN : float
        Root-mean-square residual (mN).
    noise_mN : float
        The noise standard deviation sigma (mN) used for ``chi2`` and the covariance.
    n_points : int
    chi2 : float
        ``sum((residual / noise_mN)^2)``.
    aic_ml, bic_ml : float
        See the module notes (Gaussian likelihood, sigma estimated by maximum likelihood):
        :attr:`BIC_ML_FORMULA`. Not the ``bic`` of a fit's result, which weighs the residual by the
        error model (:data:`skin_indent.fitting.error_model.BIC_FORMULA`).
    method : {"ekf-paper", "ekf", "lsq"}
    iterations : int
        Sweeps through the curve for the filters; Jacobian evaluations (= TRF
        iterations) for least squares (``info["nfev"]`` has the function calls).
    status : int
        > 0 converged, 0 stopped at the iteration limit, < 0 failed.
    message : str
    history : dict[str, ndarray]
        Filters: ``"first_pass"`` (n, p) free parameters after each update of the
        first forward pass and ``"first_pass_std"``, ``"first_pass_covariance"``
        (n, p, p); ``"sweeps"`` (sweeps + 1, p) parameters at the end of each sweep
        (row 0 = start), ``"sweep_std"``, ``"sweep_covariance"``; ``"innovation"`` and
        ``"innovation_var"`` (n,) of the last sweep. Least squares:
        ``"iterates"`` (nfev, p), the free parameters at every function evaluation.
    fixed_names : tuple of str
        Parameters held fixed.
    covariance_source : str
        ``"jacobian"`` (``noise_mN^2 (J^T J)^-1``) or ``"filter"`` (final EKF P).
    info : dict
        Method-specific extras (``nfev``, ``time_s``, ``covariance_jacobian``, ...).
    """

    parameters: dict[str, float]
    std: dict[str, float]
    covariance: np.ndarray
    free_names: tuple[str, ...]
    correlation: np.ndarray
    residuals_mN: np.ndarray
    rms_mN: float
    noise_mN: float
    n_points: int
    chi2: float
    aic_ml: float
    bic_ml: float
    method: str
    iterations: int
    status: int
    message: str
    history: Mapping[str, np.ndarray] = field(default_factory=dict)
    fixed_names: tuple[str, ...] = ()
    covariance_source: str = "jacobian"
    info: Mapping[str, Any] = field(default_factory=dict)

    #: how ``bic_ml`` is computed
    BIC_ML_FORMULA = "n ln(2 pi RSS / n) + n + (p + 1) ln n (Gaussian, noise by maximum likelihood)"

    def criteria(self) -> dict:
        """The information criteria this result reports, by name (a fit's result: its ``aic`` and ``bic``
        against the error model, with their formula)."""
        return {"aic_ml": self.aic_ml, "bic_ml": self.bic_ml, "bic_ml_formula": self.BIC_ML_FORMULA}

    def criteria_line(self, digits: int = 5) -> str:
        """The line of :meth:`report` that gives the information criteria."""
        return f"    AIC_ml     = {self.aic_ml:.{digits}g}, BIC_ml = {self.bic_ml:.{digits}g}"

    @property
    def success(self) -> bool:
        """True if the method reports convergence (``status > 0``)."""
        return self.status > 0

    @property
    def n_free(self) -> int:
        return len(self.free_names)

    @property
    def redchi(self) -> float:
        """Reduced chi-square ``chi2 / (n - p)``."""
        dof = self.n_points - self.n_free
        return self.chi2 / dof if dof > 0 else math.nan

    def to_dict(self) -> dict:
        """JSON-safe summary (NaN/inf become None; no per-point arrays except residuals)."""
        d = {
            "method": self.method,
            "parameters": dict(self.parameters),
            "std": dict(self.std),
            "free_names": list(self.free_names),
            "fixed_names": list(self.fixed_names),
            "covariance": self.covariance,
            "correlation": self.correlation,
            "covariance_source": self.covariance_source,
            "rms_mN": self.rms_mN,
            "noise_mN": self.noise_mN,
            "n_points": self.n_points,
            "chi2": self.chi2,
            "redchi": self.redchi,
            **self.criteria(),
            "iterations": self.iterations,
            "status": self.status,
            "success": self.success,
            "message": self.message,
            "residuals_mN": self.residuals_mN,
            "info": {k: v for k, v in self.info.items()},
        }
        out = _jsonable(d)
        json.dumps(out)  # guarantee
        return out

    def report(self, digits: int = 5, units=None) -> str:
        """Readable multi-line summary, in the spirit of lmfit's ``fit_report``.

        ``units``: a :class:`~skin_indent.measurement.scale.DisplayUnits` to show forces and the
        parameters with a unit suffix in (``E_kPa`` as ``E_Pa``...); default the package units.
        """
        u = units or _PACKAGE_UNITS
        lines = [
            f"[[Identification: {self.method}]]",
            f"    status     = {self.status} ({self.message})",
            f"    iterations = {self.iterations}" + (" sweeps" if self.method.startswith("ekf") else ""),
            f"    points     = {self.n_points}, free parameters = {self.n_free}",
            f"    rms        = {self.rms_mN * u.per_mN:.{digits}g} {u.force}, noise sigma = "
            f"{self.noise_mN * u.per_mN:.{digits}g} {u.force}",
            f"    chi-square = {self.chi2:.{digits}g}, reduced = {self.redchi:.{digits}g}",
            self.criteria_line(digits),
            f"[[Parameters]]  (std from {self.covariance_source})",
        ]
        width = max(len(u.name(n)) for n in self.parameters)
        for name, value in self.parameters.items():
            k, shown = u.factor(name), u.name(name)
            value = value * k
            if name in self.std:
                sd = self.std[name] * k
                rel = f" ({100 * sd / abs(value):.3g}%)" if value != 0 and math.isfinite(sd) else ""
                lines.append(f"    {shown:<{width}} = {value:.{digits}g} +/- {sd:.3g}{rel}")
            else:
                lines.append(f"    {shown:<{width}} = {value:.{digits}g} (fixed)")
        pairs = self.correlation_pairs()
        if pairs:
            lines.append("[[Correlations]]")
            for a, b, r in pairs:
                lines.append(f"    C({u.name(a)}, {u.name(b)}) = {r:+.4f}")
        return "\n".join(lines)

    def correlation_pairs(self) -> list[tuple[str, str, float]]:
        """``(name, name, correlation)`` of every pair of free parameters, as :meth:`report` lists them
        (results whose ``parameters`` are not the fit's coordinates give them under the names
        ``parameters`` uses)."""
        return [(self.free_names[i], self.free_names[j], float(self.correlation[i, j]))
                for i in range(self.n_free) for j in range(i + 1, self.n_free)]

    def __str__(self) -> str:
        return self.report()


class _PackageUnits:
    """The package units (mm, mN, kPa) as :meth:`IdentificationResult.report` asks for units."""

    force, per_mN = "mN", 1.0

    @staticmethod
    def name(name: str) -> str:
        return name

    @staticmethod
    def factor(name: str) -> float:
        return 1.0


_PACKAGE_UNITS = _PackageUnits()


def build_result(problem, x: np.ndarray, *, method: str, iterations: int, status: int, message: str,
                 noise_mN: float | None = None, covariance: np.ndarray | None = None,
                 covariance_source: str = "jacobian", history: Mapping[str, np.ndarray] | None = None,
                 info: Mapping[str, Any] | None = None) -> IdentificationResult:
    """Assemble an :class:`IdentificationResult` at the free-parameter vector ``x``.

    Parameters
    ----------
    problem : Problem
        From ``_problem.make_problem``.
    x : ndarray
        Estimated free parameters.
    noise_mN : float, optional
        Noise sigma to use; default ``sqrt(RSS / (n - p))`` from the residuals.
    covariance : ndarray, optional
        Covariance to report (e.g. a filter's P); default the Jacobian estimate
        ``noise_mN^2 (J^T J)^-1``, which is then also stored as
        ``info["covariance_jacobian"]`` in either case.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    x = np.asarray(x, dtype=float)
    n, p = problem.n, x.size
    residuals = problem.force_mN - problem.model_force(x)
    rss = float(residuals @ residuals)
    scale = float(np.max(np.abs(problem.force_mN))) or 1.0
    s_resid = math.sqrt(rss / (n - p)) if n > p else math.nan
    sigma = float(noise_mN) if noise_mN is not None else s_resid
    sigma = max(sigma, np.finfo(float).eps * scale)
    unscaled, rank = jacobian_covariance(problem.model_jacobian(x))
    cov_jac = sigma**2 * unscaled
    cov = cov_jac if covariance is None else np.asarray(covariance, dtype=float).reshape(p, p)
    with np.errstate(invalid="ignore"):
        sd = np.sqrt(np.where(np.diag(cov) >= 0, np.diag(cov), np.nan))
    aic_ml, bic_ml = information_criteria(rss, n, p, scale)
    extra = dict(info or {})
    extra.setdefault("covariance_jacobian", cov_jac)
    extra.setdefault("residual_sigma_mN", s_resid)
    extra.setdefault("jacobian_rank", rank)
    return IdentificationResult(
        parameters=dict(zip(problem.params.names, map(float, problem.theta(x)))),
        std=dict(zip(problem.free_names, map(float, sd))),
        covariance=cov,
        free_names=problem.free_names,
        correlation=_correlation(cov, unscaled),
        residuals_mN=residuals,
        rms_mN=math.sqrt(rss / n),
        noise_mN=sigma,
        n_points=n,
        chi2=rss / sigma**2,
        aic_ml=aic_ml,
        bic_ml=bic_ml,
        method=method,
        iterations=int(iterations),
        status=int(status),
        message=str(message),
        history=dict(history or {}),
        fixed_names=problem.params.fixed_names,
        covariance_source=covariance_source,
        info=extra,
    )
