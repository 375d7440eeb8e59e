"""``skin-indent diagnose``: where the model fails, which effect is missing, the ladder."""

from __future__ import annotations

from pathlib import Path

from .options import CLIError, positive_radius, progress_of, command_provenance

def add_diagnose(sub):
    from ..effects import EFFECTS

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
    from ..runtime.json_io import dumps
    from ..runtime.context import Context
    from ..diagnosis import diagnose
    from ..report import write_report
    from ..measurement import load_curve

    positive_radius(args.radius)
    model = args.model.split("+")
    if model[0] != "neo-hooke":
        raise CLIError(f"--model must start with neo-hooke (the base law), got {args.model!r}")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    add = [*model[1:], *args.add]
    candidates = [c.strip() for c in args.candidates.split(",") if c.strip()]
    measurement = load_curve(args.data, radius_mm=args.radius)
    segments = tuple(x.strip() for x in args.segments.split(",") if x.strip())
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args, off=args.json))
    if args.max_rungs < 0:
        raise CLIError(f"--max-rungs must be >= 0, got {args.max_rungs}")
    diag = diagnose(measurement, candidates=candidates, add=add, noise_mN=args.noise, segments=segments,
                    max_rungs=args.max_rungs, in_loop=not args.surfaces_only, context=context, mesh=args.mesh)
    prov = command_provenance(args, [args.data], leave_out=("data", "report"), surface=diag.surfaces)
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

