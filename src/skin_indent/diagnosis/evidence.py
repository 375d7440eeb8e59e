"""Which measurement would separate two explanations that explain a curve about equally well.

The sentence of a diagnosis (``suggested_measurement``), read from the one engine
(:mod:`.identifiability`: :func:`~.identifiability.weigh`, the candidates, predictions and
ranking that :func:`~skin_indent.diagnosis.planning.plan` reads too): it names the next
measurement, the candidate ranked first, with how far apart the choice and its closest rival
predict it (:func:`~.separation.separation`).
"""

from __future__ import annotations

import math

from ..measurement.scale import Quantity, UnitText
from .separation import Separation

__all__ = ["sentence", "suggest_measurement"]


def _names(a: str, b: str) -> tuple[str, str]:
    """How the sentence names two explanations (models ``neo-hooke+layer+stiffening``): the effect each
    adds on one rung, else their sets of effects."""
    ea, eb = tuple(a.split("+")[1:]), tuple(b.split("+")[1:])
    if len(ea) == len(eb) and ea[:-1] == eb[:-1]:
        return ea[-1], eb[-1]
    return "+".join(ea), "+".join(eb)


def sentence(candidate, s: Separation, ea: str, eb: str, noise_mN: float) -> str:
    """``"<measurement> would separate <ea> from <eb>: ..."`` with the separation's numbers.

    Parameters
    ----------
    candidate : Candidate
        The measurement (its ``label``: lengths in mm).
    s : Separation
        How far apart the two explanations predict it (the largest difference in mN).
    ea, eb : str
        How the sentence names the two explanations.
    noise_mN : float
        The recorded curve's noise (mN).

    Returns
    -------
    UnitText
        A ``str`` in package units (mm, mN: what JSON keeps) that keeps its numbers, so that the
        text of a diagnosis writes it in the units of the curve's scale
        (:func:`~skin_indent.measurement.scale.shown_in`: um and nN at AFM scale).
    """
    if s.repeat:
        return UnitText("{label} would separate {ea} from {eb} by {separation:.3g} noise units, the systematic part "
                        "of the chi-square gap the recorded curve gives (the fitted models differ there by up to "
                        "{diff:.3g}, {times:.1f} times the noise)", label=candidate.label, ea=ea, eb=eb,
                        separation=s.separation, diff=Quantity(s.max_difference_mN, "mN"),
                        times=s.max_difference_mN / noise_mN)
    return UnitText("{label} would separate {ea} from {eb}: the fitted models differ there by up to {diff:.3g}, "
                    "{times:.1f} times the noise, and by {separation:.3g} noise units in root-sum-square over its "
                    "{points} points", label=candidate.label, ea=ea, eb=eb, diff=Quantity(s.max_difference_mN, "mN"),
                    times=s.max_difference_mN / noise_mN, separation=s.separation, points=s.points)


def suggest_measurement(outlook) -> str:
    """Which extra measurement separates the explanations of an outlook, with the predicted difference.

    Parameters
    ----------
    outlook : Outlook
        :func:`~.identifiability.weigh` of the explanations (the choice first), ranked
        (:func:`~.identifiability.rank`): the next measurement is its first candidate, the one whose
        predicted curves lie furthest apart from the closest rival, in root-sum-square noise units.

    Returns
    -------
    str
        One sentence (without a final full stop): a
        :class:`~skin_indent.measurement.scale.UnitText` (:func:`sentence`) in package units that
        reads in the units of the curve's scale, or a plain ``str`` when no measurement separates them.
    """
    top = outlook.next if outlook is not None else None
    s = top.closest if top is not None else None
    if s is None or not math.isfinite(s.separation):
        return "no extra measurement computed here separates them"
    ea, eb = _names(s.a, s.b)
    return sentence(top.candidate, s, ea, eb, outlook.noise_mN)
