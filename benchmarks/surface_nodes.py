"""Does the layer surface need every node, and how far off is it between them?

The diagnosis fits a layer on an effect surface of 7 thicknesses x 7 compliances x 4 nu
(:meth:`skin_indent.effects.layer.Layer.surface_axes`), 196 finite-element runs per sphere
radius: most of a diagnosis from an empty cache. This script loads (or builds) the surface of
the forearm-like curve (R = 6.22 mm, depths to 0.6 mm, coarse mesh, as the diagnosis builds
it), drops one interior node of one axis, interpolates the surface of the others at the
dropped node's runs, and reports the largest relative error of the force there (depths 0.05 mm
and deeper, every node of the other axes, every nu). The diagnosis allows a model error of
0.3 % (:data:`skin_indent.fitting.rung.MODEL_ERROR`): a node whose removal costs more is
needed. Then (``--between``) it compares the surface with finite-element runs at the centres
of its cells (the middle of each thickness interval and of four compliance intervals, in the
surface's own coordinates; nu = 0.44 and 0.48, between its nodes): 48 runs, about a minute.

    python benchmarks/surface_nodes.py [--cache DIR] [--between]

The surface's runs are cached in ``DIR`` (default: the package's cache), so a second run
takes seconds.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from skin_indent.effects import EffectAxis, effect
from skin_indent.fitting.rung import MODEL_ERROR
from skin_indent.fitting.surfaces import EFFECT_NU, curve_grid
from skin_indent.models.effect_surface import EffectSurface, model_unit_curve

RADIUS_MM, DEPTH_MM = 6.22, 0.6


def leave_one_out(full: EffectSurface, axis: int, drop: int, depth_mm: np.ndarray) -> tuple[float, tuple]:
    """Largest relative force error at the runs of node ``drop`` of ``axis`` when the surface of
    the other nodes interpolates them, and where (the node values and nu)."""
    keep = [i for i in range(len(full.axes[axis].nodes)) if i != drop]
    axes = list(full.axes)
    a = axes[axis]
    axes[axis] = EffectAxis(a.name, tuple(a.nodes[i] for i in keep), a.coordinate, a.shift)
    surfaces = np.take(full.surfaces, keep, axis=axis)
    part = EffectSurface(full.effects, tuple(axes), surfaces, full.radius_mm)
    worst, where = 0.0, None
    others = [range(len(b.nodes)) for b in full.axes]
    others[axis] = [drop]
    for idx in np.ndindex(*[len(o) for o in others]):
        values = tuple(full.axes[k].nodes[list(others[k])[i]] for k, i in enumerate(idx))
        for nu in full.grid.nu:
            exact = full.unit_force(depth_mm, nu, values)  # at a node: its own runs
            err = float(np.max(np.abs(part.unit_force(depth_mm, nu, values) / exact - 1.0)))
            if err > worst:
                worst, where = err, values + (float(nu),)
    return worst, where


def centre(axis: EffectAxis, i: int) -> float:
    """The middle of the interval between nodes ``i`` and ``i + 1`` in the axis's coordinate."""
    x = 0.5 * (axis.node_coords[i] + axis.node_coords[i + 1])
    return float(np.exp(x) - axis.shift) if axis.coordinate == "log" else float(x)


def between_nodes(full: EffectSurface, depth_mm: np.ndarray) -> list[tuple]:
    """``(thickness, compliance, nu, largest relative error)`` of the surface against a direct run at
    the centres of its cells."""
    thickness, compliance = full.axes
    out = []
    for i in range(len(thickness.nodes) - 1):
        for j in (0, 1, 3, 5):
            t, c = centre(thickness, i), centre(compliance, j)
            for nu in (0.48, 0.44):
                fe = model_unit_curve(nu, depth_mm, effects=("layer",), parameters=(("ratio", 1.0 / c),
                                      ("thickness_mm", t)), radius_mm=full.radius_mm, mesh="coarse")
                err = float(np.max(np.abs(full.unit_force(depth_mm, nu, (t, c)) / fe - 1.0)))
                out.append((t, c, nu, err))
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", default=None, help="cache folder of the surface's runs")
    parser.add_argument("--between", action="store_true", help="also finite-element runs at the cells' centres")
    args = parser.parse_args(argv)
    grid = curve_grid(10.0, DEPTH_MM, EFFECT_NU)
    axes = effect("layer").surface_axes(grid.depth_mm[-1])
    t = time.perf_counter()
    full = EffectSurface.build(("layer",), axes, grid, radius_mm=RADIUS_MM, mesh="coarse", cache_dir=args.cache)
    print(f"layer surface R = {RADIUS_MM} mm, depths to {grid.depth_mm[-1]:g} mm, "
          f"{' x '.join(str(len(a.nodes)) for a in axes)} x {grid.nu.size} nu: ready in {time.perf_counter() - t:.1f} s")
    depth = grid.depth_mm[grid.depth_mm >= 0.05]
    print(f"model error allowed: {MODEL_ERROR:.1%}")
    print(f"{'axis':<14}{'node left out':>15}{'largest error':>15}   where (thickness, compliance, nu)")
    result = {"radius_mm": RADIUS_MM, "depth_mm": float(grid.depth_mm[-1]), "model_error": MODEL_ERROR,
              "left_out": [], "between": []}
    for k, a in enumerate(axes):
        for i in range(1, len(a.nodes) - 1):
            worst, where = leave_one_out(full, k, i, depth)
            print(f"{a.name:<14}{a.nodes[i]:>15g}{worst:>15.2%}   {where}")
            result["left_out"].append({"axis": a.name, "node": float(a.nodes[i]), "error": worst, "where": where})
    if args.between:
        rows = between_nodes(full, depth)
        print(f"{'thickness mm':>13}{'compliance':>12}{'nu':>6}{'largest error':>15}")
        for t, c, nu, err in rows:
            print(f"{t:>13.3f}{c:>12.4f}{nu:>6.2f}{err:>15.2%}")
        result["between"] = [{"thickness_mm": t, "compliance": c, "nu": nu, "error": err} for t, c, nu, err in rows]
        errs = np.array([r[3] for r in rows])
        print(f"{len(rows)} centres: median {np.median(errs):.2%}, above {MODEL_ERROR:.1%} at {np.sum(errs > MODEL_ERROR)}, "
              f"largest {errs.max():.2%}")
    out = Path(__file__).parent / "results" / "surface_nodes.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(result, indent=1))
    print(f"written: {out}")


if __name__ == "__main__":
    main()
