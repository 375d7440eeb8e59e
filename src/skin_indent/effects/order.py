"""When two orders of the same effects are one model: :func:`canonical`.

A model is the half-space plus a sequence of effects, and its name keeps the order it was asked
in (``neo-hooke+layer+stiffening``, ``neo-hooke+stiffening+layer``). Most orders build the same
force model, with parameters of the same names:

- **finite elements** (:meth:`~skin_indent.effects.Model.spec`): every effect fills in its own
  fields of one :class:`~skin_indent.effects.ForwardSpec`, and the sample is built from it after all
  of them. A layer stacks under the layers before it (its occurrence number says where:
  ``thickness2_mm`` is the second layer whatever stands between), stiffening sets one C20 / E of
  every material, relaxation one Prony series of every material, adhesion and friction the contact
  law, the offset the depth origin: none reads what another kind writes;
- **a fitted curve** (:class:`~skin_indent.models.ComposedModel`): the stages act in
  :data:`~skin_indent.effects.STAGE_ORDER` whatever the order of the effects. Within a stage,
  the :data:`~skin_indent.effects.ELASTIC` effects are one body (above), and the
  :data:`~skin_indent.effects.FORCE` effects each add a force of their own to the curve
  (adhesion its pull-off, drag the probe's, a baseline its drift), so their sum does not depend
  on their order. Within :data:`~skin_indent.effects.DEPTH` and
  :data:`~skin_indent.effects.HISTORY` the order is kept: the vocabulary has one effect of each
  (the contact point; one relaxation law, :attr:`~skin_indent.effects.Effect.kind`), and another
  one need not commute with it.

Two sequences of effects with the same :func:`canonical` key are the same model: the same force
at the same parameters (checked for every pair and triple of the vocabulary in
``tests/test_effect_order.py``, with finite-element runs for the elastic ones). A fitter fits such
a model once (:meth:`~skin_indent.fitting.multistart.Fitter.fit`).
"""

from __future__ import annotations

from .base import ELASTIC, FORCE, STAGE_ORDER
from .repeat import instances

__all__ = ["COMMUTING", "canonical", "same_model"]

#: stages whose effects act in any order among themselves (module docstring)
COMMUTING = (ELASTIC, FORCE)


def canonical(effects) -> tuple[str, ...]:
    """The key of the model of ``effects``: the same for every order of them that builds the same model.

    The effects sorted by the stage they act in (:data:`~skin_indent.effects.STAGE_ORDER`), by name
    within a stage of :data:`COMMUTING` effects, in their own order within the others.

    Parameters
    ----------
    effects : sequence of str or Effect

    Returns
    -------
    tuple of str
        Effect names (repeats kept).

    Examples
    --------
    >>> canonical(("stiffening", "layer")) == canonical(("layer", "stiffening"))
    True
    >>> canonical(("baselines", "layer", "offset"))
    ('offset', 'layer', 'baselines')
    """
    objs = instances(effects)

    def rank(item):
        i, e = item
        stage = STAGE_ORDER.index(e.stage) if e.stage in STAGE_ORDER else len(STAGE_ORDER)
        return (stage, e.name if e.stage in COMMUTING else "", i)

    return tuple(e.name for _, e in sorted(enumerate(objs), key=rank))


def same_model(a, b) -> bool:
    """``a`` and ``b`` (sequences of effects) are one model in two orders, or in the same one (False
    when either is no model: an unknown effect, one given twice that cannot repeat)."""
    try:
        return canonical(a) == canonical(b)
    except ValueError:
        return False
