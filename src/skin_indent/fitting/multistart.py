"""The multistart fitter of any model (the half-space with any effects): each set of effects fitted once,
as a :class:`~skin_indent.fitting.FitResult` (:mod:`.assembly` makes it from the end of the fit;
:mod:`.side_by_side` fits several at once)."""

from __future__ import annotations

import logging
import math
import threading

import numpy as np

from ..effects import CONTACT_POINT, ELASTIC, WEIGHED, Model, instances, model_name
from ..effects.order import same_model
from ..inverse import fit_least_squares
from ..measurement import CurveSet
from ..models import ComposedModel, JointModel
from .identification import hertz_modulus
from .error_model import MODEL_ERROR, described, point_sigma
from .result import FitResult
from .rung import NO_STRUCTURE, evidence, structure_sentence
from .knowledge import held_coordinates
from .scale_checks import check_points
from .ended import stalled
from .resume import at_rigid_base, cost as _cost, first_fit, resumed
from .starts import MAX_STARTS, same_body, screen, start_vectors
from .reorder import relabelled
from .assembly import assemble
from .side_by_side import side_by_side
from .surfaces import elastic_core

log = logging.getLogger(__name__)

__all__ = ["FE_MAX_EVALUATIONS", "FE_PROBE", "FE_PROBES", "FE_RETRY", "FE_TOL", "MAX_STARTS", "MODEL_ERROR",
           "NO_STRUCTURE", "Fitter", "FitResult", "evidence", "forward_runs", "in_loop", "structure_sentence"]

#: function evaluations (finite-element runs, besides the Jacobians') of one such start
FE_MAX_EVALUATIONS = 20
#: starts kept after screening: the fit goes from the best-ranked; when it ends above
#: :data:`FE_RETRY` times the noise (with the model error), it goes on from where it got if its budget
#: (:data:`FE_MAX_EVALUATIONS`) stopped it, and if still above, each of the others gets a short fit
#: (:data:`FE_PROBE` evaluations) and the best of those, if better, is fitted to the end
FE_PROBES = 3
FE_RETRY = 1.3
FE_PROBE = 5
#: relative tolerance of such a fit on the cost and the parameters: 1e-4 of a chi-square of ~n
#: moves a BIC by ~0.01, far below the differences diagnosis acts on
FE_TOL = 1e-4
#: function evaluations of a fit on response surfaces (None: scipy's default, 100 per parameter)
SURFACE_MAX_EVALUATIONS = None


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
                 fixed: dict | None = None, priors: dict | None = None, starts: dict | None = None):
        #: start values known from fits of the same models to other curves of the sample (a single
        #: curve's diagnosis): ``{sorted effects: {fit parameter: value}}``; only where to start from
        self.known_starts = {tuple(sorted(k)): dict(v) for k, v in (starts or {}).items()}
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
        self.fits: dict[tuple, FitResult] = {}
        self._seen = threading.local()  # in fit_all's threads: the fits a thread's warm starts may read
        #: the contact point is a parameter of every model of a curve recorded from before contact
        self.implicits = [(CONTACT_POINT.name,) if c.contact_mode == "fit" else () for c in curves]
        self.implicit = self.implicits[0]

    @property
    def joint(self) -> bool:
        """Several curves of one sample are fitted together."""
        return len(self.curves) > 1

    def sigma(self, force) -> np.ndarray:
        """The error model: sigma_i (mN) of each point, noise (its curve's) and model error in quadrature."""
        return point_sigma(self.noise_points if self.joint else self.noise_mN, force)

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
        return described(self.noise_mN if not self.joint else list(self.noises_mN), MODEL_ERROR, self.joint)

    def held(self, model) -> dict:
        """The fixed values of the parameters ``model`` has, as its fit coordinates ``{name: value}``
        (:func:`held_coordinates`)."""
        return held_coordinates(model, self.fixed)

    def prior_terms(self, model, but: str | None = None) -> list:
        """The priors on parameters of ``model`` (all but the one on ``but``), as
        :func:`~skin_indent.inverse.fit_least_squares` takes them: ``(g, mean, sd)`` with ``g(theta)``
        the reported parameter."""
        reported = model.model_parameters(0.5 * (model.bounds[0] + np.minimum(model.bounds[1], 1e6)))
        out = []
        for k, (m, sd) in self.priors.items():
            if k in reported and k != but:
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
        check_points(self.data, len(names) - len(self.fixed), model=model_name(full))

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
        """The fitted rung of the largest set of effects contained in ``effects`` (None: none fitted);
        of equal size, one of the same elastic body (:func:`~.starts.same_body`), else the first fitted."""
        want = sorted(effects)
        best = None
        seen = getattr(self._seen, "keys", None)  # fit_all's threads: what was fitted before, and their own
        for key, rung in list(self.fits.items()):  # a copy: fits in other threads add to it
            if len(key) >= len(effects) or (seen is not None and key not in seen):
                continue
            rest = list(want)
            try:
                for e in key:
                    rest.remove(e)
            except ValueError:
                continue
            if best is None or len(key) > len(best.effects) or (
                    len(key) == len(best.effects) and same_body(rung, effects) and not same_body(best, effects)):
                best = rung  # of equal size, the one of the same elastic body (starts.same_body)
        return best

    def prior_chi2(self, model, x) -> float:
        """The priors' share of the cost at ``x``: sum of ((g(x) - mean) / sd)^2."""
        return float(sum(((g(x) - mean) / sd) ** 2 for g, mean, sd in self.prior_terms(model)))

    def fit_all(self, keys) -> dict:
        """Fit several sets of effects at once, the fits in the loop side by side: ``{key: FitResult or
        ValueError}`` in the order of ``keys`` (:func:`~.side_by_side.side_by_side`)."""
        return side_by_side(self, keys)

    def twin(self, effects: tuple) -> tuple | None:
        """The fitted set of effects that is the model of ``effects`` in another order
        (:func:`~skin_indent.effects.order.same_model`: ``layer+stiffening`` for ``stiffening+layer``), or None."""
        key = tuple(effects)
        return next((k for k in list(self.fits) if k != key and same_model(k, key)), None)

    def fit(self, effects: tuple) -> FitResult:
        """The fit of the model of ``effects`` (:class:`FitResult`), made once: the same effects in another
        order fitted before give its numbers under this order's name (:func:`~.reorder.relabelled`)."""
        key = tuple(effects)
        if key in self.fits:
            return self.fits[key]
        twin = self.twin(key)
        if twin is not None:
            rung = relabelled(self, self.fits[twin], key)
            if rung is not None:
                log.info("%s is %s in another order: its fit", model_name(key), self.fits[twin].model)
                self.fits[key] = rung
                return rung
        self.check_points_before_building(key)
        model = self.model(key)
        self.check_points(model)
        d = self.data
        known = {"fixed": self.held(model) or None, "priors": self.prior_terms(model) or None}
        starts = start_vectors(self, model, key)
        options = {}
        lo, hi = model.bounds
        runs0 = forward_runs(model)
        cached0 = sum(getattr(c, "cached", 0) for c in model.cores)
        looped = in_loop(model)
        if self.joint:  # each point weighed by its own curve's noise
            known["sigma_mN"] = self.noise_points
        # no time estimate: on a rerun the runs come from the run cache (measured, module docstring, 2 cores:
        # 50-100 runs and 1-3 minutes per fit in the loop from an empty cache)
        log.info("fitting %s %s%s", model.name, "with finite elements in the loop" if looped else "on response surfaces",
                 f" to {len(self.curves)} curves of one sample" if self.joint else "")
        if looped:  # each evaluation is a finite-element run: screen the starts, stop at FE_TOL
            # not from the nested start of an added elastic effect nor from starts equivalent to it:
            # there the combination is the simpler model exactly (a second layer of the first one's
            # modulus, or under a rigid base), a stationary point the fit does not leave (measured: it
            # stops after 3 evaluations at the simpler model's RMS)
            nested = starts[0] if self.warm(key) is not None else None
            options = dict(ftol=FE_TOL, xtol=FE_TOL, gtol=1e-8, max_nfev=FE_MAX_EVALUATIONS)
            seed = self._known_start(model, key, starts)
            if seed is not None:
                # the optimum of the same model on other curves of the sample: from there first; the
                # screened starts only if that fit fails or does not move
                best, first = self._first_fit(model, [seed], known, options, looped)
                if best is not None and best.status == 0:
                    best = self._resumed(model, best, known, options)
                if best is None or stalled(best, model):
                    log.info("%s from the known start: %s; screening its starts", model.name,
                             "failed" if best is None else f"RMS {best.rms_mN:.3g} mN")
                    kept = best
                    starts = screen(self, model, starts, FE_PROBES, nested=nested)
                    best, first = self._first_fit(model, starts, known, options, looped,
                                                  still=kept if kept is not None and stalled(kept, model) else None)
                    if kept is not None and not stalled(kept, model) and (best is None or _cost(kept) < _cost(best)):
                        best, first = kept, len(starts)
                else:
                    starts = [seed]
            elif nested is not None and same_body(self.warm(key), key):
                # only effects outside the elastic body added to a body fitted in the loop (the contact
                # points on two layers): from that optimum, no start of the body screened again; the
                # screened starts only if the fit does not move from there
                best, first = self._first_fit(model, [nested], known, options, looped)
                if best is None or stalled(best, model):
                    starts = screen(self, model, starts, FE_PROBES, nested=nested)
                    best, first = self._first_fit(model, starts, known, options, looped, still=best)
                else:
                    starts = [nested]
            else:
                starts = screen(self, model, starts, FE_PROBES, nested=nested)
                best, first = self._first_fit(model, starts, known, options, looped)
        else:
            if SURFACE_MAX_EVALUATIONS is not None:
                options = dict(max_nfev=SURFACE_MAX_EVALUATIONS)
            best, first = self._first_fit(model, starts, known, options, looped)
        noise = float(np.sqrt(np.mean(self.sigma(d.force_mN) ** 2)))  # with the model error
        if best is not None and (best.status == 0 or looped and best.status in (2, 3)):
            # stopped by its budget: on from where it got (measured: two layers on a rigid base
            # stopped at 0.065 mN on its way to the truth's 0.041 mN, noise 0.03); in the loop also
            # stopped by its step or cost tolerance, within the noise too: the trust region may have
            # shrunk on the way (measured: two layers on a rigid base stopped in a narrow valley at
            # chi2 80.5, RMS 0.038 mN against 0.048 allowed, the base's compliance 0.0101; restarted
            # 78.5; then held rigid from there 58.9, resume.at_rigid_base); a fresh one from the end
            # goes on while it gains
            best = self._resumed(model, best, known, options, early=looped)
        if looped and best is not None and (best.rms_mN > FE_RETRY * noise or stalled(best, model)):
            # the best-ranked start led to a fit that does not reach the noise, or did not move: a
            # short fit from each of the other screened starts, and the best of those, if better (or
            # the first that moved, for one that did not), to the end
            probes = []
            for x0 in starts[first + 1:]:
                try:
                    probes.append(fit_least_squares(model, d.depth_mm, d.force_mN, x0, noise_mN=self.noise_mN, **known,
                                                    **{**options, "max_nfev": FE_PROBE}))
                except ValueError:
                    continue
            lead = min((p for p in probes if not stalled(p, model)), key=_cost, default=None)
            if lead is not None and (_cost(lead) < _cost(best) or stalled(best, model)):
                if lead.status == 0:  # stopped by its budget: on from where it got
                    lead = self._resumed(model, lead, known, options)
                best = lead if _cost(lead) < _cost(best) else best
        if looped and best is not None:
            best = self._at_rigid_base(model, best, known, options)
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
        if looped:  # on a rerun they come from the run cache: say so
            cached = sum(getattr(c, "cached", 0) for c in model.cores) - cached0
            log.info("fitted %s: %d finite-element runs%s", model.name, runs,
                     f" ({cached} read from the run cache)" if cached else "")
        rung = assemble(self, model, key, best, known, options, runs)
        self.fits[key] = rung
        return rung

    def _at_rigid_base(self, model, best, known: dict, options: dict):
        """:func:`~.resume.at_rigid_base` on this fitter's points."""
        return at_rigid_base(model, self.data.depth_mm, self.data.force_mN, best, noise_mN=self.noise_mN,
                             known=known, options=options)

    def _known_start(self, model, key: tuple, starts: list):
        """The start of ``key`` from :attr:`known_starts` (the nested start with the known values in
        place: each curve's own parameters from it), or None."""
        values = self.known_starts.get(tuple(sorted(key)))
        if not values or not starts:
            return None
        held = self.held(model)
        x = np.array(starts[0], dtype=float)
        hit = False
        for i, n in enumerate(model.parameter_names):
            if n in values and n not in held:
                x[i], hit = values[n], True
        lo, hi = model.bounds
        return np.clip(x, lo, hi) if hit else None

    def _first_fit(self, model, starts: list, known: dict, options: dict, looped: bool, still=None) -> tuple:
        """:func:`~.resume.first_fit` on this fitter's points."""
        return first_fit(model, self.data.depth_mm, self.data.force_mN, starts, noise_mN=self.noise_mN, known=known,
                         options=options, looped=looped, still=still, tol=FE_TOL)

    def _resumed(self, model, result, known: dict, options: dict, early: bool = False):
        """:func:`~.resume.resumed` on this fitter's points (the fit's own ``known`` and ``options``)."""
        return resumed(model, self.data.depth_mm, self.data.force_mN, result, noise_mN=self.noise_mN, known=known,
                       options=options, early=early)


def in_loop(model) -> bool:
    """The model is fitted with the finite-element model in the loop (some curve's core is a
    :class:`~skin_indent.models.fe_core.FECore`): ``model.in_loop``."""
    return model.in_loop


def forward_runs(model) -> int:
    """Finite-element runs made so far by the model's cores (0 for surfaces)."""
    return sum(getattr(c, "runs", 0) for c in model.cores)
