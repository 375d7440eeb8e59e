"""Newton's convergence criterion: a relative residual with a floor at the attainable precision.

The decision (:func:`~skin_indent.mechanics.convergence.newton_converged`) is checked on synthetic
residual and increment histories, which do not depend on the floating-point path; the floor
(:meth:`~skin_indent.mechanics.solver.IndentationProblem.roundoff_floor`) against the round-off
the contact forces really carry (recomputed in extended precision); and whole solves with a
tolerance no float64 state can meet, which converge on any CPU to the forces of a reachable one.
"""

from __future__ import annotations

import numpy as np
import pytest

from skin_indent import simulate
from skin_indent.mechanics import IndentationProblem, NeoHooke, SphericalIndenter, graded_mesh
from skin_indent.mechanics.layers import RIGID, Layer, LayeredSample
from skin_indent.mechanics.convergence import EPS, newton_converged

R = 6.22


# ----------------------------------------------------------------- the decision, synthetic
def test_the_residual_criterion_is_unchanged():
    assert newton_converged(1e-6, 1e-6) == "residual"
    assert newton_converged(1e-6 * (1 + 1e-15), 1e-6) is None
    # below rtol the increment and the floor play no part
    assert newton_converged(1e-7, 1e-6, floor=0.0, increment=1.0) == "residual"
    assert newton_converged(np.nan, 1e-6, floor=1.0, increment=0.0) is None
    assert newton_converged(np.inf, 1e-6, floor=np.inf, increment=0.0) is None


def test_round_off_needs_the_floor_and_a_negligible_increment():
    rtol, floor = 3e-11, 5e-10
    assert newton_converged(8e-11, rtol, floor) is None  # no increment computed yet: residual only
    assert newton_converged(8e-11, rtol, floor, increment=5e-13) == "round-off"
    assert newton_converged(6e-10, rtol, floor, increment=5e-13) is None  # above the floor: go on
    # a residual within the round-off that still moves the state (a soft mode): go on
    assert newton_converged(8e-11, rtol, floor, increment=1e-6) is None
    # an increment within the floor counts as negligible when rtol is below it
    assert newton_converged(8e-11, 1e-14, floor, increment=2e-12) == "round-off"
    assert newton_converged(8e-11, rtol, 0.0, increment=0.0) is None  # no floor: rtol alone


def _first_converged(history, rtol, floor):
    """Index of the first iterate of a (relative residual, relative increment) history that converges."""
    return next((i for i, (rel, inc) in enumerate(history) if newton_converged(rel, rtol, floor, inc)), None)


@pytest.mark.parametrize("seed", range(5))
def test_a_residual_stagnating_at_round_off_converges_whatever_the_noise(seed):
    """Quadratic convergence down to round-off, then noise: as measured on two OpenBLAS kernels for a
    0.3 mm layer on a rigid base (stagnation at 3-15e-11 with rtol 3e-11, which failed on one of them).
    Whatever the noise's values and order, the first iterate at the floor is accepted."""
    rng = np.random.default_rng(seed)
    converging = [(1.0, 0.5), (3e-3, 1e-3), (2e-7, 5e-8), (4e-9, 2e-11)]
    noise = list(zip(rng.uniform(3.1e-11, 1.5e-10, 20), rng.uniform(1e-13, 2e-12, 20)))
    floor = 4.8e-10  # the floor of that state (roundoff_floor / reference)
    assert _first_converged(converging + noise, 3e-11, floor) == len(converging)
    # on the residual alone it never converges (the ConvergenceError such solves raised before)
    assert _first_converged(converging + noise, 3e-11, 0.0) is None


# ----------------------------------------------------------------- the floor, from the problem
def _contact_force_extended(contact, u, depth):
    """The frictionless contact force vector (mN) of ``u`` computed in extended precision."""
    L = np.longdouble
    x = contact.X.astype(L)
    ue = u[contact.element_dofs].astype(L)
    for k in range(contact.N.shape[0]):
        x[contact.comp[k]] += contact.N[k].astype(L) * ue[k][:, None]
    Rl = L(contact.indenter.radius_mm)
    d = np.stack([x[0], x[1] - (Rl - L(depth))])
    dist = np.sqrt(d[0] ** 2 + d[1] ** 2)
    p = L(contact.penalty(depth)) * np.maximum(Rl - dist, 0)
    fe = np.stack([-(contact.N[k] * (d[contact.comp[k]] / dist) * p * contact.dA).sum(axis=1)
                   for k in range(contact.N.shape[0])])
    f = np.zeros(u.size, dtype=L)
    np.add.at(f, contact.element_dofs.ravel(), fe.ravel())
    return f


@pytest.mark.skipif(np.finfo(np.longdouble).eps >= EPS, reason="long double is float64 on this platform")
@pytest.mark.parametrize("depth", [0.04, 0.3])
def test_the_floor_bounds_the_round_off_of_the_contact_forces(depth):
    """At a state converged to round-off the contact forces' float64 round-off (against extended
    precision) stays below the floor; the floor itself is far below any tolerance in use."""
    prob = IndentationProblem(graded_mesh(R, 0.6, "coarse"), NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6,
                              rtol=1e-14)
    _, u, report = prob.solve([depth])
    assert report.roundoff_stops == report.increments >= 1  # 1e-14 is out of float64's reach here
    f_int, f_c, _ = prob._residual(u, depth)
    free = prob.free
    ref = max(np.linalg.norm(f_c[free]), np.linalg.norm(f_int[free]))
    floor = prob.roundoff_floor(u, depth)
    error = float(np.linalg.norm((f_c - _contact_force_extended(prob.contact, u, depth))[free]))
    print(f"round-off {error / ref:.2e}, floor {floor / ref:.2e} (relative)")
    assert 0 < error <= floor, (error, floor)
    assert floor <= 1e-8 * ref  # the floor never accepts what a tolerance of 1e-8 would not


# ----------------------------------------------------------------- whole solves
@pytest.mark.parametrize("sample", [
    NeoHooke(8.0, 0.45),
    LayeredSample((Layer(0.3, NeoHooke(12.4, 0.45)), Layer(1.2, NeoHooke(4.0, 0.45))), RIGID),
], ids=["half-space", "two-layers-rigid-base"])
def test_an_unreachable_tolerance_converges_to_the_reachable_forces(sample):
    """rtol = 1e-14 cannot be met in float64: every increment stops at its round-off floor, on any CPU
    (before this criterion such solves raised ConvergenceError; the two layers, with rtol 3e-11, did on
    one OpenBLAS kernel of two). Their forces are those of states converged to 1e-9 by the residual
    alone, to the accuracy that tolerance gives (1e-8)."""
    depths = np.array([0.3, 0.6])
    tight = simulate(sample, SphericalIndenter(R), depths, solve_at_outputs=True, mesh="coarse", rtol=1e-14)
    plain = simulate(sample, SphericalIndenter(R), depths, solve_at_outputs=True, mesh="coarse", rtol=1e-9)
    assert tight.report.roundoff_stops == tight.report.increments
    assert plain.report.roundoff_stops == 0  # the residual criterion as it always was
    assert np.allclose(tight.force_mN, plain.force_mN, rtol=1e-8, atol=0)


def test_default_tolerance_never_reaches_the_floor():
    """At the default tolerance the criterion is the relative residual alone: the floor is orders of
    magnitude below it, and the solve is the one before the floor existed."""
    curve = simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), 0.6, 10, mesh="coarse")
    assert curve.report.roundoff_stops == 0 and max(curve.report.residuals) <= 1e-5
