"""``skin-indent diagnose``: where the model fails, which effect is missing, the ladder; one curve or many.

One file with one curve (or ``--index N``) and no ``--out``: the diagnosis of that curve, as
text, JSON (``--json``) and an HTML report (``--report``). Several files with ``--sample``: the
curves of ONE sample, diagnosed together (:func:`skin_indent.diagnosis.diagnose` with a list),
reported as one curve is. Several files without it, a folder, a file with several curves (a force
map) or ``--out``: a batch (:func:`skin_indent.diagnosis.diagnose_many`), one line and one TSV row
per curve, figures with ``--plot``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .options import (EXIT_FLAGGED, EXIT_OK, CLIError, command_provenance, number_or_numbers, one_value, parse_fix,
                      parse_priors, per_file, positive_radius, progress_of, sample_curves)

#: what a batch is, as --help says it
BATCH = ("Several files, a folder, a file with several curves (a force map) or --out: every curve is diagnosed "
         "(--workers local processes, or a Dask cluster with --scheduler; each curve's finite-element work runs "
         "in its worker), one line per curve and, with --out, one TSV row per curve with a provenance header; a "
         "curve that cannot be read or diagnosed is a row with its error, never the end of the batch.")


def add_diagnose(sub):
    from ..effects import EFFECTS

    p = sub.add_parser("diagnose", help="compare model and measurement, name the missing physical effect",
                       description="Fit the neo-Hookean half-space to every segment of a measured curve, test "
                                   "whether the residual is noise, rank the missing effects by BIC, add the "
                                   "best and diagnose again on top until the residual is noise or nothing "
                                   "helps (a ladder; --add builds rungs by hand). With --sample, several files are "
                                   "curves of one sample (two spheres, two depths, two speeds, a ramp and a hold) "
                                   "diagnosed together: the material shared, each curve with its own sphere, contact "
                                   "point and noise. " + BATCH)
    p.add_argument("data", type=Path, nargs="+",
                   help="measurement CSV (time_s optional) or instrument file; several files, folders or a force "
                        "map are diagnosed as a batch (several files of one sample: --sample)")
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
    p.add_argument("--free", action="append", default=[], choices=("nu",),
                   help="fit a parameter the scale's convention holds: --free nu fits nu at AFM scale (sphere "
                        "radius < 0.5 mm), where every model holds it at 0.49, the nearly incompressible end of "
                        "the surfaces, as the field holds nu = 0.5")
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
                   help="noise standard deviation, mN (default: from the data; in a batch, for every curve); with "
                        "--sample one per file")
    p.add_argument("--segments", default="approach,hold,retract",
                   help="kinds of motion to diagnose (default all; only trailing ones can be left out)")
    p.add_argument("--radius", type=number_or_numbers, default=None, metavar="MM[,MM...]",
                   help="sphere radius, mm (default: the file's # radius_mm/radius_um comment or instrument header, "
                        "else the skin sphere 6.22); with --sample one per file, in order")
    p.add_argument("--mesh", choices=("coarse", "medium", "fine"), default="coarse",
                   help="mesh of the finite-element runs behind the surfaces (default coarse: within 0.03%% of "
                        "medium, below the 0.3%% model error that diagnosis allows)")
    p.add_argument("--workers", type=int, default=None,
                   help="local processes: one curve each in a batch (default: all cores), else the surface builds "
                        "and finite-element runs of the one diagnosis")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="Dask scheduler: the curves of a batch are diagnosed on its workers (else the surface "
                        "builds of the one diagnosis run there)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--report", type=Path, default=None, metavar="DIR",
                   help="one curve: write an HTML page with embedded figures and the PNG figures into DIR")
    batch = p.add_argument_group("many curves", BATCH)
    batch.add_argument("--out", type=Path, default=None, metavar="FILE.tsv",
                       help="write one TSV row per curve (verdict, final model, its parameters with sd, misfit, "
                            "whiteness, explained, provisional), with a provenance header; makes a batch even of "
                            "one curve")
    batch.add_argument("--plot", type=Path, default=None, metavar="DIR",
                       help="write verdicts.png (verdict, misfit and E of the final model per curve), NAME_map.png "
                            "per force map (the same over the map, a pixel per curve) and each curve's HTML report "
                            "(DIR/NAME_INDEX/index.html) into DIR")
    batch.add_argument("--index", type=int, default=None, metavar="N",
                       help="diagnose only curve N (from 0) of each file (one file: that curve alone, as one "
                            "curve, unless --out)")
    batch.add_argument("--recursive", "-r", action="store_true",
                       help="search folders and their subfolders (default: the files directly in each folder)")
    batch.add_argument("--strict", action=argparse.BooleanOptionalAction, default=None,
                       help="exit with status 3 when a curve could not be read or diagnosed (default on in a batch)")
    p.set_defaults(run=_run_diagnose)


def _settings(args) -> dict:
    """The keywords of :func:`~skin_indent.diagnosis.diagnose` (and of ``diagnose_many``) from the
    options, each checked with a one-line error."""
    from ..measurement import SEGMENTS

    positive_radius(args.radius)
    model = args.model.split("+")
    if model[0] != "neo-hooke":
        raise CLIError(f"--model must start with neo-hooke (the base law), got {args.model!r}")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    if args.max_rungs < 0:
        raise CLIError(f"--max-rungs must be >= 0, got {args.max_rungs}")
    segments = tuple(x.strip() for x in args.segments.split(",") if x.strip())
    unknown = [s for s in segments if s not in SEGMENTS]
    if unknown or not segments:
        raise CLIError(f"--segments must be some of {','.join(SEGMENTS)}, got {args.segments!r}")
    noise = per_file(args.noise, len(args.data), "--noise") if args.sample else one_value(args.noise, "--noise")
    out = {"candidates": [c.strip() for c in args.candidates.split(",") if c.strip()],
           "add": [*model[1:], *args.add], "noise_mN": noise, "segments": segments,
           "max_rungs": args.max_rungs, "in_loop": not args.surfaces_only, "mesh": args.mesh}
    fixed, priors = parse_fix(args.fix, any_name=True), parse_priors(args.prior)
    if "nu" in args.free and "nu" in fixed:
        raise CLIError(f"--free nu and --fix nu={fixed['nu']:g}: give one of them")
    if args.free:
        out["free"] = tuple(args.free)
    if fixed:
        out["fixed"] = fixed
    if priors:
        out["priors"] = priors
    return out


def _run_diagnose(args) -> int:
    from ..runtime.context import Context

    settings = _settings(args)
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args, off=args.json))
    if args.sample:
        return _diagnose_one(args, _sample_curves(args), settings, context)
    args.radius = one_value(args.radius, "--radius")
    measurement = _one_curve(args)
    if measurement is not None:
        return _diagnose_one(args, measurement, settings, context)
    return _diagnose_batch(args, settings, context)


def _one_curve(args):
    """The measurement of a single diagnosis (one file of one curve, or ``--index``, and no ``--out``),
    else None: a batch."""
    from ..measurement import load_curve

    path = args.data[0]
    if len(args.data) > 1 or args.out is not None or path.is_dir():
        return None
    measurement = load_curve(path, radius_mm=args.radius, index=args.index or 0)  # one line for a bad file
    n_curves = measurement.columns.get("reader", {}).get("n_curves", 1) if isinstance(measurement.columns, dict) else 1
    if args.index is None and n_curves > 1:
        return None  # a force map
    return measurement


def _sample_curves(args) -> list:
    """The curves of one sample (``--sample``: :func:`~.options.sample_curves`)."""
    given = [o for o, v in (("--out", args.out), ("--recursive", args.recursive or None)) if v is not None]
    if given:
        raise CLIError(f"{', '.join(given)}: for a batch of samples; --sample diagnoses the files as one sample "
                       "(--report DIR writes its page)")
    return sample_curves(args, "diagnoses")


def _diagnose_one(args, measurement, settings, context) -> int:
    """One curve: the report (or JSON), the HTML page; errors as one line (exit 2)."""
    from ..diagnosis import diagnose
    from ..report import write_report
    from ..runtime.json_io import dumps

    for option, value in (("--plot", args.plot), ("--recursive", args.recursive or None)):
        if value is not None:
            raise CLIError(f"{option}: for a batch (several curves or --out); one curve's figures: --report DIR")
    diag = diagnose(measurement, context=context, **settings)
    inputs = list(args.data) if args.sample else [args.data[0]]
    prov = command_provenance(args, inputs, leave_out=("data", "report"), surface=diag.surfaces)
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
    return EXIT_OK


def _diagnose_batch(args, settings, context) -> int:
    """Every curve of every file: one line (and TSV row) per curve; a bad curve is a row, never the end."""
    from ..diagnosis import diagnose_many
    from ..report.batch_table import write_tsv
    from ..report.verdict_map import verdict_line, write_batch_figures, write_curve_report
    from ..runtime.json_io import dumps

    missing = [str(path) for path in args.data if not path.exists()]
    if missing:  # a user error (exit 2), not a failed curve
        raise CLIError(f"no such file or folder: {', '.join(missing)}")
    if args.recursive and not any(path.is_dir() for path in args.data):
        raise CLIError("--recursive searches folders: give a folder")
    if args.report is not None:
        raise CLIError("--report DIR is for one curve; in a batch --plot DIR writes each curve's report")
    on_row = None
    if args.plot is not None:
        args.plot.mkdir(parents=True, exist_ok=True)

        def on_row(row, provenance):  # each curve's report as it arrives, while the others are diagnosed
            return write_curve_report(row, args.plot, provenance)

    rows = diagnose_many(args.data, index=args.index, radius_mm=args.radius, context=context,
                         progress=context.progress, recursive=args.recursive, command=args.command_line,
                         on_row=on_row, **settings)
    if args.out is not None:
        write_tsv(rows, args.out)
    if args.plot is not None:
        write_batch_figures(rows, args.plot)
    if args.json:
        print(dumps({"rows": [r.to_dict() for r in rows], "provenance": rows.provenance}))
    else:
        for r in rows:
            print(verdict_line(r))
        print(f"{len(rows)} curves: {rows.n_failed} failed; verdicts: "
              + ", ".join(f"{v} {n}" for v, n in rows.verdicts().items())
              + (f"; wrote {args.out}" if args.out is not None else "")
              + (f"; figures and reports in {args.plot}" if args.plot is not None else ""))
    for r in rows:
        for flag in r.flags:
            print(f"skin-indent diagnose: warning: {r.label}: {flag}", file=sys.stderr)
    strict = True if args.strict is None else args.strict
    return EXIT_FLAGGED if (strict and not rows.trusted) else EXIT_OK
