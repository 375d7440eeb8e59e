"""A diagnosis reads in the units of its curve's scale (issue 28), its JSON in the package units.

An AFM-scale curve (the bundled JPK force-save curve, R = 18.64 um, forces of nN) is diagnosed
once, cheaply (one candidate, no climb, surfaces only, coarse mesh, in the gallery cache: a
few seconds): its text, sentences, HTML page and figures show um, nN and Pa (``E_Pa``,
``offset_um``), from the numbers its JSON keeps in mm, mN and kPa (``E_kPa``, ``rms_mN``). A
skin-scale diagnosis (the clean hidden-effect curve, on the surfaces conftest.py's
``diagnosis_surfaces`` builds once) reads as it always did, in mm, mN and kPa.
"""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

import skin_indent as si
from skin_indent.cli import main
from skin_indent.diagnosis import diagnose
from skin_indent.diagnosis.evidence import sentence as separation_sentence
from skin_indent.diagnosis.identifiability import candidates, suggestion
from skin_indent.diagnosis.outlook import Assessment, Outlook
from skin_indent.diagnosis.measurements import base_history
from skin_indent.diagnosis.separation import Separation
from skin_indent.measurement import load_csv
from skin_indent.measurement.scale import (AFM_UNITS, PACKAGE_UNITS, SKIN_UNITS, Quantity, Unit, UnitText, joined,
                                          shown_in)
from skin_indent.report.diagnosis_page import (fit_figure, ladder_figure, page_context, render_page,
                                               residual_figure)
from skin_indent.runtime.json_io import dumps

JPK = si.bundled_path("afm_jpk_force-save-example_R18.64um.csv")
#: cheap settings: one candidate, no climb, surfaces only
CHEAP = {"candidates": ("offset",), "max_rungs": 0, "in_loop": False, "mesh": "coarse"}
#: a number as the texts print it
NUMBER = r"[-+]?[\d.]+(?:e[-+]?\d+)?"


@pytest.fixture(scope="module")
def afm(gallery_cache):
    """The AFM-scale curve diagnosed against the offset (not detectable: its contact point is fitted)."""
    return diagnose(load_csv(JPK), cache_dir=gallery_cache, workers=1, progress=False, **CHEAP)


@pytest.fixture(scope="module")
def skin(gallery_cache, hidden, diagnosis_surfaces):
    """The clean skin-scale curve against offset and stiffening, no climb."""
    return diagnose(hidden["v01_clean"], candidates=("offset", "stiffening"), max_rungs=0, in_loop=False,
                    cache_dir=gallery_cache, mesh="coarse", workers=1, progress=False)


def _ranges(text: str, unit: str) -> list[float]:
    """The numbers of the depth ranges (``from A to B unit``) of a text, in order."""
    return [float(v) for pair in re.findall(rf"from ({NUMBER}) to ({NUMBER}) {unit}", text) for v in pair]


# ------------------------------------------------------------------ one place decides
def test_the_scale_of_the_first_curve_decides_the_units(afm, skin):
    assert afm.units is AFM_UNITS and skin.units is SKIN_UNITS
    # several curves of one sample: the first curve's scale
    assert dataclasses.replace(skin, curves=[afm.data, skin.data]).units is AFM_UNITS
    assert dataclasses.replace(afm, curves=[skin.data, afm.data]).units is SKIN_UNITS


# ------------------------------------------------------------------ the text
def test_an_afm_diagnosis_reads_in_um_nn_and_pa(afm):
    text = afm.report()
    assert "sphere R = 18.64 um" in text and " nN" in text and "E_Pa = " in text and "offset_um = " in text
    for unit in (" mN", "kPa", " mm", "E_kPa", "offset_mm"):
        assert unit not in text, (unit, text)
    assert afm.report(PACKAGE_UNITS) != text and " mN" in afm.report(PACKAGE_UNITS)
    assert afm.sentence() in text and " nN" in afm.sentence()


def test_the_afm_json_keeps_the_package_units_and_the_same_numbers(afm):
    out = json.loads(dumps(afm.to_dict()))
    flat = json.dumps(out)
    assert "E_kPa" in out["current"]["parameters"] and "offset_mm" in out["current"]["parameters"]
    assert "E_Pa" not in flat and "offset_um" not in flat and " nN" not in flat
    # the JSON's sentence: the package units, the text's numbers converted
    assert out["sentence"] == afm.sentence(PACKAGE_UNITS) and " mN" in out["sentence"]
    assert " nN" not in out["sentence"] and " um" not in out["sentence"]
    text = afm.report()
    lines = [line for line in text.splitlines() if line.startswith("  neo-hooke ")]
    assert len(lines) == 1 == len(out["ladder"])
    rung = out["ladder"][0]
    assert f"RMS {rung['rms_mN'] * 1e6:.4g} nN" in lines[0]
    assert f"noise: {out['noise_mN'] * 1e6:.4g} nN" in text
    assert f"E_Pa = {rung['parameters']['E_kPa'] * 1e3:.4g} +- {rung['std']['E_kPa'] * 1e3:.2g}" in lines[0]
    assert f"offset_um = {rung['parameters']['offset_mm'] * 1e3:.4g}" in lines[0]
    assert f"({rung['rms_mN'] * 1e6:.3g} nN RMS against {out['noise_mN'] * 1e6:.3g} nN noise" in afm.sentence()
    assert f"({rung['rms_mN']:.3g} mN RMS against {out['noise_mN']:.3g} mN noise" in out["sentence"]
    # where the model fails: the same depth ranges, in um in the text and in mm in the JSON
    structure = rung["structure"]
    (shown,) = [line for line in text.splitlines() if line.startswith("where neo-hooke fails: ")]
    mm, um = _ranges(structure, "mm"), _ranges(shown, "um")
    assert mm and um == pytest.approx([1e3 * v for v in mm], rel=5e-3)
    # a reason a parameter is not determined (nu at the edge of its range): named in its units
    assert out["undetermined"] == {k: str(v) for k, v in afm.undetermined().items()}


def test_a_skin_diagnosis_reads_as_before(skin):
    text = skin.report()
    assert text == skin.report(SKIN_UNITS) and skin.sentence() == skin.to_dict()["sentence"]
    assert "sphere R = 6.22 mm" in text and " mN" in text and "E_kPa = " in text
    assert " nN" not in text and "E_Pa" not in text and " um" not in text


# ------------------------------------------------------------------ the measurement that separates two explanations
def test_the_separating_measurement_keeps_its_numbers_and_reads_in_nn(afm):
    """The sentence evidence.py makes (``suggested_measurement``) is a UnitText: JSON in mm and mN, the text in
    um and nN, the same numbers."""
    rung = afm.current
    h = np.asarray(rung.bound_model.evaluate(rung.x).h_mm, dtype=float)
    candidate = candidates(base_history(afm.data, h))[0][1]  # a sphere of half the radius
    said = separation_sentence(candidate, Separation("a", "b", 2.5e-6, 40.0, 12.3, 200), "layer", "offset",
                               afm.noise_mN)
    assert isinstance(said, str) and "differ there by up to 2.5e-06 mN" in said and " mm)" in said
    assert "differ there by up to 2.5 nN" in said.in_units(AFM_UNITS)
    radius_mm = float(re.search(rf"R = ({NUMBER}) mm", said).group(1))
    radius_um = float(re.search(rf"R = ({NUMBER}) um", said.in_units(AFM_UNITS)).group(1))
    assert radius_um == pytest.approx(1e3 * radius_mm, rel=5e-3) and radius_um == pytest.approx(9.32, abs=0.01)
    # a diagnosis whose climb added stiffening, with layer nearly as good: the sentence names the measurement
    added = dataclasses.replace(afm.base, effects=("stiffening",), model="neo-hooke+stiffening")
    rival = dataclasses.replace(afm, ladder=[afm.base, added], verdict="stiffening", suggested_measurement=said,
                                confounded_with=["stiffening", "layer"])
    assert f"Layer explains it nearly as well: {said.in_units(AFM_UNITS)}." in rival.report()
    assert str(said) not in rival.report()
    out = rival.to_dict()
    assert out["suggested_measurement"] == str(said) and f"nearly as well: {said}." in out["sentence"]


def test_a_measurement_that_would_determine_a_parameter_reads_in_the_units_shown(afm):
    rung = afm.current
    base = base_history(afm.data, np.asarray(rung.bound_model.evaluate(rung.x).h_mm, dtype=float))
    larger = candidates(base, radii=(2 * afm.data.radius_mm,))[0][1]  # twice the radius
    outlook = Outlook([rung.model], rung.model, {"E_kPa": 0.3}, afm.noise_mN,
                      [Assessment(larger, std={"E_kPa": 0.012, "offset_mm": 4e-5})])
    clause = suggestion("E_kPa", 0.2, outlook)
    h = Quantity(float(np.max(base.depth_mm)), "mm")
    assert clause == f"; fitted with this curve, a sphere of twice the radius (R = 0.0373 mm) to the same depth " \
                     f"({h.value:.3g} mm) would determine it to +- 0.012"
    assert shown_in(clause, AFM_UNITS) == ("; fitted with this curve, a sphere of twice the radius (R = 37.3 um) to "
                                           f"the same depth ({1e3 * h.value:.3g} um) would determine it to +- 12")


# ------------------------------------------------------------------ the page and the figures
def test_the_page_of_an_afm_diagnosis_reads_in_um_nn_and_pa(afm):
    page = render_page([page_context(afm)], None, title="afm")
    assert "<th>RMS (nN)</th>" in page and "sphere R = 18.64 um" in page and "E_Pa = " in page
    assert f"Noise {afm.noise_mN * 1e6:.4g} nN" in page
    assert f"<td>{afm.current.rms_mN * 1e6:.4g}</td>" in page
    for unit in (" mN", "kPa", " mm", "E_kPa", "offset_mm", "(mm)", "(mN)"):
        assert unit not in page, unit
    assert afm.sentence() in page.replace("&#39;", "'")


def test_the_figures_of_an_afm_diagnosis_are_in_um_and_nn(afm):
    fig = fit_figure(afm)
    (ax,) = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("depth (um)", "force (nN)")
    measured = ax.lines[0]
    assert np.allclose(measured.get_xdata(), afm.data.depth_mm * 1e3)
    assert np.allclose(measured.get_ydata(), afm.data.force_mN * 1e6)
    assert any(f"RMS {afm.current.rms_mN * 1e6:.3g} nN" in t.get_text() for t in ax.get_legend().get_texts())
    residual = residual_figure(afm)
    assert {a.get_ylabel() for a in residual.axes} == {"residual (nN)"}
    assert residual.axes[0].get_xlabel() in ("", "depth (um)") and "depth (um)" in [a.get_xlabel()
                                                                                     for a in residual.axes]
    ladder = ladder_figure(afm)
    assert ladder.axes[0].get_ylabel() == "RMS residual (nN)"
    assert ladder.axes[0].patches[0].get_height() == pytest.approx(afm.current.rms_mN * 1e6)


def test_the_figures_of_a_skin_diagnosis_stay_in_mm_and_mn(skin):
    (ax,) = fit_figure(skin).axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("depth (mm)", "force (mN)")
    assert np.array_equal(ax.lines[0].get_ydata(), skin.data.force_mN)
    assert ladder_figure(skin).axes[0].get_ylabel() == "RMS residual (mN)"


# ------------------------------------------------------------------ the command line
def test_skin_indent_diagnose_prints_an_afm_curve_in_its_units(gallery_cache, monkeypatch, capsys):
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(gallery_cache))
    args = ["diagnose", str(JPK), "--candidates", "offset", "--max-rungs", "0", "--surfaces-only", "--mesh", "coarse",
            "-q"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "sphere R = 18.64 um" in text and "E_Pa = " in text and " mN" not in text and "kPa" not in text
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["radius_mm"] == pytest.approx(0.01864) and "E_kPa" in out["current"]["parameters"]
    rms = float(re.search(rf"RMS ({NUMBER}) nN", text).group(1))
    assert rms == float(f"{out['ladder'][0]['rms_mN'] * 1e6:.4g}")


# ------------------------------------------------------------------ texts that hold numbers
def test_unit_texts_nest_and_join():
    ranges = UnitText("too soft from {a:.3g} to {b:.3g} {unit}", a=Quantity(0.0121, "from_mm"),
                      b=Quantity(0.0298, "to_mm"), unit=Unit("mm"))
    assert ranges == "too soft from 0.0121 to 0.0298 mm"
    assert ranges.in_units(AFM_UNITS) == "too soft from 12.1 to 29.8 um"
    whole = joined("; ", ["curve 1 {x}: ", ranges])
    assert isinstance(whole, UnitText) and whole == "curve 1 {x}: ; too soft from 0.0121 to 0.0298 mm"
    assert shown_in(whole, AFM_UNITS) == "curve 1 {x}: ; too soft from 12.1 to 29.8 um"
    assert joined(", ", ["a", "b"]) == "a, b" and not isinstance(joined(", ", ["a", "b"]), UnitText)
    nested = UnitText("{what} by {f:.2g}", what=ranges, f=Quantity(3e-6, "mN"))
    assert nested.in_units(AFM_UNITS) == "too soft from 12.1 to 29.8 um by 3 nN"
    with pytest.raises(ValueError, match="Unit takes one of"):
        Unit("s")
