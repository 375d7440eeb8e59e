"""The final model as a reader wants it: the Young's modulus of each body, the thicknesses, and what ``ratio`` means.

A fitted model reports its parameters as the fit needs them: ``E_kPa`` of the top material, each
layer's ``thickness_mm`` and ``ratio`` (the modulus below it over its own). :func:`bodies` turns
them into the bodies a skin researcher names (the top layer, the layer under it, the material
below: a half-space or a rigid base), each with its modulus and standard deviation (the delta
method from the fit's covariance), and :func:`body_lines` writes them for the terminal; the JSON
and the report show the same numbers (:meth:`~skin_indent.diagnosis.Diagnosis.to_dict`).
"""

from __future__ import annotations

import math

import numpy as np

from ..effects import numbered
from .ended import limit_notes

__all__ = ["RATIOS_MEANING", "RATIO_MEANING", "bodies", "body_lines", "limits"]

#: what ``ratio`` is, in one line
RATIO_MEANING = ("ratio = E of the material below a layer / E of the layer (ratio < 1: softer below, > 1: stiffer "
                 "below, inf: a rigid base)")
#: the same, for a model of several layers
RATIOS_MEANING = RATIO_MEANING + "; ratio2 the same for the second layer"


def _sd(rung, chain: tuple) -> float:
    """Standard deviation of E times the ratios ``chain`` by the delta method, from the covariance of the
    reported parameters (:attr:`~skin_indent.fitting.FitResult.reported_cov`); NaN where unknown."""
    names, V = getattr(rung, "reported_cov", None) or ((), np.zeros((0, 0)))
    p = rung.parameters
    value = p["E_kPa"] * math.prod(p[n] for n in chain)
    g = np.zeros(len(names))
    for k in ("E_kPa", *chain):
        if k in names:
            g[names.index(k)] += value / p[k]  # d(E r1 r2...)/dk = product / k
        elif k in rung.std:  # a parameter with a variance the covariance does not hold
            return math.nan
    var = float(g @ np.asarray(V, dtype=float) @ g) if len(names) else math.nan
    return math.sqrt(var) if var >= 0 else math.nan


def bodies(rung) -> dict:
    """The bodies of a fitted model, top first, and its other parameters.

    Parameters
    ----------
    rung : FitResult
        A fitted model (its ``parameters``, ``std``, ``effects``, ``model`` and ``reported_cov``).

    Returns
    -------
    dict
        ``model``; ``bodies``: a list of ``{"body", "E_kPa", "E_sd_kPa", "thickness_mm", "thickness_sd_mm"}``
        (``thickness_mm`` None for the material below; ``E_kPa`` ``inf`` for a rigid base; an sd None
        where the value is held, NaN where the fit does not give one); ``nu`` and ``nu_sd``; ``other``: every other
        parameter ``{name: [value, sd]}``; ``ratio``: :data:`RATIO_MEANING` where the model has layers;
        ``limits``: where a parameter ended at a physical limit (a rigid base, nu at the nearly
        incompressible end), that it is a bound the data reach, not a measured value
        (:func:`~skin_indent.fitting.ended.limit_notes`).
    """
    p, std = rung.parameters, rung.std
    layers = sum(1 for e in rung.effects if e == "layer")
    used = {"E_kPa", "nu"}
    out, names = [], []
    E = p["E_kPa"]

    def modulus(chain: tuple) -> tuple:
        """E times the ratios ``chain`` and its sd: None where every factor is held, NaN where unknown."""
        value = E * math.prod(p[n] for n in chain)
        if not math.isfinite(value):  # a rigid base: no sd
            return value, math.nan
        if all(n not in std for n in ("E_kPa", *chain)):
            return value, None
        if not chain:
            return value, float(std["E_kPa"])
        return value, _sd(rung, chain)

    for k in range(1, layers + 1):
        t, r = numbered("thickness_mm", k), numbered("ratio", k)
        used |= {t, r}
        value, sd = modulus(tuple(names))
        out.append({"body": "top layer" if k == 1 else f"layer {k}", "E_kPa": value, "E_sd_kPa": sd,
                    "thickness_mm": p.get(t), "thickness_sd_mm": std.get(t)})
        names.append(r)
    value, sd = modulus(tuple(names))
    if names and math.isinf(value):
        out.append({"body": "below: rigid base", "E_kPa": math.inf, "E_sd_kPa": math.nan, "thickness_mm": None,
                    "thickness_sd_mm": None})
    else:
        out.append({"body": "below: half-space" if names else "half-space", "E_kPa": value, "E_sd_kPa": sd,
                    "thickness_mm": None, "thickness_sd_mm": None})
    other = {k: [v, std.get(k)] for k, v in p.items() if k not in used}
    limits_ = limits(rung)
    return {"model": rung.model, "bodies": out, "nu": p.get("nu"), "nu_sd": std.get("nu"), "other": other,
            **({"ratio": RATIO_MEANING if layers == 1 else RATIOS_MEANING} if layers else {}),
            **({"limits": limits_} if limits_ else {})}


def limits(rung) -> list[str]:
    """Where ``rung`` ended at a physical limit, that it is a bound the data reach (:func:`~.ended.limit_notes`);
    a rung without its model (sent back from a worker) keeps them in ``info["limits"]``."""
    model = getattr(rung, "bound_model", None)
    if model is None:
        return list((getattr(rung, "info", None) or {}).get("limits", ()))
    return [str(n) for n in limit_notes(rung, model, getattr(rung, "x", None))]


def _pm(value, sd, scale: float, unit: str = "") -> str:
    if value is None:
        return "-"
    if math.isinf(value):
        return "inf (rigid)"
    text = f"{value * scale:.4g}"
    if sd is not None and math.isfinite(sd):
        text += f" +- {sd * scale:.2g}"
    text += f" {unit}" if unit else ""
    return text + (" (held)" if sd is None else "")


def body_lines(rung, units) -> list[str]:
    """The final model for the terminal: one line per body (E, thickness), nu, the other parameters,
    and what ``ratio`` means; in ``units`` (:class:`~skin_indent.measurement.scale.DisplayUnits`)."""
    b = bodies(rung)
    M, L = units.modulus, units.length
    lines = [f"final model: {b['model']} (sd from the fit)"]
    for body in b["bodies"]:
        text = f"  {body['body']}: E = {_pm(body['E_kPa'], body['E_sd_kPa'], units.per_kPa, M)}"
        if body["thickness_mm"] is not None:
            text += f", thickness = {_pm(body['thickness_mm'], body['thickness_sd_mm'], units.per_mm, L)}"
        lines.append(text)
    lines.append(f"  nu = {_pm(b['nu'], b['nu_sd'], 1.0)} (all materials)")
    for name, (v, sd) in b["other"].items():
        lines.append(f"  {units.name(name)} = {_pm(v, sd, units.factor(name))}")
    lines.extend(f"  note: {n}" for n in b.get("limits", ()))
    if "ratio" in b:
        lines.append(f"  ({b['ratio']})")
    return lines
