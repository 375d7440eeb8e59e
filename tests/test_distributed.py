"""Response-surface builds on Dask distributed, and the executor choices around them.

A LocalCluster on loopback (2 worker processes) stands for a user's cluster. The Dask
tests are skipped when ``dask.distributed`` is not installed (``pip install
'skin_indent[dask]'``); the error message for that case is tested without it.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from skin_indent.mechanics.convergence import ConvergenceError
from skin_indent.response_surface import (DASK_MISSING, InProcess, LocalProcesses, ResponseSurface, SurfaceGrid,
                                          default_settings, make_executor, run_batch)
from skin_indent.runtime import executors as _executors

R_MM = 6.22
SETTINGS = {"model": "stand-in", "radius_mm": R_MM, "code_version": "test"}
GRID = SurfaceGrid(np.linspace(0.01, 0.6, 40), np.geomspace(1, 100, 5), np.linspace(0.2, 0.49, 8))
NO_DASK = "Dask is not installed: pip install 'skin_indent[dask]'"


def standin_unit_curve(nu, depth_mm):
    """Hertz-like unit curve (mN at E = 1 kPa); module level, so workers can import it."""
    h = np.asarray(depth_mm, dtype=float)
    return 4 / 3 / (1 - nu**2) * np.sqrt(R_MM) * h**1.5 * (1 - (0.15 + 0.3 * (0.5 - nu)) * h / R_MM)


def failing_unit_curve(nu, depth_mm):
    """Newton fails at nu = 0.2 (as the FE model may for extreme parameters)."""
    if nu < 0.21:
        raise ConvergenceError(f"Newton did not converge at nu = {nu}")
    return standin_unit_curve(nu, depth_mm)


def exit_once_unit_curve(nu, depth_mm, marker):
    """Kills the worker process that runs nu = 0.49 the first time (a crashed worker)."""
    if nu > 0.48:
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            pass
        else:
            os._exit(1)
    return standin_unit_curve(nu, depth_mm)


def local(grid=GRID, curve=standin_unit_curve, settings=SETTINGS, **kw):
    kw.setdefault("workers", 1)
    return ResponseSurface.build(grid, curve, settings, progress=False, **kw)


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed", reason=NO_DASK)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cl:
        yield cl


@pytest.fixture(scope="module")
def client(cluster):
    from distributed import Client

    with Client(cluster, set_as_default=False) as c:
        yield c


# ------------------------------------------------------------------ without Dask


def test_without_dask_the_error_says_how_to_install(monkeypatch):
    assert DASK_MISSING == NO_DASK
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    for kw in ({"scheduler": "tcp://127.0.0.1:8786"}, {"client": object()}):
        with pytest.raises(ImportError) as info:
            local(**{**kw, "workers": None})
        assert str(info.value) == NO_DASK


def test_executor_choice():
    assert isinstance(make_executor(1), InProcess)
    ex = make_executor(2)
    assert isinstance(ex, LocalProcesses) and ex.slots() == 2
    ex.close()
    assert isinstance(make_executor(None, tasks=1), InProcess)
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="workers must be an integer >= 1"):
            make_executor(bad)
    with pytest.raises(ValueError, match="cluster decides"):
        make_executor(2, scheduler="tcp://127.0.0.1:1")
    with pytest.raises(ValueError, match="executor= alone"):
        local(executor=InProcess(), workers=2)
    with pytest.raises(TypeError, match="Executor"):
        local(executor="dask", workers=None)


def test_run_batch_keeps_input_order_and_reports_errors():
    items = [(nu, GRID.depth_mm) for nu in (0.2, 0.3, 0.4)]
    for workers in (1, 2):
        out = run_batch(failing_unit_curve, items, workers=workers)
        assert out[0][0] is None and isinstance(out[0][1], ConvergenceError)
        for (nu, h), (value, error) in zip(items[1:], out[1:]):
            assert error is None and np.array_equal(value, standin_unit_curve(nu, h))


class PretendRemote(InProcess):
    """Runs here, but is treated like a cluster (whose workers may run other sources)."""

    remote = True


def test_remote_workers_running_other_sources_are_refused(tmp_path):
    """A remote worker whose forward-model sources differ from the settings' code_version gives no data."""
    settings = {**default_settings(mesh="coarse"), "code_version": "0.1.0+src.000000000000"}
    assert local(curve=standin_unit_curve, settings=settings, workers=2).complete  # local: not checked
    with pytest.warns(RuntimeWarning, match="other forward-model sources"):
        s = local(curve=standin_unit_curve, settings=settings, cache_dir=tmp_path, executor=PretendRemote(),
                  workers=None)
    assert not s.complete and all("install the same skin_indent" in why for why in s.failures.values())
    manifest = json.loads(next(tmp_path.glob("runs/*/manifest.json")).read_text())
    assert {e["status"] for e in manifest["runs"].values()} == {"failed"}


class OtherSources(PretendRemote):
    """A pretend cluster whose workers report other forward-model sources than this installation's."""

    def imap_unordered(self, fn, tasks):
        for tag, out, error in super().imap_unordered(fn, tasks):
            yield tag, (None if out is None else {**out, "code": "000000000000"}), error


def test_an_effect_surface_refuses_runs_of_other_sources_as_a_response_surface_does(tmp_path):
    """Effect surfaces make their runs as response surfaces do (``make_runs``): a remote worker
    running other forward-model sources gives no data, and the store says why."""
    from skin_indent.effects import EffectAxis
    from skin_indent.models.effect_surface import EffectSurface

    grid = SurfaceGrid(np.linspace(0.01, 0.05, 5), np.array([1.0, 10.0]), np.array([0.3, 0.45]))
    axes = (EffectAxis("C20_over_E", (0.0, 1.0), "linear"),)
    with pytest.warns(RuntimeWarning, match="install the same skin_indent"):
        s = EffectSurface.build(("stiffening",), axes, grid, radius_mm=1.0, mesh="coarse", cache_dir=tmp_path,
                                executor=OtherSources())
    assert len(s.failures) == 4 and all("install the same skin_indent" in why for why in s.failures.values())
    entries = [e for m in tmp_path.glob("runs/*/manifest.json") for e in json.loads(m.read_text())["runs"].values()]
    assert len(entries) == 4 and all(e["status"] == "failed" and "install the same" in e["reason"] for e in entries)
    with pytest.raises(ValueError, match="misses 4 run"):
        s.force(grid.depth_mm, np.array([5.0, 0.4, 0.5]))


# ------------------------------------------------------------------ on a LocalCluster


def test_dask_build_equals_local_build(client, tmp_path):
    reference = local()
    parallel = local(workers=2)
    on_dask = local(client=client, workers=None, cache_dir=tmp_path)
    assert np.array_equal(on_dask.unit_forces, reference.unit_forces)
    assert np.array_equal(parallel.unit_forces, reference.unit_forces)
    assert on_dask.hash == reference.hash and on_dask.complete
    # every run was computed on a worker and written here, by the submitting process
    (manifest,) = tmp_path.glob("runs/*/manifest.json")
    runs = json.loads(manifest.read_text())["runs"]
    assert sorted(e["nu"] for e in runs.values()) == GRID.nu.tolist()
    me = f":{os.getpid()}"
    assert all(e["status"] == "done" and e["by"].endswith(me) and not e["worker"].endswith(me) for e in runs.values())
    workers = {e["worker"] for e in runs.values()}
    assert len(workers) >= 1
    # a second build reads everything from the cache
    again = local(client=client, workers=None, cache_dir=tmp_path, curve=failing_unit_curve)
    assert np.array_equal(again.unit_forces, reference.unit_forces)


def test_scheduler_address(cluster):
    s = local(scheduler=cluster.scheduler_address, workers=None)
    assert np.array_equal(s.unit_forces, local().unit_forces)


def test_unreachable_scheduler_is_one_line_oserror(monkeypatch):
    pytest.importorskip("distributed", reason=NO_DASK)
    monkeypatch.setattr(_executors, "DASK_CONNECT_TIMEOUT_S", 1)
    import socket

    with socket.socket() as s:  # a free port, nobody listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(OSError, match=f"cannot connect to the Dask scheduler at tcp://127.0.0.1:{port}") as info:
        local(scheduler=f"tcp://127.0.0.1:{port}", workers=None)
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="tcp://HOST:PORT"):
        local(scheduler="127.0.0.1:8786", workers=None)


@pytest.mark.parametrize("where", ["local processes", "dask"])
def test_failure_is_recorded_and_retried(where, request, tmp_path):
    """A run that does not converge: listed with nu and reason, NaN column, retried by the next build."""
    kw = {"client": request.getfixturevalue("client"), "workers": None} if where == "dask" else {"workers": 2}
    with pytest.warns(RuntimeWarning, match="nu = 0.2 failed"):
        s = local(curve=failing_unit_curve, cache_dir=tmp_path, **kw)
    assert np.all(np.isnan(s.unit_forces[:, 0])) and np.all(np.isfinite(s.unit_forces[:, 1:]))
    assert list(s.failures) == [0.2] and "ConvergenceError: Newton did not converge" in s.failures[0.2]
    with pytest.raises(ValueError, match=r"needs the column nu = 0.2 whose forward run failed \(ConvergenceError"):
        s.force([0.3], (10.0, 0.22))
    entry = json.loads(next(tmp_path.glob("runs/*/manifest.json")).read_text())["runs"]["0.2"]
    assert entry["status"] == "failed" and entry["nu"] == 0.2 and "ConvergenceError" in entry["reason"]
    fixed = local(cache_dir=tmp_path, **kw)
    assert json.loads(next(tmp_path.glob("runs/*/manifest.json")).read_text())["runs"]["0.2"]["status"] == "done"
    assert fixed.complete and np.array_equal(fixed.unit_forces, local().unit_forces)


def test_dask_worker_that_dies_is_rescheduled(client, tmp_path):
    import functools

    curve = functools.partial(exit_once_unit_curve, marker=str(tmp_path / "died"))
    s = local(curve=curve, settings={**SETTINGS, "case": "exit"}, client=client, workers=None)
    assert (tmp_path / "died").exists()  # a worker did die
    assert s.complete and np.array_equal(s.unit_forces, local().unit_forces)


def test_dask_fe_build_equals_local_build(client):
    """The real finite-element unit curve (coarse mesh, 3 nu, 20 depths) on Dask and locally."""
    grid = SurfaceGrid(np.linspace(0.03, 0.6, 20), np.geomspace(1, 100, 4), [0.2, 0.35, 0.49])
    # a fixed code_version: sources edited while the test runs must not fail it
    settings = {**default_settings(mesh="coarse"), "code_version": "test-distributed"}
    on_dask = ResponseSurface.build(grid, settings=settings, client=client, progress=False)
    here = ResponseSurface.build(grid, settings=settings, workers=2, progress=False)
    assert on_dask.complete and here.complete
    assert np.array_equal(on_dask.unit_forces, here.unit_forces)
    assert on_dask.hash == here.hash


def test_malloc_tuning_only_where_dasks_nanny_set_the_trim_threshold():
    """Dask's nanny sets MALLOC_TRIM_THRESHOLD_, which slows the FE model ~1.8x; tune_malloc undoes it."""
    import subprocess

    code = "from skin_indent.runtime.executors import tune_malloc; print(tune_malloc(), tune_malloc())"
    src = str(Path(__file__).parents[1] / "src")
    for env, expected in [({"MALLOC_TRIM_THRESHOLD_": "65536"}, "True False"), ({}, "False False"),
                          ({"MALLOC_TRIM_THRESHOLD_": "65536", "MALLOC_MMAP_THRESHOLD_": "1048576"}, "False False")]:
        base = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                             env={**base, "PYTHONPATH": src, **env}).stdout.strip()
        assert out == expected, (env, out)
