"""Layered samples against known answers: the half-space limit, Hertz of the top
layer, Dimitriadis' bonded thin layer, and the independent finite-element curves."""

import numpy as np
import pytest
from skfem import MeshTri
from _data import load_curve

from skin_indent.mechanics.analytic import dimitriadis_bonded_force, hertz_force
from skin_indent.mechanics import LinearElastic, NeoHooke, SphericalIndenter
from skin_indent.mechanics.materials import NeoHookeStiffening
from skin_indent.mechanics.layers import RIGID, Layer, LayeredSample
from skin_indent.mechanics.mesh import conform_to_interfaces, graded_mesh
from skin_indent.simulate import simulate

R = 6.22


def test_layer_of_the_substrate_material_is_the_half_space():
    law = NeoHooke(8.0, 0.45)
    d = np.linspace(0.06, 0.6, 10)
    homogeneous = simulate(law, SphericalIndenter(R), d, mesh="coarse").force_mN
    layered = simulate(LayeredSample((Layer(1.0, law),), law), SphericalIndenter(R), d, mesh="coarse").force_mN
    assert np.abs(layered / homogeneous - 1).max() < 2e-3


def test_small_depth_limit_is_hertz_of_the_top_layer():
    """As chi = sqrt(R h)/t -> 0 the force tends to Hertz of the top layer; a 10x stiffer
    substrate adds a correction linear in chi (so it is still ~2% at chi = 0.025)."""
    t = 5.0
    sample = LayeredSample((Layer(t, NeoHooke(5.0, 0.45)),), NeoHooke(50.0, 0.45))
    curve = simulate(sample, SphericalIndenter(R), 0.002 * R, 5, mesh="coarse")
    ratio = curve.force_mN / hertz_force(curve.depth_mm, 5.0, 0.45, R)
    chi = np.sqrt(R * curve.depth_mm) / t
    slope, intercept = np.polyfit(chi, ratio, 1)
    print(f"F/F_Hertz(top) = {intercept:.4f} + {slope:.3f} chi")
    assert abs(intercept - 1) < 0.01 and slope > 0


@pytest.mark.parametrize("nu", [0.3, 0.45])
def test_thin_bonded_layer_on_rigid_base_vs_dimitriadis(nu):
    """Small strain, chi = sqrt(R h)/t <= 0.3: the layer stiffens the contact by up to ~45%;
    the FE agrees with the (fitted) Dimitriadis series to a small fraction of that."""
    t = 2.0
    depth = np.linspace(0.01, 0.09 * t**2 / R, 6)  # chi up to 0.3
    curve = simulate(LayeredSample((Layer(t, LinearElastic(10.0, nu)),), RIGID), SphericalIndenter(R), depth)
    stiffening = curve.force_mN / hertz_force(depth, 10.0, nu, R) - 1
    mismatch = curve.force_mN / dimitriadis_bonded_force(depth, 10.0, nu, R, t) - 1
    print(f"nu={nu}: stiffening {np.round(stiffening, 3)}, FE/Dimitriadis - 1 = {np.round(mismatch, 4)}")
    assert stiffening[-1] > 0.3
    assert np.abs(mismatch).max() < 0.025
    assert np.all(np.abs(mismatch) < 0.06 * stiffening)


@pytest.mark.parametrize("name, sample", [
    ("hidden-effects/v02_layer_soft_base_exact.csv",
     LayeredSample((Layer(1.0, NeoHooke(25.0, 0.45)),), NeoHooke(4.0, 0.45))),
    ("hidden-effects/v03_layer_rigid_base_exact.csv", LayeredSample((Layer(3.0, NeoHooke(6.0, 0.45)),), RIGID)),
    ("invivo-like/forearm_like_exact.csv",
     LayeredSample((Layer(1.0, NeoHooke(17.54, 0.48)), Layer(3.0, NeoHooke(2.92, 0.48))), NeoHooke(9.35, 0.48))),
])
def test_independent_layered_curves(name, sample):
    """The independent code's layered cases with their true parameters: within 0.5% for h >= 0.05 mm
    (measured on the default mesh, conforming interfaces: 3.5e-3, 1.7e-3, 2.6e-3; 4.6e-3, 5.0e-3,
    5.1e-3 before, with triangles cut by the interfaces and twice the vertices along them)."""
    data = load_curve(name)
    d, F_ref = data[1:, 1], data[1:, 2]
    curve = simulate(sample, SphericalIndenter(R), d)
    err = np.abs(curve.force_mN / F_ref - 1)[d >= 0.05]
    print(f"{name}: max error {err.max():.2e}; {curve.mesh_name}")
    assert err.max() < 0.005


@pytest.mark.parametrize("interfaces", [(1.0, 3.0), (0.2,)])
def test_layered_mesh_conforms_to_its_interfaces_under_the_contact(interfaces):
    """No triangle near the contact is cut by an interface; the moved vertices keep every
    triangle's orientation and the free surface flat."""
    imesh = graded_mesh(R, 0.6, "coarse", interfaces_mm=interfaces)
    p, t = imesh.mesh.p, imesh.mesh.t
    a = np.sqrt(R * 0.6)
    z, r = p[1, t], p[0, t].mean(axis=0)
    for depth in interfaces:
        cut = (z.max(axis=0) > -depth + 1e-12) & (z.min(axis=0) < -depth - 1e-12)
        assert not np.any(cut & (r < 2 * a + depth)), depth
        assert np.count_nonzero(np.isclose(p[1], -depth)) > 10


def test_conform_to_interfaces_moves_only_vertices_near_an_interface():
    mesh = MeshTri.init_tensor(np.linspace(0, 4, 9), np.linspace(-4, 0, 9)).refined(1)
    moved = conform_to_interfaces(mesh, [1.3])
    dz = moved.p[1] - mesh.p[1]
    assert np.all(moved.p[0] == mesh.p[0]) and np.all(dz[mesh.p[1] == 0] == 0)
    assert np.all(np.isclose(moved.p[1, dz != 0], -1.3))
    assert np.abs(dz).max() <= 0.125 + 1e-12  # half the edge length: only the nearer ends moved
    z = moved.p[1, moved.t]
    assert not np.any((z.max(axis=0) > -1.3 + 1e-12) & (z.min(axis=0) < -1.3 - 1e-12))

    def areas(m):
        x = m.p[:, m.t]
        return (x[0, 1] - x[0, 0]) * (x[1, 2] - x[1, 0]) - (x[0, 2] - x[0, 0]) * (x[1, 1] - x[1, 0])

    assert np.all(areas(moved) / areas(mesh) >= 0.25)


def test_bad_layers():
    with pytest.raises(ValueError, match="thickness"):
        Layer(0.0, NeoHooke(1.0, 0.4))
    with pytest.raises(ValueError, match="at least one"):
        LayeredSample((), NeoHooke(1.0, 0.4))
    with pytest.raises(ValueError, match="substrate"):
        LayeredSample((Layer(1.0, NeoHooke(1.0, 0.4)),), "granite")
    with pytest.raises(ValueError, match="small-strain or finite-strain"):
        LayeredSample((Layer(1.0, LinearElastic(1.0, 0.4)),), NeoHooke(1.0, 0.4))


def test_neo_hookean_layers_in_one_pass_equal_the_per_layer_evaluation():
    """Layers of neo-Hookean laws are evaluated with per-point Lame parameters: same forces and tangents."""
    from skin_indent.mechanics import graded_mesh
    from skin_indent.mechanics.axisymmetric import AxisymmetricSolid

    sample = LayeredSample((Layer(0.5, NeoHooke(12.0, 0.45)), Layer(1.0, NeoHooke(8.0, 0.4))), NeoHooke(2.4, 0.48))
    imesh = graded_mesh(6.22, 0.6, "coarse", interfaces_mm=sample.interfaces_mm)
    solid = AxisymmetricSolid(imesh.mesh, sample)
    assert solid._merged is not None
    u = 1e-3 * np.random.default_rng(5).standard_normal(solid.n_dofs)
    f_one, K_one = solid.forces(u)
    solid._merged = None  # per layer, with masked copies
    f_each, K_each = solid.forces(u)
    assert np.abs(f_one - f_each).max() <= 1e-12 * np.abs(f_each).max()
    assert np.abs(K_one - K_each).max() <= 1e-12 * np.abs(K_each).max()


@pytest.mark.parametrize("sample", [
    LayeredSample((Layer(1.2, NeoHookeStiffening(1.0, 0.49, 4.0)),), NeoHookeStiffening(0.25, 0.49, 1.0)),
    LayeredSample((Layer(0.5, NeoHookeStiffening(12.0, 0.45, 30.0)),), NeoHooke(2.4, 0.48)),
    NeoHookeStiffening(6.0, 0.45, 12.0),
    NeoHooke(8.0, 0.45),
], ids=["stiffening layers", "stiffening over neo-Hooke", "stiffening half-space", "neo-Hooke half-space"])
def test_a_body_of_neo_hookean_laws_with_stiffening_in_one_pass_equals_each_law(sample):
    """Regions of neo-Hookean laws with or without stiffening (a layer with stiffening as the
    finite-element fits build it, a half-space) are evaluated in one pass on the five axisymmetric
    components with per-point parameters: the same forces and tangents as each law's own 3 x 3
    code, region by region, and a tangent that is the derivative of the forces."""
    from skin_indent.mechanics import graded_mesh
    from skin_indent.mechanics.axisymmetric import AxisymmetricSolid

    interfaces = getattr(sample, "interfaces_mm", None)
    imesh = graded_mesh(R, 0.6, "coarse", **({"interfaces_mm": interfaces} if interfaces is not None else {}))
    solid = AxisymmetricSolid(imesh.mesh, sample)
    assert solid._merged is not None
    u = simulate(sample, SphericalIndenter(R), [0.3, 0.6], mesh=imesh, solve_at_outputs=True,
                 keep_fields=True).solved_fields[-1]  # the strains of an indentation to 0.6 mm
    f_one, K_one = solid.forces(u)
    solid._merged = None  # each region by its own law
    f_each, K_each = solid.forces(u)
    assert np.abs(f_one - f_each).max() <= 1e-12 * np.abs(f_each).max()
    assert np.abs(K_one - K_each).max() <= 1e-12 * np.abs(K_each).max()
    solid._merged = AxisymmetricSolid(imesh.mesh, sample)._merged
    du = 1e-7 * np.random.default_rng(8).standard_normal(solid.n_dofs)
    f_plus, _ = solid.forces(u + du, tangent=False)
    f_minus, _ = solid.forces(u - du, tangent=False)
    dofs = solid.element_dofs  # (nloc, nel)
    Kdu = np.bincount(dofs.T.ravel(), weights=np.einsum("ekl,el->ek", K_one, du[dofs.T]).ravel(),
                      minlength=solid.n_dofs)
    assert np.abs((f_plus - f_minus) / 2 - Kdu).max() <= 1e-6 * np.abs(Kdu).max()


def test_a_thin_layer_on_a_rigid_base_keeps_the_depth_step_that_converged():
    """1 mm on a rigid base, 60 % compressed: Newton fails for large depth steps at depth. After
    a failed (halved) increment the converged step is kept (doubled after easy increments)
    instead of retrying the full step, and the curve reaches the force of small uniform steps.
    (How many step cuts that saves depends on the floating-point path: benchmarks/solver_counts.py.)"""
    sample = LayeredSample((Layer(1.0, NeoHooke(8.0, 0.45)),), RIGID)
    curve = simulate(sample, SphericalIndenter(R), 0.6, 100, mesh="coarse")
    small_steps = simulate(sample, SphericalIndenter(R), np.linspace(0.01, 0.6, 60), mesh="coarse",
                           solve_at_outputs=True)
    # the same state to the Newton tolerance (RTOL 1e-5: forces within a few 1e-6)
    assert curve.solved_force_mN[-1] == pytest.approx(small_steps.force_mN[-1], rel=2e-5)


@pytest.mark.parametrize("easy", [False, True])
def test_a_failed_increment_keeps_the_halved_depth_step(monkeypatch, easy):
    """The step control on its own: Newton is made to fail every step longer than 0.03 mm and to
    report hard (or easy) increments. Hard: after two cuts the 0.025 mm step is kept up to the
    first depth and toward the next one (not the whole 0.1 mm range first); easy: it doubles
    again after each converged increment."""
    from skin_indent.mechanics import IndentationProblem
    from skin_indent.mechanics.solver import EASY_ITERATIONS

    prob = IndentationProblem(graded_mesh(R, 0.2, "coarse"), NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.2)
    newton, tried, last = prob._newton, [], [0.0]

    def limited(u, depth, report):
        tried.append(depth)
        if depth - last[0] > 0.03:
            return False, prob.max_iterations, np.inf, 0.0
        ok, _, rel, force = newton(u, depth, report)
        assert ok  # steps of 0.025 mm converge
        last[0] = depth
        return ok, 1 if easy else EASY_ITERATIONS + 1, rel, force

    monkeypatch.setattr(prob, "_newton", limited)
    forces, _, report = prob.solve([0.1, 0.2])
    if easy:
        assert tried[:4] == pytest.approx([0.1, 0.05, 0.025, 0.075], abs=1e-12)
    else:
        assert tried == pytest.approx([0.1, 0.05, 0.025, 0.05, 0.075, 0.1, 0.125, 0.15, 0.175, 0.2], abs=1e-12)
        assert report.step_cuts == 2  # set by the step rule above, not by Newton
    assert tried[-1] == 0.2 and np.all(forces > 0)


def test_keeping_the_contact_zone_against_the_sphere_on_a_rigid_base(monkeypatch):
    """The predictor of a confined layer lifts part of the contact zone off the sphere;
    predictor.SurfaceFit puts it back on the loading steps of the solve, and the curve stays the same
    to the Newton tolerance. (The Newton iterations and step cuts it saves depend on the floating-point
    path: benchmarks/solver_counts.py.)"""
    from skin_indent.mechanics.predictor import SurfaceFit

    fit, steps = SurfaceFit.__call__, []

    def recorded(self, trial, u, depth, new_depth):
        if not 0 < depth < new_depth:
            return fit(self, trial, u, depth, new_depth)
        touching = self._penetration(u, depth) > 0
        lifted = touching & (self._penetration(trial, new_depth) < 0)
        out = fit(self, trial, u, depth, new_depth)
        steps.append((int(lifted.sum()), self._penetration(out, new_depth)[touching]))
        return out

    sample = LayeredSample((Layer(1.0, NeoHooke(8.0, 0.45)),), RIGID)
    monkeypatch.setattr(SurfaceFit, "__call__", recorded)
    fitted = simulate(sample, SphericalIndenter(R), 0.6, 100, mesh="coarse")
    assert any(n > 0 for n, _ in steps)  # the zone is lifted (measured: up to 28 of its 32 surface nodes)
    assert all(np.all(after >= 0) for _, after in steps)  # and put back: every node of it inside the sphere
    monkeypatch.setattr(SurfaceFit, "__call__", lambda self, trial, u, depth, new_depth: trial)
    plain = simulate(sample, SphericalIndenter(R), 0.6, 100, mesh="coarse")
    assert np.abs(fitted.force_mN / plain.force_mN - 1).max() < 2e-5


def test_a_layer_thinner_than_the_depth_stops_with_a_convergence_error():
    """0.6 mm into a 0.5 mm layer on a rigid base cannot be solved: the kept depth steps halve down to
    1/2^max_cuts of a depth range and the solve stops with a clear error (no endless creeping)."""
    from skin_indent.mechanics import ConvergenceError

    sample = LayeredSample((Layer(0.5, NeoHooke(8.0, 0.45)),), RIGID)
    with pytest.raises(ConvergenceError, match="did not converge at depth"):
        simulate(sample, SphericalIndenter(R), 0.6, 20, mesh="coarse")
