"""How a response surface interpolates its runs: in depth, in nu and in E, with the gradients.

:class:`Interpolant` holds the interpolated quantity of a
:class:`~skin_indent.response_surface.ResponseSurface` (its unit forces with the shape
divided out, ``g = f / (s_h(h) s_nu(nu))``) and evaluates F(h; E, nu) and its gradient
(:meth:`~skin_indent.response_surface.ResponseSurface.evaluate` calls it);
:class:`NodeForces` interpolates the runs of several surfaces on one grid in depth at once.
"""

from __future__ import annotations

import numpy as np

from ._interpolate import _DEPTH_BUILDERS, _lagrange_stencils, _spline_stencils

METHODS = ("lagrange", "spline")
DEPTH_INTERPS = ("lagrange", "quartic", "spline")
SCALINGS = ("hertz", "h1.5", "none")
_RTOL_BOUNDS = 1e-9  # relative tolerance on the box checks


def _check_choice(name, value, choices):
    if value not in choices:
        raise ValueError(f"{name}={value!r} is not one of {choices}")
    return value


class Interpolant:
    """The interpolation of a response surface's runs (its stencils made when first used).

    Parameters
    ----------
    grid : SurfaceGrid
        The nodes.
    f : ndarray, shape (n_depth, n_nu)
        Unit forces (mN at E = 1 kPa), NaN columns for failed runs.
    missing : ndarray of bool, shape (n_nu,)
        The columns of failed runs.
    failures : dict
        ``{nu: reason}`` of the failed runs.
    scaling : {"hertz", "h1.5", "none"}
        Shape divided out before interpolating.
    """

    def __init__(self, grid, f, missing, failures, scaling):
        self.grid, self._missing, self.failures, self.scaling = grid, missing, failures, scaling
        # the interpolated quantity g = f / (s_h(h) s_nu(nu))
        h, nu = grid.depth_mm, grid.nu
        s_h = h**1.5 if scaling != "none" else np.ones_like(h)
        s_nu = 1.0 / (1.0 - nu**2) if scaling == "hertz" else np.ones_like(nu)
        self._g = f / (s_h[:, None] * s_nu[None, :])
        self._nu_ops = {}  # method -> interpolation in nu, made when first used (:meth:`nu_op`)
        self._E_op = _lagrange_stencils(grid.E_kPa)
        self._E_coef = self._E_op.data_coef(grid.E_kPa)  # polynomial sum_j L_j(E) E_j per interval
        self._depth = {}  # depth_interp -> (stencils, coefficients (n_int, K, n_nu) of g)

    @property
    def depth_range(self) -> tuple[float, float]:
        """Valid depths (mm), as :attr:`~skin_indent.response_surface.ResponseSurface.depth_range`."""
        h = self.grid.depth_mm
        return (float(h[0]) if self.scaling == "none" else 0.0), float(h[-1])

    def nu_op(self, method):
        """The interpolation in nu of ``method`` (made when first used)."""
        if method not in self._nu_ops:
            build = _lagrange_stencils if method == "lagrange" else _spline_stencils
            self._nu_ops[method] = build(self.grid.nu)
        return self._nu_ops[method]

    def depth_op(self, kind):
        """The interpolation in depth of ``kind``: its stencils and the coefficients of g (made when first used)."""
        if kind not in self._depth:
            op = _DEPTH_BUILDERS[kind](self.grid.depth_mm)
            # missing columns -> 0 (never weighted: evaluate checks the nu stencil first)
            self._depth[kind] = op, np.nan_to_num(op.data_coef(self._g), nan=0.0)
        return self._depth[kind]

    def _check_param(self, name, value, nodes, unit, extrapolate):
        lo, hi = nodes[0], nodes[-1]
        tol = _RTOL_BOUNDS * max(hi - lo, abs(hi))
        if not np.isfinite(value) or (not extrapolate and not lo - tol <= value <= hi + tol):
            raise ValueError(f"{name} = {value:g} is outside the response surface [{lo:g}, {hi:g}]{unit} "
                             "(extrapolate=True evaluates outside)")

    def evaluate(self, depth_mm, theta, method: str, depth_interp: str, extrapolate: bool) -> tuple:
        """Force (mN) and its gradient [dF/dE, dF/dnu]: :meth:`~skin_indent.response_surface.ResponseSurface.evaluate`
        with ``method`` and ``depth_interp`` given."""
        th = np.asarray(theta, dtype=float)
        if th.shape != (2,):
            raise ValueError(f"theta must be (E_kPa, nu), got shape {th.shape}")
        E, nu = float(th[0]), float(th[1])
        g = self.grid
        self._check_param("E_kPa", E, g.E_kPa, " kPa", extrapolate)
        self._check_param("nu", nu, g.nu, "", extrapolate)
        if not -1.0 < nu < 1.0:
            raise ValueError(f"nu = {nu:g} is outside (-1, 1)")
        h_in = np.asarray(depth_mm, dtype=float)
        h = h_in.ravel()
        if h.size:
            lo, hi = h.min(), h.max()
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise ValueError("depth_mm must be finite")
            hmin, hmax = self.depth_range
            if not extrapolate and (lo <= 0 or lo < hmin * (1 - _RTOL_BOUNDS) or hi > hmax * (1 + _RTOL_BOUNDS)):
                bad, valid = (hi if hi > hmax else lo), (f"({hmin:g}" if hmin == 0 else f"[{hmin:g}")
                raise ValueError(f"depth_mm = {bad:g} is outside the response surface {valid}, {hmax:g}] mm "
                                 "(extrapolate=True evaluates outside)")
        contact = None
        if extrapolate and h.size and lo <= 0:
            contact = h > 0
            h = np.where(contact, h, g.depth_mm[0])
        # weights of the nu nodes, then the per-interval depth polynomials of g contracted
        # with them: g(h, nu) = sum_k t^k sum_c D[i, k, c] w_c(nu)
        cols, w, dw = self.nu_op(method).weights(nu)
        if self._missing[cols].any():
            bad = g.nu[cols][self._missing[cols]]
            why = "; ".join(self.failures.get(float(x), "?") for x in bad)
            raise ValueError(f"nu = {nu:g} ({method} interpolation) needs the column nu = "
                             f"{', '.join(f'{x:g}' for x in bad)} whose forward run failed ({why})")
        wn = np.zeros((g.nu.size, 2))
        wn[cols, 0] = w
        wn[cols, 1] = dw
        op, coef = self.depth_op(depth_interp)
        i, tp = op.locate(h, deriv=False)
        gv = (tp[:, None, :] @ (coef[i] @ wn))[:, 0, :]  # (m, 2): g, dg/dnu at (h, nu)
        if method == "lagrange":  # E-direction of the bicubic: sum_j L_j(E) E_j (= E exactly)
            k, tpe, dtpe = self._E_op.locate_scalar(E)
            e, de = float(tpe @ self._E_coef[k]), float(dtpe @ self._E_coef[k])
        else:
            e, de = E, 1.0
        if self.scaling == "hertz":
            s_nu = 1.0 / (1.0 - nu * nu)
            ds_nu = 2.0 * nu * s_nu * s_nu
        else:
            s_nu, ds_nu = 1.0, 0.0
        # [F, dF/dE, dF/dnu] = s_h(h) [g, dg/dnu] @ m
        m = np.array([[e * s_nu, de * s_nu, e * ds_nu], [0.0, 0.0, e * s_nu]])
        out = gv @ m
        if self.scaling != "none":
            out *= (h * np.sqrt(h))[:, None]
        if contact is not None:
            out[~contact] = 0.0
        return out[:, 0].reshape(h_in.shape), out[:, 1:].reshape(h_in.shape + (2,))


class NodeForces:
    """The runs of several response surfaces on one grid, interpolated in depth at once.

    An :class:`~skin_indent.models.effect_surface.EffectSurface` holds one surface per node of
    its effect axes; at every evaluation it needs every run of every one of them at the
    measured depths. The depth interpolation is linear in the data, so it is one contraction
    of the stacked polynomial coefficients of all surfaces (what :meth:`~._surface.ResponseSurface.evaluate`
    computes at a nu node, surface by surface).

    Parameters
    ----------
    surfaces : sequence of ResponseSurface
        On the same depth and nu nodes, with the same ``depth_interp`` and ``scaling``.
    """

    def __init__(self, surfaces):
        surfaces = list(surfaces)
        if not surfaces:
            raise ValueError("no surface given")
        first = surfaces[0]
        for other in surfaces[1:]:
            if (not np.array_equal(other.grid.depth_mm, first.grid.depth_mm)
                    or not np.array_equal(other.grid.nu, first.grid.nu) or other.depth_interp != first.depth_interp
                    or other.scaling != first.scaling):
                raise ValueError("the surfaces must share their depth and nu nodes, depth_interp and scaling")
        self._op = first._interp.depth_op(first.depth_interp)[0]
        self._coef = np.stack([s._interp.depth_op(s.depth_interp)[1] for s in surfaces])  # (S, n_int, K, n_nu)
        self._missing = np.stack([s._missing for s in surfaces])  # (S, n_nu)
        self._range = first.depth_range
        nu = first.grid.nu
        self._s_nu = 1.0 / (1.0 - nu * nu) if first.scaling == "hertz" else np.ones_like(nu)
        self._scaled = first.scaling != "none"

    def __call__(self, depth_mm) -> np.ndarray:
        """f(h; nu_j) (mN at E = 1 kPa), shape ``(n_surfaces, n_nu) + depth_mm.shape``; NaN where a run failed.

        Raises
        ------
        ValueError
            A depth outside the surfaces (0 < h <= the last depth node).
        """
        h_in = np.asarray(depth_mm, dtype=float)
        h = h_in.ravel()
        if h.size:
            hmin, hmax = self._range
            lo, hi = float(h.min()), float(h.max())
            if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= 0 or lo < hmin * (1 - _RTOL_BOUNDS) \
                    or hi > hmax * (1 + _RTOL_BOUNDS):
                raise ValueError(f"depth_mm must lie in ({hmin:g}, {hmax:g}] mm for this response surface")
        i, tp = self._op.locate(h, deriv=False)
        f = np.einsum("mk,smkc->scm", tp, self._coef[:, i]) * self._s_nu[None, :, None]
        if self._scaled:
            f *= (h * np.sqrt(h))[None, None, :]
        f[self._missing] = np.nan
        return f.reshape(f.shape[:2] + h_in.shape)
