"""Bounded nonlinear least squares on a force model (scipy ``least_squares``, TRF)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping

import numpy as np

from ._coords import Coordinates
from ._units import in_force_units
from ._problem import make_problem
from .result import IdentificationResult, build_result, jacobian_covariance
from ._problem import iterating

__all__ = ["fit_least_squares"]


@in_force_units
def fit_least_squares(model, depth, force, x0, *, fixed: Mapping[str, float] | None = None,
                      noise_mN: float | None = None, coordinates: str = "auto", x_scale="jac",
                      loss: str = "linear", ftol: float = 1e-8, xtol: float = 1e-8, gtol: float = 1e-10,
                      max_nfev: int | None = None, priors=None, sigma_mN=None) -> IdentificationResult:
    """Fit the free parameters by bounded least squares.

    Minimises ``sum((F_model(h_i; theta) - F_i)^2)`` with
    :func:`scipy.optimize.least_squares` (``method="trf"``, bounds = the model's
    box, analytic Jacobian from ``model.jacobian``), in internal coordinates ``u``
    that straighten the E-nu valley (``coordinates="auto"``: ``u = (log E*, nu)``
    with ``E* = E / (1 - nu^2)`` when both are free; log of other moduli). TRF
    keeps ``u`` strictly inside its box and the raw point is clipped to the model
    box, so ``model.force`` is never called outside its bounds.

    Parameters
    ----------
    model : ForceModel
        Forward model (``force``, ``jacobian``, ``parameter_names``, ``bounds``).
    depth : array_like (n,)
        Depths (mm).
    force : array_like (n,)
        Measured forces (mN).
    x0 : array_like, mapping or ParameterSet
        Start values (full length in model order, or by name).
    fixed : mapping, optional
        ``{name: value}`` held fixed; only the other parameters are fitted, the
        model still receives the full theta.
    noise_mN : float, optional
        Known noise sigma (mN). Default: ``s = sqrt(RSS / (n - p))`` from the
        residuals at the solution.
    coordinates : {"auto", "hertz", "log", "linear"}
        Internal coordinates (see ``skin_indent.inverse._coords``). ``"linear"``
        fits raw (E, nu): correct but 2-5x more iterations along the curved valley.
    x_scale : {"jac"} or array_like
        Scaling of ``u`` passed to scipy (``"jac"``: inverse column norms of J).
    loss : str
        scipy loss (``"linear"`` for ordinary least squares; robust losses change
        the meaning of the covariance, and their soft margin, scipy's
        ``f_scale = 1``, is one RMS of the measured force).
    ftol, xtol, gtol : float
        scipy tolerances. Tight defaults: the curves have 100 points, each
        iteration is cheap. The residuals handed to scipy are divided by the
        RMS of the measured force, so ``gtol`` (scipy's is absolute) is relative
        to the data's force scale: the same for an AFM curve (nN) as for skin
        (mN). A loose ``gtol`` stops early in the narrow E-nu valley of a short
        curve (8 points to 0.3 mm: 1e-8 absolute left E 2.5e-4 off).
    max_nfev : int, optional
        Function-evaluation limit (scipy default if None).
    sigma_mN : array_like (n,), optional
        Standard deviation of each point (mN), an error model (the noise and the forward
        model's relative error in quadrature): the fit minimises ``sum(r_i^2 / sigma_i^2)``,
        the covariance is ``(J^T W J)^-1`` with ``W = diag(1 / sigma_i^2)``
        (``covariance_source = "weighted jacobian"``) and ``chi2`` is that sum. ``noise_mN``
        stays the noise level reported with the result (default the smallest sigma_i).
    priors : sequence of (callable, float, float), optional
        Gaussian priors ``(g, mean, sd)``: ``g(theta)`` is a quantity of the full parameter
        vector (a parameter as users read it: a thickness in mm, a ratio...) known
        independently as ``mean +- sd`` (an ultrasound thickness). Each adds the residual
        ``(g(theta) - mean) / sd`` to the data's ``(F_model - F) / noise``, so the cost is
        ``-2 ln`` of the posterior; the covariance is then ``(J_w^T J_w)^-1`` of the whitened
        Jacobian with the prior rows (``covariance_source = "jacobian+priors"``), and
        ``info["prior_chi2"]`` holds the priors' share of the cost. Needs ``noise_mN``.

    Returns
    -------
    IdentificationResult
        ``method="lsq"``; ``iterations`` = Jacobian evaluations (TRF iterations),
        ``info["nfev"]`` = function evaluations; ``history["iterates"]`` (nfev, p)
        holds the free parameters at every function evaluation. Covariance
        ``noise_mN^2 (J^T J)^-1`` at the solution (SVD pseudo-inverse); not
        meaningful for a parameter sitting on an active bound. ``status`` is
        scipy's (1-4 converged, 0 max_nfev reached, -1 failure).

    Raises
    ------
    ValueError
        Bad data, x0 or fixed values outside the bounds, unknown names.
    """
    problem = make_problem(model, depth, force, x0, fixed)
    lo, hi = problem.params.free_bounds()
    x_start = problem.params.to_array()
    if noise_mN is not None and not (np.isfinite(noise_mN) and noise_mN > 0):
        raise ValueError(f"noise_mN must be a positive number, got {noise_mN}")
    coords = Coordinates(problem.free_names, lo, hi, coordinates)
    priors = list(priors or ())
    weighted = sigma_mN is not None
    if weighted:
        sigma_mN = np.broadcast_to(np.asarray(sigma_mN, dtype=float), problem.force_mN.shape)
        if not np.all(np.isfinite(sigma_mN) & (sigma_mN > 0)):
            raise ValueError("sigma_mN must be positive and finite at every point")
        if noise_mN is None:
            noise_mN = float(sigma_mN.min())
    if priors and noise_mN is None:
        raise ValueError("priors need the noise level (noise_mN): they are weighed against it")
    # data rows are (F_model - F) / scale, times noise / sigma_i where points are weighted
    row_weight = noise_mN / sigma_mN if weighted else None
    for _, mean, sd in priors:
        if not (np.isfinite(mean) and np.isfinite(sd) and sd > 0):
            raise ValueError(f"a prior needs a finite mean and a positive sd, got {mean} +- {sd}")

    iterates = []
    scale = float(np.sqrt(np.mean(problem.force_mN**2))) or 1.0  # mN: tolerances relative to the data
    # prior rows in the units of the data rows: (g - mean) / sd times noise / scale
    weight = np.array([noise_mN / (scale * sd) for _, _, sd in priors]) if priors else None

    def prior_residual(x):
        theta = problem.theta(x)
        return np.array([g(theta) - mean for g, mean, _ in priors]) * weight

    def prior_jacobian(x):
        """d prior residual / d x (central differences in the free parameters: no force model run)."""
        G = np.zeros((len(priors), x.size))
        for j in range(x.size):
            step = 1e-6 * max(abs(x[j]), 1e-6)
            up, down = x.copy(), x.copy()
            up[j] = min(x[j] + step, hi[j])
            down[j] = max(x[j] - step, lo[j])
            if up[j] > down[j]:
                G[:, j] = (prior_residual(up) - prior_residual(down)) / (up[j] - down[j])
        return G

    def fun(u):
        x = coords.external(u)[0]
        iterates.append(x)
        r = (problem.model_force(x) - problem.force_mN) / scale
        if weighted:
            r = r * row_weight
        return np.r_[r, prior_residual(x)] if priors else r

    def jac(u):
        x, dxdu = coords.external(u)
        if not (priors or weighted):
            return problem.model_jacobian(x) @ dxdu / scale
        J = problem.model_jacobian(x) / scale
        if weighted:
            J = J * row_weight[:, None]
        return (np.vstack([J, prior_jacobian(x)]) if priors else J) @ dxdu

    from scipy.optimize import least_squares  # lazy: scipy.optimize is slow to import

    t0 = time.perf_counter()
    with iterating(model):  # the iterations' Jacobians may be secant updates; the covariance's is exact
        sol = least_squares(fun, coords.internal(x_start), jac=jac, bounds=coords.bounds, method="trf",
                            x_scale=x_scale, loss=loss, ftol=ftol, xtol=xtol, gtol=gtol, max_nfev=max_nfev)
    elapsed = time.perf_counter() - t0
    x = coords.external(sol.x)[0]
    span = hi - lo
    active = [n for n, xi, a, b, w in zip(problem.free_names, x, lo, hi, span)
              if min(xi - a, b - xi) <= 1e-9 * w]
    message = sol.message.rstrip(".")
    if active:
        message += f"; at bound: {', '.join(active)}"
    info = {"nfev": int(sol.nfev), "njev": int(sol.njev or 0), "optimality": float(sol.optimality),
            "active_bounds": active, "time_s": elapsed, "coordinates": coords.kind,
            "x0": dict(zip(problem.free_names, x_start))}
    covariance, source = None, "jacobian"
    if priors or weighted:
        # whitened rows: data (F_model - F) / sigma_i, priors (g - mean) / sd
        Jd = problem.model_jacobian(x) / (sigma_mN[:, None] if weighted else noise_mN)
        covariance, _ = jacobian_covariance(np.vstack([Jd, prior_jacobian(x) * scale / noise_mN]) if priors else Jd)
        source = "weighted jacobian" if weighted else "jacobian"
        if priors:
            source += "+priors"
            info["prior_chi2"] = float(np.sum((prior_residual(x) * scale / noise_mN) ** 2))
    result = build_result(
        problem, x, method="lsq", iterations=sol.njev if sol.njev is not None else sol.nfev,
        status=sol.status, message=message, noise_mN=noise_mN, covariance=covariance, covariance_source=source,
        history={"iterates": np.array(iterates)}, info=info)
    if weighted:
        result = dataclasses.replace(result, chi2=float(np.sum((result.residuals_mN / sigma_mN) ** 2)))
    return result
