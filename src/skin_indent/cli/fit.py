"""``skin-indent fit``: one curve, a model of the user's choice, or a batch of files, folders and force maps."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .options import (EXIT_FLAGGED, EXIT_OK, CLIError, command_provenance, number_or_numbers, one_value, parse_fix,
                      parse_priors, parse_start, parse_window, per_file, positive_radius, progress_of, sample_curves)


def add_fit(sub):
    p = sub.add_parser("fit", help="identify E and nu from a measured curve",
                       description="Fit a model (default the neo-Hookean half-space) to a measured curve, every "
                                   "segment, as diagnose fits it; --method ekf-paper|ekf, --window, --start, --tol, "
                                   "--surface or --contact ask for the paper's identification (the loading segment). "
                                   "Reads CSV with depth_mm|depth_um|depth_nm|depth_m, "
                                   "force_mN|force_N|force_uN|force_nN, optional time_s; or an instrument file "
                                   "such as JPK .jpk-force with the optional afmformats package.) A curve that "
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
                   help="mesh of the finite-element runs behind a built surface (default coarse, as diagnose; medium "
                        "for the paper's identification and a batch)")
    p.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT", help="fit on this Dask scheduler")
    p.add_argument("--method", choices=("ekf-paper", "ekf", "lsq"), default=None,
                   help="ekf-paper: the paper's filter; ekf: better-conditioned filter (both the paper's identification); lsq: "
                        "least squares (default)")
    p.add_argument("--surface", type=Path, default=None,
                   help="response surface file (default: cache, built if needed); a neo-Hookean surface of another "
                        "radius is rescaled by similarity")
    p.add_argument("--window", default=None,
                   help="indentation depth window MIN:MAX in mm past the contact point (e.g. 0.05:0.6): the paper's "
                        "identification of the loading segment")
    p.add_argument("--radius", type=number_or_numbers, default=None, metavar="MM[,MM...]",
                   help="sphere radius, mm (default: the file's, else the skin sphere 6.22; AFM: e.g. 0.0275); with "
                        "--sample one per file, in order")
    p.add_argument("--sample", action="store_true",
                   help="the files are curves of ONE sample measured several ways (two spheres, two depths, two "
                        "speeds, a ramp and a hold), fitted together: the material's parameters shared, each curve "
                        "with its own sphere, contact point (offset_mm[2]...) and noise (the model path: --model, "
                        "default neo-hooke)")
    p.add_argument("--start", default=None, help="start values E,nu (default: a Hertz estimate at nu = 0.4)")
    p.add_argument("--model", default=None, metavar="neo-hooke[+EFFECT...]",
                   help="fit this model, e.g. neo-hooke+layer+layer (two bonded layers) or neo-hooke+stiffening: "
                        "every segment, the diagnosis's fit (response surfaces, or finite elements in the loop where "
                        "none covers the model), least squares; default neo-hooke (the same fit)")
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
    p.add_argument("--noise", type=number_or_numbers, default=None, metavar="MN[,MN...]",
                   help="noise standard deviation of a raw sample, mN (default: from the data); with --sample one per "
                        "file")
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
                   help="write the settings of this run as a profile (TOML for a .toml name, else JSON), once the "
                        "fit has succeeded (with several curves: once any curve was fitted); a failed fit writes none")
    p.set_defaults(run=_run_fit)


def _fit_settings(args, fixed, window, priors=None) -> dict:
    """The settings of a fit as its provenance records them (a profile: :mod:`skin_indent.fitting.profile`)."""
    out = {"radius_mm": args.radius, "window_mm": window, "method": args.method, "mesh": args.mesh,
           "fixed": fixed, "free": list(args.free), "contact": args.contact, "index": args.index,
           "noise_mN": args.noise, "x0": None if args.start is None else parse_start(args.start), "tol": args.tol,
           "surface": None if args.surface is None else str(args.surface)}
    if args.model is not None or priors:
        out.update(model=args.model or "neo-hooke", priors={k: list(v) for k, v in (priors or {}).items()})
    return out


def _apply_profile(args) -> None:
    """Fill the fit options not given on the command line from ``--profile``, then the defaults."""
    from ..fitting.profile import read_profile

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
    from ..runtime.context import Context
    from ..measurement import load_curves

    _apply_profile(args)
    positive_radius(args.radius)
    if args.sample:
        return _fit_sample(args)
    args.radius = one_value(args.radius, "--radius")
    args.noise = one_value(args.noise, "--noise")
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    missing = [str(path) for path in args.data if not path.exists()]
    if missing:  # a user error (exit 2), not a failed curve
        raise CLIError(f"no such file or folder: {', '.join(missing)}")
    priors = parse_priors(args.prior)
    chosen = args.model is not None or bool(priors)
    fixed = parse_fix(args.fix, any_name=chosen)
    if args.free and (chosen or "nu" in fixed):
        raise CLIError("--free nu: " + ("a --model/--prior fit fits nu unless --fix holds it" if chosen else
                                        "nu is also held with --fix; give one of them"))
    if chosen:
        from ..fitting.model_fit import parse_model

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
    window = parse_window(args.window) if args.window else None
    if args.save_profile is not None and not args.save_profile.absolute().parent.is_dir():
        raise CLIError(f"--save-profile {args.save_profile}: no such folder {args.save_profile.absolute().parent}")
    x0 = parse_start(args.start) if args.start else None
    surface = None
    if args.surface is not None:
        from ..response_surface import ResponseSurface

        if not args.surface.is_file():
            raise CLIError(f"surface file not found: {args.surface}")
        surface = ResponseSurface.load(args.surface)
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args, off=args.json))
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


def _fit_sample(args) -> int:
    """Several files, one sample: one model fitted to every curve together (one curve per file, or
    ``--index N`` of each)."""
    from ..fitting import fit
    from ..fitting.model_fit import parse_model
    from ..runtime.context import Context

    given = [o for o, v in (("--out", args.out), ("--window", args.window), ("--start", args.start),
                            ("--surface", args.surface), ("--tol", args.tol), ("--profile", args.profile),
                            ("--save-profile", args.save_profile), ("--recursive", args.recursive or None),
                            ("--free", args.free or None),
                            ("--contact", None if args.contact == "auto" else args.contact),
                            ("--method", None if args.method == "lsq" else args.method)) if v is not None]
    if given:
        raise CLIError(f"{', '.join(given)}: not taken with --sample (the curves are prepared as diagnose prepares "
                       "them and fitted together by least squares; --plot DIR and --json write the result)")
    if args.scheduler is not None and args.workers is not None:
        raise CLIError("--workers sets local processes; with --scheduler the Dask cluster decides")
    model = args.model or "neo-hooke"
    parse_model(model)  # one line for a bad model before any file is read
    n = len(args.data)
    radii, noise = per_file(args.radius, n, "--radius"), per_file(args.noise, n, "--noise")
    curves = sample_curves(args, "fits")
    fixed, priors = parse_fix(args.fix, any_name=True), parse_priors(args.prior)
    context = Context(workers=args.workers, scheduler=args.scheduler, progress=progress_of(args, off=args.json))
    result = fit(curves, model=model, fixed=fixed or None, priors=priors or None, noise_mN=noise, context=context,
                 mesh=args.mesh or "coarse")
    settings = {"model": model, "radius_mm": radii, "noise_mN": noise, "fixed": fixed,
                "priors": {k: list(v) for k, v in priors.items()}, "mesh": args.mesh or "coarse", "index": args.index,
                "sample": True}
    prov = command_provenance(args, list(args.data), settings)
    return _fit_output(args, " + ".join(str(p) for p in args.data), "+".join(p.stem for p in args.data), result,
                       prov)


def _fit_one(args, measurement, surface, fixed, window, x0, context) -> int:
    """One curve: the report (or JSON), errors as one line (exit 2), flags as warnings."""
    from ..fitting import fit
    from ..measurement import prepare

    from ..fitting.one_fit import paper_identification, paper_needed

    paper = paper_identification(args.method, window=window, contact=args.contact, surface=surface, x0=x0,
                                 tol=args.tol) or paper_needed(measurement, fixed=fixed, radius_mm=args.radius,
                                                               model=args.model, priors=args.priors)
    if not paper:
        from ..fitting.model_fit import prepare_curve

        prepared = prepare_curve(measurement, radius_mm=args.radius)
    else:
        prepared = prepare(measurement, window=window, contact=args.contact, contact_mm=fixed.get("offset_mm"),
                           radius_mm=args.radius)
    path = args.data[0]
    if not args.json:
        from ..measurement.scale import display_units

        data, u = prepared.data, display_units(prepared.radius_mm)
        what = "loading points" if paper else "points"
        print(f"data: {path} ({data.n_points} {what} from {data.depth_mm.min() * u.per_mm:.4g} to "
              f"{data.depth_mm.max() * u.per_mm:.4g} {u.length}), sphere R = {prepared.radius_mm * u.per_mm:g} "
              f"{u.length} ({prepared.radius_source})"
              + ("; the paper's identification" if paper else f"; model {args.model or 'neo-hooke'}"), flush=True)
    if not paper:
        result = fit(prepared, model=args.model or "neo-hooke", fixed=fixed, priors=args.priors,
                     noise_mN=args.noise, context=context, mesh=args.mesh, free=args.free)
        settings = _fit_settings(args, fixed, window, args.priors)
        code = _fit_output(args, path, path.stem, result,
                           command_provenance(args, _fit_inputs(args), settings, result.surface))
        if result.success:
            _save_profile(args, settings)
        return code
    if surface is not None:
        r_surface = surface.settings.get("radius_mm")
        if r_surface is not None and abs(r_surface - prepared.radius_mm) > 1e-9 * prepared.radius_mm:
            try:
                surface = surface.at_radius(prepared.radius_mm)
            except ValueError:
                raise CLIError(f"the surface is for a sphere of R = {r_surface:g} mm, the measurement for "
                               f"{prepared.radius_mm:g} mm") from None
    result = fit(prepared, surface, args.method, window=window, contact=args.contact, fixed=fixed, x0=x0, tol=args.tol,
                 noise_mN=args.noise, context=context, mesh=args.mesh, free=args.free)
    settings = _fit_settings(args, fixed, window)
    code = _fit_output(args, path, path.stem, result,
                           command_provenance(args, _fit_inputs(args), settings, result.surface))
    if result.success:  # a failed fit leaves no profile
        _save_profile(args, settings)
    return code


def _save_profile(args, settings) -> None:
    """``--save-profile``: the settings of a fit that ran, written atomically (called only after success)."""
    if args.save_profile is None:
        return
    from ..fitting.profile import write_profile

    write_profile(settings, args.save_profile)
    if not args.json:
        print(f"wrote the profile of this fit to {args.save_profile}")


def _fit_inputs(args) -> list:
    """The files a fit reads: the data, and the profile and surface file when given."""
    return [*args.data, *(p for p in (args.profile, args.surface) if p is not None)]


def _fit_output(args, label, stem, result, prov) -> int:
    """Write the figure and table (``STEM.png``, ``STEM.csv``), print the report or JSON and the flags
    (each line starting with ``label``: the file, or the files of a sample); the exit status."""
    from ..measurement.scale import display_units, shown_in
    from ..runtime.json_io import dumps
    from ..runtime.provenance import with_provenance

    if args.plot is not None:
        from ..report.fit_figure import plot_fit, write_fit_csv

        args.plot.mkdir(parents=True, exist_ok=True)
        figure = plot_fit(result, args.plot / f"{stem}.png", provenance=prov)
        table = write_fit_csv(result, args.plot / f"{stem}.csv", prov)
    if args.json:
        print(dumps(with_provenance(result.to_dict(), prov)))
    else:
        print(result.report())
        if args.plot is not None:
            print(f"wrote {figure} and {table}")
    units = display_units(result.curves[0]["radius_mm"])
    for flag in result.flags:
        print(f"skin-indent fit: warning: {label}: {shown_in(flag, units)}", file=sys.stderr)
    if not result.success:  # a failed fit (exit 3 as a flagged one), said on stderr
        print(f"skin-indent fit: warning: {label}: {_not_converged(result)}", file=sys.stderr)
        return EXIT_FLAGGED
    return EXIT_FLAGGED if (args.strict and result.flags) else EXIT_OK


def _not_converged(result) -> str:
    """Why a fit is not a result, in one line with the next step (the flags above say it per parameter)."""
    why = getattr(result, "message", "")
    why = f" ({why})" if why else ""
    return (f"the fit did not converge{why}: its values are where it stopped, not a result; next: "
            "hold a parameter you know (--fix NAME=VALUE) or weigh it (--prior NAME=MEAN:SD), or fit a simpler "
            "model (the flags above name the parameters)")


def _fit_batch(args, surface, fixed, window, x0, context) -> int:
    """Every curve of every file: one line (or TSV row) per curve; a bad file is a row, never the end."""
    from ..measurement.scale import display_units, shown_in
    from ..runtime.json_io import dumps
    from ..batch import fit_many
    from ..report.batch_table import row_line, summary_figure, write_tsv

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
        from ..runtime.provenance import file_identity

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
        units = display_units(r.radius_mm)
        for flag in r.flags:
            print(f"skin-indent fit: warning: {r.label}: {shown_in(flag, units)}", file=sys.stderr)
    if len(rows) > rows.n_failed:  # a batch where no curve could be fitted leaves no profile
        _save_profile(args, _fit_settings(args, fixed, window, args.priors))
    strict = True if args.strict is None else args.strict
    return EXIT_FLAGGED if (strict and not rows.trusted) else EXIT_OK

