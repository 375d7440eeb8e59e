"""``skin-indent surface build``: the response surfaces ``fit`` uses, built into the cache."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .options import EXIT_FLAGGED, EXIT_OK, CLIError, missing_subcommand, positive_radius, progress_of

def add_surface(sub):
    p = sub.add_parser("surface", help="response surfaces F(h; E, nu)")
    ssub = p.add_subparsers(dest="surface_command", metavar="SURFACE_COMMAND")
    b = ssub.add_parser("build", help="build (or complete) the response surfaces that fit uses",
                        description="Build (or complete) neo-Hookean response surfaces F(h; E, nu) in the per-user "
                                    "cache (SKIN_INDENT_CACHE or ~/.cache/skin_indent), where `fit` finds them. "
                                    "With DATA: the surface `fit` uses for each curve of these files (same radius, "
                                    "depth and --mesh as `fit DATA --mesh ...`). Without: the one `fit` uses for a "
                                    "curve to --depth with a sphere of --radius (the unit-radius surface that "
                                    "serves every radius by similarity). --E, --nu, --points or --out build an "
                                    "explicit grid at --radius instead. `fit --model` and `diagnose` build their "
                                    "own surfaces (grids fitted to each curve). Several builds at once share the "
                                    "finite-element runs through the cache: each run is computed once.")
    b.add_argument("data", type=Path, nargs="*", metavar="DATA",
                   help="measurement files or folders whose curves `fit` will fit (default: none, see above)")
    b.add_argument("--mesh", choices=("coarse", "medium", "fine"), default="medium",
                   help="mesh of the finite-element runs (default medium, as `fit`)")
    b.add_argument("--E", default=None, help="explicit E grid MIN:MAX:N[:log], kPa (default of an explicit grid "
                                             "1:100:8:log)")
    b.add_argument("--nu", default=None, help="explicit nu grid MIN:MAX:N (default of an explicit grid 0.2:0.49:6)")
    b.add_argument("--depth", type=float, default=0.6, help="largest depth without DATA, mm (default 0.6)")
    b.add_argument("--points", type=int, default=None, help="number of depths of an explicit grid (default 100)")
    b.add_argument("--radius", type=float, default=None,
                   help="sphere radius, mm (default: each file's, else the skin sphere 6.22)")
    b.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    b.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run the finite-element runs on this Dask scheduler (pip install 'skin_indent[dask]'); "
                        "results are cached on this machine")
    b.add_argument("--out", type=Path, default=None, help="surface file (.npz) of an explicit grid; default the cache")
    b.set_defaults(run=_run_surface_build)
    p.set_defaults(run=lambda args: missing_subcommand(p))


def _surface_requests(args) -> list[tuple[float, float, list[str]]]:
    """``[(radius_mm, depth_mm, [curve labels])]``: the :func:`~skin_indent.fitting.surface_for` calls
    that `fit` makes for the curves of ``args.data`` (one per radius and unit-radius surface)."""
    from ..batch import _needed_depth, _surface_key, expand_paths
    from ..measurement import load_curves, prepare

    missing = [str(path) for path in args.data if not path.exists()]
    if missing:
        raise CLIError(f"no such file or folder: {', '.join(missing)}")
    groups: dict = {}
    for path in expand_paths(args.data):
        curves = load_curves(path, radius_mm=args.radius)
        for i, m in enumerate(curves):
            p = prepare(m)  # as `fit` prepares a curve by default
            depth = _needed_depth(p)
            radius, ceiling = _surface_key(p.radius_mm, depth)
            label = str(path) if len(curves) == 1 else f"{path}[{i}]"
            # a unit-radius surface serves every depth below its ceiling; deeper: one per depth asked
            group = groups.setdefault((radius, ceiling if ceiling is not None else depth), [radius, depth, []])
            group[1] = max(group[1], depth)
            group[2].append(label)
    return [tuple(g) for g in groups.values()]


def _run_surface_build(args) -> int:
    import time

    from ..mechanics.contact_law import SphericalIndenter
    from ..response_surface import SurfaceGrid, parse_range
    from ..runtime.context import Context
    from ..fitting import surface_for

    positive_radius(args.radius)
    radius = 6.22 if args.radius is None else args.radius
    SphericalIndenter(radius)  # validates the radius
    if not (args.depth > 0 and np.isfinite(args.depth)):
        raise CLIError(f"depth must be a finite number > 0 mm, got {args.depth}")
    if args.points is not None and args.points < 4:
        raise CLIError(f"points must be an integer >= 4, got {args.points}")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    explicit = any(v is not None for v in (args.E, args.nu, args.points, args.out))
    if explicit and args.data:
        raise CLIError("DATA builds the surfaces `fit` uses for those curves; --E, --nu, --points and --out "
                       "describe one explicit grid instead: give one or the other")
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args))
    if explicit:
        points = 100 if args.points is None else args.points
        grid = SurfaceGrid(depth_mm=args.depth * np.arange(1, points + 1) / points,
                           E_kPa=parse_range(args.E or "1:100:8:log"), nu=parse_range(args.nu or "0.2:0.49:6"))
        requests = [(radius, args.depth, [f"an explicit grid at R = {radius:g} mm"])]
    elif args.data:
        requests = _surface_requests(args)
        if not requests:
            raise CLIError(f"no curves found in {', '.join(map(str, args.data))}")
    else:
        grid = None
        requests = [(radius, args.depth, [f"curves to {args.depth:g} mm with R = {radius:g} mm"])]
    failed = False
    for r, depth, labels in requests:
        t = time.perf_counter()
        surface = surface_for(r, depth, grid=grid if explicit else None, path=args.out, context=context,
                              mesh=args.mesh)
        origin = surface.settings.get("similarity")
        g = surface.grid
        what = (f"unit-radius surface {origin['hash'][:12]} (h/R to {g.depth_mm[-1] / r:.3g}, for R = {r:g} mm)"
                if origin else f"surface {surface.hash[:12]} at R = {r:g} mm")
        print(f"{what}: {len(g.E_kPa)} E x {len(g.nu)} nu x {len(g.depth_mm)} depths, mesh {args.mesh}, "
              f"ready in {time.perf_counter() - t:.1f} s ({args.out or 'the cache'}); for {', '.join(labels)}")
        for nu, reason in surface.failures.items():
            print(f"  nu = {nu:g} failed: {reason}")
            failed = True
    return EXIT_FLAGGED if failed else EXIT_OK

