"""Which response surface serves a curve: found in the cache, or built (and cached).

- :func:`surface_for`: the neo-Hookean surface F(h; E, nu) for a sphere and a depth
  range; one unit-radius surface serves every radius by the exact similarity
  F = E R^2 phi(h/R, nu).
- :func:`elastic_core`: the elastic force model a fitted model needs for its elastic
  effects (none: the neo-Hookean surface; one: an effect surface over its axes; more, e.g.
  two layers: the finite-element model in the loop). The surfaces are dimensionless ones
  (:func:`unit_core`: R = 1 mm, one per depth ceiling h/R of :data:`EFFECT_CEILINGS`,
  shipped with the package) scaled to the curve's radius, or, for the demo's curves, the
  shipped surfaces made for their radius and depths;
- :func:`interpolation_flags`: a flag where an effect surface interpolates a fit's
  parameters less accurately than the error the fits allow for the model.
"""

from __future__ import annotations

import math

import numpy as np

from ..runtime.context import Context, context_of
from ..response_surface import ResponseSurface, RunCache, SurfaceGrid, default_settings, nice_depth
from ..effects import ELASTIC
from ..effects import instances
from ..models.effect_surface import EffectSurface, scaled_surface
from ..models.fe_core import FECore
from .rung import MODEL_ERROR

#: Depth ceilings h/R of the unit-radius surfaces that :func:`surface_for` reuses for
#: every radius (the mesh is designed for the ceiling: the smallest one that covers
#: the data keeps the contact region finely resolved).
SIMILARITY_RATIOS = (0.1, 0.2, 0.5)
#: nu nodes of the effect surfaces (skin is nearly incompressible; E* barely depends on nu there)
EFFECT_NU = (0.3, 0.42, 0.46, 0.49)
#: nu nodes of the neo-Hookean surface of a fitted model
BASE_NU = tuple(np.linspace(0.2, 0.49, 6))
#: Depth ceilings c = h_max / R of the dimensionless (unit-radius, coarse-mesh) surfaces of
#: :func:`elastic_core`: about 2^(1/4) apart, so that the thinnest layer node (1.2 c R) of the
#: smallest ceiling at or above a curve's h_max / R is at most 1.46 h_max (1.2 h_max on a
#: surface made for the curve's own depth).
EFFECT_CEILINGS = (0.05, 0.06, 0.07, 0.085, 0.1, 0.12, 0.14, 0.17, 0.2, 0.24, 0.28)
#: the neo-Hookean base surface of a fitted model reaches this many times the deepest depth
BASE_REACH = 1.25


def default_grid(max_depth_mm: float, n_depth: int = 100) -> SurfaceGrid:
    """The paper's grid (8 E x 6 nu) reaching at least ``max_depth_mm`` (0.6 mm or more)."""
    depth = max(0.6, math.ceil(max_depth_mm / 0.05 - 1e-9) * 0.05)
    return SurfaceGrid.paper(depth_max_mm=depth, n_depth=n_depth)


def unit_surface_grid(depth_ratio_max: float, n_depth: int = 100) -> SurfaceGrid:
    """The unit-radius grid (R = 1 mm, depths = h/R) of :meth:`SurfaceGrid.unit_radius`."""
    return SurfaceGrid.unit_radius(depth_ratio_max, n_depth)


def surface_for(radius_mm: float, max_depth_mm: float, *, grid: SurfaceGrid | None = None, path=None,
                context: Context | None = None, mesh: str = "medium") -> ResponseSurface:
    """Load or build the neo-Hookean response surface for a sphere and depth range.

    Without ``grid`` and ``path``, and for ``max_depth_mm / radius_mm <= 0.5``, one
    unit-radius surface (R = 1 mm, depths h/R up to the smallest of
    :data:`SIMILARITY_RATIOS` that covers the data) is loaded or built once and scaled
    to ``radius_mm`` (:meth:`ResponseSurface.at_radius`): skin (R = 6 mm) and AFM
    (R = 20 um) curves share it. With ``grid`` (or ``path``), or deeper than h/R = 0.5,
    the surface is built for this radius directly.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R (mm).
    max_depth_mm : float
        Deepest indentation depth to cover (mm).
    grid : SurfaceGrid, optional
        Explicit grid at this radius (default: the similarity path above).
    path : path, optional
        Surface file (.npz) to load or write.
    context : Context, optional
        Cache folder, executor and progress of the builds.
    mesh : str
        Mesh preset of the finite-element runs (``"coarse"``, ``"medium"``, ``"fine"``).
    """
    kw = context_of(context).build_options()
    ratio = float(max_depth_mm) / float(radius_mm)
    ceiling = next((r for r in SIMILARITY_RATIOS if ratio <= r * (1 + 1e-9)), None)
    if grid is None and path is None and ceiling is not None:
        unit = ResponseSurface.load_or_build(unit_surface_grid(ceiling), default_settings(1.0, mesh=mesh), **kw)
        return unit.at_radius(radius_mm)
    grid = grid or default_grid(max_depth_mm)
    return ResponseSurface.load_or_build(grid, default_settings(radius_mm=radius_mm, mesh=mesh), path=path, **kw)


def check_inside(surface, depth_mm) -> None:
    """One-line error when measured depths lie beyond the surface."""
    lo, hi = surface.depth_range
    if np.max(depth_mm) > hi * (1 + 1e-9):
        origin = getattr(surface, "settings", {}).get("similarity")
        scaled = (f" (a surface for R = {origin['radius_mm']:g} mm scaled to R = {surface.settings['radius_mm']:g} mm)"
                  if origin else "")
        raise ValueError(f"measured depth reaches {np.max(depth_mm):.4g} mm, beyond the surface's {hi:.4g} mm"
                         f"{scaled}: build a deeper surface or narrow the window")


def curve_grid(e_star_kPa: float, depth_max_mm: float, nu) -> SurfaceGrid:
    """100 depths to a :func:`nice_depth`, 8 E from E*/30 to 30 E* (3 digits), the ``nu`` nodes."""
    top = nice_depth(depth_max_mm)
    E = np.geomspace(e_star_kPa / 30.0, e_star_kPa * 30.0, 8)
    E = np.array([float(f"{e:.3g}") for e in E])
    return SurfaceGrid(np.linspace(top / 100, top, 100), E, np.asarray(nu, dtype=float))


def ceiling_for(radius_mm: float, max_depth_mm: float) -> float | None:
    """The smallest of :data:`EFFECT_CEILINGS` at or above ``max_depth_mm / radius_mm`` (None: deeper)."""
    ratio = float(max_depth_mm) / float(radius_mm)
    return next((c for c in EFFECT_CEILINGS if ratio <= c * (1 + 1e-9)), None)


def unit_core(effects, ceiling: float, *, context: Context | None = None, mesh: str = "coarse"):
    """The dimensionless surface of a fitted model with at most one elastic effect: at R = 1 mm,
    depths (= h/R) from ``ceiling / 100`` to ``ceiling``, the nodes :func:`elastic_core` gives a
    curve at R = 1 mm reaching ``ceiling`` (the base surface to :data:`BASE_REACH` x ``ceiling``).

    Loaded from the shipped surfaces or the cache, or built; :func:`elastic_core` scales it
    to a curve's radius.
    """
    elastic = [e for e in instances(effects) if e.stage == ELASTIC]
    if len(elastic) > 1:
        raise ValueError("no surface combines two elastic effects: the finite-element model is in the loop")
    kw = context_of(context).build_options()
    if not elastic:
        top = BASE_REACH * float(ceiling)
        grid = SurfaceGrid(np.linspace(top / 100, top, 100), np.geomspace(1 / 3, 300.0, 8), np.array(BASE_NU))
        return ResponseSurface.load_or_build(grid, default_settings(radius_mm=1.0, mesh=mesh), **kw)
    e = elastic[0]
    grid = SurfaceGrid(np.linspace(ceiling / 100, ceiling, 100), np.geomspace(1 / 3, 300.0, 8), np.array(EFFECT_NU))
    return EffectSurface.build((e.name,), tuple(e.surface_axes(float(ceiling))), grid, radius_mm=1.0, mesh=mesh, **kw)


def _shipped_for_curve(grid: SurfaceGrid, settings: dict) -> bool:
    """Whether the package ships a surface made for this curve's radius and depths (the demo's two
    curves): it is used as it is, so that the demo's numbers stay (built as before if the shipped
    runs are not verified for the installed forward model)."""
    from ..response_surface import shipped

    return shipped.ships(settings, grid.depth_mm)


def elastic_core(effects, *, radius_mm: float, max_depth_mm: float, e_star_kPa: float,
                 context: Context | None = None, mesh: str = "coarse"):
    """The elastic force model of a fitted model with these effects (see the module docstring).

    With at most one elastic effect, a surface: the one made for the curve's radius and depth
    range (:func:`curve_grid`) if the package ships it (the demo's two curves), else the
    dimensionless one (:func:`unit_core`) of the smallest of :data:`EFFECT_CEILINGS` at or
    above ``max_depth_mm / radius_mm`` on the coarse mesh, scaled to ``radius_mm`` by exact
    similarity (force x R^2, depths and thicknesses x R: no law has a length scale and the
    mesh is scaled by sqrt(R h_max)), with E bounds from ``e_star_kPa``; deeper than the
    largest ceiling, or on another mesh, the surface is made for the curve.

    With more than one elastic effect (two layers, layer and stiffening...) no surface
    combines them: the core is then a :class:`~skin_indent.models.fe_core.FECore`, the
    finite-element model in the loop, whose runs are kept in the run cache of the
    context's cache folder (:class:`~skin_indent.response_surface.RunCache`).
    """
    elastic = [e for e in instances(effects) if e.stage == ELASTIC]
    context = context_of(context)
    kw = context.build_options()
    if len(elastic) > 1:  # no surface combines them: the finite-element model in the loop

        return FECore(elastic, radius_mm=radius_mm, max_depth_mm=max_depth_mm, e_star_kPa=e_star_kPa, mesh=mesh,
                      workers=context.workers, run_cache=RunCache(context.cache_dir))
    ceiling = ceiling_for(radius_mm, max_depth_mm) if mesh == "coarse" else None
    E = curve_grid(e_star_kPa, max_depth_mm, EFFECT_NU).E_kPa
    if not elastic:
        grid = curve_grid(e_star_kPa, BASE_REACH * max_depth_mm, BASE_NU)
        settings = default_settings(radius_mm=radius_mm, mesh=mesh)
        if ceiling is None or _shipped_for_curve(grid, settings):
            return ResponseSurface.load_or_build(grid, settings, **kw)
        return scaled_surface(unit_core((), ceiling, context=context, mesh=mesh), float(radius_mm), E)

    e = elastic[0]
    grid = curve_grid(e_star_kPa, max_depth_mm, EFFECT_NU)
    axes = tuple(e.surface_axes(grid.depth_mm[-1]))
    if ceiling is None or _shipped_for_curve(grid, EffectSurface.node_settings((e.name,), axes, radius_mm, mesh)):
        return EffectSurface.build((e.name,), axes, grid, radius_mm=radius_mm, mesh=mesh, **kw)
    return unit_core((e.name,), ceiling, context=context, mesh=mesh).at_radius(radius_mm, E_kPa=E)


def interpolation_flags(model, x) -> list[str]:
    """Flags of the effect surfaces of ``model`` (a fitted model: one curve's, or a joint one's
    parts) that interpolate its parameters ``x`` less accurately than :data:`MODEL_ERROR`, the
    model error the fits allow: :meth:`EffectSurface.interpolation_error` over the depths the
    curve reaches (from a tenth of the deepest). A surface of the neo-Hookean half-space is
    not checked (its interpolation is within 1e-4, :mod:`skin_indent.response_surface`).
    """
    x = np.asarray(x, dtype=float)
    parts = getattr(model, "parts", None)
    pieces = [(p, x[model.index(k)]) for k, p in enumerate(parts)] if parts is not None else [(model, x)]
    flags = []
    for part, theta in pieces:
        core = part.core
        if not isinstance(core, EffectSurface):
            continue
        h = part.evaluate(theta).h_mm
        h = h[h >= 0.1 * h.max()] if h.size and h.max() > 0 else h[:0]
        if not h.size:
            continue
        error = core.interpolation_error(h, theta[: len(core.parameter_names)])
        if error > MODEL_ERROR:
            flags.append(f"the {core.name} surface (R = {core.radius_mm:g} mm) interpolates the fitted parameters to "
                         f"about {error:.1%} "
                         f"(its cubic and quadratic splines between the finite-element runs differ by that much; "
                         f"the fit allows {MODEL_ERROR:.1%} for the model): the values are approximate")
    return flags

