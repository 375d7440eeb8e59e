"""Where a fit starts: the start vectors of a model, and the screen that ranks them.

- :func:`start_vectors`: the simpler model's optimum with the added effects switched off
  (the nested start), one more occurrence of a repeatable effect inserted among the
  fitted ones, then the product of the effects' own start values (at most
  :data:`MAX_STARTS`), with what the user holds or knows in place;
- :func:`screen`: with the finite-element model in the loop, the starts ranked by cheap
  runs (each at its best modulus) and by what each adds to the simpler model
  (:func:`blended_misfit`), the best few kept.

Both read the :class:`~skin_indent.fitting.multistart.Fitter` of the diagnosis (its
curves, fits so far, held values and priors) and change nothing in it.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..effects import ELASTIC, instances, numbered
from ..models import JointModel
from ..models.joint import curve_name, split_name
from .knowledge import held_coordinates

__all__ = ["DEGENERATE", "MAX_STARTS", "blended_misfit", "elastic_body", "screen", "same_body", "start_vectors"]

#: at most this many start vectors (the product of the effects' start values, warm values first)
MAX_STARTS = 24
#: a start whose misfit is within this fraction of the nested start's is the simpler model in
#: disguise (its added effect does nothing there) and is not fitted from
DEGENERATE = 1e-3


def start_vectors(fitter, model, effects: tuple) -> list[np.ndarray]:
    """Start vectors (:func:`_own_starts`) with the held values in place, each once; with priors,
    each start also once more with the priors' means in place (after all of them), so that
    the fit can start where what the user knows puts it.

    Parameters
    ----------
    fitter : Fitter
        The diagnosis's fitter: its curves, the rungs fitted so far (the nested start is the
        optimum of the largest set of effects fitted within ``effects``), held values, priors.
    model : ComposedModel or JointModel
        The fitted model of ``effects`` (:meth:`Fitter.model`).
    effects : tuple of str

    Returns
    -------
    list of ndarray
        Vectors in ``model.parameter_names`` order and units (kPa, mm, ...), inside its bounds.
    """
    held = fitter.held(model)
    base = _own_starts(fitter, model, effects)
    if not held and not fitter.priors:
        return base
    idx = {model.parameter_names.index(k): v for k, v in held.items()}
    means = {}
    for k, (mean, _) in fitter.priors.items():
        try:
            means.update(held_coordinates(model, {**fitter.fixed, k: mean}))
        except ValueError:  # a prior on a parameter of several coordinates: no pinned start
            continue
    pinned = {model.parameter_names.index(k): v for k, v in means.items() if k not in held}
    lo, hi = model.bounds
    out, seen = [], set()
    for variant in ({}, pinned) if pinned else ({},):
        for x in base:
            x = np.array(x, dtype=float)
            for i, v in {**idx, **variant}.items():
                x[i] = min(max(v, lo[i]), hi[i])
            key = tuple(np.round(x, 12))
            if key not in seen:
                seen.add(key)
                out.append(x)
    return out


def elastic_body(effects) -> tuple:
    """The elastic effects of ``effects`` (names, with repeats), sorted: what sets the body a
    finite-element run solves (``("layer", "layer")`` for two layers); the contact point, baselines,
    drag or relaxation added to it leave the body as it is."""
    return tuple(sorted(e.name for e in instances(effects) if e.stage == ELASTIC))


def same_body(rung, effects: tuple) -> bool:
    """The fitted ``rung`` has the elastic body of ``effects`` (:func:`elastic_body`): what
    ``effects`` add to it leaves the body as it is, so its optimum is where their fit starts.

    :meth:`~skin_indent.fitting.multistart.Fitter.warm` prefers such a rung among fitted rungs of
    equal size, and with the finite-element model in the loop the fit then goes from it without
    screening starts of the body again (measured on the demo's pair: two layers with the contact
    points added started from the two layers' optimum instead of one layer's, no screen)."""
    return rung is not None and elastic_body(rung.effects) == elastic_body(effects)


def _own_starts(fitter, model, effects: tuple) -> list[np.ndarray]:
    """Start vectors: the warm start with the new effects switched off first (a fit can
    then only improve on the nested model), then one more occurrence of a repeatable effect
    inserted among the fitted ones (:func:`_inserted`), then the effects' own start values.
    With the finite-element model in the loop, each body is started from once (starts that
    build the same body up to its modulus are one) and none is the simpler model's body.
    """
    names = model.parameter_names
    lo, hi = model.bounds
    nu0 = min(max(0.45, lo[1]), hi[1])
    base = {"E_kPa": fitter.e_star * (1 - nu0**2), "nu": nu0}
    prev = fitter.warm(tuple(effects))
    if prev is not None:
        base.update({k: v for k, v in prev.fit_parameters.items() if k in names})
    options, off = {}, {}
    for e, data, named in _effect_views(fitter, model):
        fit_names = [named(n) for n in e.fit_names]
        bounds = {n: (lo[names.index(m)], hi[names.index(m)]) for n, m in zip(e.fit_names, fit_names)
                  if m in names}
        options.update({named(n): v for n, v in e.starts(data, bounds).items()})
        values = {p.name: p.off if p.off is not None else p.neutral for p in e.parameters}
        if all(v is not None for v in values.values()) and set(fit_names) <= set(names):
            try:
                off.update({named(n): v for n, v in e.to_fit(values, base["E_kPa"]).items()})
            except (ValueError, ZeroDivisionError):
                pass
    varied = [k for k in names if k in options and k not in base]
    out = []
    if model.in_loop:
        # the finite-element model in the loop: the simpler model's elastic values may be far
        # from the combination's (one layer standing in for two), so the elastic parameters
        # fitted before vary too; the starts are screened (one cheap run each) before a fit
        core_names = set(model.core.parameter_names[2:])
        for k in core_names & set(options):
            if k in base:
                options[k] = tuple(dict.fromkeys((base[k], *options[k])))
                varied.append(k)
        varied = [k for k in names if k in varied]
    new = [k for k in names if k not in base]  # the parameters of the effects added to the simpler model
    if prev is not None and all(k in off for k in new):
        nested = [base[k] if k in base else off[k] for k in names]
        out.append(np.clip(np.array(nested, dtype=float), lo, hi))
    candidates = _inserted(fitter, model, prev, base)
    axes = _axes(varied, options)
    for combo in itertools.islice(itertools.product(*(values for _, values in axes)), 20 * MAX_STARTS):
        chosen = {k: v for (keys, _), values in zip(axes, combo) for k, v in zip(keys, values)}
        x = [chosen[k] if k in chosen else base.get(k, 0.5 * (lo[i] + hi[i])) for i, k in enumerate(names)]
        candidates.append(np.clip(np.array(x, dtype=float), lo, hi))
    body = getattr(model.core, "body", None)
    if body is None:
        return out + candidates[: max(MAX_STARTS - len(out), 1)]
    n_core = len(model.core.parameter_names)
    seen = {body(x[1:n_core]) for x in out}  # the nested start: the simpler model's body
    for x in candidates:
        if len(out) >= MAX_STARTS:
            break
        try:
            b = body(x[1:n_core])
        except ValueError:
            continue
        if b not in seen:
            seen.add(b)
            out.append(x)
    return out


def _effect_views(fitter, model):
    """``(effect, the curve it starts from, its fit names in the model)`` of every effect of
    ``model``: the shared effects once, from the first curve; an effect of each curve
    (:attr:`~skin_indent.effects.Effect.per_curve`, the contact point) once per curve that has it,
    from that curve, its names numbered (``offset_mm[2]``)."""
    if not isinstance(model, JointModel):
        for e in model.effects:
            yield e, fitter.data, (lambda n: n)
        return
    for e in model.parts[0].effects:
        if not e.per_curve:
            yield e, fitter.curves[0], (lambda n: n)
    for k, part in enumerate(model.parts):
        for e in part.effects:
            if e.per_curve:
                yield e, fitter.curves[k], (lambda n, k=k: curve_name(n, k))


def _inserted(fitter, model, prev, base: dict) -> list[np.ndarray]:
    """Starts with one more occurrence of a repeatable effect than the simpler model
    ``prev`` (a second layer): the new one at every place among the fitted ones (above,
    between, below: :meth:`~skin_indent.effects.Effect.insert`) with its own start values,
    the fitted ones keeping their values. A second layer found by the fit may be a thin
    one above the interface fitted before, which the product of every parameter's start
    values (capped at :data:`MAX_STARTS`) does not reach."""
    if prev is None:
        return []
    names = model.parameter_names
    lo, hi = model.bounds
    before = {}
    for e in instances(prev.effects):
        before[e.name] = before.get(e.name, 0) + 1
    out = []
    for e in model.effects:
        inner = getattr(e, "inner", None)
        if inner is None or e.k != before.get(e.name, 0) + 1:
            continue
        try:
            fitted = [{n: prev.fit_parameters[numbered(n, k)] for n in inner.fit_names} for k in range(1, e.k)]
            at = {n: names.index(n) for n in inner.fit_names}
        except (KeyError, ValueError):
            continue
        options = inner.starts(fitter.curves[0], {n: (lo[i], hi[i]) for n, i in at.items()})
        for position in range(e.k):
            for combo in itertools.product(*(options[n] for n in inner.fit_names)):
                seq = inner.insert(fitted, position, dict(zip(inner.fit_names, combo)))
                if seq is None:
                    continue
                x = np.array([base.get(n, 0.5 * (lo[i] + hi[i])) for i, n in enumerate(names)], dtype=float)
                for k, values in enumerate(seq, 1):
                    for n, v in values.items():
                        x[names.index(numbered(n, k))] = v
                out.append(np.clip(x, lo, hi))
    return out


def screen(fitter, model, starts: list, keep: int, nested=None) -> list:
    """The ``keep`` best starts by their weighted misfit, from cheap runs made in parallel
    (:meth:`~skin_indent.models.fe_core.FECore.screening`).

    With the ``nested`` start (the simpler model's optimum), starts that fit as the
    simpler model does (within :data:`DEGENERATE` of its misfit: the added effect has
    no effect there, e.g. a second layer under a rigid base, or one of the first's
    modulus) are left out with it: the fit would not leave them. ``nested`` is
    ``starts[0]``. Each start is ranked at its best modulus E (the force is
    proportional to it, so the same run serves), and returned with it.

    Parameters
    ----------
    fitter : Fitter
        Its data, error model (weights 1 / sigma^2, sigma in mN) and priors.
    model : ComposedModel or JointModel
        A model with the finite-element model in the loop (``screening`` and ``prefetch``).
    starts : list of ndarray
        Start vectors (:func:`start_vectors`).
    keep : int
        How many to return.
    nested : ndarray, optional
        The nested start (``starts[0]``), if the simpler model has been fitted.

    Returns
    -------
    list of ndarray
        The best ``keep`` starts, best first (a start whose run fails is left out; with
        ``nested`` and nothing else left, ``[nested]``).
    """
    if nested is None and len(starts) <= keep:
        return starts
    d = fitter.data
    held = fitter.held(model)
    costs, forces = [], []
    lo, hi = model.bounds
    w = 1.0 / fitter.sigma(d.force_mN) ** 2
    starts = [np.array(x, dtype=float) for x in starts]
    with model.screening():  # cheaper runs that only rank the starts
        try:
            model.prefetch(starts)
        except ValueError:  # a start whose run does not converge ranks last (below), the others stand
            pass
        for i, x in enumerate(starts):
            try:
                # E profiled out: the force is proportional to it (a start whose other
                # parameters are right is not ranked down for a modulus carried over from a
                # simpler model); the run is the same for any E
                # (the nested start too, on a copy: a start that is the simpler model's body
                # then costs exactly what it costs, whatever E each carries)
                y = x.copy() if nested is not None and i == 0 else x
                f = model.force(d.depth_mm, y)
                top = float(np.sum(w * f * f))
                if top > 0 and "E_kPa" not in held:
                    y[0] = np.clip(y[0] * float(np.sum(w * f * d.force_mN)) / top, lo[0], hi[0])
                    f = model.force(d.depth_mm, y)
                costs.append(float(np.sum(((f - d.force_mN) / fitter.sigma(f)) ** 2)))
                forces.append(f)
            except ValueError:
                costs.append(math.inf)
                forces.append(None)
    if nested is not None:  # starts[0] is the nested start
        simpler = costs[0]
        costs = [math.inf if abs(c - simpler) <= DEGENERATE * simpler else c for c in costs]
        if forces[0] is not None:
            # ranked by how much of the simpler model's misfit the start's curve removes in
            # combination with the simpler model's: a ~ b F_start + a F_nested (a, b >= 0), a
            # linear view of the path from the optimum of the simpler model towards the start
            # (measured on two layers over a rigid base: the start from which the fit reaches
            # the noise ranked 5th of 23 by its own misfit, 1st by this)
            costs = [c if not math.isfinite(c) else blended_misfit(forces[0], f, d.force_mN, w) for c, f in
                     zip(costs, forces)]
    if fitter.priors:  # ranked by what the fit minimises: the misfit and the priors' share
        costs = [c + fitter.prior_chi2(model, x) if math.isfinite(c) else c for c, x in zip(costs, starts)]
    order = [int(i) for i in np.argsort(costs, kind="stable") if math.isfinite(costs[int(i)])]
    if not order and nested is not None:
        return [nested]  # nothing else to start from
    return [starts[i] for i in order[:keep]]


def blended_misfit(f0: np.ndarray, f1: np.ndarray, y: np.ndarray, w: np.ndarray) -> float:
    """Weighted misfit of ``y`` by ``a f0 + b f1`` at the best a, b >= 0."""
    A = np.stack([f0, f1], axis=1)
    G = A.T @ (w[:, None] * A)
    g = A.T @ (w * y)
    options = []
    try:
        c = np.linalg.solve(G, g)
        if np.all(c >= 0):
            options.append(c)
    except np.linalg.LinAlgError:
        pass
    for j in (0, 1):  # one curve alone
        c = np.zeros(2)
        if G[j, j] > 0:
            c[j] = max(g[j] / G[j, j], 0.0)
        options.append(c)
    return min(float(np.sum(w * (y - A @ c) ** 2)) for c in options)


def _axes(varied: list, options: dict) -> list:
    """The axes of the product of start values: ``[(names, [values...])]``. A parameter of each
    curve (``offset_mm[1]``, ``offset_mm[2]``) is one axis with the others of its name: the i-th
    start value of every curve together (its own contact guess, then the same shifts in units of
    each curve's indentation), not every combination."""
    axes, grouped = [], {}
    for k in varied:
        base, curve = split_name(k)
        if curve is None:
            axes.append(((k,), [(v,) for v in options[k]]))
        elif base in grouped:
            grouped[base][0].append(k)
        else:
            grouped[base] = ([k], len(axes))
            axes.append(None)
    for base, (keys, at) in grouped.items():
        width = max(len(options[k]) for k in keys)
        values = [tuple(options[k][min(i, len(options[k]) - 1)] for k in keys) for i in range(width)]
        axes[at] = (tuple(keys), values)
    return axes
