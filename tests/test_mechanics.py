"""The finite-element forward model against known answers.

Hertz and Sneddon at small depth, the independent reference curves, the
scikit-fem statement of the weak form, finite-difference tangents, the exact
E-scaling, penetration, smoothness, mesh files and bad input.
"""

from pathlib import Path

import numpy as np
import pytest
from skfem import asm

from skin_indent.mechanics.analytic import hertz_force, sneddon_sphere_force
from skin_indent.mechanics import (ConvergenceError, IndentationProblem, LinearElastic, NeoHooke,
                                   SphericalIndenter, graded_mesh, load_mesh)
from skin_indent.mechanics.weakform import residual_form, tangent_form
from skin_indent.simulate import DEFAULT_INCREMENTS, RTOL, not_a_knot_spline, simulate

R = 6.22
ROOT = Path(__file__).parents[1]


@pytest.fixture(scope="module")
def coarse_problem():
    return IndentationProblem(graded_mesh(R, 0.6, "coarse"), NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6)


def smooth_displacement(problem, amplitude=0.02, seed=1):
    b = problem.solid.basis
    x = b.doflocs
    rng = np.random.default_rng(seed)
    u = amplitude * np.exp(-np.hypot(x[0], x[1]) / 3.0) * (np.sin(x[0]) + 0.3 * rng.standard_normal(b.N))
    u[~problem.free] = 0.0
    return u


def test_fast_kernel_equals_scikit_fem_weak_form(coarse_problem):
    prob = coarse_problem
    b = prob.solid.basis
    u = smooth_displacement(prob)
    material = prob.solid.regions[0][1]
    R_skfem = asm(residual_form(material), b, u=b.interpolate(u))
    K_skfem = asm(tangent_form(material), b, u=b.interpolate(u))[prob.free][:, prob.free]
    f, Ke = prob.solid.forces(u)
    K = prob.pattern.assemble([(prob.solid.element_dofs, Ke)])
    assert np.abs(f - R_skfem).max() <= 1e-12 * np.abs(R_skfem).max()
    assert abs(K - K_skfem).max() <= 1e-12 * abs(K_skfem).max()


@pytest.mark.parametrize("depth", [0.1, 0.6])
def test_tangent_equals_finite_difference_of_residual(coarse_problem, depth):
    prob = coarse_problem
    u = smooth_displacement(prob, amplitude=0.02)
    f_int, Ke, f_c, Kc, _ = prob._evaluate(u, depth)
    assert np.count_nonzero(prob.contact.state(u, depth).pressure_kPa) > 0  # contact active
    K = prob.pattern.assemble([(prob.solid.element_dofs, Ke), (prob.contact.element_dofs, Kc)])
    v = np.zeros_like(u)
    v[prob.free] = np.random.default_rng(2).standard_normal(np.count_nonzero(prob.free))
    h = 1e-7 * depth
    rp = sum(prob._evaluate(u + h * v, depth, tangent=False)[i] for i in (0, 2))
    rm = sum(prob._evaluate(u - h * v, depth, tangent=False)[i] for i in (0, 2))
    fd = (rp - rm)[prob.free] / (2 * h)
    assert np.linalg.norm(K @ v[prob.free] - fd) <= 1e-6 * np.linalg.norm(fd)


@pytest.mark.parametrize("law", [LinearElastic, NeoHooke])
@pytest.mark.parametrize("nu", [0.3, 0.49])
def test_hertz_limit_at_small_depth(law, nu):
    """h/R <= 0.01: within 1% of Hertz (no volumetric locking at nu = 0.49)."""
    curve = simulate(law(10.0, nu), SphericalIndenter(R), 0.01 * R, 10)
    ratio = curve.force_mN / hertz_force(curve.depth_mm, 10.0, nu, R)
    print(f"{law.name} nu={nu}: F/F_Hertz - 1 =", np.round(ratio - 1, 4))
    assert np.all(np.abs(ratio - 1) < 0.01)
    if law is LinearElastic:  # the exact small-strain sphere solution: tighter
        sneddon = sneddon_sphere_force(curve.depth_mm, 10.0, nu, R)
        assert np.all(np.abs(curve.force_mN / sneddon - 1) < 0.005)


@pytest.mark.parametrize("E, nu", [(8.0, 0.45), (5.0, 0.48)])
def test_reference_curves_on_default_mesh(reference_curves, E, nu):
    depth, force_ref = reference_curves[(E, nu)]
    curve = simulate(NeoHooke(E, nu), SphericalIndenter(R), depth)
    err = curve.force_mN / force_ref - 1
    print(f"E={E} nu={nu}: max |err| h>=0.1: {np.abs(err[depth >= 0.1]).max():.2e}, "
          f"h>=0.05: {np.abs(err[depth >= 0.05]).max():.2e}; {curve.report.summary()}")
    assert np.abs(err[depth >= 0.1]).max() < 0.005
    assert np.abs(err[depth >= 0.05]).max() < 0.01
    assert curve.report.max_penetration_ratio < 1e-3  # penetration below 0.1% of the depth


def test_force_is_exactly_proportional_to_E():
    d = np.linspace(0.02, 0.3, 8)
    f1 = simulate(NeoHooke(3.7, 0.42), SphericalIndenter(R), d, mesh="coarse").force_mN
    f2 = simulate(NeoHooke(7.4, 0.42), SphericalIndenter(R), d, mesh="coarse").force_mN
    assert np.abs(f2 / (2 * f1) - 1).max() < 1e-8


def test_interpolated_curve_equals_direct_solves():
    """The default mesh: interpolating between the solved increments costs less than its roughness."""
    d = np.linspace(0.06, 0.6, 10)
    law, ind = NeoHooke(8.0, 0.45), SphericalIndenter(R)
    fast = simulate(law, ind, d)
    direct = simulate(law, ind, d, solve_at_outputs=True)
    assert fast.solved_depth_mm.size == DEFAULT_INCREMENTS and direct.solved_depth_mm.size == d.size
    err = np.abs(fast.force_mN / direct.force_mN - 1)
    print("interpolated vs direct:", np.round(err, 5))
    assert err.max() < 1e-3


def test_solid_tangent_reuses_the_kinematics_of_the_residual(coarse_problem):
    """Newton evaluates the residual first and the tangent only when it goes on: same matrices."""
    prob = coarse_problem
    u = smooth_displacement(prob)
    f, Ke = prob.solid.forces(u)
    f2, none = prob.solid.forces(u, tangent=False)
    assert none is None and np.array_equal(f, f2)
    assert np.array_equal(prob.solid.tangent(u), Ke)
    v = smooth_displacement(prob, seed=3)
    assert np.array_equal(prob.solid.tangent(v), prob.solid.forces(v)[1])  # another u: recomputed


def test_not_a_knot_spline_is_scipys_cubic_spline():
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(4)
    for n in (2, 3, 4, 5, 12, 30):
        x = np.cumsum(rng.uniform(0.1, 1.0, n))
        y = rng.standard_normal(n)
        xi = np.linspace(x[0], x[-1], 97)
        ref = CubicSpline(x, y, bc_type="not-a-knot")(xi)
        assert np.abs(not_a_knot_spline(x, y, xi) - ref).max() <= 1e-12 * np.abs(ref).max()


def test_solver_statistics_count_the_linear_algebra():
    curve = simulate(NeoHooke(10.0, 0.4), SphericalIndenter(R), 0.6, 100, mesh="coarse")
    rep = curve.report
    assert rep.tangents + rep.modified_steps == rep.total_iterations
    assert 1 <= rep.factorisations <= rep.tangents + rep.modified_steps
    assert rep.factorisations + rep.preconditioned_solves >= rep.total_iterations


def test_factorisations_reuse_the_ordering_of_the_pattern(coarse_problem):
    """Tangents of one pattern are factorised in the minimum-degree order of the first: same solutions."""
    from scipy.sparse.linalg import splu

    from skin_indent.mechanics.linear import SymmetricOrdering

    prob = coarse_problem
    ordering = SymmetricOrdering()
    rng = np.random.default_rng(5)
    for seed, depth in ((1, 0.3), (2, 0.6), (3, 0.45)):
        u = smooth_displacement(prob, seed=seed)
        prob._residual(u, depth)
        K = prob._tangent(u, depth)
        b = rng.standard_normal(K.shape[0])
        first = ordering._pattern is None
        lu = ordering.factorise(K)
        assert (type(lu).__name__ == "SuperLU") == first  # later ones: the stored order, natural ordering
        x = lu.solve(b)
        ref = splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True}).solve(b)
        assert np.abs(x - ref).max() <= 1e-9 * np.abs(ref).max()
        assert np.abs(K @ x - b).max() <= 1e-8 * np.abs(b).max()
    # another pattern: a new ordering
    K2 = K[:-1, :-1].tocsr()
    lu2 = ordering.factorise(K2)
    assert type(lu2).__name__ == "SuperLU"
    assert np.abs(K2 @ lu2.solve(b[:-1]) - b[:-1]).max() <= 1e-8 * np.abs(b).max()


def test_a_tangent_whose_contact_set_moved_is_factorised_at_once(monkeypatch):
    """When more than REFACTORISE_AFTER_CONTACT_CHANGES contact points changed state since the stored
    factorisation, the new tangent is factorised without a (mostly failing) preconditioned attempt, and the
    curve is the same. The decision is checked on constructed contact sets, the solver's two paths on one
    tangent, and the wiring on real curves; how many LU applications it saves (a count that depends on
    the floating-point path) is measured by benchmarks/solver_counts.py."""
    import skin_indent.mechanics.solver as solver_module
    from skin_indent.mechanics.linear import TangentSolver

    threshold = solver_module.REFACTORISE_AFTER_CONTACT_CHANGES
    prob = IndentationProblem(graded_mesh(R, 0.6, "coarse"), NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6)
    # the decision: more than `threshold` points entering or leaving contact since the stored factors
    n = prob.contact.state(np.zeros(prob.n_dofs), 0.3).pressure_kPa.size
    assert n > 40 + threshold + 1
    stored = np.zeros(n, dtype=bool)
    stored[:40] = True
    entered, few, left = stored.copy(), stored.copy(), stored.copy()
    entered[40:41 + threshold] = True
    few[40:40 + threshold] = True
    left[:threshold + 1] = False
    prob._factorised = (prob.linear_solver.factorisations, stored)
    assert prob._contact_set_moved(entered) and prob._contact_set_moved(left)
    assert not prob._contact_set_moved(few) and not prob._contact_set_moved(stored)
    assert not prob._contact_set_moved(None)  # friction, adhesion: no hint
    prob._factorised = (prob.linear_solver.factorisations + 1, stored)  # factors replaced since: not these
    assert not prob._contact_set_moved(entered)
    prob._factorised = None  # nothing factorised in Newton yet
    assert not prob._contact_set_moved(entered)

    # the solver: refactorise=True skips the preconditioned attempt that a stored factorisation gets otherwise
    u = smooth_displacement(prob)
    prob._residual(u, 0.3)
    K = prob._tangent(u, 0.3)
    b = np.random.default_rng(6).standard_normal(K.shape[0])
    solver = TangentSolver()
    solver.solve(K, b)
    assert (solver.factorisations, solver.preconditioner_applications) == (1, 0)
    solver.solve(K, b)  # preconditioned with the stored factors
    assert solver.preconditioner_applications > 0
    applied, factorised = solver.preconditioner_applications, solver.factorisations
    x_fresh = solver.solve(K, b, refactorise=True)
    assert solver.factorisations == factorised + 1 and solver.preconditioner_applications == applied
    assert np.abs(K @ x_fresh - b).max() <= 1e-8 * np.abs(b).max()

    # the wiring: every decision of a Newton iteration reaches the linear solve that follows it
    events = []
    decide, solve = IndentationProblem._contact_set_moved, TangentSolver.solve

    def recorded_decision(self, active):
        moved = decide(self, active)
        events.append(("decision", moved))
        return moved

    def recorded_solve(self, K, b, rtol=None, refactorise=False):
        events.append(("solve", refactorise))
        return solve(self, K, b, rtol=rtol, refactorise=refactorise)

    monkeypatch.setattr(IndentationProblem, "_contact_set_moved", recorded_decision)
    monkeypatch.setattr(TangentSolver, "solve", recorded_solve)
    curves = {}
    for value in (threshold, 10**9, -1):  # -1: every tangent after a factorisation in Newton counts as moved
        monkeypatch.setattr(solver_module, "REFACTORISE_AFTER_CONTACT_CHANGES", value)
        events.clear()
        curves[value] = simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6, 100, mesh="coarse")
        decisions = [i for i, (kind, _) in enumerate(events) if kind == "decision"]
        assert decisions and all(events[i + 1] == ("solve", events[i][1]) for i in decisions)
        if value == -1:
            assert any(events[i][1] for i in decisions)
        if value == 10**9:
            assert not any(events[i][1] for i in decisions)
    hinted, plain, always = curves.values()
    assert np.abs(hinted.force_mN / plain.force_mN - 1).max() < 1e-5  # the Newton tolerance
    assert np.abs(always.force_mN / plain.force_mN - 1).max() < 1e-5


def test_hertz_start_and_modified_newton_leave_the_solution_unchanged(monkeypatch):
    """The first increment from Hertz's shape and the modified-Newton steps change the path, not the answer.

    Hertz's shape is checked as a first iterate (close to the converged state, where the zero field is
    100 % off); the Newton iterations it saves are measured by benchmarks/solver_counts.py."""
    import skin_indent.mechanics.solver as solver_module
    from skin_indent.mechanics.predictor import hertz_start

    starts = []

    def recorded_start(problem, depth):
        starts.append(depth)
        return hertz_start(problem, depth)

    monkeypatch.setattr(solver_module, "hertz_start", recorded_start)
    law, ind, d = NeoHooke(8.0, 0.45), SphericalIndenter(R), np.geomspace(0.006, 0.6, 8)
    imesh = graded_mesh(R, 0.6, "coarse")
    fast = IndentationProblem(imesh, law, ind, 0.6)
    F_fast, _, rep = fast.solve(d)
    assert starts == [d[0]]  # the first increment, and only it, starts from Hertz's shape
    plain = IndentationProblem(imesh, law, ind, 0.6, modified_below=0.0)
    F_plain, _, rep_plain = plain.solve(d, predictor="linear")  # zero first iterate, full Newton
    assert starts == [d[0]]
    assert np.abs(F_fast / F_plain - 1).max() < 1e-6
    assert rep.modified_steps > 0 and rep_plain.modified_steps == 0
    u0 = hertz_start(fast, 0.01)  # the surface on the axis sits at the sphere's tip
    assert np.isclose(u0[fast.axis_top_dof], -0.01) and np.all(u0[~fast.free] == 0)
    # a first iterate near the converged first increment (measured: 3.4 % off)
    _, u1, _ = IndentationProblem(imesh, law, ind, 0.6).solve(d[:1])
    assert np.linalg.norm(hertz_start(fast, d[0]) - u1) < 0.1 * np.linalg.norm(u1)


def test_surface_fit_puts_a_lifted_contact_zone_back_against_the_sphere():
    """A prediction that lifts the contact zone off the sphere has it moved back to the converged
    penetration scaled with the depth; the rest of the surface, the Dirichlet dofs, predictions that
    keep the zone and unloading steps are left alone."""
    prob = IndentationProblem(graded_mesh(R, 0.6, "coarse"), NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6)
    _, u, _ = prob.solve([0.15, 0.3])
    fit = prob._surface_fit
    before = fit._penetration(u, 0.3)
    touching = before > 0
    assert 10 < touching.sum() < touching.size / 2
    lifted = u.copy()
    lifted[fit._uz] -= 0.05  # the sphere goes 0.03 mm deeper, the body 0.05 mm: every point lifts off
    assert np.all(fit._penetration(lifted, 0.33) < 0)
    fitted = fit(lifted.copy(), u, 0.3, 0.33)
    after = fit._penetration(fitted, 0.33)
    assert np.allclose(after[touching], 1.1 * before[touching], rtol=1e-9, atol=1e-12)
    assert np.array_equal(fitted[fit._top_z][~touching], lifted[fit._top_z][~touching])
    assert np.all(fitted[~prob.free] == 0)
    changed = np.flatnonzero(fitted != lifted)
    assert np.all(np.isin(changed, fit._uz))  # vertical corrections only
    kept = u.copy()
    kept[fit._uz] -= 0.03  # the body follows the sphere: the contact zone stays
    assert np.array_equal(fit(kept.copy(), u, 0.3, 0.33), kept)
    assert np.array_equal(fit(lifted.copy(), u, 0.3, 0.27), lifted)  # unloading


@pytest.mark.parametrize("kw", [{}, {"interfaces_mm": (1.0,), "rigid_base_mm": 3.0}])
def test_points_are_located_by_walking_from_nearby_triangles(kw):
    """The similarity predictor's point location: each scaled node is found in a triangle that
    holds it (coordinates reproduce the point), equal to testing every triangle; a point outside
    the mesh gets clipped coordinates in a boundary triangle."""
    from skfem import Basis, ElementTriP2

    from skin_indent.mechanics.predictor import _barycentric, locate

    mesh = graded_mesh(R, 0.6, "coarse", **kw).mesh
    scalar = Basis(mesh, ElementTriP2(), intorder=1)
    own = np.empty(scalar.N, dtype=np.int64)
    own[scalar.element_dofs] = np.arange(mesh.t.shape[1])
    pts = scalar.doflocs / np.sqrt(1.5)
    elem, lam = locate(mesh, pts, own)
    assert np.all(lam >= 0) and np.allclose(lam.sum(axis=0), 1.0)
    back = sum(lam[i] * mesh.p[:, mesh.t[i, elem]] for i in range(3))
    assert np.allclose(back, pts, rtol=0, atol=1e-9 * np.abs(mesh.p).max())
    k = np.argsort(-np.hypot(*pts))[:20]  # far points: many triangles from where their walks start
    every = np.array([_barycentric(mesh.p, mesh.t, np.arange(mesh.t.shape[1]),
                                   np.repeat(pts[:, [j]], mesh.t.shape[1], axis=1)).min(axis=0).max() for j in k])
    assert np.all(every >= -1e-12)  # each is inside some triangle, and the walk found one
    outside = np.array([[mesh.p[0].max() * 2.0], [-1.0]])
    e, l_out = locate(mesh, outside, np.array([0]))
    assert np.all(l_out >= 0) and np.isclose(l_out.sum(), 1.0)
    assert np.any(mesh.f2t[1, mesh.t2f[:, e[0]]] < 0)  # it ends in a boundary triangle


def test_force_depth_curve_is_smooth():
    """Quadrature-integrated contact: no steps when quadrature points enter contact."""
    curve = simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6, 100)
    h, F = curve.solved_depth_mm, curve.solved_force_mN
    sel = h >= 0.05
    x = np.sqrt(h[sel])
    ratio = F[sel] / h[sel] ** 1.5
    fit = np.polyval(np.polyfit(x, ratio, 5), x)
    assert np.abs(ratio / fit - 1).max() < 1e-3  # node-by-node contact: 0.5-0.8% steps
    assert np.all(np.diff(curve.force_mN) > 0)


def test_newton_statistics_and_penetration():
    """Every solved increment meets the tolerance; the penetration stays small. (Step cuts and Newton
    iterations per increment depend on the floating-point path: benchmarks/solver_counts.py.)"""
    curve = simulate(NeoHooke(10.0, 0.4), SphericalIndenter(R), 0.6, 100, mesh="coarse")
    rep = curve.report
    assert curve.solved_depth_mm.size == DEFAULT_INCREMENTS
    assert rep.increments == len(rep.iterations) == len(rep.residuals) >= DEFAULT_INCREMENTS
    assert max(rep.residuals) <= RTOL
    assert rep.max_penetration_ratio < 1e-3


def test_clear_error_when_newton_cannot_converge():
    prob = IndentationProblem(graded_mesh(R, 0.6, "coarse"), NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6,
                              max_iterations=1, max_cuts=1)
    with pytest.raises(ConvergenceError, match=r"did not converge at depth .* after 1 step cuts"):
        prob.solve([0.3, 0.6])


def test_fields_are_written_with_meshio(tmp_path):
    import meshio

    curve = simulate(NeoHooke(10.0, 0.4), SphericalIndenter(R), 0.3, 5, mesh="coarse", keep_state=True)
    path = curve.write_vtu(tmp_path / "fields.vtu")
    m = meshio.read(path)
    assert m.cells[0].type == "triangle6"
    vm = m.cell_data["von_mises_kPa"][0]
    p = m.point_data["contact_pressure_kPa"]
    assert np.all(vm >= 0) and vm.max() > 0
    # the resultant of the nodal pressures is of the order of the force (area weights aside)
    assert p.max() > 0 and np.count_nonzero(p) >= 3
    uz = m.point_data["displacement_mm"][:, 1]
    assert np.isclose(uz.min(), -0.3, rtol=0.01)  # the pole follows the sphere


def test_mesh_files_are_what_the_generator_builds():
    for name in ("coarse", "medium", "fine"):
        stored = load_mesh(ROOT / "meshes" / f"{name}.vtu")
        built = graded_mesh(R, 0.6, name)
        assert np.array_equal(stored.mesh.t, built.mesh.t)
        assert np.abs(stored.mesh.p - built.mesh.p).max() < 1e-12 * built.extent_mm


def test_mesh_file_and_generated_mesh_give_the_same_curve():
    law, ind = NeoHooke(8.0, 0.45), SphericalIndenter(R)
    a = simulate(law, ind, 0.6, 10, mesh="coarse")
    b = simulate(law, ind, 0.6, 10, mesh=ROOT / "meshes" / "coarse.vtu")
    assert "read from file" in b.mesh_name and "generated" in a.mesh_name
    assert np.allclose(a.force_mN, b.force_mN, rtol=1e-10)


@pytest.mark.parametrize("kwargs, match", [
    (dict(depth_mm=0.0), "depth must be"), (dict(depth_mm=-0.1), "depth must be"),
    (dict(depth_mm=float("nan")), "depth must be"), (dict(points=1), "points must be"),
    (dict(depth_mm=[0.1, 0.05]), "strictly increasing"), (dict(depth_mm=[0.1, float("nan")]), "finite"),
    (dict(mesh="huge"), "unknown mesh"), (dict(increments=1), "increments must be"),
])
def test_bad_simulation_input(kwargs, match):
    args = dict(depth_mm=0.6, points=10, mesh="coarse") | kwargs
    with pytest.raises(ValueError, match=match):
        simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), **args)


@pytest.mark.parametrize("radius", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_radius(radius):
    with pytest.raises(ValueError, match="radius"):
        SphericalIndenter(radius)


@pytest.mark.slow
def test_mesh_convergence_over_the_family_and_uniform_refinement(reference_curves):
    """Force at 0.6 mm over the family, and the observed order under uniform refinement."""
    law, ind = NeoHooke(8.0, 0.45), SphericalIndenter(R)
    family = {m: simulate(law, ind, [0.3, 0.6], mesh=m, solve_at_outputs=True).force_mN[-1]
              for m in ("coarse", "medium", "fine")}
    print("F(0.6 mm) over the family:", family)
    assert max(family.values()) / min(family.values()) - 1 < 5e-4
    from skin_indent.mechanics.mesh import IndentationMesh

    base = graded_mesh(R, 0.6, "coarse")
    forces = []
    for k in range(3):
        m = base.mesh.refined(k) if k else base.mesh
        im = IndentationMesh(_named(m, base.extent_mm),
                             f"coarse refined {k}x", base.contact_radius_mm, base.surface_size_mm / 2**k,
                             base.extent_mm)
        forces.append(simulate(law, ind, [0.3, 0.6], mesh=im, solve_at_outputs=True).force_mN[-1])
    d1, d2 = abs(forces[0] - forces[1]), abs(forces[1] - forces[2])
    order = np.log2(d1 / d2)
    print(f"uniform refinement F(0.6): {forces}; changes {d1 / forces[2]:.1e}, {d2 / forces[2]:.1e} (relative); "
          f"observed order {order:.1f} (the second change is at the Newton tolerance, so this is a lower bound)")
    assert abs(forces[2] / reference_curves[(8.0, 0.45)][1][-1] - 1) < 0.005
    assert d2 < d1 / 4  # at least second order


def _named(mesh, L):
    from skin_indent.mechanics.mesh import with_named_boundaries

    return with_named_boundaries(mesh, L)
