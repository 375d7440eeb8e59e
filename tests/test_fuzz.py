"""Property-based tests of bad input at the API and the command line (hypothesis).

tests/test_measurement.py fuzzes :func:`load_csv` itself; here malformed files go
through the whole ``skin-indent fit`` path (loader, loading segment, window, start
values, inversion, report) in-process, and out-of-range numbers through
``simulate``, the response surface and the CLI. Every case must end in either

* a result (exit 0, or 1 when the inversion reports no convergence), without a
  traceback, or
* exit status 2 and exactly one line on stderr, ``skin-indent CMD: error: ...``;

and never hang (each call runs under an alarm). No finite-element run is started:
``simulate`` is only called with at least one invalid argument, and ``surface build``
gets an analytic surface.
"""

from __future__ import annotations

import contextlib
import json
import math
import signal

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from skin_indent.cli import main
from skin_indent.mechanics import NeoHooke, SphericalIndenter
from skin_indent.mechanics.materials import LinearElastic
from skin_indent.response_surface import ResponseSurface, SurfaceGrid, parse_range
from skin_indent.simulate import simulate

R_MM = 6.22
FIXTURE_OK = [HealthCheck.function_scoped_fixture]
CALL_LIMIT_S = 60  # "never a hang": any single call longer than this fails the test


def unit_curve(nu, depth_mm):
    """Hertz-like unit curve (mN at E = 1 kPa), the analytic stand-in of the FE model."""
    h = np.asarray(depth_mm, dtype=float)
    return 4 / 3 / (1 - nu**2) * np.sqrt(R_MM) * h**1.5 * (1 - (0.15 + 0.3 * (0.5 - nu)) * h / R_MM)


def analytic_surface(grid: SurfaceGrid) -> ResponseSurface:
    forces = np.column_stack([unit_curve(nu, grid.depth_mm) for nu in grid.nu])
    return ResponseSurface(grid, forces, settings={"model": "analytic stand-in", "radius_mm": R_MM})


GRID = SurfaceGrid(np.linspace(0.01, 0.6, 60), np.geomspace(1, 100, 8), np.linspace(0.2, 0.49, 6))
SURFACE = analytic_surface(GRID)


@pytest.fixture(scope="module")
def surface_file(tmp_path_factory):
    return str(SURFACE.save(tmp_path_factory.mktemp("surface") / "analytic.npz"))


class Hang(Exception):
    pass


@contextlib.contextmanager
def no_hang(seconds=CALL_LIMIT_S):
    def alarm(signum, frame):
        raise Hang(f"call did not return within {seconds} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def run_cli(capsys, argv):
    """``(code, stdout, stderr)`` of ``skin-indent ARGV`` run in this process."""
    capsys.readouterr()
    with no_hang():
        code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_clean(code, out, err, command):
    """A result, or exit 2 with exactly one error line; never a traceback."""
    assert "Traceback" not in err and "Traceback" not in out
    assert code in (0, 1, 2), (code, err)
    if code == 2:
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"skin-indent {command}: error: "), err
        assert len(lines[0]) > len(f"skin-indent {command}: error: ") + 3
    return code


# ------------------------------------------------------------------ malformed CSV -> fit

DEPTH_NAMES = ["depth_mm", "depth_um", "depth_m", "depth_in", "Depth_mm", "depth (mm)", "depth", ""]
FORCE_NAMES = ["force_mN", "force_N", "force_uN", "force_kN", "force", "Force_mN", ""]
DELIMITERS = [",", ";", "\t", " ", "|"]
CELLS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-1.0, 2.0).map(lambda x: f"{x:.6g}"),
    st.sampled_from(["", "nan", "NaN", "inf", "-inf", "1e999", "-0", "0", "1,5", "abc", "0x10", "1e-320",
                     '"1.0"', " 2 ", "\u00b5", "1.2.3", "--1", "+.5", "1e", "\u2212" "1"]),
)


def encode(text: str, how: str) -> bytes:
    if how == "utf-8-sig":
        return b"\xef\xbb\xbf" + text.encode()
    if how == "latin-1":  # a non-UTF-8 byte somewhere
        return text.encode("utf-8").replace(b",", b",\xb5", 1)
    if how == "utf-16":
        return text.encode("utf-16")
    if how == "crlf":
        return text.replace("\n", "\r\n").encode()
    return text.encode()


@st.composite
def malformed_csvs(draw):
    kind = draw(st.sampled_from(["random", "curve", "empty", "header only", "blank lines"]))
    depth_name, force_name = draw(st.sampled_from(DEPTH_NAMES)), draw(st.sampled_from(FORCE_NAMES))
    header_delim = draw(st.sampled_from(DELIMITERS))
    body_delim = draw(st.sampled_from(DELIMITERS)) if draw(st.booleans()) else header_delim
    with_time = draw(st.booleans())
    names = (["time_s"] if with_time else []) + [depth_name, force_name]
    header = header_delim.join(names)
    if kind == "empty":
        text = ""
    elif kind == "header only":
        text = header + "\n"
    elif kind == "blank lines":
        text = header + "\n\n  \n" + "\n" * draw(st.integers(0, 3))
    elif kind == "random":
        rows = draw(st.lists(st.lists(CELLS, min_size=1, max_size=4), max_size=12))
        text = header + "\n" + "".join(body_delim.join(r) + "\n" for r in rows)
    else:  # a plausible curve, then damaged
        n = draw(st.integers(3, 40))
        h = np.linspace(draw(st.floats(0.0, 0.3)), draw(st.floats(0.31, 1.0)), n)
        F = draw(st.floats(1.0, 100.0)) * unit_curve(draw(st.floats(0.2, 0.49)), h)
        t = np.arange(n, dtype=float)
        damage = draw(st.sampled_from(["none", "duplicate", "decreasing", "reverse", "nan", "inf", "negative",
                                       "units", "cell", "short row", "long row", "time back"]))
        i = draw(st.integers(0, n - 1))
        if damage == "duplicate":
            h[i:] = np.r_[h[i], h[i:-1]]
        elif damage == "decreasing":
            h[i] = h[i] - 0.5
        elif damage == "reverse":
            h, F = h[::-1], F[::-1]
        elif damage in ("nan", "inf"):
            F[i] = np.nan if damage == "nan" else -np.inf
        elif damage == "negative":
            F = -F
        elif damage == "units":  # mm written as um, or N as mN: 1000x off
            h = h * 1000
        elif damage == "time back":
            t[i] = -1.0
        cells = [[repr(float(a)) for a in row] for row in
                 (np.column_stack([t, h, F]) if with_time else np.column_stack([h, F]))]
        if damage == "cell":
            cells[i][-1] = draw(CELLS)
        elif damage == "short row":
            cells[i] = cells[i][:-1]
        elif damage == "long row":
            cells[i] = cells[i] + ["0"]
        text = header + "\n" + "".join(body_delim.join(r) + "\n" for r in cells)
    return encode(text, draw(st.sampled_from(["utf-8", "utf-8", "utf-8-sig", "latin-1", "utf-16", "crlf"])))


@settings(max_examples=120, deadline=None, suppress_health_check=FIXTURE_OK)
@given(content=malformed_csvs(), extra=st.sampled_from([[], ["--json"], ["--method", "ekf"], ["--window", "0.05:0.5"]]))
@example(content=b"", extra=[])
@example(content=b"depth_mm,force_mN\n", extra=[])
@example(content=b"depth_mm;force_mN\n0.1;1\n0.1;1\n0.2;2\n", extra=[])
@example(content=b"\x89PNG\r\n\x1a\n\x00\x00", extra=[])
def test_fit_cli_on_malformed_csv_is_a_result_or_one_line(tmp_path, capsys, surface_file, content, extra):
    path = tmp_path / "measured curve.csv"
    path.write_bytes(content)
    code, out, err = run_cli(capsys, ["fit", path, "--surface", surface_file, *extra])
    assert_clean(code, out, err, "fit")
    if code in (0, 1) and "--json" in extra:
        json.loads(out)


@st.composite
def valid_curves(draw):
    """A noise-free curve of the analytic model, in random units and delimiters."""
    E, nu = draw(st.floats(2.0, 80.0)), draw(st.floats(0.22, 0.47))
    n = draw(st.integers(8, 60))
    h = np.linspace(draw(st.floats(0.01, 0.1)), draw(st.floats(0.3, 0.6)), n)
    F = E * unit_curve(nu, h)
    depth_name, dscale = draw(st.sampled_from([("depth_mm", 1.0), ("depth_um", 1e3), ("depth_nm", 1e6), ("depth_m", 1e-3)]))
    force_name, fscale = draw(st.sampled_from([("force_mN", 1.0), ("force_N", 1e-3), ("force_uN", 1e3), ("force_nN", 1e6)]))
    delim = draw(st.sampled_from([",", ";", "\t"]))
    text = f"{depth_name}{delim}{force_name}\n" + "".join(
        f"{float(a * dscale)!r}{delim}{float(b * fscale)!r}\n" for a, b in zip(h, F))
    return (E, nu), text.encode()


# derandomized so that CI runs the same 25 curves every time; a random draw once found E 1.99949 for 2.0
# (an absolute gtol stopped early in the E-nu valley of a short curve), kept as the test below
@settings(max_examples=25, deadline=None, suppress_health_check=FIXTURE_OK, derandomize=True)
@given(case=valid_curves())
def test_fit_cli_recovers_parameters_in_any_units(tmp_path, capsys, surface_file, case):
    (E, nu), content = case
    path = tmp_path / "curve.csv"
    path.write_bytes(content)
    code, out, err = run_cli(capsys, ["fit", path, "--surface", surface_file, "--json"])
    assert code == 0, err
    p = json.loads(out)["parameters"]
    assert p["E_kPa"] == pytest.approx(E, rel=1e-4) and p["nu"] == pytest.approx(nu, abs=1e-4)


@pytest.mark.parametrize("force_name, fscale", [("force_mN", 1.0), ("force_nN", 1e6)])
def test_a_short_curve_is_fitted_to_round_off(tmp_path, capsys, surface_file, force_name, fscale):
    """8 noise-free points to 0.3 mm (E and nu correlated to -0.999997): the fit stops at the minimum,
    not where an absolute gradient tolerance first holds (it left E 2.5e-4 off), in mN as in nN."""
    E, nu = 2.0, 0.3984375
    h = np.linspace(0.0625, 0.3, 8)
    path = tmp_path / "short.csv"
    path.write_text(f"depth_mm,{force_name}\n" + "".join(
        f"{a!r},{b!r}\n" for a, b in zip(h.tolist(), (E * unit_curve(nu, h) * fscale).tolist())))
    code, out, err = run_cli(capsys, ["fit", path, "--surface", surface_file, "--json"])
    assert code == 0, err
    result = json.loads(out)
    assert result["parameters"]["E_kPa"] == pytest.approx(E, rel=1e-8)
    assert result["parameters"]["nu"] == pytest.approx(nu, abs=1e-8)
    assert result["quality"]["verdict"] == "fits below the noise level"


@pytest.mark.parametrize("damage", ["valid", "bad last cell"])
def test_huge_file_loads_or_fails_cleanly(tmp_path, capsys, surface_file, damage):
    n = 200_000
    h = np.linspace(0.01, 0.6, n)
    data = np.column_stack([np.arange(n) * 1e-3, h, 12.5 * unit_curve(0.35, h)])
    path = tmp_path / "huge.csv"
    np.savetxt(path, data, delimiter=",", header="time_s,depth_mm,force_mN", comments="", fmt="%.17g")
    if damage == "bad last cell":
        with open(path, "a") as fh:
            fh.write("200,0.61,oops\n")
    # (run_cli's watchdog catches a hang; the time of this fit is measured by benchmarks/startup.py)
    code, out, err = run_cli(capsys, ["fit", path, "--surface", surface_file, "--json"])
    assert_clean(code, out, err, "fit")
    if damage == "valid":
        p = json.loads(out)["parameters"]
        assert code == 0 and p["E_kPa"] == pytest.approx(12.5, rel=1e-6) and p["nu"] == pytest.approx(0.35, abs=1e-6)
    else:
        assert code == 2 and f"line {n + 2}" in err and "'oops' is not a number" in err


# Known gaps in other modules, kept visible (strict: they fail loudly once fixed).
def test_fit_accepts_a_curve_that_starts_at_contact(tmp_path, capsys, surface_file):
    h = np.linspace(0.0, 0.5, 30)
    path = tmp_path / "from_contact.csv"
    path.write_text("depth_mm,force_mN\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(h, 10 * unit_curve(0.4, h))))
    code, out, err = run_cli(capsys, ["fit", path, "--surface", surface_file, "--json"])
    assert code == 0, err


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # overflow inside the fit
def test_fit_rejects_absurd_forces(tmp_path, capsys, surface_file):
    path = tmp_path / "absurd.csv"
    path.write_text("depth_mm,force_mN\n0.1,1e300\n0.2,1e301\n0.3,1e302\n")
    code, out, err = run_cli(capsys, ["fit", path, "--surface", surface_file, "--json"])
    assert code == 2 and len(err.splitlines()) == 1


# ------------------------------------------------------------------ simulate API and CLI

BAD_FLOATS = st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, -1e-300, -1e300])


def finite_positive(x):
    return isinstance(x, float) and math.isfinite(x) and x > 0


@st.composite
def simulate_inputs(draw):
    """(E, nu, radius, depth, points) with at least one value out of range."""
    E = draw(st.one_of(st.floats(1e-3, 1e4), BAD_FLOATS, st.floats(allow_nan=True, allow_infinity=True)))
    nu = draw(st.one_of(st.floats(-0.99, 0.49), st.sampled_from([0.5, 0.7, -1.0, -2.0, math.nan, math.inf]),
                        st.floats(allow_nan=True, allow_infinity=True)))
    radius = draw(st.one_of(st.floats(0.1, 50.0), BAD_FLOATS))
    depth = draw(st.one_of(st.floats(1e-3, 2.0), BAD_FLOATS))
    points = draw(st.one_of(st.integers(2, 200), st.integers(-5, 1), st.sampled_from([2.5, True, "10", None])))
    valid = (finite_positive(E) and math.isfinite(nu) and -1 < nu < 0.5 and finite_positive(radius)
             and finite_positive(depth) and isinstance(points, int) and not isinstance(points, bool) and points >= 2)
    assume(not valid)  # valid inputs would start a finite-element run
    return E, nu, radius, depth, points


@settings(max_examples=150, deadline=None)
@given(args=simulate_inputs(), law=st.sampled_from([NeoHooke, LinearElastic]))
def test_simulate_api_rejects_out_of_range_input_in_one_line(args, law):
    E, nu, radius, depth, points = args
    with no_hang(), pytest.raises(ValueError) as info:
        simulate(law(E_kPa=E, nu=nu), SphericalIndenter(radius), depth, points, mesh="coarse")
    message = str(info.value)
    assert message and "\n" not in message and len(message) < 300


@settings(max_examples=60, deadline=None, suppress_health_check=FIXTURE_OK)
@given(args=simulate_inputs())
def test_simulate_cli_rejects_out_of_range_input_in_one_line(tmp_path, capsys, args):
    E, nu, radius, depth, points = args
    if not isinstance(points, int) or isinstance(points, bool):
        points = -3  # argparse would reject a non-integer with its usage text
    # --opt=VALUE: argparse would take "-inf" after a space for an option
    code, out, err = run_cli(capsys, ["simulate", f"--E={E!r}", f"--nu={nu!r}", f"--radius={radius!r}",
                                      f"--depth={depth!r}", f"--points={points}", "--mesh", "coarse",
                                      "--out", tmp_path / "c.csv"])
    assert assert_clean(code, out, err, "simulate") == 2


def test_simulate_tiny_valid_run_succeeds():
    """One cheap real run, so the invalid-only fuzzing above is not vacuous."""
    curve = simulate(NeoHooke(E_kPa=5.0, nu=0.3), SphericalIndenter(6.22), 0.02, 3, mesh="coarse")
    assert curve.force_mN.shape == (3,) and np.all(np.diff(curve.force_mN) > 0)


# ------------------------------------------------------------------ surface build CLI (analytic)


@pytest.fixture()
def analytic_surface_for(monkeypatch):
    """`surface build` without finite elements: the analytic surface on the requested grid."""
    import skin_indent.fitting

    def fake(radius_mm, max_depth_mm, *, grid=None, path=None, **kw):
        return analytic_surface(grid)

    monkeypatch.setattr(skin_indent.fitting, "surface_for", fake)


RANGE_TEXT = st.one_of(
    st.builds(lambda a, b, n, log: f"{a!r}:{b!r}:{n}" + (":log" if log else ""),
              st.floats(allow_nan=True, allow_infinity=True), st.floats(allow_nan=True, allow_infinity=True),
              st.integers(-2, 12), st.booleans()),
    st.text(alphabet="0123456789.:-elognaif ", max_size=14),
)


@settings(max_examples=120, deadline=None, suppress_health_check=FIXTURE_OK)
@given(E=RANGE_TEXT, nu=RANGE_TEXT, depth=st.one_of(st.floats(0.1, 1.0), BAD_FLOATS),
       points=st.integers(-2, 40), radius=st.one_of(st.floats(1.0, 10.0), BAD_FLOATS))
@example(E="1:100:8:log", nu="0.2:0.49:6", depth=0.6, points=20, radius=6.22)
def test_surface_build_cli_bad_grids_are_one_line(capsys, analytic_surface_for, E, nu, depth, points, radius):
    code, out, err = run_cli(capsys, ["surface", "build", f"--E={E}", f"--nu={nu}", f"--depth={depth!r}",
                                      f"--points={points}", f"--radius={radius!r}"])
    assert_clean(code, out, err, "surface")
    if code == 0:
        assert "surface " in out


# ------------------------------------------------------------------ surface API


@settings(max_examples=300, deadline=None)
@given(E=st.one_of(st.floats(1, 100), st.floats(allow_nan=True, allow_infinity=True)),
       nu=st.one_of(st.floats(0.2, 0.49), st.floats(allow_nan=True, allow_infinity=True)),
       h=st.one_of(st.floats(1e-4, 0.6), st.floats(allow_nan=True, allow_infinity=True)),
       method=st.sampled_from(["lagrange", "spline"]))
def test_surface_force_is_exact_inside_and_names_the_parameter_outside(E, nu, h, method):
    inside = {"E_kPa": math.isfinite(E) and 1 <= E <= 100, "nu": math.isfinite(nu) and 0.2 <= nu <= 0.49,
              "depth_mm": math.isfinite(h) and 0 < h <= 0.6}
    if all(inside.values()):
        F = SURFACE.force([h], (E, nu), method=method)
        assert np.isfinite(F).all() and F[0] >= 0  # 0 when h**1.5 underflows
        if method == "lagrange":
            assert F[0] == pytest.approx(E * unit_curve(nu, h), rel=1e-9, abs=1e-300)
        return
    with pytest.raises(ValueError) as info:
        SURFACE.force([0.3, h], (E, nu), method=method)
    message = str(info.value)
    assert "\n" not in message
    assert any(message.startswith(f"{name} = ") or message.startswith(f"{name} must") for name, ok in inside.items()
               if not ok), message


@settings(max_examples=150, deadline=None)
@given(values=st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=6),
       axis=st.sampled_from(["depth_mm", "E_kPa", "nu"]))
def test_surface_grid_rejects_bad_axes_by_name(values, axis):
    axes = {"depth_mm": [0.1, 0.2, 0.3], "E_kPa": [1.0, 10.0], "nu": [0.2, 0.4]}
    axes[axis] = values
    try:
        grid = SurfaceGrid(**axes)
    except ValueError as err:
        assert str(err).startswith(f"grid {axis}:") and "\n" not in str(err)
    else:
        a = getattr(grid, axis)
        assert np.all(np.isfinite(a)) and np.all(np.diff(a) > 0)


@settings(max_examples=200, deadline=None)
@given(text=RANGE_TEXT)
def test_parse_range_is_increasing_or_one_line_error(text):
    try:
        a = parse_range(text)
    except ValueError as err:
        assert "\n" not in str(err) and str(err).startswith("range ")
    else:
        assert a.ndim == 1 and a.size >= 1 and np.all(np.isfinite(a)) and np.all(np.diff(a) > 0)


@settings(max_examples=40, deadline=None, suppress_health_check=FIXTURE_OK)
@given(content=st.binary(max_size=300))
def test_surface_load_of_garbage_is_a_one_line_cli_error(tmp_path, capsys, content):
    """`fit --surface GARBAGE`: the surface file itself is malformed."""
    bad = tmp_path / "surface.npz"
    bad.write_bytes(content)
    data = tmp_path / "curve.csv"
    h = np.linspace(0.05, 0.5, 20)
    data.write_text("depth_mm,force_mN\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(h, 10 * unit_curve(0.4, h))))
    code, out, err = run_cli(capsys, ["fit", data, "--surface", bad])
    assert assert_clean(code, out, err, "fit") == 2
