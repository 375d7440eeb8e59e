"""The instrument in the model: drag on the probe and the baselines of the segments (skin_indent.effects.drag,
skin_indent.effects.segment_baseline), checked against closed forms, and a diagnosis that names them as the
instrument's, not the sample's.

The synthetic curve is the independent finite-element curve of a clean neo-Hookean half-space (E = 8 kPa,
nu = 0.45, R = 6.22 mm: src/skin_indent/data/neo-hooke_halfspace_E8kPa_nu0.45.csv), recorded from 0.3 mm
before contact, approached at 1 mm/s and retracted at 3 mm/s (two speeds), with the lubrication and
far-field drag (within the drag's physical bounds: a liquid of 8 mPa s), a tilted approach baseline (the virtual
deflection), a drift during the retract and noise added.
"""

import math

import numpy as np
import pytest
from _data import DATA

from skin_indent.effects import EFFECTS, INSTRUMENT, Evaluation, effect
from skin_indent.effects.drag import GAP_FRACTION, MPA_S, baseline_part, lubrication_force, probe_velocity
from skin_indent.measurement import measurement_from_arrays
from skin_indent.measurement.contact import Baseline

REFERENCE = DATA.parent.parent / "src" / "skin_indent" / "data" / "neo-hooke_halfspace_E8kPa_nu0.45.csv"
R_MM = 6.22


def brenner(gap_over_radius: float) -> float:
    """Brenner's (1961) exact drag factor lambda = F / (6 pi eta R v) of a sphere moving towards a plane
    wall at gap s (cosh alpha = 1 + s / R); the terms are summed until (2n + 1) alpha reaches 60 (each is
    then below 1e-20 of the sum)."""
    a = math.acosh(1.0 + gap_over_radius)
    total = 0.0
    for n in range(1, int(30.0 / a) + 2):
        num = 2.0 * math.sinh((2 * n + 1) * a) + (2 * n + 1) * math.sinh(2 * a)
        den = 4.0 * math.sinh((n + 0.5) * a) ** 2 - (2 * n + 1) ** 2 * math.sinh(a) ** 2
        total += n * (n + 1) / ((2 * n - 1) * (2 * n + 3)) * (num / den - 1.0)
    return 4.0 / 3.0 * math.sinh(a) * total


def test_lubrication_drag_is_the_limit_of_brenners_exact_solution():
    """6 pi eta R^2 v / s against Brenner's series: within 3 % at s = R / 100, closer as the gap closes
    (the next terms are (1/5) ln(R/s) + O(1), which the lubrication form leaves out)."""
    eta, v = 1e-6, 0.01  # water (kPa s), 10 um/s
    errors = []
    for ratio in (0.04, 0.01, 0.0025):
        s = ratio * R_MM
        ours = float(lubrication_force(eta, R_MM, v, s, 0.0))
        exact = 6.0 * math.pi * eta * R_MM * v * brenner(ratio)
        errors.append(abs(ours / exact - 1.0))
    assert errors[1] < 0.03
    assert errors[0] > errors[1] > errors[2]
    # far from the wall Brenner's factor goes to 1 (Stokes): the series itself is right
    assert brenner(50.0) == pytest.approx(1.0, abs=0.03)
    # bounded as the gap closes: 6 pi eta R^2 v / s0
    s0 = GAP_FRACTION * R_MM
    assert float(lubrication_force(eta, R_MM, v, 0.0, s0)) == pytest.approx(6 * math.pi * eta * R_MM**2 * v / s0)


def _ramp(va=0.1, vr=0.3, c0=0.3, top=0.9, dt=0.05):
    ta = np.arange(0.0, top / va, dt)
    tr = np.arange(dt, top / vr + dt / 2, dt)
    t = np.r_[ta, ta[-1] + tr]
    d = np.r_[va * ta, top - vr * tr]
    kind = np.r_[np.full(ta.size, "approach"), np.full(tr.size, "retract")]
    return t, d, kind


def test_drag_effect_is_the_closed_form_less_what_the_baseline_took():
    """Drag.apply at constant speeds: 6 pi eta R^2 v / (s + s0) + c v, less the line fitted to it over the
    approach points of the subtracted baseline; the step at the turn is c (v_r - v_a) far from the surface."""
    t, d, kind = _ramp()
    c0 = 0.3
    v = probe_velocity(t, d, kind)
    assert np.allclose(v[kind == "approach"][3:-3], 0.1) and np.allclose(v[kind == "retract"][3:-3], -0.3)
    eta, c = 500.0, 0.4
    h = d - c0
    expected = lubrication_force(eta * MPA_S, R_MM, v, np.maximum(-h, 0), GAP_FRACTION * R_MM) + c * v
    ev = Evaluation(d, t, h.copy(), R_MM, force_mN=np.zeros_like(d), kind=kind)
    effect("drag").apply(ev, {"eta_mPa_s": eta, "drag_N_s_per_m": c})
    assert np.allclose(ev.force_mN, expected)  # no baseline subtracted: the closed form itself
    flat = Baseline(0.0, 0.0, 0.01, 20, (0.0, 0.15), 0.0)
    ev = Evaluation(d, t, h.copy(), R_MM, force_mN=np.zeros_like(d), kind=kind, baseline=flat)
    effect("drag").apply(ev, {"eta_mPa_s": 0.0, "drag_N_s_per_m": c})
    far = (d < 0.1) & (np.abs(v) > 0)
    assert np.allclose(ev.force_mN[far & (kind == "approach")][2:], 0.0, atol=1e-12)
    assert np.allclose(ev.force_mN[far & (kind == "retract")][:-3], c * (-0.3 - 0.1))
    assert np.allclose(baseline_part(expected, d, kind, None), 0.0)


def test_segment_baseline_is_continuous_and_drifts_at_its_rate():
    t, d, kind = _ramp()
    ev = Evaluation(d, t, d.copy(), R_MM, force_mN=np.zeros_like(d), kind=kind)
    effect("baselines").apply(ev, {"retract_drift_mN_per_s": 0.05})
    start = t[kind == "retract"][0]
    assert np.all(ev.force_mN[kind == "approach"] == 0.0)
    assert np.allclose(ev.force_mN[kind == "retract"], 0.05 * (t[kind == "retract"] - start))
    # a hold's drift is held after the hold: the retract starts where it ended
    kind3 = kind.copy()
    kind3[(t > 8.0) & (kind == "approach")] = "hold"
    ev = Evaluation(d, t, d.copy(), R_MM, force_mN=np.zeros_like(d), kind=kind3)
    effect("hold_baseline").apply(ev, {"hold_drift_mN_per_s": 0.1})
    hold_t = t[kind3 == "hold"]
    assert np.allclose(ev.force_mN[kind3 == "retract"], 0.1 * (hold_t[-1] - hold_t[0]))


def test_instrument_effects_are_registered_as_the_instruments():
    assert set(INSTRUMENT) == {"drag", "body_drag", "baselines", "hold_baseline"}
    assert all(EFFECTS[n].instrument and EFFECTS[n].per_curve for n in INSTRUMENT)
    assert not any(e.instrument for n, e in EFFECTS.items() if n not in INSTRUMENT)


def synthetic_curve(seed=7, eta_mPa_s=8.0, drag=5e-5, drift=0.3, noise=0.005, va=1.0, vr=3.0):
    """The clean finite-element half-space with two speeds, drag (a liquid 8 times as viscous as water),
    per-segment baselines and noise: approach at 1 mm/s, retract at 3 mm/s, 200 samples a second."""
    ref = np.loadtxt(REFERENCE, delimiter=",", skiprows=1)
    c0, hmax, dt = 0.3, 0.6, 0.005
    ta = np.arange(0, (c0 + hmax) / va, dt)
    tr = np.arange(dt, (c0 + hmax) / vr + dt / 2, dt)
    t = np.r_[ta, ta[-1] + tr]
    d = np.r_[va * ta, c0 + hmax - vr * tr]
    v = np.r_[np.full(ta.size, va), np.full(tr.size, -vr)]
    h = d - c0
    F = np.where(h > 0, np.interp(np.maximum(h, 0), ref[:, 0], ref[:, 1]), 0.0)
    F += lubrication_force(eta_mPa_s * MPA_S, R_MM, v, np.maximum(-h, 0), GAP_FRACTION * R_MM) + drag * v
    F += 0.3 + 0.2 * d  # the approach's own baseline (offset and tilt: the virtual deflection)
    F += drift * np.clip(t - ta[-1] - dt, 0, None)  # the retract's drift
    F += np.random.default_rng(seed).normal(0, noise, F.size)
    return measurement_from_arrays(d, F, t, source="synthetic_drag_two_speeds.csv", radius_mm=R_MM)


def test_a_clean_half_space_with_drag_and_baselines_is_none_for_the_sample(diagnosis_surfaces, gallery_cache):
    """No effect of the sample is named for drag and baselines: sample none, instrument drag and baselines,
    every segment explained; the drag's viscosity within 3 sd of the truth."""
    from skin_indent.diagnosis import diagnose

    d = diagnose(synthetic_curve(), cache_dir=gallery_cache, mesh="coarse", workers=2, in_loop=False)
    assert d.verdict == "none" and d.missing == ()
    assert set(d.instrument) == {"drag", "baselines"}
    assert d.explained and all(m.explained for m in d.segments)
    assert [m.kind for m in d.segments] == ["approach", "retract"]
    p, sd = d.current.parameters, d.current.std
    assert abs(p["eta_mPa_s"] - 8.0) < 3 * sd["eta_mPa_s"]
    assert abs(p["E_kPa"] - 8.0) < 3 * sd["E_kPa"]
    out = d.to_dict()
    assert out["sample"] == "none" and out["instrument"] == ["drag", "baselines"]
    assert "sample: none; instrument: drag, baselines" in d.report()


def test_the_same_curve_without_the_instrument_names_nothing(diagnosis_surfaces, gallery_cache):
    """A control: no drag, no drift: the instrument's effects are not named (and the sample's verdict is none)."""
    from skin_indent.diagnosis import diagnose

    d = diagnose(synthetic_curve(eta_mPa_s=0.0, drag=0.0, drift=0.0), cache_dir=gallery_cache, mesh="coarse",
                 workers=2, in_loop=False, candidates=("stiffening", "viscoelastic", "adhesion", *INSTRUMENT))
    assert d.verdict == "none" and d.instrument == ()
    assert d.instrument_verdict == "none"


def test_a_batch_row_and_its_table_hold_both_verdicts(diagnosis_surfaces, gallery_cache, tmp_path):
    from skin_indent.runtime.context import Context
    from skin_indent.diagnosis import diagnose_many
    from skin_indent.measurement import save_csv
    from skin_indent.report.batch_table import write_tsv

    save_csv(synthetic_curve(), tmp_path / "drag.csv")
    rows = diagnose_many([tmp_path / "drag.csv"], candidates=("stiffening", "adhesion", *INSTRUMENT), in_loop=False,
                         context=Context(cache_dir=gallery_cache, workers=1), progress=False)
    row = rows[0]
    assert not row.error, row.error
    assert (row.sample, row.instrument) == ("none", "drag, baselines")
    assert row.segments.startswith("approach explained") and "retract explained" in row.segments
    lines = [ln for ln in write_tsv(rows, tmp_path / "rows.tsv").read_text().splitlines() if not ln.startswith("#")]
    header = lines[0].split("\t")
    cells = dict(zip(header, lines[1].split("\t")))
    assert cells["sample"] == "none" and cells["instrument"] == "drag, baselines"


def test_an_instrument_effect_fitted_at_its_null_value_is_switched_off():
    """drag whose viscosity and far-field coefficient both end at 0 gives no force: switched off, not named;
    drag with either term above 0 on, and the body's drag is off once its drag area is 0 whatever its height.
    A per-curve effect of several curves is off only when it is off on every curve. A baseline's drift, whose
    range holds its off value inside, is off within 2 sd of 0 (-1.05e-8 +- 7.2e-9 mN/s: the Chiaro retract's
    once relaxation is fitted, 0.012 nN over its 1.16 s against a noise of 0.017 nN), on at 3 sd."""
    from types import SimpleNamespace

    from skin_indent.diagnosis.instrument import switched_off

    def rung(names, lo, hi, x, parameters=None, std=None):
        model = SimpleNamespace(parameter_names=tuple(names), bounds=(np.array(lo, float), np.array(hi, float)))
        return SimpleNamespace(bound_model=model, x=np.array(x, float), parameters=parameters or {}, std=std or {})

    names = ("E_kPa", "eta_mPa_s", "drag_N_s_per_m", "a_eff2_mm2", "h_eff_mm")
    lo, hi = (1e-3, 0.0, 0.0, 0.0, 1e-4), (10.0, 5.0, 1e-4, 0.25, 0.5)
    both_off = rung(names, lo, hi, (0.2, 1e-12, 0.0, 0.09, 0.02))
    assert switched_off(both_off, ("drag", "body_drag")) == ["drag"]
    one_on = rung(names, lo, hi, (0.2, 1e-12, 3e-6, 0.0, 0.02))
    assert switched_off(one_on, ("drag", "body_drag")) == ["body_drag"]
    joint = ("E_kPa", "eta_mPa_s[1]", "drag_N_s_per_m[1]", "eta_mPa_s[2]", "drag_N_s_per_m[2]")
    lo2, hi2 = (1e-3, 0.0, 0.0, 0.0, 0.0), (10.0, 5.0, 1e-4, 5.0, 1e-4)
    assert switched_off(rung(joint, lo2, hi2, (0.2, 0.0, 0.0, 0.0, 2e-6)), ("drag",)) == []
    assert switched_off(rung(joint, lo2, hi2, (0.2, 0.0, 0.0, 0.0, 0.0)), ("drag",)) == ["drag"]
    drift = ("E_kPa", "retract_drift_mN_per_s")
    lo3, hi3 = (1e-3, -1e-6), (10.0, 1e-6)
    off = rung(drift, lo3, hi3, (0.08, -1.05e-8), {"E_kPa": 0.08, "retract_drift_mN_per_s": -1.05e-8},
               {"E_kPa": 0.002, "retract_drift_mN_per_s": 7.2e-9})
    assert switched_off(off, ("baselines",)) == ["baselines"]
    on = rung(drift, lo3, hi3, (0.08, -2.2e-8), {"E_kPa": 0.08, "retract_drift_mN_per_s": -2.2e-8},
              {"E_kPa": 0.002, "retract_drift_mN_per_s": 7.2e-9})
    assert switched_off(on, ("baselines",)) == []


def test_a_log_scaled_height_is_at_a_face_within_a_fraction_of_its_decades():
    """The body's effective height runs over 3.2 decades (0.34 um to 0.5 mm on the spot3 curve): 0.71 um (the
    sphere-sized body 0.4 um above its lower face that fits spot3's near-wall drag) is inside its range, not
    at its face (it was, by 1e-3 of the linear span: 0.5 um); 0.3405 um is at it, and so is 0.4995 mm."""
    from types import SimpleNamespace

    from skin_indent.diagnosis.instrument import at_physical_range

    def rung(h):
        model = SimpleNamespace(parameter_names=("a_eff2_mm2", "h_eff_mm"),
                                bounds=(np.array([0.0, 3.4e-4]), np.array([0.25, 0.5])))
        return SimpleNamespace(bound_model=model, x=np.array([0.0013, h]))

    assert at_physical_range(rung(7.1e-4), ("body_drag",)) == []
    assert at_physical_range(rung(3.405e-4), ("body_drag",)) == ["h_eff_mm"]
    assert at_physical_range(rung(0.4995), ("body_drag",)) == ["h_eff_mm"]
