"""Conventions every command keeps: messages (-v/-q), progress bars, exit statuses, and
`surface build` building what `fit` uses, once, with builders sharing the runs."""

import importlib
import logging
import os
import subprocess
import sys
import threading
from types import SimpleNamespace

import numpy as np
import pytest
from filelock import FileLock, Timeout

from _data import DATA
from skin_indent.cli import EXIT_STATUS, build_parser, main
from skin_indent.data import bundled_path

FOREARM = str(bundled_path("forearm_like.csv"))
#: a command line of each command that gets past option parsing
COMMANDS = {
    "simulate": ["simulate", "--mesh", "coarse", "--points", "3", "--depth", "0.05"],
    "fit": ["fit", FOREARM, "--mesh", "coarse", "--workers", "1"],
    "diagnose": ["diagnose", FOREARM, "--max-rungs", "0", "--surfaces-only"],
    "plan": ["plan", FOREARM, "--max-rungs", "0", "--surfaces-only"],
    "surface": ["surface", "build", "--mesh", "coarse", "--workers", "1"],
    "demo": ["demo", "--no-diagnosis"],
}


def run_cli(*args, env=None):
    """``python -m skin_indent ARGS`` with stderr a pipe (not a terminal): (code, stdout, stderr).

    Bytes decoded as they are: ``text=True`` would translate a carriage return into a newline.
    """
    p = subprocess.run([sys.executable, "-m", "skin_indent", *args], capture_output=True, timeout=300,
                       env={**os.environ, **(env or {})})
    return p.returncode, p.stdout.decode(), p.stderr.decode()


# ------------------------------------------------------------------ fake finite elements
class Counter:
    """A stand-in for the finite-element unit curve (Hertz at E = 1 kPa) that counts its runs."""

    def __init__(self, fail_nu=None, barrier=None):
        self.runs = []
        self.fail_nu = fail_nu
        self.barrier = barrier
        self.lock = threading.Lock()

    def __call__(self, nu, depth_mm, radius_mm=1.0, mesh="medium"):
        with self.lock:
            self.runs.append(float(nu))
            first = len(self.runs) <= 2
        if self.barrier is not None and first:
            try:  # both builders are computing at once (a run each), whatever the speed
                self.barrier.wait(timeout=20)
            except threading.BrokenBarrierError:
                pass
        if self.fail_nu is not None and abs(nu - self.fail_nu) < 1e-12:
            raise RuntimeError("did not converge (test)")
        return 4.0 / 3.0 / (1.0 - nu**2) * np.sqrt(radius_mm) * np.asarray(depth_mm) ** 1.5


@pytest.fixture
def fake_fe(monkeypatch, tmp_path):
    """The FE unit curve replaced by a counter (the same settings, so the same cache keys), an empty cache."""
    from skin_indent.response_surface import _cache

    counter = Counter()
    monkeypatch.setattr(_cache, "_fe_unit_curve", counter)
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(tmp_path / "cache"))
    return counter


# ------------------------------------------------------------------ help and options
@pytest.mark.parametrize("command", [[], ["simulate"], ["fit"], ["diagnose"], ["plan"], ["surface"],
                                     ["surface", "build"], ["demo"]])
def test_every_help_states_the_exit_statuses_and_the_message_options(command, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([*command, "--help"])
    assert exit_.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert " ".join(EXIT_STATUS.split()) in out
    for text in ("-q, --quiet", "-v, --verbose", "--progress, --no-progress", "130 interrupted", "3 a curve failed"):
        assert text in out, text


@pytest.mark.parametrize("where", ["before", "after"])
def test_message_options_before_or_after_the_subcommand(where):
    parser = build_parser()
    for flags, (verbose, quiet, progress) in ((["-q"], (0, True, None)), (["-v"], (1, False, None)),
                                              (["--no-progress"], (0, False, False)), ([], (0, False, None))):
        argv = [*flags, "fit", "x.csv"] if where == "before" else ["fit", "x.csv", *flags]
        args = parser.parse_args(argv)
        assert (args.verbose, args.quiet, args.progress) == (verbose, quiet, progress), argv
    args = parser.parse_args(["surface", "build", "-q"] if where == "after" else ["-q", "surface", "build"])
    assert args.quiet


def test_verbose_and_quiet_together_are_a_user_error(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["-v", "fit", "x.csv", "-q"])
    assert exit_.value.code == 2
    assert "choose one" in capsys.readouterr().err


# ------------------------------------------------------------------ logging
def test_the_library_configures_no_output_and_the_cli_restores_logging(capsys, tmp_path):
    logger = logging.getLogger("skin_indent")
    before = list(logger.handlers), logger.level, logger.propagate
    assert all(isinstance(h, logging.NullHandler) for h in logger.handlers)
    assert main(["fit", str(tmp_path / "nope.csv")]) == 2
    assert (list(logger.handlers), logger.level, logger.propagate) == before


def test_a_surface_build_logs_its_runs_and_what_was_cached(caplog, tmp_path):
    from skin_indent.response_surface import ResponseSurface, SurfaceGrid

    counter = Counter()
    grid = SurfaceGrid(np.linspace(0.01, 0.1, 5), [1.0, 10.0], [0.3, 0.4, 0.45])
    with caplog.at_level(logging.INFO, logger="skin_indent"):
        ResponseSurface.build(grid, counter, {"fake": 1}, cache_dir=tmp_path, workers=1, progress=False)
        ResponseSurface.build(SurfaceGrid(grid.depth_mm, grid.E_kPa, [0.3, 0.4, 0.45, 0.48]), counter, {"fake": 1},
                              cache_dir=tmp_path, workers=1, progress=False)
    lines = [r.getMessage() for r in caplog.records if r.name.startswith("skin_indent")]
    assert any("3 finite-element runs to make, 0 of 3 cached" in m for m in lines), lines
    assert any("1 finite-element run to make, 3 of 4 cached" in m for m in lines), lines
    assert len(counter.runs) == 4


def test_quiet_runs_leave_stderr_empty_and_default_runs_write_no_carriage_returns(tmp_path):
    """Real processes, stderr a pipe: phase lines by default, no tqdm updates; -q: nothing."""
    env = {"SKIN_INDENT_CACHE": str(tmp_path / "cache"), "SKIN_INDENT_THREADS": "1"}
    out = tmp_path / "c.csv"
    code, _, err = run_cli(*COMMANDS["simulate"], "--out", str(out), "-q", env=env)
    assert code == 0 and err == ""
    build = ["surface", "build", "--mesh", "coarse", "--workers", "1", "--nu", "0.3:0.4:2", "--points", "5",
             "--depth", "0.05", "--E", "1:10:2"]
    code, stdout, err = run_cli(*build, env=env)
    assert code == 0 and "2 finite-element runs to make, 0 of 2 cached" in err and "\r" not in err, err
    assert all(line.startswith("skin-indent surface: ") for line in err.splitlines())
    code, _, err = run_cli(*build, "-q", env=env)
    assert code == 0 and err == ""
    code, _, err = run_cli(*build[:-2], "--E", "1:20:2", "--nu", "0.3:0.42:2", "--progress", env=env)
    assert code == 0 and "\r" in err  # asked for: drawn even into a pipe


def test_quiet_fit_of_a_bundled_curve_shows_only_warnings(coarse_unit_surfaces):
    code, stdout, err = run_cli("fit", FOREARM, "--mesh", "coarse", "--workers", "1", "-q",
                                env={"SKIN_INDENT_CACHE": str(coarse_unit_surfaces), "SKIN_INDENT_THREADS": "1"})
    assert code == 0 and "data: " in stdout
    assert all(line.startswith("skin-indent fit: warning: ") for line in err.splitlines()), err


# ------------------------------------------------------------------ exit statuses
def _malformed(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("depth_mm,force_mN\n0.1,abc\nnot,numbers\n")
    return str(bad)


@pytest.mark.parametrize("argv", [
    ["fit", "{missing}"], ["diagnose", "{missing}"], ["plan", "{missing}"], ["surface", "build", "{missing}"],
    ["simulate", "--protocol", "{missing}", "--mesh", "coarse"],
    ["fit", "{malformed}"], ["diagnose", "{malformed}"], ["plan", "{malformed}"], ["surface", "build", "{malformed}"],
    ["simulate", "--protocol", "{malformed}", "--mesh", "coarse"],
    ["simulate", "--nu", "0.7"], ["fit", FOREARM, "--window", "0.6:0.1"], ["diagnose", FOREARM, "--max-rungs", "-1"],
    ["surface", "build", "--points", "2"], ["fit", FOREARM, "--radius", "-1"],
])
def test_user_errors_exit_2_with_one_line(argv, tmp_path, capsys):
    argv = [a.format(missing=tmp_path / "nope.csv", malformed=_malformed(tmp_path)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"skin-indent {argv[0]}: error: "), err


@pytest.mark.parametrize("argv", [["simulate", "--E", "abc"], ["fit", FOREARM, "--method", "newton"],
                                  ["diagnose", FOREARM, "--mesh", "huge"], ["surface", "build", "--workers", "x"],
                                  ["demo", "--frobnicate"], ["fit"]])
def test_bad_options_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error:" in err.strip().splitlines()[-1]


@pytest.mark.parametrize("command, target", [
    ("simulate", "skin_indent.simulate.simulate"), ("fit", "skin_indent.measurement.load_curves"),
    ("diagnose", "skin_indent.measurement.load_curve"), ("plan", "skin_indent.measurement.load_curve"),
    ("surface", "skin_indent.fitting.surface_for"),
    ("demo", "skin_indent.demo.run_demo"),
])
def test_an_interruption_exits_130(command, target, monkeypatch, capsys, tmp_path):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    module, name = target.rsplit(".", 1)
    monkeypatch.setattr(importlib.import_module(module), name, interrupted)  # skin_indent.simulate: the module
    argv = COMMANDS[command] + (["--out", str(tmp_path / "c.csv")] if command == "simulate" else [])
    assert main(argv) == 130
    assert capsys.readouterr().err.strip() == f"skin-indent {command}: interrupted"


def _fake_fit(flags=(), success=True):
    result = SimpleNamespace(flags=tuple(flags), success=success, surface=None, radius_mm=6.22,
                             curves=[{"radius_mm": 6.22}], report=lambda: "report", to_dict=lambda: {"E_kPa": 1.0})

    def fit(*args, **kwargs):
        return result
    return fit


@pytest.mark.parametrize("strict, flags, success, code", [
    ([], (), True, 0), ([], ("E at a bound",), True, 0), (["--strict"], ("E at a bound",), True, 3),
    (["--strict"], (), True, 0), ([], (), False, 3), (["--no-strict"], (), False, 3),
])
def test_a_flagged_or_failed_single_curve_exits_3(strict, flags, success, code, monkeypatch, capsys):
    monkeypatch.setattr("skin_indent.fitting.fit", _fake_fit(flags, success))
    assert main(["fit", FOREARM, *strict]) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert all(line.startswith("skin-indent fit: warning: ") for line in err)
    assert len(err) == len(flags) + (not success)


def test_a_batch_with_a_failed_curve_exits_3_unless_not_strict(tmp_path, monkeypatch, capsys, fake_fe):
    folder = tmp_path / "curves"
    folder.mkdir()
    (folder / "a.csv").write_text(open(FOREARM).read())
    (folder / "b.csv").write_text("depth_mm,force_mN\n0.1,abc\n")
    assert main(["fit", str(folder), "--mesh", "coarse", "--workers", "1", "-q"]) == 3
    assert main(["fit", str(folder), "--mesh", "coarse", "--workers", "1", "-q", "--no-strict"]) == 0


def test_a_failed_surface_run_exits_3(fake_fe, capsys):
    fake_fe.fail_nu = 0.4
    assert main(["surface", "build", "--mesh", "coarse", "--workers", "1", "--nu", "0.3:0.4:2", "--points", "5",
                 "--depth", "0.05"]) == 3
    captured = capsys.readouterr()
    assert "nu = 0.4 failed" in captured.out
    assert any(line.startswith("skin-indent surface: warning: forward run at nu = 0.4 failed")
               for line in captured.err.splitlines()), captured.err


# ------------------------------------------------------------------ surface build builds what fit uses
def test_fit_after_a_default_surface_build_makes_no_finite_element_run(fake_fe, capsys):
    assert main(["surface", "build", "--mesh", "coarse", "--workers", "1", "-q"]) == 0
    built = len(fake_fe.runs)
    assert built == 6  # the unit-radius surface's nu nodes
    assert "unit-radius surface" in capsys.readouterr().out
    assert main(["fit", FOREARM, "--mesh", "coarse", "--workers", "1", "-q"]) in (0, 3)
    assert len(fake_fe.runs) == built
    assert main(["surface", "build", "--mesh", "coarse", "--workers", "1", "-q"]) == 0  # all cached now
    assert len(fake_fe.runs) == built


def test_surface_build_of_data_builds_what_fit_of_that_data_uses(fake_fe, capsys):
    """A curve with a pre-contact baseline (its contact point fitted: the surface reaches further),
    a skin curve, and an AFM curve of another radius: after the builds, fitting them makes no run."""
    curves = [str(DATA / "hidden-effects" / "v05_offset.csv"), FOREARM]
    afm = [str(DATA / "real-data" / "chiaro_AEBP1_R27.5um.csv"), "--radius", "0.0275"]
    common = ["--mesh", "coarse", "--workers", "1"]
    assert main(["surface", "build", *curves, *common]) == 0
    assert main(["surface", "build", *afm, *common]) == 0
    out = capsys.readouterr().out
    assert all(c in out for c in curves + afm[:1]), out
    built = len(fake_fe.runs)
    assert built > 0
    for curve in [[c] for c in curves] + [afm]:
        assert main(["fit", *curve, *common, "-q"]) in (0, 3)
    assert len(fake_fe.runs) == built


# ------------------------------------------------------------------ builders share the runs
def test_two_builders_at_once_compute_each_run_once(tmp_path):
    from skin_indent.response_surface import ResponseSurface, SurfaceGrid

    counter = Counter(barrier=threading.Barrier(2))
    grid = SurfaceGrid(np.linspace(0.01, 0.1, 5), [1.0, 10.0], [0.2, 0.3, 0.4, 0.45, 0.49])
    out, errors = [], []

    def build():
        try:
            out.append(ResponseSurface.build(grid, counter, {"fake": "shared"}, cache_dir=tmp_path, workers=1,
                                             progress=False))
        except BaseException as err:  # noqa: BLE001 - reported below
            errors.append(err)

    threads = [threading.Thread(target=build) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors and len(out) == 2
    assert sorted(counter.runs) == sorted(grid.nu.tolist())  # each run computed once, by one of them
    assert out[0].complete and out[1].complete
    assert np.array_equal(out[0].unit_forces, out[1].unit_forces)


def test_file_lock_excludes_another_lock_of_the_same_file(tmp_path):
    from skin_indent.response_surface._store import file_lock

    path = tmp_path / ".lock"
    with file_lock(path):
        with pytest.raises(Timeout):
            FileLock(str(path)).acquire(timeout=0)
        assert (path.stat().st_mode & 0o777) == 0o644
    other = FileLock(str(path))
    other.acquire(timeout=0)  # released at the end of the block
    other.release()


def test_two_effect_surface_builders_at_once_compute_each_run_once(tmp_path, monkeypatch):
    """The diagnosis's surfaces (one sub-surface per node of the effect's axes) share runs the same way."""
    from skin_indent.models import effect_surface
    from skin_indent.response_surface import SurfaceGrid

    counter = Counter(barrier=threading.Barrier(2))
    calls = []

    def fake(nu, depth_mm, *, effects, parameters, radius_mm, mesh):
        calls.append((float(nu), parameters))
        return counter(nu, depth_mm, radius_mm)

    monkeypatch.setattr(effect_surface, "model_unit_curve", fake)
    grid = SurfaceGrid(np.linspace(0.02, 0.2, 5), [1.0, 10.0], [0.3, 0.45])
    axes = effect_surface.default_axes("layer", 0.2)
    out, errors = [], []

    def build():
        try:
            out.append(effect_surface.EffectSurface.build(("layer",), axes, grid, radius_mm=1.0, mesh="coarse",
                                                          cache_dir=tmp_path, workers=1, progress=False))
        except BaseException as err:  # noqa: BLE001 - reported below
            errors.append(err)

    threads = [threading.Thread(target=build) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors and len(out) == 2
    n_nodes = int(np.prod([len(a.nodes) for a in axes]))
    assert len(calls) == len(set(calls)) == n_nodes * grid.nu.size
