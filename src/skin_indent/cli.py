"""Command-line interface: ``skin-indent COMMAND ...``.

A thin front end over the Python API. Every error a user can cause (bad numbers,
bad files, a model that does not converge) ends in a one-line message on stderr
and exit status 2, never a traceback; the exit statuses of every command are
:data:`EXIT_STATUS`. Messages of long phases go to stderr through the ``skin_indent``
logger (:mod:`skin_indent.runtime.log`; ``-v``/``-q`` on every command), progress bars
only to a terminal unless ``--progress`` asks for them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

MATERIALS = ("neo-hooke", "linear-elastic", "neo-hooke-stiffening")

#: the exit statuses of every command
EXIT_OK, EXIT_USER_ERROR, EXIT_FLAGGED, EXIT_INTERRUPTED = 0, 2, 3, 130
#: the epilog of every command's --help: messages and exit statuses, said once
EXIT_STATUS = ("Messages: the phases of long work (surface builds, batches, the rungs of a diagnosis) as one line "
               "each on stderr; -v adds details, -q keeps only warnings and errors (a clean run with -q leaves "
               "stderr empty). Progress bars only when stderr is a terminal (--progress, --no-progress). "
               "Results go to stdout. "
               "Exit status: 0 done; 2 a user error (a bad option or value, a missing or malformed file, a "
               "model that does not converge), one line on stderr; 3 a curve failed or was flagged as not to be "
               "trusted (fit: with --strict, the default for several curves; a single fit that fails always) or a "
               "finite-element run of a surface build failed; 130 interrupted (Ctrl-C).")


class CLIError(Exception):
    """A user error, reported in one line."""


def _material(name: str, E: float, nu: float, C20: float = 0.0):
    from .mechanics.materials import LinearElastic, NeoHooke, NeoHookeStiffening

    if name == "neo-hooke-stiffening":
        return NeoHookeStiffening(E_kPa=E, nu=nu, C20_kPa=C20)
    if C20:
        raise CLIError("--C20 needs --material neo-hooke-stiffening")
    laws = {"neo-hooke": NeoHooke, "linear-elastic": LinearElastic}
    return laws[name](E_kPa=E, nu=nu)


def _numbers(text: str, count: int, what: str) -> list[float]:
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        raise CLIError(f"{what} must be {count} comma-separated numbers, got {text!r}")
    return values


def _sample(args):
    """The material, or the layered sample, described by the simulate options."""
    from .mechanics.layers import RIGID, Layer, LayeredSample
    from .mechanics.materials import PronyTerm, Viscoelastic

    def law(E, nu):
        base = _material(args.material, E, nu, args.C20)
        if args.prony:
            terms = tuple(PronyTerm(*_numbers(p, 2, "--prony G,TAU_S")) for p in args.prony)
            return Viscoelastic(base, terms)
        return base

    if args.rigid_base and not args.layer:
        raise CLIError("--rigid-base needs at least one --layer THICKNESS_MM,E_KPA,NU")
    if not args.layer:
        return law(args.E, args.nu)
    layers = [Layer(t, law(E, nu)) for t, E, nu in (_numbers(x, 3, "--layer THICKNESS_MM,E_KPA,NU")
                                                      for x in args.layer)]
    return LayeredSample(tuple(layers), RIGID if args.rigid_base else law(args.E, args.nu))


def _add_simulate(sub):
    p = sub.add_parser("simulate", help="simulate a force-depth curve with the finite-element model",
                       description="Simulate a rigid sphere pressed into a half-space; write the force-depth curve "
                                   "(CSV: depth_mm,force_mN) and optionally the fields (VTU).")
    p.add_argument("--material", choices=MATERIALS, default="neo-hooke", help="constitutive law (default neo-hooke)")
    p.add_argument("--E", type=float, default=10.0, help="Young's modulus, kPa (default 10)")
    p.add_argument("--nu", type=float, default=0.4, help="Poisson's ratio (default 0.4)")
    p.add_argument("--radius", type=float, default=6.22, help="sphere radius, mm (default 6.22)")
    p.add_argument("--depth", type=float, default=0.6, help="largest depth, mm (default 0.6)")
    p.add_argument("--points", type=int, default=100, help="number of equally spaced depths (default 100)")
    p.add_argument("--mesh", default="medium", help="coarse, medium (default), fine, or a mesh file")
    p.add_argument("--increments", type=int, default=None, help="solved increments (default: automatic)")
    p.add_argument("--C20", type=float, default=0.0, help="stiffening parameter of neo-hooke-stiffening, kPa")
    p.add_argument("--layer", action="append", default=[], metavar="THICKNESS_MM,E_KPA,NU",
                   help="a bonded layer (repeatable, top first); --E/--nu then describe the half-space below")
    p.add_argument("--rigid-base", action="store_true", help="the layers are bonded to a rigid base")
    p.add_argument("--prony", action="append", default=[], metavar="G,TAU_S",
                   help="a Prony term of quasi-linear viscoelasticity (repeatable); E is the instantaneous modulus")
    p.add_argument("--protocol", type=Path, default=None,
                   help="replay the time and depth history of a measurement CSV (with time_s)")
    p.add_argument("--speed", type=float, default=0.02, help="loading speed of the default ramp, mm/s (0.02)")
    p.add_argument("--unload", action="store_true", help="unload back to depth 0 after the ramp")
    p.add_argument("--offset", type=float, default=0.0, help="contact begins at this recorded depth, mm")
    p.add_argument("--friction", type=float, default=0.0, metavar="MU",
                   help="Coulomb friction coefficient between sphere and skin (history dependent: solved along "
                        "the protocol)")
    p.add_argument("--adhesion", type=float, default=0.0, metavar="W_MJ_PER_M2",
                   help="work of adhesion, mJ/m^2 (attractive traction; pull-off on unloading)")
    p.add_argument("--out", type=Path, default=Path("curve.csv"), help="output CSV (default curve.csv)")
    p.add_argument("--vtu", type=Path, default=None, help="also write the deformed mesh and fields at the last depth")
    p.set_defaults(run=_run_simulate)


def _run_simulate(args) -> int:
    from .mechanics.contact import SphericalIndenter
    from .measurement import load_csv
    from .protocol import Protocol

    material = _sample(args)
    indenter = SphericalIndenter(args.radius)
    for path in [args.out] + ([args.vtu] if args.vtu else []):
        if not path.parent.exists():
            raise CLIError(f"output folder does not exist: {path.parent}")
    from .mechanics.contact import ContactLaw

    contact = ContactLaw(friction=args.friction, adhesion_mJ_per_m2=args.adhesion)
    protocol = None
    if args.protocol is not None:
        protocol = Protocol.from_measurement(load_csv(args.protocol))
    elif args.unload or not material.path_independent or args.friction > 0:
        protocol = Protocol.ramp(args.depth, args.points, args.speed, unload=args.unload)
    print(f"model: {material.name} {material.parameters()}; sphere R = {args.radius:g} mm", flush=True)
    from .simulate import simulate  # the finite-element machinery, after the first line

    curve = simulate(material, indenter, args.depth, args.points, mesh=args.mesh, increments=args.increments,
                     protocol=protocol, offset_mm=args.offset, keep_state=args.vtu is not None, contact=contact)
    curve.to_csv(args.out, _provenance(args, [args.protocol] if args.protocol else [], leave_out=("out", "vtu")))
    print(f"mesh: {curve.mesh_name}")
    print(f"Newton: {curve.report.summary()}")
    k = int(np.argmax(curve.force_mN))
    print(f"peak force {curve.force_mN[k]:.6g} mN at {curve.depth_mm[k]:g} mm"
          + (f" (t = {curve.time_s[k]:g} s)" if curve.time_s is not None else ""))
    columns = "time_s,depth_mm,force_mN" if curve.time_s is not None else "depth_mm,force_mN"
    print(f"wrote {args.out} ({curve.depth_mm.size} rows: {columns})")
    if args.vtu:
        curve.write_vtu(args.vtu)
        print(f"wrote {args.vtu} (deformed mesh; displacement, contact pressure, Cauchy and von Mises stress)")
    return 0


def _add_surface(sub):
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
    p.set_defaults(run=lambda args: _missing_subcommand(p))


def _missing_subcommand(parser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_USER_ERROR


def _surface_requests(args) -> list[tuple[float, float, list[str]]]:
    """``[(radius_mm, depth_mm, [curve labels])]``: the :func:`~skin_indent.fitting.surface_for` calls
    that `fit` makes for the curves of ``args.data`` (one per radius and unit-radius surface)."""
    from .batch import _needed_depth, _surface_key, expand_paths
    from .measurement import load_curves, prepare

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

    from .mechanics.contact import SphericalIndenter
    from .response_surface import SurfaceGrid, parse_range
    from .runtime.context import Context
    from .fitting import surface_for

    _positive_radius(args.radius)
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
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=_progress(args))
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


def _parse_window(text: str) -> tuple[float, float]:
    """``"0.05:0.6"`` -> (0.05, 0.6) mm, with a one-line error for anything else."""
    import math

    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise CLIError(f"window must be MIN:MAX in mm (e.g. 0.05:0.6), got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise CLIError(f"window must satisfy 0 <= MIN < MAX, got {text!r}")
    return lo, hi


#: ``--fix`` names and the model parameter each one sets.
FIX_ALIASES = {"E_kPa": "E_kPa", "E": "E_kPa", "nu": "nu", "contact_point_mm": "offset_mm",
               "offset_mm": "offset_mm"}


def _parse_fix(items, any_name: bool = False) -> dict[str, float]:
    """``["nu=0.499", "E_kPa=3"]`` -> ``{"nu": 0.499, "E_kPa": 3.0}`` (model names), one-line errors.

    ``any_name``: a chosen model's parameters by the names results report (``thickness_mm``,
    ``ratio``, which may be ``inf``: a rigid base), checked against the model when it is fitted.
    """
    import math

    out: dict[str, float] = {}
    for item in items or ():
        name, sep, value = str(item).partition("=")
        name = name.strip()
        if not sep or not name or (not any_name and name not in FIX_ALIASES):
            names = "a parameter of the model" if any_name else f"one of {', '.join(FIX_ALIASES)} (more with --model)"
            raise CLIError(f"--fix must be NAME=VALUE with NAME {names}, got {item!r}")
        try:
            number = float(value)
        except ValueError:
            raise CLIError(f"--fix {name}: {value!r} is not a number") from None
        if math.isnan(number) or (math.isinf(number) and not (any_name and number > 0)):
            raise CLIError(f"--fix {name}: the value must be finite, got {value!r}")
        out[FIX_ALIASES.get(name, name)] = number
    return out


def _parse_priors(items) -> dict[str, tuple[float, float]]:
    """``["thickness_mm=1.2:0.1"]`` -> ``{"thickness_mm": (1.2, 0.1)}``, one-line errors."""
    import math

    out: dict[str, tuple[float, float]] = {}
    for item in items or ():
        name, sep, value = str(item).partition("=")
        name = name.strip()
        try:
            mean, sd = (float(x) for x in value.split(":"))
        except ValueError:
            raise CLIError(f"--prior must be NAME=MEAN:SD (e.g. thickness_mm=1.2:0.1), got {item!r}") from None
        if not sep or not name or not (math.isfinite(mean) and math.isfinite(sd) and sd > 0):
            raise CLIError(f"--prior must be NAME=MEAN:SD with a finite mean and SD > 0, got {item!r}")
        out[FIX_ALIASES.get(name, name)] = (mean, sd)
    return out


def _add_fit(sub):
    p = sub.add_parser("fit", help="identify E and nu from a measured curve",
                       description="Fit a neo-Hookean half-space to the loading (approach) segment of a measured "
                                   "curve (CSV with depth_mm|depth_um|depth_nm|depth_m, "
                                   "force_mN|force_N|force_uN|force_nN, optional time_s; or an instrument file "
                                   "such as JPK .jpk-force with the optional afmformats package). A curve that "
                                   "starts before contact gets its force baseline subtracted (and reported) and its "
                                   "contact point fitted with the material.")
    p.add_argument("data", type=Path, nargs="+",
                   help="measurement files or folders: CSV, Chiaro .txt, or .jpk-force / .jpk-force-map etc. with "
                        "afmformats installed; several curves (a folder, a force map) are fitted in parallel")
    p.add_argument("--recursive", "-r", action="store_true",
                   help="search folders and their subfolders (default: the files directly in each folder)")
    p.add_argument("--out", type=Path, default=None, help="write one TSV row per curve, with a provenance header")
    p.add_argument("--index", type=int, default=None, help="fit only curve N (from 0) of each file")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR",
                   help="write a PNG and a CSV (depth, force, model, residual) per curve, and summary.png, into DIR")
    p.add_argument("--mesh", choices=("coarse", "medium", "fine"), default=None,
                   help="mesh of the finite-element runs behind a built surface (default medium; with --model or "
                        "--prior coarse, as diagnose)")
    p.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT", help="fit on this Dask scheduler")
    p.add_argument("--method", choices=("ekf-paper", "ekf", "lsq"), default=None,
                   help="ekf-paper: the paper's filter; ekf: better-conditioned filter; lsq: least squares (default)")
    p.add_argument("--surface", type=Path, default=None,
                   help="response surface file (default: cache, built if needed); a neo-Hookean surface of another "
                        "radius is rescaled by similarity")
    p.add_argument("--window", default=None,
                   help="indentation depth window MIN:MAX in mm past the contact point (e.g. 0.05:0.6)")
    p.add_argument("--radius", type=float, default=None,
                   help="sphere radius, mm (default: the file's, else the skin sphere 6.22; AFM: e.g. 0.0275)")
    p.add_argument("--start", default=None, help="start values E,nu (default: a Hertz estimate at nu = 0.4)")
    p.add_argument("--model", default=None, metavar="neo-hooke[+EFFECT...]",
                   help="fit this model, e.g. neo-hooke+layer+layer (two bonded layers) or neo-hooke+stiffening: "
                        "every segment, the diagnosis's fit (response surfaces, or finite elements in the loop where "
                        "none covers the model), least squares; default: the paper's neo-Hookean half-space on the "
                        "loading segment")
    p.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                   help="hold a parameter fixed (repeatable): E_kPa, nu or contact_point_mm, e.g. --fix nu=0.5 "
                        "(the incompressible limit of the compressible FE law); with --model any parameter the "
                        "results report, e.g. --fix thickness_mm=1.2 (the top layer) or --fix ratio=inf. Default: "
                        "nu = 0.5 at AFM scale (sphere radius < 0.5 mm, the field's convention; results then in Pa, "
                        "nN, um), nothing at skin scale (nu fitted, as in the paper)")
    p.add_argument("--free", action="append", default=[], choices=("nu",),
                   help="fit a parameter the scale's default holds: --free nu fits nu at AFM scale")
    p.add_argument("--prior", action="append", default=[], metavar="NAME=MEAN:SD",
                   help="a Gaussian prior from an independent measurement (repeatable), e.g. --prior "
                        "thickness_mm=1.2:0.1 (ultrasound); implies the model path (--model, default neo-hooke)")
    p.add_argument("--noise", type=float, default=None,
                   help="noise standard deviation of a raw sample, mN (default: from the data)")
    p.add_argument("--contact", choices=("auto", "fit", "origin"), default=None,
                   help="contact point: auto (fitted if the curve has a pre-contact baseline, else recorded depth "
                        "0; default), fit (always fitted), origin (recorded depth 0)")
    p.add_argument("--tol", type=float, default=None, help="stop rule C of the filters (default 1e-6)")
    p.add_argument("--strict", action=argparse.BooleanOptionalAction, default=None,
                   help="exit with status 3 when a curve failed or is flagged as not to be trusted (a parameter at a "
                        "bound, a misfit over 10 times the noise, a scale no tissue has: E outside 10 Pa-100 MPa, h/R "
                        "< 1e-3, fewer than 5 points in contact per parameter, a parameter's sd above its value); "
                        "default on for several curves, off for one. Flags are always printed as warnings")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--profile", type=Path, default=None, metavar="FILE",
                   help="take the settings of this fit profile (JSON; TOML with Python >= 3.11: keys model, fix, "
                        "prior, method, window, radius, mesh, noise, contact, start, tol, index, surface), or of "
                        "the provenance of a fit output (JSON, CSV, TSV or PNG); options given override it")
    p.add_argument("--save-profile", type=Path, default=None, metavar="FILE",
                   help="write the settings of this run as a profile (TOML for a .toml name, else JSON)")
    p.set_defaults(run=_run_fit)


def _parse_start(text):
    try:
        E, nu = (float(x) for x in text.split(","))
    except ValueError:
        raise CLIError(f"--start must be E,nu (e.g. 10,0.3), got {text!r}") from None
    return np.array([E, nu])


def _positive_radius(radius):
    if radius is not None and not (np.isfinite(radius) and radius > 0):
        raise CLIError(f"--radius must be a positive number of mm, got {radius:g}")


def _fit_settings(args, fixed, window, priors=None) -> dict:
    """The settings of a fit as its provenance records them (a profile: :mod:`skin_indent.fitting.profile`)."""
    out = {"radius_mm": args.radius, "window_mm": window, "method": args.method, "mesh": args.mesh,
           "fixed": fixed, "free": list(args.free), "contact": args.contact, "index": args.index,
           "noise_mN": args.noise, "x0": None if args.start is None else _parse_start(args.start), "tol": args.tol,
           "surface": None if args.surface is None else str(args.surface)}
    if args.model is not None or priors:
        out.update(model=args.model or "neo-hooke", priors={k: list(v) for k, v in (priors or {}).items()})
    return out


def _provenance(args, inputs, settings=None, surface=None, leave_out=()):
    """The provenance of a command's output: its command line, inputs and settings (default its options)."""
    from .runtime.provenance import provenance

    if settings is None:
        settings = {k: v for k, v in vars(args).items()
                    if k not in ("run", "command", "command_line", "json", "workers", "scheduler", *leave_out)}
    return provenance(command=getattr(args, "command_line", None), inputs=inputs, settings=settings,
                      surface=surface)


def _apply_profile(args) -> None:
    """Fill the fit options not given on the command line from ``--profile``, then the defaults."""
    from .fitting.profile import read_profile

    prof = read_profile(args.profile) if args.profile is not None else {}
    for key in ("model", "method", "radius", "mesh", "noise", "contact", "tol", "index"):
        if getattr(args, key) is None and key in prof:
            setattr(args, key, prof[key])
    if args.window is None and "window" in prof:
        args.window = "{!r}:{!r}".format(*prof["window"])
    if args.start is None and "start" in prof:
        args.start = "{!r},{!r}".format(*prof["start"])
    if args.surface is None and "surface" in prof:
        args.surface = Path(prof["surface"])
        if not args.surface.is_file():
            raise CLIError(f"--profile {args.profile}: its surface file {prof['surface']!r} is not found; give "
                           "--surface FILE")
    # --fix and --prior by name: the command line's after the profile's, so they win
    args.fix = [f"{k}={v!r}" for k, v in prof.get("fix", {}).items()] + list(args.fix)
    args.prior = [f"{k}={m!r}:{sd!r}" for k, (m, sd) in prof.get("prior", {}).items()] + list(args.prior)
    if not args.free and "free" in prof:
        args.free = list(prof["free"])
    args.method = args.method or "lsq"
    args.contact = args.contact or "auto"


def _run_fit(args) -> int:
    from .runtime.context import Context
    from .measurement import load_curves

    _apply_profile(args)
    _positive_radius(args.radius)
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    missing = [str(path) for path in args.data if not path.exists()]
    if missing:  # a user error (exit 2), not a failed curve
        raise CLIError(f"no such file or folder: {', '.join(missing)}")
    priors = _parse_priors(args.prior)
    chosen = args.model is not None or bool(priors)
    fixed = _parse_fix(args.fix, any_name=chosen)
    if args.free and (chosen or "nu" in fixed):
        raise CLIError("--free nu: " + ("a --model/--prior fit fits nu unless --fix holds it" if chosen else
                                        "nu is also held with --fix; give one of them"))
    if chosen:
        from .fitting.model_fit import parse_model

        parse_model(args.model or "neo-hooke")  # one line for a bad model before any file is read
        given = [o for o, v in (("--window", args.window), ("--start", args.start), ("--surface", args.surface),
                                ("--tol", args.tol), ("--contact", None if args.contact == "auto" else args.contact))
                 if v is not None]
        if given:
            raise CLIError(f"{', '.join(given)}: not taken with --model/--prior (each curve is prepared as "
                           "diagnose prepares it: every segment, the contact point as a parameter where the curve "
                           "starts before contact)")
        if args.method != "lsq" and (parse_model(args.model or "neo-hooke") or priors):
            raise CLIError(f"--method {args.method} fits the neo-Hookean half-space on a response surface; "
                           f"{'--model ' + args.model if args.model else '--prior'} needs least squares "
                           "(--method lsq)")
    args.priors = priors
    window = _parse_window(args.window) if args.window else None
    if args.save_profile is not None:
        from .fitting.profile import write_profile

        write_profile(_fit_settings(args, fixed, window, priors), args.save_profile)
        if not args.json:
            print(f"wrote the profile of this fit to {args.save_profile}")
    x0 = _parse_start(args.start) if args.start else None
    surface = None
    if args.surface is not None:
        from .response_surface import ResponseSurface

        if not args.surface.is_file():
            raise CLIError(f"surface file not found: {args.surface}")
        surface = ResponseSurface.load(args.surface)
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=_progress(args, off=args.json))
    if args.recursive and not any(path.is_dir() for path in args.data):
        raise CLIError("--recursive searches folders: give a folder")
    if len(args.data) == 1 and args.data[0].is_file() and args.out is None:
        curves = load_curves(args.data[0], radius_mm=args.radius)
        if len(curves) == 1 or args.index is not None:
            if args.index is not None and not 0 <= args.index < len(curves):
                raise CLIError(f"{args.data[0]}: --index {args.index} is out of range (the file has {len(curves)} "
                               "curve(s))")
            return _fit_one(args, curves[args.index or 0], surface, fixed, window, x0, context)
    return _fit_batch(args, surface, fixed, window, x0, context)


def _fit_one(args, measurement, surface, fixed, window, x0, context) -> int:
    """One curve: the report (or JSON), errors as one line (exit 2), flags as warnings."""
    from .fitting import fit
    from .measurement import prepare

    chosen = args.model is not None or bool(args.priors)
    if chosen:
        from .fitting.model_fit import prepare_curve

        prepared = prepare_curve(measurement, radius_mm=args.radius)
    else:
        prepared = prepare(measurement, window=window, contact=args.contact, contact_mm=fixed.get("offset_mm"),
                           radius_mm=args.radius)
    path = args.data[0]
    if not args.json:
        from .measurement.scale import display_units

        data, u = prepared.data, display_units(prepared.radius_mm)
        what = "points" if chosen else "loading points"
        print(f"data: {path} ({data.n_points} {what} from {data.depth_mm.min() * u.per_mm:.4g} to "
              f"{data.depth_mm.max() * u.per_mm:.4g} {u.length}), sphere R = {prepared.radius_mm * u.per_mm:g} "
              f"{u.length} ({prepared.radius_source})"
              + (f"; model {args.model or 'neo-hooke'}" if chosen else ""), flush=True)
    if chosen:
        result = fit(prepared, model=args.model or "neo-hooke", fixed=fixed, priors=args.priors,
                     noise_mN=args.noise, context=context, mesh=args.mesh)
        return _fit_output(args, path, result, _provenance(args, _fit_inputs(args), _fit_settings(args, fixed, window,
                                                                                                args.priors)))
    if surface is not None:
        r_surface = surface.settings.get("radius_mm")
        if r_surface is not None and abs(r_surface - prepared.radius_mm) > 1e-9 * prepared.radius_mm:
            try:
                surface = surface.at_radius(prepared.radius_mm)
            except ValueError:
                raise CLIError(f"the surface is for a sphere of R = {r_surface:g} mm, the measurement for "
                               f"{prepared.radius_mm:g} mm") from None
    result = fit(prepared, surface, args.method, fixed=fixed, x0=x0, tol=args.tol, noise_mN=args.noise,
                 context=context, mesh=args.mesh, free=args.free)
    prov = _provenance(args, _fit_inputs(args), _fit_settings(args, fixed, window), result.surface)
    return _fit_output(args, path, result, prov)


def _fit_inputs(args) -> list:
    """The files a fit reads: the data, and the profile and surface file when given."""
    return [*args.data, *(p for p in (args.profile, args.surface) if p is not None)]


def _fit_output(args, path, result, prov) -> int:
    """Write the plots, print the report or JSON and the flags; the exit status."""
    from .runtime.json_io import dumps
    from .runtime.provenance import with_provenance

    if args.plot is not None:
        from .report.fit_figure import plot_fit, write_fit_csv

        args.plot.mkdir(parents=True, exist_ok=True)
        plot_fit(result, args.plot / f"{path.stem}.png", provenance=prov)
        write_fit_csv(result, args.plot / f"{path.stem}.csv", prov)
    if args.json:
        print(dumps(with_provenance(result.to_dict(), prov)))
    else:
        print(result.report())
        if args.plot is not None:
            print(f"wrote {args.plot / (path.stem + '.png')} and {args.plot / (path.stem + '.csv')}")
    for flag in result.flags:
        print(f"skin-indent fit: warning: {path}: {flag}", file=sys.stderr)
    if not result.success:  # a failed curve (exit 3 as a flagged one), said on stderr
        print(f"skin-indent fit: warning: {path}: the fit failed", file=sys.stderr)
        return EXIT_FLAGGED
    return EXIT_FLAGGED if (args.strict and result.flags) else EXIT_OK


def _fit_batch(args, surface, fixed, window, x0, context) -> int:
    """Every curve of every file: one line (or TSV row) per curve; a bad file is a row, never the end."""
    from .runtime.json_io import dumps
    from .batch import fit_many
    from .report.batch_table import row_line, summary_figure, write_tsv

    if args.model is not None or args.priors:
        rows = fit_many(args.data, index=args.index, radius_mm=args.radius, fixed=fixed, mesh=args.mesh,
                        context=context, progress=context.progress, plot_dir=args.plot, model=args.model or "neo-hooke",
                        priors=args.priors, recursive=args.recursive, command=args.command_line)
    else:
        rows = fit_many(args.data, index=args.index, radius_mm=args.radius, window=window, contact=args.contact,
                        fixed=fixed, method=args.method, mesh=args.mesh, context=context, progress=context.progress,
                        surface=surface, tol=args.tol, x0=x0, plot_dir=args.plot, free=args.free,
                        recursive=args.recursive, command=args.command_line)
    if args.surface is not None:  # replayable: the file, not the object fit_many was given
        rows.provenance["settings"]["surface"] = str(args.surface)
    if args.profile is not None:
        from .runtime.provenance import file_identity

        rows.provenance["inputs"].append(file_identity(args.profile))
    if args.out is not None:
        write_tsv(rows, args.out)
    if args.plot is not None and rows:
        summary_figure(rows, args.plot / "summary.png")
    if args.json:
        print(dumps({"rows": [r.to_dict() for r in rows], "provenance": rows.provenance}))
    else:
        for r in rows:
            print(row_line(r))
        print(f"{len(rows)} curves: {rows.n_failed} failed, {rows.n_flagged} flagged"
              + (f"; wrote {args.out}" if args.out is not None else "")
              + (f"; figures in {args.plot}" if args.plot is not None else ""))
    for r in rows:
        for flag in r.flags:
            print(f"skin-indent fit: warning: {r.label}: {flag}", file=sys.stderr)
    strict = True if args.strict is None else args.strict
    return EXIT_FLAGGED if (strict and not rows.trusted) else EXIT_OK


def _add_diagnose(sub):
    from .effects import EFFECTS

    p = sub.add_parser("diagnose", help="compare model and measurement, name the missing physical effect",
                       description="Fit the neo-Hookean half-space to every segment of a measured curve, test "
                                   "whether the residual is noise, rank the missing effects by BIC, add the "
                                   "best and diagnose again on top until the residual is noise or nothing "
                                   "helps (a ladder; --add builds rungs by hand).")
    p.add_argument("data", type=Path, help="measurement CSV (time_s optional) or instrument file")
    p.add_argument("--model", default="neo-hooke",
                   help="base model: neo-hooke, optionally with effects, e.g. neo-hooke+layer (same as --add)")
    p.add_argument("--candidates", default=",".join(EFFECTS),
                   help=f"comma-separated effects to test (default {','.join(EFFECTS)})")
    p.add_argument("--add", action="append", default=[], metavar="EFFECT",
                   help="add an effect to the model by hand (repeatable, in order; --add layer --add layer: two "
                        "layers); the automatic climb goes on from there")
    p.add_argument("--max-rungs", type=int, default=3, metavar="N",
                   help="effects the automatic climb may add (default 3; 0: examine the model and stop)")
    p.add_argument("--surfaces-only", action="store_true",
                   help="do not fit combinations that no response surface covers (two layers, layer and "
                        "stiffening) with the finite-element model in the loop (minutes each)")
    p.add_argument("--noise", type=float, default=None, help="noise standard deviation, mN (default: from the data)")
    p.add_argument("--segments", default="approach,hold,retract",
                   help="kinds of motion to diagnose (default all; only trailing ones can be left out)")
    p.add_argument("--radius", type=float, default=None,
                   help="sphere radius, mm (default: the file's, else the skin sphere 6.22)")
    p.add_argument("--mesh", choices=("coarse", "medium", "fine"), default="coarse",
                   help="mesh of the finite-element runs behind the surfaces (default coarse: within 0.03%% of "
                        "medium, below the 0.3%% model error that diagnosis allows)")
    p.add_argument("--workers", type=int, default=None, help="local processes for building surfaces")
    p.add_argument("--scheduler", default=None, help="Dask scheduler tcp://HOST:PORT for building surfaces")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--report", type=Path, default=None, metavar="DIR",
                   help="write an HTML page with embedded figures and the PNG figures into DIR")
    p.set_defaults(run=_run_diagnose)


def _run_diagnose(args) -> int:
    from .runtime.json_io import dumps
    from .runtime.context import Context
    from .diagnosis import diagnose
    from .report import write_report
    from .measurement import load_curve

    _positive_radius(args.radius)
    model = args.model.split("+")
    if model[0] != "neo-hooke":
        raise CLIError(f"--model must start with neo-hooke (the base law), got {args.model!r}")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    add = [*model[1:], *args.add]
    candidates = [c.strip() for c in args.candidates.split(",") if c.strip()]
    measurement = load_curve(args.data, radius_mm=args.radius)
    segments = tuple(x.strip() for x in args.segments.split(",") if x.strip())
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=_progress(args, off=args.json))
    if args.max_rungs < 0:
        raise CLIError(f"--max-rungs must be >= 0, got {args.max_rungs}")
    diag = diagnose(measurement, candidates=candidates, add=add, noise_mN=args.noise, segments=segments,
                    max_rungs=args.max_rungs, in_loop=not args.surfaces_only, context=context, mesh=args.mesh)
    prov = _provenance(args, [args.data], leave_out=("data", "report"))
    if args.report is not None:
        page = write_report(diag, args.report, provenance=prov)
    if args.json:
        out = diag.to_dict()
        if args.report is not None:
            out["report"] = str(page)
        print(dumps({**out, "provenance": prov}))
    else:
        print(diag.report())
        if args.report is not None:
            print(f"report: {page}")
    return 0


def _add_demo(sub):
    p = sub.add_parser("demo", help="the paper's workflow on the bundled in-vivo-like curve",
                       description="Identify (E, nu) of the bundled forearm-like curve with the paper's EKF and "
                                   "global stabilisation, a better-conditioned EKF and least squares; then "
                                   "diagnose what the homogeneous half-space misses (the ladder); write figures.")
    p.add_argument("--out", type=Path, default=Path("skin_indent_demo"), help="output folder (default skin_indent_demo)")
    p.add_argument("--workers", type=int, default=None, help="local processes for building the surface")
    p.add_argument("--no-diagnosis", action="store_true",
                   help="stop after the paper's workflow (the diagnosis ladder builds effect surfaces and fits "
                        "with the finite-element model in the loop: minutes on 2 cores)")
    p.set_defaults(run=_run_demo)


def _run_demo(args) -> int:
    from .demo import run_demo

    run_demo(args.out, workers=args.workers, diagnosis=not args.no_diagnosis, progress=_progress(args),
             command=args.command_line)
    return 0


def _output_options(parser, top: bool) -> None:
    """-v/-q/--progress on ``parser``; on a subcommand they default to SUPPRESS, so that the
    top level's value stands unless given after the subcommand (``skin-indent fit x.csv -q``)."""
    keep = {} if top else {"default": argparse.SUPPRESS}
    group = parser.add_argument_group("messages")
    talk = group.add_mutually_exclusive_group()
    talk.add_argument("-v", "--verbose", action="count", help="more messages on stderr (details of each phase)",
                      **({"default": 0} if top else keep))
    talk.add_argument("-q", "--quiet", action="store_true",
                      help="only warnings and errors on stderr, no progress bars", **keep)
    group.add_argument("--progress", action=argparse.BooleanOptionalAction,
                       help="progress bars on stderr (default: only when stderr is a terminal)",
                       **({"default": None} if top else keep))


def _conventions(parser, top: bool = False) -> None:
    """The messages options and the exit-status epilog on ``parser`` and every subcommand below it."""
    _output_options(parser, top)
    parser.epilog = EXIT_STATUS
    for action in parser._actions:  # noqa: SLF001 - argparse keeps subcommands only there
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for child in dict.fromkeys(action.choices.values()):
                _conventions(child)


def _progress(args, off: bool = False):
    """Progress bars: --progress/--no-progress if given, off with -q (or ``off``), else None (a terminal only)."""
    if args.progress is not None:
        return args.progress
    return False if (args.quiet or off) else None


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(prog="skin-indent", description="Sphere indentation of skin: simulate, "
                                     "identify material parameters, diagnose missing physics. Units: mm, kPa, mN, s.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_demo(sub)
    _add_simulate(sub)
    _add_surface(sub)
    _add_fit(sub)
    _add_diagnose(sub)
    _conventions(parser, top=True)
    return parser



def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``skin-indent`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)  # a bad option: argparse's usage line and SystemExit(2)
    args.command_line = ["skin-indent", *(sys.argv[1:] if argv is None else argv)]  # for every provenance
    if not getattr(args, "run", None):
        parser.print_help()
        return EXIT_USER_ERROR
    if args.verbose and args.quiet:  # one given before the subcommand, the other after it
        parser.error("-v/--verbose and -q/--quiet: choose one")
    from .runtime.log import cli_logging

    try:
        from .runtime.threads import configure_threads

        configure_threads()  # BLAS threads: 1 per process, or SKIN_INDENT_THREADS=N|off
        with cli_logging(f"skin-indent {args.command}", -1 if args.quiet else min(args.verbose, 1)):
            return args.run(args)
    except (CLIError, ValueError, TypeError, OSError, RuntimeError) as err:  # MeasurementError is a ValueError
        solver = sys.modules.get("skin_indent.mechanics.solver")  # loaded by whatever could fail to converge
        if isinstance(err, RuntimeError) and not (solver and isinstance(err, solver.ConvergenceError)):
            raise
        message = " ".join(str(err).split()) or type(err).__name__
        print(f"skin-indent {args.command}: error: {message}", file=sys.stderr)
        return EXIT_USER_ERROR
    except ImportError as err:  # an optional extra (dask) is missing: say how to install it
        from .response_surface import DASK_MISSING

        if str(err) != DASK_MISSING:
            raise
        print(f"skin-indent {args.command}: error: {err}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print(f"skin-indent {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
