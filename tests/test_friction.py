"""Coulomb friction between sphere and skin (penalty-regularised return mapping) against known answers.

The reference for full stick is the incremental no-slip indentation of an elastic
half-space by a rigid sphere (Mossakovskii 1963; Spence 1968, "Self similar
solutions to adhesive contact problems with incremental loading", Proc. R. Soc. A
305, 55-80): while the contact grows, every point sticks where it touched. The
ratio of the stick force to Hertz's force at the same depth is a constant that
depends on nu alone. No printed table of it could be pinned, so it is computed
here independently of the finite elements (:func:`incremental_stick_ratio`): a
ring boundary-element solution of the bonded rigid flat punch on a half-space,
superposed over the growing contact radius. The same boundary elements reproduce
Mossakovskii's closed-form bonded-punch stiffness ``(1-nu) ln(3-4nu)/(1-2nu)``
times the frictionless one (Popov, Hess & Willert, Handbook of Contact Mechanics,
2019, eq. 2.141; Borodich & Keer 2004, Proc. R. Soc. A 460, 507) to 5e-5
(``test_boundary_element_reference_reproduces_mossakovskii``). Values (M = 80 rings):

=====  =====================
nu     F_stick / F_Hertz
=====  =====================
0.0    1.05290
0.1    1.04096
0.2    1.02854
0.3    1.01621
0.4    1.00541
0.45   1.00160
0.49   1.00007
=====  =====================

so the stick force exceeds the frictionless one by 5.3% at nu = 0 and the effect
vanishes as nu -> 0.5, as (1-2nu)/(1-nu) does.
"""

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad
from scipy.special import ellipe, ellipk

from skin_indent.mechanics import IndentationProblem, LinearElastic, NeoHooke, SphericalIndenter, graded_mesh
from skin_indent.mechanics.contact_law import ContactLaw
from skin_indent.mechanics.protocol import Protocol
from skin_indent.simulate import simulate

R = 6.22
H = 0.01 * R  # h/R = 0.01: small strain
#: F_stick / F_frictionless - 1 of the incremental no-slip solution (module docstring).
STICK_REFERENCE = {0.0: 0.05290, 0.3: 0.01621, 0.49: 0.00007}


# ---------------------------------------------------------------------------------------
# independent reference: ring boundary elements for the bonded flat punch
# ---------------------------------------------------------------------------------------
def _uz_pressure_disk(r, b, A):
    """Normal surface displacement at r of a unit uniform pressure on the disk r' < b (A = (1-nu)/G)."""
    r = np.asarray(r, float)
    out = np.empty_like(r)
    inside = r < b
    out[inside] = A * b * (2 / np.pi) * ellipe((r[inside] / b) ** 2)
    m = (b / r[~inside]) ** 2
    out[~inside] = A * (2 * r[~inside] / np.pi) * (ellipe(m) - (1 - m) * ellipk(m))
    return out


def _ur_pressure_disk(r, b, B):
    """Radial displacement from a unit uniform pressure on the disk r' < b (B = (1-2nu)/(2G))."""
    r = np.asarray(r, float)
    return -B * np.where(r < b, r / 2, b**2 / (2 * r))


def _uz_shear_disk(r, b, B):
    """Normal displacement from a unit outward radial shear on the disk r' < b (Betti: the transpose of the above)."""
    return -B * np.maximum(b - np.asarray(r, float), 0.0)


def _ur_shear_disk(r, b, A):
    """Radial displacement from a unit radial shear on the disk: A int_0^b s int J1(xi r) J1(xi s) d xi ds."""
    def kernel(ri, s):
        k2 = min(4 * ri * s / (ri + s) ** 2, 1 - 1e-16)
        return 2 / (np.pi * np.sqrt(k2 * ri * s)) * ((1 - k2 / 2) * ellipk(k2) - ellipe(k2))

    return np.array([A * quad(lambda s: s * kernel(ri, s), 0, b, points=[ri] if ri < b else None,
                              limit=200, epsabs=1e-13)[0] for ri in np.atleast_1d(r)])


def bonded_punch(M, nu, bonded=True):
    """Unit-radius rigid flat punch pressed 1 into a half-space (G = 1): tractions on M rings."""
    A, B = (1 - nu), (1 - 2 * nu) / 2
    t = np.sin(0.5 * np.pi * np.arange(M + 1) / M)  # ring edges, dense at the edge
    rc = 0.5 * (t[1:] + t[:-1])

    def rings(fun, coef):
        return np.stack([fun(rc, t[j + 1], coef) - (fun(rc, t[j], coef) if t[j] > 0 else 0.0)
                         for j in range(M)], axis=1)

    Uzp = rings(_uz_pressure_disk, A)
    if not bonded:
        return t, np.linalg.solve(Uzp, np.ones(M)), A
    K = np.block([[Uzp, rings(_uz_shear_disk, B)], [rings(_ur_pressure_disk, B), rings(_ur_shear_disk, A)]])
    return t, np.linalg.solve(K, np.r_[np.ones(M), np.zeros(M)])[:M], A


def incremental_stick_ratio(M, nu, bonded=True):
    """(k, F_stick / F_Hertz) for a rigid paraboloid under incremental loading with full stick.

    Each depth increment dh of a contact of radius a is a bonded flat punch of
    radius a (stuck points move down with the sphere, not sideways), so
    dF/dh = 2 E* a k with k the bonded-punch stiffness relative to the
    frictionless one. Self-similarity gives a^2 = c R h; a surface point r reaches
    the sphere when the earlier punches have moved it by h - r^2/(2R), which gives
    c = 2 (1 - I) with I = int_1^inf 2 W(rho) rho^-3 d rho, W the surface
    displacement outside the unit punch. Then F / F_Hertz = k sqrt(c)
    (frictionless: k = 1, W = (2/pi) asin(1/rho), I = 1/2, c = 1).
    """
    t, p, A = bonded_punch(M, nu, bonded)
    k = np.sum(p * np.pi * (t[1:] ** 2 - t[:-1] ** 2)) / (2 * 2 / (1 - nu))  # P / (2 E* a), E* = 2G/(1-nu)

    def W(rho):
        rho = np.array([rho])
        return sum(p[j] * (_uz_pressure_disk(rho, t[j + 1], A)[0]
                           - (_uz_pressure_disk(rho, t[j], A)[0] if t[j] > 0 else 0.0)) for j in range(len(p)))

    I = quad(lambda rho: 2 * W(rho) / rho**3, 1, np.inf, limit=200)[0]
    return k, k * math.sqrt(2 * (1 - I))


def test_boundary_element_reference_reproduces_mossakovskii():
    """The independent reference: frictionless punch exact, bonded punch = Mossakovskii, stick ratio as tabulated."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        k0, ratio0 = incremental_stick_ratio(16, 0.3, bonded=False)
        k, ratio = incremental_stick_ratio(16, 0.3)
    mossakovskii = 0.7 * math.log(3 - 4 * 0.3) / (1 - 2 * 0.3)
    print(f"M=16: frictionless k={k0:.5f} ratio={ratio0:.5f}; bonded k={k:.5f} (Mossakovskii {mossakovskii:.5f}), "
          f"F_stick/F_Hertz={ratio:.5f} (M=80: {1 + STICK_REFERENCE[0.3]:.5f})")
    assert k0 == pytest.approx(1.0, abs=2e-3) and ratio0 == pytest.approx(1.0, abs=2e-3)
    assert k == pytest.approx(mossakovskii, abs=2e-3)
    assert ratio == pytest.approx(1 + STICK_REFERENCE[0.3], abs=2e-4)


# ---------------------------------------------------------------------------------------
# the finite-element friction
# ---------------------------------------------------------------------------------------
def _frictionless_force(nu):
    """Force at the full depth H, frictionless (path independent)."""
    return simulate(LinearElastic(10.0, nu), SphericalIndenter(R), [H / 2, H], mesh="coarse",
                    solve_at_outputs=True).force_mN[-1]


def _stick_change(nu, points):
    prot = Protocol.ramp(H, points, 0.01)
    curve = simulate(LinearElastic(10.0, nu), SphericalIndenter(R), protocol=prot, mesh="coarse",
                     contact=ContactLaw(friction=10.0))
    return curve.force_mN[-1] / _frictionless_force(nu) - 1, curve.report


def test_full_stick_against_incremental_no_slip_solution():
    """nu = 0.3, h/R = 0.01, mu = 10 (sticks wherever it touches): +1.62% over frictionless
    (reference: the incremental no-slip solution of the module docstring, computed
    independently). A point that touches during an increment sticks at its position
    at the start of the increment, so the FE change converges from above at first
    order in the increment: 20 and 40 equal increments and their Richardson
    extrapolation must bracket and meet the reference."""
    d20, _ = _stick_change(0.3, 20)
    d40, rep = _stick_change(0.3, 40)
    extrapolated = 2 * d40 - d20
    ref = STICK_REFERENCE[0.3]
    print(f"nu=0.3: F_stick/F_frictionless - 1 = {d20:.5f} (20 increments), {d40:.5f} (40), "
          f"extrapolated {extrapolated:.5f}; reference {ref:.5f}; {rep.summary()}")
    assert ref < d40 < d20 < ref + 0.004
    assert extrapolated == pytest.approx(ref, abs=1.5e-3)


def test_full_stick_changes_nothing_near_incompressibility():
    """nu = 0.49: normal and tangential surface responses uncouple ((1-2nu) -> 0), reference +0.007%."""
    d20, rep = _stick_change(0.49, 20)
    print(f"nu=0.49: F_stick/F_frictionless - 1 = {d20:.2e} (reference {STICK_REFERENCE[0.49]:.0e}); {rep.summary()}")
    assert abs(d20 - STICK_REFERENCE[0.49]) < 2e-4


@pytest.fixture(scope="module")
def load_unload():
    """nu = 0.3, h/R = 0.01, 8 loading and 8 unloading increments: {mu: curve}. (What friction costs in
    Newton iterations on this protocol depends on the floating-point path: benchmarks/solver_counts.py.)"""
    prot = Protocol.ramp(H, 8, 0.01, unload=True)
    return {mu: simulate(LinearElastic(10.0, 0.3), SphericalIndenter(R), protocol=prot, mesh="coarse",
                         contact=ContactLaw(friction=mu) if mu else None)
            for mu in (0.0, 0.1, 10.0)}


def test_partial_slip_lies_between_frictionless_and_stick_and_dissipates(load_unload):
    """Finite mu: the force rises with mu up to the stick value (mu = 0.1 slips over most of
    the contact); unloading with slip dissipates (unloading force below loading force),
    sticking does not; the force returns to 0."""
    F = {mu: c.force_mN for mu, c in load_unload.items()}
    rise = {mu: f[7] / F[0.0][7] - 1 for mu, f in F.items()}
    print("F/F_frictionless - 1 at full depth:", {mu: round(float(v), 5) for mu, v in rise.items()})
    assert rise[0.0] == 0.0 < rise[0.1] < 0.5 * rise[10.0]
    for mu in (0.1, 10.0):
        unload_over_load = F[mu][8:15][::-1] / F[mu][:7] - 1  # the same depths H/8 .. 7H/8
        print(f"mu={mu}: unloading / loading force - 1:", np.round(unload_over_load, 5))
        assert F[mu][-1] == 0.0
        if mu == 0.1:  # slip: a hysteresis loop
            assert np.all(unload_over_load < -1e-3)
        else:  # stick: no slip, no dissipation (but the stick pattern of loading)
            assert np.all(np.abs(unload_over_load) < 5e-4)


def test_zero_friction_is_exactly_the_frictionless_model():
    """mu = 0 skips the friction code: the same floating-point numbers, loading and unloading."""
    fractions = np.array([0.25, 0.5, 0.75, 1.0, 0.95])  # loading, then the start of unloading
    for law, depth, n in ((NeoHooke(8.0, 0.45), 0.1, 4), (LinearElastic(10.0, 0.3), H, 5)):
        prot = Protocol(np.arange(float(n)), depth * fractions[:n])
        base = simulate(law, SphericalIndenter(R), protocol=prot, mesh="coarse")
        zero = simulate(law, SphericalIndenter(R), protocol=prot, mesh="coarse", contact=ContactLaw(friction=0.0))
        assert np.array_equal(base.force_mN, zero.force_mN)
    d = np.linspace(0.05, 0.3, 4)
    assert np.array_equal(simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), d, mesh="coarse").force_mN,
                          simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), d, mesh="coarse",
                                   contact=ContactLaw()).force_mN)


def test_friction_needs_a_protocol():
    with pytest.raises(ValueError, match="friction depends on the loading history"):
        simulate(LinearElastic(10.0, 0.3), SphericalIndenter(R), 0.3, 5, mesh="coarse",
                 contact=ContactLaw(friction=0.3))


@pytest.mark.parametrize("kwargs, match", [
    (dict(friction=-0.1), "friction"), (dict(friction=float("nan")), "friction"),
    (dict(friction=float("inf")), "friction"), (dict(friction=True), "friction"),
    (dict(adhesion_mJ_per_m2=-1.0), "work of adhesion"), (dict(adhesion_range_mm=0.0), "range"),
    (dict(tangential_penalty=0.0), "tangential penalty"),
])
def test_bad_contact_law(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ContactLaw(**kwargs)


@pytest.mark.parametrize("law", [NeoHooke(8.0, 0.45), LinearElastic(8.0, 0.3)])
def test_frictional_tangent_equals_finite_difference_and_force_is_vertical_resultant(law):
    """Stick and slip points (a random committed history), finite and small strain: the
    non-symmetric tangent is the derivative of the force vector, and the force on the
    sphere is the vertical sum of the contact forces."""
    prob = IndentationProblem(graded_mesh(R, 0.6, "coarse"), law, SphericalIndenter(R), 0.6,
                              contact=ContactLaw(friction=0.3))
    c = prob.contact
    x = prob.solid.basis.doflocs
    noise = 0.3 * np.random.default_rng(1).standard_normal(x.shape[1])
    u = 0.02 * np.exp(-np.hypot(x[0], x[1]) / 3.0) * (np.sin(x[0]) + noise)
    u[~prob.free] = 0.0
    depth = 0.3
    c.begin_step()
    n, _, gap = c._kinematics(u, depth)
    p_c = c.epsilon * np.maximum(-gap, 0.0)
    rng = np.random.default_rng(5)
    c._q = 0.3 * p_c * rng.uniform(-1.5, 1.5, p_c.shape)  # some beyond the cone
    c._s = c._slip_coordinate(u, n)[2] + 1e-3 * rng.standard_normal(p_c.shape) / c.law.tangential_penalty
    _, _, _, stick = c._return_mapping(c._slip_coordinate(u, n)[2], p_c)
    n_stick, n_slip = int(stick.sum()), int(((p_c > 0) & ~stick).sum())
    assert n_stick > 5 and n_slip > 5
    f, Kc, force = c.forces(u, depth)
    K = prob.pattern.assemble([(c.element_dofs, Kc)])
    v = np.zeros_like(u)
    v[prob.free] = np.random.default_rng(2).standard_normal(np.count_nonzero(prob.free))
    h = 1e-7 * depth
    fd = (c.forces(u + h * v, depth, False)[0] - c.forces(u - h * v, depth, False)[0])[prob.free] / (2 * h)
    err = np.linalg.norm(K @ v[prob.free] - fd) / np.linalg.norm(fd)
    asym = abs(K - K.T).max() / abs(K).max()
    print(f"{law.name}: {n_stick} stick, {n_slip} slip points; FD error {err:.1e}, asymmetry {asym:.2f}")
    assert err < 1e-6
    assert asym > 1e-3 and not c.symmetric_tangent
    b = prob.solid.basis
    vertical = np.r_[b.nodal_dofs[1], b.facet_dofs[1]]
    assert np.sum(f[vertical]) == pytest.approx(force, rel=1e-12)


def test_full_stick_check_is_kept_in_the_run_cache(tmp_path, monkeypatch):
    """The diagnosis' full-stick check (two runs) is kept in ``cache_dir/checks``: a second call
    reads it (no run), a damaged file is made again, and a different nu is a different entry."""
    from skin_indent.effects import friction

    calls = []

    def runs(nu, depth_mm, radius_mm):
        calls.append(nu)
        return np.array([0.1, 0.2]), np.array([1.0 + nu, 1.0 + nu / 2])

    monkeypatch.setattr(friction, "_full_stick_runs", runs)
    first = friction.full_stick_ratio(0.3, 0.6, 6.22, cache_dir=tmp_path)
    again = friction.full_stick_ratio(0.3, 0.6, 6.22, cache_dir=tmp_path)
    assert calls == [0.3]
    np.testing.assert_array_equal(first[1], again[1])
    (path,) = (tmp_path / "checks").glob("*.npz")
    path.write_bytes(b"not an npz")
    np.testing.assert_array_equal(friction.full_stick_ratio(0.3, 0.6, 6.22, cache_dir=tmp_path)[1], first[1])
    friction.full_stick_ratio(0.4, 0.6, 6.22, cache_dir=tmp_path)
    assert calls == [0.3, 0.3, 0.4] and len(list((tmp_path / "checks").glob("*.npz"))) == 2
