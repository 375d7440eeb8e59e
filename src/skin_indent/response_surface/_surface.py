"""The ResponseSurface: build, cache, store, rescale; its interpolation is :mod:`._interpolation`."""

from __future__ import annotations

import json
import logging
import os
import zipfile
from pathlib import Path
from typing import Mapping

import numpy as np

from ..runtime.executors import Executor
from ._cache import UnitCurve, canonical_json, default_cache_dir, resolve_model, settings_hash
from ._core import SurfaceCore
from ._file import load_surface, save_surface
from ._grid import SurfaceGrid
from ._interpolation import _RTOL_BOUNDS, DEPTH_INTERPS, METHODS, SCALINGS, Interpolant, NodeForces, _check_choice
from ._runs import surface_columns

log = logging.getLogger(__name__)


def _describe(settings, grid) -> str:
    """``"response surface R = 1 mm, mesh coarse (6 nu x 100 depths)"``: which surface a log line is about."""
    where = "".join(f", {k} {settings[k]}" for k in ("model", "mesh") if isinstance(settings.get(k), str))
    radius = settings.get("radius_mm")
    return (f"response surface{'' if radius is None else f' R = {radius:g} mm'}{where} "
            f"({grid.nu.size} nu x {grid.depth_mm.size} depths)")


class ResponseSurface(SurfaceCore):
    """Force F(h; E, nu) (mN) on a grid, interpolated with analytic parameter gradients.

    Implements the model protocol of :mod:`skin_indent.inverse`: ``parameter_names``,
    ``bounds``, ``force(depth_mm, theta)`` and ``jacobian(depth_mm, theta)`` with
    ``theta = (E_kPa, nu)``.

    Parameters
    ----------
    grid : SurfaceGrid
        Depths (mm), E (kPa) and nu of the nodes.
    unit_forces : array_like, shape (n_depth, n_nu)
        f(h; nu), force (mN) at E = 1 kPa. A column of NaN marks a failed forward run.
    settings : mapping, optional
        JSON-serialisable description of the forward model; hashed with the grid.
    failures : mapping, optional
        ``{nu: reason}`` of the failed runs (their columns must be NaN).
    method : {"lagrange", "spline"}
        Default interpolation in (E, nu). ``"lagrange"``: the paper's bicubic Lagrange
        on the 4 nodes around the interval, in E over the nodal values E_j f(nu) (exact
        in E, since Lagrange reproduces the linear function E); C0 across nodes.
        ``"spline"``: not-a-knot cubic spline in nu (C2), times E.
    depth_interp : {"lagrange", "quartic", "spline"}
        Default interpolation in depth: local 4-point cubic Lagrange (the paper's),
        a global least-squares quartic (the paper's smoother, less exact option), or a
        not-a-knot cubic spline.
    scaling : {"hertz", "h1.5", "none"}
        Shape divided out before interpolating (see the module docstring).
    """

    parameter_names = ("E_kPa", "nu")
    parameter_units = ("kPa", "-")

    def __init__(self, grid, unit_forces, *, settings=None, failures=None,
                 method="lagrange", depth_interp="lagrange", scaling="hertz"):
        if not isinstance(grid, SurfaceGrid):
            raise TypeError(f"grid must be a SurfaceGrid, got {type(grid).__name__}")
        self.grid = grid
        self.settings = json.loads(canonical_json(settings or {}))
        self.method = _check_choice("method", method, METHODS)
        self.depth_interp = _check_choice("depth_interp", depth_interp, DEPTH_INTERPS)
        self.scaling = _check_choice("scaling", scaling, SCALINGS)
        f = np.array(unit_forces, dtype=float)
        n_d, n_e, n_nu = grid.shape
        if f.shape != (n_d, n_nu):
            raise ValueError(f"unit_forces has shape {f.shape}, expected (n_depth, n_nu) = {(n_d, n_nu)}")
        missing = np.all(np.isnan(f), axis=0)
        if not np.all(np.isfinite(f[:, ~missing])):
            raise ValueError("unit_forces: a column must be all finite or all NaN (failed run)")
        failures = {float(k): str(v) for k, v in (failures or {}).items()}
        if not set(failures) <= set(grid.nu[missing].tolist()):
            raise ValueError("failures must name nu values of the grid whose columns are NaN")
        for nu in grid.nu[missing].tolist():
            failures.setdefault(nu, "no data")
        f.flags.writeable = False
        self._f = f
        self._missing = missing
        self.failures = failures
        self.hash = settings_hash(self.settings, grid)
        self._interp = Interpolant(grid, f, missing, failures, scaling)  # its stencils made when first used

    # ------------------------------------------------------------ construction
    def with_options(self, **options) -> "ResponseSurface":
        """A copy with other ``method``, ``depth_interp`` or ``scaling``."""
        kw = {"method": self.method, "depth_interp": self.depth_interp, "scaling": self.scaling, **options}
        return type(self)(self.grid, self._f, settings=self.settings, failures=self.failures, **kw)

    @classmethod
    def build(cls, grid: SurfaceGrid, unit_curve: UnitCurve | None = None, settings: Mapping | None = None,
              cache_dir: str | os.PathLike | None = None, workers: int | None = None,
              progress: bool | None = None, *, client=None, scheduler: str | None = None,
              executor: Executor | None = None, quiet: bool = False, **options) -> "ResponseSurface":
        """Run the unit curve once per nu and assemble the surface.

        Parameters
        ----------
        grid : SurfaceGrid
            Nodes of the surface.
        unit_curve : callable, optional
            ``unit_curve(nu, depth_mm) -> force_mN`` at E = 1 kPa. Default: the FE model
            (:func:`default_unit_curve` of ``settings``). Must be picklable (module-level
            function, or ``functools.partial`` of one) for ``workers > 1``; with Dask,
            anything ``cloudpickle`` serialises, importable on the workers.
        settings : mapping, optional
            Description of the forward model; it keys the cache, so it must change
            whenever the unit curve's results would. Default: :func:`default_settings`
            for the FE curve, else the callable's qualified name and partial arguments.
        cache_dir : path, optional
            If given, each finished run is written at once by this process (whoever
            computed it), atomically, to ``cache_dir/runs/<key>/``, keyed by the
            settings and depths, and listed with its checksum in the directory's
            ``manifest.json`` (see :class:`RunStore`). A rerun (after a crash or a kill
            of this process or a worker) computes only what the manifest does not list
            as done; failed runs are listed with their reason and retried. Several
            processes may build into one cache at once: a run is computed only under its
            lock, after checking that it is not done, so each run is computed once and a
            run that another process computes meanwhile is waited for and read.
            Default: nothing is written.
        workers : int, optional
            Local processes; default ``min(available CPUs, runs to do)``, or 1 if
            ``unit_curve`` cannot be pickled. 1 runs in this process.
        progress : bool or None
            Show a tqdm progress bar (stderr); default None: only when stderr is a terminal
            (:func:`skin_indent.runtime.log.progress_bar`).
        client : dask.distributed.Client, optional
            Run the forward runs on this Dask cluster (needs ``pip install
            'skin_indent[dask]'``); results still come back here and are cached here.
            Every worker needs the same ``skin_indent``: a result computed with other
            forward-model sources than ``settings["code_version"]`` names is refused
            (listed as a failure).
        scheduler : str, optional
            Address of a Dask scheduler (``tcp://HOST:PORT``) to connect to instead.
        executor : Executor, optional
            An executor of :mod:`skin_indent.response_surface` (instead of the above).
        quiet : bool
            No INFO line about the runs to make (a caller that builds several surfaces
            announces them in one line, as an effect surface does).
        **options
            ``method``, ``depth_interp``, ``scaling`` of the returned surface.

        Returns
        -------
        ResponseSurface
            A failed run (``unit_curve`` raised, e.g. ``ConvergenceError``, or returned
            bad values, or its worker died) leaves its column NaN, is listed in
            ``failures`` (and in the manifest) and is reported by a RuntimeWarning.

        Raises
        ------
        ImportError
            ``client`` or ``scheduler`` given without Dask installed.
        OSError
            The Dask scheduler cannot be reached, or the cache cannot be written.
        """
        unit_curve, settings = resolve_model(unit_curve, settings)
        f, failures = surface_columns(grid, unit_curve, settings, _describe(settings, grid), cache_dir=cache_dir,
                                      workers=workers, progress=progress, client=client, scheduler=scheduler,
                                      executor=executor, quiet=quiet)
        return cls(grid, f, settings=settings, failures=failures, **options)

    # ------------------------------------------------------------ persistence
    def save(self, path: str | os.PathLike) -> Path:
        """Write the surface to ``path`` (npz with JSON metadata), atomically."""
        return save_surface(self, path)

    @classmethod
    def load(cls, path: str | os.PathLike, **options) -> "ResponseSurface":
        """Read a surface written by :meth:`save`; checks the stored hash.

        Parameters
        ----------
        path : path
            The npz file.
        **options
            Override the stored ``method``, ``depth_interp``, ``scaling``.
        """
        for name, choices in (("method", METHODS), ("depth_interp", DEPTH_INTERPS), ("scaling", SCALINGS)):
            if name in options:
                _check_choice(name, options[name], choices)
        return load_surface(cls, path, **options)

    @classmethod
    def load_or_build(cls, grid: SurfaceGrid, settings: Mapping | None = None,
                      unit_curve: UnitCurve | None = None, *, path: str | os.PathLike | None = None,
                      cache_dir: str | os.PathLike | None = None, workers: int | None = None,
                      progress: bool | None = None, client=None, scheduler: str | None = None,
                      executor: Executor | None = None, quiet: bool = False, **options) -> "ResponseSurface":
        """Reuse a stored surface if its hash matches ``settings`` and ``grid``, else build.

        A stored surface with failed runs is rebuilt (finished runs are reused from the
        run cache, failed ones retried). Forward runs depend only on the settings, the
        depths and nu, so changing the E grid or adding nu values reuses earlier runs.

        Parameters
        ----------
        grid, settings, unit_curve, workers, progress, client, scheduler, executor, quiet, **options
            As in :meth:`build` (``settings`` default as there).
        path : path, optional
            Surface file; default ``cache_dir/surfaces/<hash>.npz``.
        cache_dir : path, optional
            Root of the run cache; default :func:`default_cache_dir`.
        """
        unit_curve, settings = resolve_model(unit_curve, settings)
        cache_dir = default_cache_dir() if cache_dir is None else Path(cache_dir)
        key = settings_hash(settings, grid)
        path = cache_dir / "surfaces" / f"{key[:24]}.npz" if path is None else Path(path)
        if path.exists():
            try:
                stored = cls.load(path, **options)
            except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile):  # unreadable: rebuild
                stored = None
            if stored is not None and stored.hash == key and stored.complete:
                log.debug("response surface %s loaded from %s", key[:12], path)
                return stored
        out = cls.build(grid, unit_curve, settings, cache_dir=cache_dir, workers=workers, progress=progress,
                        client=client, scheduler=scheduler, executor=executor, quiet=quiet, **options)
        out.save(path)
        return out

    def at_radius(self, radius_mm: float) -> "ResponseSurface":
        """The same surface for another sphere radius, by exact similarity.

        For the neo-Hookean half-space F(h; E, R, nu) = E R^2 phi(h/R, nu): the law
        has no length scale and the finite-element mesh is scaled by sqrt(R h_max),
        so a curve at radius R0 maps to radius R by depth x k and force x k^2 with
        k = R / R0 (checked against direct runs to ~1e-9). The interpolation is
        affine-invariant in depth, so the scaled surface interpolates exactly as the
        original. Depths of the returned surface reach ``k x`` the original's.

        Parameters
        ----------
        radius_mm : float
            Sphere radius R (mm), > 0.

        Returns
        -------
        ResponseSurface
            ``self`` if the radius is the same; else a new surface whose settings
            record ``radius_mm`` and, under ``"similarity"``, the source radius and hash.

        Raises
        ------
        ValueError
            If the surface does not record its radius or is not a homogeneous
            neo-Hookean half-space (layers, custom unit curves: no similarity).
        """
        R = float(radius_mm)
        if not (np.isfinite(R) and R > 0):
            raise ValueError(f"radius must be a finite number > 0 mm, got {radius_mm}")
        R0 = self.settings.get("radius_mm")
        if R0 is None or self.settings.get("model") != "neo-hooke half-space":
            raise ValueError("this surface cannot be rescaled to another radius: only a neo-Hookean half-space "
                             "surface that records its radius_mm is self-similar")
        R0 = float(R0)
        if abs(R / R0 - 1) <= _RTOL_BOUNDS:
            return self
        k = R / R0
        origin = self.settings.get("similarity", {"radius_mm": R0, "hash": self.hash})
        settings = {**self.settings, "radius_mm": R, "similarity": origin}
        kw = {"method": self.method, "depth_interp": self.depth_interp, "scaling": self.scaling}
        return type(self)(self.grid.scaled_depths(k), self._f * k**2, settings=settings, failures=self.failures,
                          **kw)

    # ------------------------------------------------------------ properties
    @property
    def unit_forces(self) -> np.ndarray:
        """f(h; nu), force (mN) at E = 1 kPa, shape (n_depth, n_nu); NaN = failed run."""
        return self._f

    @property
    def forces(self) -> np.ndarray:
        """F = E f at the nodes (mN), shape (n_depth, n_E, n_nu)."""
        return self._f[:, None, :] * self.grid.E_kPa[None, :, None]

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` of ``(E_kPa, nu)``, the grid box."""
        g = self.grid
        return np.array([g.E_kPa[0], g.nu[0]]), np.array([g.E_kPa[-1], g.nu[-1]])

    @property
    def depth_range(self) -> tuple[float, float]:
        """Valid depths (mm): ``0 < h <= depth_range[1]``; with ``scaling="none"``,
        ``depth_range[0] <= h <= depth_range[1]`` (the nodes' span)."""
        return self._interp.depth_range

    @property
    def complete(self) -> bool:
        """True if no forward run failed."""
        return not self._missing.any()

    def __repr__(self):
        g = self.grid
        return (f"ResponseSurface({g.depth_mm.size} depths {g.depth_mm[0]:g}-{g.depth_mm[-1]:g} mm x "
                f"{g.E_kPa.size} E {g.E_kPa[0]:g}-{g.E_kPa[-1]:g} kPa x {g.nu.size} nu "
                f"{g.nu[0]:g}-{g.nu[-1]:g}, {len(self.failures)} failed, hash {self.hash[:12]})")

    # ------------------------------------------------------------ evaluation
    def evaluate(self, depth_mm, theta, *, method: str | None = None, depth_interp: str | None = None,
                 extrapolate: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Force and its gradient in one call (what an EKF step needs).

        Parameters
        ----------
        depth_mm : array_like
            Depths h (mm) within :attr:`depth_range`. Below the first node the smooth
            scaled variable is extrapolated (not allowed with ``scaling="none"``).
        theta : array_like, shape (2,)
            ``(E_kPa, nu)``.
        method, depth_interp : str, optional
            Override the surface defaults.
        extrapolate : bool
            Allow (E, nu) outside the grid box (end stencils are extended) and depths
            beyond the last node; depths <= 0 then give zero force and gradient.

        Returns
        -------
        force : numpy.ndarray, shape of ``depth_mm``
            F (mN).
        jacobian : numpy.ndarray, shape ``depth_mm.shape + (2,)``
            dF/dE (mN/kPa) and dF/dnu (mN).

        Raises
        ------
        ValueError
            A parameter or depth outside the surface, or an interpolation that needs
            the column of a failed run.
        """
        method = self.method if method is None else _check_choice("method", method, METHODS)
        depth_interp = self.depth_interp if depth_interp is None else _check_choice(
            "depth_interp", depth_interp, DEPTH_INTERPS)
        return self._interp.evaluate(depth_mm, theta, method, depth_interp, extrapolate)

    def node_unit_forces(self, depth_mm) -> np.ndarray:
        """f(h; nu_j) at every nu node of the grid (mN at E = 1 kPa): each run interpolated in depth only.

        What :meth:`evaluate` gives at a nu node, for all of them at once (to rounding); see
        :class:`NodeForces` for several surfaces on one grid.

        Parameters
        ----------
        depth_mm : array_like
            Depths h (mm), 0 < h <= the last depth node (with ``scaling="none"``, within the nodes).

        Returns
        -------
        numpy.ndarray, shape ``(n_nu,) + depth_mm.shape``
            NaN in the columns of failed runs.
        """
        return NodeForces([self])(depth_mm)[0]

    def force(self, depth_mm, theta, method: str | None = None, **kwargs) -> np.ndarray:
        """Interpolated force F(h; E, nu) (mN); arguments as in :meth:`evaluate`."""
        return self.evaluate(depth_mm, theta, method=method, **kwargs)[0]

    __call__ = force

    def jacobian(self, depth_mm, theta, method: str | None = None, **kwargs) -> np.ndarray:
        """``[dF/dE (mN/kPa), dF/dnu (mN)]``, shape ``(n_depth, 2)``; as in :meth:`evaluate`."""
        return self.evaluate(depth_mm, theta, method=method, **kwargs)[1]
