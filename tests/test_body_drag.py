"""Drag on the probe's body (skin_indent.effects.body_drag): Alcaraz et al.'s (2002) cantilever drag
b(s) = 6 pi eta a_eff^2 / (s + h_eff) against a hand calculation and its far-field limit, and diagnoses
that keep it apart from relaxation: an elastic curve with body drag is ``none`` for the sample and
``body_drag`` for the instrument; a power-law curve without drag is given no drag.

The elastic curve is the independent finite-element curve of a clean neo-Hookean half-space (E = 8 kPa,
nu = 0.45, R = 6.22 mm: src/skin_indent/data/neo-hooke_halfspace_E8kPa_nu0.45.csv) scaled to an AFM
sphere by similarity (depths x R'/R, forces x (E'/E) (R'/R)^2), recorded from 20 um above the surface,
approached at 5 um/s and retracted at 15 um/s (two speeds), with the drag of a 0.3 mm body 15 um above
the sphere's apex in water added (the Chiaro probe's, tests/data/real-data/README.md).
"""

import math

import numpy as np
import pytest
from _data import DATA

from skin_indent.effects import Evaluation, effect
from skin_indent.effects.body_drag import A_EFF_MAX_MM, H_EFF_MAX_MM, H_EFF_MIN_MM, body_drag_coefficient
from skin_indent.effects.drag import MPA_S
from skin_indent.measurement import measurement_from_arrays

REFERENCE = DATA.parent.parent / "src" / "skin_indent" / "data" / "neo-hooke_halfspace_E8kPa_nu0.45.csv"
R_REF, E_REF, NU = 6.22, 8.0, 0.45
R_AFM, E_AFM = 0.0275, 0.2  # the Chiaro sphere on a sample of 200 Pa
A_EFF, H_EFF = 0.3, 0.015  # the body: 0.3 mm, 15 um (mm)
SAMPLE_AND_INSTRUMENT = ("viscoelastic", "viscoelastic_powerlaw", "adhesion", "drag", "body_drag", "baselines")


def test_alcaraz_coefficient_against_a_hand_calculation():
    """b = 6 pi eta a^2 / (s + h): water (1 mPa s = 1e-6 kPa s), a = 0.3 mm, s = 10 um, h = 15 um:
    6 pi x 1e-3 Pa s x (3e-4 m)^2 / 2.5e-5 m = 6.7858e-5 N s/m (= mN s/mm)."""
    assert float(body_drag_coefficient(1e-6, 0.3, 0.010, 0.015)) == pytest.approx(6.7858e-5, rel=1e-4)
    # in contact (a separation below 0) the separation is held at 0: b(0) = 6 pi eta a^2 / h
    assert float(body_drag_coefficient(1e-6, 0.3, -0.002, 0.015)) == pytest.approx(6 * math.pi * 1e-6 * 0.09 / 0.015)


def test_far_field_limits():
    """Far from the surface (s >> h_eff) b falls as 6 pi eta a^2 / s; with h_eff much larger than every
    distance travelled it is the constant far-field coefficient of ``drag``, c = 6 pi eta a^2 / h_eff:
    the two effects then give the same force (to s / h_eff)."""
    s = np.array([1.0, 10.0, 100.0])
    b = body_drag_coefficient(1e-6, 0.3, s, 1e-3)
    assert np.allclose(b * s, 6 * math.pi * 1e-6 * 0.09, rtol=1.1e-3)
    t = np.arange(0.0, 4.0, 0.01)
    d = np.r_[0.01 * t[:200], 0.02 - 0.01 * (t[200:] - t[199])]
    kind = np.r_[np.full(200, "approach"), np.full(200, "retract")]
    h = d - 0.015
    h_eff = 0.4
    body, far = (Evaluation(d, t, h.copy(), R_AFM, force_mN=np.zeros_like(d), kind=kind) for _ in range(2))
    effect("body_drag").apply(body, {"a_eff2_mm2": 0.09, "h_eff_mm": h_eff})
    effect("drag").apply(far, {"eta_mPa_s": 0.0, "drag_N_s_per_m": 6 * math.pi * MPA_S * 0.09 / h_eff})
    assert np.allclose(body.force_mN, far.force_mN, rtol=0.04, atol=0.0)  # s <= 15 um of 0.4 mm
    assert np.abs(body.force_mN).max() > 0


def test_bounds_are_physical_and_the_same_for_every_curve():
    m = _elastic_with_body_drag()
    from skin_indent.fitting.model_fit import prepare_curve

    b = effect("body_drag").fit_bounds(prepare_curve(m))
    assert b == {"a_eff2_mm2": (0.0, A_EFF_MAX_MM**2), "h_eff_mm": (H_EFF_MIN_MM, H_EFF_MAX_MM)}
    assert effect("body_drag").instrument and effect("body_drag").per_curve
    assert effect("body_drag").from_fit({"a_eff2_mm2": 0.09, "h_eff_mm": 0.015}, 1.0) == \
        pytest.approx({"a_eff_mm": 0.3, "h_eff_mm": 0.015})


def _elastic_with_body_drag(a_eff=A_EFF, h_eff=H_EFF, noise=2e-8, seed=3, va=0.005, vr=0.015):
    """The finite-element half-space at the AFM sphere, 20 um of approach out of contact, 2.6 um into it,
    approach at ``va`` and retract at ``vr`` (mm/s), body drag and noise (mN) added; 1 kHz sampling."""
    ref = np.loadtxt(REFERENCE, delimiter=",", skiprows=1)
    k = R_AFM / R_REF
    depth, force = ref[:, 0] * k, ref[:, 1] * (E_AFM / E_REF) * k**2
    c0, top, dt = 0.02, 0.02 + depth[-1], 2e-3
    ta = np.arange(0.0, top / va, dt)
    tr = np.arange(dt, top / vr + dt / 2, dt)
    t = np.r_[ta, ta[-1] + tr]
    d = np.r_[va * ta, top - vr * tr]
    v = np.r_[np.full(ta.size, va), np.full(tr.size, -vr)]
    h = d - c0
    F = np.where(h > 0, np.interp(np.maximum(h, 0), depth, force), 0.0)
    F += body_drag_coefficient(MPA_S, a_eff, -h, h_eff) * v
    F += np.random.default_rng(seed).normal(0, noise, F.size)
    return measurement_from_arrays(d, F, t, source="synthetic_body_drag.csv", radius_mm=R_AFM)


def test_an_elastic_curve_with_body_drag_is_none_for_the_sample(context):
    """Body drag of two speeds on an elastic half-space: sample none (no relaxation named for the drag's
    hysteresis), the instrument's body_drag named, its effective radius within 3 sd of the truth."""
    from skin_indent.diagnosis import diagnose

    d = diagnose(_elastic_with_body_drag(), candidates=SAMPLE_AND_INSTRUMENT, fixed={"nu": NU}, in_loop=False,
                 context=context)
    print(d.report())
    assert d.verdict == "none" and d.missing == (), d.report()
    assert "body_drag" in d.instrument
    p, sd = d.current.parameters, d.current.std
    assert abs(p["a_eff_mm"] - A_EFF) < max(3 * sd["a_eff_mm"], 0.02 * A_EFF)
    assert abs(p["E_kPa"] - E_AFM) < 0.02 * E_AFM


def test_a_power_law_curve_without_drag_is_given_no_drag(context):
    """Ting's solution for a power-law sample (beta = 0.2) recorded from 10 um above the surface, approach
    and retract at 2 um/s, no drag: relaxation is named, no drag of either kind."""
    from skin_indent.mechanics.analytic import ting_power_law_force
    from skin_indent.diagnosis import diagnose

    beta, v, lead, depth = 0.2, 2e-3, 0.01, 0.003
    T = (lead + depth) / v
    t = np.linspace(0.0, 2 * T, 1200)
    d = v * np.minimum(t, 2 * T - t)
    tc = lead / v
    F = ting_power_law_force(t - tc, v, E_AFM, NU, R_AFM, beta, peak_s=T - tc)
    F = F + np.random.default_rng(11).normal(0.0, 0.005 * F.max(), t.size)
    m = measurement_from_arrays(d, F, t, source="Ting power law", radius_mm=R_AFM)
    dg = diagnose(m, candidates=SAMPLE_AND_INSTRUMENT, fixed={"nu": NU}, in_loop=False, context=context)
    print(dg.report())
    assert not {"drag", "body_drag"} & set(dg.instrument), dg.report()
    assert dg.verdict == "viscoelastic_powerlaw", dg.report()
