"""A repeatable effect occurring more than once in a model: two layers, three layers.

The k-th occurrence (k >= 2) of an effect is a :class:`Repeat` of it: the same physics
with numbered parameter names (``thickness2_mm``, ``ratio2``, fitted as
``thickness2_mm``, ``compliance2``), so that the parameters of every occurrence live
side by side in one model. :func:`instances` turns a sequence of effect names into
these objects.

Example
-------
>>> [e.parameter_names for e in instances(("layer", "layer"))]
[('thickness_mm', 'ratio'), ('thickness2_mm', 'ratio2')]
"""

from __future__ import annotations

import dataclasses

from .base import Effect
from .registry import effect


def numbered(name: str, k: int) -> str:
    """``name`` of the ``k``-th occurrence: ``thickness_mm`` -> ``thickness2_mm``, ``compliance`` -> ``compliance2``."""
    if k == 1:
        return name
    head, sep, tail = name.partition("_")
    return f"{head}{k}{sep}{tail}"


class Repeat(Effect):
    """The ``k``-th occurrence (k >= 2) of the repeatable effect ``inner``.

    Everything is delegated to ``inner`` with the parameter names translated.
    """

    def __init__(self, inner: Effect, k: int):
        if not inner.repeatable:
            raise ValueError(f"the {inner.name} effect can appear once in a model")
        self.inner, self.k = inner, int(k)
        self.name = inner.name
        self.description = f"{inner.description} (occurrence {k})"
        self.parameters = tuple(dataclasses.replace(p, name=numbered(p.name, k)) for p in inner.parameters)
        self.stage = inner.stage
        self.needs_history = inner.needs_history
        self.linear_in_E = inner.linear_in_E
        self.repeatable = True
        self.per_curve = inner.per_curve
        self.kind = inner.kind

    def __repr__(self) -> str:
        return f"<effect {self.name} #{self.k}: {self.inner.description}>"

    def _in(self, values: dict) -> dict:
        """Numbered names -> the inner effect's names."""
        names = {numbered(n, self.k): n for n in (*self.inner.parameter_names, *self.inner.fit_names)}
        return {names.get(k, k): v for k, v in values.items()}

    def _out(self, values: dict) -> dict:
        return {numbered(k, self.k): v for k, v in values.items()}

    @property
    def fit_names(self):
        return tuple(numbered(n, self.k) for n in self.inner.fit_names)

    def configure(self, spec, values):
        self.inner.configure(spec, self._in(values))

    def to_fit(self, values, E_kPa):
        return self._out(self.inner.to_fit(self._in(values), E_kPa))

    def from_fit(self, fit, E_kPa):
        return self._out(self.inner.from_fit(self._in(fit), E_kPa))

    def relative(self, values, E_kPa):
        return self._out(self.inner.relative(self._in(values), E_kPa))

    def fit_bounds(self, data, reach_mm=float("inf")):
        return self._out(self.inner.fit_bounds(data, reach_mm))

    def starts(self, data, bounds):
        return self._out(self.inner.starts(data, self._in(bounds)))

    def fe_bounds(self, max_depth_mm):
        return self._out(self.inner.fe_bounds(max_depth_mm))

    def apply(self, ev, fit):
        self.inner.apply(ev, self._in(fit))

    def visible(self, data, noise_mN):
        return self.inner.visible(data, noise_mN)


def instances(effects) -> tuple[Effect, ...]:
    """The effect objects of a sequence of names (or effects): repeats numbered, one-line errors.

    Raises
    ------
    ValueError
        An unknown name, or a non-repeatable effect given twice.
    """
    out, seen = [], {}
    for e in effects:
        if isinstance(e, Repeat):
            out.append(e)
            seen[e.name] = max(seen.get(e.name, 0), e.k)
            continue
        obj = effect(e)
        k = seen.get(obj.name, 0) + 1
        seen[obj.name] = k
        if k > 1 and not obj.repeatable:
            raise ValueError(f"the {obj.name} effect can appear once in a model")
        out.append(obj if k == 1 else Repeat(obj, k))
    return tuple(out)


def check_kinds(effects) -> None:
    """One-line error for two effects of one kind in a model (:attr:`~skin_indent.effects.Effect.kind`:
    ``viscoelastic`` and ``viscoelastic_powerlaw`` are alternative relaxation laws)."""
    kinds: dict[str, str] = {}
    for e in effects:
        obj = e if isinstance(e, Effect) else effect(e)
        if obj.kind and kinds.setdefault(obj.kind, obj.name) != obj.name:
            raise ValueError(f"the {kinds[obj.kind]} and {obj.name} effects are alternative {obj.kind} laws: "
                             "a model has one")


def addable(key, name) -> bool:
    """Whether the effect ``name`` can be added on top of the effects ``key`` (a repeatable effect
    again; not a second effect of a kind the model has already, :attr:`~skin_indent.effects.Effect.kind`)."""
    e = effect(name)
    present = [effect(k) for k in key]
    if any(p.name == e.name for p in present) and not e.repeatable:
        return False
    return not (e.kind and any(p.kind == e.kind and p.name != e.name for p in present))
