"""The paper's blind tests (Delalleau et al. 2006, Tables 1 and 2) on any force model.

A synthetic "measurement" is the model itself at the true parameters (noise-free,
100 depths 0.006-0.6 mm, as the paper's blind tests used all points); each method
starts from the paper's initial values and must land back on the truth.

Acceptance bands
----------------
``ekf-paper``: ``|dE| <= 0.1 kPa`` and ``|dnu| <= 0.005`` (the paper's own scatter).
``ekf``, ``lsq``: ``|dE|/E <= 0.1%`` and ``|dnu| <= 0.002``, entered within 10 sweeps
(ekf) or 10 function evaluations (lsq; >= iterations), and still inside at the end.
All methods must also report convergence (``status > 0``).

Run from the command line (any importable model factory)::

    python -m skin_indent.inverse.blind_tests --model analytic_model:HertzLikeModel
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import sys
import time
from collections.abc import Mapping, Sequence

import numpy as np

from .kalman import fit_ekf
from .kalman_paper import fit_ekf_paper
from .least_squares import fit_least_squares

__all__ = ["PAPER_TABLE_1", "PAPER_TABLE_2", "blind_test_cases", "run_blind_tests", "format_table", "main"]

#: Table 1: truth E = 31 kPa, nu = 0.4, C = 1e-6; starts, sweeps, found E, found nu.
PAPER_TABLE_1 = {
    "truth": (31.0, 0.4),
    "starts": [(10, 0.3), (70, 0.3), (10, 0.45), (70, 0.45), (50, 0.2), (10, 0.2), (70, 0.2)],
    "sweeps": [235, 237, 187, 185, 309, 301, 309],
    "E": [31.02, 31.02, 30.98, 30.98, 31.02, 31.02, 30.98],
    "nu": [0.399, 0.399, 0.4, 0.4, 0.399, 0.399, 0.399],
}
#: Table 2: start E = 30 kPa, nu = 0.35, C = 1e-6; truths, sweeps, found E, found nu.
PAPER_TABLE_2 = {
    "start": (30.0, 0.35),
    "truths": [(21, 0.3), (21, 0.4), (41, 0.3), (41, 0.4), (61, 0.3), (61, 0.4)],
    "sweeps": [551, 385, 229, 167, 187, 131],
    "E": [20.99, 21.0, 40.97, 41.01, 60.98, 61.01],
    "nu": [0.3, 0.4, 0.3, 0.4, 0.3, 0.4],
}
#: Single forward pass of the paper (Sec. 2.4.1): (10, 0.3) -> (32.9, 0.3001) for truth (31, 0.4).
PAPER_SINGLE_PASS = {"truth": (31.0, 0.4), "start": (10.0, 0.3), "E": 32.9, "nu": 0.3001}

METHODS = ("ekf-paper", "ekf", "lsq")
#: ekf and lsq must enter their band within this many sweeps / function evaluations.
MAX_ITERATIONS_TO_BAND = 10
_FITTERS = {"ekf-paper": fit_ekf_paper, "ekf": fit_ekf, "lsq": fit_least_squares}


def blind_test_cases(tables: Sequence[int] = (1, 2)) -> list[dict]:
    """The paper's blind-test cases with the paper's results, one dict per case."""
    cases = []
    for t in tables:
        if t == 1:
            tab = PAPER_TABLE_1
            for i, s in enumerate(tab["starts"]):
                cases.append({"table": 1, "case": i + 1, "truth": tab["truth"], "start": tuple(map(float, s)),
                              "paper_sweeps": tab["sweeps"][i], "paper_E": tab["E"][i], "paper_nu": tab["nu"][i]})
        elif t == 2:
            tab = PAPER_TABLE_2
            for i, tr in enumerate(tab["truths"]):
                cases.append({"table": 2, "case": i + 1, "truth": tuple(map(float, tr)), "start": tab["start"],
                              "paper_sweeps": tab["sweeps"][i], "paper_E": tab["E"][i], "paper_nu": tab["nu"][i]})
        else:
            raise ValueError(f"tables must be 1 and/or 2, got {t!r}")
    return cases


def _in_band(method, truth, found):
    dE, dnu = abs(found[0] - truth[0]), abs(found[1] - truth[1])
    if method == "ekf-paper":
        return dE <= 0.1 and dnu <= 0.005
    return dE / abs(truth[0]) <= 1e-3 and dnu <= 2e-3


def _first_in_band(method, truth, steps):
    """Index of the first sweep / function evaluation inside the accuracy band."""
    for k, x in enumerate(steps):
        if _in_band(method, truth, x):
            return k
    return None


def _passes(method, truth, found, success, first_in_band):
    if not (success and _in_band(method, truth, found)):
        return False
    return method == "ekf-paper" or (first_in_band is not None and first_in_band <= MAX_ITERATIONS_TO_BAND)


def run_blind_tests(model, methods: Sequence[str] = METHODS, *, tables: Sequence[int] = (1, 2),
                    cases: Sequence[dict] | None = None, depth=None, n_points: int = 100,
                    depth_range: tuple[float, float] = (0.006, 0.6), modulus: str = "E_kPa",
                    poisson: str = "nu", fixed: Mapping[str, float] | None = None,
                    options: Mapping[str, Mapping] | None = None, synthesize=None) -> list[dict]:
    """Run the blind tests of Tables 1-2 for each method on ``model``.

    Parameters
    ----------
    model : ForceModel
        Needs parameters named ``modulus`` and ``poisson``; any other parameter must
        be given in ``fixed``.
    methods : sequence of {"ekf-paper", "ekf", "lsq"}
    tables : sequence of {1, 2}
    cases : sequence of dict, optional
        Subset of :func:`blind_test_cases` (overrides ``tables``).
    depth : array_like, optional
        Depths (mm); default ``n_points`` evenly spaced in ``depth_range``.
    fixed : mapping, optional
        Values of the model's other parameters (held fixed).
    options : mapping, optional
        Extra keyword arguments per method, e.g. ``{"ekf-paper": {"max_sweeps": 2000}}``.
    synthesize : callable, optional
        ``synthesize(depth_mm, (E, nu)) -> force_mN``: the "measured" curve at the
        truth. Default: the model itself. Pass the finite-element forward model to
        test a response surface on independent data, as in the paper.

    Returns
    -------
    list of dict
        One row per (case, method): ``table, case, method, truth, start,
        iterations, E, nu, dE, dnu, in_band (passes the acceptance band, see the
        module notes), first_in_band, status, message, time_s`` and the paper's
        ``paper_sweeps, paper_E, paper_nu``. Cases whose
        truth or start lies outside the model's bounds are returned with
        ``status = None`` and ``message = "skipped: ..."``.
    """
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"unknown method {m!r}; choose from {METHODS}")
    names = tuple(model.parameter_names)
    fixed = dict(fixed or {})
    missing = [n for n in names if n not in (modulus, poisson) and n not in fixed]
    if modulus not in names or poisson not in names or missing:
        raise ValueError(f"model parameters {names}: need {modulus!r}, {poisson!r} and fixed values for {missing}")
    ie, iv = names.index(modulus), names.index(poisson)
    lo, hi = (np.asarray(b, float) for b in model.bounds)
    h = np.linspace(*depth_range, int(n_points)) if depth is None else np.asarray(depth, float)
    options = {k: dict(v) for k, v in (options or {}).items()}
    rows = []
    for case in (blind_test_cases(tables) if cases is None else cases):
        truth, start = case["truth"], case["start"]

        def full(pair):
            theta = np.array([fixed.get(n, np.nan) for n in names], float)
            theta[ie], theta[iv] = pair
            return theta

        inside = all(np.all((full(p) >= lo) & (full(p) <= hi)) for p in (truth, start))
        for method in methods:
            row = {**case, "method": method}
            if not inside:
                rows.append({**row, "iterations": None, "E": None, "nu": None, "dE": None, "dnu": None,
                             "in_band": False, "first_in_band": None, "status": None, "time_s": 0.0,
                             "message": "skipped: truth or start outside the model bounds"})
                continue
            z = np.asarray(model.force(h, full(truth)) if synthesize is None else synthesize(h, truth), float)
            t0 = time.perf_counter()
            res = _FITTERS[method](model, h, z, full(start), fixed=fixed or None, **options.get(method, {}))
            elapsed = time.perf_counter() - t0
            found = (res.parameters[modulus], res.parameters[poisson])
            steps = res.history.get("sweeps" if method != "lsq" else "iterates")
            names_free = res.free_names
            steps2 = None if steps is None else [(s[names_free.index(modulus)], s[names_free.index(poisson)]) for s in steps]
            fib = None if steps2 is None else _first_in_band(method, truth, steps2)
            rows.append({**row, "iterations": res.iterations, "E": found[0], "nu": found[1],
                         "dE": found[0] - truth[0], "dnu": found[1] - truth[1],
                         "in_band": _passes(method, truth, found, res.success, fib),
                         "first_in_band": fib, "status": res.status, "message": res.message, "time_s": elapsed})
    return rows


def format_table(rows: Sequence[dict]) -> str:
    """Text tables: the paper's sweeps and values next to ours, per case and method."""
    out = []
    for table in sorted({r["table"] for r in rows}):
        sub = [r for r in rows if r["table"] == table]
        if table == 1:
            out.append(f"Table 1 (truth E = {PAPER_TABLE_1['truth'][0]:g} kPa, nu = {PAPER_TABLE_1['truth'][1]:g}; "
                       f"varied start)")
        else:
            out.append(f"Table 2 (start E = {PAPER_TABLE_2['start'][0]:g} kPa, nu = {PAPER_TABLE_2['start'][1]:g}; "
                       f"varied truth)")
        head = (f"{'truth':>12} {'start':>12} | {'paper: sweeps':>13} {'E':>6} {'nu':>6} | {'method':<9} "
                f"{'iters':>5} {'to band':>7} {'E found':>10} {'nu found':>9} {'dE':>9} {'dnu':>9} {'time s':>7}  ok")
        out += [head, "-" * len(head)]
        last = None
        for r in sub:
            key = (r["truth"], r["start"])
            if key != last:
                left = (f"{'(%g, %g)' % r['truth']:>12} {'(%g, %g)' % r['start']:>12} | "
                        f"{r['paper_sweeps']:>13} {r['paper_E']:>6g} {r['paper_nu']:>6g} | ")
            else:
                left = " " * 12 + " " + " " * 12 + " | " + " " * 27 + " | "
            last = key
            if r["status"] is None:
                out.append(left + f"{r['method']:<9} {r['message']}")
                continue
            fib = "-" if r["first_in_band"] is None else str(r["first_in_band"])
            out.append(left + f"{r['method']:<9} {r['iterations']:>5} {fib:>7} {r['E']:>10.5f} {r['nu']:>9.5f} "
                       f"{r['dE']:>9.2e} {r['dnu']:>9.2e} {r['time_s']:>7.3f}  {'yes' if r['in_band'] else 'NO'}")
        out.append("")
    out.append("iters: sweeps (filters) or Jacobian evaluations (lsq); to band: first sweep / function evaluation "
               "inside the band (ekf-paper |dE|<=0.1 kPa, |dnu|<=0.005; ekf, lsq |dE|/E<=0.1%, |dnu|<=0.002).")
    return "\n".join(out)


def _load_model(spec: str):
    module, _, attr = spec.partition(":")
    if not attr:
        raise ValueError(f"--model must look like 'module:factory', got {spec!r}")
    obj = getattr(importlib.import_module(module), attr)
    return obj() if isinstance(obj, type) or (callable(obj) and not hasattr(obj, "force")) else obj


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``python -m skin_indent.inverse.blind_tests --model module:factory``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", required=True, help="importable 'module:factory' returning a ForceModel")
    ap.add_argument("--methods", default=",".join(METHODS), help="comma-separated subset of ekf-paper,ekf,lsq")
    ap.add_argument("--tables", default="1,2")
    ap.add_argument("--json", help="also write the rows to this JSON file")
    args = ap.parse_args(argv)
    model = _load_model(args.model)
    rows = run_blind_tests(model, [m for m in args.methods.split(",") if m],
                           tables=[int(t) for t in args.tables.split(",") if t])
    print(format_table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([{k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in r.items()}
                       for r in rows], fh, indent=1)
    return 0 if all(r["in_band"] for r in rows if r["status"] is not None) else 1


if __name__ == "__main__":
    sys.exit(main())
