"""The vocabulary: every effect a model can have, by name.

The effects of the package (the sample's, then the instrument's) are registered when :mod:`skin_indent.effects` is
imported; :func:`register` adds another one (a subclass of
:class:`~skin_indent.effects.base.Effect`), after which models, fits, the diagnosis
and the command line take it like the others.
"""

from __future__ import annotations

from .base import Effect

#: name -> effect, in registration order (the order diagnosis tries candidates in)
EFFECTS: dict[str, Effect] = {}


def register(effect: Effect, *, replace: bool = False) -> Effect:
    """Add ``effect`` to the vocabulary (one-line error if its name is taken or it is malformed)."""
    if not isinstance(effect, Effect):
        raise TypeError(f"an effect must be an instance of skin_indent.effects.Effect, got {type(effect).__name__}")
    if not effect.name or not effect.name.isidentifier():
        raise ValueError(f"an effect needs a name that is an identifier, got {effect.name!r}")
    if effect.name in EFFECTS and not replace:
        raise ValueError(f"an effect called {effect.name!r} is already registered")
    taken = {p.name for e in EFFECTS.values() if e.name != effect.name for p in e.parameters}
    clash = taken & set(effect.parameter_names)
    if clash:
        raise ValueError(f"effect {effect.name!r}: parameter name(s) {sorted(clash)} belong to another effect")
    EFFECTS[effect.name] = effect
    return effect


def unregister(name: str) -> None:
    """Remove an effect from the vocabulary (tests that register their own)."""
    EFFECTS.pop(name, None)


def effect(name) -> Effect:
    """The effect called ``name`` (an :class:`Effect` is returned as is), one-line error otherwise."""
    if isinstance(name, Effect):
        return name
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}: choose from {', '.join(EFFECTS)}") from None
