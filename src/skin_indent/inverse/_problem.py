"""Input validation and the (model, data, parameters) bundle shared by all methods."""

from __future__ import annotations

import contextlib
import inspect
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from .parameters import ParameterSet

__all__ = ["ForceModel", "Problem", "make_problem", "check_data", "iterating"]


@runtime_checkable
class ForceModel(Protocol):
    """What every identification method needs from a forward model.

    Attributes
    ----------
    parameter_names : tuple of str
        E.g. ``("E_kPa", "nu")``.
    bounds : (ndarray, ndarray)
        Lower and upper corners of the valid parameter box. ``force`` may raise
        ``ValueError`` outside it, so the algorithms keep ``theta`` inside.

    Methods
    -------
    force(depth_mm, theta) -> ndarray (n,)
        Indentation force (mN) at the depths (mm).
    jacobian(depth_mm, theta) -> ndarray (n, p)
        dF/dtheta (mN per parameter unit).
    """

    parameter_names: tuple[str, ...]
    bounds: tuple[np.ndarray, np.ndarray]

    def force(self, depth_mm: np.ndarray, theta: np.ndarray) -> np.ndarray: ...

    def jacobian(self, depth_mm: np.ndarray, theta: np.ndarray) -> np.ndarray: ...


def iterating(model):
    """``model.iterating()`` where a force model has it, else a null context.

    A model whose Jacobians within a fit's iterations may be approximate (secant updates,
    see :meth:`~skin_indent.models.fe_core.FECore.iterating`) offers this context; the
    fits enter it around their iterations and leave it before the covariance's Jacobian.
    """
    enter = getattr(model, "iterating", None)
    return enter() if callable(enter) else contextlib.nullcontext()


def check_data(depth, force, *, min_points: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Validate a force-depth curve; return float arrays.

    Raises
    ------
    ValueError
        Not 1-D, mismatched lengths, fewer than ``min_points`` points, NaN/inf.
    """
    depth = np.asarray(depth, dtype=float)
    force = np.asarray(force, dtype=float)
    if depth.ndim != 1 or force.ndim != 1:
        raise ValueError(f"depth and force must be 1-D, got shapes {depth.shape} and {force.shape}")
    if depth.size != force.size:
        raise ValueError(f"depth and force lengths differ: {depth.size} != {force.size}")
    if depth.size < min_points:
        raise ValueError(f"need at least {min_points} points, got {depth.size}")
    for label, arr in (("depth", depth), ("force", force)):
        bad = ~np.isfinite(arr)
        if bad.any():
            raise ValueError(f"{label} contains NaN or inf at {int(bad.sum())} point(s), first index {int(np.argmax(bad))}")
    return depth, force


def _check_model(model) -> None:
    missing = [a for a in ("parameter_names", "bounds", "force", "jacobian") if not hasattr(model, a)]
    if missing:
        raise ValueError(f"model does not implement the ForceModel protocol: missing {missing}")


@dataclass(frozen=True)
class Problem:
    """A validated identification problem: model, measured curve and parameters.

    The free-parameter vector ``x`` maps to the model's full ``theta`` through
    ``params.full(x)``; ``force``/``jacobian`` here take ``x`` and return the
    model force (mN) and the Jacobian columns of the free parameters only.
    """

    model: object
    depth: np.ndarray
    force_mN: np.ndarray
    params: ParameterSet

    def __post_init__(self):
        # cached: these are used once per EKF update
        object.__setattr__(self, "_template", self.params.values)
        object.__setattr__(self, "_free", self.params.free_index)
        object.__setattr__(self, "_by_column", takes_columns(self.model))

    @property
    def n(self) -> int:
        return self.depth.size

    @property
    def free_names(self) -> tuple[str, ...]:
        return self.params.free_names

    def theta(self, x: np.ndarray) -> np.ndarray:
        theta = self._template.copy()
        theta[self._free] = x
        return theta

    def model_force(self, x: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        d = self.depth if depth is None else depth
        return np.asarray(self.model.force(d, self.theta(x)), dtype=float).reshape(-1)

    def model_jacobian(self, x: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray:
        d = self.depth if depth is None else depth
        if self._by_column:  # only the free columns (a finite-element model then runs for no held parameter)
            J = self.model.jacobian(d, self.theta(x), columns=self._free)
        else:
            J = self.model.jacobian(d, self.theta(x))
        return np.asarray(J, dtype=float).reshape(d.size, -1)[:, self._free]


def takes_columns(model) -> bool:
    """The model's ``jacobian(depth_mm, theta, columns=...)`` computes only the columns asked for."""
    try:
        return "columns" in inspect.signature(model.jacobian).parameters
    except (TypeError, ValueError):
        return False


def make_problem(model, depth, force, x0, fixed: Mapping[str, float] | None = None,
                 *, min_points: int = 3) -> Problem:
    """Validate everything up front and bundle it.

    Parameters
    ----------
    model : ForceModel
    depth, force : array_like
        Depths (mm) and measured forces (mN), same length, finite.
    x0 : array_like, mapping or ParameterSet
        Start values (full length, model order; or by name).
    fixed : mapping, optional
        ``{name: value}`` held fixed.

    Raises
    ------
    ValueError
        One-line message for every bad input.
    """
    _check_model(model)
    depth, force = check_data(depth, force, min_points=min_points)
    params = ParameterSet.from_model(model, x0, fixed=fixed)
    n_free = len(params.free_names)
    if n_free == 0:
        raise ValueError("all parameters are fixed: nothing to identify")
    if depth.size <= n_free:
        raise ValueError(f"need more points ({depth.size}) than free parameters ({n_free})")
    return Problem(model, depth, force, params)
