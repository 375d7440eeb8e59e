"""What the user knows about a sample, in a fit: values held and Gaussian priors.

:func:`held_coordinates` holds reported parameters (``ratio``) through the fit coordinates they
are functions of (``compliance``, with :func:`solve_coordinate`); :func:`prior_rows` are the
priors' rows of a covariance; :func:`prior_summary` says what the data did to a prior.
"""

from __future__ import annotations

import math

import numpy as np


#: posterior sd over prior sd below which the data determined a parameter, above which the prior did
DATA_DETERMINED, PRIOR_DETERMINED = 0.5, 0.9
#: a prior and the data disagree when the data alone put the parameter this many combined sd away
TENSION = 3.0
#: what ``determined_by`` of :func:`prior_summary` means, in words
DETERMINED_BY = {"data": "determined by the data", "prior": "determined by the prior",
                 "both": "data and prior both count", "unknown": "not determined"}


def prior_summary(posterior: float, posterior_sd: float, mean: float, sd: float, alone=None) -> dict:
    r"""What the data did to a Gaussian prior ``mean +- sd`` on one parameter.

    ``narrowed`` = posterior sd / prior sd (1: the data added nothing); ``determined_by``
    ``"data"`` (below :data:`DATA_DETERMINED`), ``"prior"`` (above :data:`PRIOR_DETERMINED`)
    or ``"both"``; ``tension`` = how many combined sd separate the prior from what the data
    alone say, :math:`|a - m| / \sqrt{s_d^2 + s_p^2}`, flagged above :data:`TENSION`.

    What the data alone say, ``a +- s_d``, is ``alone`` where given (the fit without this prior:
    :func:`tension_checked`), else the linear-Gaussian estimate from the posterior,
    ``1/s_d^2 = 1/s_post^2 - 1/s_p^2`` and ``a = s_d^2 (post/s_post^2 - m/s_p^2)``.
    """
    ratio = posterior_sd / sd if math.isfinite(posterior_sd) else math.nan
    if not math.isfinite(ratio):
        by = "unknown"
    else:
        by = "data" if ratio < DATA_DETERMINED else "prior" if ratio > PRIOR_DETERMINED else "both"
    tension = math.nan
    if alone is not None:
        a, sd_data = alone
        if math.isfinite(a) and math.isfinite(sd_data):
            tension = abs(a - mean) / math.hypot(sd_data, sd)
    elif math.isfinite(ratio) and 0 < ratio < 1:
        info_data = 1 / posterior_sd**2 - 1 / sd**2
        sd_data = 1 / math.sqrt(info_data)
        a = (posterior / posterior_sd**2 - mean / sd**2) / info_data
        tension = abs(a - mean) / math.hypot(sd_data, sd)
    out = {"prior_mean": mean, "prior_sd": sd, "posterior": posterior, "posterior_sd": posterior_sd,
           "narrowed": ratio, "determined_by": by, "tension_sd": tension,
           "in_tension": bool(math.isfinite(tension) and tension > TENSION)}
    if alone is not None:
        out["data_alone"], out["data_alone_sd"] = float(alone[0]), float(alone[1])
    return out


def needs_data_alone(summary: dict) -> bool:
    """The linear-Gaussian tension of ``summary`` (:func:`prior_summary`) flags a prior that determines
    the parameter: there it cannot be trusted, and the fit without the prior decides.

    Where the prior determines the parameter (posterior sd above :data:`PRIOR_DETERMINED` times the
    prior's), the data's information ``1/s_post^2 - 1/s_p^2`` is a small difference of two nearly equal
    numbers and the data-alone estimate an extrapolation far beyond the posterior: for a nonlinear
    model a shift of a fraction of the prior's sd, made by the model's curvature, reads as many sd
    (measured: the forearm-like curve's two layers with the dermis thickness 1.0 +- 0.1 mm, the truth,
    ended at 1.067 +- 0.0991 mm; extrapolated, the data alone would say 4.7 +- 0.74 mm, 5.0 combined sd
    from the prior; fitted without the prior they say 1.32 +- 0.38 mm, 0.81 sd). A prior 5 sd from the
    truth and four times narrower than the data's sd reads the same by the posterior alone (measured, the v02 layer curve: ``narrowed`` 0.99): only the fit
    without the prior tells them apart.
    """
    return bool(summary["in_tension"] and summary["determined_by"] == "prior")


def solve_coordinate(model, x, j: int, name: str, value: float) -> float:
    """The fit coordinate ``j`` at which the reported parameter ``name`` equals ``value`` (the other
    coordinates as in ``x``); ``ValueError`` when no value of the coordinate's range gives it."""
    from scipy.optimize import brentq  # lazy: scipy.optimize is slow to import

    lo, hi = model.bounds[0][j], model.bounds[1][j]

    def reported(t):
        y = np.array(x, dtype=float)
        y[j] = t
        return float(model.model_parameters(y)[name])

    for end in (lo, hi):
        if math.isfinite(end) and reported(end) == value:
            return float(end)
    top = hi if math.isfinite(hi) else max(lo, 0.0) + 1e6
    grid = np.linspace(lo, top, 401)
    values = np.array([reported(t) for t in grid])
    diff = values - value
    for a, b, fa, fb in zip(grid[:-1], grid[1:], diff[:-1], diff[1:]):
        if math.isfinite(fa) and math.isfinite(fb) and fa * fb <= 0:
            return float(a if fa == 0 else brentq(lambda t: reported(t) - value, a, b, xtol=1e-14, rtol=1e-12))
    finite = values[np.isfinite(values)]
    span = f"{finite.min():.4g} to {finite.max():.4g}" if finite.size else "none"
    raise ValueError(f"{name} = {value:g} is outside what {model.name} can take (from {span})")


def held_coordinates(model, fixed: dict) -> dict:
    """The values ``fixed`` (by the names results report) of the parameters ``model`` has, as its
    fit coordinates ``{name: value}``.

    A name the model fits directly (``E_kPa``, ``nu``, ``thickness_mm``, ``offset_mm``) is held
    as it is; a reported parameter that is a one-to-one function of one fit coordinate
    (``ratio`` = 1 / ``compliance``) is held through that coordinate. A parameter that
    depends on several fit coordinates (``C20_kPa`` = ``C20_over_E`` E with E free) cannot be
    held this way: ``ValueError`` saying what to hold instead.
    """
    names = model.parameter_names
    lo, hi = model.bounds
    out = {k: v for k, v in fixed.items() if k in names}
    rest = {k: v for k, v in fixed.items() if k not in names}
    if not rest:
        return out
    x = np.array([out.get(n, min(max(1.0, lo[i]), hi[i]) if not math.isfinite(hi[i] - lo[i])
                             else 0.5 * (lo[i] + hi[i])) for i, n in enumerate(names)])
    reported = model.model_parameters(x)
    for k, value in rest.items():
        if k not in reported:
            continue  # a parameter of other models (a thickness when no layer is fitted)
        moves = []
        for j, n in enumerate(names):
            y = x.copy()
            y[j] = x[j] * 1.01 + 1e-3 if math.isfinite(x[j]) else x[j]
            y[j] = min(max(y[j], lo[j]), hi[j])
            if model.model_parameters(y)[k] != reported[k]:
                moves.append(j)
        free = [j for j in moves if names[j] not in out]
        if len(moves) != 1 or len(free) != 1:
            raise ValueError(f"{k} cannot be held on its own in {model.name}: it depends on "
                             f"{', '.join(names[j] for j in moves)}; hold those instead")
        j = free[0]
        out[names[j]] = solve_coordinate(model, x, j, k, value)
    return out


def prior_rows(terms, x: np.ndarray, columns, lo, hi) -> np.ndarray:
    """Whitened rows ``d g(theta) / d theta_j / sd`` of the priors ``(g, mean, sd)`` at ``x``, for
    the parameters ``columns`` (central differences: a prior never runs the force model)."""
    G = np.zeros((len(terms), len(columns)))
    for col, j in enumerate(columns):
        step = 1e-6 * max(abs(x[j]), 1e-6)
        up, down = x.copy(), x.copy()
        up[j], down[j] = min(x[j] + step, hi[j]), max(x[j] - step, lo[j])
        if up[j] > down[j]:
            G[:, col] = [(g(up) - g(down)) / (up[j] - down[j]) / sd for g, _, sd in terms]
    return G
