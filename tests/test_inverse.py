"""Tests of skin_indent.inverse on the analytic stand-in (tests/analytic_model.py).

Blind tests after Delalleau et al. (2006), Tables 1-2; agreement of the methods;
fixed parameters; noise and covariance estimates against Monte Carlo; profile
intervals; input validation. Whole file: a few seconds.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analytic_model import HertzLikeModel, PureHertzModel
from skin_indent.inverse import (
    IdentificationResult,
    Parameter,
    ParameterSet,
    blind_test_cases,
    estimate_noise,
    fit_ekf,
    fit_ekf_paper,
    fit_least_squares,
    format_table,
    hertz_equivalence,
    profile,
    run_blind_tests,
)

pytestmark = pytest.mark.filterwarnings("error")  # the algorithms must be warning-free

H = np.linspace(0.006, 0.6, 100)  # the paper's 100 points up to 600 um
FITTERS = {"ekf-paper": fit_ekf_paper, "ekf": fit_ekf, "lsq": fit_least_squares}


@pytest.fixture(scope="module")
def model():
    return HertzLikeModel()


class RecordingModel(HertzLikeModel):
    """Stand-in that records every theta it is called with."""

    def __init__(self):
        super().__init__()
        self.thetas = []

    def force(self, depth_mm, theta):
        self.thetas.append(np.array(theta, float))
        return super().force(depth_mm, theta)

    def jacobian(self, depth_mm, theta):
        self.thetas.append(np.array(theta, float))
        return super().jacobian(depth_mm, theta)


def _noisy(model, truth, sigma, seed, h=H):
    return model.force(h, truth) + np.random.default_rng(seed).normal(0.0, sigma, h.size)


# ------------------------------------------------------------------------------ blind tests
@pytest.mark.parametrize("method", ["lsq", "ekf"])
def test_blind_tables_fast_methods(model, method):
    rows = run_blind_tests(model, [method])
    assert len(rows) == 13
    bad = [(r["truth"], r["start"], r["E"], r["nu"], r["iterations"], r["first_in_band"]) for r in rows
           if not r["in_band"]]
    assert not bad, bad
    for r in rows:  # |dE|/E <= 0.1 %, |dnu| <= 0.002 within 10 sweeps / evaluations
        assert abs(r["dE"]) / r["truth"][0] <= 1e-3 and abs(r["dnu"]) <= 2e-3
        assert r["first_in_band"] <= 10
    if method == "ekf":
        assert max(r["iterations"] for r in rows) <= 10


def test_blind_ekf_paper_subset(model):
    """Paper-faithful filter: hundreds of (odd) sweeps, in the paper's band, paper's trends."""
    cases = [c for c in blind_test_cases() if (c["table"], c["case"]) in {(1, 1), (2, 6)}]
    rows = run_blind_tests(model, ["ekf-paper"], cases=cases)
    by = {(r["table"], r["case"]): r for r in rows}
    for r in rows:
        assert r["in_band"], r
        assert r["status"] == 1 and r["iterations"] % 2 == 1
        assert abs(r["dE"]) <= 0.1 and abs(r["dnu"]) <= 0.005
    # Table 1, case 1: the paper needs 235 sweeps
    assert 150 <= by[(1, 1)]["iterations"] <= 400
    # stiff skin (61 kPa, 0.4) converges much faster (paper: 131 sweeps)
    assert by[(2, 6)]["iterations"] < 0.6 * by[(1, 1)]["iterations"]
    text = format_table(rows)
    assert "paper: sweeps" in text and "235" in text and "ekf-paper" in text


def test_ekf_paper_first_pass_behaviour(model):
    """E reaches plausible values at once; nu moves slowly (paper Figs. 6-7)."""
    z = model.force(H, (31, 0.4))
    res = fit_ekf_paper(model, H, z, (10, 0.3), max_sweeps=3)
    first = res.history["first_pass"]
    assert first.shape == (100, 2) and res.history["first_pass_covariance"].shape == (100, 2, 2)
    assert np.all(first[10:, 0] > 30.0)          # E jumped close to the E*-matching value
    assert 0.3 < first[-1, 1] < 0.33              # nu barely moved in one pass
    assert res.history["sweeps"].shape == (4, 2)  # start + 3 sweeps
    assert np.allclose(res.history["sweeps"][0], [10, 0.3])
    assert res.status == 0 and "max sweeps" in res.message and not res.success


def test_ekf_paper_keeping_covariance_stalls(model):
    """Q = 0 and P kept across sweeps: the gain decays, nu stalls (documented choice)."""
    z = model.force(H, (31, 0.4))
    reset = fit_ekf_paper(model, H, z, (10, 0.3), max_sweeps=41)
    kept = fit_ekf_paper(model, H, z, (10, 0.3), max_sweeps=41, keep_covariance=True)
    assert abs(kept.parameters["nu"] - 0.4) > 3 * abs(reset.parameters["nu"] - 0.4)


# ----------------------------------------------------------------------- methods agree
def test_methods_agree_noiseless(model):
    truth = (45.0, 0.33)
    z = model.force(H, truth)
    lsq = fit_least_squares(model, H, z, (20, 0.45))
    ekf = fit_ekf(model, H, z, (20, 0.45))
    for r in (lsq, ekf):
        assert r.success
        assert r.parameters["E_kPa"] == pytest.approx(truth[0], rel=1e-6)
        assert r.parameters["nu"] == pytest.approx(truth[1], abs=1e-6)
        assert r.rms_mN < 1e-6


def test_ekf_and_lsq_agree_on_noisy_data(model):
    z = _noisy(model, (31, 0.4), 0.01, seed=3)
    lsq = fit_least_squares(model, H, z, (10, 0.3), noise_mN=0.01)
    ekf = fit_ekf(model, H, z, (10, 0.3), noise_mN=0.01)
    for name in ("E_kPa", "nu"):  # the iterated (sweep-linearised) EKF lands on the LSQ optimum
        assert abs(ekf.parameters[name] - lsq.parameters[name]) < 1e-3 * lsq.std[name]
        assert ekf.std[name] == pytest.approx(lsq.std[name], rel=0.15)
    assert ekf.success and ekf.iterations <= 10 and "sweep" in ekf.info["sweep_modes"]
    assert ekf.covariance_source == "filter" and lsq.covariance_source == "jacobian"
    np.testing.assert_allclose(ekf.info["covariance_jacobian"], lsq.covariance, rtol=0.05)
    # identical fit statistics when the estimates are the same
    assert ekf.aic_ml == pytest.approx(lsq.aic_ml, abs=0.01) and ekf.bic_ml == pytest.approx(lsq.bic_ml, abs=0.01)


def test_optimum_on_the_bound(model):
    """nu beyond the box: both methods stop on the bound, agree, and say so."""
    box = HertzLikeModel(upper=(100.0, 0.38))
    z = _noisy(model, (31, 0.45), 0.01, seed=0)
    lsq = fit_least_squares(box, H, z, (10, 0.3))
    ekf = fit_ekf(box, H, z, (10, 0.3))
    for r in (lsq, ekf):
        assert r.success and r.parameters["nu"] == pytest.approx(0.38, abs=1e-9)
        assert "at bound: nu" in r.message
    assert ekf.parameters["E_kPa"] == pytest.approx(lsq.parameters["E_kPa"], rel=1e-6)
    assert ekf.covariance_source == "jacobian"  # no filter variance for a held parameter


# --------------------------------------------------------------------- fixed parameters
@pytest.mark.parametrize("method", list(FITTERS))
def test_fixed_parameter_is_honoured(method):
    m = RecordingModel()
    z = m.force(H, (31, 0.4))
    m.thetas.clear()
    kwargs = {"max_sweeps": 50} if method == "ekf-paper" else {}
    res = FITTERS[method](m, H, z, (10, 0.3), fixed={"nu": 0.45}, **kwargs)
    assert res.free_names == ("E_kPa",) and res.fixed_names == ("nu",)
    assert res.parameters["nu"] == 0.45 and set(res.std) == {"E_kPa"}
    assert res.covariance.shape == (1, 1)
    thetas = np.array(m.thetas)
    assert thetas.shape[1] == 2 and np.all(thetas[:, 1] == 0.45)  # full theta, nu held
    # E compensates through E* = E / (1 - nu^2): 31 / 0.84 * (1 - 0.45^2) = 29.4
    ref = fit_least_squares(HertzLikeModel(), H, z, (10, 0.3), fixed={"nu": 0.45})
    assert res.parameters["E_kPa"] == pytest.approx(ref.parameters["E_kPa"], abs=1e-3)
    assert res.parameters["E_kPa"] == pytest.approx(31 / 0.84 * (1 - 0.45**2), rel=0.01)


def test_parameter_set():
    ps = ParameterSet.from_model(HertzLikeModel(), {"E_kPa": 20.0}, fixed={"nu": 0.3})
    assert ps.names == ("E_kPa", "nu") and ps.free_names == ("E_kPa",)
    assert ps["E_kPa"].unit == "kPa" and ps["nu"].unit == "" and ps["nu"].fixed
    np.testing.assert_array_equal(ps.to_array(), [20.0])
    np.testing.assert_array_equal(ps.full(np.array([25.0])), [25.0, 0.3])
    ps2 = ps.free("nu").fix("E_kPa", 50.0)
    assert ps2.free_names == ("nu",) and ps2["E_kPa"].value == 50.0
    assert ps.from_array([30.0])["E_kPa"].value == 30.0 and ps["E_kPa"].value == 20.0  # immutable
    with pytest.raises(ValueError, match="outside bounds"):
        ps.from_array([300.0])
    with pytest.raises(ValueError):
        Parameter("x", 2.0, 0.0, 1.0)


# ------------------------------------------------------------------------- uncertainty
def test_estimate_noise():
    h = np.linspace(0.006, 0.6, 300)
    smooth = 4 / 3 * 36.9 * math.sqrt(6.22) * h**1.5
    rng = np.random.default_rng(7)
    assert estimate_noise(h, smooth + rng.normal(0, 0.05, h.size)) == pytest.approx(0.05, rel=0.15)
    # 100 points, several realisations: unbiased within a few %
    est = [estimate_noise(H, 50 * H**1.5 + rng.normal(0, 0.05, H.size)) for _ in range(20)]
    assert np.mean(est) == pytest.approx(0.05, rel=0.08)
    assert estimate_noise(h, smooth) < 1e-6
    # robust: a few spikes barely matter
    y = smooth + rng.normal(0, 0.05, h.size)
    y[[30, 120, 250]] += 2.0
    assert estimate_noise(h, y) == pytest.approx(0.05, rel=0.2)


@settings(max_examples=25, deadline=None)
@given(scale=st.floats(0.01, 100.0), a=st.floats(-5, 5), b=st.floats(-5, 5), c=st.floats(-5, 5))
def test_estimate_noise_invariances(scale, a, b, c):
    """sigma scales with the force and ignores any added cubic (it is cancelled exactly)."""
    h = np.linspace(0.01, 0.6, 60)
    y = 20 * h**1.5 + np.random.default_rng(1).normal(0, 0.05, h.size)
    s0 = estimate_noise(h, y)
    assert estimate_noise(h, scale * y) == pytest.approx(scale * s0, rel=1e-6)
    assert estimate_noise(h, y + a + b * h + c * h**3) == pytest.approx(s0, rel=1e-6)


def test_lsq_covariance_matches_monte_carlo(model):
    truth, sigma = (31.0, 0.4), 0.05
    fits = [fit_least_squares(model, H, _noisy(model, truth, sigma, seed), (20, 0.35)) for seed in range(50)]
    est = np.array([[f.parameters["E_kPa"], f.parameters["nu"]] for f in fits])
    reported = np.median([[f.std["E_kPa"], f.std["nu"]] for f in fits], axis=0)
    mc = est.std(axis=0, ddof=1)
    np.testing.assert_allclose(reported, mc, rtol=0.3)
    assert np.median([f.noise_mN for f in fits]) == pytest.approx(sigma, rel=0.1)
    assert np.mean([f.correlation[0, 1] for f in fits]) < -0.99  # the E*-valley


def test_profile_contains_truth_on_noisy_data(model):
    z = _noisy(model, (31, 0.4), 0.01, seed=11)
    prof = profile(model, H, z, "nu", noise_mN=0.01, n_values=21)
    lo, hi = prof.interval_95
    assert lo < 0.4 < hi and prof.identifiable and prof.verdict.startswith("identifiable")
    assert prof.interval_68[0] > lo and prof.interval_68[1] < hi
    assert np.min(prof.delta_chi2) == 0.0 and prof.values[0] == 0.2 and prof.values[-1] == 0.49
    # the profile half-width matches the least-squares standard error (parabolic profile)
    lsq = fit_least_squares(model, H, z, (20, 0.3), noise_mN=0.01)
    assert 0.5 * (prof.interval_68[1] - prof.interval_68[0]) == pytest.approx(lsq.std["nu"], rel=0.2)
    assert 0.5 * (hi - lo) == pytest.approx(1.96 * lsq.std["nu"], rel=0.2)
    json.dumps(prof.to_dict())
    assert "delta_chi2" in prof.report()


def test_profile_not_identifiable_with_large_noise(model):
    z = _noisy(model, (31, 0.4), 0.3, seed=5)
    prof = profile(model, H, z, "nu", noise_mN=0.3, n_values=11)
    assert not prof.identifiable
    assert prof.verdict.startswith(("not identifiable", "bounded only from")), prof.verdict
    assert any(prof.open_95)


def test_hertz_equivalence(model):
    z = _noisy(model, (31, 0.4), 0.01, seed=2)
    he = hertz_equivalence(model, H, z, noise_mN=0.01, n_values=9)
    assert he.correlation_E_nu < -0.999
    assert he.E_star_kPa == pytest.approx(31 / 0.84, rel=1e-3)
    assert he.nu_std_given_E < he.nu_std_given_E_star < he.nu_std
    assert 0.9 < he.fraction_through_E_star < 1.0
    pure = PureHertzModel()
    he0 = hertz_equivalence(pure, H, pure.force(H, (31, 0.4)) + z - model.force(H, (31, 0.4)), noise_mN=0.01,
                            n_values=9)
    assert he0.fraction_through_E_star == pytest.approx(1.0) and math.isinf(he0.nu_std_given_E_star)
    assert not he0.profile.identifiable and he0.E_star_spread < 1e-6
    json.dumps(he0.to_dict())


# ------------------------------------------------------------------------------- results
def test_result_dict_and_report(model):
    z = _noisy(model, (31, 0.4), 0.05, seed=4)
    res = fit_least_squares(model, H, z, (10, 0.3))
    assert isinstance(res, IdentificationResult) and res.success and res.method == "lsq"
    d = json.loads(json.dumps(res.to_dict()))
    assert set(d["parameters"]) == {"E_kPa", "nu"} and set(d["std"]) == {"E_kPa", "nu"}
    for key in ("rms_mN", "noise_mN", "chi2", "aic_ml", "bic_ml", "iterations", "status", "message", "method"):
        assert key in d
    n, rss = res.n_points, float(res.residuals_mN @ res.residuals_mN)
    assert res.aic_ml == pytest.approx(n * math.log(2 * math.pi * rss / n) + n + 2 * 3)
    assert res.bic_ml == pytest.approx(n * math.log(2 * math.pi * rss / n) + n + 3 * math.log(n))
    assert res.rms_mN == pytest.approx(math.sqrt(rss / n))
    np.testing.assert_allclose(res.residuals_mN, z - model.force(H, list(res.parameters.values())))
    text = res.report()
    assert "E_kPa" in text and "nu" in text and "C(E_kPa, nu)" in text
    # a wrong fixed nu is worse by AIC
    wrong = fit_least_squares(model, H, z, (10, 0.3), fixed={"nu": 0.2})
    assert wrong.aic_ml > res.aic_ml + 10
    # a perfect fit stays finite and JSON-safe
    exact = fit_ekf(model, H, model.force(H, (31, 0.4)), (10, 0.3))
    assert math.isfinite(exact.aic_ml) and json.dumps(exact.to_dict())


@pytest.mark.parametrize("method", list(FITTERS))
def test_theta_stays_inside_bounds(method):
    """Start in a corner, truth in the opposite corner: the model never sees theta outside its box."""
    m = RecordingModel()  # force() raises outside bounds, like the response surface
    z = m.force(H, (95.0, 0.21))
    kwargs = {"max_sweeps": 15} if method == "ekf-paper" else {}
    FITTERS[method](m, H, z, (1.5, 0.48), **kwargs)
    thetas = np.array(m.thetas)
    lo, hi = m.bounds
    assert np.all(thetas >= lo) and np.all(thetas <= hi)


# ------------------------------------------------------------------------- bad inputs
BAD_INPUTS = {
    "nan in force": (H, np.where(np.arange(100) == 5, np.nan, 1.0), (10, 0.3), None, "NaN"),
    "too few points": (H[:2], np.ones(2), (10, 0.3), None, "at least 3"),
    "x0 outside bounds": (H, np.ones(100), (150, 0.3), None, "outside the model bounds"),
    "nu outside bounds": (H, np.ones(100), (10, 0.5), None, "outside the model bounds"),
    "mismatched lengths": (H, np.ones(99), (10, 0.3), None, "lengths differ"),
    "wrong x0 length": (H, np.ones(100), (10, 0.3, 1.0), None, "3 values"),
    "unknown fixed": (H, np.ones(100), (10, 0.3), {"mu": 1.0}, "unknown parameter"),
    "fixed outside bounds": (H, np.ones(100), (10, 0.3), {"nu": 0.5}, "outside the model bounds"),
    "all fixed": (H, np.ones(100), (10, 0.3), {"nu": 0.3, "E_kPa": 10.0}, "nothing to identify"),
}


@pytest.mark.parametrize("method", list(FITTERS))
@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_inputs_raise_one_line_value_error(model, method, case):
    depth, force, x0, fixed, match = BAD_INPUTS[case]
    with pytest.raises(ValueError, match=match) as err:
        FITTERS[method](model, depth, force, x0, fixed=fixed)
    assert "\n" not in str(err.value)


def test_bad_method_options(model):
    z = model.force(H, (31, 0.4))
    with pytest.raises(ValueError, match="tol"):
        fit_ekf_paper(model, H, z, (10, 0.3), tol=0.0)
    with pytest.raises(ValueError, match="noise_mN"):
        fit_least_squares(model, H, z, (10, 0.3), noise_mN=-1.0)
    with pytest.raises(ValueError, match="covariance"):
        fit_ekf(model, H, z, (10, 0.3), covariance="magic")
    with pytest.raises(ValueError, match="unknown method"):
        run_blind_tests(model, ["newton"])
    with pytest.raises(ValueError, match="fixed"):
        profile(model, H, z, "nu", fixed={"nu": 0.3})
