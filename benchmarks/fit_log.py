"""Where the finite-element runs of a diagnosis go: every fit in the loop logged (issue 39).

::

    python benchmarks/fit_log.py --demo                 # the demo's two diagnoses (the curve, then the pair)
    python benchmarks/fit_log.py DATA.csv [DATA2.csv]   # one diagnosis (several files: one sample together)

Runs the diagnoses in this process with an empty cache (a fresh folder; ``--cache`` to give one) and
logs, for every model the :class:`~skin_indent.fitting.multistart.Fitter` fits: on surfaces or with
the finite-element model in the loop, the starts it screened and kept, the runs of the screen, of
the first fit, of the restarts from its end, of the short fits from the other starts, how it ended
(moved or not, its flags, RMS) and its wall time; then the runs of the next-measurement engine
(:func:`~skin_indent.diagnosis.identifiability.weigh`: separations and finite-element Jacobians) and
of everything else, as new files of the run cache. The functions are wrapped here, not changed.
Written to ``benchmarks/results/fit_log_<name>.json`` and printed as a table.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))

from skin_indent.data import bundled_path  # noqa: E402
from skin_indent.diagnosis import workflow  # noqa: E402
from skin_indent.fitting import multistart as ms  # noqa: E402

_local = threading.local()
LOG: list[dict] = []
PHASE = {"name": ""}


def fe_files(cache: Path) -> int:
    """Single finite-element runs kept in the cache (``fe-runs``), the runs made so far from an empty cache."""
    return sum(1 for _ in (cache / "fe-runs").glob("*/*.npz"))


def _runs(model) -> int:
    return ms.forward_runs(model)


@contextlib.contextmanager
def _part(model, kind: str, **extra):
    """Counts the runs of ``model`` made within the block as a part ``kind`` of the current fit."""
    record = getattr(_local, "record", None)
    r0, t0 = _runs(model), time.perf_counter()
    try:
        yield extra
    finally:
        if record is not None:
            record["parts"].append({"kind": kind, "runs": _runs(model) - r0, "wall_s": time.perf_counter() - t0,
                                    **extra})


def install(cache: Path) -> None:
    """Wrap the fitter's steps (module attributes, looked up at call time) to log them."""
    fit, screen, first_fit, resumed, lsq = (ms.Fitter.fit, ms.screen, ms.first_fit, ms.resumed,
                                            ms.fit_least_squares)
    weigh = workflow.weigh

    def fit_logged(self, effects):
        key = tuple(effects)
        if key in self.fits:
            return self.fits[key]
        record = {"phase": PHASE["name"], "model": "+".join(("neo-hooke",) + key), "curves": len(self.curves),
                  "parts": []}
        outer, _local.record = getattr(_local, "record", None), record
        t0 = time.perf_counter()
        try:
            rung = fit(self, effects)
        except ValueError as err:
            record.update(error=str(err), wall_s=time.perf_counter() - t0)
            LOG.append(record)
            raise
        finally:
            _local.record = outer
        record.update(wall_s=time.perf_counter() - t0, in_loop=bool(rung.bound_model.in_loop),
                      runs=int(rung.forward_runs), moved=bool(rung.moved), rms_mN=list(rung.curve_rms_mN),
                      chi2=float(rung.chi2_weighted), flags=list(rung.flags), iterations=int(rung.iterations),
                      warm=(None if self.warm(key) is None else self.warm(key).model))
        LOG.append(record)
        return rung

    def screen_logged(fitter, model, starts, keep, nested=None):
        with _part(model, "screen", starts=len(starts), nested=nested is not None) as extra:
            out = screen(fitter, model, starts, keep, nested=nested)
            extra["kept"] = len(out)
        return out

    def first_fit_logged(model, *args, starts=None, **kw):
        starts = args[2] if starts is None else starts
        with _part(model, "first fit", offered=len(starts)) as extra:
            best, first = first_fit(model, *args, **kw)
            extra.update(start=first, iterations=None if best is None else int(best.iterations),
                         status=None if best is None else int(best.status))
        return best, first

    def resumed_logged(model, *args, **kw):
        with _part(model, "resumed (early)" if kw.get("early") else "resumed (budget)"):
            return resumed(model, *args, **kw)

    def lsq_logged(model, *args, **kw):
        kind = "nested check" if kw.get("max_nfev") == 1 else f"probe ({kw.get('max_nfev')} evaluations)"
        if not getattr(model, "in_loop", False):
            return lsq(model, *args, **kw)
        with _part(model, kind):
            return lsq(model, *args, **kw)

    def weigh_logged(*args, **kw):
        n0, t0 = fe_files(cache), time.perf_counter()
        try:
            return weigh(*args, **kw)
        finally:
            LOG.append({"phase": PHASE["name"], "model": "weigh (next measurement, with_std=%s)" % kw.get("with_std"),
                        "explanations": [f.model for f in args[0]], "runs_made": fe_files(cache) - n0,
                        "wall_s": time.perf_counter() - t0, "parts": []})

    ms.Fitter.fit = fit_logged
    ms.screen = screen_logged
    ms.first_fit = first_fit_logged
    ms.resumed = resumed_logged
    ms.fit_least_squares = lsq_logged
    workflow.weigh = weigh_logged


def table(log: list[dict]) -> str:
    lines = [f"{'phase':<7} {'model':<44} {'runs':>5} {'wall s':>7}  parts; how it ended"]
    for r in log:
        if "runs_made" in r:
            lines.append(f"{r['phase']:<7} {r['model']:<44} {r['runs_made']:>5} {r['wall_s']:7.1f}  "
                         f"{' | '.join(r['explanations'])}")
            continue
        if not r.get("in_loop") and "error" not in r:
            continue
        parts = ", ".join(f"{p['kind']} {p['runs']}" + (f" ({p['starts']}->{p['kept']})" if "kept" in p else "")
                          + (f" (start {p['start']} of {p['offered']}, {p['iterations']} it)" if "offered" in p else "")
                          for p in r["parts"])
        if "error" in r:
            lines.append(f"{r['phase']:<7} {r['model']:<44} {'':>5} {r['wall_s']:7.1f}  {parts}; ERROR {r['error']}")
            continue
        end = ("moved" if r["moved"] else "DID NOT MOVE") + f", RMS {', '.join(f'{v:.4f}' for v in r['rms_mN'])}"
        if r["flags"]:
            end += "; " + "; ".join(f[:70] for f in r["flags"])
        lines.append(f"{r['phase']:<7} {r['model']:<44} {r['runs']:>5} {r['wall_s']:7.1f}  {parts}; {end} "
                     f"(warm {r['warm']})")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="*", type=Path, help="curves (several: one sample diagnosed together)")
    parser.add_argument("--demo", action="store_true", help="the demo's diagnoses: the curve, then the pair")
    parser.add_argument("--cache", type=Path, default=None, help="cache folder (default a fresh temporary one)")
    parser.add_argument("--name", default=None, help="name of the results file")
    args = parser.parse_args()
    import logging

    from skin_indent.diagnosis import diagnose
    from skin_indent.measurement import load_csv
    from skin_indent.runtime.context import Context

    logging.basicConfig(level=logging.INFO, format="%(relativeCreated)8.0f ms %(name)s: %(message)s",
                        stream=sys.stderr)
    cache = args.cache or Path(tempfile.mkdtemp(prefix="fit_log_"))
    fresh = args.cache is None
    install(cache)
    context = Context(cache_dir=cache)
    jobs = []
    if args.demo:
        first = load_csv(bundled_path("forearm_like.csv"), radius_mm=6.22)
        jobs = [("curve", first), ("pair", [first, load_csv(bundled_path("forearm_like_R3.11mm.csv"))])]
    elif args.data:
        curves = [load_csv(p) for p in args.data]
        jobs = [("curve" if len(curves) == 1 else "pair", curves[0] if len(curves) == 1 else curves)]
    else:
        parser.error("give --demo or curves")
    summary = {"cache": str(cache), "load_start": os.getloadavg(), "diagnoses": []}
    t0 = time.perf_counter()
    for name, m in jobs:
        PHASE["name"] = name
        n0, t = fe_files(cache), time.perf_counter()
        d = diagnose(m, context=context)
        summary["diagnoses"].append({"phase": name, "verdict": d.verdict, "ladder": [f.model for f in d.ladder],
                                     "runs_made": fe_files(cache) - n0, "wall_s": time.perf_counter() - t,
                                     "sentence": str(d.sentence())})
    summary.update(wall_s=time.perf_counter() - t0, load_end=os.getloadavg(), fits=LOG)
    print(table(LOG))
    for d in summary["diagnoses"]:
        print(f"{d['phase']}: {d['runs_made']} runs made, {d['wall_s']:.1f} s, verdict {d['verdict']}, ladder "
              f"{' -> '.join(d['ladder'])}")
        print(f"  {d['sentence']}")
    name = args.name or ("demo" if args.demo else "_".join(p.stem for p in args.data))
    out = HERE / "results" / f"fit_log_{name}.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(summary, indent=1, default=str))
    print(f"written: {out}")
    if fresh:
        shutil.rmtree(cache, ignore_errors=True)


if __name__ == "__main__":
    main()
