"""The hooks of an elastic core whose forces are interpolated: :class:`SurfaceCore`.

A response surface is one of the elastic cores of a fitted model
(:class:`skin_indent.models.core.ElasticCore`); unlike the finite-element model in the loop it
has nothing to run during a fit, so its hooks do nothing.
"""

from __future__ import annotations

import contextlib
from typing import ContextManager

__all__ = ["SurfaceCore"]


class SurfaceCore:
    """The hooks of a core whose forces are interpolated (nothing to run, nothing to start)."""

    #: the forces are interpolated from runs made before the fit
    in_loop = False

    def iterating(self) -> ContextManager:
        """Nothing: a surface has no state across iterations."""
        return contextlib.nullcontext(self)

    def screening(self) -> ContextManager:
        """Nothing: a surface ranks starts at full accuracy for free."""
        return contextlib.nullcontext(self)

    def in_workers(self) -> ContextManager:
        """Nothing: a surface runs nothing."""
        return contextlib.nullcontext(self)

    def prefetch(self, thetas) -> None:
        """Nothing to make."""

    def start_workers(self) -> None:
        """No workers."""
