"""Side-by-side FElupe model of the sphere indentation problem (for speed comparison).

An independent implementation, with FElupe (https://github.com/adtzlr/felupe), of the
problem that :func:`skin_indent.simulate.simulate` solves: a rigid sphere (R = 6.22 mm,
frictionless, penalty) pressed into a compressible neo-Hookean half-space, axisymmetric,
total Lagrangian, under displacement control. It shares no code with ``skin_indent``
(own mesh, own element family, own contact, FElupe's Newton solver), and it follows the
settings of the reference curves in ``tests/data/reference/README.md``, only on a
smaller mesh (~2200 nodes by default, the size of our default mesh, instead of ~14500):

* law: :class:`felupe.NeoHookeCompressible`, whose energy
  ``mu/2 tr C - mu ln J + lambda/2 (ln J)^2`` is exactly
  ``W = mu/2 (I1 - 3 - 2 ln J) + lambda/2 (ln J)^2`` up to the constant ``3 mu/2``;
* 9-node (biquadratic) quadrilaterals, :class:`felupe.RegionBiQuadraticQuad` with
  :class:`felupe.FieldAxisymmetric`;
* a tensor-product graded mesh of ``[0, L] x [-L, 0]``, L = 1000 mm: uniform elements
  of size ``h0`` along the surface out to 2 mm (just beyond the largest contact radius
  1.93 mm), then geometric growth to L; in depth geometric growth from ``h0``;
  ``h0`` is chosen to approach ``n_nodes_target``;
* frictionless node-to-rigid-sphere penalty on the surface nodes, written as a
  subclass of FElupe's :class:`felupe.mechanics.ContactRigidBase` (FElupe ships a
  plane and a cylinder, not a sphere); the sphere is a centre point added to the mesh
  whose axial displacement is prescribed, so the force on the sphere is the reaction
  at that point; penalty ``1e4 x E`` (mN/mm) per node ring;
* boundary conditions: u_r = 0 on the axis and on r = L, u = 0 on z = -L;
* FElupe's Newton-Raphson (:func:`felupe.newtonraphson`, driven by
  :class:`felupe.Step`), no line search, sparse direct solver
  :func:`scipy.sparse.linalg.spsolve` (FElupe's default), relative residual tolerance
  1e-8 (or a correction below 1e-10 mm, see :func:`_check_with_roundoff_floor`); one
  substep per output depth, each starting from the previous converged state.

FElupe's axisymmetric convention: the first coordinate is the axial one (here z, the
surface at z = 0, the body below), the second the radial one.

Validation against ``tests/data/reference/neo-hooke_halfspace_E8kPa_nu0.45.csv``
(measured 2026-11-22): the default 2205-node mesh (h0 = 0.108 mm) gives
F(0.6 mm) = 15.283 mN, +0.24 % (max 0.25 % for h >= 0.1 mm); the reference's mesh size
(``--h0 0.05 --growth-r 1.3 --growth-z 1.185``: 73 x 49 elements, 14553 nodes, 29106
unknowns) gives +0.07 % with a penetration of 5.0e-6 mm, as the reference reports.
Known limit: with h0 <= ~0.025 mm (~8000 nodes) Newton (without line search) fails at
the fourth increment.

Usage::

    python benchmarks/felupe_reference.py          # E = 8 kPa, nu = 0.45, checks the reference
    python benchmarks/felupe_reference.py --h0 0.05 --growth-r 1.3 --growth-z 1.185   # ~6 min
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

INSTALL_HINT = "install the bench extra: pip install .[bench]"

#: Largest extent of the truncated half-space (mm), as in the reference curves.
EXTENT_MM = 1000.0
#: Radius out to which the surface elements are uniform (mm): beyond the largest
#: contact radius sqrt(R h) = 1.93 mm of the R = 6.22 mm, h = 0.6 mm test.
UNIFORM_MM = 2.0
#: Largest growth ratio of neighbouring element sizes along the surface and in depth.
GROWTH_R = 2.0
GROWTH_Z = 1.7
#: Penalty stiffness per node ring, in units of E (mN/mm per kPa).
PENALTY_PER_E = 1e4
#: Newton tolerance (FElupe's relative residual: free dofs over reactions).
TOL = 1e-8
#: ... or a Newton correction below this (mm): converged to round-off (see
#: :func:`_check_with_roundoff_floor`).
XTOL = 1e-10

REFERENCE_CSV = Path(__file__).resolve().parents[1] / "tests" / "data" / "reference" / "neo-hooke_halfspace_E8kPa_nu0.45.csv"


def _import_felupe():
    try:
        import felupe
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise ImportError(INSTALL_HINT) from err
    return felupe


def graded_coordinates(h0: float, length: float, uniform: float = 0.0, growth: float = 1.5) -> np.ndarray:
    """Node coordinates from 0 to ``length``: uniform size ``h0`` up to ``uniform``, then
    geometric growth with the smallest ratio <= ``growth`` that lands exactly on ``length``."""
    from scipy.optimize import brentq

    n_u = int(round(uniform / h0)) if uniform > 0 else 0
    x_u = h0 * np.arange(n_u + 1)
    rest = length - x_u[-1]

    def total(q, n):  # sizes h0 q, h0 q^2, ..., h0 q^n
        return h0 * q * (q**n - 1.0) / (q - 1.0)

    n = max(1, math.ceil(math.log(1.0 + rest * (growth - 1.0) / (h0 * growth)) / math.log(growth)))
    q = brentq(lambda q: total(q, n) - rest, 1.0 + 1e-12, growth * (1 + 1e-12))
    sizes = h0 * q ** np.arange(1, n + 1)
    x = np.concatenate([x_u, x_u[-1] + np.cumsum(sizes)])
    x[-1] = length
    return x


def mesh_coordinates(h0: float, extent: float = EXTENT_MM, growth_r: float = GROWTH_R, growth_z: float = GROWTH_Z):
    """Radial and axial (depth, <= 0) vertex coordinates of the tensor-product mesh."""
    r = graded_coordinates(h0, extent, UNIFORM_MM, growth_r)
    z = -graded_coordinates(h0, extent, h0, growth_z)[::-1]
    return r, z


def n_nodes(h0: float, growth_r: float = GROWTH_R, growth_z: float = GROWTH_Z) -> int:
    """Nodes of the 9-node quad mesh for surface element size ``h0`` (mm)."""
    r, z = mesh_coordinates(h0, EXTENT_MM, growth_r, growth_z)
    return (2 * r.size - 1) * (2 * z.size - 1)


def choose_h0(n_nodes_target: int, growth_r: float = GROWTH_R, growth_z: float = GROWTH_Z) -> float:
    """Surface element size whose mesh comes closest to ``n_nodes_target`` nodes."""
    candidates = np.geomspace(0.02, 0.5, 161)
    counts = np.array([n_nodes(h, growth_r, growth_z) for h in candidates])
    return float(candidates[np.argmin(np.abs(np.log(counts / n_nodes_target)))])


def _sphere_contact_class(fem):
    class ContactRigidSphere(fem.mechanics.ContactRigidBase):
        """Frictionless node-to-surface penalty contact with a rigid sphere (a circle
        in the meridian plane), centred on the centre point of the contact."""

        def __init__(self, field, points, centerpoint, radius, **kwargs):
            self.radius = radius  # used by _kinematics() in super().__init__()
            super().__init__(field, points, centerpoint, **kwargs)

        def _kinematics(self, dx):
            distance = np.linalg.norm(dx, axis=1)
            normal = dx / distance.reshape(-1, 1)
            nn = np.einsum("ai,aj->aij", normal, normal)
            curvature = (np.eye(dx.shape[1]) - nn) / distance.reshape(-1, 1, 1)
            return distance - self.radius, normal, curvature

    return ContactRigidSphere


def build_model(E_kPa: float = 8.0, nu: float = 0.45, depth_mm: float = 0.6, n_nodes_target: int = 2200,
                radius_mm: float = 6.22, h0: float | None = None, growth_r: float = GROWTH_R,
                growth_z: float = GROWTH_Z):
    """Mesh, field, solid, contact and boundary conditions (no solve).

    Returns a dict with the FElupe objects and ``info`` (mesh statistics).
    """
    fem = _import_felupe()
    h0 = choose_h0(n_nodes_target, growth_r, growth_z) if h0 is None else float(h0)
    r, z = mesh_coordinates(h0, EXTENT_MM, growth_r, growth_z)
    # FElupe axisymmetric: first coordinate axial (z), second radial (r)
    mesh = fem.mesh.convert(fem.mesh.Grid(z, r), order=2, calc_midfaces=True)
    n_body = mesh.npoints
    # centre point of the sphere, touching the surface at depth 0
    mesh.add_points(np.array([[radius_mm, 0.0]]))
    center = mesh.npoints - 1

    region = fem.RegionBiQuadraticQuad(mesh)
    u = fem.FieldAxisymmetric(region, dim=2)
    field = fem.FieldContainer([u])

    mu = E_kPa / (2.0 * (1.0 + nu))
    lmbda = E_kPa * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    solid = fem.SolidBody(fem.NeoHookeCompressible(mu=mu, lmbda=lmbda), field)

    X = mesh.points
    tol = 1e-9 * EXTENT_MM
    reach = 1.6 * math.sqrt(2.0 * radius_mm * depth_mm)
    body = np.arange(mesh.npoints) < n_body
    surface = np.where(body & (np.abs(X[:, 0]) < tol) & (X[:, 1] < reach))[0]
    contact = _sphere_contact_class(fem)(
        field, surface, center, radius_mm, multiplier=PENALTY_PER_E * E_kPa, curvature="trial"
    )

    axis = body & (X[:, 1] < tol)
    outer = body & (X[:, 1] > EXTENT_MM - tol)
    bottom = body & (X[:, 0] < -EXTENT_MM + tol)
    is_center = np.arange(mesh.npoints) == center
    boundaries = {
        "axis": fem.Boundary(u, mask=axis, skip=(True, False)),
        "outer": fem.Boundary(u, mask=outer, skip=(True, False)),
        "bottom": fem.Boundary(u, mask=bottom),
        "center-r": fem.Boundary(u, mask=is_center, skip=(True, False)),
        "move": fem.Boundary(u, mask=is_center, skip=(False, True)),
    }
    info = {
        "element": "9-node quadrilateral (BiQuadraticQuad), FieldAxisymmetric",
        "n_nodes": int(n_body),
        "n_elements": int(mesh.ncells),
        "n_dofs": int(2 * n_body),
        "surface_size_mm": h0,
        "growth_r": float(np.max(np.diff(r)[1:] / np.diff(r)[:-1])),
        "growth_z": float(np.max(np.diff(-z[::-1])[1:] / np.diff(-z[::-1])[:-1])),
        "elements_r_z": [int(r.size - 1), int(z.size - 1)],
        "extent_mm": EXTENT_MM,
        "n_contact_nodes": int(surface.size),
        "penalty_mN_per_mm": PENALTY_PER_E * E_kPa,
        "felupe_version": fem.__version__,
    }
    return {"fem": fem, "mesh": mesh, "field": field, "solid": solid, "contact": contact,
            "boundaries": boundaries, "center": center, "info": info}


def _check_with_roundoff_floor(fem, xtol_mm):
    """FElupe's convergence check, also accepting a Newton correction below ``xtol`` (mm).

    FElupe's relative residual (free dofs over reactions) cannot drop below ~1e-6 at the
    smallest depths (F ~ 0.016 mN at 0.006 mm) on a 1000 mm mesh: the internal forces of
    the far-field elements (rings of radius ~1000 mm) carry a round-off of ~1e-8 mN. A
    correction |du| < xtol_mm then means that the iterate was already converged.
    """
    base = fem.tools._newton.check

    def check(dx, x, f, xtol, ftol, dof1=None, dof0=None, items=None):
        xnorm, fnorm, success = base(dx, x, f, xtol, ftol, dof1, dof0, items)
        return xnorm, fnorm, bool(success or xnorm < xtol_mm)

    return check


def run_felupe(E_kPa: float = 8.0, nu: float = 0.45, depth_mm: float = 0.6, points: int = 100,
               n_nodes_target: int = 2200, *, radius_mm: float = 6.22, h0: float | None = None,
               growth_r: float = GROWTH_R, growth_z: float = GROWTH_Z, tol: float = TOL, xtol: float = XTOL):
    """Force-depth curve of the FElupe model.

    Parameters
    ----------
    E_kPa, nu : float
        Young's modulus (kPa) and Poisson's ratio.
    depth_mm : float
        Largest depth (mm).
    points : int
        Number of equally spaced depths ``depth_mm * (1..points) / points``; each is
        one substep (increment) of the displacement-controlled Newton solution.
    n_nodes_target : int
        Approximate number of mesh nodes (the surface element size follows from it).
    h0 : float, optional
        Surface element size (mm); overrides ``n_nodes_target``.
    growth_r, growth_z : float
        Largest size ratio of neighbouring elements along the surface and in depth.
    tol, xtol : float
        Newton tolerances, see :data:`TOL` and :data:`XTOL`.

    Returns
    -------
    depth : ndarray
        Depths (mm).
    force : ndarray
        Force on the sphere (mN).
    seconds : float
        Wall time of the solution, model set-up and mesh included, FElupe's import
        excluded (``info["import_s"]``).
    info : dict
        Mesh and Newton statistics.

    Raises
    ------
    ImportError
        FElupe is not installed.
    """
    t_import = time.perf_counter()
    _import_felupe()  # import time is not part of the solution time (as for skin_indent)
    t0 = time.perf_counter()
    t_import = t0 - t_import
    model = build_model(E_kPa, nu, depth_mm, n_nodes_target, radius_mm, h0, growth_r, growth_z)
    fem = model["fem"]
    field, boundaries, center = model["field"], model["boundaries"], model["center"]
    info = model["info"]
    t_setup = time.perf_counter() - t0

    depth = depth_mm * np.arange(1, points + 1) / points
    step = fem.Step(items=[model["solid"], model["contact"]], ramp={boundaries["move"]: -depth},
                    boundaries=boundaries)
    dof_center_z = field[0].indices.dof[center, 0]
    force = np.empty(points)
    iterations = []
    check = _check_with_roundoff_floor(fem, xtol)
    for i, res in enumerate(step.generate(x0=field, verbose=0, tol=tol, check=check)):
        if not res.success:
            raise RuntimeError(f"FElupe Newton did not converge at depth {depth[i]:.6g} mm")
        iterations.append(int(res.iterations))
        # the reaction at the sphere's centre point balances the contact forces on it
        force[i] = -res.fun[dof_center_z]
    seconds = time.perf_counter() - t0

    contact = model["contact"]
    gap = contact._kinematics(contact._gap_vectors())[0]
    info.update(
        {
            "increments": points,
            "newton_iterations": int(np.sum(iterations)),
            "mean_iterations": float(np.mean(iterations)),
            "max_penetration_mm": float(max(-gap.min(), 0.0)),
            "setup_s": t_setup,
            "import_s": t_import,
            "solver": "felupe.newtonraphson + scipy.sparse.linalg.spsolve",
        }
    )
    return depth, force, seconds, info


def reference_force(depth_mm: np.ndarray, E_kPa: float = 8.0) -> np.ndarray:
    """Reference curve (E = 8 kPa, nu = 0.45) scaled to ``E_kPa`` at depths > 0.

    Interpolated linearly in the smooth ratio F / h^1.5 (nearly Hertz's constant), not in
    F, whose curvature would add ~0.1 % at h = 0.05 mm.
    """
    ref = np.loadtxt(REFERENCE_CSV, delimiter=",", skiprows=1)
    ref = ref[ref[:, 0] > 0]
    h = np.asarray(depth_mm, dtype=float)
    return np.interp(h, ref[:, 0], ref[:, 1] / ref[:, 0] ** 1.5) * h**1.5 * (E_kPa / 8.0)


def main(argv=None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nodes", type=int, default=2200, help="target number of nodes (default 2200)")
    parser.add_argument("--points", type=int, default=100, help="number of increments (default 100)")
    parser.add_argument("--h0", type=float, default=None, help="surface element size, mm (overrides --nodes)")
    parser.add_argument("--growth-r", type=float, default=GROWTH_R, help=f"largest radial growth ratio ({GROWTH_R})")
    parser.add_argument("--growth-z", type=float, default=GROWTH_Z, help=f"largest depth growth ratio ({GROWTH_Z})")
    parser.add_argument("--tol", type=float, default=TOL, help=f"Newton tolerance ({TOL:g})")
    args = parser.parse_args(argv)
    depth, force, seconds, info = run_felupe(8.0, 0.45, 0.6, args.points, args.nodes, h0=args.h0,
                                             growth_r=args.growth_r, growth_z=args.growth_z, tol=args.tol)
    ref = reference_force(depth)
    print(f"FElupe {info['felupe_version']}: {info['n_nodes']} nodes, {info['n_elements']} elements "
          f"({info['elements_r_z'][0]} x {info['elements_r_z'][1]}), {info['n_dofs']} dofs, "
          f"h0 = {info['surface_size_mm']:.3g} mm, growth ratios <= {info['growth_r']:.2f} (r), "
          f"{info['growth_z']:.2f} (z)")
    print(f"{info['increments']} increments, {info['newton_iterations']} Newton iterations "
          f"({info['mean_iterations']:.2f} per increment), max penetration {info['max_penetration_mm']:.2e} mm")
    print(f"wall time {seconds:.2f} s (set-up {info['setup_s']:.2f} s)")
    print(f"F(0.6 mm) = {force[-1]:.5g} mN, reference {ref[-1]:.5g} mN, "
          f"error {100 * (force[-1] / ref[-1] - 1):+.3f} %")
    for hmin in (0.1, 0.05):
        m = depth >= hmin - 1e-12
        print(f"max |error| over h >= {hmin} mm: {100 * np.max(np.abs(force[m] / ref[m] - 1)):.3f} %")


if __name__ == "__main__":
    main()
