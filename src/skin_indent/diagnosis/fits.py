"""The fits of one diagnosis: each set of effects fitted once, as a :class:`Rung`."""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ..effects import CONTACT_POINT, ELASTIC, WEIGHED, effect
from ..inverse import IdentificationResult
from .residuals import analyse_residuals, describe_structure

#: relative accuracy of the forward model (FE + surface), added to the noise in quadrature
MODEL_ERROR = 0.003


@dataclass(frozen=True, eq=False)
class Rung(IdentificationResult):
    """One fitted model of a diagnosis (a rung of the ladder or a candidate).

    Everything of :class:`~skin_indent.inverse.IdentificationResult` (the least-squares
    fit; ``covariance`` and ``free_names`` in the fit coordinates ``fit_parameters``),
    with ``parameters`` and ``std`` as users read them (``ratio``, ``C20_kPa``...), and
    the diagnosis' own criterion ``bic`` (:attr:`BIC_FORMULA`).

    Attributes
    ----------
    model : str
        ``neo-hooke`` plus ``+effect`` for each effect.
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
        Where the residual departs from the noise, in words.
    bound_model : ComposedModel
        The fitted force model, ``x`` its fitted vector.
    """

    BIC_FORMULA = ("(n_eff / n) sum r_i^2 / sigma_i^2 + k ln n_eff, sigma_i^2 = noise^2 + (0.003 F_i)^2, "
                   "n_eff the AR(1) effective sample size")

    model: str = ""
    effects: tuple = ()
    fit_parameters: dict = field(default_factory=dict)
    prediction_mN: np.ndarray = None
    chi2_weighted: float = math.nan
    white: bool = False
    analysis: object = None
    structure: str = ""
    bound_model: object = field(default=None, repr=False)
    x: np.ndarray = None

    @property
    def residual_mN(self) -> np.ndarray:
        return self.residuals_mN

    @property
    def n_parameters(self) -> int:
        return self.n_free

    def summary(self) -> dict:
        """JSON-safe summary of the rung."""
        from .._json import jsonable

        return jsonable({"model": self.model, "parameters": self.parameters, "std": self.std, "rms_mN": self.rms_mN,
                         "bic": self.bic, "white": self.white, "n_parameters": self.n_parameters,
                         "structure": self.structure})


class Fitter:
    """Surfaces, error model and fits shared by one diagnosis.

    Parameters
    ----------
    data : PreparedCurve
    noise_mN : float
        Noise level (mN) of the prepared points.
    noise_known : bool
        Given by the user (else estimated: its uncertainty enters the chi-square test).
    context : Context
    mesh : str
    """

    def __init__(self, data, noise_mN: float, *, noise_known: bool, context, mesh: str):
        from ..fitting import hertz_modulus

        self.data = data
        self.radius_mm = data.radius_mm
        self.noise_mN = noise_mN
        # an estimated noise level is uncertain: ~12% for 100 points (estimate_noise), i.e. ~0.35 n dof
        self.noise_dof = None if noise_known else 0.35 * data.n
        self.context = context
        self.mesh = mesh
        h, F = data.loading()
        if h.size < 3:
            raise ValueError(f"{data.source}: fewer than 3 loading points in contact to diagnose")
        self.max_depth = data.max_indentation_mm
        self.e_star = hertz_modulus(h, np.maximum(F, 0.0), self.radius_mm)
        self._cores = {}
        self.fits: dict[tuple, Rung] = {}
        #: the contact point is a parameter of every model of a curve recorded from before contact
        self.implicit = (CONTACT_POINT.name,) if data.contact_mode == "fit" else ()

    def sigma(self, force) -> np.ndarray:
        return np.sqrt(self.noise_mN**2 + (MODEL_ERROR * np.abs(force)) ** 2)

    def core(self, effects):
        """The elastic force model of these effects (cached per elastic effect)."""
        from ..fitting import elastic_core

        key = tuple(e.name for e in map(effect, effects) if e.stage == ELASTIC)
        if key not in self._cores:
            self._cores[key] = elastic_core(key, radius_mm=self.radius_mm, max_depth_mm=self.max_depth,
                                            e_star_kPa=self.e_star, context=self.context, mesh=self.mesh)
        return self._cores[key]

    def model(self, effects: tuple):
        from ..models import ComposedModel

        objs = [effect(e) for e in effects]
        weighed = [e.name for e in objs if e.stage == WEIGHED]
        if weighed:
            raise ValueError(f"{', '.join(weighed)} is weighed, not fitted: no fitted model has it yet")
        full = tuple(dict.fromkeys([*self.implicit, *(e.name for e in objs)]))
        return ComposedModel(self.core(full), full, self.data)

    def starts(self, model, effects: tuple) -> list[np.ndarray]:
        names = model.parameter_names
        lo, hi = model.bounds
        nu0 = min(max(0.45, lo[1]), hi[1])
        base = {"E_kPa": self.e_star * (1 - nu0**2), "nu": nu0}
        prev = self.fits.get(tuple(effects[:-1])) if effects else None
        if prev is not None:
            base.update({k: v for k, v in prev.fit_parameters.items() if k in names})
        options = {}
        for e in model.effects:
            bounds = {k: (lo[names.index(k)], hi[names.index(k)]) for k in e.fit_names if k in names}
            options.update(e.starts(self.data, bounds))
        varied = [k for k in names if k in options and k not in base]
        out = []
        for combo in itertools.product(*(options[k] for k in varied)):
            x = [combo[varied.index(k)] if k in varied else base.get(k, 0.5 * (lo[i] + hi[i]))
                 for i, k in enumerate(names)]
            out.append(np.clip(np.array(x, dtype=float), lo, hi))
        return out

    def fit(self, effects: tuple) -> Rung:
        from ..inverse import fit_least_squares

        key = tuple(effects)
        if key in self.fits:
            return self.fits[key]
        model = self.model(key)
        d = self.data
        best = None
        for x0 in self.starts(model, key):
            try:
                res = fit_least_squares(model, d.depth_mm, d.force_mN, x0, noise_mN=self.noise_mN)
            except ValueError:
                continue
            if best is None or res.rms_mN < best.rms_mN:
                best = res
        if best is None:
            raise ValueError(f"the model {model.name} could not be fitted")
        x = np.array([best.parameters[n] for n in model.parameter_names])
        pred = d.force_mN - best.residuals_mN
        cov = np.full((x.size, x.size), np.nan)
        idx = [model.parameter_names.index(n) for n in best.free_names]
        cov[np.ix_(idx, idx)] = best.covariance
        params, std = model.reported(x, cov)
        r = best.residuals_mN
        s = self.sigma(pred)
        analysis = analyse_residuals(r * (self.noise_mN / s), self.noise_mN, best.n_free, noise_dof=self.noise_dof)
        base = {f.name: getattr(best, f.name) for f in dataclasses.fields(IdentificationResult)}
        base.update(parameters=params, std=std, bic=math.nan)
        rung = Rung(**base, model="neo-hooke" + "".join(f"+{e}" for e in key), effects=key,
                    fit_parameters=dict(best.parameters), prediction_mN=pred,
                    chi2_weighted=float(np.sum((r / s) ** 2)), white=analysis.white, analysis=analysis,
                    structure=structure_sentence(d, r, s), bound_model=model, x=x)
        self.fits[key] = rung
        return rung


def structure_sentence(data, residual, sigma) -> str:
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
