r"""The cantilever of an AFM-like probe: its spring constant, read from the file or estimated from the ramps.

A probe on a cantilever (AFM, fibre-optic nanoindenters) records the tip's depth :math:`d` and the
force :math:`F = k\,\delta` from the cantilever's deflection :math:`\delta`; the cantilever's base,
driven by the piezo, sits at :math:`z = d + F/k` (positive into the sample). The body of the probe
(beam, fibre, holder) moves with the base, not with the tip: while the tip is held in contact and the
force falls (the start of a retract), the base, and with it the body, already moves out at the
piezo's speed (:mod:`~skin_indent.effects.body_drag`).

Where the file records :math:`k` (afmformats' ``spring constant``, an Optics11 header's ``k (N/m)``, both
kept in ``columns["metadata"]``), that is used. Otherwise it is estimated from the
ramps: a force-distance curve drives the piezo at a constant speed in each approach and retract, so
:math:`d = a + b\,t - F/k` within each of them; a least-squares fit of :math:`(a, b)` per ramp and
one :math:`1/k` for all gives :math:`k` (on the six real curves of ``tests/data/real-data`` with a
known :math:`k`, the approach alone gives it within 2 %). Ramps whose piezo does not move at a
constant speed (a turn's acceleration, a feedback) fit that line worse and weigh less (each ramp's
estimate by its standard error). Holds are left out (their piezo follows a feedback). A
:math:`1/k` not positive or below :data:`MIN_SIGNIFICANCE` standard errors means the depth is the
base's own (a stiff load cell, a depth measured at the actuator): no cantilever, ``None``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["FILE_KEYS", "MIN_SIGNIFICANCE", "RAMPS", "estimate_spring_constant", "spring_constant"]

#: 1/k must exceed this many standard errors to count as a cantilever's compliance
MIN_SIGNIFICANCE = 5.0
#: the kinds of motion at a constant piezo speed
RAMPS = ("approach", "retract")
#: the metadata keys (N/m) of a spring constant: afmformats', an Optics11 Chiaro header's
FILE_KEYS = ("spring constant", "k (N/m)")
#: the fewest points of a ramp used
MIN_RAMP_POINTS = 10


def estimate_spring_constant(time_s, depth_mm, force_mN, kind) -> float | None:
    """The spring constant (mN/mm = N/m) from the ramps, ``d = a + b t - F / k`` per ramp, or None.

    Parameters
    ----------
    time_s, depth_mm, force_mN : array_like
        Times (s), recorded tip depths (mm, into the sample) and recorded forces (mN; a constant
        offset does not matter), in time order.
    kind : array_like of str
        ``approach``, ``hold`` or ``retract`` per point.

    Returns
    -------
    float or None
        k (N/m), or None where no ramp has a significant, positive compliance 1/k.
    """
    t, d, f = (np.asarray(x, dtype=float) for x in (time_s, depth_mm, force_mN))
    kind = np.asarray(kind)
    estimates = []
    for name in RAMPS:
        sel = kind == name
        if np.count_nonzero(sel) < MIN_RAMP_POINTS:
            continue
        X = np.c_[np.ones(np.count_nonzero(sel)), t[sel] - t[sel].mean(), -(f[sel] - f[sel].mean())]
        coef, *_ = np.linalg.lstsq(X, d[sel], rcond=None)
        r = d[sel] - X @ coef
        dof = max(r.size - X.shape[1], 1)
        try:
            cov = np.linalg.inv(X.T @ X) * float(r @ r) / dof
        except np.linalg.LinAlgError:
            continue
        se = math.sqrt(max(cov[2, 2], 0.0))
        if math.isfinite(coef[2]) and se > 0:
            estimates.append((float(coef[2]), se))
    if not estimates:
        return None
    w = np.array([1.0 / se**2 for _, se in estimates])
    c = float(np.sum(w * [c for c, _ in estimates]) / w.sum())
    se = 1.0 / math.sqrt(float(w.sum()))
    return 1.0 / c if c > MIN_SIGNIFICANCE * se else None


def spring_constant(measurement, time_s, depth_mm, force_mN, kind) -> tuple[float | None, str]:
    """The cantilever's spring constant (N/m = mN/mm) and where it comes from.

    The file's (:data:`FILE_KEYS` of ``columns["metadata"]``, in N/m), else
    :func:`estimate_spring_constant` on the given points.

    Returns
    -------
    k : float or None
    source : str
        ``"file"``, ``"estimated from the ramps"`` or ``"none"`` (no cantilever shows).
    """
    meta = (getattr(measurement, "columns", None) or {}).get("metadata") or {}
    for key in FILE_KEYS:
        try:
            k = float(meta.get(key)) if isinstance(meta, dict) and meta.get(key) is not None else math.nan
        except (TypeError, ValueError):
            k = math.nan
        if math.isfinite(k) and k > 0:
            return k, "file"
    if time_s is None:
        return None, "none"
    k = estimate_spring_constant(time_s, depth_mm, force_mN, kind)
    return (k, "estimated from the ramps") if k is not None else (None, "none")
