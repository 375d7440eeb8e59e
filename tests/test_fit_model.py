"""Fitting the model the user chooses, with what they know: values held and Gaussian priors.

The checks: priors in least squares against the closed-form Gaussian posterior of a linear
model; a bonded layer recovered from an independent code's curve with the thickness held
or given as a prior; a wrong prior reported as in tension with the data; the reduced
chi-square about 1 where the model explains the curve and far above where an effect is
missing; one fit, one set of numbers in ``fit(model=...)`` and on a diagnosis's ladder; the
command line (``--model``, ``--fix``, ``--prior``; refusals in one line) and the batch table.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from _data import DATA
from skin_indent.cli import main
from skin_indent.fitting import fit
from skin_indent.fitting.knowledge import needs_data_alone, prior_summary
from skin_indent.inverse import fit_least_squares

#: the hidden-effect curves were made with this noise (tests/data/hidden-effects/README.md)
NOISE = 0.05
#: the layer of v02_layer_soft_base: 1.0 mm, E = 25 kPa, nu = 0.45 over E = 4 kPa
LAYER = {"thickness_mm": 1.0, "E_kPa": 25.0, "ratio": 4.0 / 25.0}


@pytest.fixture(scope="module")
def cache(gallery_cache, diagnosis_surfaces):
    """The gallery cache with the coarse surfaces of the 0.6 mm hidden-effect curves."""
    return gallery_cache


class Line:
    """F = a h + b: a linear force model, for closed-form posteriors."""

    parameter_names = ("a", "b")
    bounds = (np.array([-1e3, -1e3]), np.array([1e3, 1e3]))

    def force(self, h, theta):
        return theta[0] * np.asarray(h) + theta[1]

    def jacobian(self, h, theta):
        return np.stack([np.asarray(h), np.ones_like(h)], axis=1)


def test_a_prior_enters_least_squares_as_the_gaussian_posterior_of_a_linear_model():
    rng = np.random.default_rng(3)
    h = np.linspace(0.0, 1.0, 30)
    sigma = 0.2
    F = 2.0 * h + 0.5 + rng.normal(0, sigma, h.size)
    mean, sd = 1.5, 0.1  # a prior on the slope
    r = fit_least_squares(Line(), h, F, [1.0, 0.0], noise_mN=sigma, coordinates="linear",
                          priors=[(lambda theta: theta[0], mean, sd)])
    # closed form: precision = J^T J / sigma^2 + e1 e1^T / sd^2
    J = np.stack([h, np.ones_like(h)], axis=1)
    P = J.T @ J / sigma**2 + np.diag([1 / sd**2, 0.0])
    post = np.linalg.solve(P, J.T @ F / sigma**2 + np.array([mean / sd**2, 0.0]))
    cov = np.linalg.inv(P)
    assert r.parameters["a"] == pytest.approx(post[0], rel=1e-6)
    assert r.parameters["b"] == pytest.approx(post[1], rel=1e-6)
    assert r.std["a"] == pytest.approx(math.sqrt(cov[0, 0]), rel=1e-5)
    assert r.covariance_source == "jacobian+priors"
    assert r.info["prior_chi2"] == pytest.approx(((post[0] - mean) / sd) ** 2, rel=1e-5)
    # the posterior sd is the prior's narrowed by the data
    assert r.std["a"] < sd
    with pytest.raises(ValueError, match="noise"):
        fit_least_squares(Line(), h, F, [1.0, 0.0], priors=[(lambda theta: theta[0], mean, sd)])


def test_weighted_least_squares_is_the_closed_form_generalised_fit_of_a_linear_model():
    rng = np.random.default_rng(4)
    h = np.linspace(0.0, 1.0, 40)
    sigma = 0.05 + 0.3 * h  # an error model growing with the force
    F = 2.0 * h + 0.5 + rng.normal(0, sigma)
    r = fit_least_squares(Line(), h, F, [1.0, 0.0], sigma_mN=sigma, coordinates="linear")
    J = np.stack([h, np.ones_like(h)], axis=1)
    W = np.diag(1 / sigma**2)
    cov = np.linalg.inv(J.T @ W @ J)
    best = cov @ J.T @ W @ F
    assert r.parameters["a"] == pytest.approx(best[0], rel=1e-6)
    assert r.parameters["b"] == pytest.approx(best[1], rel=1e-6)
    assert r.std["a"] == pytest.approx(math.sqrt(cov[0, 0]), rel=1e-5)
    assert r.chi2 == pytest.approx(float(np.sum(((F - J @ best) / sigma) ** 2)), rel=1e-6)
    assert r.covariance_source == "weighted jacobian"
    # the same at AFM scale (forces in nN, run in another force unit): nothing depends on the unit
    s = fit_least_squares(Line(), h, F * 1e-6, [1e-6, 0.0], sigma_mN=sigma * 1e-6, coordinates="linear")
    assert s.parameters["a"] == pytest.approx(best[0] * 1e-6, rel=1e-6)
    assert s.chi2 == pytest.approx(r.chi2, rel=1e-6)


def test_prior_summary_says_who_determined_a_parameter_and_flags_tension():
    by_data = prior_summary(1.0, 0.01, 1.02, 0.1)
    assert by_data["determined_by"] == "data" and not by_data["in_tension"]
    assert by_data["narrowed"] == pytest.approx(0.1)
    assert prior_summary(1.0, 0.099, 1.0, 0.1)["determined_by"] == "prior"
    # the data alone say 1.5 +- 0.05 against a prior 1.0 +- 0.1: 4.5 combined sd apart
    info = 1 / 0.05**2 + 1 / 0.1**2
    post, post_sd = (1.5 / 0.05**2 + 1.0 / 0.1**2) / info, info**-0.5
    s = prior_summary(post, post_sd, 1.0, 0.1)
    assert s["tension_sd"] == pytest.approx(0.5 / math.hypot(0.05, 0.1), rel=1e-9)
    assert s["in_tension"] and not needs_data_alone(s)  # the data determine it: the linearisation holds
    # a prior that determines the parameter: a shift of 0.67 prior sd extrapolates to 5 combined sd; the
    # fit without the prior decides (here it says 1.02 +- 0.7: no tension)
    weak = prior_summary(1.067, 0.0991, 1.0, 0.1)
    assert weak["determined_by"] == "prior" and weak["in_tension"] and needs_data_alone(weak)
    checked = prior_summary(1.067, 0.0991, 1.0, 0.1, alone=(1.02, 0.7))
    assert checked["tension_sd"] == pytest.approx(0.02 / math.hypot(0.7, 0.1), rel=1e-9)
    assert not checked["in_tension"] and checked["data_alone"] == 1.02


def test_a_layer_with_its_thickness_held_is_recovered_from_an_independent_code(hidden, cache, context):
    r = fit(hidden["v02_layer_soft_base"], model="neo-hooke+layer", fixed={"thickness_mm": 1.0, "nu": 0.45},
            noise_mN=NOISE, context=context, mesh="coarse")
    assert r.model == "neo-hooke+layer"
    assert r.parameters["thickness_mm"] == 1.0 and "thickness_mm" not in r.std  # held: no sd
    for name in ("E_kPa", "ratio"):
        assert abs(r.parameters[name] - LAYER[name]) < 3 * r.std[name], name
    assert 0.6 < r.redchi < 1.5  # the model explains the curve: chi-square about its dof
    assert r.quality["white"] and not r.flags


def test_a_thickness_prior_is_narrowed_by_the_data_and_a_wrong_one_is_in_tension(hidden, cache, context):
    curve = hidden["v02_layer_soft_base"]
    r = fit(curve, model="neo-hooke+layer", fixed={"nu": 0.45}, priors={"thickness_mm": (1.0, 0.1)},
            noise_mN=NOISE, context=context, mesh="coarse")
    s = r.priors["thickness_mm"]
    assert s["posterior_sd"] <= s["prior_sd"]
    assert r.std["thickness_mm"] == s["posterior_sd"]
    for name in ("E_kPa", "ratio", "thickness_mm"):
        assert abs(r.parameters[name] - LAYER[name]) < 3 * r.std[name], name
    assert not s["in_tension"] and not r.flags
    # a prior on the other parameters narrows them too: against the free thickness
    free = fit(curve, model="neo-hooke+layer", fixed={"nu": 0.45}, noise_mN=NOISE, context=context, mesh="coarse")
    assert r.std["E_kPa"] < free.std["E_kPa"]
    # 1.6 mm +- 0.1: the data say ~1 mm
    wrong = fit(curve, model="neo-hooke+layer", fixed={"nu": 0.45}, priors={"thickness_mm": (1.6, 0.1)},
                noise_mN=NOISE, context=context, mesh="coarse")
    assert wrong.priors["thickness_mm"]["in_tension"]
    assert any("thickness_mm: the prior" in f for f in wrong.flags)


def test_the_reduced_chi_square_tells_a_curve_the_model_misses(hidden, cache, context):
    clean = fit(hidden["v01_clean"], model="neo-hooke", noise_mN=NOISE, context=context, mesh="coarse")
    assert 0.6 < clean.redchi < 1.5
    missing = fit(hidden["v02_layer_soft_base"], model="neo-hooke", noise_mN=NOISE, context=context, mesh="coarse")
    assert missing.redchi > 5
    # the paper's identification (its window): its sd, chi-square and quality against the same independent noise
    paper = fit(hidden["v01_clean"], window=(0.0, 0.6), noise_mN=NOISE, context=context, mesh="coarse")
    assert paper.noise_mN == paper.quality["noise_mN"] == NOISE
    assert 0.6 < paper.redchi < 1.5


def test_a_model_fitted_alone_and_on_the_ladder_is_one_fit(hidden, cache, context):
    from skin_indent.diagnosis import diagnose

    curve = hidden["v02_layer_soft_base"]
    d = diagnose(curve, add=("layer",), max_rungs=0, in_loop=False, context=context, mesh="coarse")
    rung = d.ladder[-1]
    r = fit(curve, model="neo-hooke+layer", context=context, mesh="coarse", in_loop=False)
    assert r.rms_mN == pytest.approx(rung.rms_mN, rel=1e-6)
    assert r.noise_mN == pytest.approx(d.noise_mN, rel=1e-12)
    for k, v in rung.parameters.items():
        assert r.parameters[k] == pytest.approx(v, rel=1e-6), k
        assert r.std[k] == pytest.approx(rung.std[k], rel=1e-6), k


def test_fit_is_the_neo_hookean_fit_and_the_diagnosis_first_rung(hidden, cache, context):
    """One fit, one result: ``fit(m)`` is ``fit(m, model="neo-hooke")`` and the diagnosis's first rung, to the
    last digit (parameters, sd, chi-square); the BIC is one statistic, at the effective sample size it
    states: the rung's at the diagnosis's, the fit's at its own, each the other's at the other's ``n_eff``."""
    from skin_indent.diagnosis import diagnose
    from skin_indent.fitting.error_model import score

    curve = hidden["v01_clean"]
    plain = fit(curve, context=context)
    named = fit(curve, model="neo-hooke", context=context)
    rung = diagnose(curve, max_rungs=0, in_loop=False, context=context, mesh="coarse").ladder[0]
    assert plain.model == named.model == rung.model == "neo-hooke"
    assert type(plain) is type(named) is type(rung)  # one result type: the fit is the rung, its curve bound
    for r in (named, rung):
        assert r.parameters == plain.parameters and r.std == plain.std
        assert r.chi2 == plain.chi2 and r.noise_mN == plain.noise_mN
        assert np.array_equal(r.prediction_mN, plain.prediction_mN) and r.ended == plain.ended
    assert plain.structure == rung.structure and plain.white == rung.white
    assert plain.curve_rms_mN == rung.curve_rms_mN and plain.rms_of_curves == rung.rms_of_curves
    assert len(plain.prepared) == len(plain.curves) == 1 and plain.data is plain.prepared[0]
    assert np.allclose(plain.prediction_mN, curve_force(plain), rtol=0, atol=1e-12)
    assert plain.bic == named.bic and plain.n_eff == named.n_eff
    assert plain.at(rung.n_eff).bic == pytest.approx(rung.bic, rel=1e-12)
    assert rung.at(plain.n_eff).bic == pytest.approx(plain.bic, rel=1e-12)
    # the score by its formula: the chi-square against the error model, k ln n_eff
    assert plain.bic == pytest.approx(score(plain.chi2, 2, plain.n_points, plain.n_eff)[1], rel=1e-12)
    assert plain.chi2 == pytest.approx(float(np.sum((plain.residuals_mN / np.sqrt(
        plain.noise_mN**2 + (0.003 * (curve_force(plain))) ** 2)) ** 2)), rel=1e-9)
    # the paper's identification is an option of the same fit (the loading segment, the noise alone)
    paper = fit(curve, method="ekf", context=context, mesh="coarse")
    assert paper.error_model["model_error"] == 0.0 and paper.n_points < plain.n_points


def curve_force(result) -> np.ndarray:
    """The model's force at a fit's points (mN): measured minus residual."""
    return result.data.force_mN - result.residuals_mN


def test_cli_fits_a_chosen_model_with_a_held_thickness_and_a_prior(cache, capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(cache))
    path = DATA / "hidden-effects" / "v02_layer_soft_base.csv"
    assert main(["fit", str(path), "--model", "neo-hooke+layer", "--fix", "thickness_mm=1.0", "--fix", "nu=0.45",
                 "--noise", "0.05", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["model"] == "neo-hooke+layer"
    assert out["parameters"]["thickness_mm"] == 1.0
    assert abs(out["parameters"]["E_kPa"] - 25.0) < 3 * out["std"]["E_kPa"]
    assert out["provenance"]["settings"]["model"] == "neo-hooke+layer"
    assert main(["fit", str(path), "--model", "neo-hooke+layer", "--prior", "thickness_mm=1.0:0.1",
                 "--fix", "nu=0.45", "--noise", "0.05"]) == 0
    text = capsys.readouterr().out
    assert "thickness_mm: prior 1 +- 0.1, posterior" in text
    # refusals: one line, exit 2
    for argv, message in ((["--model", "neo-hooke+layer", "--method", "ekf"], "needs least squares"),
                          (["--model", "neo-hooke+layer", "--fix", "bogus=1"], "bogus: not a parameter"),
                          (["--model", "mooney+layer"], "starts with neo-hooke"),
                          (["--model", "neo-hooke+layer", "--window", "0:0.5"], "--window"),
                          (["--prior", "thickness_mm=1"], "NAME=MEAN:SD")):
        assert main(["fit", str(path), *argv]) == 2, argv
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, err


def test_a_batch_of_a_chosen_model_tabulates_its_parameters(cache, tmp_path, monkeypatch):
    from skin_indent.batch import fit_many
    from skin_indent.report.batch_table import write_tsv
    from skin_indent.runtime.context import Context

    folder = tmp_path / "curves"
    folder.mkdir()
    for name in ("v02_layer_soft_base", "v03_layer_rigid_base"):
        (folder / f"{name}.csv").write_bytes((DATA / "hidden-effects" / f"{name}.csv").read_bytes())
    (folder / "broken.csv").write_text("depth_mm,force_mN\n0.1,nan\n")
    rows = fit_many(folder, model="neo-hooke+layer", fixed={"nu": 0.45}, mesh="coarse",
                    context=Context(cache_dir=cache, workers=1), progress=False)
    by = {Path(r.file).name: r for r in rows}
    assert by["broken.csv"].error
    for name in ("v02_layer_soft_base.csv", "v03_layer_rigid_base.csv"):
        assert not by[name].error and by[name].model == "neo-hooke+layer"
        assert "thickness_mm" in by[name].parameters
    path = write_tsv(rows, tmp_path / "rows.tsv")
    header = [line for line in path.read_text().splitlines() if not line.startswith("#")][0].split("\t")
    assert {"model", "thickness_mm", "thickness_mm_sd", "ratio", "ratio_sd"} <= set(header)
    with pytest.raises(ValueError, match="window"):
        fit_many(folder, model="neo-hooke+layer", window=(0, 0.5), context=Context(cache_dir=cache, workers=1))


def test_a_load_unload_fit_of_a_chosen_model_is_plotted_and_tabulated_whole(hidden, cache, context, tmp_path):
    from skin_indent.report.fit_figure import fit_arrays, plot_fit, write_fit_csv
    from skin_indent.measurement import load_csv

    r = fit(hidden["v06_viscoelastic"], model="neo-hooke+viscoelastic", noise_mN=NOISE, context=context,
            mesh="coarse")
    assert r.data.has("retract") and r.n_points == r.data.n == 200
    a = fit_arrays(r)
    assert a["residual_mN"].size == 200
    np.testing.assert_allclose(a["force_mN"] - a["model_mN"], r.residuals_mN)
    plot_fit(r, tmp_path / "fit.png")
    write_fit_csv(r, tmp_path / "fit.csv", {"version": "test"})
    back = load_csv(tmp_path / "fit.csv")
    assert back.n_points == 200


