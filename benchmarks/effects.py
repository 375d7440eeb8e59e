#!/usr/bin/env python
"""Cost of each physical effect of the forward model against the base neo-Hookean model.

    python benchmarks/effects.py              # default mesh (medium), 3 repetitions, ~4 min on 2 cores
    python benchmarks/effects.py --quick      # coarse mesh, 1 repetition (~1 min)

The speed bar of issue 15 (issue #4 had 3x): each effect's forward curve costs at
most 2x the base model on the same mesh (protocol-driven effects: per time step). Problem: sphere R = 6.22 mm,
E = 8 kPa, nu = 0.45, a 0.6 mm loading curve with 100 output points. Cases:

========================  ==========================================================
base                      ``simulate(NeoHooke(8, 0.45), R, 0.6, 100)`` (default: 12
                          solved increments, the 100 forces interpolated)
layer-halfspace           1 mm top layer over a half-space 0.3 times as stiff
layer-rigid               1 mm top layer over a rigid base
stiffening                E = 6 kPa, C20 = 12 kPa
viscoelastic              g1 = 0.4, tau1 = 5 s; ramp at 0.02 mm/s to 0.6 mm (100
                          steps) and back (100 steps)
friction-0.1, friction-1  Coulomb friction mu = 0.1 and 1; the loading ramp (100 steps)
adhesion-20               w = 20 mJ/m^2 (default range 0.06 mm, Tabor mu_T = 0.49);
                          loading and unloading ramps (200 steps)
adhesion-20-short         w = 20 mJ/m^2, range 0.02 mm (mu_T = 1.46)
base-ramp, base-ramp-lu   the base model solved at every step of the loading ramp and
                          of the load-unload ramp (the frictionless, non-adhesive
                          reference on the same protocol)
========================  ==========================================================

Every repetition runs all cases one after the other (base first), so a change of
machine load hits neighbours alike; the ratios are computed per repetition against
that repetition's base run and the median over repetitions is reported. Columns:

* ``curve``: wall time of the whole curve / the base curve (the bar for path-independent
  effects; history-dependent ones solve every protocol step and cannot match 12
  interpolated increments);
* ``step``: wall time per solved increment / the base model's per increment (the bar
  for history-dependent effects: viscoelastic, and friction and adhesion, which need a
  protocol);
* ``same protocol``: wall time / the base model solved on the same protocol.

Results go to stdout and to ``benchmarks/results/effects.json`` (kept out of git).
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from _bench import HERE, ROOT, write_results  # noqa: E402,F401  (makes skin_indent importable from a checkout)

from skin_indent.effects import Model  # noqa: E402
from skin_indent.mechanics.contact_law import ContactLaw  # noqa: E402
from skin_indent.mechanics.protocol import Protocol  # noqa: E402

RADIUS_MM = 6.22
DEPTH_MM = 0.6
POINTS = 100
E_KPA, NU = 8.0, 0.45
SPEED_MM_PER_S = 0.02
RESULTS = HERE / "results"
#: The bar of issue 15: an effect costs at most this many times the base model (issue #4: 3x).
BAR = 2.0


def cases() -> dict:
    """{name: (model, theta, simulate keyword arguments, reference case on the same protocol)}."""
    base = {"E_kPa": E_KPA, "nu": NU}
    ramp = Protocol.ramp(DEPTH_MM, POINTS, SPEED_MM_PER_S)
    ramp_lu = Protocol.ramp(DEPTH_MM, POINTS, SPEED_MM_PER_S, unload=True)
    curve = {"depth_mm": DEPTH_MM, "points": POINTS}
    m0 = Model((), RADIUS_MM)
    return {
        "base": (m0, base, curve, None),
        "layer-halfspace": (Model(("layer",), RADIUS_MM), {**base, "thickness_mm": 1.0, "ratio": 0.3}, curve, "base"),
        "layer-rigid": (Model(("layer",), RADIUS_MM), {**base, "thickness_mm": 1.0, "ratio": math.inf}, curve, "base"),
        "stiffening": (Model(("stiffening",), RADIUS_MM), {"E_kPa": 6.0, "nu": NU, "C20_kPa": 12.0}, curve, "base"),
        "base-ramp": (m0, base, {"protocol": ramp}, None),
        "base-ramp-lu": (m0, base, {"protocol": ramp_lu}, None),
        "viscoelastic": (Model(("viscoelastic",), RADIUS_MM), {**base, "g1": 0.4, "tau1_s": 5.0},
                         {"protocol": ramp_lu}, "base-ramp-lu"),
        "friction-0.1": (m0, base, {"protocol": ramp, "contact": ContactLaw(friction=0.1)}, "base-ramp"),
        "friction-1": (m0, base, {"protocol": ramp, "contact": ContactLaw(friction=1.0)}, "base-ramp"),
        "adhesion-20": (m0, base, {"protocol": ramp_lu, "contact": ContactLaw(adhesion_mJ_per_m2=20.0)},
                        "base-ramp-lu"),
        "adhesion-20-short": (m0, base, {"protocol": ramp_lu,
                                         "contact": ContactLaw(adhesion_mJ_per_m2=20.0, adhesion_range_mm=0.02)},
                              "base-ramp-lu"),
    }


def run(model, theta, kwargs, mesh) -> dict:
    """One timed forward curve: wall time (s) and Newton statistics, or the error."""
    t0 = time.perf_counter()
    try:
        curve = model.simulate(theta, mesh=mesh, **kwargs)
    except Exception as exc:  # a failed case is a result too
        return {"ok": False, "wall_s": time.perf_counter() - t0, "error": f"{type(exc).__name__}: {exc}"}
    wall = time.perf_counter() - t0
    r = curve.report
    return {"ok": True, "wall_s": wall, "increments": r.increments, "newton_iterations": r.total_iterations,
            "step_cuts": r.step_cuts, "line_search_evaluations": r.line_search_backtracks,
            "factorisations": getattr(r, "factorisations", None),
            "max_force_mN": float(np.max(curve.force_mN)), "min_force_mN": float(np.min(curve.force_mN))}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description="Cost of each effect against the base model (issue 15 speed bar).")
    parser.add_argument("--mesh", default="medium", help="mesh family member (default: medium, the default mesh)")
    parser.add_argument("--repeats", type=int, default=3, help="repetitions of the whole set (median; default 3)")
    parser.add_argument("--quick", action="store_true", help="coarse mesh, one repetition")
    parser.add_argument("--only", nargs="*", help="run only these cases (base and the references are added)")
    parser.add_argument("--output", type=Path, default=RESULTS / "effects.json", help="JSON output file")
    args = parser.parse_args(argv)
    mesh, repeats = ("coarse", 1) if args.quick else (args.mesh, args.repeats)

    all_cases = cases()
    names = list(all_cases)
    if args.only:
        wanted = set(args.only) | {"base"} | {all_cases[n][3] for n in args.only if all_cases[n][3]}
        names = [n for n in names if n in wanted]
    results = {
        "date": _dt.datetime.now().isoformat(timespec="seconds"),
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "loadavg_start": os.getloadavg()},
        "problem": {"E_kPa": E_KPA, "nu": NU, "radius_mm": RADIUS_MM, "depth_mm": DEPTH_MM, "points": POINTS,
                    "speed_mm_per_s": SPEED_MM_PER_S, "mesh": mesh, "repeats": repeats},
        "runs": {n: [] for n in names},
    }
    print(f"effects benchmark, {results['date']}, mesh {mesh}, {repeats} repetition(s), "
          f"load average {results['machine']['loadavg_start'][0]:.2f}", flush=True)
    for rep in range(repeats):
        for n in names:
            model, theta, kwargs, _ = all_cases[n]
            out = run(model, theta, kwargs, mesh)
            results["runs"][n].append(out)
            status = f"{out['wall_s']:.2f} s" if out["ok"] else f"FAILED after {out['wall_s']:.1f} s: {out['error']}"
            print(f"  [{rep + 1}/{repeats}] {n:<18} {status}", flush=True)

    summary = {}
    base_runs = results["runs"]["base"]
    for n in names:
        runs, ref = results["runs"][n], all_cases[n][3]
        ok = [i for i, r in enumerate(runs) if r["ok"]]
        if not ok:
            summary[n] = {"ok": False, "error": runs[0]["error"]}
            continue
        r0 = runs[ok[0]]  # deterministic statistics: the same in every repetition
        curve = [runs[i]["wall_s"] / base_runs[i]["wall_s"] for i in ok]
        step = [(runs[i]["wall_s"] / runs[i]["increments"]) / (base_runs[i]["wall_s"] / base_runs[i]["increments"])
                for i in ok]
        row = {"ok": len(ok) == len(runs), "wall_s_median": statistics.median(runs[i]["wall_s"] for i in ok),
               "ratio_curve": statistics.median(curve), "ratio_step": statistics.median(step),
               **{k: r0[k] for k in ("increments", "newton_iterations", "step_cuts", "line_search_evaluations",
                                     "max_force_mN", "min_force_mN")}}
        if ref is not None and ref in results["runs"]:
            same = [runs[i]["wall_s"] / results["runs"][ref][i]["wall_s"] for i in ok if results["runs"][ref][i]["ok"]]
            row["reference"] = ref
            row["ratio_same_protocol"] = statistics.median(same) if same else None
        history = "protocol" in all_cases[n][2]
        row["bar_measure"] = "step" if history else "curve"
        row["meets_bar"] = bool(row["ok"] and row["ratio_" + row["bar_measure"]] <= BAR)
        summary[n] = row
    results["summary"] = summary
    results["machine"]["loadavg_end"] = os.getloadavg()

    print(f"\nratios to the base model ({mesh} mesh, medians of {repeats}; bar {BAR:g}x on the marked column)")
    head = (f"{'case':<18} {'time/s':>7} {'curve':>7} {'step':>7} {'same prot.':>10} {'incr':>5} {'newton':>6} "
            f"{'it/inc':>6} {'cuts':>4} {'LS':>5}  bar")
    print(head)
    print("-" * len(head))
    for n, row in summary.items():
        if not row.get("wall_s_median"):
            print(f"{n:<18} FAILED: {row['error']}")
            continue
        mark = {"curve": "", "step": ""}
        mark[row["bar_measure"]] = "*"
        same = row.get("ratio_same_protocol")
        same_txt = f"{same:.2f}x" if same is not None else "-"
        print(f"{n:<18} {row['wall_s_median']:7.2f} {row['ratio_curve']:6.2f}{mark['curve'] or 'x'} "
              f"{row['ratio_step']:6.2f}{mark['step'] or 'x'} {same_txt:>10} {row['increments']:5d} "
              f"{row['newton_iterations']:6d} {row['newton_iterations'] / row['increments']:6.2f} "
              f"{row['step_cuts']:4d} {row['line_search_evaluations']:5d}  "
              f"{'met' if row['meets_bar'] else 'NOT met'}")
    print("(* = the column the bar applies to: curve for path-independent effects, per step for protocols)")

    write_results(results, args.output)
    return results


if __name__ == "__main__":
    main()
