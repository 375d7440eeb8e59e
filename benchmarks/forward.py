#!/usr/bin/env python
"""Speed and accuracy of the forward model, and a side-by-side run of FElupe.

    python benchmarks/forward.py            # full run (~4-6 min on 2 cores)
    python benchmarks/forward.py --quick    # coarse mesh only, no refinement, no FElupe
    git archive <commit> src | tar -x -C /tmp/before    # an older version to compare with
    python benchmarks/forward.py --baseline-src /tmp/before/src

Problem: rigid sphere R = 6.22 mm into a neo-Hookean half-space, E = 8 kPa, nu = 0.45,
100 output depths to 0.6 mm (``simulate(..., 0.6, 100)``, default settings).

For each mesh of the family (coarse, medium, fine) it prints the size (P2 nodes =
vertices + edges, dofs), the wall time of one 100-point curve (median of 3 runs, mesh
generation included), Newton statistics, F(0.6 mm) and the error against the FElupe
reference curve ``tests/data/reference/neo-hooke_halfspace_E8kPa_nu0.45.csv`` (our
model solved at the reference depths, max relative error over h >= 0.1 mm and
h >= 0.05 mm). It also measures the Python start + import time once (a subprocess
``python -c "import skin_indent.simulate"``), the observed order of convergence of
F(0.6 mm) under uniform refinement of the coarse mesh, and, when FElupe is installed,
the FElupe model of ``benchmarks/felupe_reference.py`` on the same problem in the same
run (time ratio FElupe / our medium mesh).

The speed section (issue 15's problem: E = 10 kPa, nu = 0.4, medium mesh) reports for
one curve, in a fresh process, Newton iterations per increment, line-search
evaluations, LU factorisations, preconditioned solves and the time split from cProfile
(assembly, contact, linear solves, predictor, set-up, Python overhead); with
``--baseline-src`` the same for an older checkout, in turn (3 rounds, medians). Then
whole processes (Python start, imports, one curve): ours, the baseline's and FElupe's
(``felupe_reference.run_felupe``, its import included), in turn, and their ratios.

Results go to stdout and to ``benchmarks/results/forward.json`` (kept out of git).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import inspect
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from _bench import HERE, ROOT, write_results  # noqa: E402,F401  (makes skin_indent importable from a checkout)

from skin_indent.mechanics import IndentationMesh, NeoHooke, SphericalIndenter, graded_mesh  # noqa: E402
import skin_indent  # noqa: E402
from skin_indent.simulate import simulate  # noqa: E402

sys.path.insert(0, str(HERE))
import felupe_reference  # noqa: E402

RADIUS_MM = 6.22
DEPTH_MM = 0.6
POINTS = 100
E_KPA, NU = 8.0, 0.45
REFERENCE_CSV = ROOT / "tests" / "data" / "reference" / "neo-hooke_halfspace_E8kPa_nu0.45.csv"
RESULTS = HERE / "results"
#: Targets of the project brief.
TARGET_SECONDS = 2.0
TARGET_SPEEDUP = 8.0
#: The problem of the speed targets of issue 15 (the breakdown and the whole-process runs).
SPEED_E_KPA, SPEED_NU = 10.0, 0.4
TARGET_WHOLE_PROCESS_SPEEDUP = 15.0


def _versions() -> dict:
    import scipy
    import skfem

    out = {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
           "scikit-fem": skfem.__version__}
    try:
        import felupe

        out["felupe"] = felupe.__version__
    except ImportError:
        out["felupe"] = None
    return out


def import_time() -> dict:
    """Wall time of a fresh ``python -c "import skin_indent.simulate"`` (and of ``python -c pass``)."""
    env = dict(os.environ)
    src = str(Path(skin_indent.__file__).resolve().parents[1])
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    out = {}
    for key, code in (("python_start_s", "pass"), ("python_start_and_import_s", "import skin_indent.simulate")):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        out[key] = time.perf_counter() - t
    return out


def mesh_size(imesh: IndentationMesh) -> dict:
    v = imesh.n_vertices
    e = imesh.mesh.facets.shape[1]
    return {"vertices": v, "edges": e, "triangles": imesh.n_elements, "p2_nodes": v + e, "dofs": 2 * (v + e),
            "surface_size_mm": imesh.surface_size_mm, "extent_mm": imesh.extent_mm}


def reference() -> tuple[np.ndarray, np.ndarray]:
    ref = np.loadtxt(REFERENCE_CSV, delimiter=",", skiprows=1)
    keep = ref[:, 0] > 0
    return ref[keep, 0], ref[keep, 1]


def errors(depth, force, ref_depth, ref_force) -> dict:
    """Relative errors against the reference at the same depths."""
    rel = force / ref_force - 1.0
    out = {"at_0.6mm": float(rel[-1])}
    for hmin in (0.1, 0.05):
        m = ref_depth >= hmin - 1e-9
        out[f"max_abs_h>={hmin}"] = float(np.max(np.abs(rel[m])))
    return out


def newton_stats(report) -> dict:
    out = {"increments": report.increments, "newton_iterations": report.total_iterations,
           "mean_iterations": report.mean_iterations, "step_cuts": report.step_cuts,
           "line_search_evaluations": report.line_search_backtracks,
           "max_penetration_ratio": report.max_penetration_ratio}
    for key in ("tangents", "modified_steps", "factorisations", "preconditioned_solves"):  # newer reports only
        if hasattr(report, key):
            out[key] = getattr(report, key)
    return out


#: Where the time of one curve goes: cProfile cumulative time of these functions, as
#: (module, function name); absent ones count 0, so older versions of the code are measured alike.
TIME_BUCKETS = {
    "assembly": (("axisymmetric", "forces"), ("axisymmetric", "tangent"), ("axisymmetric", "assemble")),
    "contact": (("contact", "forces"), ("contact", "state")),
    "linear solves": (("linear", "solve"),),
    "predictor": (("predictor", "__call__"), ("predictor", "__init__")),
    "set-up (mesh, problem)": (("mesh", "graded_mesh"), ("solver", "__init__")),
}


def breakdown(E_kPa: float = SPEED_E_KPA, nu: float = SPEED_NU, mesh: str = "medium") -> dict:
    """Newton, linear-algebra and time figures of one default 100-point curve (the issue's problem).

    The time split comes from cProfile (which slows the run by ~10%): assembly =
    residual and tangent of the solid plus the sparse scatter; contact; linear solves
    (factorisations and preconditioned Krylov solves); predictor; set-up; the rest of
    the profiled time is Python overhead (Newton loop, line search, vector algebra).
    Works on the code of this checkout or of an older one (``--breakdown-json``).
    """
    import cProfile
    import pstats

    material, indenter = NeoHooke(E_kPa=E_kPa, nu=nu), SphericalIndenter(RADIUS_MM)
    simulate(material, indenter, DEPTH_MM, POINTS, mesh="coarse")  # warm-up (lazy imports)
    t = time.perf_counter()
    curve = simulate(material, indenter, DEPTH_MM, POINTS, mesh=mesh, keep_state=True)
    wall = time.perf_counter() - t
    problem = curve._state[0]
    solver = problem.linear_solver
    prof = cProfile.Profile()
    prof.enable()
    simulate(material, indenter, DEPTH_MM, POINTS, mesh=mesh)
    prof.disable()
    stats = pstats.Stats(prof).stats
    total = max(ct for (_, _, name), (_, _, _, ct, _) in stats.items() if name == "simulate")
    # a name matched twice in one module (TangentSolver.solve calls the factors' solve) is
    # nested: count its outermost (largest cumulative) entry only
    largest = {}
    for (fname, _, func), (_, _, _, ct, _) in stats.items():
        key = (Path(fname).stem, func)
        if "skin_indent" in fname:
            largest[key] = max(largest.get(key, 0.0), ct)
    split = {bucket: sum(largest.get(key, 0.0) for key in keys) for bucket, keys in TIME_BUCKETS.items()}
    split["python overhead"] = total - sum(split.values())
    rep = curve.report
    return {
        "E_kPa": E_kPa, "nu": nu, "mesh": mesh, "wall_s": wall, "profiled_s": total,
        **newton_stats(rep),
        "factorisations": solver.factorisations, "preconditioned_solves": solver.cg_solves,
        "preconditioner_applications": getattr(solver, "preconditioner_applications", None),
        "time_split_s": split, "time_split_fraction": {k: v / total for k, v in split.items()},
        "force_0.6mm_mN": float(curve.force_mN[-1]),
    }


def _breakdown_in(src: Path | None) -> dict:
    """:func:`breakdown` in a fresh process, with ``src`` (an older checkout's ``src``) first on the path."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--breakdown-json"], env=env,
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


OURS_WHOLE_PROCESS = ("from skin_indent.simulate import simulate; from skin_indent.mechanics import NeoHooke, "
                      "SphericalIndenter; simulate(NeoHooke({E}, {nu}), SphericalIndenter({R}), {d}, {n})")
FELUPE_WHOLE_PROCESS = ("import sys; sys.path.insert(0, {here!r}); import felupe_reference as f; "
                        "f.run_felupe({E}, {nu}, {d}, {n})")


def whole_process(pairs: int = 3, E_kPa: float = SPEED_E_KPA, nu: float = SPEED_NU,
                  baseline_src: Path | None = None) -> dict:
    """Wall time of whole processes (Python start, imports, one 100-point curve).

    Ours, then (with ``baseline_src``) the older checkout's, then FElupe's, ``pairs``
    times in turn; ratios of the medians and medians of the per-round ratios. Both source
    trees are byte-compiled first (as an installed package is, and FElupe is), so that no
    side pays for compiling its modules (``PYTHONDONTWRITEBYTECODE`` would otherwise make
    a checkout compile them in every process).
    """
    fmt = dict(E=E_kPa, nu=nu, R=RADIUS_MM, d=DEPTH_MM, n=POINTS, here=str(HERE))
    for src in (ROOT / "src", baseline_src):
        if src is not None:
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(src)], check=True,
                           stdout=subprocess.DEVNULL)

    def run(code, src=None):
        env = dict(os.environ)
        if src is not None:
            env["PYTHONPATH"] = str(src) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", code.format(**fmt)], env=env, check=True)
        return time.perf_counter() - t

    times = {"ours": [], "baseline": [], "felupe": []}
    for _ in range(pairs):
        times["ours"].append(run(OURS_WHOLE_PROCESS))
        if baseline_src is not None:
            times["baseline"].append(run(OURS_WHOLE_PROCESS, baseline_src))
        times["felupe"].append(run(FELUPE_WHOLE_PROCESS))
    out = {f"{k}_s": v for k, v in times.items() if v}
    med = {k: statistics.median(v) for k, v in times.items() if v}
    out.update({f"{k}_median_s": v for k, v in med.items()})
    out["felupe_over_ours"] = med["felupe"] / med["ours"]
    out["felupe_over_ours_per_round_median"] = statistics.median(
        [f / o for f, o in zip(times["felupe"], times["ours"])])
    if times["baseline"]:
        out["felupe_over_baseline"] = med["felupe"] / med["baseline"]
        out["baseline_over_ours"] = med["baseline"] / med["ours"]
    return out


def print_breakdown(label: str, b: dict) -> None:
    frac = b["time_split_fraction"]
    split = ", ".join(f"{k} {v:.2f} s ({100 * frac[k]:.0f} %)" for k, v in b["time_split_s"].items())
    apps = b.get("preconditioner_applications")
    print(f"  {label}: {b['wall_s']:.2f} s in process; {b['increments']} increments, {b['newton_iterations']} Newton "
          f"iterations ({b['mean_iterations']:.2f} per increment), {b['line_search_evaluations']} line-search "
          f"evaluations, {b['factorisations']} LU factorisations, {b['preconditioned_solves']} preconditioned solves"
          + (f" ({apps} LU applications)" if apps is not None else "")
          + (f", {b['tangents']} tangents + {b['modified_steps']} modified-Newton steps" if "tangents" in b else ""))
    print(f"    profiled {b['profiled_s']:.2f} s: {split}")


def bench_mesh(name: str, repeats: int, material, indenter, ref) -> dict:
    imesh = graded_mesh(RADIUS_MM, DEPTH_MM, name)
    walls, solves, curve = [], [], None
    for _ in range(repeats):
        t = time.perf_counter()
        curve = simulate(material, indenter, DEPTH_MM, POINTS, mesh=name)
        walls.append(time.perf_counter() - t)
        solves.append(curve.report.wall_time_s)
    ref_depth, ref_force = ref
    at_ref = simulate(material, indenter, ref_depth, mesh=name)
    return {
        "mesh": curve.mesh_name,
        **mesh_size(imesh),
        "wall_s_runs": walls,
        "wall_s_median": statistics.median(walls),
        "wall_s_min": min(walls),
        "solve_s_median": statistics.median(solves),
        **newton_stats(curve.report),
        "force_0.6mm_mN": float(curve.force_mN[-1]),
        "error_vs_reference": errors(ref_depth, at_ref.force_mN, ref_depth, ref_force),
    }


def refinement_study(material, indenter, levels: int = 2) -> dict:
    """F(0.6 mm) on the coarse mesh refined uniformly 0, 1, ..., ``levels`` times (each triangle split in 4).

    The observed order of each consecutive triple is p = log2((F1 - F2) / (F2 - F3)):
    only defined when the differences have the same sign (asymptotic regime).
    """
    base = graded_mesh(RADIUS_MM, DEPTH_MM, "coarse")
    meshes = [base]
    for k in range(1, levels + 1):
        m = meshes[-1].mesh.refined(1)
        if not m.boundaries or not {"axis", "top", "bottom", "outer"} <= set(m.boundaries):
            raise RuntimeError("uniform refinement lost the named boundaries")
        meshes.append(IndentationMesh(m, f"coarse refined uniformly x{k}", base.contact_radius_mm,
                                      base.surface_size_mm / 2**k, base.extent_mm))
    rows = []
    for im in meshes:
        t = time.perf_counter()
        c = simulate(material, indenter, DEPTH_MM, POINTS, mesh=im)
        rows.append({"mesh": im.name, **mesh_size(im), "force_0.6mm_mN": float(c.force_mN[-1]),
                     "wall_s": time.perf_counter() - t, "newton_iterations": c.report.total_iterations})
    F = [r["force_0.6mm_mN"] for r in rows]
    triples = []
    for f1, f2, f3 in zip(F, F[1:], F[2:]):
        ratio = (f1 - f2) / (f2 - f3) if f2 != f3 else float("inf")
        p = math.log2(ratio) if ratio > 0 and math.isfinite(ratio) else float("nan")
        extrapolated = f3 + (f3 - f2) / (2**p - 1) if math.isfinite(p) and p > 0 else float("nan")
        triples.append({"F1-F2": f1 - f2, "F2-F3": f2 - f3, "ratio": ratio, "observed_order": p,
                        "richardson_F_mN": extrapolated})
    return {"meshes": rows, "triples": triples, **(triples[0] if triples else {})}


def bench_felupe(ref, felupe_tol: float) -> dict:
    depth, force, seconds, info = felupe_reference.run_felupe(E_KPA, NU, DEPTH_MM, POINTS, tol=felupe_tol)
    ref_depth, ref_force = ref
    # FElupe solves at 0.006 k, the reference at 0.6 k / 99: compare at 0.6 mm and, in
    # between, with F / h^1.5 interpolated linearly (smooth, ~Hertz constant)
    ratio = np.interp(ref_depth, depth, force / depth**1.5)
    return {"wall_s": seconds, "force_0.6mm_mN": float(force[-1]), "tol": felupe_tol, **info,
            "error_vs_reference": errors(ref_depth, ratio * ref_depth**1.5, ref_depth, ref_force)}


def _time_default_medium(material, indenter) -> float:
    t = time.perf_counter()
    simulate(material, indenter, DEPTH_MM, POINTS, mesh="medium")
    return time.perf_counter() - t


def _at_every_depth() -> dict:
    """Keyword of :func:`simulate` that solves equilibrium at every output depth."""
    if "solve_at_outputs" in inspect.signature(simulate).parameters:
        return {"solve_at_outputs": True}
    return {"increments": POINTS}  # older signature: increments = points solves at the outputs


def _pct(x: float) -> str:
    return f"{100 * x:+.3f} %"


def speed_section(results: dict, args) -> None:
    """Issue 15's figures: breakdown of one curve (E = 10 kPa, nu = 0.4, medium mesh), before and
    after when ``--baseline-src`` is given (fresh processes, in turn, medians of 3), and whole
    processes against FElupe."""
    print(f"\nspeed (issue 15): E = {SPEED_E_KPA:g} kPa, nu = {SPEED_NU:g}, {POINTS} points to {DEPTH_MM} mm, "
          f"medium mesh; breakdown of one curve in a fresh process (3 rounds, median wall time)")
    runs = {"ours": []}
    if args.baseline_src is not None:
        runs["baseline"] = []
    for _ in range(3):
        for key in runs:
            runs[key].append(_breakdown_in(args.baseline_src if key == "baseline" else None))
    speed = {}
    for key, rs in runs.items():
        walls = [r["wall_s"] for r in rs]
        speed[key] = {"wall_s_runs": walls, "wall_s_median": statistics.median(walls), "last": rs[-1]}
        print_breakdown(f"{key} (median {statistics.median(walls):.2f} s of {', '.join(f'{w:.2f}' for w in walls)})",
                        rs[-1])
    if "baseline" in speed:
        speed["baseline_over_ours"] = statistics.median(
            [b["wall_s"] / o["wall_s"] for b, o in zip(runs["baseline"], runs["ours"])])
        print(f"  in-process time, baseline / ours: {speed['baseline_over_ours']:.2f}x (median of the rounds)")
    if args.whole_process_rounds > 0:
        try:
            felupe_reference._import_felupe()
        except ImportError as err:
            print(f"  whole processes against FElupe skipped: {err}")
        else:
            wp = whole_process(args.whole_process_rounds, baseline_src=args.baseline_src)
            speed["whole_process"] = wp
            print(f"  whole processes (start, imports, one curve; {args.whole_process_rounds} rounds): ours "
                  f"{wp['ours_median_s']:.2f} s, FElupe {wp['felupe_median_s']:.2f} s: {wp['felupe_over_ours']:.1f}x "
                  f"(per-round median {wp['felupe_over_ours_per_round_median']:.1f}x; target "
                  f">= {TARGET_WHOLE_PROCESS_SPEEDUP:g}x)"
                  + (f"; baseline {wp['baseline_median_s']:.2f} s: {wp['felupe_over_baseline']:.1f}x"
                     if "baseline_median_s" in wp else ""))
    results["speed"] = speed


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description="Forward-model benchmark (speed, accuracy, FElupe side by side).")
    parser.add_argument("--quick", action="store_true", help="coarse mesh only; no refinement study, no FElupe")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per mesh (median reported; default 3)")
    parser.add_argument("--felupe-tol", type=float, default=felupe_reference.TOL,
                        help=f"FElupe Newton tolerance (default {felupe_reference.TOL:g}, as the reference curves)")
    parser.add_argument("--refine-levels", type=int, default=2,
                        help="uniform refinements of the coarse mesh (default 2; 3 takes ~6 min and ~2 GB)")
    parser.add_argument("--output", type=Path, default=RESULTS / "forward.json", help="JSON output file")
    parser.add_argument("--baseline-src", type=Path, default=None,
                        help="the src/ directory of an older checkout (e.g. from `git archive`): its breakdown "
                             "and whole-process time are measured in turn with ours, as 'before'")
    parser.add_argument("--whole-process-rounds", type=int, default=3,
                        help="rounds of whole-process runs (ours, baseline, FElupe) for the ratio; 0 skips them")
    parser.add_argument("--breakdown-json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.breakdown_json:  # internal: one breakdown of the importable skin_indent, as JSON on stdout
        print(json.dumps(breakdown(), default=float))
        return {}

    material, indenter = NeoHooke(E_kPa=E_KPA, nu=NU), SphericalIndenter(RADIUS_MM)
    ref = reference()
    results = {
        "date": _dt.datetime.now().isoformat(timespec="seconds"),
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()},
        "versions": _versions(),
        "problem": {"E_kPa": E_KPA, "nu": NU, "radius_mm": RADIUS_MM, "depth_mm": DEPTH_MM, "points": POINTS},
        "quick": args.quick,
    }
    print(f"forward-model benchmark, {results['date']}, {os.cpu_count()} cpus, "
          f"load average {results['machine']['loadavg_start'][0]:.2f}")

    results["import"] = import_time()
    print(f"python start: {results['import']['python_start_s']:.2f} s; "
          f"python start + import skin_indent.simulate: {results['import']['python_start_and_import_s']:.2f} s")

    names = ["coarse"] if args.quick else ["coarse", "medium", "fine"]
    results["meshes"] = {}
    head = (f"{'mesh':<7} {'nodes':>6} {'dofs':>6} {'time/s':>7} {'min/s':>6} {'solve/s':>7} {'incr':>4} {'newton':>6} "
            f"{'it/inc':>6} {'LS':>4} {'F(0.6)/mN':>10} {'err@0.6':>9} {'max h>=.1':>9} {'max h>=.05':>10}")
    print(f"\n{POINTS}-point curve to {DEPTH_MM} mm, E = {E_KPA} kPa, nu = {NU} (time: median and min of "
          f"{args.repeats} runs, mesh generation included; solve: Newton only, median)")
    print(head)
    for name in names:
        r = bench_mesh(name, args.repeats, material, indenter, ref)
        results["meshes"][name] = r
        e = r["error_vs_reference"]
        print(f"{name:<7} {r['p2_nodes']:>6} {r['dofs']:>6} {r['wall_s_median']:>7.2f} {r['wall_s_min']:>6.2f} "
              f"{r['solve_s_median']:>7.2f} "
              f"{r['increments']:>4} {r['newton_iterations']:>6} {r['mean_iterations']:>6.2f} "
              f"{r['line_search_evaluations']:>4} {r['force_0.6mm_mN']:>10.5f} {_pct(e['at_0.6mm']):>9} "
              f"{100 * e['max_abs_h>=0.1']:>7.3f} % {100 * e['max_abs_h>=0.05']:>8.3f} %")
    print(f"reference F(0.6 mm) = {ref[1][-1]:.5f} mN (FElupe, 1000 mm domain; ours is {graded_mesh(RADIUS_MM, DEPTH_MM).extent_mm:.0f} mm)")

    if not args.quick:
        print("\nuniform refinement of the coarse mesh (F at 0.6 mm):")
        st = refinement_study(material, indenter, args.refine_levels)
        results["refinement"] = st
        for k, r in enumerate(st["meshes"]):
            label = "coarse" if k == 0 else f"coarse refined uniformly x{k}"
            print(f"  {label:<28} {r['p2_nodes']:>6} nodes {r['dofs']:>6} dofs  F = {r['force_0.6mm_mN']:.9f} mN "
                  f"({r['wall_s']:.1f} s)")
        for k, tr in enumerate(st["triples"]):
            print(f"  meshes {k},{k + 1},{k + 2}: F1-F2 = {tr['F1-F2']:+.3e} mN, F2-F3 = {tr['F2-F3']:+.3e} mN, "
                  f"ratio {tr['ratio']:.3g}, observed order p = log2(ratio) = {tr['observed_order']:.2f}"
                  + (f", Richardson F = {tr['richardson_F_mN']:.6f} mN" if math.isfinite(tr["richardson_F_mN"]) else
                     " (differences change sign: not in the asymptotic regime)"))

        medium = results["meshes"]["medium"]["wall_s_median"]
        t = time.perf_counter()
        c100 = simulate(material, indenter, DEPTH_MM, POINTS, mesh="medium", **_at_every_depth())
        results["medium_100_increments"] = {"wall_s": time.perf_counter() - t, **newton_stats(c100.report),
                                            "force_0.6mm_mN": float(c100.force_mN[-1])}
        m100 = results["medium_100_increments"]
        print(f"\nmedium mesh solved at all {POINTS} output depths ({_at_every_depth()}, as FElupe below): "
              f"{m100['wall_s']:.2f} s, {m100['newton_iterations']} Newton iterations "
              f"({m100['mean_iterations']:.2f} per increment), F(0.6) = {m100['force_0.6mm_mN']:.5f} mN")
        try:
            felupe_reference._import_felupe()
        except ImportError as err:
            print(f"\nFElupe side by side skipped: {err}")
            results["felupe"] = None
        else:
            # the machine is shared: time our default run right before and right after
            # FElupe as well, so that a change of load hits both sides of the ratio
            adjacent = [_time_default_medium(material, indenter)]
            fe = bench_felupe(ref, args.felupe_tol)
            adjacent.append(_time_default_medium(material, indenter))
            fe["medium_adjacent_s"] = adjacent
            fe["ratio_to_medium"] = fe["wall_s"] / statistics.mean(adjacent)
            fe["ratio_to_medium_table"] = fe["wall_s"] / medium
            fe["ratio_to_medium_100_increments"] = fe["wall_s"] / m100["wall_s"]
            results["felupe"] = fe
            e = fe["error_vs_reference"]
            print(f"\nFElupe {fe['felupe_version']} (benchmarks/felupe_reference.py): {fe['n_nodes']} nodes, "
                  f"{fe['n_dofs']} dofs, 9-node quads, h0 = {fe['surface_size_mm']:.3g} mm, tol {fe['tol']:g}")
            print(f"  {fe['increments']} increments, {fe['newton_iterations']} Newton iterations "
                  f"({fe['mean_iterations']:.2f} per increment), {fe['wall_s']:.2f} s, "
                  f"F(0.6) = {fe['force_0.6mm_mN']:.5f} mN ({_pct(e['at_0.6mm'])} vs reference, "
                  f"max {100 * e['max_abs_h>=0.1']:.3f} % over h >= 0.1 mm)")
            print(f"  ours (medium, default) right before / after FElupe: {adjacent[0]:.2f} s / {adjacent[1]:.2f} s")
            print(f"  time FElupe / ours (medium, default {results['meshes']['medium']['increments']} increments): "
                  f"{fe['ratio_to_medium']:.1f}x (adjacent runs; {fe['ratio_to_medium_table']:.1f}x against the table's "
                  f"median); / ours (medium, solved at all {POINTS} depths): {fe['ratio_to_medium_100_increments']:.1f}x")

        ok_time = medium <= TARGET_SECONDS
        print(f"\ntargets: <= {TARGET_SECONDS:g} s per curve on the default mesh: {medium:.2f} s "
              f"({'met' if ok_time else 'NOT met'})", end="")
        if results.get("felupe"):
            ok_speed = results["felupe"]["ratio_to_medium"] >= TARGET_SPEEDUP
            print(f"; >= {TARGET_SPEEDUP:g}x faster than FElupe: {results['felupe']['ratio_to_medium']:.1f}x "
                  f"({'met' if ok_speed else 'NOT met'})")
        else:
            print()

    if not args.quick:
        speed_section(results, args)
    results["machine"]["loadavg_end"] = os.getloadavg()
    write_results(results, args.output)
    return results


if __name__ == "__main__":
    main()
