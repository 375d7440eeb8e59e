"""The result of fitting one model to several curves of one sample (:func:`~skin_indent.fitting.fit_model`
with a list of curves).

One set of material and effect parameters, each curve with its own sphere radius,
contact point and noise (:class:`~skin_indent.models.JointModel`): :class:`SampleFit` holds
the fit (everything of :class:`~skin_indent.inverse.IdentificationResult`, the parameters
shared and each curve's own, ``offset_mm[2]``) and, per curve, what a fit of one curve
reports of its data: the radius, the points, the noise, the RMS and the misfit, and
whether its residual is white. The numbers are those of the diagnosis's rung of the same
model on the same curves (one fitter, :class:`~skin_indent.fitting.multistart.Fitter`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..measurement.scale import display_units
from ..runtime.json_io import jsonable
from .ended import limit_notes
from .result import FitResult, ScoredResult, curve_summaries, knowledge_of
from .rung import reported_correlations
from .surfaces import interpolation_flags
from .scale_checks import MISFIT_FLAG, contact_points, depth_ratio_flags, modulus_flags, points_flags, undetermined_flags


@dataclass(frozen=True, eq=False)
class SampleFit(FitResult):
    """A model fitted to several curves of one sample.

    Everything of every fit (:class:`~skin_indent.fitting.result.FitResult`: the model, each curve's
    summary in ``curves``, flags, notes, priors, error model, provenance), with each curve's points.

    Attributes
    ----------
    prepared : list of PreparedCurve
    prediction_mN : list of ndarray
        The model's force at each curve's points (mN).
    """

    prepared: list = field(default_factory=list)
    prediction_mN: list = field(default_factory=list)

    @property
    def rms_of_curves(self) -> list[float]:
        """Each curve's RMS residual (mN), in input order."""
        return [c["rms_mN"] for c in self.curves]

    def to_dict(self) -> dict:
        out = super().to_dict()
        out.update({"rms_mN": self.rms_of_curves, "rms_all_mN": self.rms_mN})
        return jsonable(out)

    def report(self, digits: int = 5, units=None) -> str:
        """Readable summary: the curves, the parameters (shared, then each curve's own), each curve's
        misfit, what the user knew, flags and notes; in the units of the first curve's scale."""
        u = units or display_units(self.curves[0]["radius_mm"])
        L, F = u.length, u.force
        lines = [f"model: {self.model}, fitted to {len(self.curves)} curves of one sample (the material shared, each "
                 "curve its own sphere, contact point and noise)"]
        for k, c in enumerate(self.curves, 1):
            contact = ("contact at recorded depth 0 (starts in contact)" if c["contact_point_std_mm"] is None
                       and c["contact_mode"] == "origin" else
                       f"contact point {c['contact_point_mm'] * u.per_mm:.6g} {L} (offset_mm[{k}])")
            lines.append(f"curve {k}: {c['data']} ({c['n_points']} points), sphere R = {c['radius_mm'] * u.per_mm:g} "
                         f"{L} ({c['radius_source']}); {contact}")
        lines.append(super().report(digits, units=u))
        for k, c in enumerate(self.curves, 1):
            lines.append(f"quality of curve {k}: RMS {c['rms_mN'] * u.per_mN:.3g} {F} = {c['misfit']:.2g} x its noise "
                         f"{c['noise_mN'] * u.per_mN:.3g} {F} ({c['noise_source']}); residual "
                         f"{'white' if c['white'] else 'structured'}")
        if self.error_model:
            lines.append(f"error model: each point weighed by sqrt(noise^2 + ({self.error_model['model_error']:g} F)^2), "
                         "the noise of its own curve and the forward model's relative error")
        lines.extend(f"flag: {f}" for f in self.flags)
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)

    __str__ = report


def sample_fit_of(rung, fitter, *, noise_sources) -> SampleFit:
    """The :class:`SampleFit` of a rung fitted to several curves: the numbers the diagnosis's ladder
    shows for that model, with each curve's data treatment, misfit and the flags."""
    flags = list(rung.flags)  # how the fit ended (fitting.ended), as the ladder shows it
    flags += modulus_flags(rung.parameters.get("E_kPa", math.nan))
    flags += interpolation_flags(rung.bound_model, rung.x)
    curves = curve_summaries(rung, fitter, noise_sources)
    predictions = [np.asarray(rung.prediction_mN)[sl] for sl in fitter.data.slices]
    for k, (c, cv) in enumerate(zip(fitter.curves, curves)):
        where = f"curve {k + 1} ({c.source}): "
        if cv["misfit"] > MISFIT_FLAG:
            flags.append(f"{where}misfit {cv['misfit']:.3g} x the noise: the model does not describe this curve and "
                         "the parameters are not to be trusted")
        flags += depth_ratio_flags(float((np.max(c.depth_mm) - cv["contact_point_mm"]) / c.radius_mm),
                                   float(c.radius_mm), where)
    n_contact = sum(contact_points(c, cv["contact_point_mm"]) for c, cv in zip(fitter.curves, curves))
    flags += points_flags(n_contact, int(rung.n_free))
    flags += undetermined_flags(rung.parameters, rung.std, list(rung.std),
                                tuple(rung.at_bounds) + tuple(n for e in rung.ended for n in e.parameters))
    known_flags, known_notes = knowledge_of(rung, fitter)
    notes = [f"curve {k + 1} ({c.source}): {n}" for k, c in enumerate(fitter.curves) for n in c.notes] + known_notes
    notes += limit_notes(rung, rung.bound_model, rung.x)
    base = {f.name: getattr(rung, f.name) for f in dataclasses.fields(ScoredResult)}
    return SampleFit(**base, model=rung.model, curves=curves, prepared=list(fitter.curves), prediction_mN=predictions,
                     flags=tuple(dict.fromkeys(flags + known_flags)), notes=notes, priors=dict(rung.priors),
                     error_model=fitter.error_model(), correlations=reported_correlations(rung))
