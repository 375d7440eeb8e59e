"""``skin-indent simulate``: one finite-element curve (and its fields) of a material or layered sample."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .options import CLIError, numbers, command_provenance

MATERIALS = ("neo-hooke", "linear-elastic", "neo-hooke-stiffening")


def _material(name: str, E: float, nu: float, C20: float = 0.0):
    from ..mechanics.materials import LinearElastic, NeoHooke, NeoHookeStiffening

    if name == "neo-hooke-stiffening":
        return NeoHookeStiffening(E_kPa=E, nu=nu, C20_kPa=C20)
    if C20:
        raise CLIError("--C20 needs --material neo-hooke-stiffening")
    laws = {"neo-hooke": NeoHooke, "linear-elastic": LinearElastic}
    return laws[name](E_kPa=E, nu=nu)


def _sample(args):
    """The material, or the layered sample, described by the simulate options."""
    from ..mechanics.layers import RIGID, Layer, LayeredSample
    from ..mechanics.materials import PronyTerm, Viscoelastic

    def law(E, nu):
        base = _material(args.material, E, nu, args.C20)
        if args.prony:
            terms = tuple(PronyTerm(*numbers(p, 2, "--prony G,TAU_S")) for p in args.prony)
            return Viscoelastic(base, terms)
        return base

    if args.rigid_base and not args.layer:
        raise CLIError("--rigid-base needs at least one --layer THICKNESS_MM,E_KPA,NU")
    if not args.layer:
        return law(args.E, args.nu)
    layers = [Layer(t, law(E, nu)) for t, E, nu in (numbers(x, 3, "--layer THICKNESS_MM,E_KPA,NU")
                                                      for x in args.layer)]
    return LayeredSample(tuple(layers), RIGID if args.rigid_base else law(args.E, args.nu))


def add_simulate(sub):
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
    p.add_argument("--C20", type=float, default=0.0, help="stiffening parameter of neo-hooke-stiffening, kPa")
    p.add_argument("--layer", action="append", default=[], metavar="THICKNESS_MM,E_KPA,NU",
                   help="a bonded layer (repeatable, top first); --E/--nu then describe the half-space below")
    p.add_argument("--rigid-base", action="store_true", help="the layers are bonded to a rigid base")
    p.add_argument("--prony", action="append", default=[], metavar="G,TAU_S",
                   help="a Prony term of quasi-linear viscoelasticity (repeatable); E is the instantaneous modulus")
    p.add_argument("--protocol", type=Path, default=None,
                   help="replay the time and depth history of a measurement CSV (with time_s)")
    p.add_argument("--speed", type=float, default=0.02, help="loading speed of the default ramp, mm/s (0.02)")
    p.add_argument("--unload", action="store_true", help="unload back to depth 0 after the ramp")
    p.add_argument("--offset", type=float, default=0.0, help="contact begins at this recorded depth, mm")
    p.add_argument("--friction", type=float, default=0.0, metavar="MU",
                   help="Coulomb friction coefficient between sphere and skin (history dependent: solved along "
                        "the protocol)")
    p.add_argument("--adhesion", type=float, default=0.0, metavar="W_MJ_PER_M2",
                   help="work of adhesion, mJ/m^2 (attractive traction; pull-off on unloading)")
    p.add_argument("--out", type=Path, default=Path("curve.csv"), help="output CSV (default curve.csv)")
    p.add_argument("--vtu", type=Path, default=None, help="also write the deformed mesh and fields at the last depth")
    p.set_defaults(run=_run_simulate)


def _run_simulate(args) -> int:
    from ..mechanics.contact_law import SphericalIndenter
    from ..measurement import load_csv
    from ..mechanics.protocol import Protocol

    material = _sample(args)
    indenter = SphericalIndenter(args.radius)
    for path in [args.out] + ([args.vtu] if args.vtu else []):
        if not path.parent.exists():
            raise CLIError(f"output folder does not exist: {path.parent}")
    from ..mechanics.contact_law import ContactLaw

    contact = ContactLaw(friction=args.friction, adhesion_mJ_per_m2=args.adhesion)
    protocol = None
    if args.protocol is not None:
        protocol = Protocol.from_measurement(load_csv(args.protocol))
    elif args.unload or not material.path_independent or args.friction > 0:
        protocol = Protocol.ramp(args.depth, args.points, args.speed, unload=args.unload)
    print(f"model: {material.name} {material.parameters()}; sphere R = {args.radius:g} mm", flush=True)
    from ..simulate import simulate  # the finite-element machinery, after the first line

    curve = simulate(material, indenter, args.depth, args.points, mesh=args.mesh, increments=args.increments,
                     protocol=protocol, offset_mm=args.offset, keep_state=args.vtu is not None, contact=contact)
    curve.to_csv(args.out, command_provenance(args, [args.protocol] if args.protocol else [], leave_out=("out", "vtu")))
    print(f"mesh: {curve.mesh_name}")
    print(f"Newton: {curve.report.summary()}")
    k = int(np.argmax(curve.force_mN))
    print(f"peak force {curve.force_mN[k]:.6g} mN at {curve.depth_mm[k]:g} mm"
          + (f" (t = {curve.time_s[k]:g} s)" if curve.time_s is not None else ""))
    columns = "time_s,depth_mm,force_mN" if curve.time_s is not None else "depth_mm,force_mN"
    print(f"wrote {args.out} ({curve.depth_mm.size} rows: {columns})")
    if args.vtu:
        curve.write_vtu(args.vtu)
        print(f"wrote {args.vtu} (deformed mesh; displacement, contact pressure, Cauchy and von Mises stress)")
    return 0

