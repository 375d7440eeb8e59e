"""What candidate measurements would bring, as plain data: :class:`Assessment` (one candidate) and
:class:`Outlook` (every candidate, ranked), the outcome of :func:`~.identifiability.weigh` that a
:class:`~.result.Diagnosis` keeps and :func:`~.planning.plan` reads back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .criteria import RIVAL
from .measurements import Candidate
from .separation import Separation

#: a parameter is determined when its standard deviation is below this fraction of its value
DETERMINED = 0.5
#: below this separation (noise units) a candidate cannot separate two explanations: S^2, the chi-square
#: rise before refitting, is under :data:`~.criteria.RIVAL`, the BIC gap at which a diagnosis excludes a rival
TOO_CLOSE = math.sqrt(RIVAL)


# ----------------------------------------------------------------------------- results (plain data)
@dataclass
class Assessment:
    """What one candidate measurement would bring.

    Attributes
    ----------
    candidate : Candidate
    forces : dict
        ``{model: ndarray}``: each explanation's predicted curve at the candidate's points (mN).
    separations : list of Separation
        The choice against each rival (:class:`~.separation.Separation`).
    std : dict
        ``{reported parameter: standard deviation}`` of the current model when the candidate is
        fitted with the recorded curves (empty when not computed).
    determines : list of str
        The undetermined parameters it would determine (sd below :data:`DETERMINED` times the value).
    error : str or None
        Why it could not be predicted (a run that did not converge...), else None.
    """

    candidate: Candidate
    forces: dict = field(default_factory=dict, repr=False)
    separations: list = field(default_factory=list)
    std: dict = field(default_factory=dict)
    determines: list = field(default_factory=list)
    error: str | None = None

    @property
    def closest(self) -> Separation | None:
        """The separation of the closest rival (None without rival)."""
        return min(self.separations, key=lambda s: s.separation, default=None)

    @property
    def separation(self) -> float:
        """S of the closest rival (noise units; NaN without rival)."""
        return math.nan if self.closest is None else self.closest.separation

    @property
    def too_close(self) -> bool:
        """S^2 of a rival stays below :data:`~.criteria.RIVAL`: this candidate cannot separate it."""
        return self.closest is not None and self.separation < TOO_CLOSE

    def score(self, recorded_std: dict, names) -> float:
        """Sum of log(sd with the candidate / sd of the recorded curves alone) over ``names`` (lower is
        better; 0 without any)."""
        out = 0.0
        for k in names:
            sd, base = self.std.get(k, math.nan), recorded_std.get(k, math.nan)
            if math.isfinite(sd) and math.isfinite(base) and sd > 0 and base > 0:
                out += math.log(sd / base)
        return out


@dataclass
class Outlook:
    """The outcome of :func:`~.identifiability.weigh`: every candidate measurement, what it would separate
    and determine.

    Attributes
    ----------
    explanations : list of str
        The models weighed against each other, the choice first (one: nothing competes).
    current : str
        The model whose standard deviations are predicted (the diagnosis' last rung).
    recorded_std : dict
        ``{reported parameter: standard deviation}`` of ``current`` from the recorded curves alone
        (finite-element Jacobians at the fitted values, the priors included); empty when not computed.
    noise_mN : float
        The noise of the first recorded curve, the noise of every candidate (mN).
    ranking : list of Assessment
        The candidates, best first (:func:`~.identifiability.rank`); those that could not be predicted last.
    skipped : dict
        ``{measurement: why}``: measurements not weighed.
    notes : list of str
    settings : dict
        The candidate settings it was weighed with (``radii_mm``, ``max_depth_mm``, ``hold_s``,
        ``speeds_mm_per_s``; None: the defaults).
    """

    explanations: list
    current: str
    recorded_std: dict
    noise_mN: float
    ranking: list
    skipped: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)

    @property
    def with_std(self) -> bool:
        """The standard deviations were computed (the finite-element Jacobians)."""
        return bool(self.recorded_std)

    def best(self, n: int = 1) -> list:
        """The first ``n`` candidates that could be predicted."""
        return [a for a in self.ranking if a.error is None][:n]

    @property
    def next(self) -> Assessment | None:
        """The next measurement: the best candidate that could be predicted (None: none)."""
        top = self.best(1)
        return top[0] if top else None
