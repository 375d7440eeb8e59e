"""Command-line interface: ``skin-indent COMMAND ...``.

A thin front end over the Python API. Every error a user can cause (bad numbers,
bad files, a model that does not converge) ends in a one-line message on stderr
and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

MATERIALS = ("neo-hooke", "linear-elastic")


class CLIError(Exception):
    """A user error, reported in one line."""


def _material(name: str, E: float, nu: float):
    from .mechanics.materials import LinearElastic, NeoHooke

    laws = {"neo-hooke": NeoHooke, "linear-elastic": LinearElastic}
    return laws[name](E_kPa=E, nu=nu)


def _add_simulate(sub):
    p = sub.add_parser("simulate", help="simulate a force-depth curve with the finite-element model",
                       description="Simulate a rigid sphere pressed into a half-space; write the force-depth curve "
                                   "(CSV: depth_mm,force_mN) and optionally the fields (VTU).")
    p.add_argument("--material", choices=MATERIALS, default="neo-hooke", help="constitutive law (default neo-hooke)")
    p.add_argument("--E", type=float, default=10.0, help="Young's modulus, kPa (default 10)")
    p.add_argument("--nu", type=float, default=0.4, help="Poisson's ratio (default 0.4)")
    p.add_argument("--radius", type=float, default=6.22, help="sphere radius, mm (default 6.22)")
    p.add_argument("--depth", type=float, default=0.6, help="largest depth, mm (default 0.6)")
    p.add_argument("--points", type=int, default=100, help="number of equally spaced depths (default 100)")
    p.add_argument("--mesh", default="medium", help="coarse, medium (default), fine, or a mesh file")
    p.add_argument("--increments", type=int, default=None, help="solved increments (default: automatic)")
    p.add_argument("--out", type=Path, default=Path("curve.csv"), help="output CSV (default curve.csv)")
    p.add_argument("--vtu", type=Path, default=None, help="also write the deformed mesh and fields at the last depth")
    p.set_defaults(run=_run_simulate)


def _run_simulate(args) -> int:
    from .mechanics.contact import SphericalIndenter
    from .simulate import simulate

    material = _material(args.material, args.E, args.nu)
    indenter = SphericalIndenter(args.radius)
    for path in [args.out] + ([args.vtu] if args.vtu else []):
        if not path.parent.exists():
            raise CLIError(f"output folder does not exist: {path.parent}")
    curve = simulate(material, indenter, args.depth, args.points, mesh=args.mesh, increments=args.increments,
                     keep_state=args.vtu is not None)
    curve.to_csv(args.out)
    print(f"material: {material.name}, E = {args.E:g} kPa, nu = {args.nu:g}; sphere R = {args.radius:g} mm")
    print(f"mesh: {curve.mesh_name}")
    print(f"Newton: {curve.report.summary()}")
    print(f"force at {curve.depth_mm[-1]:g} mm: {curve.force_mN[-1]:.6g} mN")
    print(f"wrote {args.out} ({curve.depth_mm.size} rows: depth_mm,force_mN)")
    if args.vtu:
        curve.write_vtu(args.vtu)
        print(f"wrote {args.vtu} (deformed mesh; displacement, contact pressure, Cauchy and von Mises stress)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(prog="skin-indent", description="Sphere indentation of skin: simulate, "
                                     "identify material parameters, diagnose missing physics. Units: mm, kPa, mN, s.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_simulate(sub)
    return parser



def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``skin-indent`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "run", None):
        parser.print_help()
        return 2
    from .mechanics.solver import ConvergenceError

    try:
        return args.run(args)
    except (CLIError, ValueError, ConvergenceError, OSError) as err:
        message = " ".join(str(err).split()) or type(err).__name__
        print(f"skin-indent {args.command}: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"skin-indent {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
