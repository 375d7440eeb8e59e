"""The multistart fitter of any model (the half-space with any effects): each set of effects fitted once, as a :class:`Rung`."""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import logging
import math

import numpy as np

from ..effects import CONTACT_POINT, ELASTIC, WEIGHED, Model, instances, numbered
from ..inverse import IdentificationResult
from ..inverse import fit_least_squares
from ..inverse.residuals import analyse_residuals
from ..inverse.result import jacobian_covariance
from ..measurement import CurveSet
from ..measurement.scale import joined
from ..models import ComposedModel, JointModel
from ..models.joint import curve_name, split_name
from .identification import hertz_modulus
from .rung import MODEL_ERROR, NO_STRUCTURE, Rung, evidence, structure_sentence
from .knowledge import held_coordinates, prior_rows, prior_summary
from .scale_checks import check_points
from .surfaces import elastic_core

log = logging.getLogger(__name__)

__all__ = ["FE_MAX_EVALUATIONS", "FE_PROBE", "FE_PROBES", "FE_RETRY", "FE_TOL", "MAX_STARTS", "MODEL_ERROR",
           "NO_STRUCTURE", "Fitter", "Rung", "evidence", "forward_runs", "in_loop", "structure_sentence"]

#: at most this many start vectors (the product of the effects' start values, warm values first)
MAX_STARTS = 24
#: function evaluations (finite-element runs, besides the Jacobians') of one such start
FE_MAX_EVALUATIONS = 20
#: starts kept after screening: the fit goes from the best-ranked; when it ends above
#: :data:`FE_RETRY` times the noise (with the model error), it goes on from where it got if its budget
#: (:data:`FE_MAX_EVALUATIONS`) stopped it, and if still above, each of the others gets a short fit
#: (:data:`FE_PROBE` evaluations) and the best of those, if better, is fitted to the end
FE_PROBES = 3
FE_RETRY = 1.3
FE_PROBE = 5
#: a start whose misfit is within this fraction of the nested start's is the simpler model in
#: disguise (its added effect does nothing there) and is not fitted from
DEGENERATE = 1e-3
#: relative tolerance of such a fit on the cost and the parameters: 1e-4 of a chi-square of ~n
#: moves a BIC by ~0.01, far below the differences diagnosis acts on
FE_TOL = 1e-4


def _blended(f0: np.ndarray, f1: np.ndarray, y: np.ndarray, w: np.ndarray) -> float:
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


class Fitter:
    """Surfaces, error model and fits shared by one diagnosis.

    Parameters
    ----------
    data : PreparedCurve or sequence of PreparedCurve
        One curve, or several curves of one sample (two spheres, two speeds...), fitted
        together: the material's parameters shared, each curve with its own contact point
        (:class:`~skin_indent.models.JointModel`), sphere radius and noise.
    noise_mN : float or sequence of float
        Noise level (mN) of the prepared points (one per curve).
    noise_known : bool
        Given by the user (else estimated: its uncertainty enters the chi-square test).
    context : Context
    mesh : str

    Attributes
    ----------
    curves : list of PreparedCurve
        In input order; ``data`` is the curve itself, or a
        :class:`~skin_indent.measurement.CurveSet` of them (the points concatenated).
    noises_mN : list of float
        Each curve's noise level; ``noise_mN`` is the first curve's, the scale of the fits'
        weights (each point is weighed by its own curve's noise).
    """

    def __init__(self, data, noise_mN, *, noise_known: bool, context, mesh: str, in_loop: bool = True,
                 fixed: dict | None = None, priors: dict | None = None):
        curves = list(data.curves) if isinstance(data, CurveSet) else (
            list(data) if isinstance(data, (list, tuple)) else [data])
        noises = [float(v) for v in np.broadcast_to(np.asarray(noise_mN, dtype=float), (len(curves),))]
        self.curves, self.noises_mN = curves, noises
        self.data = curves[0] if len(curves) == 1 else CurveSet(tuple(curves))
        #: each point's noise (mN): its curve's
        self.noise_points = np.concatenate([np.full(c.n, s) for c, s in zip(curves, noises)])
        data, noise_mN = curves[0], noises[0]
        #: what the user knows, by the names results report (``thickness_mm``, ``ratio``, ``E_kPa``...):
        #: values held fixed, and Gaussian priors ``{name: (mean, sd)}``; each applies to the models
        #: that have the parameter
        self.fixed = {k: float(v) for k, v in (fixed or {}).items()}
        self.priors = {k: (float(m), float(sd)) for k, (m, sd) in (priors or {}).items()}
        for k, (m, sd) in self.priors.items():
            if not (math.isfinite(m) and math.isfinite(sd) and sd > 0):
                raise ValueError(f"prior {k}: needs a finite mean and a positive sd, got {m:g} +- {sd:g}")
        both = set(self.fixed) & set(self.priors)
        if both:
            raise ValueError(f"{', '.join(sorted(both))}: held fixed and given a prior; choose one")
        self.radius_mm = data.radius_mm
        self.noise_mN = noise_mN
        # an estimated noise level is uncertain: ~12% for 100 points (estimate_noise), i.e. ~0.35 n dof
        self.noise_dof = None if noise_known else 0.35 * self.data.n
        self.context = context
        self.mesh = mesh
        #: fit combinations that no surface covers with the finite-element model in the loop
        self.in_loop = in_loop
        self.e_stars = []
        for c in curves:
            h, F = c.loading()
            if h.size < 3:
                raise ValueError(f"{c.source}: fewer than 3 loading points in contact to diagnose")
            self.e_stars.append(hertz_modulus(h, np.maximum(F, 0.0), c.radius_mm))
        self.max_depth = data.max_indentation_mm
        self.e_star = self.e_stars[0]
        self._cores = {}
        self.fits: dict[tuple, Rung] = {}
        #: the contact point is a parameter of every model of a curve recorded from before contact
        self.implicits = [(CONTACT_POINT.name,) if c.contact_mode == "fit" else () for c in curves]
        self.implicit = self.implicits[0]

    @property
    def joint(self) -> bool:
        """Several curves of one sample are fitted together."""
        return len(self.curves) > 1

    def sigma(self, force) -> np.ndarray:
        """The error model: sigma_i (mN) of each point, noise (its curve's) and model error in quadrature."""
        noise = self.noise_points if self.joint else self.noise_mN
        return np.sqrt(noise**2 + (MODEL_ERROR * np.abs(force)) ** 2)

    def visible(self, e) -> str | None:
        """None if the effect ``e`` can show in the data (a curve, or the curves of a sample
        together: :meth:`~skin_indent.effects.Effect.visible_in`), else why not."""
        if not self.joint:
            return e.visible(self.data, self.noise_mN)
        return e.visible_in(self.curves, self.noises_mN)

    def parts(self, rung):
        """Per curve of ``rung``'s fit: ``(k, curve, noise_mN, points slice, model parameters under
        the curve's own names)`` (one curve: the rung's own parameters)."""
        if not self.joint:
            yield 0, self.data, self.noise_mN, slice(0, self.data.n), dict(rung.parameters)
            return
        for k, (c, sl) in enumerate(zip(self.curves, self.data.slices)):
            yield k, c, self.noises_mN[k], sl, rung.bound_model.curve_parameters(rung.parameters, k)

    def error_model(self) -> dict:
        """The error model in words and numbers (how the chi-square and BIC of every fit of this curve weigh it)."""
        return {"noise_mN": self.noise_mN if not self.joint else list(self.noises_mN), "model_error": MODEL_ERROR,
                "sigma": "sqrt(noise^2 + (model_error * F)^2)" + (", noise of each point's curve" if self.joint else "")}

    def held(self, model) -> dict:
        """The fixed values of the parameters ``model`` has, as its fit coordinates ``{name: value}``
        (:func:`held_coordinates`)."""
        return held_coordinates(model, self.fixed)

    def prior_terms(self, model) -> list:
        """The priors on parameters of ``model``, as :func:`~skin_indent.inverse.fit_least_squares`
        takes them: ``(g, mean, sd)`` with ``g(theta)`` the reported parameter."""
        reported = model.model_parameters(0.5 * (model.bounds[0] + np.minimum(model.bounds[1], 1e6)))
        out = []
        for k, (m, sd) in self.priors.items():
            if k in reported:
                out.append((lambda theta, k=k: float(model.model_parameters(theta)[k]), m, sd))
        return out

    def check_names(self, model) -> None:
        """Every held or prior name is a parameter of ``model`` (one line naming those it has)."""
        reported = set(model.model_parameters(0.5 * (model.bounds[0] + np.minimum(model.bounds[1], 1e6))))
        reported |= set(model.parameter_names)
        unknown = [k for k in (*self.fixed, *self.priors) if k not in reported]
        if unknown:
            raise ValueError(f"{', '.join(unknown)}: not a parameter of {model.name} (its parameters: "
                             f"{', '.join(dict.fromkeys((*model.model_parameters(model.bounds[0]), )))})")

    def check_points(self, model) -> None:
        """Refuse to fit ``model`` to fewer points in contact than its free parameters need
        (:func:`~.scale_checks.check_points`: ``n_free + 2``, the fixed ones not counted).

        Raises
        ------
        MeasurementError
            One line naming the count, the model and what it needs: a diagnosis reports it as the
            curve's error for the given model, and a candidate with more parameters than the curve
            can take as not fitted (``untried``, with this reason).
        """
        check_points(self.data, len(model.parameter_names) - len(self.held(model)), model=model.name)

    def check_points_before_building(self, effects: tuple) -> None:
        """:meth:`check_points` for the model of ``effects`` before it is built (its elastic core can
        be a response surface to build: a curve too short for the model pays nothing for it).

        The parameters are counted from the effects (:class:`~skin_indent.effects.Model`: the same
        names as the built model's, one per fit coordinate) less those held. Where that count needs
        the built model (several curves, each with its own contact point; a held name the model
        does not have, as it reports its parameters) nothing is checked here:
        :meth:`check_points` checks the built model.
        """
        if self.joint:
            return
        full = self.full(effects)
        names = Model(full, float(self.data.radius_mm)).parameter_names
        if any(k not in names for k in self.fixed):
            return
        check_points(self.data, len(names) - len(self.fixed), model="neo-hooke" + "".join(f"+{e}" for e in full))

    def core(self, effects, k: int = 0):
        """The elastic force model of these effects for curve ``k`` (cached per set of elastic effects
        and curve).

        A response surface for none or one elastic effect; the finite-element model in
        the loop for more (two layers, layer and stiffening...).
        """
        key = tuple(e.name for e in instances(effects) if e.stage == ELASTIC)
        if len(key) > 1 and not self.in_loop:
            raise ValueError(f"no surface combines {' and '.join(key)}: it is fitted with the finite-element model "
                             "in the loop, switched off here")
        if (key, k) not in self._cores:
            c = self.curves[k]
            self._cores[key, k] = elastic_core(key, radius_mm=c.radius_mm, max_depth_mm=c.max_indentation_mm,
                                               e_star_kPa=self.e_stars[k], context=self.context, mesh=self.mesh)
        return self._cores[key, k]

    @property
    def cores(self) -> tuple:
        """The elastic force models the fits have used so far (response surfaces, effect surfaces, finite
        elements in the loop; one per curve of a sample), in the order they were first needed: what a
        provenance records."""
        return tuple(self._cores.values())

    def full(self, effects, k: int = 0) -> tuple:
        """The effects of curve ``k``'s fitted model: its implicit contact point first (once), then ``effects``."""
        names = tuple(e.name for e in instances(effects))
        return tuple(e for e in self.implicits[k] if e not in names) + names

    def model(self, effects: tuple):
        """The fitted model of these effects: bound to the curve, or a
        :class:`~skin_indent.models.JointModel` of every curve of the sample."""
        objs = instances(effects)
        weighed = [e.name for e in objs if e.stage == WEIGHED]
        if weighed:
            raise ValueError(f"{', '.join(weighed)} is weighed, not fitted: no fitted model has it yet")
        parts = []
        for k, c in enumerate(self.curves):
            full = self.full(effects, k)
            parts.append(ComposedModel(self.core(full, k), full, c))
        return parts[0] if len(parts) == 1 else JointModel(parts)

    def warm(self, effects: tuple):
        """The fitted rung of the largest set of effects contained in ``effects`` (None: none fitted)."""
        want = sorted(effects)
        best = None
        for key, rung in list(self.fits.items()):  # a copy: fits in other threads add to it
            if len(key) >= len(effects):
                continue
            rest = list(want)
            try:
                for e in key:
                    rest.remove(e)
            except ValueError:
                continue
            if best is None or len(key) > len(best.effects):
                best = rung
        return best

    def starts(self, model, effects: tuple) -> list[np.ndarray]:
        """Start vectors (:meth:`_starts`) with the held values in place, each once; with priors,
        each start also once more with the priors' means in place (after all of them), so that
        the fit can start where what the user knows puts it."""
        held = self.held(model)
        base = self._starts(model, effects)
        if not held and not self.priors:
            return base
        idx = {model.parameter_names.index(k): v for k, v in held.items()}
        means = {}
        for k, (mean, _) in self.priors.items():
            try:
                means.update(held_coordinates(model, {**self.fixed, k: mean}))
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

    def prior_chi2(self, model, x) -> float:
        """The priors' share of the cost at ``x``: sum of ((g(x) - mean) / sd)^2."""
        return float(sum(((g(x) - mean) / sd) ** 2 for g, mean, sd in self.prior_terms(model)))

    def _starts(self, model, effects: tuple) -> list[np.ndarray]:
        """Start vectors: the warm start with the new effects switched off first (a fit can
        then only improve on the nested model), then one more occurrence of a repeatable effect
        inserted among the fitted ones (:meth:`_inserted`), then the effects' own start values.
        With the finite-element model in the loop, each body is started from once (starts that
        build the same body up to its modulus are one) and none is the simpler model's body.
        """
        names = model.parameter_names
        lo, hi = model.bounds
        nu0 = min(max(0.45, lo[1]), hi[1])
        base = {"E_kPa": self.e_star * (1 - nu0**2), "nu": nu0}
        prev = self.warm(tuple(effects))
        if prev is not None:
            base.update({k: v for k, v in prev.fit_parameters.items() if k in names})
        options, off = {}, {}
        for e, data, named in self._effect_views(model):
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
        if in_loop(model):
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
        candidates = self._inserted(model, prev, base)
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

    def _effect_views(self, model):
        """``(effect, the curve it starts from, its fit names in the model)`` of every effect of
        ``model``: the shared effects once, from the first curve; an effect of each curve
        (:attr:`~skin_indent.effects.Effect.per_curve`, the contact point) once per curve that has it,
        from that curve, its names numbered (``offset_mm[2]``)."""
        if not isinstance(model, JointModel):
            for e in model.effects:
                yield e, self.data, (lambda n: n)
            return
        for e in model.parts[0].effects:
            if not e.per_curve:
                yield e, self.curves[0], (lambda n: n)
        for k, part in enumerate(model.parts):
            for e in part.effects:
                if e.per_curve:
                    yield e, self.curves[k], (lambda n, k=k: curve_name(n, k))

    def _inserted(self, model, prev, base: dict) -> list[np.ndarray]:
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
            options = inner.starts(self.curves[0], {n: (lo[i], hi[i]) for n, i in at.items()})
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

    def _screen(self, model, starts: list, keep: int, nested=None) -> list:
        """The ``keep`` best starts by their weighted misfit, from cheap runs made in parallel
        (:meth:`~skin_indent.models.fe_core.FECore.screening`).

        With the ``nested`` start (the simpler model's optimum), starts that fit as the
        simpler model does (within :data:`DEGENERATE` of its misfit: the added effect has
        no effect there, e.g. a second layer under a rigid base, or one of the first's
        modulus) are left out with it: the fit would not leave them. ``nested`` is
        ``starts[0]``. Each start is ranked at its best modulus E (the force is
        proportional to it, so the same run serves), and returned with it.
        """
        if nested is None and len(starts) <= keep:
            return starts
        d = self.data
        held = self.held(model)
        costs, forces = [], []
        lo, hi = model.bounds
        w = 1.0 / self.sigma(d.force_mN) ** 2
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
                    costs.append(float(np.sum(((f - d.force_mN) / self.sigma(f)) ** 2)))
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
                costs = [c if not math.isfinite(c) else _blended(forces[0], f, d.force_mN, w) for c, f in
                         zip(costs, forces)]
        if self.priors:  # ranked by what the fit minimises: the misfit and the priors' share
            costs = [c + self.prior_chi2(model, x) if math.isfinite(c) else c for c, x in zip(costs, starts)]
        order = [int(i) for i in np.argsort(costs, kind="stable") if math.isfinite(costs[int(i)])]
        if not order and nested is not None:
            return [nested]  # nothing else to start from
        return [starts[i] for i in order[:keep]]

    def fit_all(self, keys) -> dict:
        """Fit several sets of effects: ``{key: Rung or ValueError}`` (the error of a set that
        cannot be fitted), in the order of ``keys``.

        Sets fitted with the finite-element model in the loop (two layers, layer and
        stiffening) are fitted at once, one thread per elastic core whose runs go to worker
        processes (:meth:`~skin_indent.models.fe_core.FECore.in_workers`): a fit's evaluations
        are serial, so two fits side by side keep both cores busy. Each fit is the one
        :meth:`fit` makes alone (its own core, its own warm start from the rungs already fitted).
        """
        from concurrent.futures import ThreadPoolExecutor

        def attempt(group):
            out = {}
            for key in group:
                try:
                    out[key] = self.fit(key)
                except ValueError as err:
                    out[key] = err
            return out

        keys = [tuple(k) for k in keys]
        groups: dict[int, list] = {}  # new in-loop fits by core: a core serves one thread
        done = {}
        for key in keys:
            if key in self.fits:
                done[key] = self.fits[key]
                continue
            try:
                self.check_points_before_building(key)  # a curve too short for it builds nothing
                cores = self.model(key).cores  # the cores are made here, in this thread
            except ValueError as err:
                done[key] = err
                continue
            looped = tuple(id(c) for c in cores if hasattr(c, "in_workers"))
            if looped:
                groups.setdefault(looped, []).append(key)
            else:
                done.update(attempt([key]))
        if len(groups) > 1:
            cores = [c for group in groups.values() for c in self.model(group[0]).cores if hasattr(c, "in_workers")]
            with contextlib.ExitStack() as stack:
                for core in cores:
                    stack.enter_context(core.in_workers())
                    core.start_workers()  # forked from this (the main) thread, not from the fits'
                pool = ThreadPoolExecutor(max_workers=len(groups))
                try:
                    for out in pool.map(attempt, groups.values()):
                        done.update(out)
                except BaseException:  # an interrupt: the other threads stop at their next run
                    for core in cores:
                        core.cancel()
                    raise
                finally:
                    pool.shutdown(wait=True)
        else:
            for group in groups.values():
                done.update(attempt(group))
        return {key: done[key] for key in keys}

    def fit(self, effects: tuple) -> Rung:
        key = tuple(effects)
        if key in self.fits:
            return self.fits[key]
        self.check_points_before_building(key)
        model = self.model(key)
        self.check_points(model)
        d = self.data
        known = {"fixed": self.held(model) or None, "priors": self.prior_terms(model) or None}
        starts = self.starts(model, key)
        options = {}
        lo, hi = model.bounds
        runs0 = forward_runs(model)
        looped = in_loop(model)
        if self.joint:  # each point weighed by its own curve's noise
            known["sigma_mN"] = self.noise_points
        # measured (module docstring, 2 cores): 50-100 runs and 1-3 minutes per fit in the loop
        log.info("fitting %s %s%s", model.name, "with finite elements in the loop (typically 50-100 runs, 1-3 min on "
                 "2 cores)" if looped else "on response surfaces",
                 f" to {len(self.curves)} curves of one sample" if self.joint else "")
        if looped:  # each evaluation is a finite-element run: screen the starts, stop at FE_TOL
            # not from the nested start nor from starts equivalent to it: there the combination is
            # the simpler model exactly (a second layer of the first one's modulus, or under a rigid
            # base), a stationary point the fit does not leave (measured: it stops after 3
            # evaluations at the simpler model's RMS)
            nested = starts[0] if self.warm(key) is not None else None
            starts = self._screen(model, starts, FE_PROBES, nested=nested)
            options = dict(ftol=FE_TOL, xtol=FE_TOL, gtol=1e-8, max_nfev=FE_MAX_EVALUATIONS)
        best, first = None, None
        for i, x0 in enumerate(starts):
            try:
                res = fit_least_squares(model, d.depth_mm, d.force_mN, x0, noise_mN=self.noise_mN, **known, **options)
            except ValueError:  # a run of this start's fit failed: the next start
                continue
            if best is None or _cost(res) < _cost(best):
                best, first = res, i
            if looped:
                break
        noise = float(np.sqrt(np.mean(self.sigma(d.force_mN) ** 2)))  # with the model error
        if looped and best is not None and best.rms_mN > FE_RETRY * noise and best.status == 0:
            # stopped by its budget short of the noise: on from where it got (measured: two layers
            # on a rigid base stopped at 0.065 mN on its way to the truth's 0.041 mN, noise 0.03)
            best = self._resumed(model, best, known, options)
        if looped and best is not None and best.rms_mN > FE_RETRY * noise:
            # the best-ranked start led to a fit that does not reach the noise: a short fit from
            # each of the other screened starts, and the best of those, if better, to the end
            probes = []
            for x0 in starts[first + 1:]:
                try:
                    probes.append(fit_least_squares(model, d.depth_mm, d.force_mN, x0, noise_mN=self.noise_mN, **known,
                                                    **{**options, "max_nfev": FE_PROBE}))
                except ValueError:
                    continue
            lead = min(probes, key=_cost, default=None)
            if lead is not None and _cost(lead) < _cost(best):
                if lead.status == 0:  # stopped by its budget: on from where it got
                    lead = self._resumed(model, lead, known, options)
                best = lead if _cost(lead) < _cost(best) else best
        if looped and nested is not None and (best is None or _cost(best) > _cost(self.warm(key))):
            # the combination holds the simpler model: a fit that ends above it got lost on the
            # way (measured: two layers from the best screened start 0.0124 mN, one layer 0.0110);
            # the simpler model's optimum stands, the added effect doing nothing
            try:
                alt = fit_least_squares(model, d.depth_mm, d.force_mN, nested, noise_mN=self.noise_mN, **known,
                                        **{**options, "max_nfev": 1})
                best = alt if best is None or _cost(alt) < _cost(best) else best
            except ValueError:
                pass
        if best is None:
            raise ValueError(f"the model {model.name} could not be fitted")
        runs = forward_runs(model) - runs0
        if looped:
            log.info("fitted %s: %d finite-element runs", model.name, runs)
        x = np.array([best.parameters[n] for n in model.parameter_names])
        pred = d.force_mN - best.residuals_mN
        cov = np.full((x.size, x.size), np.nan)
        idx = [model.parameter_names.index(n) for n in best.free_names]
        held = [model.parameter_names.index(n) for n in best.fixed_names]
        cov[held, :] = 0.0  # a held value has no variance
        cov[:, held] = 0.0
        cov[np.ix_(idx, idx)] = best.covariance
        active = [n for n in best.info.get("active_bounds", ()) if n in best.free_names]
        if active and not np.all(np.isfinite(best.covariance)):
            # a parameter on a face of its range (a rigid base: compliance 0) is held there: the
            # covariance of the others is that of the fit with it fixed

            keep = [model.parameter_names.index(n) for n in best.free_names if n not in active]
            noise = self.noise_points[:, None] if self.joint else self.noise_mN
            rows = model.jacobian(d.depth_mm, x)[:, keep] / noise
            terms = known["priors"] or ()
            if terms:  # the priors' rows, whitened as the data's: the posterior, as the fit's own covariance
                rows = np.vstack([rows, prior_rows(terms, x, keep, lo, hi)])
            cov = np.zeros((x.size, x.size))
            cov[np.ix_(keep, keep)] = jacobian_covariance(rows)[0]
        params, std = model.reported(x, cov)
        for k in self.fixed:  # held: reported without a standard deviation, as every fit does
            std.pop(k, None)
        for k in best.fixed_names:
            std.pop(k, None)
        knowledge = {k: prior_summary(params[k], std.get(k, math.nan), *self.priors[k])
                     for k in self.priors if k in params}
        r = best.residuals_mN
        s = self.sigma(pred)
        analysis = analyse_residuals(r * (self.noise_mN / s), self.noise_mN, best.n_free, noise_dof=self.noise_dof)
        curve_rms, curve_white = self._per_curve(r, s, best.n_free)
        base = {f.name: getattr(best, f.name) for f in dataclasses.fields(IdentificationResult)}
        base.update(parameters=params, std=std, bic=math.nan)
        rung = Rung(**base, model="neo-hooke" + "".join(f"+{e}" for e in key), effects=key,
                    fit_parameters=dict(best.parameters), prediction_mN=pred,
                    chi2_weighted=float(np.sum((r / s) ** 2)), white=analysis.white, analysis=analysis,
                    structure=self.structure(r, s), bound_model=model, x=x, forward_runs=runs,
                    at_bounds=tuple(best.info.get("active_bounds", ())), priors=knowledge, curve_rms_mN=curve_rms,
                    curve_white=curve_white)
        self.fits[key] = rung
        return rung

    def _resumed(self, model, result, known: dict, options: dict):
        """A fit in the loop that stopped by its budget (``status`` 0), fitted on from where it got
        with the same budget: the better of the two (a run that fails leaves ``result``)."""
        lo, hi = model.bounds
        x = np.array([result.parameters[n] for n in model.parameter_names])
        try:
            more = fit_least_squares(model, self.data.depth_mm, self.data.force_mN, np.clip(x, lo, hi),
                                     noise_mN=self.noise_mN, **known, **options)
        except ValueError:
            return result
        return more if _cost(more) < _cost(result) else result

    def _per_curve(self, residual, sigma, n_free: int) -> tuple[tuple, tuple]:
        """Each curve's RMS residual (mN) and whether its residual alone is white (one curve: the fit's)."""
        if not self.joint:
            rms = float(np.sqrt(np.mean(residual**2)))
            return (rms,), ()
        rms, white = [], []
        for (c, sl), noise in zip(zip(self.curves, self.data.slices), self.noises_mN):
            r = residual[sl]
            rms.append(float(np.sqrt(np.mean(r**2))))
            try:
                a = analyse_residuals(r * (noise / sigma[sl]), noise, 0, noise_dof=None if self.noise_dof is None
                                      else 0.35 * c.n)
                white.append(bool(a.white))
            except ValueError:  # too few points for the tests
                white.append(True)
        return tuple(rms), tuple(white)

    def structure(self, residual, sigma) -> str:
        """Where the residual departs from the noise, in words (:func:`structure_sentence`), per curve
        of a sample (``"curve 2 (file): ..."``)."""
        if not self.joint:
            return structure_sentence(self.data, residual, sigma)
        parts = []
        for k, (c, sl) in enumerate(zip(self.curves, self.data.slices)):
            text = structure_sentence(c, residual[sl], sigma[sl])
            if text != NO_STRUCTURE:
                parts.append(joined("", [f"curve {k + 1} ({c.source}): ", text]))
        return joined("; ", parts) if parts else NO_STRUCTURE


def in_loop(model) -> bool:
    """The model is fitted with the finite-element model in the loop (some curve's core is a
    :class:`~skin_indent.models.fe_core.FECore`)."""
    return any(hasattr(c, "prefetch") for c in model.cores)


def forward_runs(model) -> int:
    """Finite-element runs made so far by the model's cores (0 for surfaces)."""
    return sum(getattr(c, "runs", 0) for c in model.cores)


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


def _cost(result) -> float:
    """What a fit minimises: the data's chi-square plus the priors' (their -2 ln posterior up to a constant)."""
    return float(result.chi2 + result.info.get("prior_chi2", 0.0))
