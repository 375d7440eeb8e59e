"""The next measurement (``si.plan``, ``skin-indent plan``, and the diagnosis' "would separate them" sentence).

Known answers first: the predicted force of a half-space against the independent reference
curve and the similarity F(h; R/2) = F(2h; R) / 4, a hold that relaxes to the long-time
modulus, and the information of a measurement made twice (the variance halves). Then a
curve where ``layer`` stands in for ``stiffening`` (our own forward model, the first
examination names stiffening with layer as a rival, on surfaces): the plan ranks the
spheres of other radii above the same sphere again, its separations are what its written
curves show, and the diagnosis' sentence names the plan's next measurement with its numbers. The forearm-like curve
(two layers and layer and stiffening fitted with finite elements in the loop, minutes) is
behind ``slow``.
"""

import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest
from _data import DATA, load_curve

import skin_indent as si
from skin_indent.diagnosis.identifiability import candidates, recorded_chi2
from skin_indent.diagnosis.information import Block, joint_std
from skin_indent.diagnosis.measurements import acts_in_time, base_history, hold, sphere
from skin_indent.diagnosis.prediction import predict, predicted_force
from skin_indent.diagnosis.planning import TOO_CLOSE, plan
from skin_indent.effects import Model, instances
from skin_indent.fitting.multistart import MODEL_ERROR
from skin_indent.measurement import measurement_from_arrays
from skin_indent.mechanics.protocol import Protocol
from skin_indent.report import write_plan
from skin_indent.runtime.provenance import read_provenance

#: tests sharing the diagnosis of the rival curve run in one xdist worker
RIVALS = pytest.mark.xdist_group("plan-rivals")


def _history(depth, radius_mm, time=None):
    """A prepared curve of the points ``depth`` (mm, contact at 0), as the candidates' points are."""
    m = measurement_from_arrays(np.asarray(depth, dtype=float), np.ones(len(depth)), time, source="points")
    return si.prepare(m, segments=("approach", "hold", "retract"), contact="origin", radius_mm=radius_mm)


# ----------------------------------------------------------------------------- known answers
def test_predicted_force_is_the_independent_reference_and_scales_with_the_radius():
    """A half-space (E = 8 kPa, nu = 0.45, R = 6.22 mm) against the independent FE code's curve, and
    the similarity of the neo-Hookean half-space: F(h; R/2) = F(2h; R) / 4."""
    data = load_curve("reference/neo-hooke_halfspace_E8kPa_nu0.45.csv")
    data = data[data[:, 0] >= 0.05]
    theta = {"E_kPa": 8.0, "nu": 0.45}
    force, J, names = predicted_force((), theta, _history(data[:, 0], 6.22), "coarse", True)
    assert force == pytest.approx(data[:, 1], rel=4e-3)
    assert names == ("E_kPa", "nu") and J[:, 0] == pytest.approx(force / 8.0, rel=1e-9)  # F is linear in E
    half, _, _ = predicted_force((), theta, _history(data[:, 0] / 2, 3.11), "coarse")
    assert 4 * half == pytest.approx(force, rel=1e-9)  # exact: the mesh scales with the radius


def test_a_hold_relaxes_to_the_long_time_modulus():
    """Ramp then a 30 s hold with one Prony term (g1 = 0.4, tau = 2 s): the force at the end of the hold
    is (1 - g1) times the elastic force at that depth (the rest decays as exp(-30 / 2))."""
    t = np.linspace(0.5, 10.0, 20)
    base = _history(0.06 * t, 6.22, time=t)
    c = hold(base, 30.0)
    assert c.kind == "hold" and c.curve.time_s[-1] == pytest.approx(40.0) and c.max_depth_mm == pytest.approx(0.6)
    theta = {"E_kPa": 10.0, "nu": 0.45, "g1": 0.4, "tau1_s": 2.0}
    relaxed, _, _ = predicted_force(("viscoelastic",), theta, c.curve, "coarse")
    elastic, _, _ = predicted_force((), theta, c.curve, "coarse")
    assert relaxed[-1] / elastic[-1] == pytest.approx(0.6, rel=1e-3)
    assert relaxed[19] < elastic[19] and np.all(np.diff(relaxed[20:]) < 0)  # it relaxes during the hold


def test_a_measurement_made_twice_halves_the_variance():
    """The same curve fitted twice, each with its own contact point: the shared parameters' sd fall by
    sqrt(2) (information adds), the first curve's contact point's less."""
    from types import SimpleNamespace

    from skin_indent.models import ComposedModel

    m = measurement_from_arrays(np.linspace(0.03, 0.6, 40), np.ones(40), source="points")
    data = si.prepare(m, contact="origin", radius_mm=6.22)
    rng = np.random.default_rng(0)
    J = rng.normal(size=(40, 3))
    core = SimpleNamespace(parameter_names=("E_kPa", "nu"), bounds=(np.array([1.0, 0.2]), np.array([50.0, 0.499])),
                           depth_range=(0.0, 1.0))
    model = ComposedModel(core, ("offset",), data)
    rung = SimpleNamespace(bound_model=model, x=np.array([10.0, 0.45, 0.0]))
    sigma = np.full(40, 0.05)
    one = joint_std(rung, [Block(J, model.parameter_names, sigma, own=False)], [0, 1, 2])
    two = joint_std(rung, [Block(J, model.parameter_names, sigma, own=False),
                           Block(J, model.parameter_names, sigma, own=True)], [0, 1, 2])
    for k in ("E_kPa", "nu"):  # shared: the information doubles
        assert two[k] == pytest.approx(one[k] / math.sqrt(2), rel=1e-9), k
    # the first curve's contact point is its own: the second curve narrows it only through E and nu
    assert one["offset_mm"] / math.sqrt(2) < two["offset_mm"] < one["offset_mm"]


# ----------------------------------------------------------------------------- a curve with a rival
@pytest.fixture(scope="module")
def rival_diagnosis(context, diagnosis_surfaces):
    """Strain stiffening, for which one layer over a stiffer base stands in (BIC within RIVAL)."""
    curve = Model(("stiffening",)).simulate({"E_kPa": 6.0, "nu": 0.47, "C20_kPa": 6.0},
                                             protocol=Protocol.ramp(0.6, 100, 0.02), mesh="coarse")
    force = curve.force_mN + np.random.default_rng(3).normal(0.0, 0.05, curve.force_mN.size)
    m = measurement_from_arrays(curve.depth_mm, force, curve.time_s, source="stiffening")
    return si.diagnose(m, candidates=("layer", "stiffening"), in_loop=False, max_rungs=1, context=context)


@pytest.fixture(scope="module")
def rival_plan(rival_diagnosis, context):
    """The plan with a sphere of half the radius, 1.5 times deeper (the default), the same sphere again,
    and a hold and a speed that no explanation cares about."""
    return plan(rival_diagnosis, radii=(3.11,), hold_s=60.0, speeds_mm_per_s=(0.1,), context=context)


@RIVALS
def test_plan_ranks_other_spheres_above_the_same_one_with_the_numbers_its_curves_show(rival_plan, tmp_path):
    p = rival_plan
    d = p.diagnosis
    assert [f.model for f in p.explanations] == ["neo-hooke+stiffening", "neo-hooke+layer"], d.report()
    assert not p.nothing_to_plan and not p.undetermined and all(a.error is None for a in p.ranking), p.report()
    ranked = [a.candidate for a in p.ranking]
    same = next(i for i, c in enumerate(ranked) if c.reference)
    half = next(i for i, c in enumerate(ranked) if c.kind == "sphere" and c.radius_mm == pytest.approx(3.11))
    assert half < same and ranked[0].kind == "sphere" and not ranked[0].reference, p.report()
    assert not p.ranking[0].too_close and p.ranking[same].too_close, p.report()
    # the written curves: loadable, with their radius, and showing the separations reported
    written = write_plan(p, tmp_path)
    assert len(written["curves"]) == 2 * 3 and read_provenance(written["figure"])["api"] == "skin_indent.plan"
    for rank, a in enumerate(p.best(), 1):
        files = {f.model: next(x for x in written["curves"] if x.name.startswith(f"{rank:02d}-")
                               and x.name.endswith(f"-{f.model}.csv")) for f in p.explanations}
        curves = {k: si.load_csv(v) for k, v in files.items()}
        fa, fb = (curves[f.model] for f in p.explanations)
        assert fa.radius_mm == pytest.approx(a.candidate.radius_mm) and np.array_equal(fa.depth_mm, fb.depth_mm)
        assert read_provenance(files[p.explanations[0].model])["api"] == "skin_indent.plan"
        diff = fb.force_mN - fa.force_mN
        sigma = np.sqrt(p.noise_mN**2 + (MODEL_ERROR * (fa.force_mN + fb.force_mN) / 2) ** 2)
        s = a.separations[0]
        assert np.max(np.abs(diff)) / p.noise_mN == pytest.approx(s.max_difference_noise, rel=1e-12)
        assert s.repeat == a.candidate.reference
        if s.repeat:  # the same sphere again adds the chi-square gap the recorded curve gives, not the curves'
            chi2 = [recorded_chi2(f, p.noise_mN) for f in p.explanations]
            assert chi2 == pytest.approx([f.chi2 for f in p.explanations], rel=1e-9)
            k = [f.n_free for f in p.explanations]
            assert s.separation == pytest.approx(math.sqrt(abs(chi2[1] - chi2[0] - (k[0] - k[1]))), rel=1e-12)
        else:
            assert math.sqrt(np.sum((diff / sigma) ** 2)) == pytest.approx(s.separation, rel=1e-12)
    # one set of numbers: the JSON and the text say the same
    out = json.loads(json.dumps(p.to_dict(), allow_nan=False))
    assert [r["label"] for r in out["ranking"]] == [a.candidate.label for a in p.ranking]
    for row, a in zip(out["ranking"], p.ranking):
        assert row["separation"] == a.separation and row["too_close"] == (a.separation < TOO_CLOSE)
        assert f"S = {a.separation:.3g}, up to {a.separations[0].max_difference_mN:.3g} mN" in p.report()


@RIVALS
def test_the_diagnosis_sentence_has_the_plans_numbers(rival_diagnosis, rival_plan, context):
    """The sentence names the plan's next measurement (the candidate whose curves lie furthest apart: a
    sphere of another radius here), with the largest difference and the separation the plan computes
    for it: the plan of the diagnosis reads the diagnosis' own outlook, and the candidates weighed
    again from scratch give the same."""
    d = rival_diagnosis
    sentence = d.suggested_measurement
    for p in (plan(d), plan(d, radii=(3.11, 12.44), context=context)):
        a = p.ranking[0]
        s = a.closest
        assert sentence.startswith(a.candidate.label + " would separate stiffening from layer"), (sentence, p.report())
        assert f"up to {s.max_difference_mN:.3g} mN, {s.max_difference_noise:.1f} times the noise" in sentence
        assert f"by {s.separation:.3g} noise units in root-sum-square over its {s.points} points" in sentence
    assert sentence in d.sentence()


@RIVALS
def test_a_hold_or_another_speed_is_not_weighed_where_no_explanation_acts_in_time(rival_plan):
    p = rival_plan
    assert {a.candidate.kind for a in p.ranking} == {"sphere", "deeper"}, p.report()
    assert set(p.skipped) == {"a 60 s hold", "a loading speed of 0.1 mm/s"}, p.skipped
    assert all("no explanation acts along the time history" in why for why in p.skipped.values())
    assert "not weighed: a 60 s hold" in p.report()


def test_a_relaxation_time_is_determined_by_a_hold_or_another_speed(context, diagnosis_surfaces, tmp_path):
    """One Prony term (g1 = 0.3) seen through a ramp and a 5 s hold leaves its time undetermined; a long
    hold or another loading speed, fitted with the recorded curve, determines it better than the
    measurement made again, whose standard deviations are those of the recorded curve over sqrt(2)."""
    proto = Protocol.ramp(0.6, 60, 0.02, hold_s=5.0, hold_points=10)
    curve = Model(("viscoelastic",)).simulate({"E_kPa": 8.0, "nu": 0.47, "g1": 0.3, "tau1_s": 60.0}, protocol=proto,
                                               mesh="coarse")
    force = curve.force_mN + np.random.default_rng(5).normal(0.0, 0.05, curve.force_mN.size)
    m = measurement_from_arrays(curve.depth_mm, force, curve.time_s, source="relaxing")
    d = si.diagnose(m, candidates=("viscoelastic",), in_loop=False, max_rungs=1, context=context)
    assert d.verdict == "viscoelastic" and "tau1_s" in d.not_determined, d.report()
    p = plan(d, radii=(), hold_s=120.0, speeds_mm_per_s=(0.2,), context=context)
    assert [f.model for f in p.explanations] == ["neo-hooke+viscoelastic"] and set(p.undetermined) == {"tau1_s"}
    by_kind = {a.candidate.kind: a for a in p.ranking}
    assert set(by_kind) == {"sphere", "deeper", "hold", "speed"} and all(a.error is None for a in p.ranking)
    same = by_kind["sphere"]
    assert same.candidate.reference
    assert same.std["tau1_s"] == pytest.approx(p.recorded_std["tau1_s"] / math.sqrt(2), rel=1e-6)
    assert p.ranking.index(by_kind["hold"]) < p.ranking.index(same), p.report()
    assert p.ranking.index(by_kind["speed"]) < p.ranking.index(same), p.report()
    assert by_kind["hold"].std["tau1_s"] < same.std["tau1_s"] and "tau1_s" in by_kind["hold"].determines
    # the hold's curve: the recorded loading, then 120 s at the deepest point, relaxing
    written = write_plan(p, tmp_path, best=4)
    held = si.load_csv(next(x for x in written["curves"] if "-hold-120s-" in x.name))
    hold_part = held.depth_mm == held.depth_mm.max()
    assert held.time_s[-1] - held.time_s[hold_part][0] == pytest.approx(120.0)
    assert np.all(np.diff(held.force_mN[hold_part]) < 0)


def test_predictions_in_workers_are_those_made_here_and_a_failed_run_is_said():
    """The runs of several candidates go to the workers at once; each equals the run made in this
    process, and a model whose run fails is that task's exception (its candidate is then not
    predicted: an assessment with the error, ranked last)."""
    t = np.linspace(0.3, 6.0, 20)
    base = _history(0.025 * t, 6.22, time=t)
    cands = [sphere(base, 3.11), sphere(base, 6.22)]
    theta = {"E_kPa": 10.0, "nu": 0.45, "C20_over_E": 0.5}  # fit coordinates (C20 = 5 kPa)
    tasks = {k: (("stiffening",), theta, c.curve, "coarse", False) for k, c in enumerate(cands)}
    tasks["broken"] = (("stiffening",), {**theta, "C20_over_E": -0.4}, cands[0].curve, "coarse", False)
    got = predict(tasks, context=si.Context(workers=2))
    for k, c in enumerate(cands):
        assert got[k][0] == pytest.approx(predicted_force(("stiffening",), theta, c.curve, "coarse")[0], rel=1e-12)
    assert isinstance(got["broken"], ValueError)


def test_the_candidates_weigh_a_hold_only_where_time_matters():
    """One candidate set for the diagnosis and the plan: the same sphere again, half and twice the radius,
    1.5 times deeper at the same speed, and a hold where an explanation acts along the time history."""
    from types import SimpleNamespace

    t = np.linspace(0.3, 30.0, 100)
    m = measurement_from_arrays(0.02 * t, np.ones(100), t, source="points")
    data = si.prepare(m, segments=("approach", "hold", "retract"), contact="origin", radius_mm=6.22)
    base = base_history(data, data.depth_mm)

    def rung(effects):
        return SimpleNamespace(bound_model=SimpleNamespace(effects=instances(effects)))

    assert not any(acts_in_time(f.bound_model.effects) for f in (rung(("layer",)), rung(("stiffening",))))
    assert acts_in_time(rung(("viscoelastic",)).bound_model.effects)
    elastic, skipped = candidates(base, not_in_time="no explanation acts along the time history")
    timed, _ = candidates(base)
    assert [c.kind for c in elastic] == ["sphere"] * 3 + ["deeper"] and not skipped
    assert [c.kind for c in timed] == ["sphere"] * 3 + ["deeper", "hold"]
    assert elastic[0].reference and [c.radius_mm for c in elastic[:3]] == pytest.approx([6.22, 3.11, 12.44])
    assert elastic[3].max_depth_mm == pytest.approx(0.9)
    # a deeper indentation at the same speed: its depths and its times scale together
    assert np.allclose(elastic[3].curve.depth_mm / elastic[3].curve.time_s, 0.02)


# ----------------------------------------------------------------------------- the command
def _cli(*args, cache=None, timeout=600):
    env = {**__import__("os").environ, **({"SKIN_INDENT_CACHE": str(cache)} if cache else {})}
    return subprocess.run([sys.executable, "-m", "skin_indent", "plan", *map(str, args)], check=False,
                          capture_output=True, text=True, env=env, timeout=timeout)


@pytest.mark.parametrize("options, says", [
    (["--radii", "-1"], "--radii must be comma-separated positive numbers"),
    (["--radii", "0.3"], "deeper than a sphere of R = 0.3 mm"),
    (["--max-depth", "0.3"], "is not deeper than the recorded indentation"),
    (["--hold", "0"], "--hold must be a positive number"),
    (["--speeds", "0.1,-3"], "--speeds must be comma-separated positive numbers"),
])
def test_bad_options_are_one_line_errors(options, says, tmp_path):
    out = _cli(DATA / "hidden-effects" / "v01_clean.csv", *options, "--out", tmp_path, timeout=120)
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and says in out.stderr, out.stderr
    assert out.stderr.startswith("skin-indent plan: error: ") and not any(tmp_path.iterdir())


def test_a_curve_explained_fully_has_nothing_to_plan(gallery_cache, diagnosis_surfaces, tmp_path):
    args = [DATA / "hidden-effects" / "v01_clean.csv", "--candidates", "offset", "--surfaces-only", "--out", tmp_path]
    out = _cli(*args, cache=gallery_cache)
    assert out.returncode == 0 and "nothing to plan" in out.stdout.lower(), out.stdout + out.stderr
    assert not any(tmp_path.iterdir())
    payload = json.loads(_cli(*args, "--json", "-q", cache=gallery_cache).stdout)
    assert payload["nothing_to_plan"] and payload["ranking"] == [] and payload["verdict"] == "none"


@pytest.mark.slow
def test_cli_plan_writes_the_ranking_the_curves_and_the_figure(gallery_cache, diagnosis_surfaces, tmp_path):
    curve = Model(("stiffening",)).simulate({"E_kPa": 6.0, "nu": 0.47, "C20_kPa": 6.0},
                                             protocol=Protocol.ramp(0.6, 100, 0.02), mesh="coarse")
    force = curve.force_mN + np.random.default_rng(3).normal(0.0, 0.05, curve.force_mN.size)
    path = tmp_path / "stiff.csv"
    si.measurement.save_csv(measurement_from_arrays(curve.depth_mm, force, curve.time_s, source="s"), path)
    out = _cli(path, "--candidates", "layer,stiffening", "--surfaces-only", "--max-rungs", "1", "--radii", "3.11,2",
               "--json", "-q", "--out", tmp_path / "plan", cache=gallery_cache)
    assert out.returncode == 0 and out.stderr == "", out.stderr
    payload = json.loads(out.stdout)
    assert not payload["ranking"][0]["too_close"] and payload["provenance"]["command"][1] == "plan"
    assert len(payload["files"]) == 7 and all(re.search(r"\.(csv|png)$", f) for f in payload["files"])


@pytest.mark.slow
def test_forearm_plan_ranks_half_the_radius_above_the_same_sphere(tmp_path):
    """The demo's curve (three layers; ambiguous between two layers and layer with stiffening, with the
    finite-element model in the loop, minutes): the diagnosis and the plan name the same next measurement
    with the same standard deviations; a sphere of half the radius (or a better candidate) ranks above
    the same sphere again, its curves lie far enough apart to separate the explanations, and the written
    curves show it."""
    m = si.load_csv(si.bundled_path("forearm_like.csv"))
    p = plan(m, workers=2)
    # the check: diagnose and plan name the same next measurement with the same predicted sd
    d, top = p.diagnosis, p.ranking[0]
    assert d.suggested_measurement.startswith(top.candidate.label + " would separate"), (d.sentence(), p.report())
    for k in p.undetermined:
        assert d.current.std[k] == p.recorded_std[k], k
        if k in top.determines:
            assert f"{top.candidate.label} would determine it to +- {top.std[k]:.2g}" in d.not_determined[k]
    models = sorted(f.model for f in p.explanations)
    assert models == ["neo-hooke+layer+layer", "neo-hooke+layer+stiffening"], p.report()
    ranked = [a.candidate for a in p.ranking]
    same = next(i for i, c in enumerate(ranked) if c.reference)
    half = next(i for i, c in enumerate(ranked) if c.kind == "sphere" and c.radius_mm == pytest.approx(3.11))
    assert half < same and not p.ranking[half].too_close and p.ranking[same].too_close, p.report()
    assert p.undetermined and set(p.ranking[0].determines), p.report()
    written = write_plan(p, tmp_path)
    a = p.best()[0]
    fa, fb = (si.load_csv(next(x for x in written["curves"]
                               if x.name.startswith("01-") and x.name.endswith(f"-{f.model}.csv")))
              for f in p.explanations)
    diff = fb.force_mN - fa.force_mN
    assert np.max(np.abs(diff)) == pytest.approx(a.separations[0].max_difference_mN, rel=1e-12)
