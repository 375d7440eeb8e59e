"""The elastic core of a fitted model: one declared protocol, no capability probes.

A :class:`~skin_indent.models.ComposedModel` is an elastic core plus effects. The core gives
the elastic force ``F(h; theta)`` (mN) at depths ``h > 0`` below the contact point (mm). Three
kinds exist:

- a response surface of the neo-Hookean half-space
  (:class:`~skin_indent.response_surface.ResponseSurface`),
- an effect surface for the elastic effects of a model
  (:class:`~skin_indent.models.effect_surface.EffectSurface`),
- the finite-element model in the loop (:class:`~skin_indent.models.fe_core.FECore`),
- Hertz's sphere, for comparison (:class:`~skin_indent.models.hertz.HertzModel`).

Each declares what :class:`ElasticCore` lists. The fitter, the joint model of several curves
and the report of how a fit ended read ``in_loop`` and call the hooks, instead of asking
whether a method exists. A surface inherits the do-nothing hooks of
:class:`~skin_indent.response_surface.SurfaceCore`.
"""

from __future__ import annotations

from typing import ContextManager, Protocol, runtime_checkable

import numpy as np

from ..response_surface._core import SurfaceCore

__all__ = ["ElasticCore", "SurfaceCore"]


@runtime_checkable
class ElasticCore(Protocol):
    """What every elastic core declares.

    Attributes
    ----------
    parameter_names : tuple of str
        Its fit parameters, ``("E_kPa", "nu", ...)``.
    bounds : (ndarray, ndarray)
        Their admissible ranges (the surface's nodes, or what the finite-element model solves).
    depth_range : (float, float)
        Depths below the contact point it gives forces for (mm).
    in_loop : bool
        True for the finite-element model in the loop, whose runs are made during the fit
        (in worker processes); False for a surface interpolated from runs made before.
    """

    parameter_names: tuple
    bounds: tuple
    depth_range: tuple
    in_loop: bool

    def force(self, depth_mm, theta) -> np.ndarray:
        """Elastic force at ``depth_mm`` (mm) for the parameters ``theta`` (mN)."""

    def jacobian(self, depth_mm, theta, columns=None) -> np.ndarray:
        """dF/dtheta at ``depth_mm`` (mN per parameter unit)."""

    def iterating(self) -> ContextManager:
        """Context of a fit's iterations."""

    def screening(self) -> ContextManager:
        """Context of cheap runs that only rank start vectors."""

    def in_workers(self) -> ContextManager:
        """Context within which every run goes to the worker processes."""

    def prefetch(self, thetas) -> None:
        """Make the runs of several parameter vectors at once."""

    def start_workers(self) -> None:
        """Start the worker processes now, from the calling (main) thread."""
