"""A fit the optimizer stopped early, taken on from where it got with a fresh trust region.

scipy's trust-region least squares stops at its evaluation budget (``status`` 0), or at its step or
cost tolerance once its trust region has shrunk on the way through a curved valley. With the
finite-element model in the loop both happen from starts a user would not choose (two layers, a
layer with stiffening, several curves): :func:`resumed` restarts the fit from its end, which gives
it a fresh trust region and the same budget, until it converges or stops gaining.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..inverse import fit_least_squares
from ..models.fe_core import STIFF_BASE
from .ended import stalled

__all__ = ["FACE_CHI2", "RESUMES", "at_rigid_base", "cost", "first_fit", "resumed"]

#: a fit stopped by its budget goes on from where it got at most this many times while each restart
#: lowers the cost by more than the fit's ``ftol``; one still stopped by its budget after them is
#: flagged (:func:`~skin_indent.fitting.ended.how_it_ended`)
RESUMES = 3


#: a fit leaves a rigid base (:func:`at_rigid_base`) when that lowers its cost by more than this: the
#: 5% point of the likelihood ratio of a parameter on the face of its range (half chi-square with 0,
#: half with 1 degree of freedom; Self & Liang 1987)
FACE_CHI2 = 2.71


def cost(result) -> float:
    """What a fit minimises: the data's chi-square plus the priors' (their -2 ln posterior up to a constant)."""
    return float(result.chi2 + result.info.get("prior_chi2", 0.0))


def first_fit(model, depth_mm, force_mN, starts: list, *, noise_mN, known: dict, options: dict, looped: bool,
              still=None, tol: float = 1e-4) -> tuple:
    """The fit from each start, or with the finite-element model in the loop from the first that can be
    fitted (its runs converge): ``(best, its index in starts)``.

    A fit that ends where it started (:func:`~.ended.stalled`) is kept only if no start that moved
    ends as low (within ``tol`` of its cost); ``still`` is such a fit made before (index -1).

    Parameters
    ----------
    model : ComposedModel or JointModel
    depth_mm, force_mN : ndarray
        The fitted points (mm, mN).
    starts : list of ndarray
        Start vectors, best first.
    noise_mN : float
    known : dict
        ``fixed``, ``priors`` (and ``sigma_mN``), as :func:`~skin_indent.inverse.fit_least_squares` takes them.
    options : dict
        Tolerances and budget.
    looped : bool
        Stop after the first start whose fit could be made.
    still : IdentificationResult, optional
    tol : float
        Relative tolerance on the cost.

    Returns
    -------
    (IdentificationResult or None, int or None)
    """
    best, first, still_at = None, None, -1
    for i, x0 in enumerate(starts):
        try:
            res = fit_least_squares(model, depth_mm, force_mN, x0, noise_mN=noise_mN, **known, **options)
        except ValueError:  # a run of this start's fit failed: the next start
            continue
        if stalled(res, model):  # a stationary start: kept only if no start that moved does as well
            if still is None or cost(res) < cost(still):
                still, still_at = res, i
        elif best is None or cost(res) < cost(best):
            best, first = res, i
        if looped:
            break
    if still is not None and (best is None or cost(best) > cost(still) * (1 + tol)):
        best, first = still, still_at
    return best, first


def resumed(model, depth_mm, force_mN, result, *, noise_mN, known: dict, options: dict, early: bool = False):
    """``result`` fitted on from where it stopped, with a fresh trust region and the same budget.

    Up to :data:`RESUMES` restarts while the fit stops by its budget (``status`` 0) and each restart
    lowers the cost by more than the fit's ``ftol``: the best fit reached (a restart whose run fails
    leaves the last, one that ends higher keeps it). A restart that lowers the cost by less than
    ``ftol`` of it over a whole budget, or not at all, meets scipy's own ``ftol`` test across the
    two, and the fit is reported converged (``status`` 2, its message saying so). The result keeps the first start in
    ``info["x0"]`` (it moved from there), counts every evaluation in ``info["nfev"]`` and the
    restarts in ``info["resumed"]``.

    Parameters
    ----------
    model : ComposedModel or JointModel
    depth_mm, force_mN : ndarray
        The fitted points.
    result : IdentificationResult
        The fit that stopped.
    noise_mN : float
    known : dict
        ``fixed``, ``priors`` (and ``sigma_mN``) of the fit, as
        :func:`~skin_indent.inverse.fit_least_squares` takes them.
    options : dict
        Its tolerances and budget (``ftol``, ``xtol``, ``gtol``, ``max_nfev``).
    early : bool
        Also restart a fit that stopped by its step or cost tolerance (scipy's ``status`` 2 or 3), again
        after each restart that lowered the cost by more than ``ftol`` (measured: two layers on a
        rigid base stopped by its step tolerance at chi2 80.5, the base's compliance 0.0101 in a
        curved valley; restarted 78.5).
    """
    lo, hi = model.bounds
    ftol = options.get("ftol", 1e-8)
    first_start = dict(result.info.get("x0", {}))
    for k in range(RESUMES):
        if result.status != 0 and not early:
            break
        x = np.array([result.parameters[n] for n in model.parameter_names])
        try:
            more = fit_least_squares(model, depth_mm, force_mN, np.clip(x, lo, hi), noise_mN=noise_mN, **known,
                                     **options)
        except ValueError:
            break
        gain = cost(result) - cost(more)
        nfev = int(more.info.get("nfev", 0)) + int(result.info.get("nfev", 0))
        runs = int(result.info.get("resumed", 0)) + 1
        if gain > 0:  # further down: on from there
            result = dataclasses.replace(more, info={**more.info, "x0": first_start, "nfev": nfev, "resumed": runs})
        else:  # the restart ended no lower: the fit stays where it was, its budget counted
            result = dataclasses.replace(result, info={**result.info, "nfev": nfev, "resumed": runs})
        if gain <= ftol * max(cost(result), 1e-300):
            if result.status == 0:  # a whole budget lowered the cost by less than ftol: scipy's own test
                result = dataclasses.replace(result, status=2, message=(
                    f"`ftol` termination condition is satisfied across a restart (a budget of "
                    f"{options.get('max_nfev')} evaluations from where the fit stopped lowered the cost by "
                    f"{max(gain, 0.0) / max(cost(result), 1e-300):.1e} of it)"))
            break
    return result


def at_rigid_base(model, depth_mm, force_mN, result, *, noise_mN, known: dict, options: dict):
    """``result``, or the fit from its end with every layer's compliance that ended above a rigid base
    by less than twice :data:`~skin_indent.models.fe_core.STIFF_BASE` (a base over 50 times stiffer
    than the layer) held at 0, if that ends lower: the fit then goes on free from there, and the rigid
    base stands unless leaving it lowers the cost by more than :data:`FACE_CHI2` (counted free, ended
    on that face: :func:`_free_at_face`).

    Leaving a rigid base there takes the other parameters along a curved valley, where the optimizer
    stops by its step tolerance (measured: two layers on a rigid base from the screened start, chi2
    78.5 with the base's compliance at 0.0100 after three restarts; with it held at 0 from there 58.9,
    the truth's rigid base; free again from there 57.7 at a compliance of 1.3e-5, a base 75000 times
    stiffer). Arguments as :func:`resumed`'s.
    """
    names = model.parameter_names
    near = [n for n in result.free_names
            if n.rstrip("0123456789") == "compliance" and 0.0 < result.parameters[n] < 2 * STIFF_BASE]
    if not near:
        return result
    held = {**(known.get("fixed") or {}), **{n: 0.0 for n in near}}
    x0 = np.array([0.0 if n in near else result.parameters[n] for n in names])
    try:
        at = fit_least_squares(model, depth_mm, force_mN, x0, noise_mN=noise_mN, **{**known, "fixed": held},
                               **options)
        at = resumed(model, depth_mm, force_mN, at, noise_mN=noise_mN, known={**known, "fixed": held},
                     options=options)
        x1 = np.array([at.parameters[n] for n in names])
        free = fit_least_squares(model, depth_mm, force_mN, x1, noise_mN=noise_mN, **known, **options)
    except ValueError:  # a run failed on the way: the fit as it ended
        return result
    if cost(at) - cost(free) <= FACE_CHI2 and cost(at) < cost(result):
        return _free_at_face(at, result.free_names, near)
    return free if cost(free) < cost(result) else result


def _free_at_face(at, free_names: tuple, near: list):
    """The fit ``at`` (``near`` held at 0) as a fit of ``free_names`` that ended with ``near`` on the
    face of their range (``info["active_bounds"]``, no covariance in them): counted free, as a fit that
    reached the face by itself (the same number of parameters in its score)."""
    idx = [at.free_names.index(n) if n in at.free_names else -1 for n in free_names]
    cov = np.full((len(free_names), len(free_names)), np.nan)
    cor = np.full_like(cov, np.nan)
    for a, i in enumerate(idx):
        for b, j in enumerate(idx):
            if i >= 0 and j >= 0:
                cov[a, b], cor[a, b] = at.covariance[i, j], at.correlation[i, j]
    active = list(dict.fromkeys([*at.info.get("active_bounds", ()), *near]))
    return dataclasses.replace(at, free_names=tuple(free_names), fixed_names=tuple(
        n for n in at.fixed_names if n not in near), covariance=cov, correlation=cor,
        std={**at.std, **{n: math.nan for n in near}}, info={**at.info, "active_bounds": active})
