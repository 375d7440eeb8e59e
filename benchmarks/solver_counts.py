#!/usr/bin/env python
"""What the solver's shortcuts save: Newton iterations, step cuts, line searches and LU work.

    python benchmarks/solver_counts.py             # coarse mesh, the tests' problems (~15 s)
    python benchmarks/solver_counts.py --mesh medium

These counts depend on the floating-point path (BLAS, SuperLU, CPU): the tests check that
each shortcut takes its path and leaves the answer unchanged, and this script measures
what it saves, against the bar the tests once asserted. Each case is the problem of the
test named beside it (sphere R = 6.22 mm, coarse mesh unless ``--mesh``):

======================  ==========================================================  ======================
case                    problem and count                                           bar (test)
======================  ==========================================================  ======================
refactorise-hint        neo-Hooke 8 kPa, 0.45, 100 points to 0.6 mm: LU            hinted < 0.9x, and
                        applications (preconditioner + solves) and factorisations   factorisations <= +3
                        with ``solver.REFACTORISE_AFTER_CONTACT_CHANGES`` and       (test_mechanics::
                        without (10**9)                                             ..._factorised_at_once)
hertz-start             8 geometric depths 0.006-0.6 mm: Newton iterations of the   Hertz <= 4 < zero
                        first increment from Hertz's shape and from a zero field    (test_mechanics::
                        (full Newton, linear predictor)                             test_hertz_start_...)
half-space              neo-Hooke 10 kPa, 0.4, 100 points: step cuts, Newton        0 cuts, < 8 per
                        iterations per increment                                    increment (test_
                                                                                    newton_statistics_...)
rigid-base-layer        1 mm neo-Hooke layer on a rigid base, 100 points to 0.6 mm  0 < cuts <= 6; 0 cuts
                        (60 % compressed): step cuts; and 60 uniform steps solved   (test_layers::..._keeps
                        directly                                                    _the_depth_step_...)
surface-fit             the same curve without ``predictor.SurfaceFit`` (the        < 0.7x the iterations,
                        contact zone not kept against the sphere)                   fewer cuts (test_layers
                                                                                    ::test_keeping_...)
friction                linear elastic 10 kPa, 0.3, h/R = 0.01, 8 loading and 8    < 3x the iterations
                        unloading steps, mu = 0.1 and 10 against mu = 0             (test_friction)
adhesion                linear elastic 10 kPa, 0.45, h/R = 0.01, load, unload and   < 3x the iterations
                        0.02 mm above; w = 5 mJ/m^2, range 0.1 and 0.0075 mm        (test_adhesion)
adhesion-short          neo-Hooke 8 kPa, 0.45, 10 loading and 10 unloading steps    0 cuts, < 100 line-
                        to 0.1 mm, w = 5 mJ/m^2, range 0.01 mm (mu_T = 1.16)         search evaluations
                                                                                    (test_adhesion)
======================  ==========================================================  ======================

Wall times are printed beside the counts (one run each; ``effects.py`` and ``forward.py``
time the default mesh properly). Results go to stdout and to
``benchmarks/results/solver_counts.json`` (kept out of git).
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as _dt
import os
import platform
import time
from pathlib import Path

import numpy as np

from _bench import HERE, ROOT, write_results  # noqa: E402,F401  (makes skin_indent importable from a checkout)

import skin_indent.mechanics.solver as solver_module  # noqa: E402
from skin_indent.mechanics import IndentationProblem, LinearElastic, NeoHooke, SphericalIndenter  # noqa: E402
from skin_indent.mechanics.contact_law import ContactLaw  # noqa: E402
from skin_indent.mechanics.layers import RIGID, Layer, LayeredSample  # noqa: E402
from skin_indent.mechanics.linear import TangentSolver  # noqa: E402
from skin_indent.mechanics.mesh import graded_mesh  # noqa: E402
from skin_indent.mechanics.predictor import SurfaceFit  # noqa: E402
from skin_indent.mechanics.protocol import Protocol  # noqa: E402
from skin_indent.simulate import simulate  # noqa: E402

R = 6.22
H_SMALL = 0.01 * R  # h/R = 0.01: the small-strain protocols of the friction and adhesion tests
RESULTS = HERE / "results"


@contextlib.contextmanager
def patched(obj, name, value):
    """``obj.name = value`` for the duration of the block."""
    old = getattr(obj, name)
    setattr(obj, name, value)
    try:
        yield
    finally:
        setattr(obj, name, old)


@contextlib.contextmanager
def counting_lu():
    """Counts the applications of a stored LU factorisation (``TangentSolver._apply_lu``)."""
    count = [0]
    apply_lu = TangentSolver._apply_lu

    def counted(self, b):
        count[0] += 1
        return apply_lu(self, b)

    with patched(TangentSolver, "_apply_lu", counted):
        yield count


def stats(curve, wall_s: float) -> dict:
    r = curve.report
    return {"increments": r.increments, "newton_iterations": r.total_iterations,
            "per_increment": round(r.mean_iterations, 3), "step_cuts": r.step_cuts,
            "line_search_evaluations": r.line_search_backtracks, "factorisations": r.factorisations,
            "wall_s": round(wall_s, 3)}


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def refactorise_hint(mesh: str) -> dict:
    out = {}
    threshold = solver_module.REFACTORISE_AFTER_CONTACT_CHANGES
    for label, value in (("hinted", threshold), ("plain", 10**9)):
        with patched(solver_module, "REFACTORISE_AFTER_CONTACT_CHANGES", value), counting_lu() as count:
            curve, wall = timed(lambda: simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6, 100, mesh=mesh))
        out[label] = {**stats(curve, wall), "lu_applications": count[0]}
    h, p = out["hinted"], out["plain"]
    out["bar"] = "hinted LU applications < 0.9x plain, factorisations <= plain + 3"
    out["met"] = bool(h["lu_applications"] < 0.9 * p["lu_applications"]
                      and h["factorisations"] <= p["factorisations"] + 3)
    out["line"] = (f"LU applications {h['lu_applications']} vs {p['lu_applications']} "
                   f"({h['lu_applications'] / p['lu_applications']:.2f}x), factorisations {h['factorisations']} vs "
                   f"{p['factorisations']}")
    return out


def hertz_start(mesh: str) -> dict:
    law, ind, d = NeoHooke(8.0, 0.45), SphericalIndenter(R), np.geomspace(0.006, 0.6, 8)
    imesh = graded_mesh(R, 0.6, mesh)
    (_, _, rep), wall = timed(lambda: IndentationProblem(imesh, law, ind, 0.6).solve(d))
    (_, _, zero), wall0 = timed(lambda: IndentationProblem(imesh, law, ind, 0.6, modified_below=0.0).solve(
        d, predictor="linear"))
    first, first0 = rep.iterations[0], zero.iterations[0]
    return {"hertz": {"first_increment": first, "newton_iterations": rep.total_iterations,
                      "modified_steps": rep.modified_steps, "wall_s": round(wall, 3)},
            "zero": {"first_increment": first0, "newton_iterations": zero.total_iterations,
                     "modified_steps": zero.modified_steps, "wall_s": round(wall0, 3)},
            "bar": "first increment: Hertz <= 4 < zero field", "met": bool(first <= 4 < first0),
            "line": f"first increment {first} vs {first0} Newton iterations; "
                    f"whole curve {rep.total_iterations} vs {zero.total_iterations}"}


def half_space(mesh: str) -> dict:
    curve, wall = timed(lambda: simulate(NeoHooke(10.0, 0.4), SphericalIndenter(R), 0.6, 100, mesh=mesh))
    s = stats(curve, wall)
    return {"curve": s, "bar": "0 step cuts, < 8 Newton iterations per increment",
            "met": bool(s["step_cuts"] == 0 and s["per_increment"] < 8),
            "line": f"{s['step_cuts']} step cuts, {s['per_increment']:.2f} Newton iterations per increment"}


def rigid_base_layer(mesh: str) -> tuple[dict, dict]:
    sample = LayeredSample((Layer(1.0, NeoHooke(8.0, 0.45)),), RIGID)
    fitted, wall = timed(lambda: simulate(sample, SphericalIndenter(R), 0.6, 100, mesh=mesh))
    steps, wall_steps = timed(lambda: simulate(sample, SphericalIndenter(R), np.linspace(0.01, 0.6, 60), mesh=mesh,
                                               solve_at_outputs=True))
    with patched(SurfaceFit, "__call__", lambda self, trial, u, depth, new_depth: trial):
        plain, wall_plain = timed(lambda: simulate(sample, SphericalIndenter(R), 0.6, 100, mesh=mesh))
    f, s, p = stats(fitted, wall), stats(steps, wall_steps), stats(plain, wall_plain)
    layer = {"curve": f, "uniform_steps": s, "bar": "0 < step cuts <= 6; 0 with 60 uniform steps",
             "met": bool(0 < f["step_cuts"] <= 6 and s["step_cuts"] == 0),
             "line": f"{f['step_cuts']} step cuts ({f['increments']} increments); 60 uniform steps: "
                     f"{s['step_cuts']} cuts"}
    fit = {"fitted": f, "plain": p, "bar": "< 0.7x the Newton iterations and fewer step cuts without the fit",
           "met": bool(f["newton_iterations"] < 0.7 * p["newton_iterations"] and f["step_cuts"] < p["step_cuts"]),
           "line": f"{f['newton_iterations']} vs {p['newton_iterations']} Newton iterations "
                   f"({f['newton_iterations'] / p['newton_iterations']:.2f}x), {f['step_cuts']} vs {p['step_cuts']} "
                   f"step cuts, {f['factorisations']} vs {p['factorisations']} factorisations"}
    return layer, fit


def _ratios(runs: dict, base_key, label: str) -> tuple[dict, bool, str]:
    """Newton iterations of each run over the base run's: ({case: ratio}, all below 3x, a line)."""
    base = runs[base_key]["newton_iterations"]
    ratios = {k: v["newton_iterations"] / base for k, v in runs.items() if k != base_key}
    line = ", ".join(f"{label} {k}: {runs[k]['newton_iterations']} ({r:.2f}x)" for k, r in ratios.items())
    return ({str(k): round(r, 3) for k, r in ratios.items()}, all(r < 3.0 for r in ratios.values()),
            f"Newton iterations {line}, against {base}")


def friction(mesh: str) -> dict:
    prot = Protocol.ramp(H_SMALL, 8, 0.01, unload=True)
    runs = {}
    for mu in (0.0, 0.1, 10.0):
        curve, wall = timed(lambda: simulate(LinearElastic(10.0, 0.3), SphericalIndenter(R), protocol=prot, mesh=mesh,
                                             contact=ContactLaw(friction=mu) if mu else None))
        runs[mu] = stats(curve, wall)
    ratios, met, line = _ratios(runs, 0.0, "mu")
    return {"runs": {str(k): v for k, v in runs.items()}, "ratios": ratios,
            "bar": "friction < 3x the frictionless Newton iterations", "met": met, "line": line}


def adhesion(mesh: str) -> dict:
    d = np.r_[H_SMALL * np.arange(1, 9) / 8, H_SMALL * np.arange(7, -1, -1) / 8, -0.0025 * np.arange(1, 9)]
    prot = Protocol(np.arange(d.size, dtype=float), d)
    runs = {}
    for delta in (None, 0.1, 0.0075):
        contact = None if delta is None else ContactLaw(adhesion_mJ_per_m2=5.0, adhesion_range_mm=delta)
        curve, wall = timed(lambda: simulate(LinearElastic(10.0, 0.45), SphericalIndenter(R), protocol=prot,
                                             mesh=mesh, contact=contact))
        runs[delta] = stats(curve, wall)
    ratios, met, line = _ratios(runs, None, "range")
    return {"runs": {str(k): v for k, v in runs.items()}, "ratios": ratios,
            "bar": "adhesion < 3x the non-adhesive Newton iterations", "met": met, "line": line}


def adhesion_short(mesh: str) -> dict:
    prot = Protocol.ramp(0.1, 10, 0.02, unload=True)
    curve, wall = timed(lambda: simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), protocol=prot, mesh=mesh,
                                         contact=ContactLaw(adhesion_mJ_per_m2=5.0, adhesion_range_mm=0.01)))
    s = stats(curve, wall)
    return {"curve": s, "bar": "0 step cuts, < 100 line-search evaluations (before the fix: 3, 331)",
            "met": bool(s["step_cuts"] == 0 and s["line_search_evaluations"] < 100),
            "line": f"{s['step_cuts']} step cuts, {s['line_search_evaluations']} line-search evaluations"}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mesh", default="coarse", help="mesh family member (default: coarse, the tests' mesh)")
    parser.add_argument("--output", type=Path, default=RESULTS / "solver_counts.json", help="JSON output file")
    args = parser.parse_args(argv)
    results = {"date": _dt.datetime.now().isoformat(timespec="seconds"),
               "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                           "loadavg_start": os.getloadavg()},
               "mesh": args.mesh, "cases": {}}
    print(f"solver counts, {results['date']}, mesh {args.mesh}, load average {os.getloadavg()[0]:.2f}", flush=True)
    layer, fit = rigid_base_layer(args.mesh)
    cases = {"refactorise-hint": lambda: refactorise_hint(args.mesh), "hertz-start": lambda: hertz_start(args.mesh),
             "half-space": lambda: half_space(args.mesh), "rigid-base-layer": lambda: layer,
             "surface-fit": lambda: fit, "friction": lambda: friction(args.mesh),
             "adhesion": lambda: adhesion(args.mesh), "adhesion-short": lambda: adhesion_short(args.mesh)}
    for name, case in cases.items():
        row = case()
        results["cases"][name] = row
        print(f"  {name:<17} {'met    ' if row['met'] else 'NOT met'}  {row['line']}  [bar: {row['bar']}]",
              flush=True)
    results["machine"]["loadavg_end"] = os.getloadavg()
    write_results(results, args.output)
    return results


if __name__ == "__main__":
    main()
