"""What the data determine: the standard deviation a parameter would have under another measurement.

:mod:`skin_indent.diagnosis.identifiability` predicts, from a fitted model, the standard
deviation of every parameter under a larger or smaller sphere or a deeper indentation
(cov = (J^T W J)^-1 with the finite-element Jacobian of the alternative measurement).
Checked here against known answers (the fit's own covariance for the same measurement;
the exact similarity F(h; E, R) = E R^2 phi(h / R) of the neo-Hookean half-space for a
sphere twice as large pressed twice as deep), against physics (a deeper indentation
determines a layer's thickness that a shallow one does not), and in the diagnosis'
sentence (a measurement named, failures quiet). Coarse meshes; a few finite-element runs each.
"""

import math
import types

import numpy as np
import pytest

from skin_indent.diagnosis import identifiability as idf
from skin_indent.effects import EffectParameter, Model
from skin_indent.measurement import measurement_from_arrays, prepare
from skin_indent.models import ComposedModel
from skin_indent.models.composed import at_physical_limit
from skin_indent.models.fe_core import FECore
from skin_indent.mechanics.protocol import Protocol

R = 6.22
#: one worker runs these tests (the module-scoped diagnosis is made once)
pytestmark = pytest.mark.xdist_group("identifiability")


def _shifted(theta, depth_mm, sigma, seed, *, shift_mm=0.02, rate=0.02):
    """A noisy loading curve of our own forward model (coarse), with its contact point at +shift."""
    curve = Model(()).simulate(theta, protocol=Protocol.ramp(depth_mm, 100, rate), mesh="coarse")
    force = curve.force_mN + np.random.default_rng(seed).normal(0.0, sigma, curve.force_mN.size)
    return measurement_from_arrays(np.r_[0.0, curve.depth_mm + shift_mm], np.r_[0.0, force],
                                   np.r_[0.0, curve.time_s + shift_mm / rate], source="own half-space")


def _fitter(data, sigma):
    from skin_indent.fitting.multistart import Fitter

    return Fitter(data, sigma, noise_known=True, context=None, mesh="coarse")


def _rung(model, x, result=None, prediction=None):
    """What the predictions read of a fitted rung (as :meth:`Fitter.fit` makes it)."""
    names = model.parameter_names
    return types.SimpleNamespace(bound_model=model, x=np.asarray(x, dtype=float),
                                 free_names=tuple(result.free_names) if result else names,
                                 covariance=result.covariance if result else np.eye(len(names)),
                                 at_bounds=tuple(result.info.get("active_bounds", ())) if result else (),
                                 prediction_mN=model.force(model.depth_mm, x) if prediction is None else prediction)


@pytest.mark.fe_loop  # finite elements in the loop: .ci/run runs it, not the default run
def test_same_measurement_is_the_fits_covariance_and_similarity_holds():
    """(i) Known answers. A half-space with a contact offset, fitted with the finite-element model
    in the loop: the predicted standard deviations for the recorded measurement equal the fit's
    own (noise^2 (J^T J)^-1 through the reported parameters). A sphere twice as large pressed
    twice as deep multiplies dF/dE and dF/dnu by 4 and dF/d(offset) by 2 (F = E R^2 phi(h / R)
    exactly), so the standard deviations are 1/4, 1/4 and 1/2 of the recorded ones."""
    from skin_indent.inverse import fit_least_squares

    sigma = 0.03
    data = prepare(_shifted({"E_kPa": 10.0, "nu": 0.42}, 0.6, sigma, seed=1), segments=("approach",))
    fitter = _fitter(data, sigma)
    core = FECore((), radius_mm=R, max_depth_mm=fitter.max_depth, e_star_kPa=fitter.e_star, mesh="coarse", workers=1)
    model = ComposedModel(core, ("offset",), data)
    res = fit_least_squares(model, data.depth_mm, data.force_mN, [10.0, 0.42, 0.02], noise_mN=sigma,
                            ftol=1e-6, xtol=1e-6, max_nfev=8)
    x = np.array([res.parameters[n] for n in model.parameter_names])
    _, fit_std = model.reported(x, res.covariance)
    rung = _rung(model, x, res)
    same, runs = idf.predicted_std(fitter, rung, error_model=False)
    assert runs == 1  # one run with sensitivities: E, nu by direct differentiation, the offset a shift
    for k, sd in fit_std.items():
        assert same[k] == pytest.approx(sd, rel=0.02), k
    scaled, _ = idf.predicted_std(fitter, rung, radius_factor=2.0, depth_factor=2.0, error_model=False)
    for k, factor in {"E_kPa": 0.25, "nu": 0.25, "offset_mm": 0.5}.items():
        assert scaled[k] == pytest.approx(factor * same[k], rel=0.02), k
    # the noise model of diagnosis (noise and 0.3 % model error in quadrature) only widens them
    weighted, _ = idf.predicted_std(fitter, rung)
    assert all(weighted[k] >= same[k] * (1 - 1e-9) for k in same)
    core.close()


@pytest.mark.fe_loop  # finite elements in the loop: .ci/run runs it, not the default run
def test_a_deeper_indentation_determines_a_layer_thickness():
    """(ii) A 2 mm layer over a half-space four times softer, indented 0.3 mm with the skin sphere:
    the curve does not determine the thickness (sd over half of it); 1.5 times deeper, the sphere
    feels the layer's base more and the predicted sd falls below half the thickness."""
    sigma, t = 0.03, 2.0
    core = FECore(("layer",), radius_mm=R, max_depth_mm=0.3, e_star_kPa=12.0, mesh="coarse", workers=1)
    x = np.array([10.0, 0.45, t, 4.0])  # E_kPa, nu, thickness_mm, compliance (= 1 / ratio)
    depth = np.linspace(0.0, 0.3, 101)
    force = np.r_[0.0, core.force(depth[1:], x)]
    data = prepare(measurement_from_arrays(depth, force, source="layer"), segments=("approach",), contact="origin")
    model = ComposedModel(core, ("layer",), data)
    fitter, rung = _fitter(data, sigma), _rung(model, x, prediction=force)
    same, _ = idf.predicted_std(fitter, rung)
    deeper = idf.assess(fitter, rung, alternatives=[a for a in idf.ALTERNATIVES if a.key == "deeper"])[0]
    assert deeper.error is None, deeper.error
    assert same["thickness_mm"] > idf.DETERMINED * t  # measured 1.33 mm
    assert deeper.std["thickness_mm"] < idf.DETERMINED * t  # measured 0.58 mm
    assert deeper.std["ratio"] < same["ratio"]
    clause = idf.suggestion("thickness_mm", t, [deeper])
    sd = deeper.std["thickness_mm"]
    assert clause == f"; an indentation 1.5 times deeper (0.45 mm) would determine it to +- {sd:.2g}"
    core.close()


@pytest.fixture(scope="module")
def shallow():
    """A diagnosis whose last rung leaves E undetermined: a shallow (0.15 mm) curve with an offset
    contact point, where E and nu trade against each other (Hertz's E / (1 - nu^2))."""
    from skin_indent.diagnosis import diagnose

    sigma = 0.03
    m = _shifted({"E_kPa": 10.0, "nu": 0.45}, 0.15, sigma, seed=2, rate=0.01)
    return diagnose(m, candidates=("offset",), noise_mN=sigma, mesh="coarse")


def test_sentence_names_the_measurement_and_reading_makes_no_run(shallow, monkeypatch):
    """(iii) The sentence says, per undetermined parameter, which measurement would determine it
    (or that none would); the finite-element runs behind it are made by diagnose, once: reading
    the result (sentence, report, JSON) makes none."""
    from skin_indent.diagnosis import workflow

    d = shallow
    monkeypatch.setattr(workflow, "assess", lambda *a, **k: pytest.fail("a finite-element run on reading"))
    assert d.missing == ("offset",), d.report()
    reasons = d.undetermined()
    assert "E_kPa" in reasons, d.report()
    for reason in reasons.values():
        if "not determined by this curve" in reason:
            assert ("would determine it to +-" in reason
                    or "none of a larger/smaller sphere or a deeper indentation would determine it" in reason), reason
    sentence = d.sentence()
    assert reasons["E_kPa"] in sentence
    d.report(), d.to_dict()
    # the standard deviation in the reason is the one the last rung reports everywhere
    assert f"+- {d.current.std['E_kPa']:.2g}: not determined" in reasons["E_kPa"]


def test_failing_alternatives_are_not_suggested(shallow, monkeypatch):
    """(iii) A finite-element run that fails (any error) removes that measurement from the
    suggestions; when every one fails the reason says only what the curve does not determine."""
    from skin_indent.diagnosis import workflow

    real = FECore.jacobian
    fitter = shallow.fitter
    rung = fitter.fit(shallow.current.effects)  # the fit itself (the diagnosis' last rung holds the decided sd)

    def spheres_fail(self, depth_mm, theta, *args, **kwargs):
        if not math.isclose(self.radius_mm, R):
            raise RuntimeError("the Newton iterations did not converge")
        return real(self, depth_mm, theta, *args, **kwargs)

    monkeypatch.setattr(FECore, "jacobian", spheres_fail)
    reason = workflow.determine(fitter, rung)[2]["E_kPa"]
    assert "sphere" not in reason, reason
    assert "; an indentation 1.5 times deeper (0.226 mm) would determine it to +-" in reason, reason  # 2.8 kPa

    def everything_fails(self, depth_mm, theta, *args, **kwargs):
        raise ValueError("finite-element run failed at nu = 0.49: no convergence")

    monkeypatch.setattr(FECore, "jacobian", everything_fails)
    std, source, reasons, _ = workflow.determine(fitter, rung)
    assert reasons["E_kPa"].endswith("not determined by this curve")
    assert std == rung.std and set(source.values()) == {workflow.FROM_FIT}  # nothing computed: the fit's sd


def test_surfaces_only_makes_no_finite_element_runs(shallow, monkeypatch):
    """A diagnosis kept to surfaces (``in_loop=False``, ``--surfaces-only``) says what is not
    determined without the finite-element runs of the predictions."""
    from skin_indent.diagnosis import workflow

    fitter = shallow.fitter
    rung = fitter.fit(shallow.current.effects)
    monkeypatch.setattr(fitter, "in_loop", False)
    monkeypatch.setattr(workflow, "assess", lambda *a, **k: pytest.fail("finite-element runs made"))
    assert workflow.determine(fitter, rung)[2]["E_kPa"].endswith("not determined by this curve")


def test_suggestion_picks_the_smallest_determining_sd():
    a = {x.key: x for x in idf.ALTERNATIVES}

    def p(key, sd):
        return idf.Prediction(a[key], f"<{key}>", None if sd is None else {"t": sd}, None if sd else "failed")

    assert idf.suggestion("t", 4.0, [p("larger sphere", 1.5), p("deeper", 0.6), p("smaller sphere", 9.0)]) \
        == "; <deeper> would determine it to +- 0.6"
    assert idf.suggestion("t", 4.0, [p("larger sphere", 3.0), p("deeper", math.inf), p("smaller sphere", 9.0)]) \
        == "; none of a larger/smaller sphere or a deeper indentation would determine it"
    assert idf.suggestion("t", 4.0, [p("larger sphere", 3.0), p("deeper", None), p("smaller sphere", 9.0)]) \
        == "; none of a larger sphere or a smaller sphere would determine it"
    assert idf.suggestion("t", 4.0, [p("deeper", 3.0)]) == "; a deeper indentation would not determine it either"
    assert idf.suggestion("t", 4.0, [p("deeper", None)]) == ""
    assert idf.ALTERNATIVES[0].describe(6.22, 0.6) == ("a sphere of twice the radius (12.4 mm) to the same depth "
                                                       "(0.6 mm)")


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


def test_alternatives_side_by_side_start_their_workers_in_the_main_thread(shallow, monkeypatch):
    """With several workers the alternatives run in threads; their worker processes are forked
    from the main thread before those start (never from a thread), and the predictions equal
    those made one after the other in this process."""
    import threading

    from skin_indent.runtime.context import Context

    fitter, rung = shallow.fitter, shallow.current
    monkeypatch.setattr(fitter, "context", Context(workers=1))
    serial = idf.assess(fitter, rung)
    started = []
    real = FECore.start_workers
    monkeypatch.setattr(FECore, "start_workers",
                        lambda self: started.append(threading.current_thread()) or real(self))
    monkeypatch.setattr(fitter, "context", Context(workers=2))
    side = idf.assess(fitter, rung)
    assert len(started) == len(idf.ALTERNATIVES) and all(t is threading.main_thread() for t in started)
    for a, b in zip(serial, side):
        assert a.label == b.label and (a.std is None) == (b.std is None)
        if a.std is not None:
            assert b.std == pytest.approx(a.std, rel=1e-9)
