"""What every command shares: the exit statuses, one-line user errors, parsers of the options
(``--fix``, ``--prior``, ``--window``, ``--start``), progress and provenance."""

from __future__ import annotations

import argparse
import sys

import numpy as np

#: the exit statuses of every command
EXIT_OK, EXIT_USER_ERROR, EXIT_FLAGGED, EXIT_INTERRUPTED = 0, 2, 3, 130


#: the epilog of every command's --help: messages and exit statuses, said once
EXIT_STATUS = ("Messages: the phases of long work (surface builds, batches, the rungs of a diagnosis) as one line "
               "each on stderr; -v adds details, -q keeps only warnings and errors (a clean run with -q leaves "
               "stderr empty). Progress bars only when stderr is a terminal (--progress, --no-progress). "
               "Results go to stdout. "
               "Exit status: 0 done; 2 a user error (a bad option or value, a missing or malformed file, a "
               "model that does not converge), one line on stderr; 3 a curve failed or was flagged as not to be "
               "trusted (fit: with --strict, the default for several curves; a single fit that fails always), a curve "
               "of a batch of diagnoses failed (diagnose: with --strict, the default of a batch) or a "
               "finite-element run of a surface build failed; 130 interrupted (Ctrl-C).")


class CLIError(Exception):
    """A user error, reported in one line."""


def numbers(text: str, count: int, what: str) -> list[float]:
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        raise CLIError(f"{what} must be {count} comma-separated numbers, got {text!r}")
    return values


def parse_window(text: str) -> tuple[float, float]:
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


def parse_fix(items, any_name: bool = False) -> dict[str, float]:
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


def parse_priors(items) -> dict[str, tuple[float, float]]:
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


def parse_start(text):
    try:
        E, nu = (float(x) for x in text.split(","))
    except ValueError:
        raise CLIError(f"--start must be E,nu (e.g. 10,0.3), got {text!r}") from None
    return np.array([E, nu])


def positive_radius(radius):
    for r in (radius if isinstance(radius, tuple) else (radius,)):
        if r is not None and not (np.isfinite(r) and r > 0):
            raise CLIError(f"--radius must be a positive number of mm, got {r:g}")


def number_or_numbers(text: str):
    """An option's value: one number, or several comma-separated (one per file of a sample: a tuple)."""
    try:
        values = tuple(float(x) for x in str(text).split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or comma-separated numbers, got {text!r}") from None
    return values[0] if len(values) == 1 else values


def per_file(value, n: int, option: str):
    """``value`` of an option for ``n`` files of one sample: None, one for all, or one per file (a list)."""
    if not isinstance(value, tuple):
        return value
    if len(value) != n:
        raise CLIError(f"{option}: {len(value)} values for {n} files (give one, or one per file in order)")
    return list(value)


def one_value(value, option: str):
    """``value`` where one number is needed (several values only go with --sample)."""
    if isinstance(value, tuple):
        raise CLIError(f"{option}: several values ({', '.join(f'{v:g}' for v in value)}) go with --sample, one per "
                       "file of the sample; give one number")
    return value


def command_provenance(args, inputs, settings=None, surface=None, leave_out=()):
    """The provenance of a command's output: its command line, inputs and settings (default its options)."""
    from ..runtime.provenance import provenance

    if settings is None:
        settings = {k: v for k, v in vars(args).items()
                    if k not in ("run", "command", "command_line", "json", "workers", "scheduler", *leave_out)}
    return provenance(command=getattr(args, "command_line", None), inputs=inputs, settings=settings,
                      surface=surface)


def progress_of(args, off: bool = False):
    """Progress bars: --progress/--no-progress if given, off with -q (or ``off``), else None (a terminal only)."""
    if args.progress is not None:
        return args.progress
    return False if (args.quiet or off) else None


def missing_subcommand(parser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_USER_ERROR


def sample_curves(args, verb: str) -> list:
    """The curves of one sample (``--sample``): one curve per file (or ``--index N`` of each), each with its
    own sphere radius (``--radius`` one per file, else each file's); one-line errors for fewer than two
    files, a missing file, a folder (a batch of samples) or a file of several curves without ``--index``.

    ``verb``: what the command does with them (``"fits"``, ``"diagnoses"``), for the messages.
    """
    from ..measurement import load_curves

    if len(args.data) < 2:
        raise CLIError(f"--sample {verb} several files as curves of one sample: give at least two")
    missing = [str(path) for path in args.data if not path.exists()]
    if missing:
        raise CLIError(f"no such file or folder: {', '.join(missing)}")
    folders = [str(path) for path in args.data if path.is_dir()]
    if folders:
        raise CLIError(f"{', '.join(folders)}: a folder is a batch of samples; --sample takes the files of one "
                       "sample")
    n = len(args.data)
    radii = per_file(args.radius, n, "--radius")
    out = []
    for path, r in zip(args.data, radii if isinstance(radii, list) else [radii] * n):
        found = load_curves(path, radius_mm=r)
        if len(found) > 1 and args.index is None:
            raise CLIError(f"{path}: {len(found)} curves; --index N picks the one of this sample")
        k = args.index or 0
        if not 0 <= k < len(found):
            raise CLIError(f"{path}: --index {k} is out of range (the file has {len(found)} curve(s))")
        out.append(found[k])
    return out

