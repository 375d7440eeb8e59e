"""Many curves at a time: every curve of every file, fitted in parallel, one row each.

:func:`fit_many` expands folders and files, reads every curve (all curves of a force
map, or one ``index``), prepares each one (:func:`skin_indent.measurement.prepare`),
loads or builds the response surfaces they need once in this process, then fits the
curves with :func:`skin_indent.fitting.fit` on the local cores or a Dask cluster with a
progress bar (:func:`skin_indent.runtime.batch.run_tasks`, as a batch of diagnoses: each worker
works on one core, with one BLAS thread). A file that cannot be read, or a curve that cannot be
fitted, is one :class:`BatchRow` with its one-line ``error``: never the end of the batch (the
files and curves are read by :mod:`skin_indent.measurement.curve_files`).

:func:`skin_indent.report.batch_table.write_tsv` writes the rows as a table (one line per curve,
a provenance header), :func:`skin_indent.report.batch_table.summary_figure` a figure of E per
curve and, for force maps, E over the map.

Surfaces
--------
Curves are grouped by sphere radius and by the depth ceiling h/R of the unit-radius
surface that :func:`skin_indent.fitting.surface_for` picks for them (0.1, 0.2 or 0.5;
deeper curves get one surface per radius, built for the deepest). The depth each curve
needs is the one :func:`skin_indent.fitting.fit` asks for (its deepest indentation, plus
half of it where the contact point is fitted, as room for it to move earlier). So each
curve is fitted on the very surface a single :func:`~skin_indent.fitting.fit` would
use, and at most three unit surfaces per mesh are built for any number of radii.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from .fitting.one_fit import fit, paper_identification, paper_needed
from .fitting.model_fit import parse_model, prepare_curve
from .fitting.surfaces import SIMILARITY_RATIOS, surface_for
from .measurement import prepare
from .measurement.curve_files import READABLE_SUFFIXES, CurveLocation, expand_paths, read_curves
from .report.fit_figure import plot_fit, write_fit_csv
from .runtime.batch import BatchRows, one_line, row_provenance, run_tasks
from .runtime.context import context_of
from .runtime.json_io import jsonable
from .runtime.provenance import provenance as make_provenance

__all__ = ["BatchResult", "BatchRow", "READABLE_SUFFIXES", "TSV_COLUMNS", "expand_paths", "fit_many"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchRow(CurveLocation):
    """The result of one curve of a batch (or the error of a file that gave no curve).

    Attributes
    ----------
    file, index, grid_x, grid_y, x_mm, y_mm
        Where the curve comes from (:class:`~skin_indent.measurement.curve_files.CurveLocation`:
        the file, the curve in it from 0, a force map's grid indices and position in mm).
    radius_mm : float
        Sphere radius (mm).
    E_kPa, E_std_kPa : float
        Young's modulus of the large-strain neo-Hookean fit and its standard error (kPa).
    E_star_kPa : float
        E* = E / (1 - nu^2) (kPa).
    nu : float
        Poisson's ratio (fitted or fixed).
    hertz_E_star_kPa : float
        E* of Hertz's fit of the same points (kPa).
    contact_point_mm : float
        Contact point, recorded depth (mm).
    baseline_mN : float
        Pre-contact force baseline subtracted, at the contact guess (mN; 0: none).
    fit_from_mm, fit_to_mm : float
        Recorded depths of the first and last fitted points (mm).
    max_indentation_mm : float
        Deepest indentation past the contact point (mm).
    n_points : int
        Points fitted.
    rms_mN, noise_mN : float
        RMS residual and the noise level independent of the model (mN).
    misfit : float
        RMS / noise.
    white : bool or None
        Residual white (no structure left).
    verdict : str
        The fit's quality in words.
    flags : tuple of str
        Why the numbers may not be trusted (a parameter at a bound, a misfit far above
        the noise); empty when there is no such reason.
    error : str
        One-line error when the file or the curve could not be read, prepared or
        fitted (the numbers are then NaN); empty otherwise.
    surface : str
        Hash of the response surface used (the one of the unit-radius surface for a
        rescaled one).
    model : str
        The model fitted (``neo-hooke``, or with ``+effect`` per effect).
    parameters, std : dict
        Every parameter of the model and its standard deviation (held ones without); the
        table gets a column ``NAME`` and ``NAME_sd`` for each beyond E_kPa and nu.
    fit : FitResult or None
        The whole fit, kept only when asked for (``fit_many(..., keep_fits=True)``).
    """

    radius_mm: float = math.nan
    E_kPa: float = math.nan
    E_std_kPa: float = math.nan
    E_star_kPa: float = math.nan
    nu: float = math.nan
    hertz_E_star_kPa: float = math.nan
    contact_point_mm: float = math.nan
    baseline_mN: float = math.nan
    fit_from_mm: float = math.nan
    fit_to_mm: float = math.nan
    max_indentation_mm: float = math.nan
    n_points: int = 0
    rms_mN: float = math.nan
    noise_mN: float = math.nan
    misfit: float = math.nan
    white: bool | None = None
    verdict: str = ""
    flags: tuple = ()
    error: str = ""
    surface: str = ""
    model: str = "neo-hooke"
    parameters: dict = field(default_factory=dict, compare=False)
    std: dict = field(default_factory=dict, compare=False)
    fit: object = field(default=None, repr=False, compare=False)

    #: parameters with a column of their own (the table gets ``NAME`` and ``NAME_sd`` for the others)
    own_parameters = ("E_kPa", "nu", "offset_mm")

    @property
    def trusted(self) -> bool:
        """No error and no flag: the numbers can be used as they are."""
        return not self.error and not self.flags

    def to_dict(self) -> dict:
        """The row as a JSON-safe dict (without ``fit``)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "fit"}
        out["flags"] = list(self.flags)
        out["parameters"], out["std"] = dict(self.parameters), dict(self.std)
        return jsonable(out)


#: the columns of :func:`~skin_indent.report.batch_table.write_tsv`, in order (then ``NAME``, ``NAME_sd`` for each parameter of the
#: models beyond E_kPa and nu)
TSV_COLUMNS = tuple(f.name for f in fields(BatchRow) if f.name not in ("fit", "parameters", "std"))


class BatchResult(BatchRows):
    """The rows of :func:`fit_many` (a list of :class:`BatchRow`, in file and curve order).

    Attributes
    ----------
    provenance : dict
        How they were made (:func:`skin_indent.runtime.provenance.provenance`): the inputs with
        their sha256, the settings and the surfaces.
    surfaces : list
        The response surfaces used.
    """

    #: the columns of :func:`~skin_indent.report.batch_table.write_tsv`
    columns = TSV_COLUMNS


# ------------------------------------------------------------------ helpers
def _needed_depth(prepared) -> float:
    """The depth :func:`skin_indent.fitting.fit` asks of a surface for this curve (mm)."""
    depth = prepared.max_indentation_mm
    if prepared.contact_mode == "fit":
        depth = max(depth, min(1.5 * depth, SIMILARITY_RATIOS[-1] * prepared.radius_mm))
    return depth


def _surface_key(radius_mm: float, depth_mm: float):
    ratio = depth_mm / radius_mm
    return radius_mm, next((r for r in SIMILARITY_RATIOS if ratio <= r * (1 + 1e-9)), None)


def _surface_hash(surface) -> str:
    origin = (getattr(surface, "settings", None) or {}).get("similarity")
    return str(origin["hash"]) if origin and "hash" in origin else str(getattr(surface, "hash", ""))


def _fit_task(context, prepared, surface, method, fixed, tol, x0=None, model=None, priors=None, mesh=None,
              free=()):
    """One fit in a worker (:func:`~skin_indent.runtime.batch.run_tasks`; ``context`` is the worker's):
    ``(FitResult, None)`` or ``(None, one-line error)`` (nothing raised). The fitted force model
    (``bound_model``: its surfaces, megabytes) stays in the worker; the row and a kept fit need its numbers."""
    try:
        if model is not None:
            result = fit(prepared, model=model, fixed=dict(fixed), priors=priors, context=context, mesh=mesh, free=free)
        else:
            result = fit(prepared, surface, method, fixed=dict(fixed), tol=tol, x0=x0, free=free)
        return dataclasses.replace(result, bound_model=None), None
    except Exception as err:  # noqa: BLE001 - one row with the error, never the end of the batch
        return None, one_line(err)


def _row_of(base: dict, result, surface) -> BatchRow:
    p = result.data
    q = result.quality or {}
    return BatchRow(
        **base, radius_mm=result.radius_mm, E_kPa=result.parameters["E_kPa"],
        E_std_kPa=result.std.get("E_kPa", math.nan), E_star_kPa=result.e_star_kPa, nu=result.parameters["nu"],
        hertz_E_star_kPa=result.hertz.get("E_star_kPa", math.nan), contact_point_mm=result.contact_point_mm,
        baseline_mN=p.baseline_mN, fit_from_mm=float(np.min(p.depth_mm)), fit_to_mm=float(np.max(p.depth_mm)),
        max_indentation_mm=float(np.max(p.depth_mm) - result.contact_point_mm), n_points=int(result.n_points),
        rms_mN=result.rms_mN, noise_mN=q.get("noise_mN", math.nan), misfit=q.get("misfit", math.nan),
        white=q.get("white"), verdict=q.get("verdict", ""),
        flags=tuple(result.flags),  # how the fit ended among them (fitting.ended: budget, start, edge, bound)
        surface=_surface_hash(surface) if surface is not None else "", model=result.model,
        parameters=dict(result.parameters), std=dict(result.std))


def _prepared_rows(files, *, index, radius_mm, prepare_one, model=None) -> list:
    """Every curve of ``files`` read and prepared here: a :class:`BatchRow` with its error, or
    ``(location keywords, prepared curve)`` waiting for its fit."""
    extra = {} if model is None else {"model": model}
    rows: list = []
    for where, m, error in read_curves(files, index=index, radius_mm=radius_mm):
        if error is None:
            try:
                rows.append((where.location, prepare_one(m)))
                continue
            except Exception as err:  # noqa: BLE001 - a curve that cannot be prepared is one row
                error = one_line(err)
        rows.append(BatchRow(**where.location, error=error, **extra))
    return rows


# ------------------------------------------------------------------ fit_many
def fit_many(paths, *, index: int | None = None, radius_mm: float | None = None, window=None,
             contact: str = "auto", fixed: dict | None = None, method: str = "lsq", mesh: str | None = None,
             context=None, progress: bool | None = None, surface=None, tol: float | None = None, x0=None,
             keep_fits: bool = False, plot_dir=None, command=None, model=None, priors=None, free=(),
             recursive: bool = False) -> BatchResult:
    """Fit every curve of every file, in parallel; one :class:`BatchRow` per curve.

    Parameters
    ----------
    paths : path or iterable of paths
        Files and folders (:func:`expand_paths`): CSV, Chiaro ``.txt`` and, with
        afmformats, JPK ``.jpk-force``/``.jpk-force-map`` and the other instrument
        formats (:func:`skin_indent.measurement.load_curves`).
    index : int, optional
        Fit only this curve of each file (from 0); default every curve (all curves of
        a force map).
    radius_mm : float, optional
        Sphere radius (mm) of every curve; default each file's own (a CSV radius
        comment, the Chiaro header), else the skin default 6.22 mm.
    window : (float, float), optional
        Indentation depths past the contact point (mm).
    contact : {"auto", "fit", "origin"}
        Contact point (:func:`skin_indent.measurement.prepare`).
    fixed : dict, optional
        Parameters held fixed: ``E_kPa``, ``nu``, ``offset_mm`` (the contact point,
        recorded depth in mm; ``contact_point_mm`` is taken as the same). Default as
        :func:`skin_indent.fitting.fit`: nu = 0.5 for AFM-scale curves (radius < 0.5 mm).
    free : sequence of str
        ``("nu",)``: fit nu where the scale's default holds it (AFM scale).
    recursive : bool
        Search folders' subfolders too (:func:`expand_paths`).
    method : {"lsq", "ekf", "ekf-paper"}
    mesh : str, optional
        Mesh preset of surfaces that have to be built (``"coarse"``, ``"medium"``, ``"fine"``;
        default ``"medium"``, with a ``model`` ``"coarse"`` as the diagnosis).
    context : Context, optional
        Surface cache, and where the fits run: ``workers`` local processes (default: the
        available cores, at most one per curve; 1 runs here), or the Dask ``client`` or
        ``scheduler``.
    progress : bool or None
        Show a progress bar of the fits (tqdm, on stderr; none for a single curve); default
        None: only when stderr is a terminal (:func:`skin_indent.runtime.log.progress_bar`).
    surface : ResponseSurface, optional
        One neo-Hookean surface for every curve (rescaled to each radius by
        similarity); default: found in the cache or built, once per group of curves
        (see the module docstring).
    tol : float, optional
        Stop rule of the filters.
    x0 : array_like, optional
        Start values (E_kPa, nu) of every fit; default a Hertz estimate per curve.
    keep_fits : bool
        Keep each :class:`~skin_indent.fitting.FitResult` in its row (``row.fit``).
    plot_dir : path, optional
        Write a plot (:func:`skin_indent.report.fit_figure.plot_fit`, ``NAME_INDEX.png``) and a
        CSV of depth, force, model and residual (``NAME_INDEX.csv``) per fitted curve
        into this folder, each with its provenance.
    command : sequence of str, optional
        Command line to record (default ``sys.argv``).
    model : str, optional
        Fit this model to every curve (``"neo-hooke+layer"``: :func:`skin_indent.fitting.fit`
        with ``model=``; every segment, least squares, ``fixed`` by any parameter name the
        model reports); ``window``, ``contact``, ``surface``, ``x0`` and ``tol`` then do not apply.
    priors : dict, optional
        ``{name: (mean, sd)}`` Gaussian priors of every fit (implies the model path).

    Returns
    -------
    BatchResult
        A list of :class:`BatchRow` in file and curve order, with ``provenance`` and
        ``surfaces``.

    Examples
    --------
    >>> from skin_indent.report.batch_table import write_tsv
    >>> from skin_indent.runtime.context import Context
    >>> rows = fit_many("curves/", radius_mm=0.02, context=Context(workers=2))  # doctest: +SKIP
    >>> write_tsv(rows, "results.tsv")                                           # doctest: +SKIP
    """
    fixed = dict(fixed or {})
    if "contact_point_mm" in fixed:
        fixed["offset_mm"] = fixed.pop("contact_point_mm")
    ctx = context_of(context)
    files = expand_paths(paths, recursive=recursive)
    free = tuple(free or ())
    if model is not None or priors:
        given = [k for k, v in (("window", window), ("contact", None if contact == "auto" else contact),
                                ("surface", surface), ("x0", x0), ("tol", tol), ("free", free or None),
                                ("method", None if method == "lsq" else method)) if v is not None]
        if given:
            raise ValueError(f"a fit of a chosen model prepares each curve as the diagnosis does (least squares): "
                             f"{', '.join(given)} not taken")
        return _fit_many_model(files, model or "neo-hooke", priors, index=index, radius_mm=radius_mm, fixed=fixed,
                               mesh=mesh, ctx=ctx, progress=progress, keep_fits=keep_fits, plot_dir=plot_dir,
                               command=command)
    # as fit() decides: the one fit of the half-space (the diagnosis's first rung), or the paper's
    # identification where the options ask for it, at AFM scale and for nu held at 0.499 or 0.5
    asked = paper_identification(method, window=window, contact=contact, surface=surface, x0=x0, tol=tol)

    def paper(data) -> bool:
        return asked or paper_needed(data, fixed=fixed, radius_mm=radius_mm)

    rows = _prepared_rows(files, index=index, radius_mm=radius_mm,
                          prepare_one=lambda m: prepare(m, window=window, contact=contact,
                                                        contact_mm=fixed.get("offset_mm"), radius_mm=radius_mm)
                          if paper(m) else prepare_curve(m, radius_mm=radius_mm))
    one_fit = [i for i, r in enumerate(rows) if isinstance(r, tuple) and not paper(r[1])]
    one_fit_mesh = mesh
    mesh = "medium" if mesh is None else mesh
    # the surfaces, once each, here
    pending = [i for i, r in enumerate(rows) if isinstance(r, tuple) and i not in one_fit]
    log.info("%d curve%s read from %d file%s (%d could not be read or prepared)", len(rows),
             "s" if len(rows) != 1 else "", len(files), "s" if len(files) != 1 else "", len(rows) - len(pending) - len(one_fit))
    groups: dict = {}
    for i in pending:
        p = rows[i][1]
        groups.setdefault(_surface_key(p.radius_mm, _needed_depth(p)), []).append(i)
    surface_of: dict = {}
    surfaces = []
    for (radius, _), members in groups.items():
        if surface is not None:
            s = surface
        else:
            depth = max(_needed_depth(rows[i][1]) for i in members)
            try:
                s = surface_for(radius, depth, context=ctx, mesh=mesh)
            except Exception as err:  # noqa: BLE001 - the curves of this group fail, the others go on
                message = f"response surface for R = {radius:g} mm: {one_line(err)}"
                for i in members:
                    rows[i] = BatchRow(**rows[i][0], radius_mm=radius, error=message)
                continue
        surfaces.append(s)
        for i in members:
            surface_of[i] = s

    radii = sorted({rows[i][1].radius_mm for i in [*pending, *one_fit] if isinstance(rows[i], tuple)})
    settings = {"radius_mm": radius_mm, "radii_mm": radii, "index": index, "window_mm": window, "contact": contact,
                "fixed": fixed, "free": list(free), "method": method, "tol": tol, "x0": x0,
                # as given (None: each fit's default, coarse for the one fit, medium for the paper's identification)
                "mesh": one_fit_mesh if one_fit else mesh,
                "surface": None if surface is None else "given (see surface)"}
    prov = make_provenance(command=command, inputs=files, settings=settings, surface=surfaces)

    x0 = None if x0 is None else np.asarray(x0, dtype=float)
    tasks = [(i, (rows[i][1], surface_of[i], method, fixed, tol, x0, None, None, None, free))
             for i in pending if i in surface_of]
    tasks += [(i, (rows[i][1], None, "lsq", fixed, None, None, "neo-hooke", None, one_fit_mesh, free)) for i in one_fit]
    tasks.sort(key=lambda t: t[0])
    _run(tasks, rows, ctx, progress=progress, keep_fits=keep_fits, plot_dir=plot_dir, prov=prov,
         surface_of=surface_of)
    return BatchResult(rows, provenance=prov, surfaces=surfaces)


def _run(tasks, rows, ctx, *, progress, keep_fits, plot_dir, prov, surface_of=None, model=None) -> None:
    """The fits of ``tasks`` on the context's executor (:func:`~skin_indent.runtime.batch.run_tasks`),
    each result (or error) put in its row as it arrives."""
    extra = {} if model is None else {"model": model}
    desc = "fitting" if model is None else f"fitting {model}"
    for i, value, err in run_tasks(_fit_task, tasks, ctx, progress=progress, desc=desc):
        base, prepared = rows[i]
        result, message = value if err is None else (None, err)
        if result is None:
            rows[i] = BatchRow(**base, radius_mm=prepared.radius_mm, error=message, **extra)
            continue
        row = _row_of(base, result, None if surface_of is None else surface_of.get(i))
        if plot_dir is not None:
            row = _write_plots(row, result, plot_dir, prov)
        rows[i] = row if not keep_fits else BatchRow(**{**_fields(row), "fit": result})


def _fit_many_model(files, model, priors, *, index, radius_mm, fixed, mesh, ctx, progress, keep_fits, plot_dir,
                    command) -> BatchResult:
    """:func:`fit_many` of a chosen model: each curve prepared as the diagnosis prepares it and fitted
    with :func:`skin_indent.fitting.fit` (``model=``) in a worker, whose surfaces go to the shared cache."""
    parse_model(model)  # one line for a bad model, before any file is read
    mesh = "coarse" if mesh is None else mesh
    rows = _prepared_rows(files, index=index, radius_mm=radius_mm, model=model,
                          prepare_one=lambda m: prepare_curve(m, radius_mm=radius_mm))
    pending = [i for i, r in enumerate(rows) if isinstance(r, tuple)]
    radii = sorted({rows[i][1].radius_mm for i in pending})
    settings = {"model": model, "radius_mm": radius_mm, "radii_mm": radii, "index": index, "fixed": fixed,
                "priors": {k: list(v) for k, v in (priors or {}).items()}, "method": "lsq", "mesh": mesh}
    prov = make_provenance(command=command, inputs=files, settings=settings)
    # each worker fits on one core (run_tasks); their surfaces and runs are shared through the cache
    tasks = [(i, (rows[i][1], None, "lsq", fixed, None, None, model, priors, mesh)) for i in pending]
    _run(tasks, rows, ctx, progress=progress, keep_fits=keep_fits, plot_dir=plot_dir, prov=prov, model=model)
    return BatchResult(rows, provenance=prov)


def _fields(row: BatchRow) -> dict:
    return {f.name: getattr(row, f.name) for f in fields(row)}


def _write_plots(row: BatchRow, result, plot_dir, prov) -> BatchRow:
    """The plot and CSV of one fit; a failure to write becomes a flag of the row, not an error."""
    name = row.plot_name
    one = row_provenance(prov, row)
    try:
        plot_fit(result, Path(plot_dir) / f"{name}.png")
        write_fit_csv(result, Path(plot_dir) / f"{name}.csv", one)
    except Exception as err:  # noqa: BLE001
        return BatchRow(**{**_fields(row), "flags": row.flags + (f"plot not written: {one_line(err)}",)})
    return row


