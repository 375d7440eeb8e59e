"""Killed builds resume from what finished; concurrent builds share one cache safely.

The builds run a slow analytic stand-in (a sleep, then a closed form) written to a
module in ``tmp_path``, so that subprocesses and this process compute bit-identical
columns. Each call appends ``nu pid`` to a log, which counts calls across processes.
"""

from __future__ import annotations

import functools
import hashlib
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from skin_indent.response_surface import LocalProcesses, ResponseSurface, RunStore, SurfaceGrid
from skin_indent.response_surface._cache import run_key

# killed and concurrent builds: out of the default run, .ci/run runs them (pyproject.toml)
pytestmark = pytest.mark.resume

SRC = str(Path(__file__).parents[1] / "src")
SETTINGS = {"model": "slow stand-in", "radius_mm": 6.22, "code_version": "test"}
GRID = SurfaceGrid(np.linspace(0.01, 0.6, 30), np.geomspace(1, 100, 4), np.linspace(0.2, 0.49, 12))

CURVE_MODULE = '''
import os, time
import numpy as np

def slow_curve(nu, depth_mm, delay=0.0, log=None):
    if log:
        fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
        os.write(fd, f"{float(nu)!r} {os.getpid()}\\n".encode())
        os.close(fd)
    time.sleep(delay)
    h = np.asarray(depth_mm, dtype=float)
    return 4 / 3 / (1 - nu**2) * np.sqrt(6.22) * h**1.5 * (1 - (0.15 + 0.3 * (0.5 - nu)) * h / 6.22)
'''

BUILD_SCRIPT = '''
import functools, json, sys
import numpy as np
sys.path.insert(0, {moddir!r})
from slowcurve_mod import slow_curve
from skin_indent.response_surface import ResponseSurface, SurfaceGrid
grid = SurfaceGrid(*[np.array(v) for v in json.loads({grid!r})])
go = {go!r}
if go:
    import os, time
    while not os.path.exists(go):
        time.sleep(0.005)
curve = functools.partial(slow_curve, delay={delay!r}, log={log!r})
s = ResponseSurface.build(grid, curve, json.loads({settings!r}), cache_dir={cache!r}, workers={workers!r},
                          progress=False)
s.save({out!r})
print("built", s.complete)
'''


@pytest.fixture()
def curve_module(tmp_path):
    moddir = tmp_path / "mod"
    moddir.mkdir()
    (moddir / "slowcurve_mod.py").write_text(CURVE_MODULE)
    sys.path.insert(0, str(moddir))
    import importlib

    mod = importlib.import_module("slowcurve_mod")
    mod = importlib.reload(mod)
    yield moddir, mod
    sys.path.remove(str(moddir))
    sys.modules.pop("slowcurve_mod", None)


def start_build(tmp_path, moddir, *, cache, out, log, delay, workers=1, go=None):
    grid = json.dumps([GRID.depth_mm.tolist(), GRID.E_kPa.tolist(), GRID.nu.tolist()])
    code = textwrap.dedent(BUILD_SCRIPT).format(moddir=str(moddir), grid=grid, go=str(go) if go else "",
                                                delay=delay, log=str(log), settings=json.dumps(SETTINGS),
                                                cache=str(cache), workers=workers, out=str(out))
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)


def run_dir(cache: Path) -> Path:
    return cache / "runs" / run_key(SETTINGS, GRID.depth_mm)[:24]


def manifest_runs(cache: Path) -> dict:
    path = run_dir(cache) / "manifest.json"
    return json.loads(path.read_text())["runs"] if path.exists() else {}


def logged_calls(log: Path) -> list[float]:
    return [float(line.split()[0]) for line in log.read_text().splitlines()] if log.exists() else []


def reference(mod):
    return ResponseSurface.build(GRID, mod.slow_curve, SETTINGS, workers=1, progress=False)


def check_cache(cache: Path):
    """Every listed run file exists and has its checksum; nothing half-written is left listed."""
    runs = manifest_runs(cache)
    for tag, e in runs.items():
        assert float(tag) == e["nu"]
        if e["status"] == "done":
            raw = (run_dir(cache) / e["file"]).read_bytes()
            assert hashlib.sha256(raw).hexdigest() == e["sha256"] and len(raw) == e["bytes"]
    return runs


@pytest.mark.parametrize("workers", [1, 2])
def test_killed_build_resumes_without_recomputing(tmp_path, curve_module, workers):
    moddir, mod = curve_module
    cache, log = tmp_path / "cache", tmp_path / "calls.log"
    proc = start_build(tmp_path, moddir, cache=cache, out=tmp_path / "s.npz", log=log, delay=0.25, workers=workers)
    deadline = time.monotonic() + 60
    while sum(e["status"] == "done" for e in manifest_runs(cache).values()) < 4:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the build did not progress"
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGKILL)  # the build and its worker processes
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    finished = {tag: e for tag, e in check_cache(cache).items() if e["status"] == "done"}
    assert 4 <= len(finished) < GRID.nu.size
    before = len(logged_calls(log))

    resumed = ResponseSurface.build(GRID, functools.partial(mod.slow_curve, log=str(log)), SETTINGS, cache_dir=cache,
                                    workers=workers, progress=False)
    recomputed = logged_calls(log)[before:]
    assert sorted(recomputed) == sorted(set(GRID.nu.tolist()) - {e["nu"] for e in finished.values()})
    runs = check_cache(cache)
    assert all(runs[tag] == e for tag, e in finished.items())  # the finished entries are untouched
    assert {e["status"] for e in runs.values()} == {"done"} and len(runs) == GRID.nu.size
    assert resumed.complete and np.array_equal(resumed.unit_forces, reference(mod).unit_forces)


def test_only_listed_intact_files_are_trusted(tmp_path, curve_module):
    _, mod = curve_module
    log = tmp_path / "calls.log"
    curve = functools.partial(mod.slow_curve, log=str(log))
    ResponseSurface.build(GRID, curve, SETTINGS, cache_dir=tmp_path, workers=1, progress=False)
    runs = manifest_runs(tmp_path)
    d = run_dir(tmp_path)
    nus = GRID.nu.tolist()
    # (a) damaged bytes, (b) a truncated file, (c) a file that is not listed, (d) a listed file gone
    p = d / runs[repr(nus[0])]["file"]
    raw = bytearray(p.read_bytes())
    raw[-40] ^= 0xFF
    p.write_bytes(bytes(raw))
    p = d / runs[repr(nus[1])]["file"]
    p.write_bytes(p.read_bytes()[:100])
    manifest = json.loads((d / "manifest.json").read_text())
    del manifest["runs"][repr(nus[2])]
    (d / "manifest.json").write_text(json.dumps(manifest))
    (d / runs[repr(nus[3])]["file"]).unlink()
    (d / ".nu_0.3_half.npz.tmp").write_bytes(b"PK\x03\x04")  # what a killed writer leaves
    log.unlink()
    again = ResponseSurface.build(GRID, curve, SETTINGS, cache_dir=tmp_path, workers=1, progress=False)
    assert sorted(logged_calls(log)) == nus[:4]
    assert np.array_equal(again.unit_forces, reference(mod).unit_forces)
    check_cache(tmp_path)
    # an unreadable manifest: set aside with a warning, all runs recomputed
    (d / "manifest.json").write_text("{not json")
    log.unlink()
    with pytest.warns(RuntimeWarning, match="manifest .* is unreadable"):
        ResponseSurface.build(GRID, curve, SETTINGS, cache_dir=tmp_path, workers=1, progress=False)
    assert sorted(logged_calls(log)) == nus and list(d.glob("manifest.json.unreadable-*"))
    assert len(check_cache(tmp_path)) == len(nus)


def kill_once_curve(nu, depth_mm, marker):
    """SIGKILLs its own (worker) process at nu = 0.49, the first time only."""
    if nu > 0.48:
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            pass
        else:
            os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.02)
    h = np.asarray(depth_mm, dtype=float)
    return 4 / 3 / (1 - nu**2) * np.sqrt(6.22) * h**1.5 * (1 - (0.15 + 0.3 * (0.5 - nu)) * h / 6.22)


def kill_always_curve(nu, depth_mm):
    if nu > 0.48:
        os.kill(os.getpid(), signal.SIGKILL)
    return kill_once_curve(nu, depth_mm, marker=None) if nu <= 0.48 else None


def test_killed_worker_process_is_replaced(tmp_path, curve_module):
    _, mod = curve_module
    ex = LocalProcesses(2)
    with ex:
        s = ResponseSurface.build(GRID, functools.partial(kill_once_curve, marker=str(tmp_path / "killed")),
                                  SETTINGS, cache_dir=tmp_path, executor=ex, progress=False)
    assert (tmp_path / "killed").exists() and ex.restarts == 1
    assert s.complete and np.array_equal(s.unit_forces, reference(mod).unit_forces)
    assert {e["status"] for e in manifest_runs(tmp_path).values()} == {"done"}


def test_a_run_that_always_kills_its_worker_is_a_failure(tmp_path):
    with pytest.warns(RuntimeWarning, match="nu = 0.49 failed .*WorkerDied"):
        s = ResponseSurface.build(GRID, kill_always_curve, SETTINGS, cache_dir=tmp_path, workers=2, progress=False)
    assert list(s.failures) == [0.49] and "worker process died 2 times" in s.failures[0.49]
    assert np.all(np.isfinite(s.unit_forces[:, :-1]))
    entry = manifest_runs(tmp_path)["0.49"]
    assert entry["status"] == "failed" and entry["attempts"] == 1 and "WorkerDied" in entry["reason"]
    with pytest.raises(ValueError, match="nu = 0.49 whose forward run failed"):
        s.force([0.3], (10.0, 0.48))


# ------------------------------------------------------------------ concurrency


def test_two_processes_build_into_one_cache(tmp_path, curve_module):
    moddir, mod = curve_module
    cache, go, log = tmp_path / "cache", tmp_path / "go", tmp_path / "calls.log"
    procs = [start_build(tmp_path, moddir, cache=cache, out=tmp_path / f"s{i}.npz", log=log, delay=0.03,
                         workers=w, go=go) for i, w in enumerate((1, 2))]
    time.sleep(0.5)
    go.touch()
    for p in procs:
        out, err = p.communicate(timeout=120)
        assert p.returncode == 0, err
    runs = check_cache(cache)
    assert len(runs) == GRID.nu.size and {e["status"] for e in runs.values()} == {"done"}
    assert not list(run_dir(cache).glob(".*.tmp"))
    ref = reference(mod).unit_forces
    for i in range(2):
        assert np.array_equal(ResponseSurface.load(tmp_path / f"s{i}.npz").unit_forces, ref)
    # the files on disk are exactly the listed ones (same results: same content-addressed name)
    assert sorted(p.name for p in run_dir(cache).glob("nu_*.npz")) == sorted(e["file"] for e in runs.values())
    calls = logged_calls(log)
    assert GRID.nu.size <= len(calls) <= 2 * GRID.nu.size
    # a third build computes nothing
    log.unlink()
    ResponseSurface.build(GRID, functools.partial(mod.slow_curve, log=str(log)), SETTINGS, cache_dir=cache,
                          workers=1, progress=False)
    assert not log.exists()


def test_a_run_finished_elsewhere_meanwhile_is_read_not_computed(tmp_path, curve_module):
    """Tasks are taken lazily: before each run the manifest is checked again."""
    _, mod = curve_module
    key = run_key(SETTINGS, GRID.depth_mm)
    other = RunStore(run_dir(tmp_path), key, SETTINGS, GRID.depth_mm)  # "another process"
    nus = GRID.nu.tolist()
    calls = []

    def curve(nu, depth_mm):
        calls.append(nu)
        if nu == nus[0]:
            other.record_done(nus[1], mod.slow_curve(nus[1], depth_mm))
        return mod.slow_curve(nu, depth_mm)

    s = ResponseSurface.build(GRID, curve, SETTINGS, cache_dir=tmp_path, workers=1, progress=False)
    assert nus[1] not in calls and len(calls) == len(nus) - 1
    assert np.array_equal(s.unit_forces, reference(mod).unit_forces)


def _record_many(run_dir_, key, nus, values):
    store = RunStore(run_dir_, key, SETTINGS, GRID.depth_mm)
    for nu in nus:
        store.record_done(nu, values * nu)


def test_manifest_updates_are_not_lost_under_contention(tmp_path):
    """Two processes list 40 runs each, interleaved: a read-modify-write without the lock loses some."""
    key = run_key(SETTINGS, GRID.depth_mm)
    ctx = multiprocessing.get_context("fork")
    nus = np.linspace(0.1, 0.45, 80).tolist()
    values = np.linspace(1, 2, GRID.depth_mm.size)
    procs = [ctx.Process(target=_record_many, args=(tmp_path, key, nus[i::2], values)) for i in range(2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
        assert p.exitcode == 0
    store = RunStore(tmp_path, key, SETTINGS, GRID.depth_mm)
    assert sorted(float(t) for t in store.runs) == nus
    for nu in nus:
        assert np.array_equal(store.load(nu), values * nu)


def test_a_finished_run_is_never_replaced_by_a_failure(tmp_path):
    key = run_key(SETTINGS, GRID.depth_mm)
    a = RunStore(tmp_path, key, SETTINGS, GRID.depth_mm)
    b = RunStore(tmp_path, key, SETTINGS, GRID.depth_mm)
    a.record_done(0.3, np.ones(GRID.depth_mm.size))
    b.record_failed(0.3, "ConvergenceError: late")  # b did not know a had finished it
    b.record_failed(0.4, "ConvergenceError: Newton\nfailed")
    b.record_failed(0.4, "again")
    a.refresh()
    assert a.is_done(0.3) and np.array_equal(a.load(0.3), np.ones(GRID.depth_mm.size))
    assert a.entry(0.4) | {"finished": None, "by": None} == {
        "nu": 0.4, "status": "failed", "reason": "again", "attempts": 2, "finished": None, "worker": None, "by": None}
    assert a.failed() == {0.4: "again"}


FE_SCRIPT = """
import json, sys
import numpy as np
from skin_indent.response_surface import ResponseSurface, SurfaceGrid
grid = SurfaceGrid(*[np.array(v) for v in json.loads(sys.argv[1])])
ResponseSurface.build(grid, settings=json.loads(sys.argv[2]), cache_dir=sys.argv[3], workers=1, progress=False)
"""


@pytest.mark.slow
def test_killed_fe_build_resumes(tmp_path):
    """The same with the real finite-element unit curve (coarse mesh): kill after 2 of 6 runs."""
    from skin_indent.response_surface import default_settings

    grid = SurfaceGrid(np.linspace(0.03, 0.6, 20), np.geomspace(1, 100, 4), np.linspace(0.2, 0.49, 6))
    settings = default_settings(mesh="coarse")
    cache = tmp_path / "cache"
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    args = [json.dumps([grid.depth_mm.tolist(), grid.E_kPa.tolist(), grid.nu.tolist()]), json.dumps(settings),
            str(cache)]
    proc = subprocess.Popen([sys.executable, "-c", FE_SCRIPT, *args], env=env, start_new_session=True)
    manifest = cache / "runs" / run_key(settings, grid.depth_mm)[:24] / "manifest.json"
    deadline = time.monotonic() + 300
    while not (manifest.exists() and len(json.loads(manifest.read_text())["runs"]) >= 2):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    finished = json.loads(manifest.read_text())["runs"]
    assert 2 <= len(finished) < 6
    resumed = ResponseSurface.build(grid, settings=settings, cache_dir=cache, workers=2, progress=False)
    after = json.loads(manifest.read_text())["runs"]
    assert all(after[tag] == e for tag, e in finished.items()) and len(after) == 6
    fresh = ResponseSurface.build(grid, settings=settings, workers=2, progress=False)
    assert resumed.complete and np.array_equal(resumed.unit_forces, fresh.unit_forces)
