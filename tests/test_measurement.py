"""Tests of skin_indent.measurement: reading, validation, segments, baseline, contact.

Expected numbers for the real curves come from tests/data/real-data/README.md (segment
start rows, baseline level and noise, rough contact depth); those for the skin curves
from the answer key in tests/data/hidden-effects/README.md.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skin_indent.data import bundled_names, bundled_path
from skin_indent.measurement import (
    Baseline,
    Measurement,
    MeasurementError,
    Segment,
    estimate_baseline,
    estimate_contact_point,
    find_contact_point,
    find_segments,
    load_csv,
    measurement_from_arrays,
    save_csv,
)

DATA = Path(__file__).parent / "data"
REAL = DATA / "real-data"
HIDDEN = DATA / "hidden-effects"

ALL_CSV = sorted(DATA.glob("*/*.csv"))

CHIARO = "chiaro_AEBP1_R27.5um.csv"
FORCE_SAVE = "jpk_force-save-example_R18.64um.csv"
BRAIN = "jpk_creep_brain_Runknown.csv"
GEL = "jpk_creep_polymergel_Runknown.csv"

# README "segments (first row)": (kind, first row) in time order.
REAL_SEGMENTS = {
    CHIARO: [("approach", 0), ("retract", 12664)],
    FORCE_SAVE: [("approach", 0), ("retract", 6000)],
    BRAIN: [("approach", 0), ("hold", 3000), ("retract", 6000)],
    GEL: [("approach", 0), ("hold", 3000), ("retract", 6000)],
}
# README "baseline, noise (std)": level (mN), half a unit of its last printed digit, noise (mN).
REAL_BASELINE = {
    CHIARO: (1.2e-7, 0.05e-7, 1.3e-7),
    FORCE_SAVE: (-6.6e-7, 0.05e-7, 1.1e-8),
    BRAIN: (1.12e-5, 0.005e-5, 5e-9),
    GEL: (4.1e-7, 0.05e-7, 5e-9),
}
# README rough contact depths (mm); Chiaro also has its own software's value.
REAL_CONTACT = {
    CHIARO: (0.0725, 0.0730),
    FORCE_SAVE: (0.0267,),
    BRAIN: (0.0168,),
    GEL: (0.0277,),
}


@functools.lru_cache(maxsize=None)
def load(path: Path) -> Measurement:
    return load_csv(path)


def write(tmp_path: Path, content, name: str = "curve.csv") -> Path:
    path = tmp_path / name
    if isinstance(content, str):
        content = content.encode("utf-8")
    path.write_bytes(content)
    return path


def assert_one_line_error(call, *fragments):
    with pytest.raises(MeasurementError) as info:
        call()
    message = str(info.value)
    assert "\n" not in message and "\r" not in message
    for fragment in fragments:
        assert fragment in message, message
    return message


# ---------------------------------------------------------------- reading


@pytest.mark.parametrize("path", ALL_CSV, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_data_file_loads_without_dropping_rows(path):
    m = load(path)
    lines = [line for line in path.read_text().splitlines() if line.strip() and not line.startswith("#")]
    n_lines = len(lines)  # a "# radius_um: ..." comment line is not a row
    assert m.n_points == n_lines - 1
    assert m.depth_mm.dtype == np.float64 and m.force_mN.dtype == np.float64
    assert np.isfinite(m.depth_mm).all() and np.isfinite(m.force_mN).all()
    assert m.has_time == (path.parent.name != "reference")
    assert m.source == path.name
    assert m.columns["depth_mm"] == {"column": "depth_mm", "factor": 1.0}
    first = lines[1].split(",")
    assert m.force_mN[0] == float(first[-1])


def test_bundled_demo_data_matches_the_test_copy():
    assert {"forearm_like.csv", "forearm_like_exact.csv", "README.md"} <= set(bundled_names())
    bundled = load_csv(bundled_path("forearm_like.csv"))
    copy = load(DATA / "invivo-like" / "forearm_like.csv")
    np.testing.assert_array_equal(bundled.force_mN, copy.force_mN)
    with pytest.raises(ValueError, match="unknown bundled data file"):
        bundled_path("no_such_file.csv")
    with pytest.raises(ValueError):
        bundled_path("../measurement.py")


DEPTH_MM = [0.0, 0.15, 0.3, 0.45]
FORCE_MN = [0.0, 0.25, 2.0, 4.5]
DEPTH_IN_FILE = {
    "depth_mm": ("0", "0.15", "0.3", "0.45"),
    "depth_um": ("0", "150", "300", "450"),
    "depth_m": ("0", "1.5e-4", "0.0003", "4.5E-4"),
}
FORCE_IN_FILE = {
    "force_mN": ("0", "0.25", "2", "4.5"),
    "force_uN": ("0", "250", "2000", "4.5e3"),
    "force_N": ("0", "0.00025", "2e-3", "0.0045"),
}


@pytest.mark.parametrize(
    "depth_col, force_col",
    [("depth_mm", "force_mN"), ("depth_um", "force_uN"), ("depth_m", "force_N"),
     ("depth_um", "force_N"), ("depth_m", "force_uN")],
)
def test_units_are_converted_to_mm_and_mN(tmp_path, depth_col, force_col):
    lines = [f"note,{force_col},{depth_col},time_s"]
    for i, (d, f) in enumerate(zip(DEPTH_IN_FILE[depth_col], FORCE_IN_FILE[force_col])):
        lines.append(f"x{i},{f},{d},{i}")
    m = load_csv(write(tmp_path, "\n".join(lines) + "\n"), radius_mm=6.22)
    np.testing.assert_allclose(m.depth_mm, DEPTH_MM, rtol=1e-12)
    np.testing.assert_allclose(m.force_mN, FORCE_MN, rtol=1e-12)
    np.testing.assert_array_equal(m.time_s, [0, 1, 2, 3])
    factors = {"depth_mm": 1.0, "depth_um": 1e-3, "depth_m": 1e3,
               "force_mN": 1.0, "force_uN": 1e-3, "force_N": 1e3}
    assert m.columns["depth_mm"] == {"column": depth_col, "factor": factors[depth_col]}
    assert m.columns["force_mN"] == {"column": force_col, "factor": factors[force_col]}
    assert m.radius_mm == 6.22


@pytest.mark.parametrize("delimiter", [",", ";", "\t"])
@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
def test_comma_semicolon_tab_and_any_newline_are_read(tmp_path, delimiter, newline):
    rows = [["time_s", "depth_mm", "force_mN"], ["0", "0", "0.01"], ["1", "0.1", "1.5"],
            ["2", "0.2", "4.25"]]
    text = newline.join(delimiter.join(r) for r in rows) + newline + newline
    m = load_csv(write(tmp_path, "\ufeff" + text))
    np.testing.assert_array_equal(m.depth_mm, [0, 0.1, 0.2])
    np.testing.assert_array_equal(m.force_mN, [0.01, 1.5, 4.25])


BAD_FILES = [
    ("empty", b"", ["empty"]),
    ("blank", b"\n  \n", ["empty"]),
    ("header only", b"depth_mm,force_mN\n", ["header only"]),
    ("no header", b"0,0\n1,1\n2,2\n", ["header row", "required"]),
    ("no depth column", b"depth,force_mN\n1,2\n", ["no depth column", "'depth'", "'force_mN'"]),
    ("no force column", b"depth_mm,load\n1,2\n", ["no force column", "'load'"]),
    ("ambiguous depth", b"depth_mm,depth_um,force_mN\n1,2,3\n", ["ambiguous depth", "'depth_um'"]),
    ("ambiguous force", b"depth_mm,force_mN,force_N\n1,2,3\n", ["ambiguous force", "'force_N'"]),
    ("duplicated column", b"depth_mm,depth_mm,force_mN\n1,2,3\n", ["ambiguous depth"]),
    ("case matters", b"Depth_mm,Force_mN\n1,2\n", ["no depth column", "'Depth_mm'"]),
    ("space delimiter", b"depth_mm force_mN\n1 2\n", ["delimiter must be"]),
    ("non-numeric", b"depth_mm,force_mN\n0,0\n1,abc\n2,3\n", ["line 3", "'force_mN'", "'abc'"]),
    ("decimal comma", b"depth_mm;force_mN\n0;0\n0,5;1\n1;2\n", ["line 3", "decimal comma"]),
    ("empty cell", b"depth_mm,force_mN\n0,0\n,1\n2,3\n", ["line 3", "'depth_mm'", "empty cell"]),
    ("nan", b"depth_mm,force_mN\n0,0\n1,nan\n2,3\n", ["line 3", "non-finite"]),
    ("inf", b"time_s,depth_mm,force_mN\n0,0,0\ninf,1,1\n2,2,3\n",
     ["line 3", "'time_s'", "non-finite"]),
    ("overflow", b"depth_mm,force_mN\n0,0\n1,1e999\n2,3\n", ["line 3", "non-finite"]),
    ("too many fields", b"depth_mm,force_mN\n0,0\n1,1,1\n2,3\n", ["line 3", "3 fields"]),
    ("too few fields", b"depth_mm,force_mN\n0,0\n1\n2,3\n", ["line 3", "1 fields"]),
    ("two rows", b"depth_mm,force_mN\n0,0\n1,1\n", ["2 data rows", "at least 3"]),
    ("time goes back", b"time_s,depth_mm,force_mN\n0,0,0\n2,1,1\n1,2,2\n",
     ["line 4", "time decreases"]),
    ("latin-1", "depth_mm,force_mN,T_\u00b0C\n0,0,1\n".encode("latin-1"), ["not UTF-8", "0xb0"]),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00", ["not UTF-8"]),
    ("nul bytes", b"depth_mm,force_mN\n0,0\x00\n", ["NUL"]),
    ("newline in name", b'"depth\nmm",force_mN\n1,2\n', ["no depth column"]),
]


@pytest.mark.parametrize(
    "content, fragments", [c[1:] for c in BAD_FILES], ids=[c[0] for c in BAD_FILES]
)
def test_bad_files_raise_one_line_measurement_error(tmp_path, content, fragments):
    path = write(tmp_path, content, "bad file.csv")
    message = assert_one_line_error(lambda: load_csv(path), *fragments)
    assert message.startswith("bad file.csv") or "bad file.csv" in message


def test_missing_file_and_directory_are_measurement_errors(tmp_path):
    assert_one_line_error(lambda: load_csv(tmp_path / "nope.csv"), "nope.csv", "not found")
    assert_one_line_error(lambda: load_csv(tmp_path), "directory")


def test_error_message_stays_one_line_for_a_hostile_file_name(tmp_path):
    path = tmp_path / "a\nb.csv"
    path.write_bytes(b"depth_mm,force_mN\n")
    assert_one_line_error(lambda: load_csv(path), "header only")


FIXTURE_OK = [HealthCheck.function_scoped_fixture]  # tmp_path is reused, files overwritten
HEADER_NAMES = ["time_s", "depth_mm", "depth_um", "depth_m", "force_mN", "force_N",
                "force_uN", "x", ""]
CSV_TOKENS = st.sampled_from(
    HEADER_NAMES + [",", ";", "\t", "\n", "\r\n", " ", '"', "0", "1.5", "-2e-3", "nan",
                    "inf", "1e999", ".", "e", "abc", "\u00b5", "\x00", "1,5"]
)


def check_loads_or_measurement_error(tmp_path, content: bytes):
    path = write(tmp_path, content)
    try:
        m = load_csv(path)
    except MeasurementError as err:
        assert "\n" not in str(err) and str(err)
        return
    assert m.n_points >= 3
    assert m.depth_mm.shape == m.force_mN.shape == (m.n_points,)
    assert np.isfinite(m.depth_mm).all() and np.isfinite(m.force_mN).all()
    if m.has_time:
        assert m.time_s.shape == (m.n_points,) and np.all(np.diff(m.time_s) >= 0)


@settings(max_examples=150, deadline=None, suppress_health_check=FIXTURE_OK)
@given(content=st.binary(max_size=400))
def test_random_bytes_load_or_raise_measurement_error(tmp_path, content):
    check_loads_or_measurement_error(tmp_path, content)


@settings(max_examples=200, deadline=None, suppress_health_check=FIXTURE_OK)
@given(
    header=st.lists(st.sampled_from(HEADER_NAMES), min_size=1, max_size=4),
    delimiter=st.sampled_from([",", ";", "\t"]),
    body=st.lists(CSV_TOKENS, max_size=80),
)
def test_random_csv_like_text_loads_or_raises_measurement_error(tmp_path, header, delimiter, body):
    text = delimiter.join(header) + "\n" + "".join(body)
    check_loads_or_measurement_error(tmp_path, text.encode("utf-8"))


@settings(max_examples=100, deadline=None, suppress_health_check=FIXTURE_OK)
@given(
    rows=st.lists(
        st.tuples(*[st.floats(-1e6, 1e6) for _ in range(3)]), min_size=3, max_size=30
    )
)
def test_numeric_rows_round_trip_through_save_csv(tmp_path, rows):
    time, depth, force = (np.array(c) for c in zip(*rows))
    m = measurement_from_arrays(depth, force, np.sort(time))
    back = load_csv(save_csv(m, tmp_path / "out.csv"))
    np.testing.assert_array_equal(back.time_s, m.time_s)
    np.testing.assert_array_equal(back.depth_mm, m.depth_mm)
    np.testing.assert_array_equal(back.force_mN, m.force_mN)


# ------------------------------------------------------------ Measurement


def test_measurement_arrays_are_read_only_float64_copies():
    depth = np.array([0, 1, 2])
    m = measurement_from_arrays(depth, [0.0, 1.0, 3.0])
    depth[0] = 5
    assert m.depth_mm[0] == 0.0 and m.depth_mm.dtype == np.float64
    assert m.time_s is None and not m.has_time and m.source == "array"
    with pytest.raises(ValueError):
        m.depth_mm[0] = 1.0
    with pytest.raises(AttributeError):
        m.source = "other"
    assert "n_points=3" in repr(m)


@pytest.mark.parametrize(
    "kwargs, fragments",
    [
        (dict(depth_mm=[0, 1, 2], force_mN=[0, 1]),
         ["differ in length", "depth_mm=3", "force_mN=2"]),
        (dict(depth_mm=[0, 1, 2, 3], force_mN=[0, 1, np.nan, np.inf]),
         ["force_mN", "index 2", "2 non-finite"]),
        (dict(depth_mm=[0, np.inf, 2], force_mN=[0, 1, 2]), ["depth_mm", "index 1"]),
        (dict(depth_mm=[0, 1, 2], force_mN=[0, 1, 2], time_s=[0, 2, 1]),
         ["time_s decreases", "index 2"]),
        (dict(depth_mm=[0, 1], force_mN=[0, 1]), ["2 points", "at least 3"]),
        (dict(depth_mm=[[0, 1, 2]], force_mN=[0, 1, 2]), ["one-dimensional"]),
        (dict(depth_mm=["a", "b", "c"], force_mN=[0, 1, 2]), ["depth_mm", "float"]),
        (dict(depth_mm=[0, 1, 2], force_mN=[0, 1, 2], radius_mm=-1.0), ["radius_mm", "positive"]),
    ],
)
def test_invalid_arrays_raise_one_line_measurement_error(kwargs, fragments):
    kwargs = dict(kwargs)
    radius = kwargs.pop("radius_mm", None)
    assert_one_line_error(lambda: measurement_from_arrays(**kwargs, radius_mm=radius), *fragments)


def test_window_depth_shift_and_radius():
    m = load(HIDDEN / "v01_clean.csv")
    w = m.window(0.1, 0.2)
    assert w.depth_mm.min() >= 0.1 and w.depth_mm.max() <= 0.2 and w.n_points == 17
    assert w.has_time and w.time_s.size == w.n_points
    assert_one_line_error(lambda: m.window(0.7, 0.8), "only 0 points")
    shifted = m.with_contact_at(0.02)
    np.testing.assert_allclose(shifted.depth_mm, m.depth_mm - 0.02)
    assert shifted.columns["depth_shift_mm"] == -0.02
    np.testing.assert_array_equal(shifted.force_mN, m.force_mN)
    assert m.with_radius(6.22).radius_mm == 6.22 and m.radius_mm is None


def test_loading_is_strictly_increasing_and_monotone_check_rejects_unloading():
    v06 = load(HIDDEN / "v06_viscoelastic.csv")
    assert_one_line_error(
        v06.require_monotone_loading, "index 100", "does not increase", ".loading()"
    )
    loading = v06.loading().require_monotone_loading()
    assert loading.n_points == 100 and loading.depth_mm[-1] == 0.6
    unloading = v06.unloading()
    assert unloading.n_points == 100
    assert unloading.depth_mm[0] < 0.6 and unloading.depth_mm[-1] == 0.0
    for name in (CHIARO, FORCE_SAVE, BRAIN, GEL):
        real_loading = load(REAL / name).loading()
        assert np.all(np.diff(real_loading.depth_mm) > 0)
        assert real_loading.n_points > 0.97 * REAL_SEGMENTS[name][1][1]
        start, stop = real_loading.columns["loading"]["rows"]
        assert real_loading.columns["loading"]["dropped"] == stop - start - real_loading.n_points


def test_monotone_check_rejects_a_shuffled_loading_only_file(tmp_path):
    lines = (HIDDEN / "v01_clean.csv").read_text().splitlines()
    lines[10], lines[11] = lines[11], lines[10]
    lines = [lines[0]] + [",".join(row.split(",")[1:]) for row in lines[1:]]  # drop time
    lines[0] = "depth_mm,force_mN"
    m = load_csv(write(tmp_path, "\n".join(lines)))
    assert_one_line_error(m.require_monotone_loading, "index 10", "strictly increasing")


def test_save_csv_replaces_atomically_without_leftovers(tmp_path):
    m = load(HIDDEN / "v06_viscoelastic.csv")
    target = tmp_path / "out.csv"
    target.write_text("old content")
    save_csv(m, target)
    assert target.read_text().splitlines()[0] == "time_s,depth_mm,force_mN"
    assert os.listdir(tmp_path) == ["out.csv"]
    back = load_csv(target)
    np.testing.assert_array_equal(back.force_mN, m.force_mN)
    no_time = load(DATA / "reference" / "neo-hooke_halfspace_E5kPa_nu0.48.csv")
    save_csv(no_time, target)
    assert target.read_text().splitlines()[0] == "depth_mm,force_mN"


# --------------------------------------------------------------- segments


@pytest.mark.parametrize("name", sorted(REAL_SEGMENTS))
def test_segments_of_real_curves_match_the_readme(name):
    m = load(REAL / name)
    segments = find_segments(m)
    expected = REAL_SEGMENTS[name]
    assert [s.kind for s in segments] == [kind for kind, _ in expected]
    assert segments[0].start == 0 and segments[-1].stop == m.n_points
    assert all(a.stop == b.start for a, b in zip(segments, segments[1:]))
    starts = [row for _, row in expected] + [m.n_points]
    for seg, (_, row), length in zip(segments, expected, np.diff(starts)):
        assert abs(seg.start - row) <= 0.01 * length, (seg, row)


def test_segments_of_skin_curves():
    v06 = find_segments(load(HIDDEN / "v06_viscoelastic.csv"))
    assert v06 == [Segment("approach", 0, 100), Segment("retract", 100, 200)]
    for path in sorted(HIDDEN.glob("v0[1-5]*.csv")) + [DATA / "invivo-like" / "forearm_like.csv"]:
        assert find_segments(load(path)) == [Segment("approach", 0, 100)], path.name


def test_creep_and_relaxation_holds_are_found_in_synthetic_curves():
    rng = np.random.default_rng(1)
    t = np.arange(3000) * 0.01
    ramp = np.minimum(t, 10.0)  # 1 mm/s for 10 s
    creep = 0.05 * np.clip(t - 10, 0, None) * np.exp(-np.clip(t - 10, 0, None) / 20)  # slow creep
    back = np.clip(t - 20, 0, None)  # retract at 1 mm/s from 20 s
    depth = ramp + creep - back + rng.normal(0, 0.002, t.size)
    segments = find_segments(measurement_from_arrays(depth, depth**1.5, t))
    assert [s.kind for s in segments] == ["approach", "hold", "retract"]
    assert abs(segments[1].start - 1000) <= 10 and abs(segments[2].start - 2000) <= 10
    # a relaxation hold at constant depth, without a time column
    depth = np.concatenate((np.linspace(0, 1, 200), np.ones(300), np.linspace(1, 0, 200)[1:]))
    segments = find_segments(measurement_from_arrays(depth, depth))
    assert [s.kind for s in segments] == ["approach", "hold", "retract"]
    assert abs(segments[1].start - 200) <= 2 and abs(segments[2].start - 500) <= 2


def test_a_slower_but_steady_approach_is_not_a_hold():
    # 1 mm/s, then 0.3 mm/s: 30% of the approach speed is still loading, not a hold
    t = np.arange(2000) * 0.01
    depth = np.where(t < 10, t, 10 + 0.3 * (t - 10))
    segments = find_segments(measurement_from_arrays(depth, depth**1.5, t))
    assert segments == [Segment("approach", 0, 2000)]


@settings(max_examples=60, deadline=None)
@given(depth=st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=300))
def test_segments_always_tile_the_curve(depth):
    m = measurement_from_arrays(depth, np.zeros(len(depth)))
    segments = find_segments(m)
    assert segments[0].start == 0 and segments[-1].stop == m.n_points
    assert all(a.stop == b.start and a.kind != b.kind for a, b in zip(segments, segments[1:]))


# --------------------------------------------------------------- baseline


@pytest.mark.parametrize("name", sorted(REAL_BASELINE))
def test_baseline_of_real_curves_matches_the_readme(name):
    level, rounding, noise = REAL_BASELINE[name]
    baseline = estimate_baseline(load(REAL / name))
    assert isinstance(baseline, Baseline)
    assert 0.5 < baseline.noise_mN / noise < 2.0
    # The README's std is about the median, so it also holds the tilt across the window
    # (a uniform spread of slope*span has std slope*span/sqrt(12)).
    tilt = baseline.slope_mN_per_mm * np.ptp(baseline.depth_range_mm)
    assert np.hypot(baseline.noise_mN, tilt / np.sqrt(12)) == pytest.approx(noise, rel=0.25)
    middle = 0.5 * sum(baseline.depth_range_mm)
    assert abs(baseline.force_at(middle) - level) < 3 * noise + rounding
    # the tilt over the fitted window is small compared with the contact forces
    span = np.ptp(baseline.depth_range_mm)
    assert abs(baseline.slope_mN_per_mm) * span < 0.05 * np.ptp(load(REAL / name).force_mN)
    assert baseline.n_points == pytest.approx(0.4 * load(REAL / name).loading().n_points, abs=1)


def test_baseline_is_only_removed_on_request():
    m = load(REAL / BRAIN)
    baseline = estimate_baseline(m)
    corrected = m.with_baseline_removed(baseline)
    assert m.force_mN[0] == pytest.approx(1.12e-5, rel=0.01)  # unchanged
    assert abs(np.median(corrected.force_mN[:1000])) < 2 * baseline.noise_mN
    assert corrected.columns["baseline_removed"]["offset_mN"] == baseline.offset_mN
    assert_one_line_error(lambda: estimate_baseline(m, fraction=0.0), "fraction")


# ---------------------------------------------------------- contact point


@pytest.mark.parametrize("name", sorted(REAL_CONTACT))
def test_contact_point_of_real_curves_within_2_um_of_readme(name):
    contact = find_contact_point(load(REAL / name))
    assert contact.has_baseline and contact.baseline is not None
    assert min(abs(contact.depth_mm - ref) for ref in REAL_CONTACT[name]) < 0.002
    assert contact.depth_mm <= contact.threshold_depth_mm < contact.fit_end_depth_mm


def test_contact_point_is_scale_and_shift_free():
    m = load(REAL / FORCE_SAVE)
    reference = estimate_contact_point(m)
    # the same curve in um and nN, moved by 5 um
    other = measurement_from_arrays(m.depth_mm * 1e3 + 5.0, m.force_mN * 1e6, m.time_s)
    assert estimate_contact_point(other) == pytest.approx(reference * 1e3 + 5.0, abs=1e-4)


@pytest.mark.parametrize(
    "path",
    [HIDDEN / "v01_clean.csv", HIDDEN / "v02_layer_soft_base.csv", HIDDEN / "v04_stiffening.csv",
     HIDDEN / "v06_viscoelastic.csv", DATA / "invivo-like" / "forearm_like.csv",
     DATA / "reference" / "neo-hooke_halfspace_E8kPa_nu0.45.csv"],
    ids=lambda p: p.name,
)
def test_skin_curves_starting_in_contact_have_no_baseline_and_contact_near_zero(path):
    m = load(path)
    contact = find_contact_point(m)
    step = np.median(np.diff(m.loading().depth_mm))
    assert not contact.has_baseline
    assert contact.baseline is None and contact.threshold_depth_mm is None
    assert 0.0 <= contact.depth_mm <= 2 * step


def test_contact_of_stiff_layered_and_offset_skin_curves():
    # layer on a rigid base: stiffer than a power 1.5, so d0 comes out late, but within 6 steps
    layered = find_contact_point(load(HIDDEN / "v03_layer_rigid_base.csv"))
    assert not layered.has_baseline and 0.0 <= layered.depth_mm <= 6 * 0.00606
    # v05: true contact at +0.020 mm, noise 0.05 mN, only 4 samples before it
    offset = find_contact_point(load(HIDDEN / "v05_offset.csv"))
    assert not offset.has_baseline
    assert offset.depth_mm == pytest.approx(0.020, abs=0.005)


def test_contact_on_flat_force_raises():
    m = measurement_from_arrays(np.linspace(0, 1, 20), np.zeros(20))
    assert_one_line_error(lambda: find_contact_point(m), "does not rise")


def test_baseline_reports_tilt_significance_and_a_flat_version():
    """A tilted pre-contact line is significant; a flat noisy one is not (scale-free: nN and um)."""
    from skin_indent.measurement import estimate_baseline

    rng = np.random.default_rng(0)
    d = np.linspace(0, 0.05, 2000)  # mm (50 um)
    noise = rng.normal(0, 1e-8, d.size)  # 0.01 nN
    flat = estimate_baseline(measurement_from_arrays(d, 2e-6 + noise, np.arange(d.size) * 1e-3), fraction=1.0)
    tilted = estimate_baseline(measurement_from_arrays(d, 2e-6 + 1e-5 * d + noise, np.arange(d.size) * 1e-3),
                               fraction=1.0)
    assert not flat.tilt_significant and tilted.tilt_significant
    assert abs(tilted.slope_mN_per_mm - 1e-5) < 5 * tilted.slope_std_mN_per_mm
    level = flat.flat()
    assert level.slope_mN_per_mm == 0.0 and abs(level.offset_mN - 2e-6) < 3e-9


@pytest.mark.parametrize("shift_mm", [0.02, 0.04])
def test_a_curve_stiffening_with_depth_keeps_its_contact_point(shift_mm):
    """A layer on a rigid base (v03: 2.9x the half-space force at 0.6 mm) recorded from before
    contact: the contact point within a depth step of the truth, and no "pre-contact baseline"
    made of its first samples in contact (a pure Hertz shape put it at 0.06-0.08 mm)."""
    m = load_csv(HIDDEN / "v03_layer_rigid_base.csv")
    step = m.depth_mm[1] - m.depth_mm[0]
    pre = np.arange(0.0, shift_mm - 1e-9, step)
    depth = np.r_[pre, m.depth_mm + shift_mm]
    force = np.r_[np.random.default_rng(3).normal(0.0, 0.05, pre.size), m.force_mN]
    cp = find_contact_point(measurement_from_arrays(depth, force, np.arange(depth.size) * 0.3, source="v03+shift"))
    assert not cp.has_baseline
    assert cp.depth_mm == pytest.approx(shift_mm, abs=step)
