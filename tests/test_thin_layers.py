"""Thin layers bonded to a rigid base (a cell or a gel on glass under an AFM sphere).

References:

- **The exact small-strain solution** of a paraboloid pressed into a layer of thickness T
  bonded to a rigid base, computed here (:func:`bonded_layer_contact`): the layer's surface
  compliance in Hankel space, :math:`\\bar w(\\xi) = 2\\bar p(\\xi) C(\\xi T)/(E^* \\xi)` with
  :math:`C(x) = (2\\kappa \\sinh 2x - 4x)/(2\\kappa \\cosh 2x + 4x^2 + 1 + \\kappa^2)`,
  :math:`\\kappa = 3 - 4\\nu` (1 for a half-space, :math:`x(1-2\\nu)/(2(1-\\nu)^2)` for
  :math:`x \\to 0`: the confined compression :math:`w = pT/M`), and the pressure expanded in
  :math:`(1 - r^2/a^2)^{k+1/2}` (smooth at the contact edge), collocated on the paraboloid
  inside the contact. The half-space part of each term is Galin's polynomial (by the method
  of dimensionality reduction), the layer's correction an integral of a kernel decaying like
  :math:`e^{-2\\xi T}`. Converged to ~4e-6 in F/h^1.5 (more terms, points and samples).
- **Dimitriadis et al., Biophys. J. 82 (2002) 2798-2810**, the bonded-sample correction
  :func:`skin_indent.mechanics.analytic.dimitriadis_bonded_force` (:math:`\\chi = \\sqrt{Rh}/T`; at
  nu = 0.5: 1 + 1.133 chi + 1.283 chi^2 + 0.769 chi^3 + 0.0975 chi^4). It is an asymptotic
  series cut after chi^4 with its coefficients fitted as functions of nu, so its error grows
  with chi: against the exact solution above it is 0.8-1.4 % low at chi = 0.23, 2-4 % at 0.35,
  4-7 % at 0.46, 8-12 % at 0.6 and 12-20 % at chi = 0.8 (nu = 0.3-0.49). Our force is checked
  against the exact solution (1 %) and against the series within the series' own error.
"""

from math import comb, gamma

import numpy as np
import pytest
from scipy.special import beta, jv

from skin_indent.mechanics.analytic import dimitriadis_bonded_force, hertz_force
from skin_indent.effects import Model, effect
from skin_indent.mechanics import LinearElastic, NeoHooke, SphericalIndenter
from skin_indent.mechanics.layers import RIGID, SQUEEZE_FROM, Layer, LayeredSample
from skin_indent.mechanics.mesh import graded_mesh
from skin_indent.mechanics.layers import CONFINED_FLOOR, ConfinedPenalty
from skin_indent.mechanics.solver import IndentationProblem
from skin_indent.simulate import simulate


def bonded_layer_contact(a_mm, radius_mm, thickness_mm, nu, terms=6, points=40, samples=4000):
    """Depth (mm) and force per unit E* (mN/kPa) of a paraboloid of radius R on a bonded layer, small
    strain, frictionless, at the contact radius ``a_mm`` (see the module docstring)."""
    kappa = 3.0 - 4.0 * nu
    xi = np.linspace(0.0, 30.0 / thickness_mm, samples + 1)  # 1/mm; the kernel is exp(-60) at the end
    w = np.full(xi.size, xi[1])  # trapezoid weights
    w[[0, -1]] *= 0.5
    x = xi * thickness_mm
    D = -(2 * kappa * np.exp(-2 * x) + 4 * x + 4 * x**2 + 1 + kappa**2) / (
        2 * kappa * np.cosh(2 * x) + 4 * x**2 + 1 + kappa**2)  # C(x) - 1
    a = a_mm
    r = a * np.sin(np.linspace(0.0, 0.5 * np.pi, points, endpoint=False))  # collocation, dense at the edge
    J0 = jv(0, np.outer(r, xi)) * (D * w)
    z = np.where(xi > 0, xi * a, 1.0)
    A = np.empty((points, terms + 1))
    for k in range(terms):
        mu = k + 0.5
        # half-space: (1 - r^2/a^2)^mu gives a polynomial displacement inside the contact
        odd = np.cumprod([1.0] + [(2 * j - 1) / (2 * j) for j in range(1, k + 2)])
        half_space = a * beta(0.5, k + 1.5) * sum(comb(k + 1, j) * (-1) ** j * (r / a) ** (2 * j) * odd[j]
                                                  for j in range(k + 2))
        # Hankel transform of (1 - r^2/a^2)^mu (Sonine), its limit at xi = 0
        P = a**2 * 2**mu * gamma(mu + 1) * np.where(xi > 0, jv(mu + 1, z) / z ** (mu + 1),
                                                    1.0 / (2 ** (mu + 1) * gamma(mu + 2)))
        A[:, k] = half_space + 2.0 * J0 @ P
    A[:, terms] = -1.0  # minus the depth
    sol = np.linalg.lstsq(A, -r**2 / (2 * radius_mm), rcond=None)[0]
    force = np.pi * a**2 * sum(sol[k] / (k + 1.5) for k in range(terms))
    return float(sol[terms]), float(force)


def test_the_exact_layer_solution_tends_to_hertz_and_to_the_confined_layer():
    h, F = bonded_layer_contact(0.01, 1.0, 10.0, 0.45)  # a layer 1000 contact radii thick: Hertz
    assert h == pytest.approx(1e-4, rel=1e-3)
    assert F == pytest.approx(4.0 / 3.0 * h**1.5, rel=2e-3)  # per unit E*, R = 1
    # thinner layers are stiffer; nu -> 0.5 stiffens a confined layer
    f = [bonded_layer_contact(0.05, 1.0, 0.1, nu) for nu in (0.3, 0.45, 0.49)]
    per_E = [F / h**1.5 / (1 - nu**2) for (h, F), nu in zip(f, (0.3, 0.45, 0.49))]
    assert per_E[0] < per_E[1] < per_E[2]


@pytest.mark.parametrize("nu", [0.3, 0.49])
def test_thin_bonded_layer_against_the_exact_solution_and_dimitriadis(nu):
    """Small strain (R = 1 mm, T = 0.1 mm, h/R <= 0.01), chi = sqrt(R h)/T from 0.23 to 1.0, coarse
    mesh. Measured: within 0.5 % of the exact solution (coarse; medium 0.3 %); the Dimitriadis
    series is low by its truncation error, which the FE reproduces (see the module docstring)."""
    R, T, E = 1.0, 0.1, 10.0
    a = T * np.array([0.3, 0.45, 0.6, 0.75, 0.9, 1.1, 1.4])
    exact = np.array([bonded_layer_contact(ai, R, T, nu) for ai in a])
    depth, F_exact = exact[:, 0], exact[:, 1] * E / (1 - nu**2)
    chi = np.sqrt(R * depth) / T
    curve = simulate(LayeredSample((Layer(T, LinearElastic(E, nu)),), RIGID), SphericalIndenter(R), depth,
                     mesh="coarse")
    fe = curve.force_mN / F_exact - 1
    series = F_exact / dimitriadis_bonded_force(depth, E, nu, R, T) - 1
    print(f"nu = {nu}: chi {np.round(chi, 3)}\n  FE/exact - 1 {np.round(fe, 4)}\n  exact/Dimitriadis - 1 "
          f"{np.round(series, 4)}\n  FE/Hertz {np.round(curve.force_mN / hertz_force(depth, E, nu, R), 3)}")
    assert chi[0] < 0.3 and chi[-1] > 0.95
    # the exact force to 1 %: the coarse mesh's discretisation error (the layer stiffens the contact 1.3-4.8x)
    assert np.abs(fe).max() < 0.01
    # Dimitriadis: low by its truncation error (exact/Dimitriadis - 1: 1-3 % at chi = 0.3, 15-22 % at 1), so
    # within 3.5 % below chi = 0.3, within 1 % + chi / 4 beyond, and increasingly low
    mismatch = curve.force_mN / dimitriadis_bonded_force(depth, E, nu, R, T) - 1
    assert np.all(np.abs(mismatch[chi < 0.3]) < 0.035)
    assert np.all((mismatch > -0.01) & (mismatch < 0.01 + chi / 4)) and np.all(np.diff(mismatch) > 0)


@pytest.mark.parametrize("radius_mm, thickness_mm, depth_mm, nu", [
    (1.0, 0.1, 0.09, 0.49),     # squeezed to 10 % of its thickness (h/T = 0.9)
    (0.005, 0.003, 0.0012, 0.49),  # the AFM case: a 3 um cell on glass, R = 5 um, 1.2 um deep (h/R = 0.24)
])
def test_a_layer_squeezed_on_a_rigid_base_solves(radius_mm, thickness_mm, depth_mm, nu):
    """Before the penalty followed the squeezed layer, h/T = 0.9 stopped at 0.83 on the coarse mesh
    (a surface mode on the soft penalty made the tangent indefinite) and the penetration reached
    0.2-0.4 % of the depth at h/T = 0.5."""
    sample = LayeredSample((Layer(thickness_mm, NeoHooke(1.0, nu)),), RIGID)
    curve = simulate(sample, SphericalIndenter(radius_mm), depth_mm, 20, mesh="coarse")
    F = curve.force_mN
    print(f"h/T = {depth_mm / thickness_mm:.2f}: F/F_Hertz {F[-1] / hertz_force(depth_mm, 1.0, nu, radius_mm):.3f}; "
          f"{curve.report.summary()}")
    assert np.all(np.isfinite(F)) and np.all(np.diff(F) > 0)
    assert F[-1] > hertz_force(depth_mm, 1.0, nu, radius_mm)  # the base stiffens
    assert curve.report.max_penetration_ratio < 2e-3  # as on a half-space (~1e-3)


def test_the_penalty_follows_the_squeezed_layer_only_where_it_is_stiffer_than_a_half_space():
    # a thick layer (the independent code's 3 mm on a rigid base, to 0.6 mm): the half-space's penalty,
    # factor exactly 1 (its results are those of the model before)
    thick = LayeredSample((Layer(3.0, NeoHooke(6.0, 0.45)),), RIGID)
    s = ConfinedPenalty(thick, 6.22, 6.0)
    assert all(s(h) == 1.0 for h in np.linspace(0.0, 0.6, 61))
    # a thin one: above 1 from some depth on, growing as the layer thins, bounded at the floor
    thin = LayeredSample((Layer(0.1, NeoHooke(1.0, 0.49)),), RIGID)
    s = ConfinedPenalty(thin, 1.0, 1.0)
    f = np.array([s(h) for h in np.linspace(0.0, 0.1, 101)])
    assert f[0] == 1.0 and f[50] > 5 and np.all(np.diff(f) >= 0)
    floor = 0.1 * (1 - CONFINED_FLOOR)  # beyond, the remaining thickness is held: the factor grows as sqrt(h)
    assert f[-1] == pytest.approx(s(floor) * np.sqrt(0.1 / floor), rel=1e-12)
    # the problem uses it for layers on a rigid base with frictionless contact only
    prob = IndentationProblem(graded_mesh(1.0, 0.05, "coarse", rigid_base_mm=0.1), thin, SphericalIndenter(1.0), 0.05)
    assert prob.contact.penalty(0.05) == pytest.approx(prob.contact.epsilon * s(0.05))
    over = LayeredSample((Layer(0.1, NeoHooke(1.0, 0.49)),), NeoHooke(10.0, 0.49))
    prob = IndentationProblem(graded_mesh(1.0, 0.05, "coarse", interfaces_mm=(0.1,)), over, SphericalIndenter(1.0),
                              0.05)
    assert prob.penalty_scale is None and prob.contact.penalty(0.05) == prob.contact.epsilon


def test_a_squeezed_layer_is_solved_at_extra_depths_near_the_base():
    """The force of a layer pressed to h/T = 0.83 grows like a power of 1/(T - h): between 12
    geometric depths the spline of F / h^1.5 was 1 % off near the end; with the extra depths of
    squeeze_depths_mm (uniform in log(T - h) beyond h/T = 0.4) it follows direct solves."""
    T, h_max = 1.2, 1.0
    sample = LayeredSample((Layer(T, NeoHooke(1.0, 0.49)),), RIGID)
    extra = sample.squeeze_depths_mm(h_max)
    assert extra[0] == pytest.approx(SQUEEZE_FROM * T) and np.all(extra < h_max)
    steps = np.diff(np.log(T - np.r_[extra, h_max]))  # uniform in log(T - h), at most 0.25
    assert np.all(steps < 0) and steps.min() > -0.251 and np.ptp(steps) < 1e-9
    assert sample.squeeze_depths_mm(0.4 * T).size == 0
    assert LayeredSample((Layer(T, NeoHooke(1.0, 0.49)),), NeoHooke(9.0, 0.49)).squeeze_depths_mm(h_max).size == 0
    R = 2.0
    d = np.linspace(0.01, h_max, 100)
    curve = simulate(sample, SphericalIndenter(R), d, mesh="coarse")
    check = d[[59, 69, 79, 89, 94]]  # h/T = 0.5-0.8
    direct = simulate(sample, SphericalIndenter(R), check, mesh="coarse", solve_at_outputs=True)
    err = curve.force_mN[[59, 69, 79, 89, 94]] / direct.force_mN - 1
    print(f"spline vs direct at h/T = {np.round(check / T, 2)}: {np.round(err, 5)}")
    assert np.abs(err).max() < 2e-3


def test_sensitivity_to_nu_where_the_penalty_follows_the_layer():
    """dF/dnu by direct differentiation includes the confined modulus' dependence on nu in the
    penalty: against a fourth-order central difference of direct solves (the factor is 1.3-1.7 there)."""
    R, T, depths = 1.0, 0.1, np.array([0.04, 0.05])

    def force(nu, sens=False):
        sample = LayeredSample((Layer(T, NeoHooke(1.0, nu)),), RIGID)
        return simulate(sample, SphericalIndenter(R), depths, solve_at_outputs=True, mesh="coarse", rtol=3e-11,
                        sensitivities=sens)

    nu, step = 0.45, 1e-3
    assert ConfinedPenalty(LayeredSample((Layer(T, NeoHooke(1.0, nu)),), RIGID), R, 1.0).active(depths[0])
    d = force(nu, True).sensitivities[0, "nu"]
    F = {m: force(nu + m * step).force_mN for m in (-2, -1, 1, 2)}
    fd = (-F[2] + 8 * F[1] - 8 * F[-1] + F[-2]) / (12 * step)
    print(f"dF/dnu {d}, finite differences {fd}")
    assert np.abs(d / fd - 1).max() < 1e-4


def test_the_layer_effect_reaches_thin_layers():
    """The layer's surfaces start at 1.2 depths (a rigid base squeezed to h/T = 0.83); thicknesses of AFM
    samples are admissible; a layer inserted above a thin fitted one keeps 5 % of it."""
    layer = effect("layer")
    axes = layer.surface_axes(0.0016)
    assert axes[0].name == "thickness_mm" and axes[0].nodes[0] == pytest.approx(1.2 * 0.0016)
    assert layer.fe_bounds(0.0016)["thickness_mm"][0] == pytest.approx(1.2 * 0.0016)
    theta = {"E_kPa": 1.0, "nu": 0.45, "thickness_mm": 0.003, "ratio": np.inf}
    assert Model(("layer",), 0.005).check(theta)["thickness_mm"] == 0.003
    assert layer.insert([{"thickness_mm": 0.004, "compliance": 0.0}], 0, {"thickness_mm": 0.002, "compliance": 4.0}) \
        == [{"thickness_mm": 0.002, "compliance": 4.0}, {"thickness_mm": pytest.approx(0.002), "compliance": 0.0}]
    assert layer.insert([{"thickness_mm": 0.004, "compliance": 0.0}], 0, {"thickness_mm": 0.0039, "compliance": 4.0}) \
        is None
