"""The automatic ladder: diagnose names the missing effect, adds it, and goes on until the noise.

Curves of our own forward model with two effects at once, and the forearm-like curve of
the demo (three layers, from an independent FE code). The cheap cases (surfaces only)
run by default; those that fit two elastic effects with the finite-element model in the
loop (minutes each on 2 cores) are behind the ``slow`` marker.
"""

import math

import numpy as np
import pytest

from skin_indent.data import bundled_path
from skin_indent.diagnosis import diagnose
from skin_indent.effects import Model
from skin_indent.measurement import load_csv, measurement_from_arrays
from skin_indent.mechanics.protocol import Protocol


def _own(effects, theta, *, sigma, seed, protocol=None, shift_mm=0.0, mesh="coarse"):
    protocol = protocol or Protocol.ramp(0.6, 100, 0.02)
    curve = Model(tuple(effects)).simulate(theta, protocol=protocol, mesh=mesh)
    force = curve.force_mN + np.random.default_rng(seed).normal(0.0, sigma, curve.force_mN.size)
    depth, time = curve.depth_mm, curve.time_s
    if shift_mm:  # the contact point at +shift: nothing before it, the curve after it
        depth, force, time = np.r_[0.0, depth + shift_mm], np.r_[0.0, force], np.r_[0.0, time + shift_mm / 0.02]
    return measurement_from_arrays(depth, force, time, source="+".join(effects))


def _ends_at_the_noise(d, sigma):
    assert d.current.rms_mN < 1.3 * sigma, d.report()
    assert d.current.white and d.explained, d.report()


def _within_3_sd_or_undetermined(d, truth):
    undetermined = d.undetermined()
    for k, v in truth.items():
        got, sd = d.current.parameters[k], d.current.std[k]
        if k in undetermined or (math.isinf(v) and math.isinf(got)):
            continue
        assert abs(got - v) <= 3 * sd, (k, got, sd, d.report())


def test_ladder_climbs_stiffening_and_offset(context, diagnosis_surfaces):
    """Stiffening and a shifted contact point: both named (either order), the last rung at the noise."""
    sigma = 0.04
    m = _own(("stiffening",), {"E_kPa": 6.0, "nu": 0.47, "C20_kPa": 15.0}, sigma=sigma, seed=5, shift_mm=0.03)
    d = diagnose(m, candidates=("stiffening", "offset", "viscoelastic"), context=context)
    assert sorted(d.missing) == ["offset", "stiffening"], d.report()
    assert d.verdict in ("stiffening+offset", "offset+stiffening"), d.report()
    _ends_at_the_noise(d, sigma)
    assert [f.rms_mN for f in d.ladder] == sorted((f.rms_mN for f in d.ladder), reverse=True)
    assert d.current.parameters["offset_mm"] == pytest.approx(0.03, abs=3 * d.current.std["offset_mm"] + 1e-3)
    assert "explains the curve to the noise" in d.sentence()
    out = d.to_dict()
    assert [r["model"] for r in out["ladder"]] == [f.model for f in d.ladder] and out["missing"] == list(d.missing)


def test_a_mimicked_set_is_never_named_wrongly_alone(context, diagnosis_surfaces):
    """Stiffening with a shifted contact point also looks like a stiff layer over a softer half-space
    (both stiffen the deep part and move the start): the ladder names the right set, or says
    ambiguous naming both with the measurement that separates them; never the layer alone."""
    sigma = 0.04
    m = _own(("stiffening",), {"E_kPa": 5.0, "nu": 0.47, "C20_kPa": 20.0}, sigma=sigma, seed=41, shift_mm=0.03,
             protocol=Protocol.ramp(0.57, 95, 0.02))
    d = diagnose(m, candidates=("layer", "stiffening", "offset"), in_loop=False, context=context)
    right = sorted(d.missing) == ["offset", "stiffening"]
    named_both = (d.verdict == "ambiguous" and any("stiffening" in c for c in d.confounded_with)
                  and any("layer" in c for c in d.confounded_with) and d.suggested_measurement)
    assert right or named_both, d.report()
    assert d.missing != ("layer",), d.report()


def test_clean_curve_climbs_no_rung(context, diagnosis_surfaces):
    sigma = 0.03
    m = _own((), {"E_kPa": 9.0, "nu": 0.46}, sigma=sigma, seed=11)
    d = diagnose(m, candidates=("stiffening", "offset"), context=context)
    assert d.verdict == "none" and len(d.ladder) == 1 and not d.missing, d.report()
    assert "no missing effect" in d.sentence()


def test_a_structured_rung_is_never_called_explained(context, diagnosis_surfaces):
    """With the only candidate that can help left out, the sentence says the misfit stays."""
    m = _own(("stiffening",), {"E_kPa": 5.0, "nu": 0.47, "C20_kPa": 25.0}, sigma=0.03, seed=12)
    d = diagnose(m, candidates=("offset",), noise_mN=0.03, context=context)
    assert not d.explained
    assert "explains" not in d.sentence() or "does not explain" in d.sentence(), d.report()


@pytest.mark.slow
def test_forearm_ladder_names_layers(context, diagnosis_surfaces):
    """The demo's curve (dermis over hypodermis over muscle): the ladder ends at the noise and names layers."""
    m = load_csv(bundled_path("forearm_like.csv"))
    d = diagnose(m, context=context)
    assert "layer" in d.missing, d.report()
    assert d.current.rms_mN < 1.3 * d.noise_mN and d.current.white, d.report()


@pytest.mark.slow
def test_two_layers_on_a_rigid_base_named(context, diagnosis_surfaces):
    # A layer with strain stiffening (E 8 kPa, 1.5 mm over a base 0.3 times as stiff, C20 16 kPa) is not
    # a case for one sphere: a thinner layer without stiffening explains its curve to the noise (0.74 mm
    # at noise 0.04 mN, 0.78 mm at 0.02; 1.44 mm for a 3 mm truth), so the climb rightly stops at one
    # layer. It passed here while the thickness nodes began at 1.5 depths (the layer fit stopped at that
    # edge and the climb went on); since they begin at 1.2 depths (e313731) it cannot. Two spheres
    # separate them: test_sample.py::test_layer_and_stiffening_seen_with_two_spheres_are_both_named.
    sigma = 0.04
    truth = {"E_kPa": 15.0, "nu": 0.48, "thickness_mm": 1.0, "ratio": 0.25, "thickness2_mm": 2.0,
             "ratio2": math.inf}
    effects, expected = ("layer", "layer"), ["layer", "layer"]
    # the curve is solved at each of its 100 depths: on the coarse mesh such a curve wiggles by
    # 0.09% rms (0.44% max) as the contact edge crosses its nodes, ~0.02 mN here, a structure of
    # the synthetic data that measured curves do not have (the fits' runs interpolate a smooth
    # curve between solved depths); on the medium mesh by 0.03% rms
    m = _own(effects, truth, sigma=sigma, seed=21, mesh="medium")
    d = diagnose(m, candidates=("layer", "stiffening", "offset"), context=context)
    assert sorted(d.missing) == expected or d.verdict == "ambiguous", d.report()
    _ends_at_the_noise(d, sigma)
    if sorted(d.missing) == expected:
        _within_3_sd_or_undetermined(d, {k: v for k, v in truth.items() if k != "nu"})


@pytest.mark.slow
def test_layer_and_relaxation_with_hold_and_unloading(context, diagnosis_surfaces):
    sigma = 0.03
    hist = Protocol.ramp(0.6, 50, 0.02, hold_s=20.0, hold_points=30, unload=True)
    truth = {"E_kPa": 10.0, "nu": 0.47, "thickness_mm": 1.2, "ratio": 0.3, "g1": 0.35, "tau1_s": 5.0}
    m = _own(("layer", "viscoelastic"), truth, sigma=sigma, seed=31, protocol=hist)
    d = diagnose(m, candidates=("layer", "viscoelastic", "offset"), context=context)
    assert sorted(d.missing) == ["layer", "viscoelastic"], d.report()
    _ends_at_the_noise(d, sigma)


def test_cli_max_rungs_and_surfaces_only(gallery_cache, diagnosis_surfaces):
    """``--max-rungs 0`` names the effect without adding it; ``--surfaces-only`` lists combinations no
    surface covers as not fitted, never as not detectable."""
    import json
    import subprocess
    import sys

    from _data import DATA

    import os

    curve = DATA / "hidden-effects" / "v04_stiffening.csv"
    env = {**os.environ, "SKIN_INDENT_CACHE": str(gallery_cache)}
    out = subprocess.run([sys.executable, "-m", "skin_indent", "diagnose", str(curve), "--json", "--max-rungs", "0",
                          "--surfaces-only", "--add", "layer", "--candidates", "stiffening,offset"],
                         capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stderr
    payload = json.loads(out.stdout)
    assert [r["model"] for r in payload["ladder"]] == ["neo-hooke", "neo-hooke+layer"]
    why = payload["steps"][0]["not_detectable"]["stiffening"]
    assert why.startswith("not fitted") and "finite-element model in the loop" in why
    bad = subprocess.run([sys.executable, "-m", "skin_indent", "diagnose", str(curve), "--max-rungs", "-1"],
                         capture_output=True, text=True, timeout=120, env=env)
    assert bad.returncode == 2 and "max-rungs" in bad.stderr and "Traceback" not in bad.stderr
