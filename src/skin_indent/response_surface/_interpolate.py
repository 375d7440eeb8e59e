"""Interpolation operators on 1-D nodes, linear in the nodal values."""

from __future__ import annotations

import bisect
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class _Stencils:
    """Piecewise polynomial interpolation that is linear in the nodal values.

    On interval ``i`` the weight of node ``columns[i, a]`` is
    ``sum_k coef[i, k, a] t**k`` with ``t = (x - origin[i]) / scale[i]``.
    """

    breaks: np.ndarray  # (n_int + 1,)
    origin: np.ndarray  # (n_int,)
    scale: np.ndarray  # (n_int,)
    columns: np.ndarray  # (n_int, p) int
    coef: np.ndarray  # (n_int, degree + 1, p)

    def __post_init__(self):  # plain lists for the scalar path
        object.__setattr__(self, "_inner", self.breaks[1:-1].tolist())
        object.__setattr__(self, "_origin", self.origin.tolist())
        object.__setattr__(self, "_scale", self.scale.tolist())

    def locate(self, x: np.ndarray, deriv: bool = True):
        """Interval index (m,), powers of t (m, K) and their d/dx (m, K) at points ``x``."""
        i = np.searchsorted(self.breaks[1:-1], x, side="right")  # in [0, n_int - 1]
        scale = self.scale[i]
        t = (x - self.origin[i]) / scale
        k = np.arange(self.coef.shape[1])
        tp = t[:, None] ** k
        if not deriv:
            return i, tp
        dtp = np.zeros_like(tp)
        dtp[:, 1:] = tp[:, :-1] * (k[1:] / scale[:, None])
        return i, tp, dtp

    def locate_scalar(self, x: float):
        """As :meth:`locate` for one point (no array overhead)."""
        i = bisect.bisect_right(self._inner, x)  # in [0, n_int - 1]
        scale = self._scale[i]
        t = (x - self._origin[i]) / scale
        tp, dtp, tk = [1.0], [0.0], 1.0
        for k in range(1, self.coef.shape[1]):
            dtp.append(k * tk / scale)
            tk *= t
            tp.append(tk)
        return i, np.array(tp), np.array(dtp)

    def weights(self, x: float):
        """Columns (p,), weights (p,) and d weights / dx (p,) at one point ``x``."""
        i, tp, dtp = self.locate_scalar(x)
        c = self.coef[i]
        return self.columns[i], tp @ c, dtp @ c

    def data_coef(self, values: np.ndarray) -> np.ndarray:
        """Polynomial coefficients (n_int, K, ...) of the interpolant of ``values`` (n, ...)."""
        return np.einsum("ika,ia...->ik...", self.coef, values[self.columns])


def _lagrange_stencils(nodes: np.ndarray, n_points: int = 4) -> _Stencils:
    """Local Lagrange interpolation on ``n_points`` nodes.

    On ``[x_i, x_i+1]`` the stencil is ``i-1 .. i+2`` (the interval in the middle),
    shifted inwards at the ends of the grid.
    """
    n = nodes.size
    p = min(n_points, n)
    n_int = max(n - 1, 1)
    start = np.clip(np.arange(n_int) - (p // 2 - 1), 0, n - p)
    cols = start[:, None] + np.arange(p)
    origin = nodes[start]
    scale = nodes[start + p - 1] - origin if p > 1 else np.ones(n_int)
    t = (nodes[cols] - origin[:, None]) / scale[:, None]  # (n_int, p)
    vander = t[:, :, None] ** np.arange(p)  # [i, a, k] = t_a^k
    coef = np.linalg.inv(vander)  # [i, k, a]: L_a(t) = sum_k coef[k, a] t^k
    breaks = nodes if n > 1 else np.repeat(nodes, 2)
    return _Stencils(breaks, origin, scale, cols, coef)


def _spline_stencils(nodes: np.ndarray) -> _Stencils:
    """Cardinal not-a-knot cubic spline (global support: every node on every interval)."""
    from scipy.interpolate import CubicSpline

    n = nodes.size
    if n < 3:
        return _lagrange_stencils(nodes, n_points=n)
    pp = CubicSpline(nodes, np.eye(n), axis=0, bc_type="not-a-knot")
    width = np.diff(nodes)
    coef = pp.c[::-1].transpose(1, 0, 2) * (width[:, None, None] ** np.arange(4)[None, :, None])
    cols = np.broadcast_to(np.arange(n), (n - 1, n))
    return _Stencils(nodes, nodes[:-1], width, cols, coef)


def _quartic_stencils(nodes: np.ndarray, degree: int = 4) -> _Stencils:
    """Global least-squares polynomial of ``degree`` through all nodes (a smoother)."""
    n = nodes.size
    degree = min(degree, n - 1)
    scale = nodes[-1] - nodes[0]
    vander = ((nodes - nodes[0]) / scale)[:, None] ** np.arange(degree + 1)
    coef = np.linalg.pinv(vander)[None]  # (1, degree + 1, n)
    return _Stencils(nodes[[0, -1]], nodes[:1], np.array([scale]), np.arange(n)[None], coef)


_DEPTH_BUILDERS = {"lagrange": _lagrange_stencils, "spline": _spline_stencils, "quartic": _quartic_stencils}
