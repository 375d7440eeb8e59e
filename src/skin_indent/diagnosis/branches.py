"""Explanations climbed side by side: when one becomes another with an effect that does nothing.

:func:`~.workflow.diagnose` climbs the best candidate of its first examination and the runner-up
(a beam of :data:`~.criteria.BEAM`). :func:`joins` says when the runner-up's branch has reached a
rung of the first explanation with one more effect that does nothing there: the branch is then
that explanation, and is not climbed further (issue 39: measured on the demo's pair of curves, the
contact points' branch ends on top of the layer rung with the contact points at 0, and climbing it
cost two more fits with the finite-element model in the loop that could only find the first
explanation again); or when it has reached a rung of the first explanation in another order
(``stiffening+layer`` after ``layer+stiffening``: one model).
"""

from __future__ import annotations

import logging

from ..effects.order import same_model
from ..fitting.multistart import Fitter
from .criteria import Scores

log = logging.getLogger(__name__)

__all__ = ["contains", "extra", "joins"]


def contains(big, small) -> bool:
    """Every effect of ``small`` is in ``big`` (as often)."""
    rest = list(big)
    for e in small:
        if e not in rest:
            return False
        rest.remove(e)
    return True


def extra(big: tuple, small: tuple) -> tuple:
    """The effects of ``big`` that ``small`` has not (as often), in ``big``'s order."""
    rest = list(small)
    out = []
    for e in big:
        if e in rest:
            rest.remove(e)
        else:
            out.append(e)
    return tuple(out)


def joins(fitter: Fitter, key: tuple, kept, scores: Scores) -> tuple | None:
    """The rung of another explanation that the rung ``key`` of a branch is, with an effect that
    does nothing on top of it; None if there is none.

    ``key`` joins the rung ``r`` of ``kept`` (rungs of explanations climbed before) when it holds the
    effects of ``r`` and one more, ``e``, and ``e`` on top of ``r`` does not lower the BIC at all: its
    parameters end at (or next to) their null values, the chi-square falls by less than they cost (the
    contact points of a pair of curves that start in contact, at 0 on top of the layer rung). The
    branch is then the explanation of ``r`` with ``e`` along for nothing, and every rung a climb would
    add on top of it that explanation's with ``e`` along: it is not climbed further (the explanation of
    ``r`` is climbed already) and its end is not compared, the end of ``r``'s explanation standing for
    both. Both rungs are fitted by then (``key`` by the examination that named its last effect, ``r``
    by the climb that kept it). An effect that lowers the BIC, even by less than :data:`~.criteria.STRONG`, keeps
    its branch: the explanations are compared as before.

    ``key`` also joins a rung ``r`` of ``kept`` that holds its effects in another order
    (:func:`~skin_indent.effects.order.same_model`: ``stiffening+layer`` and ``layer+stiffening``): one model,
    fitted once (:meth:`~skin_indent.fitting.multistart.Fitter.fit`), whose explanation is climbed already.
    """
    if len(key) < 2:
        return None
    for r in kept:
        if len(r) == len(key) and r != key and same_model(r, key):
            log.info("%s is %s in another order: that explanation is climbed already",
                     "+".join(("neo-hooke",) + key), "+".join(("neo-hooke",) + r))
            return r
    for r in kept:
        if len(r) + 1 != len(key) or not contains(key, r) or r not in fitter.fits or key not in fitter.fits:
            continue
        gain = scores(fitter.fits[r]).bic - scores(fitter.fits[key]).bic
        if gain <= 0.0:
            log.info("%s is %s with %s, which raises the BIC there by %.3g: that explanation is climbed "
                     "already", "+".join(("neo-hooke",) + key), "+".join(("neo-hooke",) + r),
                     "+".join(extra(key, r)), -gain)
            return r
    return None
