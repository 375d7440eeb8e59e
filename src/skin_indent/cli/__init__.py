"""Command-line interface: ``skin-indent COMMAND ...``, one module per command.

A thin front end over the Python API. Every error a user can cause (bad numbers,
bad files, a model that does not converge) ends in a one-line message on stderr
and exit status 2, never a traceback; the exit statuses of every command are
:data:`EXIT_STATUS`. Messages of long phases go to stderr through the ``skin_indent``
logger (:mod:`skin_indent.runtime.log`; ``-v``/``-q`` on every command), progress bars
only to a terminal unless ``--progress`` asks for them.

- :mod:`.options`: what every command shares (exit statuses, one-line errors, option parsers);
- :mod:`.simulate`, :mod:`.surface`, :mod:`.fit`, :mod:`.diagnose`, :mod:`.plan`, :mod:`.demo`: each command's
  arguments and its runner.
"""

from __future__ import annotations

import argparse
import sys

from .demo import add_demo
from .diagnose import add_diagnose
from .fit import add_fit
from .plan import add_plan
from .options import (EXIT_FLAGGED, EXIT_INTERRUPTED, EXIT_OK, EXIT_STATUS, EXIT_USER_ERROR, FIX_ALIASES, CLIError,
                      parse_fix, parse_priors)
from .simulate import MATERIALS, add_simulate
from .surface import add_surface

__all__ = ["EXIT_FLAGGED", "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_STATUS", "EXIT_USER_ERROR", "FIX_ALIASES", "MATERIALS",
           "CLIError", "build_parser", "main", "parse_fix", "parse_priors"]


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


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(prog="skin-indent", description="Sphere indentation of skin: simulate, "
                                     "identify material parameters, diagnose missing physics. Units: mm, kPa, mN, s.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    add_demo(sub)
    add_simulate(sub)
    add_surface(sub)
    add_fit(sub)
    add_diagnose(sub)
    add_plan(sub)
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
    from ..runtime.log import cli_logging

    try:
        from ..runtime.threads import configure_threads

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
        from ..response_surface import DASK_MISSING

        if str(err) != DASK_MISSING:
            raise
        print(f"skin-indent {args.command}: error: {err}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print(f"skin-indent {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


