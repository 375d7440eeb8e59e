"""How many BLAS / OpenMP threads each process of skin_indent uses.

The problems solved here are small (dense systems of a few unknowns, sparse
finite-element systems factorised by SuperLU), and BLAS threads do not speed
them up; but on a loaded machine a full pool of threads per process makes them
fight over the cores (the contact-point scan of a 14k-sample AFM curve took 5 s
instead of 0.07 s). The policy:

* worker processes of :class:`~skin_indent.response_surface.LocalProcesses` and
  Dask workers use :data:`WORKER_THREADS` (1) thread each: set through the
  environment when the process starts (in force before numpy loads) and with
  threadpoolctl in the worker initializer;
* the main process of a ``skin-indent`` command (:func:`configure_threads`) uses
  :data:`MAIN_THREADS` (1) thread, and 1 while local workers run;
* ``SKIN_INDENT_THREADS=N`` sets the main process's limit instead, and
  ``SKIN_INDENT_THREADS=off`` turns every limit off (the libraries' defaults).
  A user's own ``OPENBLAS_NUM_THREADS`` (or another variable of
  :data:`THREAD_ENV_VARS`) is left as it is for the main process.

threadpoolctl is imported only where a limit is applied to libraries that are
already loaded; setting the environment before numpy loads costs nothing.
"""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Iterator

#: environment variables read by BLAS and OpenMP runtimes when they load
THREAD_ENV_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                   "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
#: the user's setting: an integer (threads of the main process) or ``off``
SETTING_ENV = "SKIN_INDENT_THREADS"
#: BLAS threads per worker process
WORKER_THREADS = 1
#: BLAS threads of the main process of a command (measured: 2 threads gain nothing here)
MAIN_THREADS = 1

_WORKER_CONFIGURED = False


def limits_enabled() -> bool:
    """False if ``SKIN_INDENT_THREADS=off``: then no limit is set anywhere."""
    return os.environ.get(SETTING_ENV, "").strip().lower() not in ("off", "none", "default")


def main_threads() -> int | None:
    """The BLAS thread limit of a command's main process; None: leave the libraries alone.

    ``SKIN_INDENT_THREADS`` if it is an integer >= 1; None if it is ``off`` or if the
    user set one of :data:`THREAD_ENV_VARS`; else :data:`MAIN_THREADS`.

    Raises
    ------
    ValueError
        If ``SKIN_INDENT_THREADS`` is neither an integer >= 1 nor ``off``.
    """
    setting = os.environ.get(SETTING_ENV, "").strip()
    if not limits_enabled():
        return None
    if setting:
        try:
            n = int(setting)
        except ValueError:
            n = 0
        if n < 1:
            raise ValueError(f"{SETTING_ENV} must be an integer >= 1 or 'off', got {setting!r}")
        return n
    if any(name in os.environ for name in THREAD_ENV_VARS):
        return None
    return MAIN_THREADS


def _blas_loaded() -> bool:
    """True if a library that may have loaded a BLAS or OpenMP runtime is imported."""
    return any(name in sys.modules for name in ("numpy", "scipy", "sklearn", "torch"))


def _set_env(n: int, *, override: bool) -> None:
    for name in THREAD_ENV_VARS:
        if override or name not in os.environ:
            os.environ[name] = str(n)


def _apply(n: int) -> None:
    """Limit the loaded BLAS/OpenMP libraries to ``n`` threads, until changed again."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=n)


@contextlib.contextmanager
def limit_threads(n: int | None = 1) -> Iterator[None]:
    """Limit the BLAS and OpenMP thread pools of this process to ``n`` threads inside a block.

    Parameters
    ----------
    n : int or None
        Threads (>= 1); None changes nothing.

    Notes
    -----
    Uses :func:`threadpoolctl.threadpool_limits` on the libraries loaded when the block
    starts; the previous limits come back when it ends. A library loaded inside the
    block reads the environment (see :func:`configure_threads`) instead. Nothing is
    changed when ``SKIN_INDENT_THREADS=off``.

    Examples
    --------
    >>> with limit_threads(1):  # doctest: +SKIP
    ...     find_contact_point(measurement)
    """
    if n is None or not limits_enabled():
        yield
        return
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be an integer >= 1 or None, got {n!r}")
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=n):
        yield


def configure_threads(n: int | None = None) -> int | None:
    """Set the BLAS thread limit of this (main) process for the rest of its life.

    Call it first thing in a command: the environment variables of
    :data:`THREAD_ENV_VARS` that the user did not set are set to the limit, so that
    BLAS libraries loaded later (numpy, scipy) start with it; libraries already
    loaded are limited with threadpoolctl. Worker processes started later inherit
    the environment.

    Parameters
    ----------
    n : int, optional
        Threads; default :func:`main_threads` (1, or ``SKIN_INDENT_THREADS``).

    Returns
    -------
    int or None
        The limit set, or None if none was (``SKIN_INDENT_THREADS=off``, or the user
        set ``OPENBLAS_NUM_THREADS`` or the like).
    """
    n = main_threads() if n is None else n
    if n is None:
        return None
    _set_env(n, override=False)
    if _blas_loaded():
        _apply(n)
    return n


@contextlib.contextmanager
def worker_environment(n: int = WORKER_THREADS) -> Iterator[None]:
    """Environment for starting worker processes: :data:`THREAD_ENV_VARS` set to ``n``.

    Processes started inside the block (spawn, forkserver or fork) inherit the
    variables, so the limit is in force before they import numpy; this process's
    environment is restored when the block ends.
    """
    if not limits_enabled():
        yield
        return
    saved = {name: os.environ.get(name) for name in THREAD_ENV_VARS}
    _set_env(n, override=True)
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def init_worker(n: int = WORKER_THREADS) -> None:
    """Initializer of a worker process: ``n`` BLAS threads from now on (once per process).

    Sets :data:`THREAD_ENV_VARS` (for libraries loaded later) and limits the loaded ones
    with threadpoolctl. Does nothing when ``SKIN_INDENT_THREADS=off``.
    """
    global _WORKER_CONFIGURED
    if _WORKER_CONFIGURED or not limits_enabled():
        return
    _WORKER_CONFIGURED = True
    _set_env(n, override=True)
    if _blas_loaded():
        _apply(n)
