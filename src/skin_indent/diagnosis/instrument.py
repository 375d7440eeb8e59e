"""The instrument's stage of a diagnosis: drag and the baselines named before the sample's effects.

The parts of a curve out of contact, where the sample gives no force, determine the effects of the
measurement (:attr:`~skin_indent.effects.Effect.instrument`: drag on the probe, a baseline's drift).
:func:`examine_instrument` fits every combination of those that can show, with the sample's
parameters, and names the best when the evidence is strong; :func:`at_physical_range` tells an
effect of the instrument pushed to the edge of what the instrument can give (it then stands in for
the sample: tethers, creep) and is not named. :func:`~skin_indent.diagnosis.diagnose` calls both.
"""

from __future__ import annotations

import itertools
import logging
import math

from ..effects import effect
from ..fitting.multistart import Fitter
from ..fitting.rung import Rung
from ..models.joint import split_name
from .criteria import NOT_FITTED, STRONG, Scores, effective_size
from .result import Step

log = logging.getLogger(__name__)

__all__ = ["AT_LIMIT", "at_physical_range", "examine_instrument"]


#: a parameter of the instrument within this fraction of its range from a face ends on it
AT_LIMIT = 1e-3


def at_physical_range(rung: Rung, effects) -> list[str]:
    """The fit parameters of the instrument's ``effects`` in ``rung`` that end on the far face of their
    physical range (within :data:`AT_LIMIT` of it; the face at 0, their off value, does not count): an
    effect of the instrument there stands in for a force the instrument cannot give (tethers pulled on
    the retract, the sample's creep in a hold).

    Parameters
    ----------
    rung : Rung
        A fitted model (its ``bound_model`` and ``x``).
    effects : iterable of str
        Effects of the instrument in it.
    """
    model = rung.bound_model
    own = {k for n in effects for k in effect(n).fit_names}
    out = []
    for i, k in enumerate(model.parameter_names):
        if split_name(k)[0] not in own:
            continue
        lo, hi = float(model.bounds[0][i]), float(model.bounds[1][i])
        v, span = float(rung.x[i]), hi - lo
        for face in (lo, hi):
            if face != 0.0 and math.isfinite(face) and abs(v - face) <= AT_LIMIT * span:
                out.append(k)
    return out


def examine_instrument(fitter: Fitter, add: tuple, candidates) -> tuple[tuple, list]:
    """The instrument's effects the curve shows, fitted together on top of ``add``.

    Every combination of the instrument's candidates (:attr:`~skin_indent.effects.Effect.instrument`:
    drag, the baselines; at most 7 combinations of 3) that can show in the data is fitted on top of
    the current model, with the sample's parameters: drag and a drift may each fail alone where
    together they explain the parts out of contact. The combination of lowest BIC (at the effective
    sample size of these fits) is named when it lowers the BIC by more than :data:`STRONG`. The parts
    out of contact, where the sample gives no force, weigh as much as the rest: the instrument's
    effects are named there first, so that no effect of the sample is named to absorb them.

    Returns
    -------
    key : tuple of str
        The instrument's effects named, in registration order.
    steps : list of Step
        The examination (every combination ranked on top of ``add``; none when no candidate shows).
    """
    hidden, wanted = {}, []
    for name in candidates:
        why = fitter.visible(effect(name))
        if why is None:
            wanted.append(name)
        else:
            hidden[name] = why
    if not wanted:
        return (), []
    combos = [c for k in range(1, len(wanted) + 1) for c in itertools.combinations(wanted, k)]
    current = fitter.fit(add)
    fitted = fitter.fit_all([add + c for c in combos])
    tried = []
    for c in combos:
        f = fitted[add + c]
        if isinstance(f, ValueError):
            hidden["+".join(c)] = f"{NOT_FITTED}: {f}"
            continue
        pinned = at_physical_range(f, c)
        if pinned:  # at the edge of its physical range: it stands in for something else (tethers, creep)
            hidden["+".join(c)] = (f"{', '.join(pinned)} at the edge of its physical range: the instrument "
                                   "cannot give that force, something else does")
            continue
        tried.append(f)
    if not tried:
        return (), [Step(current, [], hidden, "none", [])]
    scores = Scores(fitter.data.n, effective_size(fitter, [current, *tried]))
    current = scores(current)
    ranking = sorted((scores(f) for f in tried), key=lambda f: f.bic)
    best = ranking[0]
    named = current.bic - best.bic > STRONG
    key = tuple(best.effects[len(add):]) if named else ()
    if named:
        log.info("the instrument: %s named (BIC lower by %.1f)", ", ".join(key), current.bic - best.bic)
    return key, [Step(current, ranking, hidden, "+".join(key) if named else "none", [])]
