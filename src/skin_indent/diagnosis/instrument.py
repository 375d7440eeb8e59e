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

import numpy as np

from ..effects import effect
from ..fitting.multistart import Fitter
from ..fitting.result import FitResult
from ..models.joint import split_name
from .criteria import NOT_FITTED, STRONG, Scores, effective_size
from .result import Step
from .segment_misfit import MIN_POINTS

log = logging.getLogger(__name__)

__all__ = ["AT_LIMIT", "NULL_SD", "WORSE_BY", "WORSE_FACTOR", "at_physical_range", "examine_instrument", "out_of_contact_rms",
           "switched_off", "worsened_out_of_contact"]


#: a parameter of the instrument within this fraction of its range from a face ends on it
AT_LIMIT = 1e-3
#: an out-of-contact part is left worse when its RMS rises above this factor of what it was, plus
#: :data:`WORSE_BY` noise sd: a drag fitted while the sample's misfit in contact remains may trade part of the
#: approach's out-of-contact fit (the Chiaro curve: 0.125 -> 0.21 nN, its retract's 4.95 -> 1.94 nN); one that
#: stands in for a pull on the retract alone multiplies it (the polymer gel's tethers: 0.03 -> 0.62 nN)
WORSE_FACTOR = 2.0
#: see :data:`WORSE_FACTOR`
WORSE_BY = 2.0
#: an instrument's parameter within this many standard deviations of its off value is at it (:func:`switched_off`)
NULL_SD = 2.0
#: the points of a segment this fraction of the indentation before the contact point are out of contact
MARGIN = 0.05


def out_of_contact_rms(fitter, rung) -> dict:
    """``{(curve, kind): RMS residual (mN)}`` of ``rung`` on each segment's points out of contact: recorded
    depths before the fitted contact point by more than :data:`MARGIN` of the deepest indentation (the
    pull-off's neighbourhood left out). Curves whose contact point is not fitted have none."""
    out = {}
    slices = fitter.data.slices if fitter.joint else [slice(0, fitter.data.n)]
    params = rung.parameters
    for k, (c, sl) in enumerate(zip(fitter.curves, slices)):
        offset = params.get(f"offset_mm[{k + 1}]", params.get("offset_mm")) if fitter.joint else params.get("offset_mm")
        if offset is None or not math.isfinite(offset):
            continue
        r = np.asarray(rung.residual_mN, dtype=float)[sl]
        free = c.depth_mm < offset - MARGIN * max(float(c.depth_mm.max()) - offset, 0.0)
        for kind in ("approach", "hold", "retract"):
            sel = free & (c.kind == kind)
            if np.count_nonzero(sel) >= MIN_POINTS:
                out[(k, kind)] = float(np.sqrt(np.mean(r[sel] ** 2)))
    return out


def worsened_out_of_contact(fitter, current: FitResult, candidate: FitResult) -> list[str]:
    """The out-of-contact parts that ``candidate`` (the current model with effects of the instrument)
    leaves worse than ``current``: RMS above :data:`WORSE_FACTOR` times what it was plus :data:`WORSE_BY`
    noise sd. The instrument's
    effects are what the parts out of contact show (drag acts both ways, on approach and retract); a
    combination that buys its lower BIC in contact at their expense stands in for the sample there
    (relaxation, adhesion, tethers) and is not named. Returns ``"approach"`` or ``"curve 2 retract"``."""
    before, after = out_of_contact_rms(fitter, current), out_of_contact_rms(fitter, candidate)
    out = []
    for (k, kind), rms in after.items():
        if (k, kind) in before and rms > WORSE_FACTOR * before[(k, kind)] + WORSE_BY * fitter.noises_mN[k]:
            out.append(f"curve {k + 1} {kind}" if fitter.joint else kind)
    return out


def _parameters_of(rung: FitResult, effects):
    """``(fit name, lower, upper, value, log)`` of every fit parameter of ``effects`` in ``rung`` (every curve's);
    ``log``: the parameter is sampled on a log scale (:attr:`~skin_indent.effects.EffectParameter.log`)."""
    model = rung.bound_model
    own = {k for n in effects for k in effect(n).fit_names}
    logs = {p.name for n in effects for p in effect(n).parameters if p.log}
    for i, k in enumerate(model.parameter_names):
        if split_name(k)[0] in own:
            yield (k, float(model.bounds[0][i]), float(model.bounds[1][i]), float(rung.x[i]),
                   split_name(k)[0] in logs)


def _near_face(v: float, face: float, lo: float, hi: float, log: bool) -> bool:
    """``v`` within :data:`AT_LIMIT` of the range from ``face``: of its decades for a log-scaled parameter of
    positive range (an effective height from 0.1 um to 0.5 mm: within 0.9 % of a face, not within 0.5 um)."""
    if log and lo > 0.0 and math.isfinite(hi) and v > 0.0:
        return abs(math.log(v / face)) <= AT_LIMIT * math.log(hi / lo)
    return abs(v - face) <= AT_LIMIT * (hi - lo)


def at_physical_range(rung: FitResult, effects) -> list[str]:
    """The fit parameters of the instrument's ``effects`` in ``rung`` that end on the far face of their
    physical range (within :data:`AT_LIMIT` of it, of its decades for a log-scaled one; the face at 0, their
    off value, does not count): an
    effect of the instrument there stands in for a force the instrument cannot give (tethers pulled on
    the retract, the sample's creep in a hold).

    Parameters
    ----------
    rung : FitResult
        A fitted model (its ``bound_model`` and ``x``).
    effects : iterable of str
        Effects of the instrument in it.
    """
    out = []
    for k, lo, hi, v, log in _parameters_of(rung, effects):
        for face in (lo, hi):
            if face != 0.0 and math.isfinite(face) and _near_face(v, face, lo, hi, log):
                out.append(k)
    return out


def switched_off(rung: FitResult, effects) -> list[str]:
    """The instrument's ``effects`` (names) that ``rung`` (as in :func:`at_physical_range`) fitted at their null
    value: every parameter of the effect that has an off value (drag's viscosity and far-field coefficient, the
    body's drag area, a baseline's drift) is at it, on every curve: on the face of its range that is the off
    value (within :data:`AT_LIMIT` of the range), or within :data:`NULL_SD` standard deviations of it. Such an
    effect gives no force the data show: the fit found it absent, and it is not named (the same model without
    it fits as well)."""
    params, std = getattr(rung, "parameters", None) or {}, getattr(rung, "std", None) or {}
    out = []
    for n in effects:
        on_face = [abs(v) <= AT_LIMIT * (hi if math.isfinite(hi) else 1.0)
                   for _, lo, hi, v, _ in _parameters_of(rung, (n,)) if lo == 0.0 and hi > 0.0]
        offs = {p.name: p.off for p in effect(n).parameters if p.off is not None}
        near = []
        for k, v in params.items():
            off, sd = offs.get(split_name(k)[0]), std.get(k)
            if off is not None and isinstance(v, (int, float)):
                near.append(isinstance(sd, (int, float)) and math.isfinite(sd) and abs(v - off) < NULL_SD * sd)
        if (on_face and all(on_face)) or (near and all(near)):
            out.append(n)
    return out


def examine_instrument(fitter: Fitter, add: tuple, candidates) -> tuple[tuple, list]:
    """The instrument's effects the curve shows, fitted together on top of ``add``.

    Every combination of the instrument's candidates (:attr:`~skin_indent.effects.Effect.instrument`:
    drag, the baselines; at most 7 combinations of 3) that can show in the data is fitted on top of
    the current model, with the sample's parameters: drag and a drift may each fail alone where
    together they explain the parts out of contact. A combination is not named when it leaves a part out
    of contact worse than the current model (:func:`worsened_out_of_contact`: it buys its BIC in contact)
    or ends on the far face of its physical range (:func:`at_physical_range`). The combination of lowest
    BIC (at the effective sample size of these fits) is named when it lowers the BIC by more than
    :data:`STRONG`. The parts
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
        off = switched_off(f, c)
        worse = worsened_out_of_contact(fitter, current, f)
        if worse:  # bought in contact at the expense of the parts that determine it
            hidden["+".join(c)] = (f"leaves the {', '.join(worse)} out of contact worse than without it: it "
                                   "stands in for the sample in contact, not for the instrument")
            continue
        if off:  # fitted at its null value: the same fit as the combination without it, which is tried too
            hidden["+".join(c)] = (f"{', '.join(off)} fitted at {'their' if len(off) > 1 else 'its'} null value "
                                   "(no force): the data do not show it")
            continue
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
