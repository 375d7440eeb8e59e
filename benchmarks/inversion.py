"""Speed and accuracy of the response surface and the inversion (issue: targets).

    python benchmarks/inversion.py [--quick]

Measures, on this machine, in one run:

- the paper-sized response surface (8 E x 6 nu x 100 depths, default mesh): build
  time with 1 and 2 local workers (target <= 30 s; the paper: 48 runs x 130 s);
- time of one evaluation of that surface at 1 and at 100 depths (median of 3 x 200
  calls; ``tests/test_response_surface.py`` once asserted < 1 ms; 30-60 us measured then);
- time of the paper's EKF to C = 1e-6, of the better EKF and of least squares on
  the Table 1 case (targets 1 s and 0.2 s);
- the paper's blind tests (Tables 1 and 2) with curves from the forward model at
  the true parameters, printed beside the paper's numbers;
- identifiability of nu with sigma = 0.05 mN noise: standard errors (least
  squares and Monte Carlo), E-nu correlation, and the 95% profile interval.

Results are printed and written to ``benchmarks/results/inversion.json``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from skin_indent.inverse import fit_ekf, fit_ekf_paper, fit_least_squares, format_table, profile, run_blind_tests
from skin_indent.mechanics import NeoHooke, SphericalIndenter
from skin_indent.response_surface import ResponseSurface, SurfaceGrid, default_settings
from skin_indent.simulate import simulate

R = 6.22


def timed(fn, repeat=3):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times)), out


def evaluation_time(surface, theta=(31.0, 0.4), calls: int = 200) -> dict:
    """Seconds per ``surface.evaluate`` call at 1 and at 100 depths (median of 3 x ``calls`` calls)."""
    out = {}
    for h in (np.array([0.3]), np.linspace(0.006, 0.6, 100)):
        t, _ = timed(lambda: [surface.evaluate(h, theta) for _ in range(calls)])
        out[f"evaluate_s_{h.size}_depths"] = t / calls
        print(f"surface evaluation at {h.size} depth(s): {t / calls * 1e6:.0f} us per call "
              "(tests once asserted < 1 ms)")
    return out


def main(quick: bool = False) -> dict:
    results = {}
    grid = SurfaceGrid.paper()
    settings = default_settings(R)
    surfaces = {}
    for workers in ([2] if quick else [1, 2]):
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            surfaces[workers] = ResponseSurface.build(grid, settings=settings, cache_dir=tmp, workers=workers,
                                                      progress=False)
            results[f"surface_build_s_workers{workers}"] = time.perf_counter() - t
        print(f"paper-sized surface (8 E x 6 nu x 100 depths), {workers} worker(s): "
              f"{results[f'surface_build_s_workers{workers}']:.1f} s (target <= 30 s)")
    if 1 in surfaces:
        same = np.array_equal(surfaces[1].unit_forces, surfaces[2].unit_forces)
        print(f"  1 and 2 workers give identical surfaces: {same}; parallel efficiency "
              f"{results['surface_build_s_workers1'] / (2 * results['surface_build_s_workers2']):.2f}")
    surface = surfaces[2]
    results.update(evaluation_time(surface))
    d = grid.depth_mm
    fe_cache = {}

    def fe(depth, truth):
        key = tuple(truth)
        if key not in fe_cache:
            fe_cache[key] = simulate(NeoHooke(*truth), SphericalIndenter(R), depth).force_mN
        return fe_cache[key]

    z = fe(d, (31.0, 0.4))
    x0 = np.array([10.0, 0.3])
    for name, fit in [("ekf-paper", fit_ekf_paper), ("ekf", fit_ekf), ("lsq", fit_least_squares)]:
        t, r = timed(lambda: fit(surface, d, z, x0))
        results[f"time_{name}_s"] = t
        print(f"{name:9s}: {t * 1e3:8.1f} ms, {r.iterations} iterations, E = {r.parameters['E_kPa']:.4f} kPa, "
              f"nu = {r.parameters['nu']:.5f} ({r.message})")
    print("targets: EKF to C = 1e-6 <= 1 s, least squares <= 0.2 s")
    if not quick:
        rows = run_blind_tests(surface, depth=d, synthesize=fe)
        table = format_table(rows)
        print(table)
        results["blind_tests"] = [{k: (v if not isinstance(v, np.generic) else v.item()) for k, v in row.items()}
                                  for row in rows]
        results["blind_tests_all_pass"] = all(row["in_band"] for row in rows)
    rng = np.random.default_rng(11)
    ident = []
    for truth in [(31.0, 0.4), (10.0, 0.3), (5.67, 0.48)]:
        z0 = fe(d, truth)
        mc = np.array([[r.parameters["E_kPa"], r.parameters["nu"]] for r in
                       (fit_least_squares(surface, d, z0 + rng.normal(0, 0.05, d.size), x0) for _ in range(30))])
        z1 = z0 + rng.normal(0, 0.05, d.size)
        r = fit_least_squares(surface, d, z1, x0, noise_mN=0.05)
        prof = profile(surface, d, z1, "nu", noise_mN=0.05)
        row = {"truth": truth, "E": r.parameters["E_kPa"], "nu": r.parameters["nu"], "std_E": r.std["E_kPa"],
               "std_nu": r.std["nu"], "mc_std_E": float(mc[:, 0].std()), "mc_std_nu": float(mc[:, 1].std()),
               "corr_E_nu": float(r.correlation[0, 1]), "verdict": prof.verdict}
        ident.append(row)
        print(f"sigma = 0.05 mN, truth E = {truth[0]} kPa, nu = {truth[1]}: nu = {row['nu']:.3f} +/- {row['std_nu']:.3f}"
              f" (Monte Carlo {row['mc_std_nu']:.3f}), corr(E, nu) = {row['corr_E_nu']:+.4f}; {prof.verdict}")
    results["identifiability"] = ident
    out = Path(__file__).parent / "results"
    out.mkdir(exist_ok=True)
    (out / "inversion.json").write_text(json.dumps(results, indent=1, default=str))
    return results


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="one worker count, no blind tests")
    main(parser.parse_args().quick)
