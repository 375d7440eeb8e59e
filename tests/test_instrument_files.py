"""Instrument files as instruments write them (tests/data/instrument-files, see its README).

Every bundled file loads in package units with the radius it records; JPK files read through
afmformats and the Chiaro export read by skin_indent's own reader equal the CSVs of
tests/data/real-data; force maps give all their curves; CSV comment lines are skipped; broken
files give one-line MeasurementErrors. nanite_reference.json (nanite's fits, written by
make_nanite_reference.py in a separate venv) is checked against these readings' depth axis.
"""

import json
import sys
import types

import numpy as np
import pytest
from _data import DATA

from skin_indent.measurement import (MeasurementError, find_segments, load_chiaro_txt, load_csv, load_curve,
                                     load_curves)
from skin_indent.measurement.csv_io import parse_radius_comment
from skin_indent.measurement.optics11 import is_chiaro_txt

FILES = DATA / "instrument-files"
REAL = DATA / "real-data"
CHIARO = "fmt-chiaro-txt_AEBP1_Indentation_002.txt"
FORCE_SAVE = "force-save-example.jpk-force"
SPOT3 = "fmt-jpk-fd_spot3-0192.jpk-force"
MAP = "fmt-jpk-fd_map-data-reference-points.jpk-force-map"
BRAIN = "fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force"
COMMENTS = "csv/comments_hertz_R18.64um.csv"

try:
    import afmformats
except ImportError:
    afmformats = None
needs_afmformats = pytest.mark.skipif(
    afmformats is None, reason="afmformats is not installed (pip install 'skin_indent[afm]'): JPK files "
                               "cannot be read without it")

# file: (curves, points per curve, radius_mm recorded in the file, depth span (mm), peak force (mN))
EXPECTED = {
    FORCE_SAVE: (1, 8400, None, (0.02, 0.04), (2e-6, 2e-5)),
    SPOT3: (1, 4000, None, (0.003, 0.006), (1e-6, 1e-5)),
    MAP: (3, 14000, None, (0.04, 0.06), (1e-6, 1e-5)),
    BRAIN: (1, 9000, None, (0.02, 0.04), (1e-5, 5e-5)),
    CHIARO: (1, 13827, 0.0275, (0.08, 0.1), (2e-5, 1e-4)),
    COMMENTS: (1, 31, 0.01864, (0.014, 0.016), (3e-5, 5e-5)),
}
AFM = {FORCE_SAVE, SPOT3, MAP, BRAIN}
# bundled instrument file -> the real-data CSV converted from the same file
SAME_CURVE = {FORCE_SAVE: "jpk_force-save-example_R18.64um.csv", BRAIN: "jpk_creep_brain_Runknown.csv",
              CHIARO: "chiaro_AEBP1_R27.5um.csv"}


def maybe_afm(name):
    return pytest.param(name, marks=needs_afmformats) if name in AFM else name


def one_line_error(call, *fragments) -> str:
    with pytest.raises(MeasurementError) as info:
        call()
    message = str(info.value)
    assert message and "\n" not in message and "\r" not in message
    for fragment in fragments:
        assert fragment in message, message
    return message


# ------------------------------------------------------------------ every bundled file
@pytest.mark.parametrize("name", [maybe_afm(n) for n in EXPECTED])
def test_every_bundled_file_loads_in_package_units(name):
    n_curves, n_points, radius, (span_lo, span_hi), (peak_lo, peak_hi) = EXPECTED[name]
    curves = load_curves(FILES / name)
    assert len(curves) == n_curves
    for i, m in enumerate(curves):
        assert m.n_points == n_points and m.has_time
        assert m.time_s[0] == 0 and np.all(np.diff(m.time_s) >= 0)
        assert m.depth_mm[0] == 0 and not np.signbit(m.depth_mm[0])
        assert span_lo < np.ptp(m.depth_mm) < span_hi  # um-scale depths in mm
        assert peak_lo < m.force_mN.max() < peak_hi  # nN-scale forces in mN
        assert m.radius_mm == radius
        kinds = [s.kind for s in find_segments(m)]
        assert kinds[0] == "approach" and (kinds[-1] == "retract") == (name != COMMENTS)
        base = (FILES / name).name
        assert m.source == (base if n_curves == 1 else f"{base}[{i}]")
        reader = m.columns.get("reader", {"index": 0, "n_curves": 1})
        assert (reader["index"], reader["n_curves"]) == (i, n_curves)
    assert load_curve(FILES / name).source == curves[0].source


@pytest.mark.parametrize("name", [maybe_afm(n) for n in SAME_CURVE])
def test_instrument_file_reads_exactly_as_the_real_data_csv(name):
    """The real-data CSVs were converted from these very files: the readings are identical."""
    m, csv = load_curve(FILES / name), load_csv(REAL / SAME_CURVE[name])
    np.testing.assert_array_equal(m.depth_mm, csv.depth_mm)
    np.testing.assert_array_equal(m.force_mN, csv.force_mN)
    np.testing.assert_array_equal(m.time_s, csv.time_s)


def test_radius_argument_overrides_the_recorded_radius():
    m = load_curve(FILES / CHIARO, radius_mm=0.03)
    assert m.radius_mm == 0.03
    assert m.columns["radius_mm"] == {"from": "argument", "in_file_mm": 0.0275}
    assert load_curves(FILES / COMMENTS, radius_mm=0.02)[0].radius_mm == 0.02


# ------------------------------------------------------------------ Chiaro
def test_chiaro_header_gives_radius_and_metadata():
    m = load_chiaro_txt(FILES / CHIARO)
    assert m.radius_mm == 0.0275 and m.columns["radius_mm"]["from"].startswith("file header")
    meta = m.columns["metadata"]
    assert meta["k (N/m)"] == "0.019" and meta["Device"] == "Chiaro" and meta["E[eff] (Pa)"] == "156.009"
    assert "AEBP1_01" in meta["other lines"]
    assert m.columns["force_mN"] == {"column": "Load (uN)", "factor": 1e-3}
    assert m.columns["reader"]["format"] == "Optics11 Chiaro text export"
    assert is_chiaro_txt(FILES / CHIARO) and not is_chiaro_txt(FILES / COMMENTS)
    assert not is_chiaro_txt(FILES / "no-such-file.txt")


@needs_afmformats
def test_chiaro_reader_agrees_with_afmformats():
    ours = load_chiaro_txt(FILES / CHIARO)
    data = afmformats.load_data(FILES / CHIARO)[0]
    tip = np.asarray(data["tip position"])
    np.testing.assert_allclose(ours.depth_mm, -(tip - tip[0]) * 1e3, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ours.force_mN, np.asarray(data["force"]) * 1e3, rtol=1e-14, atol=0)
    np.testing.assert_array_equal(ours.time_s, data["time"])


CHIARO_HEAD = ("Date\t12/05/2025\tTime\t11:20:38\r\nk (N/m)\t0.019\r\nTip radius (um)\t{radius}\r\n"
               "Device:\tChiaro\r\n\r\n{columns}\r\n")
CHIARO_COLUMNS = "Time (s)\tLoad (uN)\tIndentation (nm)\tCantilever (nm)\tPiezo (nm)\tAuxiliary"
CHIARO_ROWS = ["0.000\t-0.0003\t0\t-16.2\t64.9\t0", "0.001\t-0.0004\t0\t-18.4\t65.2\t0",
               "0.002\t0.0100\t0\t-10.0\t1065.2\t0", "0.003\t0.0200\t0\t-5.0\t2065.2\t0"]


def chiaro_text(radius="27.500", columns=CHIARO_COLUMNS, rows=CHIARO_ROWS):
    return CHIARO_HEAD.format(radius=radius, columns=columns) + "\r\n".join(rows) + "\r\n"


def test_small_chiaro_file_in_other_units(tmp_path):
    path = tmp_path / "mini.txt"
    path.write_text(chiaro_text(columns=CHIARO_COLUMNS.replace("Load (uN)", "Load (nN)")
                                .replace("Piezo (nm)", "Piezo (\u00b5m)").replace("Cantilever (nm)",
                                                                                "Cantilever (um)")),
                    encoding="latin-1")
    m = load_curve(path)
    np.testing.assert_allclose(m.force_mN, [-3e-10, -4e-10, 1e-8, 2e-8], rtol=1e-15)
    np.testing.assert_allclose(m.depth_mm, [0, 0.0025, 0.9941, 1.9891], rtol=1e-13)


CHIARO_BROKEN = [
    ("no column row", lambda: chiaro_text(columns="Time\tLoad"), ["not a Chiaro text export"]),
    ("force unit", lambda: chiaro_text(columns=CHIARO_COLUMNS.replace("(uN)", "(kg)")),
     ["'Load (kg)'", "not a force unit"]),
    ("length unit", lambda: chiaro_text(columns=CHIARO_COLUMNS.replace("Piezo (nm)", "Piezo (V)")),
     ["'Piezo (V)'", "not a length unit"]),
    ("no piezo", lambda: chiaro_text(columns=CHIARO_COLUMNS.replace("Piezo (nm)", "Z (nm)")),
     ["no 'Piezo (...)' column"]),
    ("non-numeric", lambda: chiaro_text(rows=CHIARO_ROWS[:2] + ["0.002\tabc\t0\t0\t0\t0"] + CHIARO_ROWS[3:]),
     ["line 9", "'Load (uN)'", "'abc'"]),
    ("nan", lambda: chiaro_text(rows=CHIARO_ROWS[:3] + ["0.003\t0.02\t0\tnan\t1\t0"]),
     ["line 10", "'Cantilever (nm)'", "not a finite number"]),
    ("missing field", lambda: chiaro_text(rows=CHIARO_ROWS[:1] + ["0.001\t-0.0004\t0"] + CHIARO_ROWS[2:]),
     ["line 8", "3 fields"]),
    ("two rows", lambda: chiaro_text(rows=CHIARO_ROWS[:2]), ["2 data rows"]),
    ("bad radius", lambda: chiaro_text(radius="abc"), ["line 3", "radius", "'abc'"]),
    ("time goes back", lambda: chiaro_text(rows=CHIARO_ROWS[:3] + ["0.001\t0.02\t0\t-5\t2065\t0"]),
     ["time_s decreases"]),
]


@pytest.mark.parametrize("text, fragments", [c[1:] for c in CHIARO_BROKEN], ids=[c[0] for c in CHIARO_BROKEN])
def test_broken_chiaro_files_give_one_line_errors(tmp_path, text, fragments):
    path = tmp_path / "broken chiaro.txt"
    path.write_text(text(), encoding="latin-1")
    one_line_error(lambda: load_chiaro_txt(path), "broken chiaro.txt", *fragments)


def test_chiaro_reader_needs_no_afmformats(monkeypatch):
    monkeypatch.setitem(sys.modules, "afmformats", None)  # import afmformats -> ImportError
    assert load_curve(FILES / CHIARO).radius_mm == 0.0275
    assert load_curves(FILES / COMMENTS)[0].n_points == 31
    one_line_error(lambda: load_curves(FILES / MAP), "pip install afmformats")


# ------------------------------------------------------------------ force maps
@needs_afmformats
def test_force_map_gives_all_its_curves_with_their_map_positions():
    curves = load_curves(FILES / MAP, radius_mm=0.01864)
    assert [m.columns["reader"]["enum"] for m in curves] == [109, 129, 416]
    assert [(m.columns["reader"]["grid_index_x"], m.columns["reader"]["grid_index_y"]) for m in curves] == [
        (9, 4), (20, 5), (16, 16)]
    positions = np.array([m.columns["reader"]["position_mm"] for m in curves])
    np.testing.assert_allclose(positions[:, 0], [-1.21977, -0.99977, -1.07977], atol=1e-5)
    assert len({m.columns["metadata"]["curve id"] for m in curves}) == 3
    assert all(m.radius_mm == 0.01864 for m in curves)
    json.dumps([m.columns for m in curves])  # the metadata is plain JSON
    one = load_curve(FILES / MAP, index=1)
    np.testing.assert_array_equal(one.depth_mm, curves[1].depth_mm)
    np.testing.assert_array_equal(one.force_mN, curves[1].force_mN)
    assert one.source == f"{MAP}[1]"


@needs_afmformats
@pytest.mark.parametrize("index", [3, -1, 10])
def test_curve_index_out_of_range_is_one_line(index):
    one_line_error(lambda: load_curve(FILES / MAP, index=index), f"curve {index} requested", "holds 3")


def test_csv_has_only_curve_zero():
    one_line_error(lambda: load_curve(FILES / COMMENTS, index=1), "curve 1 requested", "holds 1")


# ------------------------------------------------------------------ comment lines
def test_comment_lines_are_skipped_and_the_radius_comment_is_read():
    m = load_csv(FILES / COMMENTS)
    assert m.n_points == 31 and m.radius_mm == 0.01864
    assert m.columns["radius_mm"] == {"from": "comment, line 4"}
    assert m.columns["comments"][-1] == "end of approach" and len(m.columns["comments"]) == 6
    depth_m = m.depth_mm * 1e-3
    hertz_N = 2e-10 + 4 / 3 * 500 / 0.75 * np.sqrt(18.64e-6) * np.clip(depth_m - 10e-6, 0, None) ** 1.5
    np.testing.assert_allclose(m.force_mN, hertz_N * 1e3, rtol=1e-12)


def test_comments_anywhere_with_any_newline(tmp_path):
    for newline in ("\n", "\r\n", "\r"):
        text = newline.join(["# instrument: test", "  # indented comment", "depth_mm,force_mN", "0,0",
                             "# between rows, with a comma, and \"quotes", "1,1", "#", "2,4", "# end"])
        path = tmp_path / "c.csv"
        path.write_text(text + newline, newline="")
        m = load_csv(path)
        np.testing.assert_array_equal(m.depth_mm, [0, 1, 2])
        np.testing.assert_array_equal(m.force_mN, [0, 1, 4])
        assert m.radius_mm is None and "radius_mm" not in m.columns
        assert m.columns["comments"] == ["instrument: test", "indented comment",
                                         "between rows, with a comma, and \"quotes", "", "end"]


def test_line_numbers_count_comment_lines(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("# one\n# two\ndepth_mm,force_mN\n0,0\n# five\n1,x\n")
    one_line_error(lambda: load_csv(path), "line 6", "'x'")


@pytest.mark.parametrize("line, radius_mm", [
    ("# radius_um: 18.64", 0.01864), ("# tip radius (um)\t27.5", 0.0275), ("Tip radius (um)\t27.500", 0.0275),
    ("# Sphere radius = 0.5 mm", 0.5), ("# radius: 18.64 \u00b5m", 0.01864), ("#radius_m=1.864e-5", 0.01864),
    ("# tip_radius_nm: 500", 5e-4), ("# radius 10 microns", 0.01),
    ("# radius of curvature measured by SEM", None), ("# hello", None), ("# radius mismatch fixed", None),
])
def test_radius_comment_forms(line, radius_mm):
    assert parse_radius_comment(line) == (pytest.approx(radius_mm, rel=1e-12) if radius_mm else None)


BAD_COMMENT_FILES = [
    ("only comments", "# a\n# b\n", ["file is empty", "only comment lines"]),
    ("radius without unit", "# radius: 5\ndepth_mm,force_mN\n0,0\n1,1\n2,2\n", ["line 1", "without a unit"]),
    ("radius not a number", "# radius_um: big\ndepth_mm,force_mN\n0,0\n1,1\n2,2\n", ["line 1", "'big'"]),
    ("two units", "# radius_um = 5 mm\ndepth_mm,force_mN\n0,0\n1,1\n2,2\n", ["two units"]),
    ("negative radius", "# radius_um: -5\ndepth_mm,force_mN\n0,0\n1,1\n2,2\n", ["positive"]),
    ("radii disagree", "# radius_um: 5\ndepth_mm,force_mN\n0,0\n# radius_mm: 1\n1,1\n2,2\n",
     ["radius comments disagree", "line 1", "line 4"]),
    ("comment hides a row", "depth_mm,force_mN\n0,0\n# 1,1\n2,2\n", ["2 data rows"]),
]


@pytest.mark.parametrize("text, fragments", [c[1:] for c in BAD_COMMENT_FILES],
                         ids=[c[0] for c in BAD_COMMENT_FILES])
def test_bad_comment_files_give_one_line_errors(tmp_path, text, fragments):
    path = tmp_path / "bad file.csv"
    path.write_text(text)
    one_line_error(lambda: load_csv(path), "bad file.csv", *fragments)


def test_agreeing_radius_comments_and_txt_csv(tmp_path):
    path = tmp_path / "curve.txt"  # a CSV named .txt is still read as CSV
    path.write_text("# radius_um: 20\n# tip radius: 0.02 mm\ndepth_mm,force_mN\n0,0\n1,1\n2,2\n")
    assert load_curve(path).radius_mm == 0.02


# ------------------------------------------------------------------ broken instrument files
@needs_afmformats
@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 not really a zip", b"\x00" * 100, "truncated"])
def test_broken_jpk_files_give_one_line_errors(tmp_path, content):
    if content == "truncated":
        content = (FILES / FORCE_SAVE).read_bytes()[:20000]
    path = tmp_path / "broken.jpk-force"
    path.write_bytes(content)
    one_line_error(lambda: load_curves(path), "broken.jpk-force")
    one_line_error(lambda: load_curve(path), "broken.jpk-force")


def test_missing_and_directory_paths(tmp_path):
    one_line_error(lambda: load_curves(tmp_path / "nope.jpk-force"), "nope.jpk-force", "not found")
    one_line_error(lambda: load_curves(tmp_path / "nope.txt"), "nope.txt", "not found")
    folder = tmp_path / "folder.jpk-force"
    folder.mkdir()
    one_line_error(lambda: load_curves(folder), "directory")


class _FakeCurve:
    def __init__(self, columns, metadata):
        self.columns, self.metadata = columns, metadata

    def __getitem__(self, key):
        return np.linspace(0, 1e-6, 5) if key in self.columns else None


@pytest.mark.parametrize("columns, metadata, fragments", [
    (["height (measured)", "time"], {"spring constant": 0.02}, ["no force column", "calibrated"]),
    (["force", "height (measured)"], {}, ["neither a tip position", "spring constant"]),
    (["force", "time"], {"spring constant": 0.02}, ["neither a tip position"]),
])
def test_missing_columns_give_one_line_errors(tmp_path, monkeypatch, columns, metadata, fragments):
    curves = [_FakeCurve(columns, metadata)] * 2
    fake = types.SimpleNamespace(__version__="fake", load_data=lambda path: curves)
    monkeypatch.setattr("skin_indent.measurement.instrument._import_afmformats", lambda: fake)
    path = tmp_path / "fake.jpk-force"
    path.write_bytes(b"x")
    one_line_error(lambda: load_curves(path), "fake.jpk-force[0]", *fragments)
    one_line_error(lambda: load_curve(path, index=1), "fake.jpk-force[1]", *fragments)


def test_afmformats_without_curves_is_one_line(tmp_path, monkeypatch):
    fake = types.SimpleNamespace(__version__="fake", load_data=lambda path: [])
    monkeypatch.setattr("skin_indent.measurement.instrument._import_afmformats", lambda: fake)
    path = tmp_path / "empty.ibw"
    path.write_bytes(b"x")
    one_line_error(lambda: load_curves(path), "empty.ibw", "no force-distance curve")


# ------------------------------------------------------------------ nanite reference numbers
REFERENCE = json.loads((FILES / "nanite_reference.json").read_text())


def test_nanite_reference_records_how_it_was_made():
    assert REFERENCE["versions"]["nanite"] == "4.2.3" and REFERENCE["versions"]["afmformats"]
    steps = ["compute_tip_position", "correct_force_offset", "correct_tip_offset"]
    assert REFERENCE["preprocessing"] == steps
    assert REFERENCE["settings"]["hertz_unweighted"]["weight_cp"] is False
    assert REFERENCE["settings"]["hertz_unweighted"]["model_key"] == "hertz_para"
    by_curve = {(c["file"], c["index"]): c for c in REFERENCE["curves"]}
    # nanite's own test values for the map (tests/test_qmap.py) and the numbers
    assert by_curve[(MAP, 0)]["results"]["nanite_test"]["E_Pa"] == pytest.approx(57.6295, rel=1e-3)
    assert by_curve[(MAP, 1)]["results"]["nanite_test"]["E_Pa"] == pytest.approx(17608.1, rel=1e-3)
    assert by_curve[(MAP, 1)]["results"]["hertz_unweighted"]["E_Pa"] == pytest.approx(11439, rel=1e-3)
    assert by_curve[(CHIARO, 0)]["radius_um"] == 27.5


@pytest.mark.parametrize("entry", [maybe_afm(f) for f in sorted({c["file"] for c in REFERENCE["curves"]})])
def test_nanite_reference_uses_our_depth_axis(entry):
    """nanite fitted the whole approach: its fit range in our depth axis is the approach's span,
    and every recorded contact point lies inside it."""
    for c in (c for c in REFERENCE["curves"] if c["file"] == entry):
        m = load_curves(FILES / c["file"])[c["index"]]
        assert c["sha256"] and c["n_curves"] == len(load_curves(FILES / c["file"]))
        for result in c["results"].values():
            approach = m.depth_mm[: result["n_fit_points"]]
            np.testing.assert_allclose(result["fit_range_depth_mm"], [approach.min(), approach.max()],
                                       rtol=0, atol=1e-12)
            assert approach.min() < result["contact_point_depth_mm"] < approach.max()
        radius = c["radius_m"] * 1e3
        if m.radius_mm is not None:
            assert m.radius_mm == pytest.approx(radius, rel=1e-12)


# ------------------------------------------------------------------ peer check: nanite's Hertz fits
#: Curves where our Hertz fit must match nanite's unweighted one (1% in E, 0.1 um in the
#: contact point). Two differ: spot3 by -1.9% in E (same contact point; its radius is not
#: recorded, nanite's default 10 um is assumed), and the stiff map curve 1 (0.1 um of
#: indentation), where our fit reaches a lower cost of the same model than nanite's, with
#: the contact point 0.03 um earlier and E 40% lower (test below).
PEER_CURVES = [(FORCE_SAVE, 0), (MAP, 0), (MAP, 2), (CHIARO, 0)]


@needs_afmformats
@pytest.mark.parametrize("name, index", PEER_CURVES)
def test_hertz_fit_agrees_with_nanite_unweighted(name, index):
    from skin_indent.fitting import fit_hertz

    ref = json.loads((FILES / "nanite_reference.json").read_text())
    entry = next(c for c in ref["curves"] if c["file"] == name and c["index"] == index)
    nanite = entry["results"]["hertz_unweighted"]
    m = load_curves(FILES / name, radius_mm=entry["radius_um"] * 1e-3)[index]
    ours = fit_hertz(m, nu=entry["nu"])
    assert ours["success"]
    assert abs(ours["E_kPa"] * 1e3 / nanite["E_Pa"] - 1) < 0.01
    assert abs(ours["contact_point_mm"] - nanite["contact_point_depth_mm"]) < 1e-4  # 0.1 um


@needs_afmformats
def test_hertz_fit_on_the_stiff_map_curve_reaches_a_lower_cost_than_nanite():
    """Map curve 1: E differs from nanite's by 40%, but on the same model and data our optimum
    has the smaller sum of squares: nanite stops at another minimum of the contact point."""
    from skin_indent.mechanics.analytic import hertz_force
    from skin_indent.fitting import fit_hertz

    ref = json.loads((FILES / "nanite_reference.json").read_text())
    entry = next(c for c in ref["curves"] if c["file"] == MAP and c["index"] == 1)
    nanite = entry["results"]["hertz_unweighted"]
    m = load_curves(FILES / MAP, radius_mm=entry["radius_um"] * 1e-3)[1]
    ours = fit_hertz(m)
    approach = m.loading().require_monotone_loading()
    d, F = approach.depth_mm, approach.force_mN

    def cost(E_kPa, contact_mm, baseline_mN):
        model = baseline_mN + hertz_force(np.clip(d - contact_mm, 0.0, None), E_kPa / 0.75, 0.0, m.radius_mm)
        return float(np.sum((F - model) ** 2))

    theirs = cost(nanite["E_Pa"] * 1e-3, nanite["contact_point_depth_mm"],
                  (nanite["force_offset_removed_N"] + nanite["baseline_N"]) * 1e3)
    assert cost(ours["E_kPa"], ours["contact_point_mm"], ours["baseline_mN"]) < 0.9 * theirs
