"""What a fitted model leaves on each segment of a curve: its misfit against the noise and its whiteness.

A diagnosis calls a curve explained only when every segment is (:func:`segment_misfits`): the
approach, the hold and the retract each to the noise (RMS within
:data:`~.criteria.ALLOWANCE` of the noise and the model error) with a white residual. What is
left is said per segment (:func:`segments_sentence`: "approach explained; retract 12x the
noise, model too stiff from 27 to 31 um").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..inverse.residuals import analyse_residuals, describe_structure
from ..measurement.scale import Quantity, Unit, UnitText, joined
from .criteria import ALLOWANCE

#: fewest points of a segment that is judged on its own
MIN_POINTS = 5


@dataclass(frozen=True)
class SegmentMisfit:
    """The misfit of one segment of one curve.

    Attributes
    ----------
    curve : int
        The curve (0 for a single curve).
    kind : str
        ``approach``, ``hold`` or ``retract``.
    n : int
        Points of the segment.
    rms_mN, noise_mN : float
        RMS residual and the curve's noise, mN.
    level_mN : float
        What the RMS is judged against: the noise and the model error in quadrature (RMS over the
        segment's points), mN.
    white : bool
        The segment's residual has no structure at the noise level, by the rule of
        :func:`~.criteria.explained` for a whole curve: the runs and Ljung-Box tests pass at alpha, or
        pass at alpha / 10 while no range departs from the model (its level is judged by the RMS).
    where : list of dict
        The ranges where the residual departs (:func:`~skin_indent.inverse.residuals.describe_structure`):
        depths (mm), or times (s) in a hold.
    """

    curve: int
    kind: str
    n: int
    rms_mN: float
    noise_mN: float
    white: bool
    where: list
    level_mN: float = float("nan")

    @property
    def ratio(self) -> float:
        """RMS over the noise."""
        return self.rms_mN / self.noise_mN

    @property
    def explained(self) -> bool:
        """To the noise and the model error (within :data:`~.criteria.ALLOWANCE`) and white."""
        return bool(self.white and self.rms_mN <= ALLOWANCE * self.level_mN)

    def sentence(self):
        """``"approach explained"`` or ``"retract 12x the noise, model too stiff from a to b mm"``."""
        if self.explained:
            return f"{self.kind} explained ({self.ratio:.2g}x the noise, white)"
        how = f"{self.ratio:.3g}x the noise" + ("" if self.white else ", structured")
        if self.kind == "hold":
            ranges = [f"model too {r['sign'].split()[1]} from {r['from_mm']:.3g} to {r['to_mm']:.3g} s"
                      for r in self.where]
        else:
            ranges = [UnitText("model too {sign} from {a:.3g} to {b:.3g} {unit}", sign=r["sign"].split()[1],
                               a=Quantity(r["from_mm"], "from_mm"), b=Quantity(r["to_mm"], "to_mm"),
                               unit=Unit("mm")) for r in self.where]
        return joined("", [f"{self.kind} {how}"] + ([", ", joined(", ", ranges)] if ranges else []))

    def to_dict(self) -> dict:
        return {"curve": self.curve, "segment": self.kind, "n_points": self.n, "rms_mN": self.rms_mN,
                "noise_mN": self.noise_mN, "noise_and_model_error_mN": self.level_mN, "rms_over_noise": self.ratio, "white": self.white,
                "explained": self.explained, "where": list(self.where)}


def segment_misfits(fitter, rung) -> list[SegmentMisfit]:
    """Every segment's misfit of ``rung`` (each curve of a sample in input order, segments in time order).

    Parameters
    ----------
    fitter : Fitter
        The curves, their noise, the error model (:meth:`~skin_indent.fitting.multistart.Fitter.sigma`).
    rung : FitResult
        A fitted model of them.
    """
    r_all = np.asarray(rung.residual_mN, dtype=float)
    s_all = fitter.sigma(rung.prediction_mN)
    out = []
    slices = fitter.data.slices if fitter.joint else [slice(0, fitter.data.n)]
    for k, (c, sl, noise) in enumerate(zip(fitter.curves, slices, fitter.noises_mN)):
        r, s = r_all[sl], s_all[sl]
        for kind in ("approach", "hold", "retract"):
            sel = c.kind == kind
            if np.count_nonzero(sel) < MIN_POINTS:
                continue
            rs, ss = r[sel], s[sel]
            level = float(np.sqrt(np.mean(ss**2)))
            x = c.time_s[sel] if kind == "hold" and c.time_s is not None else c.depth_mm[sel]
            where = describe_structure(x, rs, float(np.median(ss)))
            try:
                a = analyse_residuals(rs * (noise / ss), noise, 0,
                                      noise_dof=None if fitter.noise_dof is None else 0.35 * c.n)
                p = min(a.runs_p, a.ljung_box_p)
                white = bool(p > a.alpha or (p > a.alpha / 10 and not where))
            except ValueError:  # too few points for the tests
                white = True
            out.append(SegmentMisfit(k, kind, int(np.count_nonzero(sel)), float(np.sqrt(np.mean(rs**2))), float(noise),
                                     white, where, level))
    return out


def segments_sentence(misfits, joint: bool = False):
    """What is left, per segment, in words ("approach explained; retract 12x the noise, ...")."""
    parts = []
    for m in misfits:
        head = f"curve {m.curve + 1} " if joint else ""
        parts.append(joined("", [head, m.sentence()]))
    return joined("; ", parts)
