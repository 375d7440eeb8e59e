"""Is a parameter determined by the curve? Profile likelihood and the Hertz E* tie.

Hertz contact depends on ``E* = E / (1 - nu^2)`` only, so from a small-strain curve
(E, nu) is not unique. The paper argues that large strain breaks the tie; how well
it does is measured here, not assumed:

:func:`profile`
    Profile chi-square of one parameter (the others re-fitted by least squares at
    each fixed value) with its 68% / 95% intervals from Delta chi2 = 1 / 3.84, and
    a verdict.
:func:`hertz_equivalence`
    How much of the nu-information comes only through E*: correlations, the
    conditional standard deviations of nu given E and given E*, and E* along the
    nu profile.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ._problem import make_problem
from .least_squares import fit_least_squares
from ..runtime.json_io import jsonable as _jsonable

__all__ = ["Profile", "profile", "HertzEquivalence", "hertz_equivalence", "DELTA_CHI2_68", "DELTA_CHI2_95"]

#: Delta chi2 for a 1-sigma (68.3%) interval of one parameter.
DELTA_CHI2_68 = 1.0
#: Delta chi2 for a 95% interval of one parameter (chi2 quantile, 1 dof).
DELTA_CHI2_95 = 3.841458820694124


@dataclass(frozen=True, eq=False)
class Profile:
    """Profile chi-square of one parameter.

    Attributes
    ----------
    name : str
        Profiled parameter.
    values : ndarray (m,)
        Fixed values of the parameter, increasing (includes the best fit).
    chi2 : ndarray (m,)
        ``RSS / noise_mN^2`` after re-fitting the other free parameters.
    delta_chi2 : ndarray (m,)
        ``chi2 - chi2_min``.
    rms_mN : ndarray (m,)
        RMS residual (mN) at each value.
    others : dict[str, ndarray]
        Best values of the other free parameters along the profile.
    best_value, chi2_min : float
        Global least-squares optimum.
    noise_mN : float
        sigma (mN) used to scale chi2.
    interval_68, interval_95 : (float, float)
        Where Delta chi2 crosses 1 and 3.84 (signed-root interpolation, exact for a
        parabolic profile); an end that never crosses is the grid end (= the box
        bound for the default grid) and is flagged in ``open_68`` / ``open_95``.
    identifiable : bool
        True if the 95% interval closes on both sides inside the grid.
    verdict : str
    """

    name: str
    values: np.ndarray
    chi2: np.ndarray
    delta_chi2: np.ndarray
    rms_mN: np.ndarray
    others: dict
    best_value: float
    chi2_min: float
    noise_mN: float
    interval_68: tuple
    interval_95: tuple
    open_68: tuple
    open_95: tuple
    identifiable: bool
    verdict: str

    def to_dict(self) -> dict:
        """JSON-safe dictionary."""
        return _jsonable({k: getattr(self, k) for k in self.__dataclass_fields__})

    def report(self) -> str:
        """Readable text table of the profile."""
        lines = [f"[[Profile of {self.name}]]  noise sigma = {self.noise_mN:.4g} mN",
                 f"    best {self.name} = {self.best_value:.6g}, chi2_min = {self.chi2_min:.6g}",
                 f"    68% interval: [{self.interval_68[0]:.6g}, {self.interval_68[1]:.6g}]",
                 f"    95% interval: [{self.interval_95[0]:.6g}, {self.interval_95[1]:.6g}]",
                 f"    verdict: {self.verdict}",
                 f"    {self.name:>10} {'delta_chi2':>12} {'rms_mN':>10} " + " ".join(f"{k:>10}" for k in self.others)]
        for i, v in enumerate(self.values):
            other = " ".join(f"{self.others[k][i]:10.5g}" for k in self.others)
            lines.append(f"    {v:10.5g} {self.delta_chi2[i]:12.5g} {self.rms_mN[i]:10.4g} {other}")
        return "\n".join(lines)


def _crossing(values, root, i_min, level, direction):
    """First crossing of sqrt(delta chi2) = sqrt(level) walking from i_min; (value, open?)."""
    target = math.sqrt(level)
    i = i_min
    while 0 <= i + direction < len(values):
        j = i + direction
        if root[j] >= target:
            t = (target - root[i]) / (root[j] - root[i]) if root[j] > root[i] else 1.0
            return float(values[i] + t * (values[j] - values[i])), False
        i = j
    return float(values[i]), True


def profile(model, depth, force, name: str = "nu", values=None, *, x0=None,
            fixed: Mapping[str, float] | None = None, noise_mN: float | None = None,
            n_values: int = 31) -> Profile:
    """Profile chi-square of parameter ``name``.

    For each fixed value of ``name`` the other free parameters are re-fitted by
    :func:`fit_least_squares` (warm-started from the neighbouring value, walking
    outward from the global optimum).

    Parameters
    ----------
    model : ForceModel
    depth, force : array_like (n,)
        Depths (mm) and forces (mN).
    name : str
        Parameter to profile (must be free).
    values : array_like, optional
        Values to fix it at; default ``n_values`` points spanning its bounds. The
        global optimum is always added.
    x0 : array_like or mapping, optional
        Start of the global fit; default the box centre.
    fixed : mapping, optional
        Other parameters held fixed throughout.
    noise_mN : float, optional
        sigma (mN) for chi2; default ``sqrt(RSS_min / (n - p))`` of the global fit
        (model misfit then counts as noise, which widens the intervals).
    n_values : int

    Returns
    -------
    Profile

    Notes
    -----
    Intervals use the profile-likelihood rule Delta chi2 = 1 (68%) and 3.84 (95%)
    for one parameter, valid when sigma is right and the noise Gaussian and
    independent.
    """
    fixed = dict(fixed or {})
    if name in fixed:
        raise ValueError(f"cannot profile {name!r}: it is fixed")
    problem = make_problem(model, depth, force, x0, fixed)
    if name not in problem.params:
        raise ValueError(f"unknown parameter {name!r}; model has {problem.params.names}")
    lo, hi = problem.params[name].lower, problem.params[name].upper
    best = fit_least_squares(model, problem.depth, problem.force_mN, problem.params, fixed=fixed, noise_mN=noise_mN)
    sigma = float(noise_mN) if noise_mN is not None else best.noise_mN
    best_value = best.parameters[name]
    if values is None:
        if int(n_values) < 3:
            raise ValueError(f"n_values must be >= 3, got {n_values}")
        values = np.linspace(lo, hi, int(n_values))
    values = np.asarray(values, float).reshape(-1)
    if values.size == 0 or not np.all(np.isfinite(values)) or np.any((values < lo) | (values > hi)):
        raise ValueError(f"profile values must be finite and inside [{lo:g}, {hi:g}]")
    near = np.abs(values - best_value) <= 1e-9 * max(hi - lo, abs(best_value), 1e-300)
    grid = np.unique(np.r_[values[~near], best_value])
    others = [k for k in problem.free_names if k != name]
    rss = np.full(grid.size, np.nan)
    opt = {k: np.full(grid.size, np.nan) for k in others}
    i_best = int(np.searchsorted(grid, best_value))
    for direction in (+1, -1):
        start = dict(best.parameters)
        i = i_best if direction > 0 else i_best - 1
        while 0 <= i < grid.size:
            fix_i = {**fixed, name: float(grid[i])}
            if others:
                r = fit_least_squares(model, problem.depth, problem.force_mN, start, fixed=fix_i, noise_mN=sigma)
                rss[i] = float(r.residuals_mN @ r.residuals_mN)
                for k in others:
                    opt[k][i] = r.parameters[k]
                start = dict(r.parameters)
            else:
                theta = problem.params.with_values(fix_i).values
                res = problem.force_mN - np.asarray(model.force(problem.depth, theta), float)
                rss[i] = float(res @ res)
            i += direction
    chi2 = rss / sigma**2
    chi2_min = float(min(np.min(chi2), (best.residuals_mN @ best.residuals_mN) / sigma**2))
    delta = np.maximum(chi2 - chi2_min, 0.0)
    root = np.sqrt(delta)
    i_min = int(np.argmin(delta))
    ci = {}
    for level in (DELTA_CHI2_68, DELTA_CHI2_95):
        (a, oa), (b, ob) = _crossing(grid, root, i_min, level, -1), _crossing(grid, root, i_min, level, +1)
        ci[level] = ((a, b), (oa, ob))
    (a95, b95), (oa, ob) = ci[DELTA_CHI2_95]
    identifiable = not (oa or ob)
    if identifiable:
        verdict = f"identifiable: {name} = {best_value:.4g}, 95% interval [{a95:.4g}, {b95:.4g}]"
    else:
        if oa and ob:
            verdict = (f"not identifiable: Delta chi2 stays below {DELTA_CHI2_95:.2f} over the whole range "
                       f"[{a95:.4g}, {b95:.4g}]")
        elif ob:
            verdict = (f"bounded only from below: {name} > {a95:.4g} (95%); Delta chi2 stays below "
                       f"{DELTA_CHI2_95:.2f} up to the upper bound {b95:.4g}")
        else:
            verdict = (f"bounded only from above: {name} < {b95:.4g} (95%); Delta chi2 stays below "
                       f"{DELTA_CHI2_95:.2f} down to the lower bound {a95:.4g}")
    return Profile(
        name=name, values=grid, chi2=chi2, delta_chi2=delta, rms_mN=np.sqrt(rss / problem.n), others=opt,
        best_value=float(best_value), chi2_min=chi2_min, noise_mN=sigma,
        interval_68=ci[DELTA_CHI2_68][0], interval_95=(a95, b95), open_68=ci[DELTA_CHI2_68][1], open_95=(oa, ob),
        identifiable=identifiable, verdict=verdict,
    )


@dataclass(frozen=True, eq=False)
class HertzEquivalence:
    """How much of the nu-information is only through E* = E / (1 - nu^2).

    Attributes
    ----------
    E_kPa, nu : float
        Least-squares estimate.
    E_star_kPa, E_star_std_kPa : float
        E* and its standard error (delta method).
    correlation_E_nu : float
        Correlation of (E, nu): near -1 when the data only pin E*.
    correlation_E_star_nu : float
        Correlation of (E*, nu).
    nu_std : float
        Marginal standard error of nu (E free).
    nu_std_given_E : float
        Standard error of nu if E were known (all nu-information).
    nu_std_given_E_star : float
        Standard error of nu if E* were known: the information beyond Hertz (large
        strain, ...). ``inf`` for a pure Hertz model.
    fraction_through_E_star : float
        ``1 - (nu_std_given_E / nu_std_given_E_star)^2``: share of the nu-information
        (at known E) that comes only through E*. 1 = pure Hertz tie.
    profile : Profile
        nu profile; ``E_star_profile`` holds E* along it.
    E_star_profile : ndarray
        E* (kPa) of the re-fitted E at each profiled nu.
    E_star_spread : float
        (max - min) / median of ``E_star_profile`` over the 95% nu-interval.
    noise_mN : float
    summary : str
    """

    E_kPa: float
    nu: float
    E_star_kPa: float
    E_star_std_kPa: float
    correlation_E_nu: float
    correlation_E_star_nu: float
    nu_std: float
    nu_std_given_E: float
    nu_std_given_E_star: float
    fraction_through_E_star: float
    profile: Profile
    E_star_profile: np.ndarray
    E_star_spread: float
    noise_mN: float
    summary: str

    def to_dict(self) -> dict:
        """JSON-safe dictionary (the profile nested)."""
        d = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "profile"}
        d["profile"] = self.profile.to_dict()
        return _jsonable(d)


def hertz_equivalence(model, depth, force, *, x0=None, modulus: str = "E_kPa", poisson: str = "nu",
                      fixed: Mapping[str, float] | None = None, noise_mN: float | None = None,
                      n_values: int = 15) -> HertzEquivalence:
    """Measure how much the curve tells about nu beyond ``E* = E / (1 - nu^2)``.

    Parameters
    ----------
    model : ForceModel
        Must have free parameters named ``modulus`` and ``poisson``.
    depth, force : array_like (n,)
        Depths (mm) and forces (mN).
    x0, fixed, noise_mN
        As :func:`profile`.
    n_values : int
        Points of the nu profile.

    Returns
    -------
    HertzEquivalence

    Notes
    -----
    Works on the Fisher information ``I = J^T J / sigma^2`` at the least-squares
    estimate (finite even when nu is not identifiable at all), in (E, nu) and in
    (E*, nu) (Jacobian ``J T`` with ``T = d(E, nu)/d(E*, nu)``). Conditional
    standard deviations are ``1/sqrt(I_nn)``, marginal ones use the Schur
    complement; other free parameters are marginalised out.
    """
    fixed = dict(fixed or {})
    for nm in (modulus, poisson):
        if nm in fixed:
            raise ValueError(f"{nm!r} must be free for hertz_equivalence")
    start = _centre(model) if x0 is None else x0
    problem = make_problem(model, depth, force, start, fixed)
    if modulus not in problem.free_names or poisson not in problem.free_names:
        raise ValueError(f"model needs free parameters {modulus!r} and {poisson!r}; has {problem.free_names}")
    fit = fit_least_squares(model, problem.depth, problem.force_mN, problem.params, fixed=fixed, noise_mN=noise_mN)
    sigma = fit.noise_mN
    E, nu = fit.parameters[modulus], fit.parameters[poisson]
    k = 1.0 / (1.0 - nu * nu)
    E_star = E * k
    # Jacobian columns (E, nu) and (E*, nu); other free parameters are marginalised
    # out of the information (Schur complement).
    x = np.array([fit.parameters[nm] for nm in problem.free_names])
    J = problem.model_jacobian(x) / sigma
    ie, iv = problem.free_names.index(modulus), problem.free_names.index(poisson)
    rest = [i for i in range(J.shape[1]) if i not in (ie, iv)]
    T = np.array([[1.0 - nu * nu, -2.0 * nu * E_star], [0.0, 1.0]])  # d(E, nu) / d(E*, nu)
    J2 = J[:, [ie, iv]]
    info, info_s = _schur(J2, J[:, rest]), _schur(J2 @ T, J[:, rest])
    tiny = np.finfo(float).eps * max(info[0, 0], info[1, 1], 1e-300)

    def _marg(I, a, b):
        # marginal sd of entry a: 1 / sqrt(I_aa - I_ab^2 / I_bb)
        s_aa = I[a, a] - (I[a, b] ** 2 / I[b, b] if I[b, b] > tiny else 0.0)
        return 1.0 / math.sqrt(s_aa) if s_aa > tiny * 1e-6 else math.inf

    def _corr(I):
        d = math.sqrt(I[0, 0] * I[1, 1])
        return float(-I[0, 1] / d) if d > tiny else 0.0

    rho, rho_s = _corr(info), _corr(info_s)
    nu_std = _marg(info, 1, 0)
    given_E = 1.0 / math.sqrt(info[1, 1]) if info[1, 1] > tiny else math.inf
    given_Es = 1.0 / math.sqrt(info_s[1, 1]) if info_s[1, 1] > tiny * 1e-12 else math.inf
    frac = 1.0 - info_s[1, 1] / info[1, 1] if info[1, 1] > tiny else math.nan
    frac = float(min(max(frac, 0.0), 1.0))
    E_star_std = _marg(info_s, 0, 1) if math.isfinite(given_Es) else 1.0 / math.sqrt(info_s[0, 0])
    prof = profile(model, depth, force, poisson, x0=dict(fit.parameters), fixed=fixed, noise_mN=sigma,
                   n_values=n_values)
    e_star = prof.others[modulus] / (1.0 - prof.values**2)
    a, b = prof.interval_95
    inside = (prof.values >= a) & (prof.values <= b) & np.isfinite(e_star)
    sel = e_star[inside] if inside.sum() >= 2 else e_star[np.isfinite(e_star)]
    spread = float((sel.max() - sel.min()) / np.median(sel)) if sel.size >= 2 else 0.0
    summary = (f"E* = {E_star:.4g} +/- {E_star_std:.2g} kPa; corr(E, nu) = {rho:+.6f}; "
               f"nu = {nu:.4g} +/- {nu_std:.2g} (+/- {given_E:.2g} if E known, +/- {given_Es:.2g} if E* known); "
               f"{100 * frac:.2f}% of the nu-information at known E comes only through E*; "
               f"nu profile: {prof.verdict}")
    return HertzEquivalence(
        E_kPa=E, nu=nu, E_star_kPa=E_star, E_star_std_kPa=E_star_std, correlation_E_nu=rho,
        correlation_E_star_nu=rho_s, nu_std=nu_std, nu_std_given_E=given_E, nu_std_given_E_star=given_Es,
        fraction_through_E_star=frac, profile=prof, E_star_profile=e_star, E_star_spread=spread,
        noise_mN=sigma, summary=summary,
    )


def _schur(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Information of the columns A with the columns B marginalised out."""
    I_aa = A.T @ A
    if B.shape[1] == 0:
        return I_aa
    I_ab, I_bb = A.T @ B, B.T @ B
    return I_aa - I_ab @ np.linalg.pinv(I_bb) @ I_ab.T


def _centre(model):
    lo, hi = (np.asarray(b, float) for b in model.bounds)
    return 0.5 * (lo + hi)
