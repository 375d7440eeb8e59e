r"""Diagnose a measured curve: fit, find where the model fails, name the missing effect.

The workflow of :func:`diagnose`:

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
   the AR(1) effective sample size of the best model's residual. An effect is named
   when it lowers the BIC by more than :data:`STRONG` (Kass & Raftery's "very strong"
   evidence); ``none`` when nothing does; ``ambiguous`` when the runner-up is within
   :data:`CLOSE` of the winner. A runner-up within :data:`RIVAL` is not excluded by
   the data: it is reported in ``confounded_with``, with the measurement that would
   separate the two, quantified from the two fitted models.
4. **Add it.** ``add`` refits with the named effects and reports the ladder: RMS,
   BIC and whiteness at every rung.

The candidates are the registered effects (:data:`skin_indent.effects.EFFECTS`): each
says whether it can show in the data (:meth:`~skin_indent.effects.Effect.visible`: a
viscoelastic effect needs time and a change of rate, adhesion tensile forces...), and
those that cannot are reported as "not detectable here" with the reason; an effect that
is weighed rather than fitted (friction) says what it could change.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..effects import EFFECTS, WEIGHED, effect
from ..measurement import SEGMENTS, Measurement, PreparedCurve, prepare
from .evidence import suggest_measurement
from .fits import MODEL_ERROR, Fitter, Rung
from .residuals import effective_sample_size

#: at most this many points are fitted (longer curves are averaged in bins, in time order)
MAX_POINTS = 400
#: BIC drop that names an effect
STRONG = 10.0
#: BIC difference under which two candidates explain the data equally well: ``ambiguous``
#: (Kass & Raftery: less is "not worth more than a bare mention")
CLOSE = 2.0
#: BIC difference under which the runner-up is not excluded: named in ``confounded_with``,
#: with the measurement that would separate it from the winner
RIVAL = 10.0




def _fmt_params(f: Rung) -> str:
    parts = []
    for k, v in f.parameters.items():
        s = f.std.get(k, math.nan)
        if math.isinf(v):
            parts.append(f"{k} = inf (rigid)")
        else:
            parts.append(f"{k} = {v:.4g}" + ("" if not math.isfinite(s) else f" +- {s:.2g}"))
    return ", ".join(parts)


# ----------------------------------------------------------------------------- result
@dataclass
class Diagnosis:
    """The outcome of :func:`diagnose` (``to_dict`` gives the JSON of ``skin-indent diagnose --json``)."""

    data: PreparedCurve
    noise_mN: float
    noise_source: str
    radius_mm: float
    ladder: list
    ranking: list
    not_detectable: dict
    verdict: str
    confounded_with: list
    suggested_measurement: str | None
    n_effective: float
    notes: list = field(default_factory=list)

    @property
    def current(self) -> Rung:
        return self.ladder[-1]

    @property
    def base(self) -> Rung:
        return self.ladder[0]

    def sentence(self) -> str:
        cur = self.current
        if self.verdict == "none":
            return (f"The {cur.model} model explains this curve to the noise level ({cur.rms_mN:.3g} mN RMS "
                    f"against {self.noise_mN:.3g} mN noise): no missing effect is needed.")
        top = self.ranking[0]
        effect = top.effects[-1]
        others = [e for e in self.confounded_with if e != effect]
        if self.verdict == "ambiguous":
            return (f"The {cur.model} model fails ({cur.structure}); {effect} and {' or '.join(others)} explain it "
                    f"about equally well: {self.suggested_measurement}")
        text = (f"The {cur.model} model fails ({cur.structure}); the missing effect is {self.verdict}: adding it "
                f"lowers the RMS from {cur.rms_mN:.3g} to {top.rms_mN:.3g} mN (noise {self.noise_mN:.3g} mN) "
                f"and the BIC by {cur.bic - top.bic:.1f}.")
        if others:
            text += f" {' and '.join(others).capitalize()} is not excluded: {self.suggested_measurement}."
        return text

    def report(self) -> str:
        """The diagnosis as text (what ``skin-indent diagnose`` prints)."""
        d = self.data
        lines = [f"data: {d.source} ({d.n} points" + (f", bins of {d.binned}" if d.binned > 1 else "") + "; "
                 + ", ".join(f"{k} {np.count_nonzero(d.kind == k)}" for k in ("approach", "hold", "retract")
                             if np.any(d.kind == k)) + f"), sphere R = {self.radius_mm:g} mm",
                 f"noise: {self.noise_mN:.4g} mN, {self.noise_source}; model error {100 * MODEL_ERROR:g}% of the "
                 f"force added in quadrature; effective sample size {self.n_effective:.1f}"]
        if d.baseline is not None:
            lines.append(f"baseline force subtracted: {d.baseline_mN:.4g} mN at the contact point (pre-contact "
                         "part)")
        lines += [f"note: {n}" for n in d.notes]
        lines.append("ladder:")
        for f in self.ladder:
            lines.append(f"  {f.model:<28} RMS {f.rms_mN:.4g} mN  BIC {f.bic:9.1f}  "
                         f"{'white' if f.white else 'structured'}  {_fmt_params(f)}")
        lines.append(f"where {self.current.model} fails: {self.current.structure}")
        lines.append("candidates (delta BIC > 0: better than the current model):")
        for f in self.ranking:
            lines.append(f"  +{f.effects[-1]:<13} dBIC {self.current.bic - f.bic:8.1f}  RMS {f.rms_mN:.4g} mN  "
                         f"{'white' if f.white else 'structured'}  {_fmt_params(f)}")
        for k, v in self.not_detectable.items():
            lines.append(f"  {k:<14} not detectable here: {v}")
        lines.append(f"verdict: {self.verdict}")
        lines.append(self.sentence())
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        from .._json import jsonable

        base, cur = self.base, self.current
        contact = cur.parameters.get("offset_mm", 0.0)
        return jsonable({
            "data": self.data.source,
            "n_points": self.data.n,
            "binned": self.data.binned,
            "bic_formula": Rung.BIC_FORMULA,
            "radius_mm": self.radius_mm,
            "noise_mN": self.noise_mN,
            "noise_source": self.noise_source,
            "model_error": MODEL_ERROR,
            "n_effective": self.n_effective,
            "baseline_mN": self.data.baseline_mN,
            "contact_point_mm": float(contact),
            "base": {"model": base.model, "parameters": base.parameters, "std": base.std,
                     "rms_mN": base.rms_mN, "bic": base.bic, "white": base.white, "structure": base.structure},
            "current": {"model": cur.model, "parameters": cur.parameters, "std": cur.std,
                        "rms_mN": cur.rms_mN, "bic": cur.bic, "white": cur.white, "structure": cur.structure},
            "ranking": [{"effect": f.effects[-1], "delta_bic": cur.bic - f.bic, **f.summary()} for f in self.ranking],
            "not_detectable": dict(self.not_detectable),
            "verdict": self.verdict,
            "confounded_with": list(self.confounded_with),
            "suggested_measurement": self.suggested_measurement,
            "sentence": self.sentence(),
            "ladder": [{"model": f.model, "rms_mN": f.rms_mN, "bic": f.bic, "white": f.white,
                        "parameters": f.parameters, "std": f.std} for f in self.ladder],
            "notes": list(self.notes),
        })


# ----------------------------------------------------------------------------- the workflow
def diagnose(measurement, *, radius_mm: float | None = None, candidates=None, add=(), noise_mN: float | None = None,
             segments=SEGMENTS, context=None, mesh: str = "coarse", **build) -> Diagnosis:
    """Compare the model with a measured curve and name the physical effect it misses.

    Parameters
    ----------
    measurement : Measurement or PreparedCurve
        Depth (mm), force (mN) and, if recorded, time (s): every segment is used.
    radius_mm : float, optional
        Sphere radius, mm; default the measurement's (else the skin default 6.22 mm).
    candidates : sequence of str, optional
        Effects to test (default: every registered effect).
    add : sequence of str
        Effects added to the base model, in order: each is a rung of the ladder,
        and the candidates are tested on top of the last rung.
    noise_mN : float, optional
        Noise standard deviation, mN; default estimated from the data.
    segments : sequence of str
        Kinds of motion to diagnose (default all: ``approach``, ``hold``, ``retract``);
        only trailing ones can be left out.
    context : Context, optional
        Where the response surfaces are cached and built (or the keywords ``cache_dir``,
        ``workers``, ``client``, ``scheduler``, ``progress`` of a :class:`~skin_indent.Context`).
    mesh : str
        Mesh family member of the forward runs. Default ``"coarse"``: it is within
        0.03% of ``"medium"`` at 0.6 mm (the mesh-convergence study of
        ``examples/ex03``), ten times below :data:`MODEL_ERROR`, and layered runs cost
        a third.

    Returns
    -------
    Diagnosis
    """
    from ..context import context_of

    context = context_of(context, **build)
    candidates = tuple(EFFECTS) if candidates is None else tuple(candidates)
    for name in (*candidates, *add):
        effect(name)  # one line naming the vocabulary for an unknown name
    add = tuple(effect(a).name for a in add)
    candidates = tuple(effect(c).name for c in candidates)
    if len(set(add)) != len(add):
        raise ValueError(f"each effect may be added once, got {add}")
    for name in add:
        if effect(name).stage == WEIGHED:
            raise ValueError(f"add {name}: it is weighed, not fitted; no fitted model has it yet")
    if isinstance(measurement, PreparedCurve):
        data = measurement
    else:
        if radius_mm is not None and not (math.isfinite(radius_mm) and radius_mm > 0):
            raise ValueError(f"radius must be a positive number of mm, got {radius_mm}")
        data = prepare(measurement, segments=tuple(segments), radius_mm=radius_mm, max_points=MAX_POINTS)
    if noise_mN is None:
        sigma, source = data.high_frequency_noise_mN(), "estimated from the data (local cubic prediction)"
        if data.binned > 1:
            source += f" after averaging bins of {data.binned} samples"
    else:
        if not (math.isfinite(noise_mN) and noise_mN > 0):
            raise ValueError(f"noise must be a positive number of mN, got {noise_mN}")
        sigma, source = float(noise_mN) / math.sqrt(data.binned), "given"
    fitter = Fitter(data, sigma, noise_known=noise_mN is not None, context=context, mesh=mesh)
    ladder = [fitter.fit(add[:i]) for i in range(len(add) + 1)]
    current = ladder[-1]
    not_detectable: dict[str, str] = {}
    tried, weighed = [], []
    for name in candidates:
        if name in add:
            continue
        e = effect(name)
        why = e.visible(data, sigma)
        if why is not None:
            not_detectable[name] = why
            continue
        if e.stage == WEIGHED:
            weighed.append(e)  # at the nu of the best-fitting model, below
            continue
        try:
            tried.append(fitter.fit(add + (name,)))
        except ValueError as err:
            not_detectable[name] = f"not fitted: {err}"
    fits = [current, *tried]
    best = min(fits, key=lambda f: f.chi2_weighted)
    for e in weighed:
        not_detectable[e.name] = e.weigh(fitter, best)
    n = data.n
    n_eff = float(min(max(effective_sample_size(best.residual_mN * fitter.noise_mN / fitter.sigma(best.prediction_mN)),
                          2.0 * max(f.n_parameters for f in fits) + 2), n))

    def scored(f: Rung) -> Rung:
        return dataclasses.replace(f, bic=f.chi2_weighted * n_eff / n + f.n_parameters * math.log(n_eff))

    ladder = [scored(f) for f in ladder]
    current = ladder[-1]
    ranking = sorted((scored(f) for f in tried), key=lambda f: f.bic)
    verdict, confounded, suggestion = "none", [], None
    if ranking and current.bic - ranking[0].bic > STRONG:
        top = ranking[0]
        rivals = [f for f in ranking[1:] if f.bic - top.bic < RIVAL and current.bic - f.bic > STRONG]
        close = [f for f in rivals if f.bic - top.bic < CLOSE]
        verdict = "ambiguous" if close else top.effects[-1]
        if rivals:  # named or not, a rival the data do not exclude is reported with the test that would
            confounded = ([top.effects[-1]] if close else []) + [f.effects[-1] for f in rivals]
            suggestion = suggest_measurement(fitter, top, rivals[0])
    return Diagnosis(data, sigma, source, data.radius_mm, ladder, ranking, not_detectable, verdict, confounded,
                     suggestion, n_eff, [])
