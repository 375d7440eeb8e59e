#!/usr/bin/env python
"""BLAS thread oversubscription under load: default thread pools against the limits of
``skin_indent.runtime.threads`` (issue 15).

    python benchmarks/threads.py               # ~2-3 min on 2 cores (3 repeats)
    python benchmarks/threads.py --repeats 1   # ~1 min
    python benchmarks/threads.py --quiet-too   # also without the background load

Cases, each timed in a fresh Python process (so that the thread settings are those of a
process start), alternately in the two modes, median of ``--repeats``:

(a) ``chiaro``: the Chiaro AFM curve (tests/data/real-data/chiaro_AEBP1_R27.5um.csv,
    13827 samples, R = 0.0275 mm): the contact-point scan
    (:func:`skin_indent.measurement.find_contact_point`) and the fit path
    (:func:`skin_indent.fitting.fit`, nu fixed at 0.499) on the coarse
    unit-radius surface, built once beforehand in ``benchmarks/results/cache``.
(b) ``build``: a small response surface from scratch, 3 nu x 20 depths on the coarse mesh
    with 2 local worker processes (:meth:`ResponseSurface.build`).

Modes: ``default`` has no ``*_NUM_THREADS`` variable and ``SKIN_INDENT_THREADS=off``
(every process with a full BLAS pool: the behaviour before the limits);
``limited`` calls :func:`skin_indent.runtime.threads.configure_threads` first, as the CLI
does, and the executors give their workers one thread each.

Load: while the cases run, ``--burners`` processes (default: one per CPU) spin in a
Python loop, each ending by itself after ``--load-seconds`` at the latest, and killed
at the end. Results are printed (times and the ratios default / limited) and written
to ``benchmarks/results/threads.json``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _bench import HERE, ROOT, write_results

from skin_indent.runtime.threads import SETTING_ENV, THREAD_ENV_VARS

CHIARO = ROOT / "tests" / "data" / "real-data" / "chiaro_AEBP1_R27.5um.csv"
CHIARO_R_MM = 0.0275
CACHE = HERE / "results" / "cache"
MODES = ("default", "limited")

BURN = "import time\nend = time.time() + {seconds}\nwhile time.time() < end:\n    pass\n"


def _unit_surface(cache: Path, workers: int = 2):
    try:
        from skin_indent.fitting import unit_surface_grid
    except ImportError:  # the layout before skin_indent.fitting
        from skin_indent.fitting import unit_surface_grid
    from skin_indent.response_surface import ResponseSurface, default_settings

    settings = {**default_settings(1.0, mesh="coarse"), "code_version": "bench-threads"}
    return ResponseSurface.load_or_build(unit_surface_grid(0.5), settings, cache_dir=cache, workers=workers,
                                         progress=False)


def case_chiaro(cache: Path) -> dict:
    t0 = time.perf_counter()
    try:
        from skin_indent.fitting import fit as fit_curve
    except ImportError:  # the layout before skin_indent.fitting
        from skin_indent.fitting import fit as fit_curve
    from skin_indent.measurement import find_contact_point, load_csv

    surface = _unit_surface(cache, workers=1)  # cached: loads
    m = load_csv(CHIARO, radius_mm=CHIARO_R_MM)
    t1 = time.perf_counter()
    cp = find_contact_point(m)
    t2 = time.perf_counter()
    fit = fit_curve(m, surface, fixed={"nu": 0.499}, radius_mm=CHIARO_R_MM)
    t3 = time.perf_counter()
    assert fit.success and abs(cp.depth_mm - 0.0725) < 0.002
    return {"contact_scan_s": t2 - t1, "fit_s": t3 - t2, "scan_plus_fit_s": t3 - t1, "setup_s": t1 - t0,
            "E_star_kPa": fit.e_star_kPa}


def case_build(cache: Path) -> dict:
    import numpy as np

    from skin_indent.response_surface import ResponseSurface, SurfaceGrid, default_settings

    grid = SurfaceGrid(np.linspace(0.03, 0.6, 20), np.geomspace(1, 100, 4), [0.2, 0.35, 0.49])
    settings = {**default_settings(mesh="coarse"), "code_version": "bench-threads"}
    with tempfile.TemporaryDirectory() as tmp:  # from scratch every time
        t0 = time.perf_counter()
        s = ResponseSurface.build(grid, settings=settings, cache_dir=tmp, workers=2, progress=False)
        t1 = time.perf_counter()
    assert s.complete
    return {"build_s": t1 - t0, "runs": 3}


CASES = {"chiaro": case_chiaro, "build": case_build}
PRIMARY = {"chiaro": ("contact_scan_s", "fit_s", "scan_plus_fit_s"), "build": ("build_s",)}


def child(case: str, mode: str, cache: Path) -> None:
    """One timed case in this (fresh) process; prints one JSON line."""
    if mode == "limited":
        from skin_indent.runtime.threads import configure_threads

        configure_threads()
    import threadpoolctl

    out = CASES[case](cache)
    out["blas_threads_main"] = sorted({i["num_threads"] for i in threadpoolctl.threadpool_info()})
    print(json.dumps(out))


def mode_env(mode: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in (*THREAD_ENV_VARS, SETTING_ENV)}
    if mode == "default":
        env[SETTING_ENV] = "off"
    return env


def run_child(case: str, mode: str, cache: Path) -> dict:
    p = subprocess.run([sys.executable, __file__, "--child", case, mode, "--cache", str(cache)], capture_output=True,
                       text=True, env=mode_env(mode), timeout=900)
    if p.returncode:
        raise RuntimeError(f"{case}/{mode} failed:\n{p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


class Load:
    """``n`` CPU-burning processes, each ending by itself after ``seconds``; killed on exit."""

    def __init__(self, n: int, seconds: float):
        self.n, self.seconds, self.procs = n, seconds, []

    def __enter__(self):
        code = BURN.format(seconds=self.seconds)
        self.procs = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(self.n)]
        time.sleep(0.5)
        return self

    def __exit__(self, *exc):
        for p in self.procs:
            if p.poll() is None:
                p.kill()
            p.wait()
        self.procs = []


def measure(cases, repeats: int, cache: Path) -> dict:
    results = {}
    for case in cases:
        samples = {mode: [] for mode in MODES}
        for r in range(repeats):
            for mode in (MODES if r % 2 == 0 else MODES[::-1]):  # alternate the order
                samples[mode].append(run_child(case, mode, cache))
                print(f"  {case:7s} {mode:8s} " + ", ".join(f"{k} {samples[mode][-1][k]:.3g}" for k in PRIMARY[case]),
                      flush=True)
        entry = {}
        for key in PRIMARY[case]:
            med = {mode: statistics.median(s[key] for s in samples[mode]) for mode in MODES}
            entry[key] = {**{f"{m}_s": med[m] for m in MODES}, "ratio": med["default"] / med["limited"]}
        entry["blas_threads_main"] = {m: samples[m][-1]["blas_threads_main"] for m in MODES}
        entry["samples"] = samples
        results[case] = entry
    return results


def print_table(title: str, results: dict) -> None:
    print(f"\n{title}")
    print(f"{'case':28s} {'default s':>10s} {'limited s':>10s} {'ratio':>7s}")
    for case, entry in results.items():
        for key in PRIMARY[case]:
            e = entry[key]
            print(f"{case + ' ' + key:28s} {e['default_s']:10.3f} {e['limited_s']:10.3f} {e['ratio']:7.1f}x")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES))
    ap.add_argument("--burners", type=int, default=os.cpu_count() or 2, help="CPU-burning processes (load)")
    ap.add_argument("--load-seconds", type=float, default=900, help="upper bound on the life of each burner")
    ap.add_argument("--quiet-too", action="store_true", help="also measure without the background load")
    ap.add_argument("--cache", type=Path, default=CACHE, help="where the Chiaro case's surface is cached")
    ap.add_argument("--child", nargs=2, metavar=("CASE", "MODE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(*args.child, args.cache)
        return 0

    print(f"unit surface for the Chiaro case (cached in {args.cache}) ...", flush=True)
    _unit_surface(args.cache)
    out = {"date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"), "machine": {
        "cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform()},
        "repeats": args.repeats, "burners": args.burners, "load_avg_start": os.getloadavg()}
    print(f"\nunder load ({args.burners} burning processes):", flush=True)
    with Load(args.burners, args.load_seconds):
        out["loaded"] = measure(args.cases, args.repeats, args.cache)
    if args.quiet_too:
        print("\nwithout added load:", flush=True)
        out["quiet"] = measure(args.cases, args.repeats, args.cache)
    out["load_avg_end"] = os.getloadavg()
    print_table(f"Under load ({args.burners} burners), median of {args.repeats}: ratio = default / limited",
                out["loaded"])
    if args.quiet_too:
        print_table("Without added load", out["quiet"])
    print(f"\nload averages: start {out['load_avg_start']}, end {out['load_avg_end']}")
    write_results(out, HERE / "results" / "threads.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
