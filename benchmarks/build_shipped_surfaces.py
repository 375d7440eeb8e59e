#!/usr/bin/env python
"""Compute, export and verify the response surfaces shipped with the package (issue 39).

    python benchmarks/build_shipped_surfaces.py build  --cache DIR [--workers 2] [--dimensionless]
    python benchmarks/build_shipped_surfaces.py export --cache DIR [--keep]
    python benchmarks/build_shipped_surfaces.py verify [--stamp] [--sample 2]

``build`` makes, into the run cache ``DIR`` (a fresh folder), every surface the default
workflows ask for: the dimensionless surfaces of a skin curve's diagnosis at any radius
(:func:`skin_indent.fitting.surfaces.unit_core`: the neo-Hookean base, layer and stiffening
surfaces at R = 1 mm, coarse mesh, for every depth ceiling h/R of ``EFFECT_CEILINGS``; only
these with ``--dimensionless``, exported with ``--keep`` to leave the other shipped files as
they are), and on the bundled skin curves: the neo-Hookean half-space at unit radius
(``surface_for``; depth ceilings h/R = 0.1 and 0.2 on the medium mesh: every radius by
similarity) and, for each of the demo's two curves (``forearm_like.csv``, R = 6.22 mm and
``forearm_like_R3.11mm.csv``, R = 3.11 mm), what the diagnosis's fits on surfaces ask for
(:func:`skin_indent.fitting.surfaces.elastic_core` with the curve's radius and deepest depth
on the coarse mesh: the neo-Hookean base surface, the layer surface and the stiffening
surface). The runs are made by local processes, one BLAS thread each.

``export`` writes the runs of that cache to ``src/skin_indent/data/surfaces/``
(:mod:`skin_indent.response_surface.shipped`): one ``.npz`` per surface and ``index.json``
with each surface's settings (without ``code_version``), the source digest of the forward
model that made them and the digests it was verified against.

``verify`` recomputes a sample of every shipped surface's runs with the installed forward
model (``--sample`` runs per surface, the same choice as the test
``tests/test_shipped_surfaces.py``) and compares their forces with the shipped ones: every
difference must be within a tenth of the model error (0.03 % of F). With ``--stamp`` and the
check passed, the installed digest is added to the digests the shipped surfaces are
accepted for (``verified_code`` in ``index.json``): a change of the mechanics that does not
move the forces needs this stamp, not a rebuild. A check that fails says to rebuild.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # one BLAS thread per process
    os.environ.setdefault(_var, "1")

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CURVES = (("forearm_like.csv", 6.22), ("forearm_like_R3.11mm.csv", None))
UNIT_CEILINGS = (0.1, 0.2)


#: the order the dimensionless surfaces are made in (the bundled R = 4 mm curve's ceiling first, then
#: ceilings about sqrt(2) apart, then those between)
FIRST_CEILINGS = (0.17, 0.12, 0.085, 0.24, 0.06, 0.1, 0.14, 0.2, 0.07, 0.05, 0.28)


def build_dimensionless(cache: Path, workers: int | None) -> None:
    """Make the runs of the dimensionless surfaces (:func:`skin_indent.fitting.surfaces.unit_core`:
    the neo-Hookean base, layer and stiffening surfaces at R = 1 mm for every depth ceiling
    of ``EFFECT_CEILINGS``, coarse mesh) into the run cache ``cache``."""
    from skin_indent.effects import ELASTIC, EFFECTS, effect
    from skin_indent.fitting.surfaces import EFFECT_CEILINGS, unit_core
    from skin_indent.runtime.context import Context

    context = Context(cache_dir=cache, workers=workers, progress=None)
    t0 = time.perf_counter()
    elastic = [name for name in EFFECTS if effect(name).stage == ELASTIC]
    order = [c for c in FIRST_CEILINGS if c in EFFECT_CEILINGS]
    for ceiling in order + [c for c in EFFECT_CEILINGS if c not in order]:
        for key in ((), *((e,) for e in elastic)):
            unit_core(key, ceiling, context=context)
            print(f"dimensionless h/R <= {ceiling:g}, {'+'.join(('neo-hooke',) + key)}: "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)


def build(cache: Path, workers: int | None) -> None:
    """Make the shipped surfaces' runs into the run cache ``cache`` (see the module docstring)."""
    from skin_indent.data import bundled_path
    from skin_indent.diagnosis.workflow import prepare_curve
    from skin_indent.effects import ELASTIC, EFFECTS, effect
    from skin_indent.fitting.surfaces import elastic_core, surface_for
    from skin_indent.measurement import load_csv
    from skin_indent.runtime.context import Context

    build_dimensionless(cache, workers)
    context = Context(cache_dir=cache, workers=workers, progress=None)
    t0 = time.perf_counter()
    for ceiling in UNIT_CEILINGS:
        surface_for(1.0, ceiling, context=context)
        print(f"unit-radius half-space h/R <= {ceiling}: {time.perf_counter() - t0:.0f} s", flush=True)
    elastic = [name for name in EFFECTS if effect(name).stage == ELASTIC]
    for name, radius in CURVES:
        curve = prepare_curve(load_csv(bundled_path(name), radius_mm=radius), radius_mm=None,
                              segments=("approach", "hold", "retract"))
        for key in ((), *((e,) for e in elastic)):
            elastic_core(key, radius_mm=curve.radius_mm, max_depth_mm=curve.max_indentation_mm, e_star_kPa=10.0,
                         context=context, mesh="coarse")
            print(f"{name} R = {curve.radius_mm:g} mm, {'+'.join(('neo-hooke',) + key)}: "
                  f"{time.perf_counter() - t0:.0f} s", flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("action", choices=("build", "export", "verify"))
    p.add_argument("--cache", type=Path, help="run cache of build / export")
    p.add_argument("--workers", type=int, default=None)
    p.add_argument("--stamp", action="store_true", help="verify: add the installed digest if the forces hold")
    p.add_argument("--sample", type=int, default=None, help="verify: runs recomputed per surface")
    p.add_argument("--keep", action="store_true",
                   help="export: keep the shipped files the cache does not make again (same forward model)")
    p.add_argument("--dimensionless", action="store_true",
                   help="build: only the dimensionless surfaces (export them with --keep)")
    args = p.parse_args(argv)
    if args.action == "build":
        (build_dimensionless if args.dimensionless else build)(args.cache, args.workers)
        return 0
    from skin_indent.models.effect_surface import recompute_shipped
    from skin_indent.response_surface import shipped

    if args.action == "export":
        index = shipped.export_cache(args.cache, shipped.SHIPPED_DIR, keep=args.keep)
        size = sum(p.stat().st_size for p in shipped.SHIPPED_DIR.iterdir() if p.is_file())
        print(f"exported {len(index['surfaces'])} surfaces to {shipped.SHIPPED_DIR} ({size / 2**20:.2f} MiB)")
        return 0
    report = shipped.verify(sample=args.sample, forces_of=recompute_shipped)
    for line in report.lines():
        print(line)
    if not report.ok:
        print("the shipped surfaces no longer match the forward model: rebuild them (build, export)", file=sys.stderr)
        return 1
    if args.stamp:
        digest = shipped.stamp()
        print(f"shipped surfaces accepted for src.{digest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
