"""From the end of a fit to its :class:`~skin_indent.fitting.FitResult`: the covariance (held at a face of
the range where the fit's is singular), the parameters as users read them, what the data did to each
prior (the fit without a prior where the linearisation cannot tell: :func:`data_alone`), the residual
judged per curve, the score and how the fit ended. :meth:`~.multistart.Fitter.fit` calls :func:`assemble`
once per model.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np

from ..effects import model_name
from ..inverse import IdentificationResult, fit_least_squares
from ..inverse.residuals import analyse_residuals
from ..inverse.result import jacobian_covariance
from ..measurement.scale import joined
from .ended import how_it_ended, reported_message
from .knowledge import needs_data_alone, prior_rows, prior_summary
from .resume import resumed
from .result import FitResult, scored
from .rung import NO_STRUCTURE, reported_covariance, structure_sentence

log = logging.getLogger(__name__)


def assemble(fitter, model, key: tuple, best, known: dict, options: dict, runs: int) -> FitResult:
    """The :class:`~skin_indent.fitting.FitResult` of ``model`` (the effects ``key``) fitted by ``fitter``
    to ``best`` (an :class:`~skin_indent.inverse.IdentificationResult`), with the fit's ``known`` (held
    values, priors, sigma) and ``options``; ``runs`` its finite-element runs."""
    d = fitter.data
    lo, hi = model.bounds
    x, cov = coordinates(model, best)
    pred = d.force_mN - best.residuals_mN
    active = [n for n in best.info.get("active_bounds", ()) if n in best.free_names]
    if active and not np.all(np.isfinite(best.covariance)):
        # a parameter on a face of its range (a rigid base: compliance 0) is held there: the
        # covariance of the others is that of the fit with it fixed
        keep = [model.parameter_names.index(n) for n in best.free_names if n not in active]
        noise = fitter.noise_points[:, None] if fitter.joint else fitter.noise_mN
        rows = model.jacobian(d.depth_mm, x)[:, keep] / noise
        terms = known["priors"] or ()
        if terms:  # the priors' rows, whitened as the data's: the posterior, as the fit's own covariance
            rows = np.vstack([rows, prior_rows(terms, x, keep, lo, hi)])
        cov = np.zeros((x.size, x.size))
        cov[np.ix_(keep, keep)] = jacobian_covariance(rows)[0]
    params, std = model.reported(x, cov)
    for k in fitter.fixed:  # held: reported without a standard deviation, as every fit does
        std.pop(k, None)
    for k in best.fixed_names:
        std.pop(k, None)
    knowledge = {k: prior_summary(params[k], std.get(k, math.nan), *fitter.priors[k])
                 for k in fitter.priors if k in params}
    for k, summary in knowledge.items():
        alone = data_alone(fitter, model, x, known, options, k) if needs_data_alone(summary) else None
        if alone is not None:  # the linearised tension of a prior-determined parameter: the fit without it says
            knowledge[k] = prior_summary(params[k], std.get(k, math.nan), *fitter.priors[k], alone=alone)
    r = best.residuals_mN
    s = fitter.sigma(pred)
    try:
        analysis = analyse_residuals(r * (fitter.noise_mN / s), fitter.noise_mN, best.n_free,
                                     noise_dof=fitter.noise_dof)
    except ValueError:  # too few points to test the residual (a fit of 4 points, nu held): not judged white
        analysis = None
    curve_rms, curve_white = per_curve(fitter, r, s, best.n_free)
    base = {f.name: getattr(best, f.name) for f in dataclasses.fields(IdentificationResult)}
    chi2 = float(np.sum((r / s) ** 2))
    base.update(parameters=params, std=std, chi2=chi2, message=reported_message(best, model, x),
                **scored(chi2, r * (fitter.noise_mN / s), best.n_free))
    ended = tuple(how_it_ended(best, model, x))
    return FitResult(**base, model=model_name(key), effects=key,
                     fit_parameters=dict(best.parameters), prediction_mN=pred,
                     chi2_weighted=chi2, white=bool(analysis is not None and analysis.white), analysis=analysis,
                     structure=structure(fitter, r, s), bound_model=model, x=x, forward_runs=runs,
                     at_bounds=tuple(best.info.get("active_bounds", ())), priors=knowledge, curve_rms_mN=curve_rms,
                     curve_white=curve_white, ended=ended, flags=tuple(e.text for e in ended),
                     error_model=fitter.error_model(),
                     reported_cov=reported_covariance(model, x, cov))


def coordinates(model, best) -> tuple[np.ndarray, np.ndarray]:
    """The fit coordinates of ``best`` (an IdentificationResult of ``model``) in the model's order and their
    covariance (held values: 0; the free ones' as fitted, NaN where it has none)."""
    x = np.array([best.parameters[n] for n in model.parameter_names])
    cov = np.full((x.size, x.size), np.nan)
    idx = [model.parameter_names.index(n) for n in best.free_names]
    held = [model.parameter_names.index(n) for n in best.fixed_names]
    cov[held, :] = 0.0  # a held value has no variance
    cov[:, held] = 0.0
    cov[np.ix_(idx, idx)] = best.covariance
    return x, cov


def data_alone(fitter, model, x, known: dict, options: dict, name: str) -> tuple[float, float] | None:
    """``(value, sd)`` of the reported parameter ``name`` by the fit of ``model`` without its prior,
    from the fit with it at ``x`` (the fit coordinates), resumed as the fit itself is where its budget
    stops it; None where that fit fails or still stops at its budget: then the linearised statistic
    stands (:func:`~.knowledge.needs_data_alone` says when it is made)."""
    terms = fitter.prior_terms(model, but=name)
    d = fitter.data
    known = {**known, "priors": terms or None}
    try:
        alone = fit_least_squares(model, d.depth_mm, d.force_mN, x, noise_mN=fitter.noise_mN, **known, **options)
        if alone.status == 0:  # stopped by its budget: on from where it got
            alone = resumed(model, d.depth_mm, d.force_mN, alone, noise_mN=fitter.noise_mN, known=known,
                            options=options)
    except ValueError:
        return None
    if alone.status == 0:
        log.info("%s: the fit without the prior on %s stopped at its budget: the linearised tension stands",
                 model.name, name)
        return None
    params, std = model.reported(*coordinates(model, alone))
    log.info("%s: the prior's tension checked by the fit without it: %s = %.4g +- %.2g", model.name, name,
             params[name], std.get(name, math.nan))
    return float(params[name]), float(std.get(name, math.nan))


def per_curve(fitter, residual, sigma, n_free: int) -> tuple[tuple, tuple]:
    """Each curve's RMS residual (mN) and whether its residual alone is white (one curve: the fit's)."""
    if not fitter.joint:
        rms = float(np.sqrt(np.mean(residual**2)))
        return (rms,), ()
    rms, white = [], []
    for (c, sl), noise in zip(zip(fitter.curves, fitter.data.slices), fitter.noises_mN):
        r = residual[sl]
        rms.append(float(np.sqrt(np.mean(r**2))))
        try:
            a = analyse_residuals(r * (noise / sigma[sl]), noise, 0, noise_dof=None if fitter.noise_dof is None
                                  else 0.35 * c.n)
            white.append(bool(a.white))
        except ValueError:  # too few points for the tests
            white.append(True)
    return tuple(rms), tuple(white)

def structure(fitter, residual, sigma) -> str:
    """Where the residual departs from the noise, in words (:func:`structure_sentence`), per curve
    of a sample (``"curve 2 (file): ..."``)."""
    if not fitter.joint:
        return structure_sentence(fitter.data, residual, sigma)
    parts = []
    for k, (c, sl) in enumerate(zip(fitter.curves, fitter.data.slices)):
        text = structure_sentence(c, residual[sl], sigma[sl])
        if text != NO_STRUCTURE:
            parts.append(joined("", [f"curve {k + 1} ({c.source}): ", text]))
    return joined("; ", parts) if parts else NO_STRUCTURE
