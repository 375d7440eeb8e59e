#!/usr/bin/env python
"""Response-surface builds: parallel speed-up and peak memory (issue 7).

    python benchmarks/surface.py                 # full run (~4-5 min on 2 cores)
    python benchmarks/surface.py --quick         # 16 runs, small memory case (~1 min)
    python benchmarks/surface.py --dask          # also the 96 runs on a 2-worker LocalCluster

(a) Wall time of a 96-run surface, built from scratch (empty cache) with 1 and 2
    local worker processes, and the parallel efficiency T1 / (2 T2). The runs are
    real finite-element unit curves on the coarse mesh, 30 depths to 0.6 mm, 96 nu
    from 0.2 to 0.49 (:func:`skin_indent.simulate.fe_unit_curve`, R = 6.22 mm), going
    through ``ResponseSurface.build(..., cache_dir=...)``: the run files and the
    manifest are written as in real use. ``--dask`` adds the same build on a
    ``LocalCluster`` (2 worker processes on loopback) through ``client=``.
(b) Peak memory of a large build: 500 runs x 200 depths with a cheap analytic unit
    curve through the same code path (2 local workers, a cache directory), in a fresh
    subprocess so that (a) does not count. Peak resident set size (``ru_maxrss``) of
    the building process and, separately, of its worker processes, against the
    1 GiB target.

Results are printed and written to ``benchmarks/results/surface.json``. On a
machine shared with other jobs the times move with the load: the load averages at
the start and the end are recorded.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
try:  # installed (pip install -e .) or run from a checkout
    import skin_indent  # noqa: F401
except ImportError:  # pragma: no cover - depends on the environment
    sys.path.insert(0, str(ROOT / "src"))
    import skin_indent  # noqa: F401

from skin_indent.response_surface import ResponseSurface, SurfaceGrid, default_settings  # noqa: E402

RESULTS = HERE / "results"
R_MM = 6.22
GIB = 1024**3


def cheap_unit_curve(nu, depth_mm):
    """Analytic stand-in (Hertz with a weak nu-dependent correction), mN at E = 1 kPa."""
    h = np.asarray(depth_mm, dtype=float)
    return 4 / 3 / (1 - nu**2) * np.sqrt(R_MM) * h**1.5 * (1 - (0.15 + 0.3 * (0.5 - nu)) * h / R_MM)


def maxrss_bytes(who) -> int:
    return resource.getrusage(who).ru_maxrss * (1 if sys.platform == "darwin" else 1024)


def fe_grid(n_nu: int, n_depth: int) -> SurfaceGrid:
    return SurfaceGrid(0.6 * np.arange(1, n_depth + 1) / n_depth, np.geomspace(1, 100, 8),
                       np.linspace(0.2, 0.49, n_nu))


def time_build(grid, settings, **kw) -> tuple[float, ResponseSurface, dict]:
    """Wall time, surface, and per-run wall / CPU seconds on the workers (from the manifest)."""
    with tempfile.TemporaryDirectory() as cache:
        t = time.perf_counter()
        s = ResponseSurface.build(grid, settings=settings, cache_dir=cache, progress=False, **kw)
        wall = time.perf_counter() - t
        (manifest,) = Path(cache).glob("runs/*/manifest.json")
        runs = [r for r in json.loads(manifest.read_text())["runs"].values() if r["status"] == "done"]
    if not s.complete:
        raise SystemExit(f"{len(s.failures)} runs failed, e.g. {next(iter(s.failures.items()))}")
    per_run = {"run_wall_s": round(float(np.mean([r["seconds"] for r in runs])), 3),
               "run_cpu_s": round(float(np.mean([r["cpu_seconds"] for r in runs])), 3)}
    return wall, s, per_run


def describe(per_run: dict) -> str:
    share = per_run["run_cpu_s"] / per_run["run_wall_s"]
    return (f"per run on the worker: {per_run['run_wall_s']:.2f} s wall, {per_run['run_cpu_s']:.2f} s CPU "
            f"({share:.0%} of a core{'; the machine was busy' if share < 0.9 else ''})")


def speed(n_nu: int, n_depth: int, dask: bool) -> dict:
    grid = fe_grid(n_nu, n_depth)
    # a fixed code_version: sources edited while the benchmark runs (a shared checkout)
    # must not make the remote-worker check refuse the Dask results
    settings = {**default_settings(R_MM, mesh="coarse"), "code_version": "benchmark"}
    out = {"runs": n_nu, "depths": n_depth, "mesh": "coarse", "unit_curve": "skin_indent.simulate.fe_unit_curve"}
    surfaces = {}
    for workers in (1, 2):
        t, surfaces[workers], per_run = time_build(grid, settings, workers=workers)
        out[f"wall_s_workers{workers}"] = round(t, 2)
        out[f"per_run_workers{workers}"] = per_run
        print(f"(a) {n_nu} FE runs (coarse, {n_depth} depths), {workers} local worker(s): {t:7.1f} s; "
              f"{describe(per_run)}", flush=True)
    eff = out["wall_s_workers1"] / (2 * out["wall_s_workers2"])
    out["parallel_efficiency"] = round(eff, 3)
    out["identical"] = bool(np.array_equal(surfaces[1].unit_forces, surfaces[2].unit_forces))
    print(f"    parallel efficiency T1 / (2 T2) = {eff:.2f}; 1 and 2 workers identical: {out['identical']}")
    if dask:
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            print("    (Dask not installed: pip install 'skin_indent[dask]')")
        else:
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                              dashboard_address=None) as cluster, Client(cluster, set_as_default=False) as client:
                client.run(lambda: __import__("skin_indent.simulate"))  # warm the workers' imports
                t, s, per_run = time_build(grid, settings, client=client)
            out["wall_s_dask_2workers"] = round(t, 2)
            out["per_run_dask"] = per_run
            out["dask_identical"] = bool(np.array_equal(s.unit_forces, surfaces[1].unit_forces))
            print(f"    Dask LocalCluster, 2 workers: {t:7.1f} s (efficiency {out['wall_s_workers1'] / (2 * t):.2f}); "
                  f"identical: {out['dask_identical']}; {describe(per_run)}")
    return out


def memory_child(n_nu: int, n_depth: int, workers: int) -> dict:
    """Run in a fresh process: build and report peak RSS."""
    grid = SurfaceGrid(np.linspace(0.6 / n_depth, 0.6, n_depth), np.geomspace(1, 100, 8),
                       np.linspace(0.2, 0.49, n_nu))
    base = maxrss_bytes(resource.RUSAGE_SELF)
    with tempfile.TemporaryDirectory() as cache:
        t = time.perf_counter()
        s = ResponseSurface.build(grid, cheap_unit_curve, {"model": "benchmark stand-in"}, cache_dir=cache,
                                  workers=workers, progress=False)
        wall = time.perf_counter() - t
        files = len(list(Path(cache).glob("runs/*/nu_*.npz")))
    assert s.complete and files == n_nu
    return {"runs": n_nu, "depths": n_depth, "workers": workers, "wall_s": round(wall, 2),
            "maxrss_before_build_MiB": round(base / 2**20, 1),
            "maxrss_self_MiB": round(maxrss_bytes(resource.RUSAGE_SELF) / 2**20, 1),
            "maxrss_children_MiB": round(maxrss_bytes(resource.RUSAGE_CHILDREN) / 2**20, 1),
            "result_MiB": round(s.unit_forces.nbytes / 2**20, 2), "run_files": files}


def memory(n_nu: int, n_depth: int, workers: int = 2) -> dict:
    code = (f"import json, sys; sys.path.insert(0, {str(HERE)!r}); import surface; "
            f"print(json.dumps(surface.memory_child({n_nu}, {n_depth}, {workers})))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    out = json.loads(p.stdout.strip().splitlines()[-1])
    peak = max(out["maxrss_self_MiB"], out["maxrss_children_MiB"])
    out["target_MiB"] = GIB / 2**20
    out["within_target"] = bool(peak < out["target_MiB"])
    print(f"(b) {n_nu} runs x {n_depth} depths (analytic unit curve, {workers} workers, cache on disk): "
          f"{out['wall_s']:.1f} s; peak RSS building process {out['maxrss_self_MiB']:.0f} MiB "
          f"(before the build {out['maxrss_before_build_MiB']:.0f} MiB), largest worker "
          f"{out['maxrss_children_MiB']:.0f} MiB; target < 1024 MiB: {'met' if out['within_target'] else 'MISSED'}")
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="16 FE runs and a 100 x 100 memory case")
    parser.add_argument("--dask", action="store_true", help="also build on a 2-worker Dask LocalCluster")
    parser.add_argument("--no-save", action="store_true", help="do not write benchmarks/results/surface.json")
    args = parser.parse_args(argv)
    result = {"date": _dt.datetime.now().isoformat(timespec="seconds"),
              "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()},
              "versions": {"python": platform.python_version(), "numpy": np.__version__,
                           "skin_indent": skin_indent.__version__}}
    result["speed"] = speed(16 if args.quick else 96, 30, args.dask)
    result["memory"] = memory(*((100, 100) if args.quick else (500, 200)))
    result["machine"]["loadavg_end"] = os.getloadavg()
    print(f"load average at start {result['machine']['loadavg_start'][0]:.2f}, "
          f"at end {result['machine']['loadavg_end'][0]:.2f} ({os.cpu_count()} CPUs)")
    if not args.no_save:
        RESULTS.mkdir(exist_ok=True)
        (RESULTS / "surface.json").write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {RESULTS / 'surface.json'}")
    return result


if __name__ == "__main__":
    main()
