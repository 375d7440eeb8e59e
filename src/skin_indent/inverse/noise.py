"""Noise level of a force-depth curve, from the data alone."""

from __future__ import annotations

import numpy as np

from ._problem import check_data

__all__ = ["estimate_noise", "noise_min_points"]

_MAD_TO_SIGMA = 1.482602218505602  # 1 / Phi^-1(3/4)
_CLIP = 3.5                          # inliers: |r| <= 3.5 MAD-sigma
_CLIP_VAR = 0.9938933                # E[z^2 | |z| <= 3.5] for z ~ N(0, 1)


def noise_min_points(half_width: int = 2) -> int:
    """The fewest points :func:`estimate_noise` takes: ``2 * half_width + 3`` (7 for its local cubic),
    so that at least three interior points are predicted from their neighbours."""
    return 2 * int(half_width) + 3


def estimate_noise(depth, force, *, half_width: int = 2) -> float:
    """Standard deviation (mN) of white measurement noise on a smooth curve.

    Each interior point is predicted from its ``2 * half_width`` neighbours by
    Lagrange interpolation (a cubic for the default ``half_width=2``; works on
    non-uniform depths). The prediction residual ``r_i = F_i - sum_j w_j F_j`` of
    pure white noise has variance ``sigma^2 (1 + sum_j w_j^2)``; the smooth part of
    the curve cancels up to its 4th derivative. With ``z_i = r_i / sqrt(1 + sum w^2)``
    a first, robust sigma is the scaled median absolute deviation (MAD) of ``z``;
    the returned sigma is the RMS of the inliers ``|z| <= 3.5 MAD-sigma``
    (corrected for the truncation), which is about 1.5x less scattered than the
    MAD alone (about 12% relative scatter for 100 points) while outliers and the
    few points where the curve is not smooth (contact onset) are still ignored.

    Parameters
    ----------
    depth : array_like (n,)
        Depths (mm), distinct. Need not be sorted or uniform.
    force : array_like (n,)
        Forces (mN).
    half_width : int
        Neighbours on each side (1 = second differences, 2 = cubic, ...).

    Returns
    -------
    float
        sigma (mN). 0.0 for a curve that is exactly polynomial of degree
        ``< 2 * half_width`` (up to round-off).

    Raises
    ------
    ValueError
        Bad data, or fewer than ``2 * half_width + 3`` points, or repeated depths.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> h = np.linspace(0.0, 0.6, 400)
    >>> round(estimate_noise(h, 50 * h**1.5 + rng.normal(0, 0.05, h.size)), 2)
    0.05
    """
    k = int(half_width)
    if k < 1:
        raise ValueError(f"half_width must be >= 1, got {half_width}")
    depth, force = check_data(depth, force, min_points=noise_min_points(k))
    order = np.argsort(depth, kind="stable")
    x, y = depth[order], force[order]
    if np.any(np.diff(x) <= 0):
        raise ValueError("depths must be distinct to estimate the noise")
    n = x.size
    # neighbour offsets -k..-1, 1..k, for all interior points at once
    offsets = np.r_[np.arange(-k, 0), np.arange(1, k + 1)]
    centre = np.arange(k, n - k)
    nb = centre[:, None] + offsets[None, :]              # (m, 2k)
    xn, x0 = x[nb], x[centre][:, None]
    # Lagrange weights w_j = prod_{l != j} (x0 - x_l) / (x_j - x_l)
    w = np.ones_like(xn)
    for j in range(2 * k):
        for l in range(2 * k):
            if l != j:
                w[:, j] *= (x0[:, 0] - xn[:, l]) / (xn[:, j] - xn[:, l])
    r = (y[centre] - np.sum(w * y[nb], axis=1)) / np.sqrt(1.0 + np.sum(w * w, axis=1))
    r = r - np.median(r)
    s0 = _MAD_TO_SIGMA * np.median(np.abs(r))
    if s0 == 0.0:
        return 0.0
    inlier = np.abs(r) <= _CLIP * s0
    return float(np.sqrt(np.mean(r[inlier] ** 2) / _CLIP_VAR))
