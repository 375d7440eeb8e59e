"""``skin-indent plan``: the next measurement, for what a diagnosis could not settle."""

from __future__ import annotations

import math
from pathlib import Path

from .options import (CLIError, command_provenance, number_or_numbers, parse_fix, parse_priors, per_file,
                      positive_radius, progress_of)


def positive_numbers(text: str | None, option: str, unit: str) -> tuple[float, ...] | None:
    """``"2,3.11,10"`` -> ``(2.0, 3.11, 10.0)``: comma-separated positive numbers, one-line errors."""
    if text is None:
        return None
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        values = ()
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise CLIError(f"{option} must be comma-separated positive numbers of {unit}, got {text!r}")
    return values


def positive(value: float | None, option: str, unit: str) -> float | None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise CLIError(f"{option} must be a positive number of {unit}, got {value:g}")
    return value


def add_plan(sub):
    from ..effects import EFFECTS

    p = sub.add_parser("plan", help="rank the next measurements: what would separate the explanations a diagnosis "
                                    "left and determine its undetermined parameters",
                       description="Diagnose DATA, then, for the explanations the diagnosis could not separate and "
                                   "the parameters it could not determine, rank the measurements you can make of "
                                   "the same sample (each sphere radius you own, a deeper indentation, a hold, "
                                   "another loading speed) by the separation of the explanations' predicted curves in "
                                   "noise units (root-sum-square over the candidate's points) and by the expected "
                                   "standard deviation of each undetermined parameter when the candidate is fitted "
                                   "with the recorded curve, from finite-element "
                                   "predictions of the fitted models. Writes the predicted curve of each "
                                   "explanation for the best candidates (CSV, loadable as curves) and a figure.")
    p.add_argument("data", type=Path, nargs="+", help="measurement CSV (time_s optional) or instrument file; several "
                                                      "are curves of one sample, diagnosed together (as diagnose "
                                                      "--sample), the candidates relative to the first")
    p.add_argument("--radii", default=None, metavar="MM,...",
                   help="sphere radii you own, mm, each pressed to the recorded depths (default: half and twice the "
                        "recorded radius; the recorded radius is always weighed: the measurement made again)")
    p.add_argument("--max-depth", type=float, default=None, metavar="MM",
                   help="deepest indentation you can make with the recorded sphere, mm (default 1.5 times the "
                        "recorded depth)")
    p.add_argument("--hold", type=float, default=None, metavar="S",
                   help="a hold at the deepest point after the recorded loading, s (default 30; weighed where an "
                        "explanation acts along the time history)")
    p.add_argument("--speeds", default=None, metavar="MM_PER_S,...",
                   help="other loading speeds, mm/s (weighed where an explanation acts along the time history)")
    p.add_argument("--out", type=Path, default=Path("skin_indent_plan"), metavar="DIR",
                   help="folder of the predicted curves and the figure (default skin_indent_plan)")
    p.add_argument("--json", action="store_true", help="print one JSON object: the ranking")
    diag = p.add_argument_group("the diagnosis (as skin-indent diagnose)")
    diag.add_argument("--candidates", default=",".join(EFFECTS),
                      help=f"comma-separated effects to test (default {','.join(EFFECTS)})")
    diag.add_argument("--max-rungs", type=int, default=3, metavar="N", help="effects the climb may add (default 3)")
    diag.add_argument("--surfaces-only", action="store_true",
                      help="do not fit combinations that no response surface covers with the finite-element model "
                           "in the loop")
    diag.add_argument("--noise", type=number_or_numbers, default=None, metavar="MN[,MN...]",
                      help="noise standard deviation, mN (default: from the data); one per file for several")
    diag.add_argument("--radius", type=number_or_numbers, default=None, metavar="MM[,MM...]",
                      help="sphere radius of the recorded curve, mm (default: the file's, else 6.22); one per file "
                           "for several")
    diag.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                      help="hold a parameter you know (as diagnose --fix)")
    diag.add_argument("--prior", action="append", default=[], metavar="NAME=MEAN:SD",
                      help="a Gaussian prior from an independent measurement (as diagnose --prior)")
    diag.add_argument("--free", action="append", default=[], choices=("nu",),
                      help="fit nu at AFM scale (sphere radius < 0.5 mm), where it is held at 0.49 (as diagnose)")
    diag.add_argument("--mesh", choices=("coarse", "medium", "fine"), default="coarse",
                      help="mesh of the finite-element runs (default coarse)")
    diag.add_argument("--workers", type=int, default=None, help="local processes")
    diag.add_argument("--scheduler", default=None, help="Dask scheduler tcp://HOST:PORT")
    p.set_defaults(run=_run_plan)


def _run_plan(args) -> int:
    from ..diagnosis import plan
    from ..measurement import load_curve
    from ..report import write_plan
    from ..runtime.context import Context
    from ..runtime.json_io import dumps

    positive_radius(args.radius)
    radii = positive_numbers(args.radii, "--radii", "mm")
    speeds = positive_numbers(args.speeds, "--speeds", "mm/s") or ()
    positive(args.max_depth, "--max-depth", "mm")
    positive(args.hold, "--hold", "s")
    n = len(args.data)
    noise = per_file(args.noise, n, "--noise")
    for v in (noise if isinstance(noise, list) else [noise]):
        positive(v, "--noise", "mN")
    radius = per_file(args.radius, n, "--radius")
    fixed, priors = parse_fix(args.fix, any_name=True), parse_priors(args.prior)
    if "nu" in args.free and "nu" in fixed:
        raise CLIError(f"--free nu and --fix nu={fixed['nu']:g}: give one of them")
    if args.max_rungs < 0:
        raise CLIError(f"--max-rungs must be >= 0, got {args.max_rungs}")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    measurements = [load_curve(path, radius_mm=r)
                    for path, r in zip(args.data, radius if isinstance(radius, list) else [radius] * n)]
    candidates = [c.strip() for c in args.candidates.split(",") if c.strip()]
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args, off=args.json))
    result = plan(measurements[0] if len(measurements) == 1 else measurements, radii=radii,
                  max_depth_mm=args.max_depth, hold_s=args.hold, speeds_mm_per_s=speeds, candidates=candidates,
                  noise_mN=noise, max_rungs=args.max_rungs, in_loop=not args.surfaces_only, context=context,
                  mesh=args.mesh, **({"fixed": fixed} if fixed else {}), **({"free": tuple(args.free)} if args.free else {}), **({"priors": priors} if priors else {}))
    prov = command_provenance(args, list(args.data), leave_out=("data", "out"))
    written = write_plan(result, args.out, provenance=prov)
    files = [str(p) for p in written["curves"]] + ([str(written["figure"])] if written["figure"] else [])
    if args.json:
        print(dumps({**result.to_dict(), "files": files, "provenance": prov}))
    else:
        print(result.report())
        for f in files:
            print(f"wrote: {f}")
    return 0
