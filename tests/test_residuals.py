"""Residual statistics of diagnose: noise is called noise, structure is found and placed."""

import numpy as np
import pytest

from skin_indent.inverse.residuals import analyse_residuals, describe_structure, effective_sample_size, sentence


def test_white_noise_is_called_white_at_the_nominal_rate():
    rng = np.random.default_rng(0)
    calls = [analyse_residuals(rng.normal(0, 0.05, 100), 0.05, 2).white for _ in range(300)]
    false_alarms = 1 - np.mean(calls)
    assert false_alarms < 0.06  # three tests at 1% each


def test_smooth_misfit_is_structure_even_below_the_noise_rms():
    d = np.linspace(0.006, 0.6, 100)
    rng = np.random.default_rng(1)
    r = 0.04 * np.sin(2 * np.pi * d / 0.6) + rng.normal(0, 0.05, d.size)
    a = analyse_residuals(r, 0.05, 2)
    assert not a.white and a.runs < a.runs_expected and a.lag1 > 0.2


def test_underestimated_noise_fails_the_chi_square():
    rng = np.random.default_rng(2)
    a = analyse_residuals(rng.normal(0, 0.1, 100), 0.05, 2)
    assert not a.white and a.chi2_p < 1e-6 and a.runs_p > 0.01


def test_structure_is_placed_in_depth_with_its_sign():
    d = np.linspace(0.006, 0.6, 100)
    rng = np.random.default_rng(3)
    r = np.where(d < 0.15, -0.12, np.where(d > 0.35, 0.1, 0.0)) + rng.normal(0, 0.05, d.size)
    ranges = describe_structure(d, r, 0.05)
    stiff = [x for x in ranges if x["sign"] == "too stiff"]
    soft = [x for x in ranges if x["sign"] == "too soft"]
    assert stiff and soft and stiff[0]["to_mm"] < 0.2 and soft[-1]["from_mm"] > 0.3
    text = sentence(ranges)
    assert text.startswith("model too stiff from") and "too soft" in text
    assert describe_structure(d, rng.normal(0, 0.05, d.size), 0.05) == []


def test_effective_sample_size():
    rng = np.random.default_rng(4)
    white = rng.normal(size=2000)
    ar = np.zeros(2000)
    for k in range(1, 2000):
        ar[k] = 0.8 * ar[k - 1] + rng.normal()
    assert effective_sample_size(white) == pytest.approx(2000, rel=0.1)
    assert effective_sample_size(ar) == pytest.approx(2000 * 0.2 / 1.8, rel=0.25)


@pytest.mark.parametrize("r, noise, match", [([0.1, 0.2], 0.05, "at least 5"), ([0.1] * 6 + [np.nan], 0.05, "finite"),
                                             ([0.1] * 6, 0.0, "noise level")])
def test_bad_input(r, noise, match):
    with pytest.raises(ValueError, match=match):
        analyse_residuals(r, noise)
