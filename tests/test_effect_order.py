"""The same effects in another order are one model, fitted once (issue 39).

``layer+stiffening`` and ``stiffening+layer`` build one body (stiffening is one C20 / E of every
material); a diagnosis climbing two explanations asked for both and fitted each with the
finite-element model in the loop (144 and 142 runs on the forearm-like curve). Checked here:

- physics: every order of every set of up to three effects of the vocabulary that
  :func:`~skin_indent.effects.order.canonical` calls one model builds the same finite-element
  specification (the sample, the contact law, the offset) and, as a fitted model, the same force at
  the same parameters (on an analytic elastic core, with a hold and a retract so that relaxation,
  adhesion, drag and the baselines all act); finite-element runs of ``layer+stiffening`` and
  ``stiffening+layer`` at the same parameters give the same force (``fe_loop``);
- the fitter: the second order makes no run, and gives the first order's numbers under its own name
  and parameter order (:func:`~skin_indent.fitting.reorder.relabelled`), alone or within one
  ``fit_all``;
- the diagnosis: a branch that reaches a climbed rung in another order joins it (:func:`~skin_indent.diagnosis.branches.joins`).
"""

from __future__ import annotations

import contextlib
import itertools
import math

import numpy as np
import pytest
from analytic_model import HertzLikeModel
from test_branch_joins import _Fitter as _GivenFitter
from test_fit_ended import _Rung

from skin_indent.diagnosis import branches
from skin_indent.diagnosis.criteria import Scores
from skin_indent.effects import EFFECTS, ELASTIC, WEIGHED, Effect, EffectParameter, Model, effect, instances, register, \
    unregister
from skin_indent.effects.order import canonical, same_model
from skin_indent.effects.repeat import check_kinds
from skin_indent.fitting import multistart
from skin_indent.fitting.multistart import Fitter
from skin_indent.measurement import measurement_from_arrays, prepare
from skin_indent.models import ComposedModel
from skin_indent.response_surface import SurfaceCore

R = 6.22


def _sets(names, most=3):
    """Every set of up to ``most`` of ``names`` (a repeatable effect up to twice) that is a model."""
    pool = [n for n in names for _ in range(2 if effect(n).repeatable else 1)]
    seen = set()
    for k in range(2, most + 1):
        for combo in itertools.combinations(pool, k):
            key = tuple(sorted(combo))
            if key in seen:
                continue
            seen.add(key)
            try:
                check_kinds(instances(key))
            except ValueError:
                continue
            yield key


def _value(p) -> float:
    """A value of the parameter ``p`` inside its range, away from its off value."""
    lo, hi = p.lower, p.upper
    if math.isfinite(lo) and math.isfinite(hi):
        return lo + 0.37 * (hi - lo)
    return (lo + 1.3) if math.isfinite(lo) else 0.1


def test_the_canonical_key():
    assert canonical(("stiffening", "layer")) == canonical(("layer", "stiffening")) == ("layer", "stiffening")
    assert canonical(("layer", "stiffening", "layer")) == ("layer", "layer", "stiffening")
    assert canonical(("drag", "viscoelastic", "offset", "layer")) == ("offset", "layer", "viscoelastic", "drag")
    assert same_model(("baselines", "adhesion"), ("adhesion", "baselines"))
    assert not same_model(("layer",), ("layer", "layer"))
    assert not same_model(("layer", "nothing"), ("nothing", "layer"))  # no model: not the same as any


# the finite-element form: every effect that has one (friction too), every order
_FE = [n for n, e in EFFECTS.items() if type(e).configure is not Effect.configure]


@pytest.mark.parametrize("key", list(_sets(_FE)), ids="+".join)
def test_every_order_builds_one_finite_element_model(key):
    theta = {p.name: _value(p) for p in Model(key).parameters}
    theta["nu"] = 0.45
    orders = sorted(set(itertools.permutations(key)))
    specs = [Model(o).spec(theta) for o in orders]
    assert len({canonical(o) for o in orders}) == 1
    assert all(s == specs[0] for s in specs[1:])  # sample, contact law, offset: the same
    assert all(Model(o).sample(theta) == Model(key).sample(theta) for o in orders)


def _history_curve():
    """A curve recorded from before contact with a hold and a faster retract (times, segments, a
    pre-contact baseline): every fitted effect acts on it."""
    c0, top, va, vr, dt = 0.3, 0.9, 0.1, 0.3, 0.05
    ta = np.arange(0.0, top / va, dt)
    th = ta[-1] + np.arange(dt, 2.0, dt)
    tr = th[-1] + np.arange(dt, top / vr, dt)
    t = np.r_[ta, th, tr]
    d = np.r_[va * ta, np.full(th.size, top), top - vr * (tr - th[-1])]
    core = HertzLikeModel(R, upper=(1e3, 0.49))
    F = core.force(np.maximum(d - c0, 0.0), [10.0, 0.45]) * np.r_[np.ones(ta.size), 0.9 + 0.1 * np.exp(
        -(th - th[0])), np.full(tr.size, 0.9)]
    F = F - 0.05 * (d > c0) + np.random.default_rng(5).normal(0.0, 0.01, d.size)
    return prepare(measurement_from_arrays(d, F, t, source="history.csv", radius_mm=R),
                   segments=("approach", "hold", "retract"), contact="fit")


class _Core(HertzLikeModel, SurfaceCore):
    """The analytic stand-in as a surface core over depths to 10 mm."""

    def __init__(self):
        super().__init__(R, upper=(1e3, 0.49))
        self.depth_range = (0.0, 10.0)


_FITTED = [n for n, e in EFFECTS.items() if e.stage not in (ELASTIC, WEIGHED)]


def test_the_history_curve_has_what_the_effects_act_on():
    data = _history_curve()
    assert data.contact_mode == "fit" and data.time_s is not None
    assert all(data.has(k) for k in ("approach", "hold", "retract"))


@pytest.mark.parametrize("key", list(_sets(_FITTED)), ids="+".join)
def test_every_order_is_one_fitted_force_model(key):
    data = _history_curve()
    models = {o: ComposedModel(_Core(), o, data) for o in sorted(set(itertools.permutations(key)))}
    names = set(next(iter(models.values())).parameter_names)
    assert all(set(m.parameter_names) == names for m in models.values())
    first = next(iter(models.values()))
    lo, hi = first.bounds
    values = {n: (lo[i] + 0.37 * (hi[i] - lo[i]) if n != "offset_mm" else data.contact_guess_mm)
              for i, n in enumerate(first.parameter_names)}
    values.update(E_kPa=10.0, nu=0.45)
    forces = [m.force(data.depth_mm, np.array([values[n] for n in m.parameter_names])) for m in models.values()]
    top = float(np.max(np.abs(forces[0])))
    assert top > 0
    # the same force (to 1e-9 of its peak: the order of a sum of terms), whatever acts
    assert all(np.max(np.abs(f - forces[0])) <= 1e-9 * top for f in forces[1:])
    assert len({canonical(o) for o in models}) == 1


class _Scaled(Effect):
    """A toy history effect that scales the force (not registered in the package)."""

    name, stage, parameters = "toy_scaled", "history", (EffectParameter("toy_k", "-", 0.0, 1.0, 0.0, False, "k"),)

    def apply(self, ev, fit):
        ev.force_mN = ev.force_mN * (1.0 + fit["toy_k"] * ev.h_mm)


class _Shifted(Effect):
    """A toy history effect that adds to the force where the sphere is in contact."""

    name, stage, parameters = "toy_shifted", "history", (EffectParameter("toy_b", "mN", 0.0, 1.0, 0.0, False, "b"),)

    def apply(self, ev, fit):
        ev.force_mN = ev.force_mN + fit["toy_b"] * (ev.h_mm > 0)


def test_effects_of_one_stage_that_do_not_commute_keep_their_order():
    """The control: two effects of the history stage, one scaling the force and one adding to it, give two
    forces in two orders, and :func:`canonical` keeps them apart (it sorts only the stages that commute)."""
    data = _history_curve()
    register(_Scaled())
    register(_Shifted())
    try:
        a, b = (ComposedModel(_Core(), k, data) for k in (("toy_scaled", "toy_shifted"), ("toy_shifted", "toy_scaled")))
        x = {"E_kPa": 10.0, "nu": 0.45, "toy_k": 0.5, "toy_b": 0.5}
        fa = a.force(data.depth_mm, np.array([x[n] for n in a.parameter_names]))
        fb = b.force(data.depth_mm, np.array([x[n] for n in b.parameter_names]))
        assert np.max(np.abs(fa - fb)) > 0.1  # b k h where in contact: up to 0.15 mN
        assert not same_model(("toy_scaled", "toy_shifted"), ("toy_shifted", "toy_scaled"))
        assert same_model(("toy_scaled", "layer", "toy_shifted"), ("layer", "toy_scaled", "toy_shifted"))
    finally:
        unregister("toy_scaled")
        unregister("toy_shifted")


@pytest.mark.fe_loop
def test_finite_element_runs_of_layer_and_stiffening_in_both_orders_give_one_force():
    from skin_indent.models.fe_core import FECore

    a = FECore(("layer", "stiffening"), radius_mm=R, max_depth_mm=0.3, e_star_kPa=10.0, workers=1)
    b = FECore(("stiffening", "layer"), radius_mm=R, max_depth_mm=0.3, e_star_kPa=10.0, workers=1)
    values = {"E_kPa": 10.0, "nu": 0.45, "thickness_mm": 1.2, "compliance": 0.5, "C20_over_E": 1.6}
    assert a.parameter_names == ("E_kPa", "nu", "thickness_mm", "compliance", "C20_over_E")
    assert b.parameter_names == ("E_kPa", "nu", "C20_over_E", "thickness_mm", "compliance")
    h = np.linspace(0.03, 0.3, 10)
    fa = a.force(h, np.array([values[n] for n in a.parameter_names]))
    fb = b.force(h, np.array([values[n] for n in b.parameter_names]))
    assert a.body(np.array([values[n] for n in a.parameter_names])[1:]) == b.body(
        np.array([values[n] for n in b.parameter_names])[1:])
    # within the Newton tolerance of a run (1e-8): far below the model error (1e-3) that BIC weighs
    assert np.max(np.abs(fa - fb)) <= 1e-6 * np.max(fa)
    a.close()
    b.close()


# ------------------------------------------------------------------------------------- the fitter
class _BodyCore(SurfaceCore):
    """An elastic core in the loop over E, nu and the elastic effects' coordinates in the order given
    (as the finite-element core stacks them), its force a function of the body alone (each coordinate
    by its name), every evaluation counted as a run."""

    name = "analytic body in the loop"
    in_loop = True
    evaluations = 0

    def __init__(self, effects, radius_mm):
        self.hertz = HertzLikeModel(radius_mm, upper=(1e3, 0.49))
        self.depth_range = (0.0, 1.0)
        self.elastic = [e for e in instances(effects) if e.stage == ELASTIC]
        names, lo, hi = ["E_kPa", "nu"], [1.0, 0.2], [1e3, 0.49]
        for e in self.elastic:
            for n, (a, b) in e.fe_bounds(0.6).items():
                names.append(n)
                lo.append(a)
                hi.append(b)
        self.parameter_names = tuple(names)
        self.bounds = (np.array(lo), np.array(hi))
        self.runs = 0

    def force(self, depth_mm, theta):
        theta = np.asarray(theta, dtype=float)
        _BodyCore.evaluations += 1
        self.runs += 1
        h = np.asarray(depth_mm, dtype=float)
        shape = 1.0
        for n, v in zip(self.parameter_names[2:], theta[2:]):
            shape = shape + {"thickness_mm": 0.02 * h / max(v, 1e-3), "compliance": -0.01 * v * h,
                             "C20_over_E": 0.05 * v * h}.get(n, 0.0)
        return self.hertz.force(h, theta[:2]) * shape

    def jacobian(self, depth_mm, theta, columns=None):
        theta = np.asarray(theta, dtype=float)
        J = np.zeros((np.asarray(depth_mm).size, theta.size))
        f0 = self.force(depth_mm, theta)
        for i in range(theta.size) if columns is None else np.arange(theta.size)[columns]:
            t = theta.copy()
            step = 1e-6 * max(abs(theta[i]), 1e-3)
            t[i] = theta[i] + step if theta[i] + step <= self.bounds[1][i] else theta[i] - step
            J[:, i] = (self.force(depth_mm, t) - f0) / (t[i] - theta[i])
        return J  # the columns not asked for are 0, as the finite-element core gives them

    def prefetch(self, thetas):
        pass

    @contextlib.contextmanager
    def screening(self):
        yield self

    def in_workers(self):
        return contextlib.nullcontext()

    def start_workers(self):
        pass

    def cancel(self):
        pass


def _skin_curve():
    d = np.linspace(0.006, 0.6, 80)
    truth = _BodyCore(("layer", "stiffening"), R)
    F = truth.force(d, [10.0, 0.45, 1.5, 0.4, 2.0]) + np.random.default_rng(3).normal(0.0, 0.01, d.size)
    return prepare(measurement_from_arrays(d, F, source="analytic.csv", radius_mm=R), segments=("approach",),
                   contact="origin")


@pytest.fixture
def fitter(monkeypatch):
    cores = []

    def core(effects, *, radius_mm, **_):
        cores.append(_BodyCore(effects, radius_mm))
        return cores[-1]

    monkeypatch.setattr(multistart, "elastic_core", core)
    monkeypatch.setattr(multistart, "screen", lambda fitter, model, starts, keep, nested=None: starts[:keep])
    f = Fitter(_skin_curve(), 0.01, noise_known=True, context=None, mesh="coarse")
    f.made_cores = cores
    return f


def test_the_second_order_is_the_first_fit_under_its_own_name(fitter):
    first = fitter.fit(("layer", "stiffening"))
    assert first.forward_runs > 0
    n, cores = _BodyCore.evaluations, len(fitter.made_cores)
    second = fitter.fit(("stiffening", "layer"))
    assert _BodyCore.evaluations == n and len(fitter.made_cores) == cores  # no run, no other core
    # the runs of the fit that gave its numbers (none made here), and which fit that was
    assert second.forward_runs == first.forward_runs and second.info["same_fit_as"] == "neo-hooke+layer+stiffening"
    assert second.model == "neo-hooke+stiffening+layer" and second.effects == ("stiffening", "layer")
    assert second.bound_model.name == second.model
    assert list(second.parameters) == ["E_kPa", "nu", "C20_kPa", "thickness_mm", "ratio"]  # in its own order
    assert second.parameters == first.parameters and second.std == first.std
    assert second.chi2_weighted == first.chi2_weighted and second.bic == first.bic
    assert np.array_equal(second.prediction_mN, first.prediction_mN)
    # its bound model and vector are one: the same force as the fit's prediction
    d = fitter.data
    assert np.allclose(second.bound_model.force(d.depth_mm, second.x), second.prediction_mN, rtol=0, atol=1e-12)
    assert dict(zip(second.bound_model.parameter_names, second.x)) == dict(zip(first.bound_model.parameter_names,
                                                                               first.x))
    names, V = second.reported_cov
    names1, V1 = first.reported_cov
    assert set(names) == set(names1)
    for p, q in itertools.product(range(len(names)), repeat=2):
        assert V[p, q] == V1[names1.index(names[p]), names1.index(names[q])]
    assert fitter.fit(("stiffening", "layer")) is second  # kept


def _evaluations(fitter, keys) -> int:
    """The stand-in's evaluations while ``fitter`` fits ``keys`` at once (fit_all)."""
    fitter.fit(())
    n = _BodyCore.evaluations
    fitter.fit_all(keys)
    return _BodyCore.evaluations - n


def test_one_fit_all_fits_one_order_of_a_model(fitter):
    both = _evaluations(fitter, [("stiffening", "layer"), ("layer", "stiffening")])
    out = fitter.fit_all([("stiffening", "layer"), ("layer", "stiffening")])
    assert out["layer", "stiffening"].info["same_fit_as"] == "neo-hooke+stiffening+layer"
    assert out["layer", "stiffening"].parameters == out["stiffening", "layer"].parameters
    assert out["layer", "stiffening"].forward_runs == out["stiffening", "layer"].forward_runs
    assert len([c for c in fitter.made_cores if c.elastic]) == 1  # one core for the model
    alone = Fitter(fitter.data, 0.01, noise_known=True, context=None, mesh="coarse")
    assert both == _evaluations(alone, [("stiffening", "layer")]) > 0  # the evaluations of one fit, in all


def test_a_branch_that_reaches_a_climbed_rung_in_another_order_joins_it():
    fits = {k: _Rung(k, chi2, 6) for k, chi2 in [(("layer",), 300.0), (("stiffening",), 320.0),
                                                 (("layer", "stiffening"), 100.0),
                                                 (("stiffening", "layer"), 100.0)]}
    fitter = _GivenFitter(fits)
    scores = Scores(100, 100)
    assert branches.joins(fitter, ("stiffening", "layer"), [("layer",), ("layer", "stiffening")],
                          scores) == ("layer", "stiffening")
    assert branches.joins(fitter, ("stiffening", "layer"), [("layer",)], scores) is None  # not climbed: no join


def test_two_curves_of_a_sample_give_the_second_order_the_first_fit(monkeypatch):
    """The joint model of two curves (two spheres): relabelled as one curve's is, its curves' models in the
    order asked."""
    monkeypatch.setattr(multistart, "elastic_core", lambda effects, *, radius_mm, **_: _BodyCore(effects, radius_mm))
    monkeypatch.setattr(multistart, "screen", lambda fitter, model, starts, keep, nested=None: starts[:keep])
    d = np.linspace(0.006, 0.6, 60)
    curves = []
    for r, seed in ((R, 3), (R / 2, 4)):
        F = _BodyCore(("layer", "stiffening"), r).force(d, [10.0, 0.45, 1.5, 0.4, 2.0])
        F = F + np.random.default_rng(seed).normal(0.0, 0.01, d.size)
        curves.append(prepare(measurement_from_arrays(d, F, source=f"R{r}.csv", radius_mm=r), segments=("approach",),
                              contact="origin"))
    fitter = Fitter(curves, [0.01, 0.01], noise_known=True, context=None, mesh="coarse")
    first = fitter.fit(("layer", "stiffening"))
    n = _BodyCore.evaluations
    second = fitter.fit(("stiffening", "layer"))
    assert _BodyCore.evaluations == n and second.info["same_fit_as"] == first.model
    assert [p.name for p in second.bound_model.parts] == ["neo-hooke+stiffening+layer"] * 2
    assert second.parameters == first.parameters and list(second.parameters)[2] == "C20_kPa"
    assert np.allclose(second.bound_model.force(second.bound_model.depth_mm, second.x), second.prediction_mN,
                       rtol=0, atol=1e-12)


def test_a_model_not_tried_is_listed_once_whatever_its_order():
    """Two explanations that each could not test the same model (``layer+stiffening`` on top of the layer
    rung, ``stiffening+layer`` on top of the stiffening rung) leave it untried once, in the first order met."""
    from types import SimpleNamespace

    from skin_indent.diagnosis import workflow
    from skin_indent.diagnosis.criteria import NOT_FITTED

    why = f"{NOT_FITTED}: it ended at its start values"
    steps = [SimpleNamespace(rung=SimpleNamespace(effects=("layer",)), not_detectable={"stiffening": why,
                                                                                        "layer": why}),
             SimpleNamespace(rung=SimpleNamespace(effects=("stiffening",)), not_detectable={"layer": why})]
    out = workflow._untried(SimpleNamespace(in_loop=True), steps, None, (), 3)
    assert list(out) == ["layer+stiffening", "layer+layer"]
    assert out["layer+stiffening"] == "it ended at its start values"
