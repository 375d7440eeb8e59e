#!/usr/bin/env python
"""Many diagnoses at a time (issue 29): a synthetic force map diagnosed on local processes and on Dask.

    python benchmarks/diagnose_batch.py                 # a 10 x 10 map (100 curves), surfaces only, 1 rung
    python benchmarks/diagnose_batch.py --side 6        # 36 curves
    python benchmarks/diagnose_batch.py --max-rungs 3 --in-loop   # the full diagnosis of every curve (hours)

The map (R = 6.22 mm, 100 points to 0.6 mm at 0.02 mm/s, noise 0.05 mN, coarse-mesh forward curves,
written as one HDF5 force map of afmformats by tests/_maps.py): a neo-Hookean background whose E
runs from 5 to 8 kPa across the map; a disk in the middle with a bonded top layer (1 mm, 25 kPa,
over a base of 4 kPa: ``layer``); a corner with strain stiffening (C20 = 12 kPa: ``stiffening``);
the top row with its contact 0.02 mm past the first sample (``offset``).

Measured, in turn, after a warm-up that fills the cache (one curve of each region, diagnosed alone):

1. the unit: one 100-point forward curve on the default mesh, in this process (median of 3), so that
   the figures hold on any machine;
2. the map on ``--workers`` local processes (:func:`skin_indent.diagnosis.diagnose_many`): wall time,
   per curve, in units;
3. the same map on a Dask LocalCluster of ``--workers`` worker processes: wall time, and whether its
   table equals that of local processes (every cell but the provenance lines);
4. ``--alone`` curves diagnosed alone (:func:`skin_indent.diagnosis.diagnose`): their verdicts equal
   the batch's;
5. the verdicts against the truth of each region.

Writes benchmarks/results/diagnose_batch.json, the table (diagnose_batch.tsv) and the figures
(diagnose_batch_plots/: verdicts.png and the map).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from _bench import HERE, ROOT, write_results  # noqa: E402

sys.path.insert(0, str(ROOT / "tests"))  # the force-map writer the tests use
from _maps import write_force_map  # noqa: E402

R_MM, DEPTH_MM, POINTS, NOISE_MN = 6.22, 0.6, 100, 0.05


def truth(i: int, j: int, n: int) -> str:
    """The hidden effect at grid point (i, j) of an n x n map."""
    if (i - (n - 1) / 2) ** 2 + (j - (n - 1) / 2) ** 2 <= (n / 4.5) ** 2:
        return "layer"
    if i < n // 4 and j < n // 4:
        return "stiffening"
    if j == n - 1:
        return "offset"
    return "none"


def curve(kind: str, E_kPa: float, seed: int):
    """Depth (mm), force (mN), time (s) of one map point."""
    import numpy as np

    from skin_indent.effects import Model

    depth = np.linspace(0.0, DEPTH_MM, POINTS)
    contact = 0.02 if kind == "offset" else 0.0
    h = depth - contact
    touching = h > 1e-9
    if kind == "layer":
        model, theta = Model(("layer",), R_MM), {"E_kPa": 25.0, "nu": 0.45, "thickness_mm": 1.0, "ratio": 4.0 / 25}
    elif kind == "stiffening":
        model, theta = Model(("stiffening",), R_MM), {"E_kPa": E_kPa, "nu": 0.45, "C20_kPa": 12.0}
    else:
        model, theta = Model((), R_MM), {"E_kPa": E_kPa, "nu": 0.45}
    force = np.zeros(POINTS)
    force[touching] = model.simulate(theta, h[touching], mesh="coarse").force_mN
    force += np.random.default_rng(seed).normal(0.0, NOISE_MN, POINTS)
    return depth, force, depth / 0.02


def make_map(path: Path, n: int) -> list[str]:
    kinds, curves = [], []
    for k in range(n * n):
        i, j = k % n, k // n
        kinds.append(truth(i, j, n))
        curves.append(curve(kinds[-1], 5.0 + 3.0 * i / max(n - 1, 1), seed=1000 + k))
    write_force_map(path, curves, nx=n, pitch_mm=0.5)
    return kinds


def unit_time() -> float:
    from skin_indent import NeoHooke, SphericalIndenter, simulate

    times = []
    for _ in range(3):
        t = time.perf_counter()
        simulate(NeoHooke(E_kPa=10.0, nu=0.4), SphericalIndenter(radius_mm=R_MM), depth_mm=DEPTH_MM, points=100)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def table_lines(path: Path) -> list[str]:
    return [line for line in path.read_text().splitlines() if not line.startswith("#")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument("--side", type=int, default=10, help="map of SIDE x SIDE curves (default 10)")
    parser.add_argument("--workers", type=int, default=2, help="local processes and Dask workers (default 2)")
    parser.add_argument("--max-rungs", type=int, default=1)
    parser.add_argument("--in-loop", action="store_true", help="finite elements in the loop (default: surfaces only)")
    parser.add_argument("--alone", type=int, default=4, help="curves also diagnosed alone (default 4)")
    parser.add_argument("--no-dask", action="store_true")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "skin_indent_bench_diagnose_batch")
    args = parser.parse_args()

    from skin_indent.diagnosis import diagnose, diagnose_many
    from skin_indent.measurement import load_curve
    from skin_indent.report.batch_table import write_tsv
    from skin_indent.report.verdict_map import write_batch_figures
    from skin_indent.runtime.context import Context

    settings = {"max_rungs": args.max_rungs, "in_loop": args.in_loop, "mesh": "coarse"}
    result = {"date": _dt.datetime.now().isoformat(timespec="seconds"), "cpus": os.cpu_count(),
              "load_start": os.getloadavg(), "side": args.side, "settings": settings, "workers": args.workers}
    work = Path(tempfile.mkdtemp(prefix="diagnose_batch_"))
    path = work / "map.h5"
    t = time.perf_counter()
    kinds = make_map(path, args.side)
    result["map_written_s"] = time.perf_counter() - t
    n = len(kinds)
    print(f"map of {n} curves written in {result['map_written_s']:.1f} s: "
          + ", ".join(f"{k} {kinds.count(k)}" for k in sorted(set(kinds))))

    # warm-up: one curve of each region fills the cache (surfaces); not timed
    firsts = [kinds.index(k) for k in sorted(set(kinds))]
    t = time.perf_counter()
    for k in firsts:
        diagnose(load_curve(path, radius_mm=R_MM, index=k), context=Context(cache_dir=args.cache,
                                                                             workers=args.workers), **settings)
    result["warm_up_s"] = time.perf_counter() - t
    print(f"warm-up (cache filled, {len(firsts)} curves alone): {result['warm_up_s']:.1f} s")

    unit = unit_time()
    result["unit_s"] = unit
    print(f"unit: one 100-point forward curve on the default mesh: {unit:.3f} s")

    t = time.perf_counter()
    local = diagnose_many(path, radius_mm=R_MM, context=Context(cache_dir=args.cache, workers=args.workers),
                          progress=False, **settings)
    wall = time.perf_counter() - t
    result["local"] = {"wall_s": wall, "per_curve_s": wall / n, "units": wall / unit, "units_per_curve": wall / n / unit,
                       "failed": local.n_failed, "verdicts": local.verdicts()}
    print(f"{args.workers} local processes: {wall:.1f} s ({wall / n:.2f} s = {wall / n / unit:.1f} units per curve), "
          f"verdicts {local.verdicts()}")
    out_tsv = write_tsv(local, HERE / "results" / "diagnose_batch.tsv")
    figures = write_batch_figures(local, HERE / "results" / "diagnose_batch_plots")
    result["figures"] = [str(p) for p in figures]

    if not args.no_dask:
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster, Client(cluster, set_as_default=False) as client:
            t = time.perf_counter()
            on_dask = diagnose_many(path, radius_mm=R_MM, context=Context(cache_dir=args.cache, client=client),
                                    progress=False, **settings)
            wall = time.perf_counter() - t
        dask_tsv = write_tsv(on_dask, work / "dask.tsv")
        same = table_lines(dask_tsv) == table_lines(out_tsv)
        result["dask"] = {"wall_s": wall, "per_curve_s": wall / n, "units": wall / unit, "same_table": same}
        print(f"Dask LocalCluster of {args.workers} workers: {wall:.1f} s ({wall / n:.2f} s per curve); "
              f"table {'equal to' if same else 'DIFFERENT from'} the local processes'")

    step = max(1, n // max(args.alone, 1))
    alone = {}
    for k in list(range(0, n, step))[:args.alone]:
        d = diagnose(load_curve(path, radius_mm=R_MM, index=k), context=Context(cache_dir=args.cache, workers=1),
                     **settings)
        alone[k] = (d.verdict, local[k].verdict)
    result["alone"] = {str(k): {"alone": a, "batch": b} for k, (a, b) in alone.items()}
    print("diagnosed alone: " + ", ".join(f"[{k}] {a}{' = ' if a == b else ' != '}{b}" for k, (a, b) in alone.items()))

    confusion: dict = {}  # by grid position: afmformats lists an HDF5 file's curves in the text order of their keys
    for row in local:
        kind = truth(row.grid_x, row.grid_y, args.side)
        confusion.setdefault(kind, {}).setdefault(row.outcome, 0)
        confusion[kind][row.outcome] += 1
    result["truth_vs_verdict"] = confusion
    print("truth -> verdicts: " + "; ".join(f"{k}: {v}" for k, v in confusion.items()))
    result["load_end"] = os.getloadavg()
    write_results(result, HERE / "results" / "diagnose_batch.json")


if __name__ == "__main__":
    main()
