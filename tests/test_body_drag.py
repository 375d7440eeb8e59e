"""Drag on the probe's body (skin_indent.effects.body_drag): Alcaraz et al.'s (2002) cantilever drag
b(s) = 6 pi eta a_eff^2 / (s + h_eff) against a hand calculation and its far-field limit, and diagnoses
that keep it apart from relaxation: an elastic curve with body drag is ``none`` for the sample and
``body_drag`` for the instrument; a power-law curve without drag is given no drag.

The elastic curve is the independent finite-element curve of a clean neo-Hookean half-space (E = 8 kPa,
nu = 0.45, R = 6.22 mm: src/skin_indent/data/neo-hooke_halfspace_E8kPa_nu0.45.csv) scaled to an AFM
sphere by similarity (depths x R'/R, forces x (E'/E) (R'/R)^2), recorded from 20 um above the surface,
approached at 5 um/s and retracted at 15 um/s (two speeds) by a piezo that drives a cantilever of
k = 0.019 N/m (the Chiaro probe's), with the drag of a 0.3 mm body 15 um above the surface when the tip
touches, in water, added: the body moves with the cantilever's base (the piezo), at its speed, and its gap
shrinks by the base's travel past contact (tests/data/real-data/README.md).
"""

import math

import numpy as np
import pytest
from _data import DATA

from skin_indent.effects import Evaluation, effect
from scipy.optimize import brentq

from skin_indent.effects.body_drag import A_EFF_MAX_MM, H_EFF_MAX_MM, H_EFF_MIN_MM, body_drag_coefficient
from skin_indent.effects.drag import MPA_S
from skin_indent.measurement import measurement_from_arrays

REFERENCE = DATA.parent.parent / "src" / "skin_indent" / "data" / "neo-hooke_halfspace_E8kPa_nu0.45.csv"
R_REF, E_REF, NU = 6.22, 8.0, 0.45
R_AFM, E_AFM = 0.0275, 0.2  # the Chiaro sphere on a sample of 200 Pa
A_EFF, H_EFF = 0.3, 0.015  # the body: 0.3 mm, 15 um (mm)
K_N_PER_M = 0.019  # the cantilever (N/m = mN/mm)
SAMPLE_AND_INSTRUMENT = ("viscoelastic", "viscoelastic_powerlaw", "adhesion", "drag", "body_drag", "baselines")


def test_alcaraz_coefficient_against_a_hand_calculation():
    """b = 6 pi eta a^2 / (s + h): water (1 mPa s = 1e-6 kPa s), a = 0.3 mm, s = 10 um, h = 15 um:
    6 pi x 1e-3 Pa s x (3e-4 m)^2 / 2.5e-5 m = 6.7858e-5 N s/m (= mN s/mm)."""
    assert float(body_drag_coefficient(1e-6, 0.3, 0.010, 0.015)) == pytest.approx(6.7858e-5, rel=1e-4)
    # the base 2 um past where it was when the tip touched: the body's gap is 13 um
    assert float(body_drag_coefficient(1e-6, 0.3, -0.002, 0.015)) == pytest.approx(6 * math.pi * 1e-6 * 0.09 / 0.013)
    # a gap that would close is held at the smallest height
    assert float(body_drag_coefficient(1e-6, 0.3, -0.02, 0.015)) == pytest.approx(6 * math.pi * 1e-6 * 0.09 / H_EFF_MIN_MM)


def test_the_body_moves_with_the_cantilever_base_by_hand():
    """The start of a retract with the tip held in contact: the force falls from 40 to 10 nN in 10 ms while
    the recorded depth stays put. With k = 0.02 N/m the base moves out by 30 nN / 0.02 N/m = 1.5 um in
    10 ms, 150 um/s, and the body's drag is b v at the base's gap: h_eff 20 um less the base's travel past
    contact (the indentation 3 um plus the deflection F/k). By hand at the middle of the fall (F = 25 nN,
    deflection 1.25 um): gap 20 - 3 - 1.25 = 15.75 um, b = 6 pi x 1e-3 x (3e-4)^2 / 15.75e-6 = 1.0771e-4
    N s/m, force -1.0771e-4 x 150e-6 m/s = -16.16 nN; the tip's velocity (0) would give none."""
    t = np.arange(0.0, 0.0201, 0.001)  # 21 samples, 1 kHz
    k = 0.02
    F = np.clip(40e-6 - 3e-6 * (t - 0.005) / 0.001, 10e-6, 40e-6)  # mN: 40 nN until 5 ms, 10 nN from 15 ms
    d = np.full(t.size, 0.053)  # the tip held 3 um past a contact at 0.050 mm
    kind = np.full(t.size, "retract")
    ev = Evaluation(d, t, d - 0.050, R_AFM, force_mN=np.zeros_like(d), kind=kind, deflection_mm=F / k)
    effect("body_drag").apply(ev, {"a_eff2_mm2": 0.09, "h_eff_mm": 0.020})
    assert ev.force_mN[10] == pytest.approx(-16.16e-6, rel=2e-3)
    still = Evaluation(d, t, d - 0.050, R_AFM, force_mN=np.zeros_like(d), kind=kind)
    effect("body_drag").apply(still, {"a_eff2_mm2": 0.09, "h_eff_mm": 0.020})
    assert np.abs(still.force_mN).max() < 1e-12


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


def test_bounds_are_physical():
    """a_eff up to the longest cantilevers; h_eff from the base's deepest travel past the contact guess (the
    body does not reach the surface: indentation plus deflection) to the body's size; the spring constant
    estimated from the ramps within 2 % of the cantilever's."""
    m = _elastic_with_body_drag()
    from skin_indent.fitting.model_fit import prepare_curve

    data = prepare_curve(m)
    k, source = data.spring_constant
    assert source == "estimated from the ramps" and k == pytest.approx(K_N_PER_M, rel=0.02)
    b = effect("body_drag").fit_bounds(data)
    travel = float(np.max(data.depth_mm + data.deflection_mm)) - data.contact_guess_mm
    assert b == {"a_eff2_mm2": (0.0, A_EFF_MAX_MM**2), "h_eff_mm": (H_EFF_MIN_MM + travel, H_EFF_MAX_MM)}
    assert 0.002 < travel < 0.004  # 2.6 um of indentation and 0.4 um of deflection
    assert effect("body_drag").instrument and effect("body_drag").per_curve
    assert effect("body_drag").from_fit({"a_eff2_mm2": 0.09, "h_eff_mm": 0.015}, 1.0) == \
        pytest.approx({"a_eff_mm": 0.3, "h_eff_mm": 0.015})


def _elastic_with_body_drag(a_eff=A_EFF, h_eff=H_EFF, noise=2e-8, seed=3, va=0.005, vr=0.015, k=K_N_PER_M):
    """The finite-element half-space at the AFM sphere, 20 um of approach out of contact, 2.6 um into it, by
    a piezo at ``va`` in and ``vr`` out (mm/s) driving a cantilever of spring constant ``k`` (N/m = mN/mm);
    body drag at the base's speed and gap, and noise (mN), added; 1 kHz sampling.

    The base sits at z; the tip at d, with d + F / k = z; the body's gap is h_eff - (z - c0) (the base's
    travel past where it was when the tip touched, the recorded force's deflection included), its drag
    b v_z; the tip's depth solves d + (F_sample(d - c0) + drag) / k = z."""
    ref = np.loadtxt(REFERENCE, delimiter=",", skiprows=1)
    scale = R_AFM / R_REF
    depth, force = ref[:, 0] * scale, ref[:, 1] * (E_AFM / E_REF) * scale**2
    c0, dt = 0.02, 1e-3
    top = c0 + depth[-1] + force[-1] / k  # the base's turn: the tip 2.6 um in
    ta = np.arange(0.0, top / va, dt)
    tr = np.arange(dt, top / vr + dt / 2, dt)
    t = np.r_[ta, ta[-1] + tr]
    z = np.r_[va * ta, va * ta[-1] - vr * tr]
    vz = np.r_[np.full(ta.size, va), np.full(tr.size, -vr)]
    drag = body_drag_coefficient(MPA_S, a_eff, -(z - c0), h_eff) * vz

    def sample(d):
        return float(np.interp(d - c0, depth, force)) if d > c0 else 0.0

    d = np.array([brentq(lambda x: x + (sample(x) + b) / k - zi, zi - 1.0, zi + 1.0, xtol=1e-12)
                  for zi, b in zip(z, drag)])
    F = np.array([sample(x) for x in d]) + drag
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
