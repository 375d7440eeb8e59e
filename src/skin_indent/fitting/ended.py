"""How a fit ended: the one place that says when its numbers are where the optimizer stopped, not a result.

A least-squares fit can end four ways that are not a result, and every output of every fit (the
terminal report, ``flags`` in the JSON, the tables, the HTML report, the diagnosis's ladder)
says so in the words :func:`how_it_ended` writes, naming the parameter and the next step:

- ``budget``: it stopped at its evaluation budget (scipy's ``status`` 0) before converging;
- ``start``: it ended at its start values without having found them optimal (:func:`stalled`: a
  stationary start, the simpler model's optimum where an added effect does nothing, or a flat
  direction; a start on a face the data push against is an optimum, not a stall);
- ``edge``: a parameter ended on a face of the range its forward model covers (a response
  surface's last node, what the finite-element model solves) inside the parameter's own range;
- ``bound``: a parameter ended on a face of its range short of a physical limit (a rigid base,
  the nearly incompressible end are limits a fit may rightly find, and are not flagged; nor is an
  effect switched off at the end of its range, ``C20_kPa`` = 0: the data do not want it).

:func:`ending_flags` is what outputs read; :func:`moved` is what a diagnosis asks before it
lets a fit decide anything (:func:`stalled`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..measurement.scale import Name, Quantity, UnitText
from ..models.composed import at_physical_limit, declared_parameters

__all__ = ["BUDGET", "BOUND", "EDGE", "START", "Ending", "ending_flags", "how_it_ended", "moved", "reported_name",
           "reported_message", "stalled", "verdict"]

BUDGET, START, EDGE, BOUND = "budget", "start", "edge", "bound"
#: a fit whose every free parameter moved less than this fraction of its value (plus
#: :data:`SPAN_STILL` of its range) did not move
STILL = 1e-9
SPAN_STILL = 1e-7
#: the next step of a parameter the fit left where it stopped
_HOLD = ("next: hold it if you know it (--fix {name}=VALUE), weigh what you know of it (--prior {name}=MEAN:SD), or "
         "fit a model without it")
#: the same for a parameter of every model (E_kPa, nu): another model, not one without it
_HOLD_BASE = ("next: hold it if you know it (--fix {name}=VALUE), weigh what you know of it (--prior {name}=MEAN:SD), "
              "or ask which model describes the curve (skin-indent diagnose)")


def _next(name: str) -> str:
    return (_HOLD_BASE if name in ("E_kPa", "nu") else _HOLD).format(name=name)


@dataclass(frozen=True)
class Ending:
    """One way a fit ended that is not a result.

    Attributes
    ----------
    kind : {"budget", "start", "edge", "bound"}
    parameters : tuple of str
        The parameters it concerns, by the names results report (``ratio``, not ``compliance``).
    text : str
        The flag: what happened, that the value is not a result, and the next step
        (a :class:`~skin_indent.measurement.scale.UnitText` where it holds a value with a unit).
    """

    kind: str
    parameters: tuple
    text: str

    @property
    def short(self) -> str:
        """The ending in a few words (a fit's verdict): ``"ratio at the edge of its surface"``."""
        names = ", ".join(self.parameters)
        return {BUDGET: "the fit stopped at its evaluation budget", START: "the fit ended at its start values",
                EDGE: f"{names} at the edge of what its forward model covers",
                BOUND: f"{names} at the bound of its range"}[self.kind]


def verdict(endings) -> str | None:
    """The verdict of a fit that ended as ``endings`` say (None: it converged inside its ranges):
    ``"not a result: ..."``, never "fits to the noise"."""
    endings = list(endings)
    if not endings:
        return None
    return "not a result (see the flags): " + "; ".join(dict.fromkeys(e.short for e in endings))


def moved(result, model=None) -> bool:
    """The fit moved from its start: some free parameter ended away from its start value.

    ``result`` is an :class:`~skin_indent.inverse.IdentificationResult` of least squares (its
    ``info["x0"]``, the start of each free parameter); a result without a recorded start (a
    filter's) counts as moved. With ``model`` (its ``parameter_names`` and ``bounds``), a change
    below :data:`SPAN_STILL` of a parameter's range is no move: the optimizer's own nudge of a start
    on a face of its range into the inside (scipy's, 1e-10 of its internal coordinate).
    """
    start = (result.info or {}).get("x0")
    if not start or not result.free_names:
        return True
    spans = _spans(model)
    for name in result.free_names:
        a, b = float(start.get(name, math.nan)), float(result.parameters.get(name, math.nan))
        if not (math.isfinite(a) and math.isfinite(b)):
            return True
        if abs(a - b) > STILL * max(abs(a), abs(b), 1e-12) + SPAN_STILL * spans.get(name, 0.0):
            return True
    return False


def _spans(model) -> dict:
    """``{fit parameter: width of its range}`` (finite widths only; empty without a model)."""
    if model is None or not hasattr(model, "bounds"):
        return {}
    lo, hi = (np.asarray(b, dtype=float) for b in model.bounds)
    return {n: float(h - l) for n, l, h in zip(model.parameter_names, lo, hi) if math.isfinite(h - l)}


def stalled(result, model=None) -> bool:
    """The fit ended at its start values without having found them optimal: it did not move
    (:func:`moved`), and either stopped short of converging or converged with no parameter against a
    face of its range. A start on a face that the data push against (an added effect switched off at
    its bound, the simpler model's optimum where that effect does nothing) is an optimum the fit
    found, and does not count; a start where the model is flat (a second layer of the first one's
    modulus, whose thickness then changes nothing) is a stationary point it could not leave, and does.
    """
    if moved(result, model):
        return False
    return result.status <= 0 or not [n for n in (result.info or {}).get("active_bounds", ())
                                      if n in result.free_names]


def reported_name(model, x, name: str) -> tuple[str, float]:
    """The parameter results report for the fit coordinate ``name`` (``compliance`` -> ``ratio``),
    and its value at ``x``: the reported parameter that moves with it (itself where it is reported)."""
    if model is None or x is None or not hasattr(model, "model_parameters"):
        return name, math.nan
    x = np.asarray(x, dtype=float)
    try:
        at = model.model_parameters(x)
    except (ValueError, ZeroDivisionError, OverflowError):
        return name, math.nan
    if name in at:
        return name, float(at[name])
    if name not in model.parameter_names:
        return name, math.nan
    i = model.parameter_names.index(name)
    lo, hi = (float(b[i]) for b in model.bounds)
    span = hi - lo
    step = 1e-3 * (span if math.isfinite(span) and span > 0 else max(abs(x[i]), 1.0))
    inward = x.copy()
    inward[i] += step if abs(x[i] - lo) <= abs(hi - x[i]) else -step
    try:
        near = model.model_parameters(inward)
    except (ValueError, ZeroDivisionError, OverflowError):
        return name, math.nan
    changed = [k for k in at if k not in model.parameter_names and at[k] != near[k]]
    return (changed[0], float(at[changed[0]])) if len(changed) == 1 else (name, math.nan)


def reported_message(result, model, x) -> str:
    """The fit's message with the parameters at a bound under the names results report (``ratio``, not
    ``compliance``): one name per parameter in every block of a report."""
    active = list((result.info or {}).get("active_bounds", ()))
    if not active or "; at bound: " not in result.message:
        return result.message
    shown = [reported_name(model, x, n)[0] for n in active]
    return result.message.replace("; at bound: " + ", ".join(active), "; at bound: " + ", ".join(shown))


def _switched_off(model, x, name: str, shown: str) -> bool:
    """The fit parameter ``name``, on a face of its range, switches its effect off there, and that is an
    end of the declared range of ``shown`` (the parameter results report): ``C20_kPa`` = 0, no
    stiffening; ``w_mJ_per_m2`` = 0, no adhesion. The fit found the effect absent: an answer, not a
    stop short of one. Judged at the face itself (the optimizer stops a hair inside it)."""
    if model is None or x is None or not hasattr(model, "effects") or name not in model.parameter_names:
        return False
    p = declared_parameters(model).get(shown)
    if p is None or p.off is None or p.off not in (p.lower, p.upper):
        return False
    i = model.parameter_names.index(name)
    lo, hi = (float(np.asarray(b, dtype=float)[i]) for b in model.bounds)
    face = np.array(x, dtype=float)
    face[i] = lo if abs(face[i] - lo) <= abs(hi - face[i]) else hi
    try:
        value = float(model.model_parameters(face)[shown])
    except (ValueError, ZeroDivisionError, OverflowError, KeyError):
        return False
    return math.isclose(value, p.off, rel_tol=1e-9, abs_tol=1e-12)


def _core_of(model, name: str):
    """The elastic core that owns the fit parameter ``name`` (None: an effect's parameter, or no core)."""
    parts = getattr(model, "parts", None) or [model]
    for part in parts:
        core = getattr(part, "core", None)
        if core is None and hasattr(part, "depth_range"):
            core = part  # a force model fitted alone (a response surface): its range is its own
        if core is not None and name in tuple(getattr(core, "parameter_names", ())):
            return core
    return None


def _edge_of(core) -> str:
    """What a core's range is: a surface's nodes, or what the finite-element model solves."""
    if core.in_loop:
        return "what the finite-element model solves"
    label = getattr(core, "name", None)
    what = f"the {label} response surface" if isinstance(label, str) and label else "the response surface"
    radius = getattr(core, "radius_mm", None)
    return what + (f" (R = {radius:g} mm)" if isinstance(radius, (int, float)) else "")


def _spent(result) -> str:
    """What a fit spent of its budget: function evaluations (least squares) or sweeps (the filters)."""
    nfev = (result.info or {}).get("nfev")
    return f"{nfev} evaluations" if nfev else f"{result.iterations} sweeps"


def _value_field(value: float) -> str:
    """The template field of a value: formatted as a number, or written as it is (inf: a rigid base)."""
    return "{value:.4g}" if math.isfinite(value) else ("inf (rigid)" if value == math.inf else "{value}")


def how_it_ended(result, model=None, x=None, *, limits: bool = True) -> list[Ending]:
    """Every way ``result`` ended that is not a result (empty for a fit that converged inside its ranges).

    Parameters
    ----------
    result : IdentificationResult
        The least-squares fit (``status``, ``info``: ``nfev``, ``x0``, ``active_bounds``; its
        ``parameters`` in the fit coordinates of ``model``).
    model : ComposedModel or JointModel, optional
        The fitted model: names the parameters as results report them, tells a response surface's
        edge from a parameter's bound and a bound from a physical limit
        (:func:`~skin_indent.models.composed.at_physical_limit`). Without it, every face of a range
        is a bound and the names are the fit's.
    x : ndarray, optional
        The fitted vector in ``model.parameter_names`` order (default from ``result.parameters``).
    limits : bool
        A face of a range that is a physical limit is not flagged (default); ``False`` flags every
        face (the paper's half-space, whose nu range is its surface's).

    Returns
    -------
    list of Ending
        In the order budget, start values, then each parameter at an edge or a bound.
    """
    info = result.info or {}
    if model is not None and x is None:
        x = np.array([result.parameters[n] for n in model.parameter_names], dtype=float)
    out = []
    still = stalled(result, model)
    if result.status == 0 and not still:  # at its start values, that says more than the budget
        out.append(Ending(BUDGET, (), (
            f"the fit stopped at its evaluation budget ({_spent(result)}) before it converged: the "
            "values are where it stopped, not a result; next: hold a parameter you know (--fix NAME=VALUE) or weigh "
            "it (--prior NAME=MEAN:SD), or fit a simpler model")))
    elif result.status < 0:
        out.append(Ending(BUDGET, (), f"the fit failed ({result.message}): the values are not a result; next: "
                                      "hold a parameter you know (--fix) or fit a simpler model"))
    if still:
        names = [reported_name(model, x, n)[0] for n in result.free_names]
        out.append(Ending(START, tuple(names), (
            f"the fit ended at its start values ({', '.join(names)}): it did not move, the values are not a result "
            "(a start where the model is stationary, e.g. the simpler model's optimum with the added effect doing "
            "nothing); next: fit from other starts (--prior NAME=MEAN:SD puts one where you know the value) or a "
            "simpler model")))
    for name in info.get("active_bounds", ()):
        if name not in result.free_names:
            continue
        if limits and hasattr(model, "model_parameters") and at_physical_limit(model, x, name):
            continue  # a rigid base, the nearly incompressible end: a limit the fit may rightly find
        shown, value = reported_name(model, x, name)
        if math.isnan(value) and shown == name:
            value = float(result.parameters.get(name, math.nan))
        if _switched_off(model, x, name, shown):
            continue  # the effect off at the end of its range (no stiffening, no adhesion): the data's answer
        core = _core_of(model, name) if model is not None else None
        head = "{name} at the bound of its range ({name} = " + _value_field(value) + ")"
        if core is not None:
            i = list(core.parameter_names).index(name)
            lo, hi = (float(np.asarray(b, dtype=float)[i]) for b in core.bounds)
            text = UnitText(head + ", the edge of {what} ({fit} from {lo:.4g} to {hi:.4g}): the data want a value "
                            "it does not cover, the value is not a result; " + _next(shown),
                            name=Name(shown), value=Quantity(value, shown), what=_edge_of(core), fit=Name(name),
                            lo=Quantity(lo, name), hi=Quantity(hi, name))
            out.append(Ending(EDGE, (shown,), text))
        else:
            text = UnitText(head + ": the fit stopped there, the value is not a result; " + _next(shown),
                            name=Name(shown), value=Quantity(value, shown))
            out.append(Ending(BOUND, (shown,), text))
    return out


def limit_notes(result, model=None, x=None) -> list[str]:
    """What a fit that stopped at a physical limit found (:func:`~skin_indent.models.composed.at_physical_limit`):
    one sentence per parameter, saying it is a limit the data reach, not a measured value."""
    if model is None or not hasattr(model, "model_parameters"):
        return []
    if x is None:
        x = np.array([result.parameters[n] for n in model.parameter_names], dtype=float)
    out = []
    for name in (result.info or {}).get("active_bounds", ()):
        if name in result.free_names and at_physical_limit(model, x, name):
            shown, value = reported_name(model, x, name)
            out.append(UnitText("{name} = " + _value_field(value) + " at the end of its range that is a physical "
                                    "limit (" + ("a rigid base" if shown.startswith("ratio") else
                                                 "the nearly incompressible end") + "): the data reach the limit; "
                                    "read it as a bound, not a measured value",
                                    name=Name(shown), value=Quantity(value, shown)))
    return out


def ending_flags(result, model=None, x=None, *, limits: bool = True) -> list[str]:
    """The flags of :func:`how_it_ended`, as every output of a fit shows them."""
    return [e.text for e in how_it_ended(result, model, x, limits=limits)]
