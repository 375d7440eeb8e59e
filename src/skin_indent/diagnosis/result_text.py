"""What a :class:`~.result.Diagnosis` says in words: its report and the sentence of its verdict.

Functions of the diagnosis' plain data (``d``, a :class:`~.result.Diagnosis`), in the units
``u`` it is read in (:attr:`~.result.Diagnosis.units`, :mod:`skin_indent.measurement.scale`):
:func:`report_text` (what ``skin-indent diagnose`` prints) and :func:`verdict_sentence` (the
first sentences of :meth:`~.result.Diagnosis.sentence`), and the pieces they share.
"""

from __future__ import annotations

import math

import numpy as np

from ..effects import EFFECTS
from ..measurement.scale import DisplayUnits, shown_in
from ..fitting.bodies import body_lines
from ..fitting.knowledge import DETERMINED_BY
from ..fitting.result import FitResult
from ..fitting.rung import MODEL_ERROR
from .criteria import FROM_FE, STRONG


def fmt_params(f: FitResult, units: DisplayUnits) -> str:
    """A rung's parameters as the text of a diagnosis shows them, ``name = value +- sd``, in ``units``
    (names and values as :meth:`~skin_indent.measurement.scale.DisplayUnits.name` and ``factor`` make
    them: ``E_Pa = 203.9 +- 1.9`` at AFM scale for ``E_kPa = 0.2039 +- 0.0019``)."""
    parts = []
    for k, v in f.parameters.items():
        s = f.std.get(k, math.nan)
        name, c = units.name(k), units.factor(k)
        if math.isinf(v):
            parts.append(f"{name} = inf (rigid)")
        else:
            parts.append(f"{name} = {v * c:.4g}" + ("" if not math.isfinite(s) else f" +- {s * c:.2g}"))
    return ", ".join(parts)


def listed(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def plural(effects) -> list[str]:
    """``("layer", "layer", "offset")`` -> ``["2 layers", "offset"]``, in order of first appearance."""
    counts: dict = {}
    for e in effects:
        counts[e] = counts.get(e, 0) + 1
    return [f"{n} {e}s" if n > 1 else e for e, n in counts.items()]


def tested(d) -> str:
    """``"of the vocabulary"``, or which effects were tested when the candidates were restricted."""
    if d.candidates is None or set(EFFECTS) <= set(d.candidates):
        return "of the vocabulary"
    return f"tested ({', '.join(d.candidates) or 'no candidate was given'})"


def untried_clause(d) -> str:
    """``"not tried: a and b (why)[; c (why)]"`` (empty when everything was tried)."""
    groups: dict = {}
    for combo, why in d.untried.items():
        groups.setdefault(why, []).append(combo)
    return "; ".join(f"not tried: {listed(combos)} ({why})" for why, combos in groups.items())


def these(d) -> str:
    """``"this curve"``, or ``"these 2 curves"`` for several."""
    return f"these {len(d.curves)} curves" if d.joint else "this curve"


def rms_text(d, f: FitResult, units: DisplayUnits, digits: int = 3) -> str:
    """A rung's RMS as the sentences show it, in ``units.force`` (the unit is not written): each
    curve's, in input order, for several."""
    k = units.per_mN
    if d.joint and len(f.curve_rms_mN) > 1:
        return "(" + ", ".join(f"{v * k:.{digits}g}" for v in f.curve_rms_mN) + ")"
    return f"{f.rms_mN * k:.{digits}g}"


def noise_text(d, units: DisplayUnits, digits: int = 3) -> str:
    """The noise as the sentences show it, in ``units.force`` (each curve's for several)."""
    k = units.per_mN
    if d.joint:
        return "(" + ", ".join(f"{v * k:.{digits}g}" for v in d.noises_mN) + ")"
    return f"{d.noise_mN * k:.{digits}g}"


def verdict_sentence(d, u: DisplayUnits) -> str:
    """The verdict in words, its numbers in the units ``u``."""
    cur, base = d.current, d.ladder[d.n_given]
    first = d.steps[0] if d.steps else None
    untried = untried_clause(d)
    structure, suggested = shown_in(cur.structure, u), shown_in(d.suggested_measurement, u)
    F = u.force
    provisional = f" The verdict is provisional: {untried}." if untried else ""
    if not d.missing:
        if d.verdict == "ambiguous" and first is not None:
            effects = [first.ranking[0].effects[-1]] + [f.effects[-1] for f in first.rivals]
            return (f"The {cur.model} model fails ({structure}); {' and '.join(effects)} explain it "
                    f"about equally well: {suggested}" + provisional)
        if d.verdict not in ("none", "unexplained") and first is not None:  # named, not added (max_rungs = 0)
            top = first.ranking[0]
            return (f"The {cur.model} model fails ({structure}); the missing effect is {d.verdict}: "
                    f"adding it lowers the RMS from {rms_text(d, cur, u)} to {rms_text(d, top, u)} {F} (noise "
                    f"{noise_text(d, u)} {F}) and the BIC by {first.rung.bic - top.bic:.1f}." + provisional)
        if d.explained:
            return (f"The {cur.model} model explains {these(d)} to the noise level ({rms_text(d, cur, u)} {F} RMS "
                    f"against {noise_text(d, u)} {F} noise): no missing effect is needed." + provisional)
        text = (f"The {cur.model} model does not explain {these(d)} ({rms_text(d, cur, u)} {F} RMS against "
                f"{noise_text(d, u)} {F} noise; {structure})")
        if untried:
            return (text + f"; of the effects fitted, none lowers the BIC by more than {STRONG:g}, and the verdict "
                    f"is provisional: {untried}.")
        outside = ("outside the vocabulary" if tested(d) == "of the vocabulary"
                   else "not among the effects tested")
        return (text + f", and no effect {tested(d)} lowers the BIC by more than {STRONG:g}: what is "
                f"missing is {outside}.")
    rms = " -> ".join(rms_text(d, f, u) for f in d.ladder[d.n_given:])
    what = " and ".join(plural(d.missing))
    text = f"What the {base.model} model misses: {what} (RMS {rms} {F} against {noise_text(d, u)} {F} noise)"
    if d.explained:
        text += f"; the {cur.model} model explains {'the curve' if not d.joint else 'every curve'} to the noise."
    elif untried and not any(s.rung.effects == cur.effects for s in d.steps):  # stopped at max_rungs
        text += (f"; the {cur.model} model still leaves a structured residual ({structure}) and was not "
                 f"examined further, so the verdict is provisional: {untried}.")
        untried = ""
    elif untried:
        text += (f"; the {cur.model} model still leaves a structured residual ({structure}); of the effects "
                 f"fitted on top of it, none lowers the BIC by more than {STRONG:g}, and the verdict is "
                 f"provisional: {untried}.")
        untried = ""
    else:
        text += (f"; the {cur.model} model still leaves a structured residual ({structure}) and no further "
                 f"effect {tested(d)} lowers the BIC by more than {STRONG:g}.")
    if d.verdict == "ambiguous" or len(d.confounded_with) > 1:
        others = d.confounded_with[1:]
        text += (f" {' or '.join(others).capitalize()} explains it "
                 f"{'about equally well' if d.verdict == 'ambiguous' else 'nearly as well'}: "
                 f"{suggested}.")
    if untried:
        text += f" The verdict is provisional: {untried}."
    return text


def report_text(d, u: DisplayUnits) -> str:
    """:meth:`~.result.Diagnosis.report` of the diagnosis ``d`` in the units ``u``."""
    F = u.force
    curves = d.curves or [d.data]
    noises = d.noises_mN or [d.noise_mN]
    sources = d.noise_sources or [d.noise_source]
    lines = [f"{len(curves)} curves of one sample, diagnosed together (the material shared, each curve its own "
             "sphere, contact point and noise):"] if d.joint else []
    for k, (c, noise_mN, source) in enumerate(zip(curves, noises, sources)):
        head = f"curve {k + 1}: " if d.joint else "data: "
        lines.append(f"{head}{c.source} ({c.n} points" + (f", bins of {c.binned}" if c.binned > 1 else "") + "; "
                     + ", ".join(f"{kind} {np.count_nonzero(c.kind == kind)}"
                                 for kind in ("approach", "hold", "retract") if np.any(c.kind == kind))
                     + f"), sphere R = {c.radius_mm * u.per_mm:g} {u.length}")
        if d.joint:
            lines.append(f"  noise: {noise_mN * u.per_mN:.4g} {F}, {source}")
        if c.baseline is not None:
            lines.append(f"{'  ' if d.joint else ''}baseline force subtracted: {c.baseline_mN * u.per_mN:.4g} "
                         f"{F} at the contact point (pre-contact part)")
        lines += [f"{'  ' if d.joint else ''}note: {shown_in(n, u)}" for n in c.notes]
    errors = (f"model error {100 * MODEL_ERROR:g}% of the force added in quadrature; effective sample size "
              f"{d.n_effective:.1f} (every BIC below")
    if d.joint:
        lines.append(errors + ", all curves together)")
    else:
        lines.insert(1, f"noise: {d.noise_mN * u.per_mN:.4g} {F}, {d.noise_source}; {errors})")
    lines.append("ladder:" + (" (RMS of each curve, in input order)" if d.joint else ""))
    for f in d.ladder:
        how = f", finite elements in the loop ({f.forward_runs} runs)" if f.forward_runs else ""
        lines.append(f"  {f.model:<28} RMS {rms_text(d, f, u, 4)} {F}  BIC {f.bic:9.1f}  "
                     f"{'white' if f.white else 'structured'}  {fmt_params(f, u)}{how}")
        lines += [f"    flag: {shown_in(t, u)}" for t in f.flags]  # how its fit ended (fitting.ended)
    for f in d.alternatives:
        lines.append(f"  (other explanation) {f.model:<20} RMS {rms_text(d, f, u, 4)} {F}  BIC {f.bic:9.1f}  "
                     f"{'white' if f.white else 'structured'}  {fmt_params(f, u)}")
        lines += [f"    flag: {shown_in(t, u)}" for t in f.flags]
    for name, k in d.current.priors.items():
        c = u.factor(name)
        lines.append(f"  what you know, {u.name(name)}: prior {k['prior_mean'] * c:.4g} +- "
                     f"{k['prior_sd'] * c:.2g}, with the data {k['posterior'] * c:.4g} +- "
                     f"{k['posterior_sd'] * c:.2g} ({DETERMINED_BY[k['determined_by']]})"
                     + (f"; IN TENSION with the data ({k['tension_sd']:.1f} combined sd apart)"
                        if k["in_tension"] else ""))
    for name, v in d.fixed.items():
        if name in d.current.parameters:
            lines.append(f"  what you know, {u.name(name)}: held at {v * u.factor(name):g}")
    fe = [u.name(k) for k, v in d.std_source.items() if v == FROM_FE]
    if fe:
        lines.append(f"  standard deviations of {listed(fe)} ({d.current.model}): {FROM_FE} at the fitted "
                     "values (the others: the fit's covariance)")
    for i, step in enumerate(d.steps):
        lines.append(f"where {step.rung.model} fails: {shown_in(step.rung.structure, u)}")
        lines.append("candidates (delta BIC > 0: better than that model):")
        for f in step.ranking:
            lines.append(f"  +{f.effects[-1]:<13} dBIC {step.rung.bic - f.bic:8.1f}  RMS {rms_text(d, f, u, 4)} {F}  "
                         f"{'white' if f.white else 'structured'}  {fmt_params(f, u)}")
            lines += [f"    flag: {shown_in(t, u)}" for t in f.flags]
        for k, v in step.not_detectable.items():
            if v.startswith("not fitted"):
                lines.append(f"  +{k:<13} {shown_in(v, u)}")
            elif i == 0:  # what the data cannot show does not change up the ladder
                lines.append(f"  {k:<14} not detectable here: {shown_in(v, u)}")
    for step in d.instrument_steps:
        lines.append(f"the instrument, on top of {step.rung.model} (delta BIC > 0: better than that model):")
        for f in step.ranking:
            added = "+".join(f.effects[len(step.rung.effects):])
            lines.append(f"  +{added:<26} dBIC {step.rung.bic - f.bic:8.1f}  RMS {rms_text(d, f, u, 4)} {F}  "
                         f"{'white' if f.white else 'structured'}")
        for k, v in step.not_detectable.items():
            how = "not named" if "+" in k or "physical range" in v or v.startswith("not fitted") else \
                "not detectable here"
            lines.append(f"  {k:<14} {how}: {shown_in(v, u)}")
    if d.segments:
        lines.append(f"per segment, {d.current.model}:")
    for m in d.segments:
        lines.append(f"  segment {('curve %d ' % (m.curve + 1)) if d.joint else ''}{m.kind:<8} "
                     f"RMS {m.rms_mN * u.per_mN:.4g} {F} = {m.ratio:.3g}x the noise, "
                     f"{'white' if m.white else 'structured'}{'' if not m.explained else ' (explained)'}")
    lines.append(f"verdict: {d.verdict}" + (" (provisional)" if d.provisional else ""))
    lines.append(d.verdicts())
    if d.provisional:
        lines.append(f"provisional: {untried_clause(d)}")
    lines += body_lines(d.current, u)  # the final model: E of each body, thicknesses (fitting.bodies)
    lines.append(d.sentence(u))
    lines += [f"note: {shown_in(n, u)}" for n in d.notes]
    return "\n".join(lines)
