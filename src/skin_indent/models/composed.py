"""A fitted force model made of an elastic core and effects, bound to one measured history."""

from __future__ import annotations

import math

import numpy as np

from ..effects import DEPTH, ELASTIC, STAGE_ORDER, WEIGHED, Evaluation, instances
from ..effects.base import stack_parameters
from ..effects import BASE_PARAMETERS, model_name


class ComposedModel:
    """Elastic core plus effects, evaluated on one measured history.

    The force at the recorded depths is computed in stages (see
    :class:`~skin_indent.effects.Effect`): effects of the :data:`DEPTH` stage move the
    depth below the contact point (``offset``), the core gives the elastic force where
    that depth is positive, and effects of the later stages act on the force in order
    (``viscoelastic`` along the time history, then ``adhesion``, ...).

    Implements the force-model protocol of :mod:`skin_indent.inverse`
    (``parameter_names``, ``bounds``, ``force``, ``jacobian``).

    Parameters
    ----------
    core : ForceModel
        Elastic force F(h; E_kPa, nu, elastic fit parameters) for depths h > 0 (mm): a
        response surface, or an effect surface for the elastic effects of the model.
    effects : sequence of str or Effect
        All effects of the model (the elastic ones are in ``core`` already).
    data : PreparedCurve
        The measured history (``depth_mm``, ``time_s``, ``radius_mm``) and what the
        effects' bounds depend on.
    """

    def __init__(self, core, effects, data):
        self.core = core
        self.effects = instances(effects)
        self.data = data
        self.depth_mm = np.asarray(data.depth_mm, dtype=float)
        self.time_s = None if data.time_s is None else np.asarray(data.time_s, dtype=float)
        self.radius_mm = float(data.radius_mm)
        self.depth_range = core.depth_range
        names = list(core.parameter_names)
        lo, hi = (list(np.asarray(b, dtype=float)) for b in core.bounds)
        self.acting = sorted((e for e in self.effects if e.stage not in (ELASTIC, WEIGHED)),
                             key=lambda e: STAGE_ORDER.index(e.stage))
        reach = float(core.depth_range[1])
        self._slices = stack_parameters(self.acting, lambda e: e.fit_bounds(data, reach_mm=reach), names, lo, hi)
        self.parameter_names = tuple(names)
        self.bounds = (np.array(lo), np.array(hi))
        self._n_core = len(core.parameter_names)
        self._linear_in_E = all(e.linear_in_E for e in self.acting)
        self._cache: dict = {}

    @property
    def name(self) -> str:
        return model_name(self.effects)

    def _check_depth(self, depth_mm):
        d = np.asarray(depth_mm, dtype=float)
        if d.shape != self.depth_mm.shape or not np.array_equal(d, self.depth_mm):
            raise ValueError(f"model {self.name} is bound to its measured history: pass its own depths")

    def _evaluation(self, h_mm, force_mN=None) -> Evaluation:
        return Evaluation(self.depth_mm, self.time_s, h_mm, self.radius_mm, force_mN=force_mN, cache=self._cache,
                          kind=getattr(self.data, "kind", None), baseline=getattr(self.data, "baseline", None),
                          deflection_mm=getattr(self.data, "deflection_mm", None))

    def evaluate(self, theta, core_change=None, *, before=None) -> Evaluation:
        """All stages at the parameters ``theta`` (the force is ``.force_mN``).

        ``core_change``, an array over the depths in contact, is added to the elastic force
        before the later stages act (directional derivatives through them). ``before``, a dict,
        receives the force ahead of each stage after the elastic one (``{stage: force}``; the
        stage's effects and those after it start from there: :meth:`_from_stage`).
        """
        theta = np.asarray(theta, dtype=float)
        ev = self._evaluation(self.depth_mm.copy())
        values = [(e, dict(zip(e.fit_names, theta[s]))) for e, s in self._slices]
        for e, fit in values:
            if e.stage == DEPTH:
                e.apply(ev, fit)
        h = ev.h_mm
        touch = h > 0
        force = np.zeros_like(h)
        if np.any(touch):
            top = self.depth_range[1]
            if h[touch].max() > top * (1 + 1e-9):
                raise ValueError(f"depth minus offset reaches {h.max():.4g} mm, beyond the surface's {top:.4g} mm")
            force[touch] = self.core.force(h[touch], theta[: self._n_core])
            if core_change is not None:
                force[touch] += core_change
        ev.force_mN = force
        for e, fit in values:
            if e.stage != DEPTH:
                if before is not None and e.stage not in before:
                    before[e.stage] = ev.force_mN  # the effects replace the array, never change it in place
                e.apply(ev, fit)
        return ev

    def _from_stage(self, theta, stage: str, force_mN, h_mm) -> np.ndarray:
        """The force at ``theta`` from ``force_mN``, the force ahead of ``stage`` (:meth:`evaluate`'s
        ``before``) at a ``theta`` that differs from this one only in parameters of that stage or later,
        and the depths below the contact point ``h_mm``: only the effects of ``stage`` and later act.
        The same numbers as :meth:`evaluate`, without the stages before (the elastic core, a hereditary
        integral) made again."""
        theta = np.asarray(theta, dtype=float)
        ev = self._evaluation(h_mm, force_mN)
        first = STAGE_ORDER.index(stage)
        for e, s in self._slices:
            if e.stage != DEPTH and STAGE_ORDER.index(e.stage) >= first:
                e.apply(ev, dict(zip(e.fit_names, theta[s])))
        return ev.force_mN

    def force(self, depth_mm, theta) -> np.ndarray:
        self._check_depth(depth_mm)
        return self.evaluate(theta).force_mN

    def iterating(self):
        """Context of a fit's iterations: the core's (:meth:`~skin_indent.models.fe_core.FECore.iterating`:
        secant updates of differenced columns), or nothing for a surface."""
        return self.core.iterating()

    def jacobian(self, depth_mm, theta, columns=None) -> np.ndarray:
        """dF/dtheta: central differences of relative step 1e-5 (one-sided at the box faces),
        dF/dE exact where F is linear in E; where the core is the finite-element model in the
        loop, its own derivatives (:meth:`~skin_indent.models.fe_core.FECore.jacobian`)
        carried through the later stages (which act linearly on the elastic force). A parameter of
        the history or force stage (relaxation, drag, baselines, adhesion) is differenced from the
        force ahead of its stage at ``theta`` (:meth:`_from_stage`: the same numbers, the elastic core
        and the stages before not evaluated again). Only the ``columns`` asked for (indices; default
        all) are computed, the others are 0."""
        theta = np.asarray(theta, dtype=float)
        lo, hi = self.bounds
        J = np.zeros((self.depth_mm.size, theta.size))
        wanted = np.zeros(theta.size, dtype=bool)
        wanted[np.arange(theta.size) if columns is None else columns] = True
        first = 0
        before: dict = {}  # the force ahead of each later stage at theta: its parameters' columns start there
        ev = self.evaluate(theta, before=before)
        if self.in_loop:  # the core's own derivatives, carried through the later stages
            touch = ev.h_mm > 0
            Jc = self.core.jacobian(ev.h_mm[touch], theta[: self._n_core],
                                    columns=np.flatnonzero(wanted[: self._n_core]))
            scale = max(float(np.max(np.abs(ev.force_mN))), 1e-300)
            for i in range(self._n_core):
                top = float(np.max(np.abs(Jc[:, i]))) if Jc.size and wanted[i] else 0.0
                if top == 0.0:
                    J[:, i] = 0.0
                    continue
                eps = 1e-6 * scale / top
                J[:, i] = (self.evaluate(theta, eps * Jc[:, i]).force_mN
                           - self.evaluate(theta, -eps * Jc[:, i]).force_mN) / (2 * eps)
            first = self._n_core
        self._check_depth(depth_mm)
        stages = {i: e.stage for e, s in self._slices for i in range(s.start, s.stop)}
        for i in range(first, theta.size):
            if not wanted[i]:
                continue
            if i == 0 and self._linear_in_E:  # F is exactly proportional to the modulus of the top material
                J[:, 0] = ev.force_mN / theta[0]
                continue
            span = hi[i] - lo[i]
            step = 1e-5 * max(abs(theta[i]), 1e-2 * span if math.isfinite(span) else 1e-3)
            up, down = theta.copy(), theta.copy()
            up[i] = min(theta[i] + step, hi[i])
            down[i] = max(theta[i] - step, lo[i])
            stage = stages.get(i)
            if stage in before:  # a parameter of a later stage: the stages before it are those at theta
                J[:, i] = ((self._from_stage(up, stage, before[stage], ev.h_mm)
                            - self._from_stage(down, stage, before[stage], ev.h_mm)) / (up[i] - down[i]))
            else:
                J[:, i] = (self.force(depth_mm, up) - self.force(depth_mm, down)) / (up[i] - down[i])
        return J

    def model_parameters(self, x) -> dict:
        """Model parameters (names with units, as users read them) of the fit vector ``x``."""
        x = dict(zip(self.parameter_names, np.asarray(x, dtype=float)))
        E = x["E_kPa"]
        out = {"E_kPa": E, "nu": x["nu"]}
        for e in self.effects:
            if e.stage == WEIGHED:
                continue
            if all(k in x for k in e.fit_names):
                out.update(e.from_fit({k: x[k] for k in e.fit_names}, E))
        return out

    def reported(self, x, cov) -> tuple[dict, dict]:
        """Model parameters and their standard deviations (delta method with ``cov`` of ``x``)."""
        return reported_parameters(self, x, cov)

    # ------------------------------------------------------------- finite-element cores
    @property
    def cores(self) -> tuple:
        """The elastic cores of the model (one: its ``core``)."""
        return (self.core,)

    @property
    def in_loop(self) -> bool:
        """The core is the finite-element model in the loop (a
        :class:`~skin_indent.models.fe_core.FECore`), not a response surface."""
        return self.core.in_loop

    def screening(self):
        """Context of cheap runs that only rank start vectors (:meth:`~skin_indent.models.fe_core.FECore.screening`),
        or nothing for a surface."""
        return self.core.screening()

    def prefetch(self, xs) -> None:
        """Make the finite-element runs of several fit vectors at once (nothing for a surface)."""
        self.core.prefetch([np.asarray(x, dtype=float)[: self._n_core] for x in xs])


def reported_parameters(model, x, cov) -> tuple[dict, dict]:
    """Model parameters of a fit vector and their standard deviations (the delta method).

    Parameters
    ----------
    model
        A fitted model with ``model_parameters(x)`` (:class:`ComposedModel`, :class:`~.joint.JointModel`).
    x : ndarray
        Fit vector.
    cov : ndarray or None
        Its covariance (None: standard deviations NaN).

    Returns
    -------
    params, std : dict
        ``{name: value}`` and ``{name: standard deviation}`` in the parameters' units (``inf`` for
        an infinite value, 0 for a parameter that no fitted coordinate moves).
    """
    x = np.asarray(x, dtype=float)
    params = model.model_parameters(x)
    names = list(params)
    C = np.asarray(cov, dtype=float) if cov is not None else np.full((x.size, x.size), np.nan)
    G = np.zeros((len(names), x.size))
    for j in range(x.size):
        step = 1e-6 * max(abs(x[j]), 1e-6)
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        a, b = model.model_parameters(up), model.model_parameters(down)
        for i, n in enumerate(names):
            diff = a[n] - b[n]
            G[i, j] = diff / (2 * step) if math.isfinite(diff) else 0.0
    std = {}
    for i, n in enumerate(names):
        g = G[i]
        used = g != 0
        if not math.isfinite(params[n]):
            std[n] = math.inf
            continue
        if not np.any(used):
            std[n] = 0.0
            continue
        sub = C[np.ix_(used, used)]
        var = float(g[used] @ sub @ g[used]) if np.all(np.isfinite(sub)) else math.nan
        std[n] = math.sqrt(var) if math.isfinite(var) and var >= 0 else math.nan
    return params, std


def declared_parameters(model) -> dict:
    """The declared parameters of a fitted model: the core's
    (:data:`~skin_indent.effects.BASE_PARAMETERS`) and every effect's.

    Parameters
    ----------
    model : ComposedModel
        A fitted model (its ``effects``).

    Returns
    -------
    dict
        ``{model parameter name: EffectParameter}``.
    """
    out = {p.name: p for p in BASE_PARAMETERS}
    for e in model.effects:
        out.update({p.name: p for p in e.parameters})
    return out


def at_physical_limit(model, x, name: str) -> bool:
    """The fit parameter ``name``, on a face of its range, stands at a physical limit.

    The face is a physical limit when, moving inward from it, a model parameter moves
    away from the end of its range that its
    :attr:`~skin_indent.effects.EffectParameter.physical_limit` declares: a layer's
    compliance at 0 is a rigid base (``ratio`` at ``inf``), Poisson's ratio at the top
    of its range the nearly incompressible end. A fit that stops there has found the
    limit; elsewhere it stopped at the edge of what the model reaches.

    Parameters
    ----------
    model : ComposedModel
        The fitted model (``parameter_names``, ``bounds``, ``model_parameters``, ``effects``).
    x : ndarray
        Its fitted vector.
    name : str
        A fit parameter (``compliance``, ``nu``...).

    Returns
    -------
    bool
    """
    if model is None or x is None or name not in model.parameter_names:
        return False
    x = np.asarray(x, dtype=float)
    i = model.parameter_names.index(name)
    lo, hi = (float(b[i]) for b in model.bounds)
    lower = abs(x[i] - lo) <= abs(hi - x[i])
    span = hi - lo
    step = 1e-3 * (span if math.isfinite(span) and span > 0 else max(abs(x[i]), 1.0))
    inward = x.copy()
    inward[i] += step if lower else -step
    try:
        at, near = model.model_parameters(x), model.model_parameters(inward)
    except (ValueError, ZeroDivisionError, OverflowError):
        return False  # no model parameters there: not a limit they declare
    for k, p in declared_parameters(model).items():
        if p.physical_limit is None or k not in at or at[k] == near[k]:
            continue
        side = "upper" if at[k] > near[k] else "lower"
        if side == p.physical_limit:
            return True
    return False
