"""Where and how the finite-element runs behind the surfaces are made: one :class:`Context`.

Made once (by the CLI from its options, or by a user) and handed down to fits and
diagnosis, instead of passing the cache folder, the executor settings and the progress
switch through every layer.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Context:
    """Execution settings of the response-surface builds.

    Attributes
    ----------
    cache_dir : path, optional
        Run cache (default ``$SKIN_INDENT_CACHE`` or ``~/.cache/skin_indent``).
    workers : int, optional
        Local processes (default: all cores).
    client : dask.distributed.Client, optional
        Run on this Dask cluster.
    scheduler : str, optional
        ``"tcp://HOST:PORT"`` of a Dask scheduler.
    progress : bool or None
        Show a progress bar while runs are made: True always, False never, None only when
        stderr is a terminal (:func:`skin_indent.runtime.log.progress_bar`).

    Examples
    --------
    >>> ctx = Context(cache_dir="/tmp/surfaces", workers=2)
    >>> sorted(ctx.build_options())
    ['cache_dir', 'client', 'progress', 'scheduler', 'workers']
    """

    cache_dir: Path | str | None = None
    workers: int | None = None
    client: object = None
    scheduler: str | None = None
    progress: bool | None = False

    def build_options(self) -> dict:
        """The keywords of :meth:`~skin_indent.response_surface.ResponseSurface.load_or_build`."""
        return {"cache_dir": self.cache_dir, "workers": self.workers, "client": self.client,
                "scheduler": self.scheduler, "progress": self.progress}


def context_of(context: Context | None = None, **options) -> Context:
    """``context`` itself, or a :class:`Context` made of keyword ``options`` (never both)."""
    given = {k: v for k, v in options.items() if v is not None and v is not False}
    if context is not None:
        if given:
            raise ValueError(f"give either a context or {', '.join(sorted(given))}, not both")
        return context
    return Context(**options)
