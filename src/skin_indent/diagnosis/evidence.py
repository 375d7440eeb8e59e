"""Which measurement would separate two candidates that explain a curve about equally well."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..effects import DEPTH, HISTORY, effect
from ..effects import Model
from ..models import ComposedModel
from ..response_surface import make_executor

#: length of the suggested hold at the deepest point, s
HOLD_S = 30.0


def _model_force(effects: tuple, radius_mm: float, theta: dict, depth_mm: float, cache_dir=None) -> np.ndarray:
    """Force (mN) of a forward FE run (coarse mesh) of ``effects`` with ``theta`` (a worker task), read from
    or kept in the run cache of ``cache_dir`` (:class:`~skin_indent.response_surface.RunCache`; default
    ``$SKIN_INDENT_CACHE`` or ``~/.cache/skin_indent``, where the command line keeps everything)."""
    from ..models.effect_surface import model_force
    from ..response_surface import RunCache

    return model_force(effects, radius_mm, theta, depth_mm, mesh="coarse", run_cache=RunCache(cache_dir))


def _run_task(a, radius_mm, depth_mm) -> tuple:
    """Arguments of :func:`_model_force` for the fitted model ``a`` (contact shift left out)."""
    effects = tuple(e for e in a.effects if effect(e).stage != DEPTH)
    names = Model(effects, radius_mm).parameter_names
    return effects, radius_mm, {k: v for k, v in a.parameters.items() if k in names}, depth_mm


def _forward_differences(fitter, a, b, scenarios: dict) -> dict:
    """``{label: max |F_a - F_b| (mN)}`` over forward FE runs of the two fitted models, for each
    ``label: (radius_mm, depth_mm)`` of ``scenarios``; the runs go to the diagnosis' workers.
    A scenario whose runs fail is left out."""
    tasks = [((label, k), _run_task(f, radius, depth))
             for label, (radius, depth) in scenarios.items() for k, f in enumerate((a, b))]
    context = getattr(fitter, "context", None)
    options = {} if context is None else {"workers": context.workers, "client": context.client,
                                          "scheduler": context.scheduler}
    if options.get("client") is not None or options.get("scheduler") is not None:
        options.pop("workers")
    forces = {}
    with make_executor(tasks=len(tasks), **options) as executor:
        for (label, k), value, error in executor.imap_unordered(_model_force, tasks):
            if error is None:
                forces[label, k] = value
    return {label: float(np.max(np.abs(forces[label, 0] - forces[label, 1])))
            for label in scenarios if (label, 0) in forces and (label, 1) in forces}


def _hold_difference(fitter, a, b) -> float:
    """Max |F_a - F_b| (mN) of the two fitted models over a hold at the deepest point after the loading."""
    d = fitter.data
    load = np.flatnonzero(d.kind == "approach")
    end = int(load[np.argmax(d.depth_mm[load])]) + 1
    t_end = float(d.time_s[end - 1])
    t_hold = t_end + np.linspace(HOLD_S / 30, HOLD_S, 30)
    history = dataclasses.replace(
        d, depth_mm=np.r_[d.depth_mm[:end], np.full(30, d.depth_mm[end - 1])],
        force_mN=np.r_[d.force_mN[:end], np.full(30, d.force_mN[end - 1])],
        time_s=np.r_[d.time_s[:end], t_hold], kind=np.r_[d.kind[:end], np.full(30, "hold")])

    out = []
    for f in (a, b):
        m = f.bound_model
        out.append(ComposedModel(m.core, m.effects, history).force(history.depth_mm, f.x))
    return float(np.max(np.abs(out[0][end:] - out[1][end:])))


def suggest_measurement(fitter, a, b) -> str:
    """Which extra measurement separates two fitted candidates, with the predicted difference.

    Compared: (i) a sphere of half the radius and (ii) an indentation 1.5 times deeper,
    by forward finite-element runs of the two fitted models (where both have a
    finite-element form and need no time history); (iii) a 30 s hold at the deepest
    point, from the two fitted models themselves (where one of them acts along the time
    history).
    """
    out = {}
    objs = [effect(e) for e in (*a.effects, *b.effects)]
    if not any(e.needs_history for e in objs):
        hmax, R = fitter.max_depth, fitter.radius_mm
        scenarios = {f"a sphere of half the radius (R = {R / 2:.3g} mm) to the same depth": (R / 2, hmax),
                     f"an indentation 1.5 times deeper ({1.5 * hmax:.3g} mm)": (R, 1.5 * hmax)}
        try:
            out.update(_forward_differences(fitter, a, b, scenarios))
        except Exception:  # noqa: BLE001 - a measurement we cannot predict is not suggested
            pass
    if fitter.data.time_s is not None and any(e.stage == HISTORY for e in objs):
        try:
            out[f"a {HOLD_S:g} s hold at the deepest point"] = _hold_difference(fitter, a, b)
        except Exception:  # noqa: BLE001
            pass
    if len(a.effects) == len(b.effects) and a.effects[:-1] == b.effects[:-1]:
        ea, eb = a.effects[-1], b.effects[-1]  # two candidates on the same rung
    else:
        ea, eb = "+".join(a.effects), "+".join(b.effects)  # two explanations (sets of effects)
    if not out:
        return "no extra measurement computed here separates them"
    label, diff = max(out.items(), key=lambda kv: kv[1])
    return (f"{label} would separate {ea} from {eb}: the fitted models differ there by up to {diff:.3g} mN, "
            f"{diff / fitter.noise_mN:.1f} times the noise")
