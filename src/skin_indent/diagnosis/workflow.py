r"""Diagnose a measured curve: fit, find where the model fails, name the missing effect.

The workflow of :func:`diagnose`:

0. **The instrument.** The effects of the measurement (:attr:`~skin_indent.effects.Effect.instrument`:
   ``drag`` on the probe, the ``baselines`` of the segments) that can show in the curve are fitted
   together with the sample's parameters, every combination of them, and the best is kept when it
   lowers the BIC by more than :data:`STRONG`; they stay in every model below and are named apart
   (:attr:`Diagnosis.instrument`), never in the sample's verdict. After the sample's climb the
   instrument is looked at again on top of its model; when that names more, the sample's climb
   starts again with the instrument complete. A curve that the instrument's effects alone explain
   is ``none`` for the sample.
1. **Compare.** Fit the current model (the neo-Hookean half-space, plus effects
   already added with ``add``) to every segment of the curve (loading, hold,
   unloading: hysteresis, creep and pull-off are evidence).
2. **Where it fails.** Judge the residual against the noise (runs test, Ljung-Box,
   chi-square; :mod:`.residuals`) and describe its structure per segment in words.
3. **Which effect is missing.** Refit the model with each candidate effect added
   (every fit runs on cached response surfaces, so no screening shortcut is needed)
   and rank them by

   .. math::

       \mathrm{BIC} = \frac{n_\mathrm{eff}}{n} \sum_i \frac{r_i^2}{\sigma_i^2} + k \ln n_\mathrm{eff},
       \qquad \sigma_i^2 = \sigma^2 + (\varepsilon F_i)^2,

   where :math:`\sigma` is the noise, :math:`\varepsilon` = :data:`MODEL_ERROR` the
   relative accuracy of the forward model itself (independent FE codes agree with ours
   to 0.08-0.22%), :math:`k` the number of fitted parameters and :math:`n_\mathrm{eff}`
   the AR(1) effective sample size of the residual of the best-fitting model of the
   first examination (the given model and each candidate on top of it). It is computed
   once: every BIC a diagnosis reports, and every comparison it makes (the ladder, the
   candidates, the explanations climbed side by side), uses that one value. An effect
   is named when it lowers the BIC by more than :data:`STRONG` (Kass & Raftery's "very
   strong" evidence); ``ambiguous`` when the runner-up is within :data:`CLOSE` of the
   winner. A runner-up within :data:`RIVAL` is not excluded by the data: it is reported
   in ``confounded_with``, with the measurement that would separate the two,
   quantified from the two fitted models.
4. **Add it.** ``add`` refits with the named effects and reports the ladder: RMS,
   BIC and whiteness at every rung.
5. **Say what was not tried.** When nothing named is missing, the verdict is ``none``
   if the model explains the curve to the noise and ``unexplained`` if it does not. The curve
   is explained only when every segment is (approach, hold, retract: each to the noise and
   white, :mod:`.segment_misfit`); what is left is said per segment.
   Combinations that were not fitted (no response surface covers them and the
   finite-element model in the loop is switched off, a fit that failed, a rung the climb
   reached at ``max_rungs`` and did not examine) are listed in ``untried``, and the
   verdict is then ``provisional``.

The candidates are the registered effects (:data:`skin_indent.effects.EFFECTS`): each
says whether it can show in the data (:meth:`~skin_indent.effects.Effect.visible`: a
viscoelastic effect needs time and a change of rate, adhesion tensile forces...), and
those that cannot are reported as "not detectable here" with the reason; an effect that
is weighed rather than fitted (friction) says what it could change.

Everything is computed by :func:`diagnose`, finite-element runs included (the
standard deviations that decide whether a parameter is determined, the measurement
that would determine it, the measurement that separates two explanations): a
:class:`Diagnosis` is plain data, and its text, sentence, JSON and HTML page show one
set of numbers per model.
"""

from __future__ import annotations

import dataclasses
import logging
import re

from ..effects import EFFECTS, WEIGHED, effect, instances
from ..effects.order import same_model
from ..effects.repeat import addable
from ..measurement import SEGMENTS, CurveSet
from .evidence import suggest_measurement
from ..fitting.model_fit import curve_noise, is_several, prepare_curve, prepare_sample, sample_noise
from ..fitting.scale_checks import check_scale, contact_points, points_flags
from ..fitting.surfaces import interpolation_flags
from ..fitting.multistart import Fitter
from ..models.joint import split_name
from .identifiability import determine, explanations, loose, weigh
from .criteria import (ALLOWANCE, BEAM, CLOSE, FROM_FE, FROM_FIT, NOT_FITTED, RIVAL, STRONG, Scores, effective_size,
                       explained,
                       settled, unmoved)
from .result import Diagnosis, Step
from .instrument import at_physical_range, examine_instrument, switched_off
from .segment_misfit import segment_misfits
from .branches import contains as _contains, joins
from .knowns import AFM_NU, check_known, known_starts, scale_conventions
from ..runtime.context import context_of
from ..runtime.provenance import records_call, surface_identity

log = logging.getLogger(__name__)

__all__ = ["AFM_NU", "ALLOWANCE", "BEAM", "CLOSE", "FROM_FE", "FROM_FIT", "NOT_FITTED", "RIVAL", "STRONG", "Diagnosis", "Scores",
           "Step", "check_known", "determine", "diagnose", "explained", "scale_conventions",
           "settled"]


def _examine(fitter: Fitter, key: tuple, candidates, scores: Scores) -> Step:
    """Fit every candidate on top of the rung ``key`` and rank them by BIC."""
    current = fitter.fit(key)
    not_detectable: dict[str, str] = {}
    tried, weighed, wanted = [], [], []
    for name in candidates:
        e = effect(name)
        if not addable(key, name):
            continue
        why = fitter.visible(e)
        if why is not None:
            not_detectable[name] = why
            continue
        if e.stage == WEIGHED:
            weighed.append(e)  # at the nu of the best-fitting model, below
            continue
        wanted.append(name)
    log.info("examining %s: %d candidate%s on top (%s)", "+".join(("neo-hooke",) + key), len(wanted),
             "s" if len(wanted) != 1 else "", ", ".join(wanted) or "none")
    fitted = fitter.fit_all([key + (name,) for name in wanted])  # the finite-element fits side by side
    for name in wanted:
        f = fitted[key + (name,)]
        if isinstance(f, ValueError):
            not_detectable[name] = f"{NOT_FITTED}: {f}"
        elif unmoved(f) is not None:  # a fit that did not move tests nothing: never ranked (criteria.unmoved)
            not_detectable[name] = unmoved(f)
        else:
            tried.append(f)
    best = min([current, *tried], key=lambda f: f.chi2_weighted)
    for e in weighed:
        not_detectable[e.name] = e.weigh(fitter, best)
    current = scores(current)
    ranking = sorted((scores(f) for f in tried), key=lambda f: f.bic)
    verdict, rivals = "none", []
    if ranking and current.bic - ranking[0].bic > STRONG:
        top = ranking[0]
        rivals = [f for f in ranking[1:] if f.bic - top.bic < RIVAL and current.bic - f.bic > STRONG]
        verdict = "ambiguous" if any(f.bic - top.bic < CLOSE for f in rivals) else top.effects[-1]
    return Step(current, ranking, not_detectable, verdict, rivals)


def _climb(fitter: Fitter, key: tuple, candidates, scores: Scores, rungs_left: int, steps: list,
           kept=()) -> tuple[tuple, tuple | None]:
    """Greedy climb from ``key``: add the named effect while the rung is not :func:`settled`, and
    until it :func:`joins` a rung of ``kept`` (the rungs of the explanations climbed before):
    ``(the last rung, the rung it joined or None)``."""
    while rungs_left > 0 and not settled(fitter.fit(key), fitter):
        joined = joins(fitter, key, kept, scores)
        if joined is not None:
            return key, joined
        step = _examine(fitter, key, candidates, scores)
        steps.append(step)
        if step.verdict in ("none", "ambiguous"):
            if step.verdict == "ambiguous":  # the best of the close ones; the comparison is reported
                key = key + (step.ranking[0].effects[-1],)
                rungs_left -= 1
                continue
            break
        key = key + (step.verdict,)
        rungs_left -= 1
    return key, None


def _fittable(fitter: Fitter, key: tuple, candidates) -> list[str]:
    """The candidates an examination of ``key`` would fit on top of it (visible, fitted, not there unless repeatable)."""
    out = []
    for name in candidates:
        e = effect(name)
        if e.stage != WEIGHED and addable(key, name) and fitter.visible(e) is None:
            out.append(name)
    return out


def _untried(fitter: Fitter, examined, unexamined: tuple | None, candidates, max_rungs: int) -> dict:
    """``{"layer+layer": why}``: the combinations not fitted by the examinations ``examined`` (every
    explanation climbed), and those on top of the last rung ``unexamined`` that the climb reached at
    ``max_rungs`` without examining it (None: none such); each model once, in the first order met
    (``stiffening+layer`` is ``layer+stiffening``: :func:`~skin_indent.effects.order.same_model`)."""
    out: dict[str, str] = {}

    def note(key: tuple, why: str) -> None:  # a model once: not again in another order (effects.order)
        if not any(same_model(key, tuple(k.split("+"))) for k in out):
            out["+".join(key)] = why

    for step in examined:
        for name, why in step.not_detectable.items():
            if not why.startswith(NOT_FITTED):
                continue
            why = why[len(NOT_FITTED):].lstrip(": ")
            why = re.sub(r"^the model \S+ could not be fitted$", "the fit failed from every start", why)
            # fewer points in contact than the model's parameters need (Fitter.check_points): one reason for all
            why = re.sub(r"^.*?: (\d+) point\(s\) in contact for \d+ fitted parameter\(s\) of \S+, at least \d+ "
                         r"needed.*$", r"too few points: \1 in contact, fewer than each model's fitted parameters + 2",
                         why)
            if not fitter.in_loop and "in the loop" in why:
                why = ("no response surface combines these effects, and in_loop=False (--surfaces-only) switches "
                       "off the finite-element model in the loop")
            note(step.rung.effects + (name,), why)
    if unexamined is not None:
        for name in _fittable(fitter, unexamined, candidates):
            note(unexamined + (name,), f"the climb stopped at max_rungs = {max_rungs} before examining "
                                       f"{'+'.join(unexamined) or 'the given model'}")
    return out


@records_call("skin_indent.diagnose", data="measurement",
              leave_out=("context", "cache_dir", "workers", "client", "scheduler", "progress"))
def diagnose(measurement, *, radius_mm=None, candidates=None, add=(), noise_mN=None,
             segments=SEGMENTS, max_rungs: int = 3, in_loop: bool = True, context=None, mesh: str = "coarse",
             fixed: dict | None = None, priors: dict | None = None, free=(), starts=None, **build) -> Diagnosis:
    """Compare the model with a measured curve, name the effects it misses and add them.

    Parameters
    ----------
    measurement : Measurement or PreparedCurve, or a list of them
        Depth (mm), force (mN) and, if recorded, time (s): every segment is used. A list
        is several curves of ONE sample (two spheres, two depths, two speeds, a ramp and a
        ramp-hold), diagnosed together: the material's and the effects' parameters are
        shared, each curve keeps its own sphere radius, contact point, baseline and noise,
        and every residual is weighed by its own curve's noise; the ladder, the BIC and the
        verdict are computed on all curves together (each rung also reports every curve's
        RMS: :attr:`~skin_indent.fitting.FitResult.curve_rms_mN`).
    radius_mm : float or list of float, optional
        Sphere radius, mm; default the measurement's (else the skin default 6.22 mm). For
        several curves, one per curve (or one for all).
    candidates : sequence of str, optional
        Effects to test (default: every registered effect).
    add : sequence of str
        Effects added to the base model by hand, in order: each is a rung of the
        ladder (``("layer", "layer")``: two layers), and the diagnosis goes on from the last.
    noise_mN : float or list of float, optional
        Noise standard deviation, mN (one per curve for several); default estimated from the data.
    segments : sequence of str
        Kinds of motion to diagnose (default all: ``approach``, ``hold``, ``retract``);
        only trailing ones can be left out.
    max_rungs : int
        Effects the automatic climb may add on top of ``add`` (0: examine the last rung
        and stop). The climb adds the named effect, diagnoses again on top, and stops
        when the rung explains the curve to the noise (:func:`explained`), or no
        candidate lowers the BIC by more than :data:`STRONG`. When the first examination
        names a runner-up too (BIC lower than the model's by more than :data:`STRONG`),
        its branch is climbed as well (a beam of :data:`BEAM`) and the two explanations
        are compared (``alternatives``): within :data:`CLOSE` of each other the verdict
        is ``ambiguous``; within :data:`RIVAL`, the other is named with the measurement
        that would separate them. The runner-up's branch stops where it becomes a rung of
        the first explanation with its own effect doing nothing on top of it (:func:`joins`:
        the contact points of curves that start in contact): it is that explanation.
    in_loop : bool
        Fit combinations of elastic effects that no response surface covers (two layers,
        layer and stiffening) with the finite-element model in the loop
        (:class:`~skin_indent.models.fe_core.FECore`; tens of forward runs, minutes on 2
        cores each). ``False``: such candidates are reported as not fitted, with the reason.
    context : Context, optional
        Where the response surfaces are cached and built (or the keywords ``cache_dir``,
        ``workers``, ``client``, ``scheduler``, ``progress`` of a :class:`~skin_indent.Context`).
    mesh : str
        Mesh family member of the forward runs. Default ``"coarse"``: it is within
        0.03% of ``"medium"`` at 0.6 mm (the mesh-convergence study of
        ``examples/ex03``), ten times below :data:`MODEL_ERROR`, and layered runs cost
        a third.
    fixed : dict, optional
        What the user knows exactly, by the names results report (``{"thickness_mm": 1.2}``,
        ``{"nu": 0.45}``): held in every model that has the parameter.
    priors : dict, optional
        What the user knows with an uncertainty, ``{name: (mean, sd)}`` (a dermis thickness
        from ultrasound: ``{"thickness_mm": (1.2, 0.1)}``): a Gaussian prior in every model that
        has the parameter (:func:`~skin_indent.fitting.fit_model`); each rung's ``priors`` says
        whether the data or the prior determined it, and whether they agree.
    free : sequence of str
        Parameters fitted that the scale's convention holds: ``("nu",)`` fits nu at AFM scale, where
        every model otherwise holds it at :data:`~.knowns.AFM_NU` (:func:`~.knowns.scale_conventions`).
    starts : Diagnosis, list of Diagnosis or dict, optional
        Where fits with the finite-element model in the loop start when the same model was fitted
        before to curves of this sample (a diagnosis of one of the curves: ``{effects: fit
        parameters}`` of its rungs): from there first, the screened starts only if that fit fails or
        does not move. Only starts: what the fits end at decides.

    Returns
    -------
    Diagnosis

    Raises
    ------
    MeasurementError
        A curve whose scale cannot be right (forces in N labelled mN, a radius in um typed as mm:
        :func:`~skin_indent.fitting.scale_checks.check_scale`, the checks ``fit`` makes), before any
        finite-element work.
    """
    context = context_of(context, **build)
    candidates = tuple(EFFECTS) if candidates is None else tuple(candidates)
    for name in (*candidates, *add):
        effect(name)  # one line naming the vocabulary for an unknown name
    add = tuple(effect(a).name for a in add)
    candidates = tuple(effect(c).name for c in candidates)
    all_candidates = candidates
    instances(add)  # one line for an effect given twice that cannot repeat
    for name in add:
        if effect(name).stage == WEIGHED:
            raise ValueError(f"add {name}: it is weighed, not fitted; no fitted model has it yet")
    if isinstance(max_rungs, bool) or not isinstance(max_rungs, int) or max_rungs < 0:
        raise ValueError(f"max_rungs must be an integer >= 0, got {max_rungs!r}")
    if is_several(measurement):
        curves = prepare_sample(measurement, radius_mm=radius_mm, segments=segments)
        sigmas, sources = sample_noise(curves, noise_mN)
        data, sigma, source = CurveSet(tuple(curves)), sigmas[0], sources[0]
    else:
        data = prepare_curve(measurement, radius_mm=radius_mm, segments=segments)
        sigma, source = curve_noise(data, noise_mN)
        curves, sigmas, sources = [data], [sigma], [source]
    check_scale(data)
    fixed, scale_notes = scale_conventions(curves, fixed, priors, free)
    check_known(fixed, priors, (*candidates, *add), len(curves))
    fitter = Fitter(curves, sigmas, noise_known=noise_mN is not None, context=context, mesh=mesh, in_loop=in_loop,
                    fixed=fixed, priors={k: tuple(v) for k, v in (priors or {}).items()}, starts=known_starts(starts))
    for c, s in zip(curves, sigmas):
        log.info("diagnosing %d points of %s (%s), noise %.3g mN, sphere R = %g mm, mesh %s; finite elements in the "
                 "loop %s", c.n, c.source, ", ".join(k for k in segments if c.has(k)) or "no segment", s, c.radius_mm,
                 mesh, "allowed" if in_loop else "off")
    for i in range(len(add) + 1):
        fitter.fit(add[:i])
    # the instrument first: drag and the baselines, which the parts out of contact determine, are
    # fitted with the sample's parameters and stay in every model the sample's climb fits
    given = add
    instrument_candidates = tuple(c for c in candidates if effect(c).instrument)
    candidates = tuple(c for c in candidates if not effect(c).instrument)
    instrument, instrument_steps = examine_instrument(fitter, add, instrument_candidates)
    excluded: set = set()  # the instrument's effects dropped at the edge of their physical range
    dropped_notes = []
    while True:
        add = given + instrument
        # the first examination: the candidates on top of the given model; the effective sample size of
        # the best fit there is that of every BIC of the diagnosis (each decision and each number reported)
        fits = [fitter.fit(add)]
        keys = [add + (name,) for name in _fittable(fitter, add, candidates)]
        fits += [f for f in fitter.fit_all(keys).values() if not isinstance(f, ValueError)]
        n_eff = effective_size(fitter, fits)
        scores = Scores(data.n, n_eff)
        first = _examine(fitter, add, candidates, scores)
        steps = [first]
        examined = [first]  # every examination, in every explanation climbed
        branches = []
        if first.verdict != "none" and max_rungs > 0:
            named = [f for f in first.ranking[1:] if first.rung.bic - f.bic > STRONG]
            heads = [first.ranking[0]] + named[:BEAM - 1]
            kept: list[tuple] = []  # the rungs of the explanations climbed so far
            for head in heads:
                log.info("climbing from %s (at most %d more rung%s)", head.model, max_rungs - 1,
                         "s" if max_rungs != 2 else "")
                branch_steps = []
                key, joined = _climb(fitter, head.effects, candidates, scores, max_rungs - 1, branch_steps, kept)
                examined += branch_steps
                if joined is None:  # else it is the explanation climbed before: that one's end stands for both
                    branches.append((key, branch_steps))
                    kept += [head.effects] + [s.rung.effects for s in branch_steps] + [key]
        notes = [*scale_notes, *dropped_notes]
        alternatives = []
        if branches:
            finals = sorted(((scores(fitter.fit(k)), k, st) for k, st in branches), key=lambda t: t[0].bic)
            best_rung, key, more = finals[0]
            steps += more
            # another explanation is a set of effects that neither contains the chosen one nor is
            # contained in it (the same set in another order, or one effect more, is the same explanation)
            alternatives = [f for f, k, _ in finals[1:] if not (_contains(k, key) or _contains(key, k))]
        else:
            key = add
        # a second look at the instrument, on top of the sample's model: an effect of the instrument
        # that the sample's misfit hid (the near-wall drag standing in for relaxation in contact) is
        # named now, and the sample's climb starts again from the given model with the instrument's
        # effects complete (what they explain may leave an effect of the sample unneeded)
        # an effect of the instrument pushed to the edge of its physical range by the sample's effects
        # stands in for a force the instrument cannot give: dropped, and the climb made again without it
        # and one fitted at its null value once another joined it (drag at 0 beside the body's drag) gives no
        # force: not named, and the climb made again without it
        pinned = {split_name(k)[0] for k in at_physical_range(fitter.fit(key), instrument)}
        off = switched_off(fitter.fit(key), instrument)
        drop = tuple(n for n in instrument if set(effect(n).fit_names) & pinned or n in off)
        if drop:
            excluded |= set(drop)
            instrument = tuple(n for n in instrument if n not in drop)
            if any(n not in off for n in drop):
                dropped_notes.append(f"{', '.join(n for n in drop if n not in off)} not named for the instrument: in "
                                     f"{fitter.fit(key).model} {', '.join(sorted(pinned))} end(s) at the edge of the "
                                     "physical range (a force the instrument cannot give: tethers, the sample's creep)")
            if off:
                dropped_notes.append(f"{', '.join(off)} not named for the instrument: in {fitter.fit(key).model} it "
                                     "is fitted at its null value (no force; the other effects hold what it held)")
            continue
        more, more_steps = examine_instrument(fitter, key, tuple(c for c in instrument_candidates
                                                          if c not in key and c not in excluded))
        if not more:
            break
        instrument, instrument_steps = instrument + more, instrument_steps + more_steps
    ladder = [scores(fitter.fit(key[:i])) for i in range(len(key) + 1)]
    missing = key[len(add):]
    verdict, confounded, suggestion = first.verdict, [], None
    if missing and len(steps) > 1:
        # the rivals of the rung that added the last effect (e.g. layer+stiffening against
        # layer+layer on top of one layer): other explanations the data do not exclude
        last = next((s for s in reversed(steps[1:]) if s.ranking and s.ranking[0].effects == key), None)
        if last is not None:
            seen = {tuple(sorted(f.effects)) for f in alternatives} | {tuple(sorted(key))}
            alternatives = alternatives + [scores(f) for f in last.rivals if tuple(sorted(f.effects)) not in seen]
    if missing and explained(ladder[-1], fitter) and not settled(ladder[-1], fitter):
        # the last rung explains the curve only from the edge of a range (a layer as thin as the
        # model solves): a candidate on top of it that explains the curve as well from inside its
        # ranges is another explanation, though it holds the same effects and one more
        top = next((s for s in reversed(steps) if s.rung.effects == key), None)
        if top is not None:
            seen = {tuple(sorted(f.effects)) for f in alternatives}
            alternatives = alternatives + [f for f in top.ranking if settled(f, fitter)
                                           and tuple(sorted(f.effects)) not in seen]
    close = [f for f in alternatives if f.bic - ladder[-1].bic < CLOSE]
    rival_sets = sorted((f for f in alternatives if f.bic - ladder[-1].bic < RIVAL), key=lambda f: f.bic)
    if missing:
        verdict = "ambiguous" if close else "+".join(missing)
    if rival_sets:
        confounded = ["+".join(ladder[-1].effects[len(add):])] + ["+".join(f.effects[len(add):]) for f in rival_sets]
    elif first.rivals and not missing:
        confounded = [first.ranking[0].effects[-1]] + [f.effects[-1] for f in first.rivals]
    is_explained = explained(ladder[-1], fitter)
    if verdict == "none" and not is_explained:
        verdict = "unexplained"  # nothing fitted helps, and the model does not explain the curve
    # what was not tried: candidates not fitted, and those on top of a last rung the climb reached
    # at max_rungs without examining it
    final = ladder[-1]
    unexamined = None
    if not any(s.rung.effects == key for s in examined) and not settled(fitter.fit(key), fitter):
        unexamined = key
    untried = _untried(fitter, examined, unexamined, candidates, max_rungs)

    # the one engine of the next measurement (identifiability.weigh): what the candidates would separate
    # and, where the fit leaves a parameter loose, determine; the last rung's standard deviations, as they
    # decide what the curve determines (finite-element derivatives of the recorded curve): one set of numbers
    rungs = explanations(final, bool(missing), rival_sets, first)
    with_std = (bool(loose(final, fitter.fixed)) and fitter.in_loop and final.bound_model is not None
                and final.x is not None)
    outlook = None
    if len(rungs) > 1 or with_std:
        try:
            outlook = weigh(rungs, final, fitter.curves, fitter.noises_mN, with_std=with_std, priors=fitter.priors,
                            mesh=fitter.mesh, context=fitter.context)
        except ValueError as err:  # no measurement can be predicted (too few points in contact)
            notes.append(f"no other measurement predicted: {err}")
    std, std_source, not_determined, _ = determine(final, fitter.fixed, outlook)
    if len(rungs) > 1:
        suggestion = suggest_measurement(outlook)
    # fewer points in contact than the last rung's parameters need to be judged (5 each): said in a note
    notes += points_flags(contact_points(data), final.n_free)
    notes += interpolation_flags(final.bound_model, final.x)  # the last rung's surface, where it is not exact
    pinned = at_physical_range(final, instrument)
    if pinned:  # named inside its range, pushed to its edge once the sample's effects joined it
        notes.append(f"{', '.join(pinned)} of the instrument end(s) at the edge of the physical range in "
                     f"{final.model}: the instrument cannot give that force; something the model does not hold "
                     "(tethers, the sample's creep) is taken by it")
    if std != final.std:
        scores.rungs[key] = dataclasses.replace(final, std=std)

    def one(f):  # every rung the diagnosis holds is its model's one scored rung
        return scores.rungs[f.effects]

    steps = [dataclasses.replace(s, rung=one(s.rung), ranking=[one(f) for f in s.ranking],
                                 rivals=[one(f) for f in s.rivals]) for s in steps]
    segments_left = segment_misfits(fitter, final)
    if is_explained and not all(m.explained for m in segments_left):
        is_explained = False  # explained on the whole, not on every segment
        if verdict == "none":
            verdict = "unexplained"
    return Diagnosis(data, sigma, source, data.radius_mm, [one(f) for f in ladder], steps[0].ranking,
                     first.not_detectable, verdict, confounded, suggestion, n_eff, notes, steps=steps,
                     alternatives=[one(f) for f in alternatives], n_given=len(add),
                     explained=is_explained, std_source=std_source, not_determined=not_determined,
                     untried=untried, outlook=outlook, fixed=dict(fitter.fixed), priors=dict(fitter.priors),
                     mesh=fitter.mesh, surfaces=surface_identity(list(fitter.cores)), candidates=all_candidates,
                     curves=list(curves),
                     noises_mN=list(sigmas), noise_sources=list(sources), instrument=instrument,
                     instrument_steps=instrument_steps, segments=segments_left, n_user=len(given))
