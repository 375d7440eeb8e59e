r"""Response surfaces over effect parameters: F(h; E, nu, p) for a :class:`~skin_indent.effects.Model`.

Every model of :mod:`skin_indent.effects` is exactly proportional to the modulus of
its top material once the other moduli are given relative to it
(:meth:`Model.unit_parameters`), so

.. math::

    F(h; E, \nu, p) = E\, f(h; \nu, \bar p), \qquad \bar p = \text{unit parameters of } p,

and a surface needs forward runs over :math:`(\nu, \bar p)` only. An
:class:`EffectSurface` holds one :class:`ResponseSurface` (depth x nu, built and
cached exactly like the neo-Hookean one: atomic, resumable, Dask-capable) per node of
the effect axes, and interpolates log F between the runs with tensor-product splines
(cubic with 4 or more nodes on an axis, else quadratic or linear) in a coordinate
chosen per parameter: ``log(0.5 - nu)`` (a confined layer stiffens like
``1 / (1 - 2 nu)``), log of a thickness, log(0.1 + compliance) with the compliance
``E_top / E_below = 1 / ratio`` of a layer (so a rigid base, ratio = inf, is the
node 0), and ``C20_over_E`` = C20 / E of stiffening.

Runs that fail (e.g. a layer much thinner than the depth on a rigid base) are
recorded with their reason by the run cache; an :class:`EffectSurface` with failed
runs refuses to evaluate and says which.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import logging
from typing import Callable, Mapping

import numpy as np

from ..response_surface import SurfaceCore, SurfaceGrid, default_cache_dir, default_settings, default_unit_curve
from ..runtime.executors import Executor
from ..effects import ELASTIC, EffectAxis, effect
from ..effects import Model, model_name
from ..response_surface import NodeForces, ResponseSurface
from ..response_surface import RunStore
from ..response_surface import Job, expected_code_of, make_runs, resolve_model, run_key
from ..runtime.executors import make_executor
from ..runtime.log import progress_bar

log = logging.getLogger(__name__)

__all__ = ["EffectAxis", "EffectSurface", "default_axes", "model_unit_curve", "recompute_shipped", "scaled_surface",
           "unit_curve_of"]




def model_parameters(effects, axis_values: Mapping[str, float]) -> dict:
    """Model parameters at E = 1 kPa (``Model.check`` names) of the surface-axis values: each effect says."""
    out = {}
    for e in (effect(name) for name in effects):
        out.update(e.unit_values({k: axis_values[k] for k in e.fit_names if k in axis_values}))
    return out


def default_axes(effect_name, max_depth_mm: float) -> tuple[EffectAxis, ...]:
    """The axes of an elastic effect's surface (nodes scale with the deepest depth): the effect says."""
    e = effect(effect_name)
    if e.stage != ELASTIC:
        raise ValueError(f"no effect surface for {e.name!r}: it does not act on the elastic response")
    return tuple(e.surface_axes(max_depth_mm))


def model_unit_curve(nu: float, depth_mm, *, effects: tuple, parameters: tuple, radius_mm: float,
                     mesh: str) -> np.ndarray:
    """Force (mN) at E = 1 kPa of ``Model(effects)`` with unit ``parameters`` ((name, value), ...)."""
    theta = {"E_kPa": 1.0, "nu": float(nu), **dict(parameters)}
    return Model(tuple(effects), radius_mm).simulate(theta, np.asarray(depth_mm, float), mesh=mesh).force_mN


class EffectSurface(SurfaceCore):
    """Force ``F(h; E_kPa, nu, effect parameters...)`` (mN), interpolated from cached FE runs.

    Implements the force-model protocol of :mod:`skin_indent.inverse`
    (``parameter_names``, ``bounds``, ``force``, ``jacobian``, ``depth_range``).

    Parameters
    ----------
    effects : tuple of str
        Effect names of the model (path-independent effects only).
    axes : tuple of EffectAxis
    surfaces : ndarray of ResponseSurface
        Shape ``tuple(len(a.nodes) for a in axes)``.
    radius_mm : float
    """

    def __init__(self, effects, axes, surfaces, radius_mm: float):
        self.effects = tuple(effects)
        self.axes = tuple(axes)
        self.surfaces = surfaces
        self.radius_mm = float(radius_mm)
        first = surfaces.flat[0]
        self.grid = first.grid
        self.parameter_names = ("E_kPa", "nu") + tuple(a.name for a in self.axes)
        lo = [first.grid.E_kPa[0], first.grid.nu[0]]
        hi = [first.grid.E_kPa[-1], first.grid.nu[-1]]
        for a in self.axes:
            lo.append(min(a.nodes))
            hi.append(max(a.nodes))
        self.bounds = (np.array(lo, float), np.array(hi, float))
        self.depth_range = first.depth_range
        self._last = None
        self._stack = None
        self._node_coords = None
        self.failures = {}
        #: ``{"radius_mm": R0, "factor": k}`` of a surface scaled by :meth:`at_radius`, else None
        self.similarity = None
        for idx in itertools.product(*(range(len(a.nodes)) for a in self.axes)):
            s = surfaces[idx]
            if s.failures:
                where = ", ".join(f"{a.name}={a.nodes[i]:g}" for a, i in zip(self.axes, idx))
                for nu, why in s.failures.items():
                    self.failures[f"{where}, nu={nu:g}"] = why

    @property
    def name(self) -> str:
        return model_name(self.effects)

    # ------------------------------------------------------------------ build
    @classmethod
    def build(cls, effects, axes, grid: SurfaceGrid, *, radius_mm: float = 6.22, mesh: str = "medium",
              cache_dir=None, workers=None, progress: bool | None = None, client=None, scheduler=None,
              executor=None) -> "EffectSurface":
        """Load or build the sub-surfaces (one per effect node; runs cached in ``cache_dir``).

        Parameters
        ----------
        effects : tuple of str
        axes : tuple of EffectAxis
        grid : SurfaceGrid
            Depths (mm), E range (kPa, bounds only: F is exactly linear in E) and nu nodes.
        radius_mm : float
            Sphere radius, mm.
        mesh : str
            Mesh family member.
        cache_dir : path, optional
            Default :func:`default_cache_dir`.
        workers, client, scheduler, executor
            As in :meth:`ResponseSurface.build`; one executor serves all sub-surfaces.
        progress : bool or None
            A tqdm bar over all runs (default None: only when stderr is a terminal).
        """
        from pathlib import Path

        effects = tuple(effects)
        cache_dir = Path(default_cache_dir() if cache_dir is None else cache_dir)
        shape = tuple(len(a.nodes) for a in axes)
        surfaces = np.empty(shape, dtype=object)
        depth = np.array(grid.depth_mm)
        pending = []
        for idx in np.ndindex(shape):
            settings, params = cls._node(effects, axes, idx, radius_mm, mesh)
            curve = functools.partial(model_unit_curve, effects=effects, parameters=params,
                                      radius_mm=float(radius_mm), mesh=mesh)
            try:  # a cached surface (or one whose runs are all cached) needs no executor
                surfaces[idx] = ResponseSurface.load_or_build(grid, settings, curve, cache_dir=cache_dir,
                                                              progress=False, executor=_Never(), quiet=True)
            except _NeedsRuns:
                pending.append((idx, curve, settings))
        if not pending:
            return cls(effects, axes, surfaces, radius_mm)
        # all missing runs of all sub-surfaces in one stream, so that every worker stays busy
        jobs, stores = [], {}
        for idx, curve, settings in pending:
            curve, canonical = resolve_model(curve, settings)
            key = run_key(canonical, depth)
            stores[idx] = store = RunStore(cache_dir / "runs" / key[:24], key, canonical, depth)
            code = expected_code_of(canonical)
            jobs += [Job((idx, float(nu)), store, float(nu), (curve, float(nu), depth), code)
                     for nu in grid.nu if store.load(nu) is None]
        owned = executor is None
        ex = executor if executor is not None else make_executor(workers, client=client, scheduler=scheduler,
                                                                 tasks=len(jobs))
        what = f"{' + '.join(effects)} surface R = {radius_mm:g} mm, mesh {mesh}"
        log.info("%s: %d finite-element run%s to make (%d sub-surfaces, %d incomplete)", what, len(jobs),
                 "s" if len(jobs) != 1 else "", surfaces.size, len(pending))
        bar = progress_bar(progress, total=len(jobs), desc=" + ".join(effects) + " surface", unit="run")
        try:
            for _ in make_runs(jobs, lambda n: (ex, False), bar=bar, what=what):
                pass  # recorded in the stores as they arrive
            for idx, curve, settings in pending:  # assembled from the store; failed runs stay missing
                again = _FailAgain(stores[idx].failed())
                surfaces[idx] = ResponseSurface.load_or_build(grid, settings, curve, cache_dir=cache_dir,
                                                              progress=False, executor=again, quiet=True)
        finally:
            bar.close()
            if owned:
                ex.close()
        return cls(effects, axes, surfaces, radius_mm)

    @staticmethod
    def _node(effects, axes, idx, radius_mm: float, mesh: str) -> tuple[dict, tuple]:
        """The run settings and unit parameters of the sub-surface at node ``idx`` of ``axes``."""
        unit = tuple((a.name, float(a.nodes[i])) for a, i in zip(axes, idx))
        params = tuple(sorted(model_parameters(effects, dict(unit)).items()))
        settings = {**default_settings(radius_mm=radius_mm, mesh=mesh),
                    "model": model_name(effects),
                    "unit_curve": "skin_indent.models.effect_surface.model_unit_curve",
                    "unit_parameters": [[k, repr(v)] for k, v in params]}
        return settings, params

    @classmethod
    def node_settings(cls, effects, axes, radius_mm: float, mesh: str) -> dict:
        """The run settings of the sub-surface at the centre node of ``axes`` (what the surface's
        runs are found by, e.g. among the shipped ones)."""
        return cls._node(tuple(effects), axes, tuple(len(a.nodes) // 2 for a in axes), radius_mm, mesh)[0]

    # ------------------------------------------------------------ similarity
    def at_radius(self, radius_mm: float, *, E_kPa=None) -> "EffectSurface":
        """The same surface for another sphere radius, by exact similarity.

        No law of the models has a length scale and the mesh is scaled by sqrt(R h_max)
        (layer interfaces and a rigid base with it), so with every length scaled by
        k = R / R0 (depths, and the axes in mm: a layer's thickness) the force scales by k^2
        (kPa x mm^2 = mN): F(k h; E, nu, k T, ratio, C20/E; k R0) = k^2 F(h; ...; R0). Checked
        against direct runs at k = 2 and 4 (``tests/test_shipped_surfaces.py``). Axes in mm
        are interpolated in log coordinates (a shift of log k) and depths by an affine-invariant
        rule, so the scaled surface interpolates exactly as the original.

        Parameters
        ----------
        radius_mm : float
            Sphere radius R (mm), > 0.
        E_kPa : array_like, optional
            E nodes (kPa) of the returned surface: the bounds of E of a fit (F is exactly
            linear in E). Default: the original's.
        """
        R = float(radius_mm)
        if not (np.isfinite(R) and R > 0):
            raise ValueError(f"radius must be a finite number > 0 mm, got {radius_mm}")
        k = R / self.radius_mm
        for a in self.axes:
            if a.name.endswith("_mm") and a.coordinate != "log":
                raise ValueError(f"the {a.name} axis is not interpolated in log coordinates: no similarity")
        axes = tuple(dataclasses.replace(a, nodes=tuple(float(v) * k for v in a.nodes)) if a.name.endswith("_mm")
                     else a for a in self.axes)
        surfaces = np.empty(self.surfaces.shape, dtype=object)
        for idx in np.ndindex(self.surfaces.shape):
            surfaces[idx] = scaled_surface(self.surfaces[idx], k, E_kPa)
        out = type(self)(self.effects, axes, surfaces, R)
        out.similarity = {"radius_mm": self.radius_mm, "factor": k}
        return out

    # ------------------------------------------------------------ evaluation
    def _check(self, theta):
        theta = np.asarray(theta, dtype=float)
        if theta.shape != (len(self.parameter_names),):
            raise ValueError(f"theta must hold {self.parameter_names}, got shape {theta.shape}")
        lo, hi = self.bounds
        tol = 1e-9 * np.maximum(np.abs(lo), np.abs(hi)) + 1e-12
        bad = ~np.isfinite(theta) | (theta < lo - tol) | (theta > hi + tol)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{self.parameter_names[i]} = {theta[i]:g} is outside the surface's "
                             f"[{lo[i]:g}, {hi[i]:g}]")
        if self.failures:
            where, why = next(iter(self.failures.items()))
            raise ValueError(f"the {self.name} surface misses {len(self.failures)} run(s) (e.g. {where}: {why})")
        return theta

    def _node_forces(self, h: np.ndarray) -> np.ndarray:
        """log f at every node (effect nodes x nu nodes x depths); kept for the last depths asked."""
        key = h.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        if self._stack is None:  # at a node: its runs, interpolated in depth only, all at once
            self._stack = NodeForces(list(self.surfaces.flat))
        V = self._stack(h).reshape(self.surfaces.shape + (self.grid.nu.size,) + h.shape)
        positive = bool(np.all(V > 0))
        out = (np.log(V) if positive else V, positive)
        self._last = (key, out)
        return out

    def unit_force(self, depth_mm, nu: float, unit_values, *, degree: int = 3) -> np.ndarray:
        """f(h; nu, unit parameters), mN at E = 1 kPa.

        Tensor-product splines of log f over the effect axes and over nu in the
        coordinate ``log(0.5 - nu)``: a layer confined by a stiff base stiffens like
        ``1 / (1 - 2 nu)`` towards incompressibility, a straight line there. The spline of
        each axis is linear in the node values, so the interpolant is one weighted sum of
        the node values: weights the outer product of every axis' spline weights. ``degree``:
        of the splines (3; 2 for :meth:`interpolation_error`).
        """
        h = np.asarray(depth_mm, dtype=float)
        V, positive = self._node_forces(h)
        if self._node_coords is None:
            self._node_coords = [tuple(float(v) for v in a.node_coords) for a in self.axes]
            self._node_coords.append(tuple(float(v) for v in np.log(0.5 - self.grid.nu)[::-1]))
        w = np.ones(1)
        for a, nodes, x in zip(self.axes, self._node_coords, unit_values):
            w = np.multiply.outer(w, _weight_spline(nodes, degree)(float(a.coords(x)))).ravel()
        w = np.multiply.outer(w, _weight_spline(self._node_coords[-1], degree)(float(np.log(0.5 - nu)))[::-1]).ravel()
        out = (w @ V.reshape(w.size, -1)).reshape(h.shape)
        return np.exp(out) if positive else out

    def interpolation_error(self, depth_mm, theta) -> float:
        """How far the interpolation between the finite-element runs may be off around ``theta``: the
        largest relative difference, over ``depth_mm``, between the force of the surface's cubic
        splines and that of quadratic splines through the same nodes, at the centre of the cell of
        nodes that holds ``theta`` (on an axis where ``theta`` is at a node, at that node: nothing is
        interpolated along it). A property of the cell, not of the point: two splines can cross
        inside a cell where neither is exact.

        Checked against the truth: on the layer surface of the forearm-like curve (R = 6.22 mm,
        depths to 0.6 mm; ``benchmarks/README.md``, finite-element runs at the centres of 24 cells
        at two nu) it exceeds 0.3 % at the 6 centres whose force is off by more than 0.4 % (by
        4.4-5.8 % where it is 2.2-2.6 %: a thin layer squeezed on a nearly rigid base), and nowhere
        else; on smooth monotonic functions (``tests/test_response_surface.py``) it exceeds 0.3 %
        wherever the cubic interpolation is off by more than 1 %. Under-resolved oscillations
        between nodes escape it, as they escape any estimate made from the nodes.
        """
        theta = self._check(theta)
        h = np.asarray(depth_mm, dtype=float)
        values = [a.value(_cell_centre(a.node_coords, float(a.coords(x)))) for a, x in zip(self.axes, theta[2:])]
        nu = 0.5 - np.exp(_cell_centre(np.log(0.5 - self.grid.nu)[::-1], float(np.log(0.5 - theta[1]))))
        cubic = self.unit_force(h, nu, values)
        quadratic = self.unit_force(h, nu, values, degree=2)
        ok = np.abs(cubic) > 0
        return float(np.max(np.abs(quadratic[ok] / cubic[ok] - 1.0), initial=0.0))

    def force(self, depth_mm, theta) -> np.ndarray:
        """Force (mN) at the depths (mm) for ``theta = (E_kPa, nu, effect parameters...)``."""
        theta = self._check(theta)
        return theta[0] * self.unit_force(depth_mm, theta[1], theta[2:])

    __call__ = force

    def jacobian(self, depth_mm, theta) -> np.ndarray:
        """dF/dtheta (mN per unit), central differences inside the box (one-sided at its faces)."""
        theta = self._check(theta)
        lo, hi = self.bounds
        J = np.empty((np.size(depth_mm), theta.size))
        J[:, 0] = self.force(depth_mm, theta) / theta[0]  # exactly linear in E
        for i in range(1, theta.size):
            step = 1e-5 * max(abs(theta[i]), 1e-2 * (hi[i] - lo[i]))
            up, down = theta.copy(), theta.copy()
            up[i] = min(theta[i] + step, hi[i])
            down[i] = max(theta[i] - step, lo[i])
            J[:, i] = (self.force(depth_mm, up) - self.force(depth_mm, down)) / (up[i] - down[i])
        return J


def scaled_surface(surface: ResponseSurface, factor: float, E_kPa=None) -> ResponseSurface:
    """``surface`` with depths x ``factor`` and forces x ``factor``^2 (every length of its model
    scaled by ``factor``: :meth:`EffectSurface.at_radius`), on the E nodes ``E_kPa`` (default its own)."""
    g = surface.grid
    E = g.E_kPa if E_kPa is None else np.asarray(E_kPa, dtype=float)
    k = float(factor)
    origin = surface.settings.get("similarity", {"radius_mm": surface.settings.get("radius_mm"), "hash": surface.hash})
    settings = {**surface.settings, "radius_mm": float(surface.settings.get("radius_mm", 1.0)) * k,
                "similarity": origin}
    return type(surface)(SurfaceGrid(g.depth_mm * k, E, g.nu), surface.unit_forces * k**2, settings=settings,
                         failures=surface.failures, method=surface.method, depth_interp=surface.depth_interp,
                         scaling=surface.scaling)


def _cell_centre(nodes, x: float) -> float:
    """The centre of the cell of ``nodes`` (increasing coordinates) that holds the coordinate ``x``;
    ``x`` itself where it is at a node."""
    nodes = np.asarray(nodes, dtype=float)
    if np.min(np.abs(nodes - x)) <= 1e-9 * (nodes[-1] - nodes[0]):
        return float(x)
    i = int(np.clip(np.searchsorted(nodes, x) - 1, 0, nodes.size - 2))
    return float(0.5 * (nodes[i] + nodes[i + 1]))


@functools.lru_cache(maxsize=256)
def _weight_spline(nodes: tuple, degree: int = 3):
    """The interpolating spline of the identity at ``nodes`` (of ``degree``, not-a-knot, with
    more nodes than that; else of degree n - 1): its value at x holds the weight of every node."""
    from scipy.interpolate import make_interp_spline  # lazy: scipy.interpolate is slow to import

    x = np.asarray(nodes, dtype=float)
    return make_interp_spline(x, np.eye(x.size), k=min(degree, x.size - 1), axis=0)


def _spline_weights(nodes, x) -> np.ndarray:
    """Weights w with s(x) = sum_j w_j v_j for the interpolating spline s of any values v_j at ``nodes``.

    The spline (cubic, not-a-knot, with 4 or more nodes; else of degree n - 1) is linear in
    the values, so interpolating the identity gives its weights at ``x``: one small spline
    instead of one over every depth and every other node, made once per set of nodes.
    """
    return _weight_spline(tuple(float(v) for v in np.asarray(nodes, dtype=float)))(float(x))


class _NeedsRuns(Exception):
    pass


class _Never(Executor):
    """An executor stand-in that signals that runs are needed (a cached surface needs none)."""

    def check_callable(self, fn):
        raise _NeedsRuns

    def imap_unordered(self, fn, tasks):
        raise _NeedsRuns


class _FailAgain(Executor):
    """Reports the runs that just failed as failed again, with the reason their store recorded,
    without rerunning them."""

    def __init__(self, reasons: dict):
        self.reasons = reasons

    def imap_unordered(self, fn, tasks):
        for tag, (_curve, nu, _depth) in tasks:
            yield tag, {"values": None, "reason": self.reasons.get(nu, "failed in this build (see the run manifest)"),
                        "worker": None}, None


def unit_curve_of(settings) -> Callable:
    """The forward model that made a surface's run, rebuilt from its settings (a shipped run's):
    an effect surface's :func:`model_unit_curve`, else the half-space's unit curve."""
    if settings.get("unit_curve") == "skin_indent.models.effect_surface.model_unit_curve":
        effects = tuple(settings["model"].split("+")[1:])
        params = tuple((k, float(v)) for k, v in settings["unit_parameters"])
        return functools.partial(model_unit_curve, effects=effects, parameters=params,
                                 radius_mm=float(settings["radius_mm"]), mesh=settings["mesh"])
    return default_unit_curve(settings)


def recompute_shipped(settings, depth_mm, nu: float) -> np.ndarray:
    """The unit forces (mN at E = 1 kPa) of a shipped run made again by the installed forward model:
    ``forces_of`` of :func:`skin_indent.response_surface.shipped.verify`."""
    return np.asarray(unit_curve_of(settings)(float(nu), np.array(depth_mm, dtype=float)), dtype=float)

