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

Effects that cannot show in the data are not fitted but reported as "not detectable
here" with the reason: viscoelasticity needs time and a change of rate (a hold, an
unloading or two speeds); friction is weighed by finite-element runs at full stick
against what E and nu absorb; adhesion needs tensile forces (a retract segment).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..fit_recorded import fit_in_force_units
from ..measurement import Measurement
from .data import SEGMENTS, DiagnosisData, estimate_data_noise, nice_depth, prepare
from .evidence import adhesion_visible, friction_visible, suggest_measurement, viscoelastic_visible
from .models import EFFECT_NU, FITTABLE, BoundModel, reported_parameters
from .residuals import analyse_residuals, describe_structure, effective_sample_size

#: the candidate effects, in the vocabulary of :mod:`skin_indent.effects`
CANDIDATES = ("layer", "stiffening", "viscoelastic", "friction", "adhesion", "offset")
#: relative accuracy of the forward model (FE + surface), added to the noise in quadrature
MODEL_ERROR = 0.003
#: BIC drop that names an effect
STRONG = 10.0
#: BIC difference under which two candidates explain the data equally well: ``ambiguous``
#: (Kass & Raftery: less is "not worth more than a bare mention")
CLOSE = 2.0
#: BIC difference under which the runner-up is not excluded: named in ``confounded_with``,
#: with the measurement that would separate it from the winner
RIVAL = 10.0


# ----------------------------------------------------------------------------- fits
@dataclass
class Fit:
    """One fitted model of the diagnosis (a rung of the ladder or a candidate).

    Attributes
    ----------
    model : str
        ``neo-hooke`` plus ``+effect`` for each effect.
    effects : tuple of str
    parameters, std : dict
        Identified parameters with units and their standard deviations.
    prediction_mN, residual_mN : ndarray
    rms_mN : float
    chi2 : float
        Sum of squared residuals over sigma_i^2 (noise and model error).
    n_parameters : int
    bic : float
        With the effective sample size of the comparison (set by :func:`diagnose`).
    white : bool
    analysis : ResidualAnalysis
    structure : str
        Where the residual departs from the noise, in words.
    """

    model: str
    effects: tuple
    parameters: dict
    std: dict
    prediction_mN: np.ndarray
    residual_mN: np.ndarray
    rms_mN: float
    chi2: float
    n_parameters: int
    white: bool = False
    bic: float = math.nan
    analysis: object = None
    structure: str = ""
    evaluate: object = field(default=None, repr=False)

    def to_dict(self) -> dict:
        return {"model": self.model, "parameters": _clean(self.parameters), "std": _clean(self.std),
                "rms_mN": float(self.rms_mN), "bic": self.bic, "white": self.white, "n_parameters": self.n_parameters,
                "structure": self.structure}


def _clean(d: dict) -> dict:
    """JSON-safe numbers: NaN -> None, +-inf -> "inf"/"-inf" (a rigid base has ratio inf)."""
    out = {}
    for k, v in d.items():
        v = float(v)
        out[k] = None if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else v
    return out


def _fmt_params(f: "Fit") -> str:
    parts = []
    for k, v in f.parameters.items():
        s = f.std.get(k, math.nan)
        if math.isinf(v):
            parts.append(f"{k} = inf (rigid)")
        else:
            parts.append(f"{k} = {v:.4g}" + ("" if not math.isfinite(s) else f" +- {s:.2g}"))
    return ", ".join(parts)


class _Context:
    """Surfaces and data shared by the fits of one diagnosis."""

    def __init__(self, data: DiagnosisData, radius_mm: float, noise_mN: float, *, noise_known: bool, cache_dir, workers, client,
                 scheduler, progress, mesh):
        from ..identify import hertz_modulus

        self.data = data
        self.radius_mm = radius_mm
        self.noise_mN = noise_mN
        # an estimated noise level is uncertain: ~12% for 100 points (estimate_noise), i.e. ~0.35 n dof
        self.noise_dof = None if noise_known else 0.35 * data.n
        self.kw = dict(cache_dir=cache_dir, workers=workers, client=client, scheduler=scheduler,
                       progress=progress)
        self.mesh = mesh
        load = (data.kind == "approach") & (data.depth_mm - data.contact_guess_mm > 0)
        h = data.depth_mm[load] - data.contact_guess_mm
        if np.count_nonzero(load) < 3:
            raise ValueError(f"{data.source}: fewer than 3 loading points in contact to diagnose")
        self.max_depth = float(np.max(data.depth_mm - data.contact_guess_mm))
        self.e_star = hertz_modulus(h, np.maximum(data.force_mN[load], 0.0), radius_mm)
        self._surfaces = {}
        self.fits: dict[tuple, Fit] = {}

    def sigma(self, force) -> np.ndarray:
        return np.sqrt(self.noise_mN**2 + (MODEL_ERROR * np.abs(force)) ** 2)

    def _grid(self, depth_max, nu):
        from ..response_surface import SurfaceGrid

        top = nice_depth(depth_max)
        E = np.geomspace(self.e_star / 30.0, self.e_star * 30.0, 8)
        E = np.array([float(f"{e:.3g}") for e in E])
        return SurfaceGrid(np.linspace(top / 100, top, 100), E, np.asarray(nu, dtype=float))

    def surface(self, effect: str | None):
        """The elastic core: base surface (effect None), or an effect surface."""
        if effect in self._surfaces:
            return self._surfaces[effect]
        if effect is None:
            from ..response_surface import ResponseSurface, default_settings

            grid = self._grid(1.25 * self.max_depth, np.linspace(0.2, 0.49, 6))
            s = ResponseSurface.load_or_build(grid, default_settings(radius_mm=self.radius_mm, mesh=self.mesh),
                                              **self.kw)
        else:
            from ..response_surface.effect_surface import EffectSurface, default_axes

            grid = self._grid(self.max_depth, EFFECT_NU)
            s = EffectSurface.build((effect,), default_axes(effect, grid.depth_mm[-1]), grid,
                                    radius_mm=self.radius_mm, mesh=self.mesh, **self.kw)
        self._surfaces[effect] = s
        return s

    # ------------------------------------------------------------------ fits
    def model(self, effects: tuple) -> BoundModel:
        elastic = [e for e in effects if e in ("layer", "stiffening")]
        if len(elastic) > 1:
            raise ValueError(f"no surface combines {' and '.join(elastic)} yet: add one of them")
        core = self.surface(elastic[0] if elastic else None)
        d = self.data
        top = core.depth_range[1]
        guess = d.contact_guess_mm
        span = self.max_depth
        off = ("offset" in effects) or guess > 0
        bounds = (guess - min(0.25 * span, max(top - span, 0.0)), guess + 0.3 * span)
        peak = float(np.max(np.abs(d.force_mN)))
        return BoundModel(core, d.depth_mm, d.time_s, offset=off, viscoelastic="viscoelastic" in effects,
                          adhesion="adhesion" in effects, radius_mm=self.radius_mm,
                          w_max_mJ_per_m2=peak / (2e-3 * math.pi * self.radius_mm),
                          offset_bounds_mm=bounds, name="neo-hooke" + "".join(f"+{e}" for e in effects))

    def starts(self, model: BoundModel, effects: tuple) -> list[np.ndarray]:
        lo, hi = model.bounds
        names = model.parameter_names
        nu0 = min(max(0.45, lo[1]), hi[1])
        base = {"E_kPa": self.e_star * (1 - nu0**2), "nu": nu0, "offset_mm": self.data.contact_guess_mm}
        prev = self.fits.get(tuple(e for e in effects if e != effects[-1])) if effects else None
        if prev is not None:
            for k in ("E_kPa", "nu", "offset_mm"):
                if k in prev.parameters:
                    base[k] = prev.parameters[k]
            if "C20_kPa" in prev.parameters:
                base["C20_over_E"] = prev.parameters["C20_kPa"] / prev.parameters["E_kPa"]
            if "ratio" in prev.parameters:
                r = prev.parameters["ratio"]
                base["compliance"] = 0.0 if math.isinf(r) else 1.0 / r
            for k in ("thickness_mm", "g1", "tau1_s"):
                if k in prev.parameters:
                    base[k] = prev.parameters[k]
        options = {"compliance": (0.0, 0.5, 4.0), "thickness_mm": (np.sqrt(lo[names.index("thickness_mm")] *
                                                                          hi[names.index("thickness_mm")]),)
                   if "thickness_mm" in names else (), "C20_over_E": (0.5, 4.0), "g1": (0.3,),
                   "w_mJ_per_m2": (0.1 * hi[names.index("w_mJ_per_m2")],) if "w_mJ_per_m2" in names else ()}
        if "tau1_s" in names:
            dur = float(self.data.time_s[-1] - self.data.time_s[0])
            options["tau1_s"] = (dur / 20, dur / 4, dur)
        varied = [k for k in names if k in options and k not in base]
        grids = [options[k] for k in varied]
        out = []
        for combo in (np.array(np.meshgrid(*grids, indexing="ij")).reshape(len(grids), -1).T if grids else [()]):
            x = []
            for k in names:
                if k in varied:
                    v = combo[varied.index(k)]
                else:
                    v = base.get(k, 0.5 * (lo[names.index(k)] + hi[names.index(k)]))
                x.append(v)
            out.append(np.clip(np.array(x, dtype=float), lo, hi))
        return out

    def fit(self, effects: tuple) -> Fit:
        key = tuple(effects)
        if key in self.fits:
            return self.fits[key]
        model = self.model(key)
        d = self.data
        best = None
        for x0 in self.starts(model, key):
            try:
                # in units of a tenth of the peak force, so that AFM curves (1e-5 mN) fit like skin (10 mN)
                res = fit_in_force_units(model, d.depth_mm, d.force_mN, x0, "lsq", noise_mN=self.noise_mN)
            except ValueError:
                continue
            if best is None or res.rms_mN < best.rms_mN:
                best = res
        if best is None:
            raise ValueError(f"the model {model.name} could not be fitted")
        x = np.array([best.parameters[n] for n in model.parameter_names])
        pred = model.force(d.depth_mm, x)
        r = d.force_mN - pred
        cov = np.full((x.size, x.size), np.nan)
        idx = [model.parameter_names.index(n) for n in best.free_names]
        cov[np.ix_(idx, idx)] = best.covariance
        params, std = reported_parameters(model.parameter_names, x, cov)
        s = self.sigma(pred)
        fit = Fit(model.name, key, params, std, pred, r, float(np.sqrt(np.mean(r**2))),
                  float(np.sum((r / s) ** 2)), len(best.free_names),
                  evaluate=lambda m=model, xx=x: (m, xx))
        z = r * (self.noise_mN / s)  # residuals standardised to the noise level
        fit.analysis = analyse_residuals(z, self.noise_mN, fit.n_parameters, noise_dof=self.noise_dof)
        fit.white = fit.analysis.white
        fit.structure = structure_sentence(d, r, s)
        self.fits[key] = fit
        return fit


def structure_sentence(data: DiagnosisData, residual, sigma) -> str:
    """Where the residual departs from the noise, per segment, in words."""
    parts = []
    noise = float(np.median(sigma))
    for kind, label in (("approach", "loading"), ("hold", "hold"), ("retract", "unloading")):
        sel = data.kind == kind
        if np.count_nonzero(sel) < 5:
            continue
        if kind == "hold" and data.time_s is not None:
            ranges = describe_structure(data.time_s[sel], residual[sel], noise)
            text = [f"too {r['sign'].split()[1]} from {r['from_mm']:.3g} to {r['to_mm']:.3g} s" for r in ranges]
        else:
            ranges = describe_structure(data.depth_mm[sel], residual[sel], noise)
            text = [f"too {r['sign'].split()[1]} from {r['from_mm']:.3g} to {r['to_mm']:.3g} mm" for r in ranges]
        if text:
            parts.append(f"on {label}: model " + ", ".join(text))
    return "; ".join(parts) if parts else "no range departs from the model beyond the noise"


# ----------------------------------------------------------------------------- result
@dataclass
class Diagnosis:
    """The outcome of :func:`diagnose` (``to_dict`` gives the JSON of ``skin-indent diagnose --json``)."""

    data: DiagnosisData
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
    def current(self) -> Fit:
        return self.ladder[-1]

    @property
    def base(self) -> Fit:
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
        if d.baseline_mN:
            lines.append(f"baseline force subtracted: {d.baseline_mN:.4g} mN (pre-contact part)")
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
        base, cur = self.base, self.current
        contact = cur.parameters.get("offset_mm", 0.0)
        return {
            "data": self.data.source,
            "n_points": self.data.n,
            "binned": self.data.binned,
            "radius_mm": self.radius_mm,
            "noise_mN": self.noise_mN,
            "noise_source": self.noise_source,
            "model_error": MODEL_ERROR,
            "n_effective": self.n_effective,
            "baseline_mN": self.data.baseline_mN,
            "contact_point_mm": float(contact),
            "base": {"model": base.model, "parameters": _clean(base.parameters), "std": _clean(base.std),
                     "rms_mN": base.rms_mN, "bic": base.bic, "white": base.white, "structure": base.structure},
            "current": {"model": cur.model, "parameters": _clean(cur.parameters), "std": _clean(cur.std),
                        "rms_mN": cur.rms_mN, "bic": cur.bic, "white": cur.white, "structure": cur.structure},
            "ranking": [{"effect": f.effects[-1], "delta_bic": cur.bic - f.bic, **f.to_dict()} for f in self.ranking],
            "not_detectable": dict(self.not_detectable),
            "verdict": self.verdict,
            "confounded_with": list(self.confounded_with),
            "suggested_measurement": self.suggested_measurement,
            "sentence": self.sentence(),
            "ladder": [{"model": f.model, "rms_mN": f.rms_mN, "bic": f.bic, "white": f.white,
                        "parameters": _clean(f.parameters), "std": _clean(f.std)} for f in self.ladder],
            "notes": list(self.notes),
        }


# ----------------------------------------------------------------------------- the workflow
def diagnose(measurement: Measurement, *, radius_mm: float = 6.22, candidates=CANDIDATES, add=(),
             noise_mN: float | None = None, segments=SEGMENTS, cache_dir=None, workers=None, client=None, scheduler=None,
             progress: bool = False, mesh: str = "coarse") -> Diagnosis:
    """Compare the model with a measured curve and name the physical effect it misses.

    Parameters
    ----------
    measurement : Measurement
        Depth (mm), force (mN) and, if recorded, time (s): every segment is used.
    radius_mm : float
        Sphere radius, mm.
    candidates : sequence of str
        Effects to test (:data:`CANDIDATES`).
    add : sequence of str
        Effects added to the base model, in order: each is a rung of the ladder,
        and the candidates are tested on top of the last rung.
    noise_mN : float, optional
        Noise standard deviation, mN; default estimated from the data.
    segments : sequence of str
        Kinds of motion to diagnose (default all: ``approach``, ``hold``, ``retract``);
        only trailing ones can be left out.
    cache_dir, workers, client, scheduler, progress
        Where and how the response surfaces are built or found (see
        :meth:`skin_indent.response_surface.ResponseSurface.build`).
    mesh : str
        Mesh family member of the forward runs. Default ``"coarse"``: it is within
        0.03% of ``"medium"`` at 0.6 mm (the mesh-convergence study of
        ``examples/ex03``), ten times below :data:`MODEL_ERROR`, and layered runs cost
        a third.

    Returns
    -------
    Diagnosis
    """
    from ..effects import effect

    for name in (*candidates, *add):
        effect(name)  # one line naming the vocabulary for an unknown name
    add = tuple(add)
    if len(set(add)) != len(add):
        raise ValueError(f"each effect may be added once, got {add}")
    for name in add:
        if name not in FITTABLE:
            raise ValueError(f"add {name}: only {', '.join(FITTABLE)} can be added to a fitted model so far")
    if not (math.isfinite(radius_mm) and radius_mm > 0):
        raise ValueError(f"radius must be a positive number of mm, got {radius_mm}")
    data = prepare(measurement, segments=tuple(segments))
    if noise_mN is None:
        sigma, source = estimate_data_noise(data), "estimated from the data (local cubic prediction)"
        if data.binned > 1:
            source += f" after averaging bins of {data.binned} samples"
    else:
        if not (math.isfinite(noise_mN) and noise_mN > 0):
            raise ValueError(f"noise must be a positive number of mN, got {noise_mN}")
        sigma, source = float(noise_mN) / math.sqrt(data.binned), "given"
    ctx = _Context(data, radius_mm, sigma, noise_known=noise_mN is not None, cache_dir=cache_dir, workers=workers, client=client,
                   scheduler=scheduler, progress=progress, mesh=mesh)
    ladder = [ctx.fit(add[:i]) for i in range(len(add) + 1)]
    current = ladder[-1]
    not_detectable: dict[str, str] = {}
    notes: list[str] = []
    tried = []
    for name in candidates:
        if name in add:
            continue
        if name == "offset" and data.contact_guess_mm > 0:
            not_detectable[name] = "the contact point is already fitted (the curve starts before contact)"
            continue
        why = None
        if name == "viscoelastic":
            why = viscoelastic_visible(data)
        elif name == "adhesion":
            why = adhesion_visible(data, sigma)
        elif name == "friction":
            continue  # weighed below, at the nu of the best-fitting model
        if why is not None:
            not_detectable[name] = why
            continue
        try:
            tried.append(ctx.fit(add + (name,)))
        except ValueError as err:
            not_detectable[name] = f"not fitted: {err}"
    fits = [current, *tried]
    best = min(fits, key=lambda f: f.chi2)
    if "friction" in candidates:
        why, info = friction_visible(ctx, best)
        if why is None:
            why = (f"full stick could change this curve beyond the noise (chi-square {info['chi2_gain_after_refit']:.3g} "
                   f"after refitting E and nu, at nu = {info['nu']:.2f}), but no friction model is fitted yet")
        not_detectable["friction"] = why
    n = data.n
    n_eff = float(min(max(effective_sample_size(best.residual_mN * ctx.noise_mN / ctx.sigma(best.prediction_mN)),
                          2.0 * max(f.n_parameters for f in fits) + 2), n))
    for f in (*ladder, *tried):
        f.bic = f.chi2 * n_eff / n + f.n_parameters * math.log(n_eff)
    ranking = sorted(tried, key=lambda f: f.bic)
    verdict, confounded, suggestion = "none", [], None
    if ranking and current.bic - ranking[0].bic > STRONG:
        top = ranking[0]
        rivals = [f for f in ranking[1:] if f.bic - top.bic < RIVAL and current.bic - f.bic > STRONG]
        close = [f for f in rivals if f.bic - top.bic < CLOSE]
        verdict = "ambiguous" if close else top.effects[-1]
        if rivals:  # named or not, a rival the data do not exclude is reported with the test that would
            confounded = ([top.effects[-1]] if close else []) + [f.effects[-1] for f in rivals]
            suggestion = suggest_measurement(ctx, top, rivals[0])
    return Diagnosis(data, sigma, source, radius_mm, ladder, ranking, not_detectable, verdict, confounded,
                     suggestion, n_eff, notes)
