"""Named, bounded, optionally fixed model parameters.

Every identification method works on the *free* parameters only, while the force
model always receives the *full* parameter vector ``theta`` in the order of
``model.parameter_names``. :class:`ParameterSet` is the bridge between the two.

Units follow the package convention (mm, kPa, mN, s); a parameter's unit is
guessed from its name suffix (``"E_kPa"`` -> ``"kPa"``) unless given.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Parameter", "ParameterSet"]

_KNOWN_UNITS = ("kPa", "MPa", "Pa", "mm", "um", "mN", "N", "s", "ms")


def _unit_from_name(name: str) -> str:
    suffix = name.rsplit("_", 1)[-1] if "_" in name else ""
    return suffix if suffix in _KNOWN_UNITS else ""


@dataclass(frozen=True)
class Parameter:
    """One scalar model parameter.

    Parameters
    ----------
    name : str
        Name, as in ``model.parameter_names`` (e.g. ``"E_kPa"``, ``"nu"``).
    value : float
        Current value (start value before a fit, estimate after it), in ``unit``.
    lower, upper : float
        Valid box; ``lower <= value <= upper``.
    unit : str
        Unit label (``""`` for dimensionless).
    fixed : bool
        If True the parameter is held at ``value`` by every identification method.
    """

    name: str
    value: float
    lower: float = -math.inf
    upper: float = math.inf
    unit: str = ""
    fixed: bool = False

    def __post_init__(self):
        for attr in ("value", "lower", "upper"):
            object.__setattr__(self, attr, float(getattr(self, attr)))
        if not math.isfinite(self.value):
            raise ValueError(f"parameter {self.name!r}: value must be finite, got {self.value}")
        if not self.lower <= self.value <= self.upper:
            raise ValueError(
                f"parameter {self.name!r}: value {self.value:g} outside bounds "
                f"[{self.lower:g}, {self.upper:g}]"
            )


class ParameterSet:
    """Ordered collection of :class:`Parameter`, addressed by name.

    Parameters
    ----------
    parameters : iterable of Parameter
        In the model's order (``model.parameter_names``). Names must be unique.

    Notes
    -----
    Immutable: :meth:`fix`, :meth:`free`, :meth:`from_array` and :meth:`with_values`
    return new sets.

    Examples
    --------
    >>> ps = ParameterSet([Parameter("E_kPa", 10, 1, 100, "kPa"), Parameter("nu", 0.3, 0.2, 0.49)])
    >>> ps.fix("nu", 0.45).free_names
    ('E_kPa',)
    >>> ps.fix("nu", 0.45).full(np.array([20.0]))
    array([20.  ,  0.45])
    """

    def __init__(self, parameters: Iterable[Parameter]):
        params = tuple(parameters)
        names = [p.name for p in params]
        if len(set(names)) != len(names):
            raise ValueError(f"duplicate parameter names in {names}")
        if not params:
            raise ValueError("a ParameterSet needs at least one parameter")
        self._params = params
        self._index = {p.name: i for i, p in enumerate(params)}

    # ------------------------------------------------------------------ build
    @classmethod
    def from_model(cls, model, values=None, *, fixed: Mapping[str, float] | None = None,
                   units: Mapping[str, str] | None = None) -> "ParameterSet":
        """Build a set from a force model's names and bounds.

        Parameters
        ----------
        model : ForceModel
            Supplies ``parameter_names`` and ``bounds``.
        values : array_like, mapping or ParameterSet, optional
            Start values: a full-length array in model order, a ``{name: value}``
            mapping (missing names start at the box centre), or a ParameterSet
            (its values and fixed flags are kept). Default: the box centre.
        fixed : mapping, optional
            ``{name: value}`` to hold fixed (overrides ``values`` for those names).
        units : mapping, optional
            Unit labels by name; default guessed from the name suffix.

        Raises
        ------
        ValueError
            Unknown names, wrong length, non-finite values or values outside the box.
        """
        names = tuple(model.parameter_names)
        lo, hi = (np.asarray(b, dtype=float).reshape(-1) for b in model.bounds)
        if lo.size != len(names) or hi.size != len(names):
            raise ValueError(f"model bounds have {lo.size}/{hi.size} entries for {len(names)} parameters")
        units = dict(units or {})
        fixed_flags = dict.fromkeys(names, False)
        if values is None:
            start = dict(zip(names, 0.5 * (lo + hi)))
        elif isinstance(values, ParameterSet):
            if values.names != names:
                raise ValueError(f"parameter names {values.names} do not match the model's {names}")
            start = values.as_dict()
            fixed_flags = {p.name: p.fixed for p in values}
        elif isinstance(values, Mapping):
            unknown = set(values) - set(names)
            if unknown:
                raise ValueError(f"unknown parameter names {sorted(unknown)}; model has {names}")
            start = dict(zip(names, 0.5 * (lo + hi)))
            start.update({k: float(v) for k, v in values.items()})
        else:
            arr = np.asarray(values, dtype=float).reshape(-1)
            if arr.size != len(names):
                raise ValueError(f"x0 has {arr.size} values, the model has {len(names)} parameters {names}")
            start = dict(zip(names, arr))
        for k, v in (fixed or {}).items():
            if k not in start:
                raise ValueError(f"cannot fix unknown parameter {k!r}; model has {names}")
            start[k] = float(v)
            fixed_flags[k] = True
        params = []
        for i, n in enumerate(names):
            v = float(start[n])
            if not math.isfinite(v):
                raise ValueError(f"start value of {n!r} must be finite, got {v}")
            if not lo[i] <= v <= hi[i]:
                what = "fixed value" if fixed_flags[n] else "x0"
                raise ValueError(f"{what} {n}={v:g} outside the model bounds [{lo[i]:g}, {hi[i]:g}]")
            params.append(Parameter(n, v, lo[i], hi[i], units.get(n, _unit_from_name(n)), fixed_flags[n]))
        return cls(params)

    # --------------------------------------------------------------- access
    def __iter__(self) -> Iterator[Parameter]:
        return iter(self._params)

    def __len__(self) -> int:
        return len(self._params)

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._params[self._index[name]]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; have {self.names}") from None

    def __contains__(self, name) -> bool:
        return name in self._index

    def __repr__(self) -> str:
        inner = ", ".join(f"{p.name}={p.value:g}{' (fixed)' if p.fixed else ''}" for p in self._params)
        return f"ParameterSet({inner})"

    @property
    def names(self) -> tuple[str, ...]:
        """All names, model order."""
        return tuple(p.name for p in self._params)

    @property
    def free_names(self) -> tuple[str, ...]:
        """Names of the free (fitted) parameters, model order."""
        return tuple(p.name for p in self._params if not p.fixed)

    @property
    def fixed_names(self) -> tuple[str, ...]:
        """Names of the fixed parameters, model order."""
        return tuple(p.name for p in self._params if p.fixed)

    @property
    def free_index(self) -> np.ndarray:
        """Integer positions of the free parameters in the full vector."""
        return np.array([i for i, p in enumerate(self._params) if not p.fixed], dtype=int)

    @property
    def values(self) -> np.ndarray:
        """Full parameter vector ``theta`` (model order)."""
        return np.array([p.value for p in self._params])

    @property
    def lower(self) -> np.ndarray:
        """Full lower bounds."""
        return np.array([p.lower for p in self._params])

    @property
    def upper(self) -> np.ndarray:
        """Full upper bounds."""
        return np.array([p.upper for p in self._params])

    def free_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the free parameters."""
        i = self.free_index
        return self.lower[i], self.upper[i]

    def as_dict(self) -> dict[str, float]:
        """``{name: value}`` of all parameters."""
        return {p.name: p.value for p in self._params}

    def to_array(self) -> np.ndarray:
        """Values of the free parameters, shape ``(n_free,)``."""
        return self.values[self.free_index]

    def full(self, x_free: np.ndarray) -> np.ndarray:
        """Full ``theta`` with the free entries replaced by ``x_free`` (no validation)."""
        theta = self.values
        theta[self.free_index] = x_free
        return theta

    # ------------------------------------------------------------- new sets
    def from_array(self, x_free) -> "ParameterSet":
        """New set with the free values replaced by ``x_free`` (validated against the box)."""
        x_free = np.asarray(x_free, dtype=float).reshape(-1)
        idx = self.free_index
        if x_free.size != idx.size:
            raise ValueError(f"expected {idx.size} free values {self.free_names}, got {x_free.size}")
        new = list(self._params)
        for i, v in zip(idx, x_free):
            new[i] = replace(new[i], value=float(v))
        return ParameterSet(new)

    def with_values(self, values: Mapping[str, float]) -> "ParameterSet":
        """New set with some values replaced by name (fixed flags unchanged)."""
        new = list(self._params)
        for k, v in values.items():
            new[self._index[k]] = replace(self[k], value=float(v))
        return ParameterSet(new)

    def fix(self, name: str, value: float | None = None) -> "ParameterSet":
        """New set with ``name`` fixed (at ``value``, default its current value)."""
        p = self[name]
        new = list(self._params)
        new[self._index[name]] = replace(p, value=p.value if value is None else float(value), fixed=True)
        return ParameterSet(new)

    def free(self, name: str) -> "ParameterSet":
        """New set with ``name`` free."""
        new = list(self._params)
        new[self._index[name]] = replace(self[name], fixed=False)
        return ParameterSet(new)
