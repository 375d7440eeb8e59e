"""One fitted model of a curve: :class:`Rung` (its numbers, its BIC), and the residual in words.

A :class:`Rung` is what :class:`~skin_indent.fitting.multistart.Fitter` makes of each set of
effects it fits; :func:`evidence` scores it (AIC, BIC) and :func:`structure_sentence` says where its
residual departs from the noise. Every output of a fit or a diagnosis reads these.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..inverse.residuals import describe_structure
from ..measurement.scale import Quantity, Unit, UnitText, joined
from ..runtime.json_io import jsonable
from .error_model import MODEL_ERROR, score as evidence  # noqa: F401 - their names here before error_model
from .result import FitResult
#: the structure sentence of a residual in which no range departs from the model
NO_STRUCTURE = "no range departs from the model beyond the noise"


@dataclass(frozen=True, eq=False)
class Rung(FitResult):
    """One fitted model of a diagnosis (a rung of the ladder or a candidate).

    A :class:`~skin_indent.fitting.result.FitResult` (the result of every fit: ``model``, ``flags``,
    ``priors``, the score ``bic``, :attr:`BIC_FORMULA`, at its own ``n_eff`` when fitted, at the
    diagnosis's common ``n_eff`` in a diagnosis; ``covariance`` and ``free_names`` in the fit
    coordinates ``fit_parameters``, ``parameters`` and ``std`` as users read them: ``ratio``,
    ``C20_kPa``...), with what the diagnosis reads of it. Its ``flags`` say how the fit ended where
    that is not a result (:attr:`ended`): what every output shows.

    Attributes
    ----------
    effects : tuple of str
    fit_parameters : dict
        The fitted coordinates (``compliance``, ``C20_over_E``...).
    prediction_mN : ndarray
    chi2_weighted : float
        Sum of squared residuals over sigma_i^2 (noise and model error).
    white : bool
        The residual passes the whiteness tests at the noise level.
    analysis : ResidualAnalysis
    structure : str
        Where the residual departs from the noise, in words (:func:`structure_sentence`: depths in
        mm as a ``str``, a :class:`~skin_indent.measurement.scale.UnitText` that reads in any units).
    bound_model : ComposedModel
        The fitted force model, ``x`` its fitted vector.
    forward_runs : int
        Finite-element runs the fit made (the finite-element model in the loop; 0 on surfaces).
    at_bounds : tuple of str
        Fit parameters that ended on a face of their range.
    curve_rms_mN : tuple of float
        The RMS residual of each curve (mN), in input order (one curve: ``(rms_mN,)``).
    curve_white : tuple of bool
        Whether each curve's residual passes the whiteness tests on its own.
    ended : tuple of Ending
        How the fit ended where that is not a result (:func:`~skin_indent.fitting.ended.how_it_ended`:
        its evaluation budget, its start values, a parameter at the edge of its surface or at a bound);
        ``flags`` their texts, ``moved`` whether it left its start.
    reported_cov : tuple
        ``(names, V)``: the covariance of ``parameters`` by the names results report, from that of the
        whole fitted vector that ``std`` comes from (:func:`reported_covariance`; a parameter on a face
        of its range held there): the correlations reports list, and quantities derived from several
        parameters (:func:`~skin_indent.fitting.bodies.bodies`: E of each body). Plain numbers: it
        stays with a rung whose model is left out.
    """

    effects: tuple = ()
    fit_parameters: dict = field(default_factory=dict)
    prediction_mN: np.ndarray = None
    chi2_weighted: float = math.nan
    white: bool = False
    analysis: object = None
    structure: str = ""
    bound_model: object = field(default=None, repr=False)
    x: np.ndarray = None
    forward_runs: int = 0
    at_bounds: tuple = ()
    curve_rms_mN: tuple = ()
    curve_white: tuple = ()
    ended: tuple = ()
    reported_cov: tuple = ()

    @property
    def moved(self) -> bool:
        """The fit left its start values (a fit that did not move decides nothing)."""
        return not any(e.kind == "start" for e in self.ended)

    @property
    def residual_mN(self) -> np.ndarray:
        return self.residuals_mN

    @property
    def n_parameters(self) -> int:
        return self.n_free

    def summary(self) -> dict:
        """JSON-safe summary of the rung."""
        return jsonable({"model": self.model, "parameters": self.parameters, "std": self.std,
                         "rms_mN": self.rms_of_curves, "bic": self.bic, "white": self.white,
                         "n_parameters": self.n_parameters, "structure": self.structure, "priors": self.priors,
                         "flags": list(self.flags)})

    @property
    def rms_of_curves(self):
        """The RMS residual (mN) as outputs report it: a number for one curve, a list in input order for
        several curves of one sample."""
        if len(self.curve_rms_mN) > 1:
            return [float(v) for v in self.curve_rms_mN]
        return self.rms_mN


def reported_covariance(model, x, cov) -> tuple:
    """The covariance of a fit's parameters under the names results report (``ratio``, not the fit's
    ``compliance``), by the delta method: ``(names, V)`` for the finite parameters some coordinate
    with a variance moves (``((), empty)`` where ``cov``, the covariance of the whole vector ``x``, is
    not finite). Held values and infinite ones (a rigid base) are left out."""
    empty = ((), np.zeros((0, 0)))
    if model is None or x is None or cov is None or not hasattr(model, "model_parameters"):
        return empty
    x, C = np.asarray(x, dtype=float), np.asarray(cov, dtype=float)
    if C.shape != (x.size, x.size) or not np.all(np.isfinite(C)):
        return empty
    at = model.model_parameters(x)
    keys = [k for k, v in at.items() if math.isfinite(v)]
    G = np.zeros((len(keys), x.size))
    for j in np.flatnonzero(np.any(C != 0, axis=0)):
        step = 1e-6 * max(abs(x[j]), 1e-6)
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        try:
            with np.errstate(invalid="ignore", over="ignore"):
                a, b = model.model_parameters(up), model.model_parameters(down)
                diffs = [a[k] - b[k] for k in keys]
        except (ValueError, ZeroDivisionError, OverflowError):
            return empty
        G[:, j] = [d / (2 * step) if math.isfinite(d) else 0.0 for d in diffs]
    moving = [i for i in range(len(keys)) if np.any(G[i] != 0)]
    return tuple(keys[i] for i in moving), G[moving] @ C @ G[moving].T


def reported_correlations(rung) -> tuple:
    """The correlations of a rung's parameters under the names results report (``ratio``, not the fit's
    ``compliance``): ``((name, name, r), ...)`` for every pair with a variance, from
    :attr:`Rung.reported_cov` (a sign and a size the fit's coordinates need not share: ``ratio`` =
    1 / ``compliance``)."""
    names, V = rung.reported_cov or ((), np.zeros((0, 0)))
    sd = np.sqrt(np.clip(np.diag(V), 0.0, None))
    return tuple((names[p], names[q], float(np.clip(V[p, q] / (sd[p] * sd[q]), -1.0, 1.0)))
                 for p in range(len(names)) for q in range(p + 1, len(names)) if sd[p] > 0 and sd[q] > 0)


def structure_sentence(data, residual, sigma) -> str:
    """Where the residual departs from the noise, per segment, in words.

    Returns
    -------
    str
        :data:`NO_STRUCTURE`, or the ranges where the model is too soft or too stiff (depths, mm;
        times of a hold, s), a :class:`~skin_indent.measurement.scale.UnitText` when it holds
        depths: in package units as a ``str``, in the units of the curve's scale where a text
        shows it (:func:`~skin_indent.measurement.scale.shown_in`).
    """
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
            text = [UnitText("too {sign} from {a:.3g} to {b:.3g} {unit}", sign=r["sign"].split()[1],
                             a=Quantity(r["from_mm"], "from_mm"), b=Quantity(r["to_mm"], "to_mm"), unit=Unit("mm"))
                    for r in ranges]
        if text:
            parts.append(joined("", [f"on {label}: model ", joined(", ", text)]))
    return joined("; ", parts) if parts else NO_STRUCTURE
