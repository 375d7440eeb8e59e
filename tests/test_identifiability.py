"""What the data determine, and which measurement would determine the rest: the one engine.

:mod:`skin_indent.diagnosis.identifiability` predicts, from a fitted model, the standard
deviation every parameter would have when a candidate measurement is fitted together with the
recorded curve (cov = (sum_k J_k^T W_k J_k)^-1, finite-element Jacobians), and the diagnosis'
sentences and ``plan`` read that one computation. Checked here against known answers (the fit's
own covariance for the recorded curve; the exact similarity F(h; E, R) = E R^2 phi(h / R) of the
neo-Hookean half-space for a sphere twice as large pressed twice as deep), against physics (a
deeper indentation determines a layer's thickness that a shallow one does not), in the
diagnosis' sentence (a measurement named, failures quiet), and against ``plan`` (the same next
measurement, the same standard deviations). Coarse meshes; a few finite-element runs each.
"""

import dataclasses
import math
import types

import numpy as np
import pytest

from skin_indent.diagnosis import identifiability as idf
from skin_indent.diagnosis.outlook import DETERMINED, Assessment, Outlook
from skin_indent.diagnosis.information import Block, free_columns, joint_std
from skin_indent.diagnosis.measurements import recorded_history
from skin_indent.diagnosis.prediction import predicted_force
from skin_indent.effects import EffectParameter, Model
from skin_indent.measurement import measurement_from_arrays, prepare
from skin_indent.models import ComposedModel
from skin_indent.models.composed import at_physical_limit
from skin_indent.models.fe_core import FECore
from skin_indent.mechanics.protocol import Protocol
from skin_indent.runtime.context import Context

R = 6.22
#: one worker runs these tests (the module-scoped diagnosis is made once)
pytestmark = pytest.mark.xdist_group("identifiability")


def _shifted(theta, depth_mm, sigma, seed, *, shift_mm=0.02, rate=0.02):
    """A noisy loading curve of our own forward model (coarse), with its contact point at +shift."""
    curve = Model(()).simulate(theta, protocol=Protocol.ramp(depth_mm, 100, rate), mesh="coarse")
    force = curve.force_mN + np.random.default_rng(seed).normal(0.0, sigma, curve.force_mN.size)
    return measurement_from_arrays(np.r_[0.0, curve.depth_mm + shift_mm], np.r_[0.0, force],
                                   np.r_[0.0, curve.time_s + shift_mm / rate], source="own half-space")


def _rung(model, x, result=None, effects=()):
    """What the engine reads of a fitted rung (as :meth:`Fitter.fit` makes it)."""
    names = model.parameter_names
    x = np.asarray(x, dtype=float)
    return types.SimpleNamespace(bound_model=model, x=x, model="+".join(("neo-hooke", *effects)), effects=effects,
                                 fit_parameters=dict(zip(names, map(float, x))),
                                 free_names=tuple(result.free_names) if result else names,
                                 covariance=result.covariance if result else np.eye(len(names)),
                                 at_bounds=tuple(result.info.get("active_bounds", ())) if result else ())


@pytest.mark.fe_loop  # finite elements in the loop: .ci/run runs it, not the default run
def test_recorded_measurement_is_the_fits_covariance_and_similarity_holds():
    """(i) Known answers. A half-space with a contact offset, fitted with the finite-element model
    in the loop: the engine's standard deviations for the recorded curve (noise alone) equal the
    fit's own (noise^2 (J^T J)^-1 through the reported parameters). A sphere twice as large pressed
    twice as deep multiplies dF/dE and dF/dnu by 4 and dF/d(offset) by 2 (F = E R^2 phi(h / R)
    exactly), so the standard deviations are 1/4, 1/4 and 1/2 of the recorded ones."""
    from skin_indent.inverse import fit_least_squares

    sigma = 0.03
    data = prepare(_shifted({"E_kPa": 10.0, "nu": 0.42}, 0.6, sigma, seed=1), segments=("approach",))
    core = FECore((), radius_mm=R, max_depth_mm=data.max_indentation_mm, e_star_kPa=12.0, mesh="coarse", workers=1)
    model = ComposedModel(core, ("offset",), data)
    res = fit_least_squares(model, data.depth_mm, data.force_mN, [10.0, 0.42, 0.02], noise_mN=sigma,
                            ftol=1e-6, xtol=1e-6, max_nfev=8)
    x = np.array([res.parameters[n] for n in model.parameter_names])
    _, fit_std = model.reported(x, res.covariance)
    rung = _rung(model, x, res, ("offset",))
    effects, theta = idf.model_of(rung, jacobian=True)
    history = recorded_history(data, idf.indentation(rung, data, 0))
    _, J, names = predicted_force(effects, theta, history, "coarse", True)
    same = joint_std(rung, [Block(J, names, np.full(J.shape[0], sigma), own=False)], free_columns(rung))
    for k, sd in fit_std.items():
        assert same[k] == pytest.approx(sd, rel=0.02), k
    twice = dataclasses.replace(history, depth_mm=2 * history.depth_mm, radius_mm=2 * R)
    _, J2, _ = predicted_force(effects, theta, twice, "coarse", True)
    scaled = joint_std(rung, [Block(J2, names, np.full(J.shape[0], sigma), own=False)], free_columns(rung))
    for k, factor in {"E_kPa": 0.25, "nu": 0.25, "offset_mm": 0.5}.items():
        assert scaled[k] == pytest.approx(factor * same[k], rel=0.02), k
    core.close()


@pytest.mark.fe_loop  # finite elements in the loop: .ci/run runs it, not the default run
def test_a_deeper_indentation_determines_a_layer_thickness():
    """(ii) A 2 mm layer over a half-space four times softer, indented 0.3 mm with the skin sphere:
    the curve does not determine the thickness (sd over half of it); fitted with an indentation 1.5
    times deeper, where the sphere feels the layer's base more, the predicted sd falls below half
    the thickness, and the sentence names it."""
    sigma, t = 0.03, 2.0
    core = FECore(("layer",), radius_mm=R, max_depth_mm=0.3, e_star_kPa=12.0, mesh="coarse", workers=1)
    x = np.array([10.0, 0.45, t, 4.0])  # E_kPa, nu, thickness_mm, compliance (= 1 / ratio)
    depth = np.linspace(0.0, 0.3, 101)
    force = np.r_[0.0, core.force(depth[1:], x)]
    data = prepare(measurement_from_arrays(depth, force, source="layer"), segments=("approach",), contact="origin")
    rung = _rung(ComposedModel(core, ("layer",), data), x, effects=("layer",))
    outlook = idf.weigh([rung], rung, [data], [sigma], with_std=True, radii=(), context=Context(workers=1))
    idf.rank(outlook, {"thickness_mm": t})
    deeper = next(a for a in outlook.ranking if a.candidate.kind == "deeper")
    same = next(a for a in outlook.ranking if a.candidate.reference)
    assert deeper.error is None, deeper.error
    assert outlook.recorded_std["thickness_mm"] > DETERMINED * t  # measured 1.25 mm
    assert deeper.std["thickness_mm"] < DETERMINED * t and deeper.std["thickness_mm"] < same.std["thickness_mm"]
    assert same.std["thickness_mm"] == pytest.approx(outlook.recorded_std["thickness_mm"] / math.sqrt(2), rel=1e-6)
    assert outlook.next is deeper and deeper.determines == ["thickness_mm"], [(a.candidate.label, a.std)
                                                                               for a in outlook.ranking]
    clause = idf.suggestion("thickness_mm", t, outlook)
    assert clause == (f"; fitted with this curve, an indentation to 0.45 mm (1.5 times deeper) with the same sphere "
                      f"would determine it to +- {deeper.std['thickness_mm']:.2g}")
    core.close()


@pytest.fixture(scope="module")
def shallow():
    """A diagnosis whose last rung leaves a parameter undetermined: a shallow (0.15 mm) curve with an offset
    contact point, where E and nu trade against each other (Hertz's E / (1 - nu^2)): nu is not
    determined (E, at 35 %, is on the shipped dimensionless surfaces)."""
    from skin_indent.diagnosis import diagnose

    sigma = 0.03
    m = _shifted({"E_kPa": 10.0, "nu": 0.45}, 0.15, sigma, seed=2, rate=0.01)
    return diagnose(m, candidates=("offset",), noise_mN=sigma, mesh="coarse")


def test_sentence_names_the_measurement_and_reading_makes_no_run(shallow, monkeypatch):
    """(iii) The sentence says, per undetermined parameter, which measurement fitted with the curve
    would determine it (or that none would); the finite-element runs behind it are made by diagnose,
    once: reading the result (sentence, report, JSON) makes none."""
    from skin_indent.diagnosis import prediction, workflow

    d = shallow
    monkeypatch.setattr(workflow, "weigh", lambda *a, **k: pytest.fail("a finite-element run on reading"))
    monkeypatch.setattr(prediction, "predicted_force", lambda *a, **k: pytest.fail("a run on reading"))
    assert d.missing == ("offset",), d.report()
    reasons = d.undetermined()
    assert "nu" in reasons, d.report()
    for reason in reasons.values():
        if "not determined by this curve" in reason:
            assert ("; fitted with this curve, " in reason and "would determine it to +-" in reason
                    or "none of the measurements weighed" in reason), reason
    sentence = d.sentence()
    assert reasons["nu"] in sentence
    d.report(), d.to_dict()
    # the standard deviation in the reason is the one the last rung reports everywhere: the recorded curve's
    assert f"+- {d.current.std['nu']:.2g}: not determined" in reasons["nu"]
    assert d.current.std["nu"] == d.outlook.recorded_std["nu"] and d.std_source["nu"] == idf.FROM_FE


def test_diagnose_and_plan_name_the_same_next_measurement_and_sd(shallow, monkeypatch):
    """The issue's check, cheaply (a half-space with an offset, its Jacobians one coarse run each):
    ``plan`` of a diagnosis names the diagnosis' next measurement with the diagnosis' standard
    deviations, without a run; and the same candidates weighed again from scratch (the settings
    given explicitly) give the same ranking and the same numbers, which the diagnosis' sentences
    quote."""
    from skin_indent.diagnosis import plan, prediction

    d = shallow
    assert d.outlook is not None and d.outlook.with_std, d.report()
    real = prediction.predicted_force
    monkeypatch.setattr(prediction, "predicted_force", lambda *a, **k: pytest.fail("plan re-ran the diagnosis'"))
    p = plan(d)
    assert p.ranking and p.ranking[0] is d.outlook.next and set(p.undetermined) == set(d.not_determined)
    monkeypatch.setattr(prediction, "predicted_force", real)
    fresh = plan(d, radii=(R / 2, 2 * R), context=Context(workers=1))  # given: weighed again
    assert [a.candidate.label for a in fresh.ranking] == [a.candidate.label for a in p.ranking], fresh.report()
    for a, b in zip(fresh.ranking, p.ranking):
        assert a.std == pytest.approx(b.std, rel=1e-9) and a.determines == b.determines
    assert fresh.recorded_std == pytest.approx(p.recorded_std, rel=1e-9)
    top = fresh.ranking[0]
    for k, v in fresh.undetermined.items():
        assert d.current.std[k] == pytest.approx(fresh.recorded_std[k], rel=1e-9), k
        if k in top.determines:  # the diagnosis names the plan's next measurement, with the plan's sd
            assert f"{top.candidate.label} would determine it to +- {top.std[k]:.2g}" in d.not_determined[k]
    assert top.determines, fresh.report()
    assert p.sentence() == fresh.sentence() and top.candidate.label in d.sentence()
    # the JSON of both: the same measurement, the same numbers
    said, planned = d.to_dict()["next_measurement"], fresh.to_dict()["ranking"][0]
    assert said["label"] == planned["label"] and said["std"] == pytest.approx(planned["std"], rel=1e-9)
    assert said["determines"] == planned["determines"]


def test_failing_candidates_are_not_suggested(shallow, monkeypatch):
    """(iii) A finite-element run that fails (any error) removes that measurement from the
    suggestions; when every one fails the reason says only what the curve does not determine."""
    from skin_indent.diagnosis import prediction

    real = prediction.predicted_force
    rung, d = shallow.current, shallow

    def spheres_fail(effects, theta, history, *args, **kwargs):
        if not math.isclose(history.radius_mm, R):
            raise RuntimeError("the Newton iterations did not converge")
        return real(effects, theta, history, *args, **kwargs)

    monkeypatch.setattr(prediction, "predicted_force", spheres_fail)
    outlook = idf.weigh([rung], rung, d.curves, d.noises_mN, with_std=True, context=Context(workers=1))
    reason = idf.determine(rung, {}, outlook)[2]["nu"]
    assert "radius" not in reason and "times deeper) with the same sphere would determine it to +-" in reason, reason
    assert sum(a.error is not None for a in outlook.ranking) == 2  # half and twice the radius

    def everything_fails(*args, **kwargs):
        raise ValueError("finite-element run failed at nu = 0.49: no convergence")

    monkeypatch.setattr(prediction, "predicted_force", everything_fails)
    outlook = idf.weigh([rung], rung, d.curves, d.noises_mN, with_std=True, context=Context(workers=1))
    std, source, reasons, _ = idf.determine(rung, {}, outlook)
    assert reasons["nu"].endswith("not determined by this curve") and outlook.notes
    assert std == rung.std and set(source.values()) == {idf.FROM_FIT}  # nothing computed: the fit's sd


def test_surfaces_only_makes_no_finite_element_runs(monkeypatch):
    """A diagnosis kept to surfaces (``in_loop=False``, ``--surfaces-only``) with nothing competing says
    what is not determined without the finite-element runs of the predictions."""
    from skin_indent.diagnosis import diagnose, workflow

    monkeypatch.setattr(workflow, "weigh", lambda *a, **k: pytest.fail("finite-element runs made"))
    m = _shifted({"E_kPa": 10.0, "nu": 0.45}, 0.15, 0.03, seed=2, rate=0.01)
    d = diagnose(m, candidates=("offset",), noise_mN=0.03, mesh="coarse", in_loop=False)
    assert d.not_determined["nu"].endswith("not determined by this curve") and d.outlook is None


def test_suggestion_names_the_next_measurement_or_the_smallest_determining_sd():
    from skin_indent.diagnosis.measurements import Candidate

    def a(kind, label, sd, sep=None, reference=False):
        return Assessment(Candidate(kind, label, None, 1.0, reference), std={} if sd is None else {"t": sd},
                              error=None if sd is not None else "failed")

    def outlook(*assessments):
        return Outlook(["m"], "m", {"t": 5.0}, 0.05, list(assessments))

    # the next measurement (ranked first) determines it: named, though another would do better
    assert idf.suggestion("t", 4.0, outlook(a("sphere", "<half>", 1.5), a("deeper", "<deeper>", 0.6))) \
        == "; fitted with this curve, <half> would determine it to +- 1.5"
    # it does not: the candidate with the smallest sd that does
    assert idf.suggestion("t", 4.0, outlook(a("sphere", "<half>", 3.0), a("deeper", "<deeper>", 0.6))) \
        == "; fitted with this curve, <deeper> would determine it to +- 0.6"
    assert idf.suggestion("t", 4.0, outlook(a("sphere", "<s>", 3.0, reference=True), a("sphere", "<half>", 2.5),
                                            a("deeper", "<deeper>", math.inf), a("hold", "<hold>", None))) \
        == "; fitted with this curve, none of the measurements weighed (another sphere or a deeper indentation) " \
           "would determine it"
    assert idf.suggestion("t", 4.0, outlook(a("deeper", "<deeper>", None))) == ""
    assert idf.suggestion("t", 4.0, None) == ""


def test_physical_limits_are_declared_not_named():
    """A rigid base (compliance 0: ratio at its upper end, inf) and nu at the top of its range are
    physical limits a fit may reach; the other faces are the edge of what the fit reaches."""
    core = FECore(("layer", "layer"), radius_mm=R, max_depth_mm=0.6, e_star_kPa=10.0, mesh="coarse")
    depth = np.linspace(0.0, 0.6, 21)
    data = prepare(measurement_from_arrays(depth, 10 * depth**1.5, source="bounds"), segments=("approach",),
                   contact="origin")
    model = ComposedModel(core, ("layer", "layer"), data)
    lo, hi = model.bounds
    mid = 0.5 * (lo + hi)

    def at(name, face):
        x = mid.copy()
        i = model.parameter_names.index(name)
        x[i] = lo[i] if face == "lower" else hi[i]
        return at_physical_limit(model, x, name)

    assert at("compliance2", "lower") and at("compliance", "lower") and at("nu", "upper")
    assert not any([at("compliance2", "upper"), at("nu", "lower"), at("thickness_mm", "lower"),
                    at("thickness2_mm", "upper"), at("E_kPa", "lower")])
    assert not at_physical_limit(model, mid, "no such parameter")
    with pytest.raises(ValueError, match="physical_limit"):
        EffectParameter("x", "-", 0.0, 1.0, None, False, "x", physical_limit="top")


def test_the_engine_weighs_by_the_one_error_model(monkeypatch):
    """Issue 38: the separation and the information blocks weigh each point by the error model of every
    fit (``fitting.error_model.point_sigma``), the numbers those of sqrt(noise^2 + (0.003 F)^2)."""
    from skin_indent.diagnosis import separation as sep
    from skin_indent.fitting.error_model import MODEL_ERROR, point_sigma

    fa, fb, noise = np.array([0.0, 1.0, 5.0, 12.0]), np.array([0.01, 1.05, 5.2, 12.5]), 0.04
    sigma = np.sqrt(noise**2 + (0.003 * 0.5 * (fa + fb)) ** 2)
    assert MODEL_ERROR == 0.003
    np.testing.assert_array_equal(sep.error_model(0.5 * (fa + fb), noise), point_sigma(noise, 0.5 * (fa + fb)))
    s = sep.separation("a", "b", fa, fb, noise)
    assert s.separation == pytest.approx(float(np.sqrt(np.sum(((fb - fa) / sigma) ** 2))), rel=1e-12)
    calls = []

    def spy(noise_mN, force_mN, model_error=MODEL_ERROR):
        calls.append(noise_mN)
        return point_sigma(noise_mN, force_mN, model_error)

    monkeypatch.setattr(sep, "point_sigma", spy)
    assert sep.separation("a", "b", fa, fb, noise).separation == s.separation
    assert sep.error_model(fa, 0.02).shape == fa.shape and calls == [noise, 0.02]
