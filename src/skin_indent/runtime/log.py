"""Messages and progress bars of long phases: the ``skin_indent`` logger, and tqdm only where it helps.

The package logs through the standard :mod:`logging` module: every module takes
``logging.getLogger(__name__)``, all under the ``skin_indent`` logger, which has only a
:class:`logging.NullHandler` (a library never configures output on import). What is
logged:

- INFO: the start of each long phase (a surface build: how many finite-element runs,
  how many cached; a batch: how many curves, on how many workers; a rung of the
  diagnosis: which fit, on surfaces or with finite elements in the loop);
- DEBUG: details (cache folders, single runs);
- WARNING: what the user must know (a failed run, a flagged fit).

A program shows them with :func:`cli_logging` (the ``skin-indent`` command does), or with
any handler of its own::

    import logging
    logging.basicConfig(level=logging.INFO)

Progress bars (:func:`progress_bar`) are drawn when asked (``progress=True``), never when
``progress=False``, and with ``progress=None`` only when stderr is a terminal, so that a
redirected stderr never fills with carriage-return updates.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import warnings

ROOT = "skin_indent"  # its NullHandler is added by the package's __init__

#: verbosity of the command line -> level of the ``skin_indent`` logger
LEVELS = {-1: logging.WARNING, 0: logging.INFO, 1: logging.DEBUG}


class _StderrHandler(logging.Handler):
    """Write each record as ``skin-indent CMD: [warning: ]message`` to the *current* ``sys.stderr``.

    The stream is looked up at each record (not bound once), so that a replaced
    ``sys.stderr`` (tests, a GUI) receives the lines. While a tqdm bar is drawn the line
    goes through :meth:`tqdm.tqdm.write`, so that it does not tear the bar.
    """

    def __init__(self, prog: str):
        super().__init__()
        self.prog = prog

    def format(self, record: logging.LogRecord) -> str:
        message = " ".join(str(record.getMessage()).split())
        kind = {logging.WARNING: "warning: ", logging.ERROR: "error: ", logging.CRITICAL: "error: "}.get(
            record.levelno, "")
        return f"{self.prog}: {kind}{message}"

    def emit(self, record: logging.LogRecord) -> None:
        try:
            line = self.format(record)
            tqdm = sys.modules.get("tqdm")
            bars = getattr(getattr(tqdm, "tqdm", None), "_instances", None) if tqdm else None
            if bars:
                tqdm.tqdm.write(line, file=sys.stderr)
            else:
                sys.stderr.write(line + "\n")
                sys.stderr.flush()
        except Exception:  # noqa: BLE001 - logging must never end the program
            self.handleError(record)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """:func:`warnings.showwarning` of the command line: one line through the logger."""
    logging.getLogger(ROOT).warning("%s", message)


@contextlib.contextmanager
def cli_logging(prog: str, verbosity: int = 0):
    """Show the package's log records on stderr for the ``with`` block (the command line's setting).

    Everything is restored afterwards (handler, level, :func:`warnings.showwarning`), so
    that calling the CLI's ``main`` twice in one process does not print lines twice.

    Parameters
    ----------
    prog : str
        Prefix of every line, e.g. ``"skin-indent fit"``.
    verbosity : int
        -1 (``-q``): warnings and errors only; 0 (default): also the INFO lines of long
        phases; 1 (``-v``): also DEBUG details. Python warnings are shown at every
        verbosity, as one line each (``skin-indent fit: warning: ...``).

    Yields
    ------
    logging.Logger
        The ``skin_indent`` logger.
    """
    logger = logging.getLogger(ROOT)
    handler = _StderrHandler(prog)
    old_level, old_propagate, old_show = logger.level, logger.propagate, warnings.showwarning
    logger.addHandler(handler)
    logger.setLevel(LEVELS[max(-1, min(1, int(verbosity)))])
    logger.propagate = False  # a root handler a user configured would print each line twice
    warnings.showwarning = _show_warning
    try:
        yield logger
    finally:
        warnings.showwarning = old_show
        logger.removeHandler(handler)
        logger.setLevel(old_level)
        logger.propagate = old_propagate


def progress_bar(progress: bool | None = None, **kwargs):
    """A :class:`tqdm.tqdm` bar on stderr, or a disabled one (same interface, draws nothing).

    Parameters
    ----------
    progress : bool or None
        True: draw it; False: never; None: only if stderr is a terminal (no carriage-return
        updates in a redirected file).
    **kwargs
        Passed to :class:`tqdm.tqdm` (``total``, ``desc``, ``unit``, ``initial``...).
    """
    from tqdm.auto import tqdm

    disable = (not progress) if progress is not None else not _stderr_is_terminal()
    return tqdm(disable=disable, file=sys.stderr, **kwargs)


def _stderr_is_terminal() -> bool:
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError):  # closed or replaced by an object without isatty
        return False
