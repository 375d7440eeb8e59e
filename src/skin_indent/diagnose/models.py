"""Force models of the diagnosis: the base law plus any combination of effects.

Each model here follows the force-model protocol of :mod:`skin_indent.inverse`
(``parameter_names``, ``bounds``, ``force``, ``jacobian``) and is bound to the
measured history (``time_s``, ``depth_mm``), so path-dependent effects see the real
loading, hold and unloading. What each effect costs and how it is computed:

``layer``, ``stiffening``
    :class:`~skin_indent.response_surface.effect_surface.EffectSurface` (FE runs over
    nu and the effect's unit parameters, cached; F is exactly linear in E).
``viscoelastic``
    Lee-Radok / Ting hereditary integral over the elastic surface
    (:mod:`skin_indent.response_surface.hereditary`): no extra FE runs.
``offset``
    the recorded depth minus the contact point (:class:`skin_indent.identify.ShiftedModel`).
``adhesion``
    a DMT-type attraction: the force is lowered by ``2 pi w R`` while the sphere is
    below the contact point (Derjaguin-Muller-Toporov; the JKR pull-off is 3/4 of
    it). The finite-element adhesive traction law
    (:class:`~skin_indent.mechanics.contact.ContactLaw`) is for forward runs.
``friction``
    not fitted here; :mod:`.workflow` weighs whether it can show in the data.
"""

from __future__ import annotations

import math

import numpy as np

#: nu nodes of the effect surfaces (skin is nearly incompressible; E* barely depends on nu there)
EFFECT_NU = (0.3, 0.42, 0.46, 0.49)
#: effects fitted through models of this module
FITTABLE = ("layer", "stiffening", "viscoelastic", "adhesion", "offset")


class BoundModel:
    """A force model evaluated on one measured history.

    Parameters
    ----------
    core : ForceModel
        Elastic force F(h; theta_core) for depths h > 0 (a surface).
    depth_mm, time_s : ndarray
        The measured history (time may be None).
    offset : bool
        Add ``offset_mm``: contact begins at that recorded depth.
    viscoelastic : bool
        Add ``g1`` and ``tau1_s`` (needs time).
    offset_bounds_mm : (float, float)
    """

    def __init__(self, core, depth_mm, time_s=None, *, offset: bool = False, viscoelastic: bool = False,
                 adhesion: bool = False, radius_mm: float = 6.22, w_max_mJ_per_m2: float = 0.0,
                 offset_bounds_mm=(0.0, 0.0), name: str = "neo-hooke"):
        self.core = core
        self.depth_mm = np.asarray(depth_mm, dtype=float)
        self.time_s = None if time_s is None else np.asarray(time_s, dtype=float)
        self.offset = offset
        self.viscoelastic = viscoelastic
        self.adhesion = adhesion
        self.radius_mm = float(radius_mm)
        self.name = name
        names = list(core.parameter_names)
        lo, hi = (list(np.asarray(b, dtype=float)) for b in core.bounds)
        if offset:
            names.append("offset_mm")
            lo.append(offset_bounds_mm[0])
            hi.append(offset_bounds_mm[1])
        if viscoelastic:
            if self.time_s is None:
                raise ValueError("a viscoelastic model needs the measurement's time_s")
            duration = float(self.time_s[-1] - self.time_s[0])
            dt = np.diff(self.time_s)
            names += ["g1", "tau1_s"]
            lo += [0.0, max(float(np.median(dt[dt > 0])) if np.any(dt > 0) else duration * 1e-3, duration * 1e-3)]
            hi += [0.9, 10.0 * duration]
        if adhesion:
            names.append("w_mJ_per_m2")
            lo.append(0.0)
            hi.append(float(w_max_mJ_per_m2))
        self.parameter_names = tuple(names)
        self.bounds = (np.array(lo), np.array(hi))
        self.depth_range = core.depth_range
        self._n_core = len(core.parameter_names)
        self._weights = {}

    def _check_depth(self, depth_mm):
        d = np.asarray(depth_mm, dtype=float)
        if d.shape != self.depth_mm.shape or not np.array_equal(d, self.depth_mm):
            raise ValueError(f"model {self.name} is bound to its measured history: pass its own depths")

    def elastic(self, theta) -> np.ndarray:
        """Elastic force at the recorded depths (0 before contact), mN."""
        theta = np.asarray(theta, dtype=float)
        shift = theta[self._n_core] if self.offset else 0.0
        h = self.depth_mm - shift
        touch = h > 0
        out = np.zeros_like(h)
        if np.any(touch):
            top = self.depth_range[1]
            if h[touch].max() > top * (1 + 1e-9):
                raise ValueError(f"depth minus offset reaches {h.max():.4g} mm, beyond the surface's {top:.4g} mm")
            out[touch] = self.core.force(h[touch], theta[: self._n_core])
        return out

    def force(self, depth_mm, theta) -> np.ndarray:
        self._check_depth(depth_mm)
        theta = np.asarray(theta, dtype=float)
        fe = self.elastic(theta)
        shift = theta[self._n_core] if self.offset else 0.0
        out = fe
        if self.viscoelastic:
            from ..response_surface.hereditary import hereditary_force, relaxation_weights

            i = self.parameter_names.index("g1")
            g, tau = float(theta[i]), float(theta[i + 1])
            key = (g, tau)
            if key not in self._weights:
                if len(self._weights) > 64:
                    self._weights.clear()
                self._weights[key] = relaxation_weights(self.time_s, ((g, tau),))
            out = hereditary_force(self.time_s, self.depth_mm - shift, fe, ((g, tau),), weights=self._weights[key])
        if self.adhesion:  # DMT: 2 pi w R while below the contact point; w in mJ/m^2 = 1e-3 mN/mm
            w = float(theta[self.parameter_names.index("w_mJ_per_m2")])
            out = out - 2e-3 * math.pi * w * self.radius_mm * (self.depth_mm - shift > 0)
        return out

    def jacobian(self, depth_mm, theta) -> np.ndarray:
        """Central differences (relative steps; one-sided at the box faces); dF/dE exact."""
        theta = np.asarray(theta, dtype=float)
        lo, hi = self.bounds
        J = np.empty((self.depth_mm.size, theta.size))
        for i in range(theta.size):
            if i == 0 and not self.adhesion:  # F is exactly proportional to the modulus of the top material
                J[:, 0] = self.force(depth_mm, theta) / theta[0]
                continue
            span = hi[i] - lo[i]
            step = 1e-5 * max(abs(theta[i]), 1e-2 * span if math.isfinite(span) else 1e-3)
            up, down = theta.copy(), theta.copy()
            up[i] = min(theta[i] + step, hi[i])
            down[i] = max(theta[i] - step, lo[i])
            J[:, i] = (self.force(depth_mm, up) - self.force(depth_mm, down)) / (up[i] - down[i])
        return J


def reported_parameters(names, values, cov) -> tuple[dict, dict]:
    """Parameters with units as users read them, and their standard deviations.

    ``compliance`` (E_top / E_below) becomes ``ratio`` = E_below / E_top (``inf``: a
    rigid base); ``C20_over_E`` becomes ``C20_kPa`` = C20/E * E. Standard deviations by
    the delta method with the covariance of the fit.
    """
    names = list(names)
    x = np.asarray(values, dtype=float)
    C = np.asarray(cov, dtype=float) if cov is not None else np.full((x.size, x.size), np.nan)
    params, std = {}, {}
    for i, n in enumerate(names):
        s = math.sqrt(C[i, i]) if np.isfinite(C[i, i]) and C[i, i] >= 0 else math.nan
        if n == "compliance":
            c = x[i]
            params["ratio"] = math.inf if c < 1e-6 else 1.0 / c
            std["ratio"] = math.inf if c < 1e-6 else s / c**2
        elif n == "C20_over_E":
            e = names.index("E_kPa")
            E, c = x[e], x[i]
            params["C20_kPa"] = c * E
            var = E**2 * C[i, i] + c**2 * C[e, e] + 2 * E * c * C[i, e]
            std["C20_kPa"] = math.sqrt(var) if np.isfinite(var) and var >= 0 else math.nan
        else:
            params[n] = float(x[i])
            std[n] = s
    return params, std
