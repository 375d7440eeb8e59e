"""Force units: every method's tolerances and defaults hold for any force scale.

The methods carry absolute numbers set for skin, whose forces are ~10 mN: scipy's
``gtol`` on the gradient of the cost, the paper's 0.05 mN measurement noise of the
filter. An AFM curve (~1e-5 mN) would stop at its start. :func:`in_force_units` runs a
method on a curve whose peak force lies outside :data:`NATIVE_RANGE_MN` with the forces
expressed in the decade that brings its peak to ~10, ``unit = 10^round(log10(max|F| /
10))`` mN, and rebuilds the result in mN at the solution: the parameters do not depend
on the force unit. Skin curves (0.1-1000 mN) run in mN, so the paper's numbers are
reproduced exactly.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from ._problem import iterating
from ._problem import make_problem
from ._problem import takes_columns
from .result import build_result


#: peak forces (mN) for which the methods' absolute defaults were set
NATIVE_RANGE_MN = (0.1, 1000.0)


def force_unit(force) -> float:
    """1 mN for a peak force in :data:`NATIVE_RANGE_MN`, else the decade (mN) that makes it ~10."""
    peak = float(np.max(np.abs(np.asarray(force, dtype=float)))) if np.size(force) else 0.0
    if not (math.isfinite(peak) and peak > 0) or NATIVE_RANGE_MN[0] <= peak <= NATIVE_RANGE_MN[1]:
        return 1.0
    return 10.0 ** round(math.log10(peak / 10.0))


class _Scaled:
    """A force model divided by a constant force unit (same parameters and bounds)."""

    def __init__(self, model, unit_mN: float):
        self.model, self.unit = model, float(unit_mN)
        self.parameter_names = tuple(model.parameter_names)
        self.bounds = model.bounds
        self.depth_range = getattr(model, "depth_range", (0.0, np.inf))

    def force(self, depth_mm, theta):
        return np.asarray(self.model.force(depth_mm, theta)) / self.unit

    def iterating(self):
        return iterating(self.model)

    def jacobian(self, depth_mm, theta, columns=None):
        if columns is not None and takes_columns(self.model):
            return np.asarray(self.model.jacobian(depth_mm, theta, columns=columns)) / self.unit
        return np.asarray(self.model.jacobian(depth_mm, theta)) / self.unit


def in_force_units(method):
    """Wrap an identification method ``method(model, depth, force, x0, **kw)`` (see the module docstring)."""

    @functools.wraps(method)
    def wrapped(model, depth, force, x0, **kwargs):
        unit = force_unit(force) if np.ndim(force) == 1 and np.all(np.isfinite(force)) else 1.0
        if unit == 1.0:
            return method(model, depth, force, x0, **kwargs)

        kw = dict(kwargs)
        for key in ("noise_mN", "measurement_std_mN_scaled", "sigma_mN"):
            if kw.get(key) is not None:
                kw[key] = np.asarray(kw[key]) / unit
        r = method(_Scaled(model, unit), depth, np.asarray(force, dtype=float) / unit, x0, **kw)
        theta = np.array([r.parameters[n] for n in model.parameter_names])
        problem = make_problem(model, depth, force, theta, kwargs.get("fixed"))
        x = np.array([r.parameters[n] for n in problem.free_names])
        filt = r.covariance_source != "jacobian"  # a filter's, weighted, or with priors: kept as it is
        info = {k: v for k, v in r.info.items() if k not in ("covariance_jacobian", "residual_sigma_mN")}
        info["force_unit_mN"] = unit
        out = build_result(problem, x, method=r.method, iterations=r.iterations, status=r.status,
                           message=r.message, noise_mN=r.noise_mN * unit,
                           covariance=r.covariance if filt else None, covariance_source=r.covariance_source,
                           history=r.history, info=info)
        if kwargs.get("sigma_mN") is not None:  # the weighted chi-square does not depend on the force unit
            out = dataclasses.replace(out, chi2=r.chi2)
        return out

    return wrapped
