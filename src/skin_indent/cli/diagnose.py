"""``skin-indent diagnose``: where the model fails, which effect is missing, the ladder."""

from __future__ import annotations

from pathlib import Path

from .options import (CLIError, command_provenance, number_or_numbers, one_value, parse_fix, parse_priors, per_file,
                      positive_radius, progress_of)


def add_diagnose(sub):
    from ..effects import EFFECTS

    p = sub.add_parser("diagnose", help="compare model and measurement, name the missing physical effect",
                       description="Fit the neo-Hookean half-space to every segment of a measured curve, test "
                                   "whether the residual is noise, rank the missing effects by BIC, add the "
                                   "best and diagnose again on top until the residual is noise or nothing "
                                   "helps (a ladder; --add builds rungs by hand). With --sample, several files are "
                                   "curves of one sample (two spheres, two depths, two speeds, a ramp and a hold) "
                                   "diagnosed together: the material shared, each curve with its own sphere, contact "
                                   "point and noise.")
    p.add_argument("data", type=Path, nargs="+", help="measurement CSV (time_s optional) or instrument file; several "
                                                      "with --sample")
    p.add_argument("--sample", action="store_true",
                   help="the files are curves of ONE sample measured several ways, diagnosed together: the ladder, "
                        "BIC and verdict on all curves at once, every rung with the RMS of each curve")
    p.add_argument("--fix", action="append", default=[], metavar="NAME=VALUE",
                   help="hold a parameter you know, by the name results report (repeatable), e.g. --fix "
                        "thickness_mm=1.2: in every model that has it")
    p.add_argument("--prior", action="append", default=[], metavar="NAME=MEAN:SD",
                   help="a Gaussian prior from an independent measurement (repeatable), e.g. --prior "
                        "thickness_mm=1.2:0.1 (a dermis thickness from ultrasound): in every model that has it; the "
                        "report says whether the data or the prior determined it")
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
    p.add_argument("--noise", type=number_or_numbers, default=None, metavar="MN[,MN...]",
                   help="noise standard deviation, mN (default: from the data); with --sample one per file")
    p.add_argument("--segments", default="approach,hold,retract",
                   help="kinds of motion to diagnose (default all; only trailing ones can be left out)")
    p.add_argument("--radius", type=number_or_numbers, default=None, metavar="MM[,MM...]",
                   help="sphere radius, mm (default: the file's # radius_mm/radius_um comment or instrument header, "
                        "else the skin sphere 6.22); with --sample one per file, in order")
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
    from ..runtime.json_io import dumps
    from ..runtime.context import Context
    from ..diagnosis import diagnose
    from ..report import write_report
    from ..measurement import load_curve

    positive_radius(args.radius)
    missing = [str(path) for path in args.data if not path.exists()]
    if missing:
        raise CLIError(f"no such file or folder: {', '.join(missing)}")
    if args.sample and len(args.data) < 2:
        raise CLIError("--sample diagnoses several files as curves of one sample: give at least two")
    if len(args.data) > 1 and not args.sample:
        raise CLIError("several files: --sample diagnoses them together as curves of one sample")
    model = args.model.split("+")
    if model[0] != "neo-hooke":
        raise CLIError(f"--model must start with neo-hooke (the base law), got {args.model!r}")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    add = [*model[1:], *args.add]
    candidates = [c.strip() for c in args.candidates.split(",") if c.strip()]
    n = len(args.data)
    if args.sample:
        radii, noise = per_file(args.radius, n, "--radius"), per_file(args.noise, n, "--noise")
        measurement = [load_curve(path, radius_mm=r) for path, r in zip(args.data, radii or [None] * n)]
    else:
        noise = one_value(args.noise, "--noise")
        measurement = load_curve(args.data[0], radius_mm=one_value(args.radius, "--radius"))
    fixed, priors = parse_fix(args.fix, any_name=True), parse_priors(args.prior)
    segments = tuple(x.strip() for x in args.segments.split(",") if x.strip())
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args, off=args.json))
    if args.max_rungs < 0:
        raise CLIError(f"--max-rungs must be >= 0, got {args.max_rungs}")
    diag = diagnose(measurement, candidates=candidates, add=add, noise_mN=noise, segments=segments,
                    max_rungs=args.max_rungs, in_loop=not args.surfaces_only, context=context, mesh=args.mesh,
                    fixed=fixed or None, priors=priors or None)
    prov = command_provenance(args, list(args.data), leave_out=("data", "report"), surface=diag.surfaces)
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

