"""The effect vocabulary: names, off values that give back the base model, exact E-scaling."""

import math

import numpy as np
import pytest

from skin_indent.effects import EFFECTS, Model, effect
from skin_indent.mechanics import NeoHooke
from skin_indent.mechanics.protocol import Protocol


def test_vocabulary_names_and_units():

    # one vocabulary everywhere (API, CLI, JSON, reports), in the order of the issue
    assert tuple(EFFECTS) == ("layer", "stiffening", "viscoelastic", "friction", "adhesion", "offset",
                            "viscoelastic_powerlaw", "drag", "baselines", "hold_baseline")  # then the instrument's (issue 37)
    for e in EFFECTS.values():
        for p in e.parameters:
            assert p.unit and p.lower <= (p.off if p.off is not None else p.lower) <= p.upper
            assert p.unit == "-" or p.name.endswith(p.unit.replace("/", "_per_")) or p.name.endswith("_" + p.unit)


@pytest.mark.parametrize("name", ["layer", "stiffening", "viscoelastic", "offset", "viscoelastic_powerlaw"])
def test_off_values_give_back_the_base_model_exactly(name):
    model = Model((name,))
    assert model.sample({"E_kPa": 7.0, "nu": 0.45}) == NeoHooke(7.0, 0.45)
    d = np.linspace(0.05, 0.3, 4)
    base = Model().simulate({"E_kPa": 7.0, "nu": 0.45}, d, mesh="coarse").force_mN
    off = model.simulate({"E_kPa": 7.0, "nu": 0.45, **EFFECTS[name].off_values()}, d, mesh="coarse").force_mN
    assert np.array_equal(base, off)


@pytest.mark.parametrize("effects, theta", [
    (("layer",), {"thickness_mm": 1.0, "ratio": 0.2}),
    (("layer",), {"thickness_mm": 2.0, "ratio": math.inf}),
    (("stiffening",), {"C20_kPa": 5.0}),
])
def test_force_is_proportional_to_E_with_effects(effects, theta):
    model = Model(effects)
    d = np.linspace(0.05, 0.3, 4)
    one = {"E_kPa": 3.0, "nu": 0.45, **theta}
    two = {**one, "E_kPa": 6.0}
    if "C20_kPa" in theta:
        two["C20_kPa"] = 2 * theta["C20_kPa"]
    f1 = model.simulate(one, d, mesh="coarse").force_mN
    f2 = model.simulate(two, d, mesh="coarse").force_mN
    assert np.abs(f2 / (2 * f1) - 1).max() < 1e-8
    assert model.unit_parameters(one) == model.unit_parameters(two)


def test_viscoelastic_model_needs_a_protocol():
    model = Model(("viscoelastic",))
    theta = {"E_kPa": 10.0, "nu": 0.45, "g1": 0.4, "tau1_s": 5.0}
    with pytest.raises(ValueError, match="needs a protocol"):
        model.simulate(theta, np.linspace(0.05, 0.3, 4), mesh="coarse")
    curve = model.simulate(theta, protocol=Protocol.ramp(0.3, 5), mesh="coarse")
    assert curve.time_s is not None and curve.force_mN[-1] > 0


@pytest.mark.parametrize("theta, message", [
    ({"E_kPa": -1.0, "nu": 0.4}, "E_kPa = -1 is outside"),
    ({"E_kPa": 1.0, "nu": 0.5}, "nu = 0.5 is outside"),
    ({"E_kPa": 1.0, "nu": 0.4, "ratio": -2.0}, "ratio = -2 is outside"),
    ({"E_kPa": 1.0, "nu": 0.4, "colour": 2.0}, "no parameter"),
])
def test_bad_parameters(theta, message):
    with pytest.raises(ValueError, match=message):
        Model(("layer",)).check(theta)


def test_unknown_or_repeated_effect():
    with pytest.raises(ValueError, match="unknown effect 'glue'"):
        effect("glue")
    with pytest.raises(ValueError, match="once"):
        Model(("offset", "offset"))
    assert Model(("layer", "layer")).parameter_names[-2:] == ("thickness2_mm", "ratio2")  # layers repeat


@pytest.mark.parametrize("name, on", [("friction", {"mu": 0.5}), ("adhesion", {"w_mJ_per_m2": 5.0})])
def test_contact_effects_switch_off_exactly_and_scale_with_E(name, on):
    """Friction and adhesion are contact laws: off gives the frictionless curve bit for bit;
    on, F(2E, 2w) = 2 F(E, w) (w / E is the unit parameter)."""
    model = Model((name,))
    ramp = Protocol.ramp(0.2, 6)
    base = Model().simulate({"E_kPa": 7.0, "nu": 0.3}, protocol=ramp, mesh="coarse").force_mN
    off = model.simulate({"E_kPa": 7.0, "nu": 0.3, **EFFECTS[name].off_values()}, protocol=ramp,
                         mesh="coarse").force_mN
    assert np.array_equal(base, off)
    if name == "friction":  # stick and slip depend on the path; the adhesive traction law does not
        with pytest.raises(ValueError, match="needs a protocol"):
            model.simulate({"E_kPa": 7.0, "nu": 0.3, **on}, np.linspace(0.05, 0.2, 3), mesh="coarse")
    one = {"E_kPa": 7.0, "nu": 0.3, **on}
    two = {**one, "E_kPa": 14.0, **({"w_mJ_per_m2": 2 * on["w_mJ_per_m2"]} if name == "adhesion" else {})}
    f1 = model.simulate(one, protocol=ramp, mesh="coarse").force_mN
    f2 = model.simulate(two, protocol=ramp, mesh="coarse").force_mN
    assert np.abs(f2[1:] / (2 * f1[1:]) - 1).max() < 1e-6 and not np.array_equal(f1, base)
    assert model.unit_parameters(one) == model.unit_parameters(two)


def test_a_model_is_one_noun_parsed_once_named_once_and_composed_with_plus():
    from skin_indent.effects import Model, model_name, parse_effects
    from skin_indent.fitting.model_fit import parse_model

    m = Model.parse("neo-hooke+layer") + "layer" + ("adhesion",)
    assert m.name == str(m) == "neo-hooke+layer+layer+adhesion" == model_name(m.effects)
    assert m.parameter_names[-3:] == ("thickness2_mm", "ratio2", "w_mJ_per_m2")
    assert parse_model(m.name) == parse_effects(m) == m.effects  # the fit's parser is the model's
    assert (Model.parse("neo-hooke") + Model(("stiffening",))).effects == ("stiffening",)
    for bad, why in (("layer", "starts with neo-hooke"), ("neo-hooke+friction", "weighed"),
                     ("neo-hooke+adhesion+adhesion", "adhesion"), ("neo-hooke+glue", "glue")):
        with pytest.raises(ValueError, match=why):
            Model.parse(bad)
