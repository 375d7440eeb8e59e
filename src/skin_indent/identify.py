"""The user's path from a measured curve to material parameters.

:func:`identify` takes a :class:`~skin_indent.measurement.Measurement` and a response
surface, keeps the loading segment inside a depth window, starts from a Hertz
estimate (or given values) and runs one of the inversion methods of
:mod:`skin_indent.inverse`. :func:`surface_for` finds (or builds and caches) the
response surface that covers a measurement.

Real instrument curves (AFM, nanoindenters: contact well past depth 0, a force
baseline, approach/hold/retract) go through :func:`skin_indent.fit_recorded.fit_curve`.
"""

from __future__ import annotations

import math

import numpy as np

from .analytic import hertz_force
from .measurement import Measurement, MeasurementError
from .response_surface import ResponseSurface, SurfaceGrid, default_settings

METHODS = ("ekf-paper", "ekf", "lsq")
#: The paper's in vivo stop rule and window.
PAPER_TOLERANCE = 1e-5


def parse_window(text: str) -> tuple[float, float]:
    """``"0.05:0.6"`` -> (0.05, 0.6) mm, with a one-line error for anything else."""
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise ValueError(f"window must be MIN:MAX in mm (e.g. 0.05:0.6), got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise ValueError(f"window must satisfy 0 <= MIN < MAX, got {text!r}")
    return lo, hi


def fitting_data(measurement: Measurement, window: tuple[float, float] | None = None) -> Measurement:
    """The strictly increasing loading segment, restricted to ``window`` (mm).

    A curve with a ``time_s`` column is split into segments and its approach is
    used (depth jitter within it dropped, as :meth:`Measurement.loading` records). A
    curve without time must be a loading curve: its depths must increase, or it is
    rejected (a decreasing depth there is a malformed file, not jitter).
    """
    if measurement.has_time:
        data = measurement.loading().require_monotone_loading()
    else:
        data = measurement.require_monotone_loading()
    lo = 0.0 if window is None else window[0]
    hi = np.inf if window is None else window[1]
    # depths <= 0 (the contact row h = 0, F = 0) say nothing about the material
    return data.window(max(lo, np.nextafter(0.0, 1.0)), hi)


def hertz_modulus(depth_mm, force_mN, radius_mm: float) -> float:
    """Reduced modulus E* = E / (1 - nu^2) (kPa) of the least-squares Hertz fit through the origin."""
    shape = hertz_force(depth_mm, 1.0, 0.0, radius_mm)  # 4/3 sqrt(R) h^1.5
    denom = float(shape @ shape)
    if denom <= 0:
        raise ValueError("cannot estimate a modulus: all depths are <= 0")
    with np.errstate(over="ignore", invalid="ignore"):
        e_star = float(shape @ np.asarray(force_mN)) / denom
    if not e_star > 0:
        raise ValueError("cannot estimate a modulus: the force does not increase with depth")
    return e_star


def start_values(surface, depth_mm, force_mN, radius_mm: float, nu: float = 0.4) -> np.ndarray:
    """Hertz first guess (E, nu) clipped into the surface's box."""
    lo, hi = surface.bounds
    nu = float(np.clip(nu, lo[1], hi[1]))
    E = hertz_modulus(depth_mm, force_mN, radius_mm) * (1 - nu**2)
    return np.array([float(np.clip(E, lo[0], hi[0])), nu])


def default_grid(max_depth_mm: float, n_depth: int = 100) -> SurfaceGrid:
    """The paper's grid (8 E x 6 nu) reaching at least ``max_depth_mm`` (0.6 mm or more)."""
    depth = max(0.6, math.ceil(max_depth_mm / 0.05 - 1e-9) * 0.05)
    return SurfaceGrid.paper(depth_max_mm=depth, n_depth=n_depth)


#: Depth ceilings h/R of the unit-radius surfaces that :func:`surface_for` reuses for
#: every radius (the mesh is designed for the ceiling: the smallest one that covers
#: the data keeps the contact region finely resolved).
SIMILARITY_RATIOS = (0.1, 0.2, 0.5)


def unit_surface_grid(depth_ratio_max: float, n_depth: int = 100) -> SurfaceGrid:
    """The unit-radius grid (R = 1 mm, depths = h/R) of :meth:`SurfaceGrid.unit_radius`."""
    return SurfaceGrid.unit_radius(depth_ratio_max, n_depth)


def surface_for(radius_mm: float, max_depth_mm: float, *, grid: SurfaceGrid | None = None, path=None,
                cache_dir=None, workers=None, progress: bool = True, client=None,
                scheduler: str | None = None, mesh: str = "medium") -> ResponseSurface:
    """Load or build the neo-Hookean response surface for a sphere and depth range.

    Without ``grid`` and ``path``, and for ``max_depth_mm / radius_mm <= 0.5``, one
    unit-radius surface (R = 1 mm, depths h/R up to the smallest of
    :data:`SIMILARITY_RATIOS` that covers the data) is loaded or built once and
    scaled to ``radius_mm`` by the exact similarity F = E R^2 phi(h/R, nu)
    (:meth:`ResponseSurface.at_radius`): skin (R = 6 mm) and AFM (R = 20 um) curves
    share it. With ``grid`` (or ``path``), or deeper than h/R = 0.5, the surface is
    built for this radius directly, as before.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R (mm).
    max_depth_mm : float
        Deepest indentation depth to cover (mm).
    grid : SurfaceGrid, optional
        Explicit grid at this radius (default: the similarity path above).
    path, cache_dir, workers, progress : optional
        As in :meth:`ResponseSurface.load_or_build`.
    client, scheduler : optional
        ``client`` (a ``dask.distributed.Client``) or ``scheduler``
        (``"tcp://HOST:PORT"``) run the finite-element runs on a Dask cluster; by
        default local processes.
    mesh : str
        Mesh preset of the finite-element runs (``"coarse"``, ``"medium"``, ``"fine"``).
    """
    kw = dict(cache_dir=cache_dir, workers=workers, progress=progress, client=client, scheduler=scheduler)
    ratio = float(max_depth_mm) / float(radius_mm)
    ceiling = next((r for r in SIMILARITY_RATIOS if ratio <= r * (1 + 1e-9)), None)
    if grid is None and path is None and ceiling is not None:
        unit = ResponseSurface.load_or_build(unit_surface_grid(ceiling), default_settings(1.0, mesh=mesh), **kw)
        return unit.at_radius(radius_mm)
    grid = grid or default_grid(max_depth_mm)
    settings = default_settings(radius_mm=radius_mm, mesh=mesh)
    return ResponseSurface.load_or_build(grid, settings, path=path, **kw)


def check_inside(surface, depth_mm) -> None:
    """One-line error when measured depths lie beyond the surface."""
    lo, hi = surface.depth_range
    if np.max(depth_mm) > hi * (1 + 1e-9):
        origin = getattr(surface, "settings", {}).get("similarity")
        scaled = (f" (a surface for R = {origin['radius_mm']:g} mm scaled to R = {surface.settings['radius_mm']:g} mm)"
                  if origin else "")
        raise ValueError(f"measured depth reaches {np.max(depth_mm):.4g} mm, beyond the surface's {hi:.4g} mm"
                         f"{scaled}: build a deeper surface (skin-indent surface build --depth ...) or narrow --window")


def identify(data: Measurement, surface, method: str = "lsq", *, x0=None, fixed=None, tol: float | None = None,
             radius_mm: float | None = None, noise_mN: float | None = None):
    """Identify (E, nu) from a loading curve with a response surface.

    Parameters
    ----------
    data : Measurement
        Increasing loading data (see :func:`fitting_data`), mm and mN.
    surface : ResponseSurface
        The forward model (``force``/``jacobian`` over (E_kPa, nu)).
    method : {"ekf-paper", "ekf", "lsq"}
        The paper's filter with global stabilisation, the better-conditioned filter,
        or least squares.
    x0 : array_like, optional
        Start (E_kPa, nu); default a Hertz estimate at nu = 0.4.
    fixed : dict, optional
        Parameters held fixed, e.g. ``{"nu": 0.5}``.
    tol : float, optional
        Stop rule C of the filters (default 1e-6 as in the paper's blind tests).
    radius_mm : float, optional
        Sphere radius for the Hertz start (default the surface's).
    noise_mN : float, optional
        Noise level; default estimated from the data.

    Returns
    -------
    skin_indent.inverse.IdentificationResult
    """
    from . import inverse

    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if data.n_points < 3:
        raise MeasurementError(f"{data.source}: fewer than 3 points to fit")
    check_inside(surface, data.depth_mm)
    if fixed:
        check_fixed(dict(fixed), surface)
    radius = radius_mm or float(surface.settings.get("radius_mm", 6.22))
    e_star = hertz_modulus(data.depth_mm, data.force_mN, radius)
    lo, hi = surface.bounds
    if not (np.isfinite(e_star) and lo[0] / 3 <= e_star * (1 - 0.4**2) <= 3 * hi[0]):
        raise ValueError(f"the data need E ~ {e_star * (1 - 0.4**2):.3g} kPa (Hertz estimate), far outside the "
                         f"surface's {lo[0]:g}-{hi[0]:g} kPa: build a surface that covers it (surface build --E)")
    if x0 is None:
        x0 = start_values(surface, data.depth_mm, data.force_mN, radius)
    kwargs = {"fixed": fixed}
    if method == "lsq":
        return inverse.fit_least_squares(surface, data.depth_mm, data.force_mN, x0, noise_mN=noise_mN, **kwargs)
    if tol is not None:
        kwargs["tol"] = tol
    if method == "ekf":
        return inverse.fit_ekf(surface, data.depth_mm, data.force_mN, x0, noise_mN=noise_mN, **kwargs)
    return inverse.fit_ekf_paper(surface, data.depth_mm, data.force_mN, x0, **kwargs)


class ShiftedModel:
    """A force model whose contact point is a parameter: F_rec(d) = F(d - offset_mm).

    The recorded depth ``d`` starts at an arbitrary zero; contact begins at the
    recorded depth ``offset_mm`` (a nuisance parameter, the ``offset`` effect), and
    the force is zero before it. Implements the :class:`skin_indent.inverse.ForceModel`
    protocol around any model that does (e.g. a :class:`ResponseSurface`), with the
    depth derivative needed for the offset column of the Jacobian taken by central
    differences of the model in depth (the surface is smooth in depth).

    Parameters
    ----------
    model : ForceModel
        Force as a function of the true depth h > 0 (mm).
    offset_bounds_mm : (float, float)
        Admissible offsets, mm.
    """

    def __init__(self, model, offset_bounds_mm: tuple[float, float]):
        self.model = model
        self.parameter_names = tuple(model.parameter_names) + ("offset_mm",)
        lo, hi = (np.asarray(b, dtype=float) for b in model.bounds)
        self.bounds = (np.r_[lo, offset_bounds_mm[0]], np.r_[hi, offset_bounds_mm[1]])
        self.depth_range = getattr(model, "depth_range", (0.0, np.inf))

    def _split(self, depth_mm, theta):
        theta = np.asarray(theta, dtype=float)
        h = np.asarray(depth_mm, dtype=float) - theta[-1]
        if np.any(h > self.depth_range[1] * (1 + 1e-12)):
            raise ValueError(f"depth minus offset reaches {h.max():.4g} mm, beyond the model's "
                             f"{self.depth_range[1]:.4g} mm")
        return h, h > 0, theta[:-1]

    def force(self, depth_mm, theta) -> np.ndarray:
        h, touching, inner = self._split(depth_mm, theta)
        out = np.zeros_like(h)
        if np.any(touching):
            out[touching] = self.model.force(h[touching], inner)
        return out

    def jacobian(self, depth_mm, theta) -> np.ndarray:
        h, touching, inner = self._split(depth_mm, theta)
        J = np.zeros((h.size, len(self.parameter_names)))
        if np.any(touching):
            ht = h[touching]
            J[touching, :-1] = self.model.jacobian(ht, inner)
            step = 1e-4 * self.depth_range[1] if np.isfinite(self.depth_range[1]) else 1e-6
            up = np.minimum(ht + step, self.depth_range[1])
            down = np.maximum(ht - step, 0.5 * ht)
            J[touching, -1] = -(self.model.force(up, inner) - self.model.force(down, inner)) / (up - down)
        return J


# ---------------------------------------------------------------- real instrument curves

#: ``--fix`` names and the model parameter each one sets.
FIX_ALIASES = {"E_kPa": "E_kPa", "E": "E_kPa", "nu": "nu", "contact_point_mm": "offset_mm",
               "offset_mm": "offset_mm"}
CONTACT_MODES = ("auto", "fit", "origin")
#: The nu the finite-element surfaces offer for "incompressible" (the law needs nu < 0.5).
NEARLY_INCOMPRESSIBLE_NU = 0.499


def parse_fix(items) -> dict[str, float]:
    """``["nu=0.499", "E_kPa=3"]`` -> ``{"nu": 0.499, "E_kPa": 3.0}`` (model names), one-line errors.

    Accepted names: ``E_kPa`` (or ``E``), ``nu``, ``contact_point_mm`` (or ``offset_mm``,
    the recorded depth of contact, mm).
    """
    out: dict[str, float] = {}
    for item in items or ():
        name, sep, value = str(item).partition("=")
        name = name.strip()
        if not sep or name not in FIX_ALIASES:
            raise ValueError(f"--fix must be NAME=VALUE with NAME one of {', '.join(FIX_ALIASES)}, got {item!r}")
        try:
            number = float(value)
        except ValueError:
            raise ValueError(f"--fix {name}: {value!r} is not a number") from None
        if not math.isfinite(number):
            raise ValueError(f"--fix {name}: the value must be finite, got {value!r}")
        out[FIX_ALIASES[name]] = number
    return out


def check_fixed(fixed: dict, surface) -> None:
    """One-line errors for fixed values the model cannot take (nu = 0.5 above all)."""
    lo, hi = surface.bounds
    nu = fixed.get("nu")
    if nu is not None and nu >= 0.5:
        raise ValueError(f"nu = {nu:g} (incompressible) is outside the finite-element law, which is compressible "
                         f"(nu < 0.5): fix nu={NEARLY_INCOMPRESSIBLE_NU} instead (E/(1-nu^2) changes by 0.13%)")
    for k, name in enumerate(("E_kPa", "nu")):
        v = fixed.get(name)
        if v is not None and not lo[k] * (1 - 1e-9) <= v <= hi[k] * (1 + 1e-9):
            raise ValueError(f"fixed {name} = {v:g} is outside the response surface [{lo[k]:g}, {hi[k]:g}]")
