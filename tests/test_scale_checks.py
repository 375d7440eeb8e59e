"""Scale checks that catch common slips (skin_indent.fitting.scale_checks), the units of a curve's
scale (skin_indent.measurement.scale), nu = 0.5 by default at AFM scale, and ``fit DIR --recursive``.

Each slip a user reported is made on a bundled curve (forces in N labelled mN, an AFM radius in
um typed as mm, a curve of 5 points) and must give a flag or a refusal that names the likely
cause. Fits run on the coarse unit-radius surfaces of the gallery cache (conftest.py
``coarse_unit_surfaces``), so each costs well under a second.
"""

import json
import pickle
import re

import numpy as np
import pytest

import skin_indent as si
from skin_indent.batch import BatchRow, expand_paths
from skin_indent.cli import main
from skin_indent.fitting import fit
from skin_indent.fitting.scale_checks import MODULUS_RANGE_KPA, min_points, soft_min_points
from skin_indent.measurement import MeasurementError, load_csv, measurement_from_arrays
from skin_indent.measurement.scale import (AFM_UNITS, SKIN_UNITS, Name, Quantity, UnitText, afm_scale,
                                          display_units, shown_in)
from skin_indent.report.batch_table import row_line

JPK = si.bundled_path("afm_jpk_force-save-example_R18.64um.csv")
FOREARM = si.bundled_path("forearm_like.csv")


@pytest.fixture
def cli(capsys, coarse_unit_surfaces, monkeypatch):
    """``(code, stdout, stderr)`` of ``skin-indent ARGS`` in this process, on the gallery cache."""
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(coarse_unit_surfaces))

    def run(*args):
        capsys.readouterr()
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return code, out, err

    return run


def _forearm(scale=1.0, every=1, rows=None):
    m = load_csv(FOREARM)
    depth, force = m.depth_mm[::every], m.force_mN[::every] * scale
    if rows is not None:
        depth, force = depth[:rows], force[:rows]
    return measurement_from_arrays(depth, force, source="forearm", radius_mm=6.22)


def _write(path, m):
    path.write_text("# radius_mm: 6.22\ndepth_mm,force_mN\n"
                    + "".join(f"{d:.9g},{f:.9g}\n" for d, f in zip(m.depth_mm, m.force_mN)))
    return path


# ------------------------------------------------------------------ the reported slips
def test_forces_in_newton_labelled_mN_are_flagged_with_the_force_unit(context):
    good = fit(_forearm(), context=context, mesh="coarse")
    slip = fit(_forearm(scale=1e-3), context=context, mesh="coarse")
    assert slip.parameters["E_kPa"] < MODULUS_RANGE_KPA[0] <= good.parameters["E_kPa"]
    modulus = [f for f in slip.flags if f.startswith("E = ")]
    assert len(modulus) == 1 and "forces in N in a column labelled mN" in modulus[0] and "10 Pa" in modulus[0]
    assert not [f for f in good.flags if f.startswith("E = ")]
    assert slip.to_dict()["flags"] == list(slip.flags)


def test_forces_in_newton_exit_3_with_strict_and_warn_on_stderr(cli, tmp_path):
    path = _write(tmp_path / "newton.csv", _forearm(scale=1e-3))
    code, out, err = cli("fit", path, "--mesh", "coarse", "--strict")
    assert code == 3
    warnings = [line for line in err.splitlines() if "forces in N" in line]
    assert len(warnings) == 1 and warnings[0].startswith("skin-indent fit: warning:")
    assert "E_kPa" in out and " mN" in out  # a skin-scale curve reads in the package units


def test_afm_radius_in_um_typed_as_mm_is_flagged_with_the_radius_unit(context):
    m = load_csv(JPK)
    slip = fit(m, radius_mm=18.64, context=context, mesh="coarse")  # 18.64 um meant
    depth = [f for f in slip.flags if f.startswith("h/R = ")]
    assert len(depth) == 1 and "a radius in um typed as mm" in depth[0] and "0.01864 for 18.64 um" in depth[0]
    assert any("radius in um typed as mm" in f for f in slip.flags if f.startswith("E = "))
    good = fit(m, context=context, mesh="coarse")
    assert good.radius_mm == pytest.approx(0.01864) and good.flags == ()


def test_a_radius_that_makes_the_contact_wider_than_the_sphere_is_refused(context):
    m = load_csv(JPK)
    with pytest.raises(MeasurementError, match=r"deeper than the sphere's radius.*mm labelled um"):
        fit(m, radius_mm=1.864e-5, context=context, mesh="coarse")  # 18.64 um written as 0.01864 um


def test_five_points_are_flagged_and_two_refused(context):
    # rows 0 (h = 0), then 5 in contact: too few to estimate the noise from, given
    five = fit(_forearm(every=15, rows=6), noise_mN=0.05, context=context, mesh="coarse")
    assert five.n_points == 6 and five.n_free == 2  # every point fitted, the one at h = 0 too
    few = [f for f in five.flags if "points in contact" in f]
    assert len(few) == 1 and few[0].startswith("5 points in contact for 2 fitted parameters")
    assert "decimated export" in few[0]
    with pytest.raises(MeasurementError,
                       match=r"3 point\(s\) in contact for 2 fitted parameter\(s\) of neo-hooke, at least 4"):
        fit(_forearm(every=15, rows=4), context=context, mesh="coarse")
    # holding nu leaves one parameter: 3 points are enough to fit, and still too few to trust
    three = fit(_forearm(every=15, rows=4), fixed={"nu": 0.45}, noise_mN=0.05, context=context, mesh="coarse")
    assert any(f.startswith("3 points in contact for 1 fitted parameters") for f in three.flags)
    assert (min_points(1), min_points(2), soft_min_points(2), soft_min_points(3)) == (3, 4, 10, 15)


def test_too_few_points_on_the_command_line_is_one_line_exit_2(cli, tmp_path):
    path = _write(tmp_path / "three.csv", _forearm(every=15, rows=4))
    code, out, err = cli("fit", path, "--mesh", "coarse")
    assert code == 2 and "E_kPa" not in out
    assert err.count("\n") == 1 and "at least 4 needed" in err and "--fix nu=0.5" in err


def test_a_parameter_whose_sd_exceeds_its_value_is_flagged(context):
    """E and nu of the first 5 points (h/R < 0.02): E's sd exceeds E; the whole curve determines it."""
    r = fit(_forearm(every=4, rows=6), noise_mN=0.05, context=context, mesh="coarse")
    assert r.std["E_kPa"] > r.parameters["E_kPa"]
    flags = [f for f in r.flags if "is not determined by this curve" in f]
    assert flags[0].startswith(f"E_kPa is not determined by this curve (sd {r.std['E_kPa']:.3g} > value ")
    whole = fit(_forearm(), context=context, mesh="coarse")
    assert not any("is not determined" in f for f in whole.flags)


def test_the_chosen_model_path_has_the_same_checks(context):
    seven = fit(_forearm(every=10, rows=8), model="neo-hooke", context=context, mesh="coarse")
    assert seven.n_free == 2 and any(f.startswith("7 points in contact for 2 fitted") for f in seven.flags)
    whole = fit(_forearm(), model="neo-hooke", context=context, mesh="coarse")
    assert not [f for f in whole.flags if not f.startswith(("nu at the bound", "misfit"))]


def test_a_model_fit_of_too_few_points_for_the_noise_names_the_cause(context, cli, tmp_path):
    """The chosen-model path estimates the noise from the data (a local cubic: 7 points at least):
    fewer points are one line naming the cause and --noise; with the noise given, the fit runs."""
    six = _forearm(every=15, rows=6)  # h = 0 and 5 points in contact: 6 points on the model path
    with pytest.raises(MeasurementError, match=r"forearm: 6 points are too few to estimate the noise from the data \(the "
                                               r"local cubic prediction needs at least 7\): give the noise level"):
        fit(six, model="neo-hooke", context=context, mesh="coarse")
    given = fit(six, model="neo-hooke", noise_mN=0.05, context=context, mesh="coarse")
    assert given.n_points == 6 and any(f.startswith("5 points in contact") for f in given.flags)
    path = _write(tmp_path / "six.csv", six)
    for command in ("fit", "diagnose"):
        extra = ("--model", "neo-hooke") if command == "fit" else ("--max-rungs", "0", "--surfaces-only")
        code, out, err = cli(command, path, *extra, "--mesh", "coarse")
        assert code == 2 and err.count("\n") == 1, err
        assert "too few to estimate the noise" in err and "--noise" in err and "need at least 7 points" not in err


# ------------------------------------------------------------------ units follow the data
def test_one_rule_decides_the_scale_and_its_units():
    assert afm_scale(0.01864) and afm_scale(0.499) and not afm_scale(0.5) and not afm_scale(6.22)
    assert display_units(0.0275) is AFM_UNITS and display_units(6.22) is SKIN_UNITS
    assert (AFM_UNITS.name("E_kPa"), AFM_UNITS.name("offset_mm"), AFM_UNITS.name("nu")) == ("E_Pa", "offset_um", "nu")
    assert AFM_UNITS.factor("E_kPa") == 1e3 and AFM_UNITS.factor("baseline_mN") == 1e6


def test_an_afm_fit_reads_in_pa_nn_and_um_and_its_json_keeps_the_package_units(context):
    r = fit(load_csv(JPK), context=context, mesh="coarse")
    text = r.report()
    E_Pa = r.parameters["E_kPa"] * 1e3
    assert f"E_Pa      = {E_Pa:.5g} +/-" in text
    assert f"contact point: {r.contact_point_mm * 1e3:.6g} +/-" in text and " um (fitted jointly" in text
    assert f"noise {r.quality['noise_mN'] * 1e6:.3g} nN" in text and " mN" not in text
    d = r.to_dict()
    assert d["parameters"]["E_kPa"] == r.parameters["E_kPa"] and "contact_point_mm" in d
    row = BatchRow(file="a.csv", index=0, radius_mm=0.01864, E_kPa=0.132, E_star_kPa=0.176, nu=0.5,
                   contact_point_mm=0.00123, misfit=1.0, verdict="fits to the noise")
    assert row_line(row).startswith("a.csv[0]: E = 132 Pa, E* = 176 Pa, nu = 0.5, contact 1.23 um")
    skin = BatchRow(file="b.csv", index=0, radius_mm=6.22, E_kPa=5.7, E_star_kPa=7.0, nu=0.45,
                    contact_point_mm=0.0, misfit=1.0, verdict="fits to the noise")
    assert row_line(skin).startswith("b.csv[0]: E = 5.7 kPa, E* = 7 kPa, nu = 0.45, contact 0 mm")


def test_the_notes_of_an_afm_fit_read_in_its_units_and_its_json_in_the_package_units(context, cli):
    """The incompressible limit's note (E* at nu = 0.49, 0.499, and 0.5), a value held and a prior print in
    Pa and um, from the numbers the JSON keeps in kPa and mm."""
    limit = fit(load_csv(JPK), context=context, mesh="coarse")
    (note,) = [n for n in limit.notes if n.startswith("nu = 0.5: the incompressible limit")]
    kPa = [float(v) for v in re.findall(r"\(?([-+\d.e]+) kPa", note)]
    assert len(kPa) == 3 and kPa[-1] == pytest.approx(limit.e_star_kPa, rel=1e-4)  # JSON: package units
    text = limit.report()
    (shown,) = [line for line in text.splitlines() if line.startswith("note: nu = 0.5: the incompressible")]
    Pa = [float(v) for v in re.findall(r"\(?([-+\d.e]+) Pa", shown)]
    assert Pa == pytest.approx([1e3 * v for v in kPa], rel=1e-4) and "kPa" not in text
    assert limit.to_dict()["notes"] == [str(n) for n in limit.notes]
    held = fit(load_csv(JPK), fixed={"nu": 0.45}, context=context, mesh="coarse")
    E = held.parameters["E_kPa"]
    assert f"nu fixed at 0.45; E = {E:.5g} kPa" in held.notes
    assert f"note: nu fixed at 0.45; E = {E * 1e3:.5g} Pa" in held.report()
    code, out, err = cli("fit", JPK, "--model", "neo-hooke", "--fix", "offset_mm=0.0268", "--prior",
                         "E_kPa=0.13:0.05", "--mesh", "coarse")
    assert code in (0, 3) and "note: offset_um held at 26.8" in out and "contact point: 26.8 um (held)" in out
    assert re.search(r"note: E_Pa: prior 130 \+- 50, posterior [\d.]+ \+- ", out), out
    assert " kPa" not in out and " mm" not in out.split("sphere R")[1]
    code, out, _ = cli("fit", JPK, "--model", "neo-hooke", "--fix", "offset_mm=0.0268", "--prior",
                       "E_kPa=0.13:0.05", "--mesh", "coarse", "--json")
    notes = json.loads(out)["notes"]
    assert "offset_mm held at 0.0268" in notes and any(n.startswith("E_kPa: prior 0.13 +- 0.05") for n in notes)


def test_unit_texts_read_in_any_units_and_pickle():
    note = UnitText("{name} held at {value:g}; E = {E:.3g}", name=Name("offset_mm"), value=Quantity(0.0072, "offset_mm"),
                    E=Quantity(0.132, "kPa"))
    assert note == "offset_mm held at 0.0072; E = 0.132 kPa"
    assert note.in_units(AFM_UNITS) == "offset_um held at 7.2; E = 132 Pa" and shown_in(note, SKIN_UNITS) == note
    again = pickle.loads(pickle.dumps(note))
    assert again == note and again.in_units(AFM_UNITS) == note.in_units(AFM_UNITS)
    assert json.loads(json.dumps({"n": note})) == {"n": str(note)} and shown_in("plain", AFM_UNITS) == "plain"


def test_the_fit_command_prints_an_afm_curve_in_its_units(cli):
    code, out, err = cli("fit", JPK, "--mesh", "coarse")
    assert code == 0 and err.count("warning") == 0, err
    assert "sphere R = 18.64 um" in out and "E_Pa" in out and "nu        = 0.5 (fixed)" in out


# ------------------------------------------------------------------ nu per field
def test_nu_is_held_at_half_at_afm_scale_unless_freed(context):
    m = load_csv(JPK)
    held = fit(m, context=context, mesh="coarse")
    explicit = fit(m, fixed={"nu": 0.5}, context=context, mesh="coarse")
    assert held.parameters == explicit.parameters and "nu" in held.fixed_names
    assert any("default at AFM scale" in n for n in held.notes)
    freed = fit(m, free=("nu",), context=context, mesh="coarse")
    assert "nu" in freed.free_names
    with pytest.raises(ValueError, match="both held"):
        fit(m, fixed={"nu": 0.45}, free=("nu",), context=context, mesh="coarse")
    skin = fit(_forearm(), context=context, mesh="coarse")
    assert "nu" in skin.free_names  # the paper's convention at skin scale


def test_free_nu_on_the_command_line(cli):
    code, out, err = cli("fit", JPK, "--mesh", "coarse", "--free", "nu", "--json")
    assert '"nu"' in out and "nu at the bound" in err  # freed by request: its bound is flagged again
    code, _, err = cli("fit", JPK, "--free", "nu", "--fix", "nu=0.45")
    assert code == 2 and err.count("\n") == 1 and "give one of them" in err


# ------------------------------------------------------------------ folders
def test_folders_are_searched_recursively_on_request(tmp_path, cli):
    (tmp_path / "sub" / "deeper").mkdir(parents=True)
    (tmp_path / ".hidden").mkdir()
    for p in ("a.csv", "sub/b.csv", "sub/deeper/c.csv", ".hidden/d.csv", "sub/notes.md"):
        (tmp_path / p).write_text("depth_mm,force_mN\n0,0\n")
    assert [p.name for p in expand_paths(tmp_path)] == ["a.csv"]
    assert [p.relative_to(tmp_path).as_posix() for p in expand_paths(tmp_path, recursive=True)] == [
        "a.csv", "sub/b.csv", "sub/deeper/c.csv"]
    code, out, err = cli("fit", tmp_path, "--recursive", "--mesh", "coarse")
    assert code == 3 and "3 curves: 3 failed" in out  # every file found, each a row with its error
    code, _, err = cli("fit", JPK, "--recursive")
    assert code == 2 and "give a folder" in err


def test_the_bundled_skin_curves_raise_no_scale_flag(context):
    for name in ("forearm_like.csv", "neo-hooke_halfspace_E8kPa_nu0.45.csv", "v02_layer_soft_base.csv"):
        r = fit(load_csv(si.bundled_path(name)), context=context, mesh="coarse")
        scale = [f for f in r.flags if not f.startswith(("nu at the bound", "misfit"))]
        assert scale == [], (name, scale)
    assert np.isfinite(r.parameters["E_kPa"])


# ------------------------------------------------------------------ the same checks before a diagnosis
def test_diagnose_plan_and_batches_refuse_a_slip_before_any_finite_element_work(cli, tmp_path, monkeypatch):
    """The slips ``fit`` flags stop ``diagnose``, ``plan`` and each curve of a batch in one line, before
    a surface or a finite-element run is asked for (any such request fails this test)."""
    from skin_indent.response_surface import ResponseSurface

    def no_fe(*args, **kwargs):
        raise AssertionError("finite-element work asked for")

    monkeypatch.setattr(ResponseSurface, "build", no_fe)
    newton = _write(tmp_path / "newton.csv", _forearm(scale=1e-3))
    for command in ("diagnose", "plan"):
        code, out, err = cli(command, newton, "--out", tmp_path / command) if command == "plan" else cli(command, newton)
        assert code == 2 and err.count("\n") == 1, (command, err)
        assert "forces in N in a column labelled mN" in err and "before any finite-element work" in err
    code, _, err = cli("diagnose", JPK, "--radius", "18.64")  # 18.64 um meant
    assert code == 2 and err.count("\n") == 1
    assert "0.01864 for 18.64 um" in err and "radius in um typed as mm" in err
    code, out, err = cli("diagnose", newton, "--out", tmp_path / "rows.tsv", "--workers", "1")
    assert code == 3 and "1 failed" in out and "forces in N" in out


def test_curve_scale_flags_are_the_fit_flags_of_the_same_slips():
    from skin_indent.fitting.scale_checks import curve_scale_flags
    from skin_indent.measurement import prepare

    assert curve_scale_flags(prepare(_forearm())) == []
    assert curve_scale_flags(prepare(load_csv(JPK))) == []
    slip = curve_scale_flags(prepare(_forearm(scale=1e-3)))
    assert len(slip) == 1 and slip[0].startswith("E = ") and "forces in N" in slip[0]
    radius = curve_scale_flags(prepare(load_csv(JPK), radius_mm=18.64))
    assert [f[:6] for f in radius] == ["h/R = ", "E = 4."]


def test_diagnose_holds_nu_at_afm_scale_unless_freed(monkeypatch):
    """As ``fit``: nu held at AFM scale (at 0.49, the surfaces' nearly incompressible end), free on
    request and at skin scale; a note says so and by how much E at nu = 0.5 differs."""
    from skin_indent.diagnosis.knowns import AFM_NU, scale_conventions
    from skin_indent.measurement import prepare

    afm, skin = prepare(load_csv(JPK)), prepare(_forearm())
    fixed, notes = scale_conventions([afm], None, None)
    assert fixed == {"nu": AFM_NU} and len(notes) == 1 and "1.3 % lower" in notes[0] and "--free nu" in notes[0]
    assert scale_conventions([afm], None, None, free=("nu",)) == (None, [])
    assert scale_conventions([afm], {"nu": 0.45}, None) == ({"nu": 0.45}, [])
    assert scale_conventions([afm], None, {"nu": (0.45, 0.02)}) == (None, [])
    assert scale_conventions([skin], None, None) == (None, [])
    assert scale_conventions([afm, skin], None, None) == (None, [])  # a sample measured at both scales: free
    with pytest.raises(ValueError, match="both held"):
        scale_conventions([afm], {"nu": 0.45}, None, free=("nu",))
