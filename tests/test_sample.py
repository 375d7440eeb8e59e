"""Several curves of one sample fitted and diagnosed together (issue "Close the loop").

The checks: the joint model shares the material and gives each curve its own contact point,
its Jacobian is the finite-difference one; a joint fit of a half-space seen with two spheres
recovers E and nu and determines nu better than either curve alone; a viscoelastic
half-space at two loading speeds is diagnosed as viscoelastic although neither ramp alone can
show relaxation; a prior narrows the other parameters and a wrong one is reported in tension;
the command line (``--sample``, per-file radii, one-line refusals), the JSON (``rms_mN`` a
list in input order) and the figures. The full checks of the issue (two layers at two radii,
stiffening at two radii, a clean half-space at two radii with every candidate, the
forearm-like pair) fit layered models with finite elements in the loop: ``slow``.

The curves are made by our own forward model on the medium mesh; the fits run on coarse
surfaces and coarse finite-element runs (a different mesh: no inverse crime).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from _data import DATA
from analytic_model import HertzLikeModel
from skin_indent.cli import main
from skin_indent.effects import Model
from skin_indent.fitting import fit
from skin_indent.response_surface import SurfaceCore
from skin_indent.fitting.model_fit import prepare_curve
from skin_indent.measurement import load_csv, measurement_from_arrays, save_csv
from skin_indent.models import ComposedModel, JointModel
from skin_indent.mechanics.protocol import Protocol

#: noise of the synthetic curves (mN): the forearm-like curve's is 0.05
NOISE = 0.03


def _context(cache):
    from skin_indent.runtime.context import Context

    return Context(cache_dir=cache, workers=2, progress=False)


def curve(effects, theta, radius_mm, *, depth_mm=0.6, n=100, noise=NOISE, seed=0, speed=None, name="curve"):
    """A curve of our forward model (medium mesh) with Gaussian noise; with ``speed`` a ramp in time."""
    model = Model(tuple(effects), radius_mm)
    if speed is None:
        d = np.linspace(depth_mm / n, depth_mm, n)
        F, t = model.simulate(theta, d, mesh="medium").force_mN, None
    else:
        p = Protocol.ramp(depth_mm, n, speed)
        d, t = p.depth_mm, p.time_s
        F = model.simulate(theta, protocol=p, mesh="medium").force_mN
    F = F + np.random.default_rng(seed).normal(0.0, noise, F.size)
    return measurement_from_arrays(d, F, t, source=f"{name}_R{radius_mm:g}", radius_mm=radius_mm)


# ----------------------------------------------------------------------------- the joint model
class _Core(HertzLikeModel, SurfaceCore):
    """The analytic stand-in as an elastic core (a depth range, as a surface has)."""

    def __init__(self, radius_mm, lower=(1.0, 0.2), upper=(100.0, 0.49)):
        super().__init__(radius_mm, lower, upper)
        self.depth_range = (0.0, 1.0)


def _prepared(radius_mm, offset_mm, seed):
    core = _Core(radius_mm)
    d = np.linspace(0.01, 0.6, 60)
    F = np.where(d > offset_mm, core.force(np.maximum(d - offset_mm, 0.0), [10.0, 0.45]), 0.0)
    F = F + np.random.default_rng(seed).normal(0, 1e-3, d.size)
    return prepare_curve(measurement_from_arrays(d, F, source=f"R{radius_mm}", radius_mm=radius_mm))


def test_the_joint_model_shares_the_material_and_gives_each_curve_its_own_contact_point():
    a, b = _prepared(6.22, 0.025, 1), _prepared(2.0, -0.005, 2)  # no point within a step of contact
    ma = ComposedModel(_Core(6.22, lower=(2.0, 0.2)), ("offset",), a)
    mb = ComposedModel(_Core(2.0, upper=(50.0, 0.49)), ("offset",), b)
    joint = JointModel([ma, mb])
    assert joint.parameter_names == ("E_kPa", "nu", "offset_mm[1]", "offset_mm[2]")
    # a shared parameter's range is the intersection of the curves' ranges
    assert joint.bounds[0][0] == 2.0 and joint.bounds[1][0] == 50.0
    x = np.array([10.0, 0.45, 0.025, -0.005])
    F = joint.force(joint.depth_mm, x)
    assert np.array_equal(F[:a.n], ma.force(a.depth_mm, x[[0, 1, 2]]))
    assert np.array_equal(F[a.n:], mb.force(b.depth_mm, x[[0, 1, 3]]))
    # every curve's Jacobian in its rows and its parameters' columns: central differences
    J = joint.jacobian(joint.depth_mm, x)
    for j in range(x.size):
        step = 1e-6 * max(abs(x[j]), 1e-2)
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        fd = (joint.force(joint.depth_mm, up) - joint.force(joint.depth_mm, down)) / (2 * step)
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-5, atol=1e-7 * np.max(np.abs(F)))
    assert np.all(J[:a.n, 3] == 0) and np.all(J[a.n:, 2] == 0)  # a curve's contact point moves only its own force
    params = joint.model_parameters(x)
    assert params == {"E_kPa": 10.0, "nu": 0.45, "offset_mm[1]": 0.025, "offset_mm[2]": -0.005}
    assert joint.curve_parameters(params, 1) == {"E_kPa": 10.0, "nu": 0.45, "offset_mm": -0.005}
    with pytest.raises(ValueError, match="no common value of E_kPa"):
        JointModel([ComposedModel(_Core(6.22, lower=(60.0, 0.2)), (), a), mb])


# ----------------------------------------------------------------------------- fits
@pytest.fixture(scope="module")
def two_spheres():
    """A neo-Hookean half-space (E = 10 kPa, nu = 0.45) indented to 0.6 mm with spheres of 6.22 and 3.11 mm."""
    theta = {"E_kPa": 10.0, "nu": 0.45}
    return [curve((), theta, 6.22, seed=11, name="halfspace"), curve((), theta, 3.11, seed=12, name="halfspace")]


def test_a_joint_fit_of_two_spheres_recovers_the_half_space_and_determines_nu_better(two_spheres, context):
    joint = fit(two_spheres, model="neo-hooke", context=context)
    alone = [fit(m, model="neo-hooke", context=context) for m in two_spheres]
    for name, truth in (("E_kPa", 10.0), ("nu", 0.45)):
        assert abs(joint.parameters[name] - truth) < 3 * joint.std[name] + 0.003 * truth, name
    # two radii see the large-strain shape at two h/R: nu better determined than by either curve
    assert joint.std["nu"] < min(r.std["nu"] for r in alone)
    d = joint.to_dict()
    assert len(d["rms_mN"]) == 2 and d["curves"][1]["radius_mm"] == 3.11
    for c in joint.curves:  # each curve explained to its own noise
        assert c["misfit"] < 1.3 and c["white"]
    assert joint.trusted
    # one result: the joint fit is the ladder's rung of the same model on the same curves, its curves bound
    from skin_indent.diagnosis import diagnose

    rung = diagnose(two_spheres, max_rungs=0, in_loop=False, context=context).ladder[0]
    assert type(rung) is type(joint) and rung.model == joint.model
    assert rung.parameters == joint.parameters and rung.std == joint.std and rung.chi2 == joint.chi2
    assert rung.curve_rms_mN == joint.curve_rms_mN and joint.rms_of_curves == [c["rms_mN"] for c in joint.curves]
    # per curve: one entry each, the points split as each curve was prepared
    assert len(joint.prepared) == len(joint.curves) == 2
    parts = joint.per_curve(joint.prediction_mN)
    assert [p.size for p in parts] == [p.n for p in joint.prepared]
    for p, part, r in zip(joint.prepared, parts, joint.per_curve(joint.residuals_mN)):
        assert np.allclose(part + r, p.force_mN, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="curves"):  # no one radius for two spheres: curves[k] says each
        joint.radius_mm


def test_two_loading_speeds_show_relaxation_that_one_ramp_cannot(context, diagnosis_surfaces, tmp_path):
    from skin_indent.diagnosis import diagnose

    theta = {"E_kPa": 10.0, "nu": 0.45, "g1": 0.4, "tau1_s": 5.0}
    slow = curve(("viscoelastic",), theta, 6.22, speed=0.02, seed=21, name="slow")
    fast = curve(("viscoelastic",), theta, 6.22, speed=0.2, seed=22, name="fast")
    one = diagnose(slow, candidates=("viscoelastic", "stiffening"), context=context, in_loop=False, max_rungs=1)
    assert "viscoelastic" in one.not_detectable  # a single constant-speed ramp
    both = diagnose([slow, fast], candidates=("viscoelastic", "stiffening"), context=context, in_loop=False,
                    max_rungs=2)
    assert both.verdict == "viscoelastic", both.report()
    assert both.explained
    g1 = both.current.parameters["g1"]
    assert abs(g1 - 0.4) < max(3 * both.current.std["g1"], 0.05)
    out = both.to_dict()
    assert [len(r["rms_mN"]) for r in out["ladder"]] == [2, 2]
    assert out["data"] == [slow.source, fast.source]
    assert both.report().count("curve ") >= 2
    # the report shows every curve with every rung: the page's table has each curve's RMS as the JSON has it
    from skin_indent.report import write_report

    page = write_report(both, tmp_path / "report").read_text()
    assert "2 curves of one sample" in page and slow.source in page and fast.source in page
    for rung in out["ladder"]:
        assert ", ".join(f"{v:.4g}" for v in rung["rms_mN"]) in page
    assert (tmp_path / "report" / "fit.png").is_file() and (tmp_path / "report" / "ladder.png").is_file()


def test_a_prior_narrows_the_other_parameters_and_a_wrong_one_is_in_tension(context, diagnosis_surfaces, hidden):
    from skin_indent.diagnosis import diagnose

    data = hidden["v02_layer_soft_base"]  # a 1.0 mm layer of 25 kPa over 4 kPa (answer key)
    kw = dict(candidates=("layer",), add=("layer",), max_rungs=0, context=context, in_loop=False)
    free = diagnose(data, **kw).current
    known = diagnose(data, priors={"thickness_mm": (1.0, 0.05)}, **kw)
    told = known.current
    for name in ("E_kPa", "ratio"):
        assert told.std[name] < free.std[name], name
    s = told.priors["thickness_mm"]
    assert not s["in_tension"] and s["posterior_sd"] < 0.05
    assert "what you know, thickness_mm" in known.report()
    # a prior 5 sd (prior and data alone combined) from the truth: the data disagree with it
    off = 5 * math.hypot(free.std["thickness_mm"], 0.05)
    wrong = diagnose(data, priors={"thickness_mm": (1.0 + off, 0.05)}, **kw)
    said = wrong.current.priors["thickness_mm"]
    assert said["in_tension"]
    # the prior determines the posterior (4 times narrower than the data): the fit without it decided
    assert said["determined_by"] == "prior" and abs(said["data_alone"] - free.parameters["thickness_mm"]) < 0.1 * off
    assert "IN TENSION" in wrong.report()
    assert wrong.to_dict()["current"]["priors"]["thickness_mm"]["in_tension"] is True


# ----------------------------------------------------------------------------- the command line
@pytest.fixture(scope="module")
def two_files(two_spheres, tmp_path_factory):
    folder = tmp_path_factory.mktemp("sample")
    paths = []
    for m in two_spheres:
        path = folder / f"{m.source}.csv"
        save_csv(m, path)
        paths.append(path)
    return paths


def test_fit_sample_on_the_command_line(two_files, gallery_cache, coarse_unit_surfaces, tmp_path, capsys,
                                        monkeypatch):
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(gallery_cache))
    a, b = (str(p) for p in two_files)
    assert main(["fit", a, b, "--sample", "--json", "--plot", str(tmp_path), "-q"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["rms_mN"]) == 2 and [c["data"] for c in out["curves"]] == [p.name for p in two_files]
    assert [c["radius_mm"] for c in out["curves"]] == [6.22, 3.11]  # each file's own sphere
    assert max(c["misfit"] for c in out["curves"]) < 1.3
    assert [i["sha256"] for i in out["provenance"]["inputs"]][:2] and len(out["provenance"]["inputs"]) == 2
    figure = tmp_path / f"{two_files[0].stem}+{two_files[1].stem}.png"
    assert figure.is_file()
    table = tmp_path / f"{two_files[0].stem}+{two_files[1].stem}.csv"
    rows = [line for line in table.read_text().splitlines() if not line.startswith("#")]
    assert rows[0].startswith("curve,depth_mm") and len(rows) == 1 + 200
    # the table's residuals are the fit's
    residual = np.array([float(r.split(",")[4]) for r in rows[1:]])
    np.testing.assert_allclose(residual, out["residuals_mN"], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("argv, message", [
    (["fit", "{a}", "--sample"], "give at least two"),
    (["fit", "{a}", "{b}", "--sample", "--radius", "1,2,3"], "3 values for 2 files"),
    (["fit", "{a}", "{b}", "--sample", "--window", "0:0.5"], "not taken with --sample"),
    (["fit", "{a}", "--radius", "1,2"], "go with --sample"),
    (["diagnose", "{a}", "{b}", "--sample", "--prior", "thickness=1:0.1"], "not a parameter"),
    (["diagnose", "{a}", "{b}", "--sample", "--fix", "offset_mm[3]=0"], "not a parameter"),
])
def test_sample_options_are_refused_in_one_line(two_files, argv, message, capsys):
    a, b = (str(p) for p in two_files)
    assert main([x.format(a=a, b=b) for x in argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


# ----------------------------------------------------------------------------- the checks (slow)
def _diagnose_pair(ms, cache, **kw):
    from skin_indent.diagnosis import diagnose

    return diagnose(ms, context=_context(cache), **kw)


def _within_noise(d):
    return all(rms <= 1.3 * math.sqrt(s**2 + (0.003 * float(np.max(np.abs(c.force_mN)))) ** 2)
               for rms, s, c in zip(d.current.curve_rms_mN, d.noises_mN, d.curves))


@pytest.mark.slow
def test_two_layers_seen_with_two_spheres_are_two_layers(tmp_path):
    # a dermis (1 mm, 15 kPa) over a hypodermis (2 mm, 3 kPa) over muscle three times stiffer than the hypodermis
    theta = {"E_kPa": 15.0, "nu": 0.45, "thickness_mm": 1.0, "ratio": 0.2, "thickness2_mm": 2.0, "ratio2": 3.0}
    ms = [curve(("layer", "layer"), theta, R, seed=31 + i, name="twolayers") for i, R in enumerate((6.22, 2.0))]
    d = _diagnose_pair(ms, tmp_path)
    assert d.verdict == "layer+layer", d.report()
    assert _within_noise(d), d.report()


@pytest.mark.slow
def test_stiffening_seen_with_two_spheres_is_stiffening_not_a_layer(tmp_path):
    theta = {"E_kPa": 10.0, "nu": 0.45, "C20_kPa": 30.0}
    ms = [curve(("stiffening",), theta, R, seed=41 + i, name="stiff") for i, R in enumerate((6.22, 2.0))]
    d = _diagnose_pair(ms, tmp_path)
    assert d.verdict == "stiffening", d.report()


@pytest.mark.slow
def test_layer_and_stiffening_seen_with_two_spheres_are_both_named(tmp_path):
    # one sphere cannot tell this sample from a thinner layer without stiffening (test_ladder.py); two
    # can: measured 469 s from an empty cache, layer+stiffening at (0.029, 0.029) mN against noise
    # (0.029, 0.027), thickness 1.50 +- 0.29 mm
    theta = {"E_kPa": 8.0, "nu": 0.47, "thickness_mm": 1.5, "ratio": 0.3, "C20_kPa": 16.0}
    ms = [curve(("layer", "stiffening"), theta, R, seed=61 + i, name="layerstiff") for i, R in enumerate((6.22, 2.0))]
    d = _diagnose_pair(ms, tmp_path)
    assert d.verdict == "layer+stiffening", d.report()
    assert _within_noise(d), d.report()
    t, sd = d.current.parameters["thickness_mm"], d.current.std["thickness_mm"]
    assert abs(t - theta["thickness_mm"]) < 3 * sd, d.report()


@pytest.mark.slow
def test_a_clean_half_space_seen_with_two_spheres_needs_nothing(tmp_path):
    theta = {"E_kPa": 10.0, "nu": 0.45}
    ms = [curve((), theta, R, seed=51 + i, name="clean") for i, R in enumerate((6.22, 2.0))]
    d = _diagnose_pair(ms, tmp_path)
    assert d.verdict == "none" and len(d.ladder) == 1, d.report()


@pytest.mark.slow
def test_the_forearm_like_pair_is_two_layers_explained_to_the_noise(tmp_path):
    ms = [load_csv(DATA / "invivo-like" / "forearm_like.csv", radius_mm=6.22),
          load_csv(DATA / "invivo-like" / "forearm_like_R3.11mm.csv")]
    assert ms[1].radius_mm == pytest.approx(3.11)
    d = _diagnose_pair(ms, tmp_path)
    assert d.verdict == "layer+layer", d.report()
    assert _within_noise(d), d.report()


def test_plan_of_two_curves_adds_a_third_measurement_to_both(context, diagnosis_surfaces):
    """A relaxation time that a ramp with a short hold leaves undetermined, recorded twice (two curves of one
    sample, each its own noise): the plan's candidates are fitted with both curves, so the same sphere once
    more brings the standard deviations of the two curves to sqrt(2/3) of theirs (information 2 -> 3), while
    a long hold determines the time better."""
    from skin_indent import diagnose, plan
    from skin_indent.diagnosis.planning import recorded

    proto = Protocol.ramp(0.6, 60, 0.02, hold_s=5.0, hold_points=10)
    theta = {"E_kPa": 8.0, "nu": 0.47, "g1": 0.3, "tau1_s": 60.0}
    clean = Model(("viscoelastic",)).simulate(theta, protocol=proto, mesh="coarse")
    ms = [measurement_from_arrays(clean.depth_mm, clean.force_mN + np.random.default_rng(s).normal(0, 0.05, 70),
                                  clean.time_s, source=f"relaxing{s}", radius_mm=6.22) for s in (5, 6)]
    d = diagnose(ms, candidates=("viscoelastic",), in_loop=False, max_rungs=1, context=context)
    assert d.verdict == "viscoelastic" and "tau1_s" in d.not_determined, d.report()
    p = plan(d, radii=(), hold_s=120.0, context=context)
    assert [c.source for c, _ in recorded(d)] == ["relaxing5", "relaxing6"]
    by_kind = {a.candidate.kind: a for a in p.ranking}
    same = by_kind["sphere"]
    assert same.candidate.reference and same.error is None
    # the third curve is like the first (its noise): the information of tau grows by the first curve's share
    assert same.std["tau1_s"] < p.recorded_std["tau1_s"]
    assert same.std["tau1_s"] == pytest.approx(p.recorded_std["tau1_s"] * math.sqrt(2 / 3), rel=0.1)
    assert by_kind["hold"].std["tau1_s"] < same.std["tau1_s"], p.report()
