#!/usr/bin/env python
"""Start-up time: imports of each subpackage and the CLI's time to its first line (issue 15).

    python benchmarks/startup.py             # ~2-3 min (+ one surface build the first time)
    python benchmarks/startup.py --repeats 3
    python benchmarks/startup.py --src /tmp/before/src --out before.json   # another source tree

(``--src``: e.g. ``git archive HEAD src | tar -x -C /tmp/before`` to measure the last commit.)

Every figure is measured in a fresh Python process (median of ``--repeats``, default 5),
from just before the process starts:

* imports: ``python -c "import X"`` for the interpreter alone, numpy, scipy, the CLI
  module and each subpackage; the process's whole wall time, and its CPU time
  (user + system, less sensitive to other jobs on the machine);
* commands (``python -m skin_indent ...``, unbuffered output): the wall time to the
  first line of output and to the end, for ``--version``, ``simulate --points 10
  --mesh coarse`` and ``fit`` on the bundled forearm-like CSV with a cached surface
  (``SKIN_INDENT_CACHE`` pointing to ``--cache``, filled once beforehand by the same
  command; it is a medium-mesh unit surface, built in minutes the first time); then,
  on the same cached surface, ``fit`` of a 200,000-row CSV (a Hertz-like curve with
  noise, as ``tests/test_fuzz.py`` loads: it once asserted < 30 s) and ``demo
  --no-diagnosis`` (whose second run ``tests/test_identify.py`` once required to take
  < 2 s and < half the first, which builds the surface: ~10 s).

The target is <= 0.4 s from Python start to the first line of ``fit`` or ``simulate``.
Results are printed as a table and written to ``benchmarks/results/startup.json``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _bench import HERE, ROOT, write_results

FIT_CSV = ROOT / "src" / "skin_indent" / "data" / "forearm_like.csv"
CACHE = HERE / "results" / "cache-startup"
HUGE_ROWS = 200_000

IMPORTS = ["pass", "import numpy", "import scipy", "import skin_indent", "import skin_indent.cli",
           "from skin_indent.cli import build_parser; build_parser()",
           *[f"import skin_indent.{name}" for name in (
               "measurement", "inverse", "response_surface", "analytic", "protocol", "plotting", "models",
               "fitting", "simulate", "mechanics", "effects", "diagnosis",
               "identify", "fit_recorded", "diagnose")]]  # the last three: names before the 0.2 layout


def huge_csv(path: Path, rows: int | None = None) -> Path:
    """A ``rows``-row approach curve to 0.6 mm (time, depth, force: Hertz at 12.5 kPa, nu = 0.35, R = 6.22 mm,
    with 0.02 mN noise), the size of ``tests/test_fuzz.py``'s huge file."""
    import numpy as np

    from skin_indent.mechanics.analytic import hertz_force

    rows = rows or HUGE_ROWS
    h = np.linspace(0.01, 0.6, rows)
    force = hertz_force(h, 12.5, 0.35, 6.22) + np.random.default_rng(1).normal(0.0, 0.02, rows)
    np.savetxt(path, np.column_stack([np.arange(rows) * 1e-3, h, force]), delimiter=",",
               header="time_s,depth_mm,force_mN", comments="", fmt="%.17g")
    return path


def timed(cmd: list[str], env: dict, cwd: str, ok=(0,)) -> dict | None:
    """Run ``cmd``; wall time to its first stdout line and to its end, and its CPU time.

    None if its exit status is not in ``ok`` (a module that does not exist in this tree).
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=cwd)
    first = p.stdout.readline()
    t_first = time.perf_counter() - t0
    rest, err = p.communicate(timeout=900)
    t_end = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode not in ok:
        return None
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"first_line_s": t_first if first else None, "end_s": t_end, "cpu_s": cpu,
            "first_line": first.decode().rstrip()}


def median_of(cmd, env, cwd, repeats, ok=(0,)) -> dict | None:
    samples = [timed(cmd, env, cwd, ok) for _ in range(repeats)]
    if any(s is None for s in samples):
        return None
    out = {key: statistics.median(s[key] for s in samples) for key in ("end_s", "cpu_s")}
    firsts = [s["first_line_s"] for s in samples if s["first_line_s"] is not None]
    out["first_line_s"] = statistics.median(firsts) if firsts else None
    out["first_line"] = samples[-1]["first_line"]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cache", type=Path, default=CACHE, help="SKIN_INDENT_CACHE for the fit command (kept)")
    ap.add_argument("--src", type=Path, default=None, help="import skin_indent from this folder (PYTHONPATH)")
    ap.add_argument("--out", default="startup.json", help="file name in benchmarks/results/")
    args = ap.parse_args(argv)

    env = {**os.environ, "PYTHONUNBUFFERED": "1", "SKIN_INDENT_CACHE": str(args.cache)}
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    if args.src is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(args.src.resolve()), *filter(None, [env.get("PYTHONPATH")])])
    cwd = str(ROOT)
    py = sys.executable
    args.cache.mkdir(parents=True, exist_ok=True)
    fit_cmd = [py, "-m", "skin_indent", "fit", str(FIT_CSV)]
    print(f"filling the surface cache {args.cache} once (fit {FIT_CSV.name}, demo) ...", flush=True)
    t = time.perf_counter()
    subprocess.run(fit_cmd, env=env, cwd=cwd, check=True, capture_output=True, timeout=3600)
    with tempfile.TemporaryDirectory() as tmp:  # the same surface; should it ever differ, it is built here
        subprocess.run([py, "-m", "skin_indent", "demo", "--no-diagnosis", "--out", tmp], env=env, cwd=cwd,
                       check=True, capture_output=True, timeout=3600)
    print(f"  {time.perf_counter() - t:.1f} s", flush=True)

    out = {"date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
           "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                       "platform": platform.platform()},
           "src": str(args.src or ROOT / "src"), "repeats": args.repeats, "load_avg_start": os.getloadavg(),
           "imports": {}, "commands": {}}
    print(f"\n{'imports (python -c ...)':58s} {'wall s':>7s} {'cpu s':>7s}")
    for code in IMPORTS:
        r = median_of([py, "-c", code], env, cwd, args.repeats)
        if r is None:
            continue  # not in this source tree
        out["imports"][code] = {"wall_s": r["end_s"], "cpu_s": r["cpu_s"]}
        print(f"{code[:58]:58s} {r['end_s']:7.3f} {r['cpu_s']:7.3f}", flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        commands = {
            "--version": [py, "-m", "skin_indent", "--version"],
            "simulate --points 10 --mesh coarse": [py, "-m", "skin_indent", "simulate", "--points", "10",
                                                   "--mesh", "coarse", "--out", str(Path(tmp) / "curve.csv")],
            f"fit {FIT_CSV.name} (cached surface)": fit_cmd,
            f"fit {HUGE_ROWS}-row CSV (cached surface)": [py, "-m", "skin_indent", "fit",
                                                          str(huge_csv(Path(tmp) / "huge.csv"))],
            "demo --no-diagnosis (cached surface)": [py, "-m", "skin_indent", "demo", "--no-diagnosis",
                                                     "--out", str(Path(tmp) / "demo")],
        }
        print(f"\n{'command (python -m skin_indent ...)':44s} {'1st line s':>10s} {'end s':>7s} {'cpu s':>7s}")
        for name, cmd in commands.items():
            r = median_of(cmd, env, cwd, args.repeats, ok=(0, 1))  # fit: 1 if the fit did not converge
            if r is None:
                raise RuntimeError(f"{' '.join(cmd)} failed")
            out["commands"][name] = r
            first = "-" if r["first_line_s"] is None else f"{r['first_line_s']:.3f}"
            print(f"{name[:44]:44s} {first:>10s} {r['end_s']:7.3f} {r['cpu_s']:7.3f}   | {r['first_line'][:50]}",
                  flush=True)
    out["load_avg_end"] = os.getloadavg()
    print(f"\nload averages: start {out['load_avg_start']}, end {out['load_avg_end']}")
    write_results(out, HERE / "results" / args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
