"""Neo-Hooke with Yeoh-type strain stiffening: derivatives, limits, closed forms, FE cross-check."""

import dataclasses

import numpy as np
import pytest
from _laws import finite_differences, random_H
from conftest import load_curve
from scipy.optimize import brentq

from skin_indent.mechanics import SphericalIndenter
from skin_indent.mechanics.axisymmetric import F_COMPONENTS
from skin_indent.mechanics.materials import LinearElastic, Material, NeoHooke, lame_parameters
from skin_indent.mechanics.materials.base import kinematics
from skin_indent.mechanics.materials.stiffening import NeoHookeStiffening
from skin_indent.simulate import simulate

LAWS = [NeoHookeStiffening(6.0, 0.45, 12.0), NeoHookeStiffening(3.0, 0.2, 0.7), NeoHookeStiffening(10.0, 0.49, 40.0)]


# -- derivatives ---------------------------------------------------------------

@pytest.mark.parametrize("law", LAWS, ids=lambda m: f"E{m.E_kPa}-nu{m.nu}-C{m.C20_kPa}")
@pytest.mark.parametrize("scale, axisymmetric", [(0.05, True), (0.2, True), (0.1, False)])
def test_stress_is_energy_derivative_and_tangent_is_stress_derivative(law, scale, axisymmetric):
    H = random_H(scale=scale, seed=1, axisymmetric=axisymmetric)
    P, A = law.stress_and_tangent(H)
    P_fd, A_fd = finite_differences(law, H)
    assert np.abs(P - P_fd).max() <= 1e-7 * np.abs(P).max()
    assert np.abs(A - A_fd).max() <= 1e-7 * np.abs(A).max()
    assert np.array_equal(law.stress(H), P)


@pytest.mark.parametrize("law", LAWS, ids=lambda m: f"E{m.E_kPa}-nu{m.nu}-C{m.C20_kPa}")
def test_reduced_tangent_matches_full_tangent(law):
    H = random_H(n=20, scale=0.2, seed=2)
    P, A = law.stress_and_tangent(H)
    P5, A55 = law.tangent_components(H, F_COMPONENTS)
    P_g, A_g = Material.tangent_components(law, H, F_COMPONENTS)
    assert np.abs(P5 - P_g).max() <= 1e-13 * np.abs(P_g).max()
    assert np.abs(A55 - A_g).max() <= 1e-13 * np.abs(A_g).max()
    for a, (i, j) in enumerate(F_COMPONENTS):
        assert np.allclose(P5[a], P[i, j], rtol=1e-13, atol=0)


def test_energy_is_the_documented_law():
    E, nu, C20 = 6.0, 0.45, 12.0
    mu, lam = lame_parameters(E, nu)
    H = random_H(n=5, seed=5)
    F = np.eye(3)[:, :, None] + H
    J = np.linalg.det(np.moveaxis(F, -1, 0))
    I1 = np.einsum("ij...,ij...->...", F, F)
    I1b = J ** (-2.0 / 3.0) * I1
    W = mu / 2 * (I1 - 3 - 2 * np.log(J)) + lam / 2 * np.log(J) ** 2 + C20 * (I1b - 3) ** 2
    assert np.allclose(NeoHookeStiffening(E, nu, C20).energy(H), W, rtol=1e-12)


def test_stress_free_reference_state():
    H = np.zeros((3, 3, 4))
    law = LAWS[0]
    assert np.all(law.energy(H) == 0.0)
    assert np.abs(law.stress(H)).max() < 1e-14 * law.E_kPa


# -- limits --------------------------------------------------------------------

def test_zero_C20_is_neo_hooke_bit_for_bit():
    H = random_H(n=11, scale=0.2, seed=7)
    st, nh = NeoHookeStiffening(7.0, 0.42, 0.0), NeoHooke(7.0, 0.42)
    assert np.array_equal(st.energy(H), nh.energy(H))
    assert np.array_equal(st.stress(H), nh.stress(H))
    for a, b in zip(st.stress_and_tangent(H), nh.stress_and_tangent(H)):
        assert np.array_equal(a, b)
    for a, b in zip(st.tangent_components(H, F_COMPONENTS), nh.tangent_components(H, F_COMPONENTS)):
        assert np.array_equal(a, b)
    assert st.reference_modulus == nh.reference_modulus == 7.0


def test_small_strain_is_hooke_with_the_same_E_and_nu():
    E, nu = 7.0, 0.42
    st, nh, le = NeoHookeStiffening(E, nu, 50.0), NeoHooke(E, nu), LinearElastic(E, nu)
    errors = []
    for scale in (1e-4, 1e-5):
        H = random_H(scale=scale, seed=4)
        P_lin = le.stress(H)
        errors.append(np.abs(st.stress(H) - P_lin).max() / np.abs(P_lin).max())
        # the stiffening term is of fourth order in the energy: O(C20 |H|^3) in the stress
        assert np.abs(st.stress(H) - nh.stress(H)).max() < 10 * 50.0 * (10 * scale) ** 3
    assert errors[0] < 1e-3 and errors[1] < 1e-4
    assert 0.05 < errors[1] / errors[0] < 0.2  # O(strain^2) differences: linear in the scale
    # the tangent at H = 0 is exactly the neo-Hookean one, i.e. Hooke's with E and nu
    _, A_st = st.stress_and_tangent(np.zeros((3, 3, 1)))
    _, A_nh = nh.stress_and_tangent(np.zeros((3, 3, 1)))
    _, A_le = le.stress_and_tangent(np.zeros((3, 3, 1)))
    assert np.array_equal(A_st, A_nh) and np.allclose(A_st, A_le, rtol=1e-12)


def test_far_field_stress_keeps_its_digits():
    """On a 1000 mm mesh strains are ~1e-9: the stress must not lose them to cancellation."""
    H = random_H(scale=1e-9, seed=3)
    st = NeoHookeStiffening(10.0, 0.45, 30.0)
    P = st.stress(H)
    P_lin = LinearElastic(10.0, 0.45).stress(H)
    P_nh = NeoHooke(10.0, 0.45).stress(H)
    assert np.abs(P - P_lin).max() < 1e-6 * np.abs(P_lin).max()
    # digits lost to cancellation would show as ~eps/|H| ~ 1e-7; the laws agree to 0.2-0.4 eps on
    # numpy's AVX-512 and AVX2 paths: a bound of 45 eps holds on any floating-point path
    assert np.abs(P - P_nh).max() <= 1e-14 * np.abs(P_nh).max()
    P5, A55 = st.tangent_components(H, F_COMPONENTS)
    assert np.abs(P5 - P[[0, 0, 1, 1, 2], [0, 1, 0, 1, 2]]).max() <= 1e-14 * np.abs(P).max()
    # I1b - 3 is O(|H|^2) ~ 1e-18 here, not the O(1e-16) roundoff of forming J^(-2/3) I1 - 3
    _, _, lnJ, _ = kinematics(H)
    _, b, _ = st._scalars(H, lnJ)
    assert np.all(np.abs(b) < 1e-16)


# -- homogeneous uniaxial stress -------------------------------------------------

def uniaxial_nominal_stress(law, lam):
    """Axial nominal stress P_zz (kPa) at axial stretch ``lam`` with zero lateral stress.

    F = diag(l, lam, l) in (r, z, theta); the lateral stretch l solves P_rr(l) = 0 with the
    law's own stress (P_theta = P_rr by symmetry).
    """
    def P(lt):
        H = np.zeros((3, 3, 1))
        H[0, 0] = H[2, 2] = lt - 1.0
        H[1, 1] = lam - 1.0
        return law.stress(H)[:, :, 0]

    lt = brentq(lambda x: P(x)[0, 0], 0.3, 3.0, xtol=1e-15, rtol=1e-15)
    Pd = P(lt)
    assert abs(Pd[2, 2]) < 1e-10 * abs(Pd[1, 1])
    return Pd[1, 1]


def yeoh_incompressible(lam, C10, C20):
    """Incompressible Yeoh (C30 = 0) uniaxial nominal stress, kPa."""
    I1 = lam**2 + 2.0 / lam
    return 2.0 * (lam - lam**-2) * (C10 + 2.0 * C20 * (I1 - 3.0))


def test_uniaxial_tension_and_compression_match_incompressible_yeoh():
    E, C20 = 6.0, 12.0
    rel = {}
    for nu in (0.4999, 0.49999):
        law = NeoHookeStiffening(E, nu, C20)
        C10 = lame_parameters(E, nu)[0] / 2.0
        rel[nu] = np.array([uniaxial_nominal_stress(law, lam) / yeoh_incompressible(lam, C10, C20) - 1.0
                            for lam in (0.7, 0.8, 0.9, 1.1, 1.25, 1.5)])
    print("uniaxial relative error vs incompressible Yeoh:", {k: np.abs(v).max() for k, v in rel.items()})
    # compressibility error ~ (1 - 2 nu): below 1e-3 at nu = 0.4999 for 0.8 <= lam <= 1.25
    assert np.abs(rel[0.4999][1:5]).max() < 1e-3
    assert np.abs(rel[0.4999]).max() < 5e-3 and np.abs(rel[0.49999]).max() < 5e-4
    # and it vanishes linearly as nu -> 1/2 (so the closed form is the exact limit)
    assert np.allclose(rel[0.49999] / rel[0.4999], 0.1, atol=0.01)


def uniaxial_tangent(law, lam, dl=1e-5):
    return (uniaxial_nominal_stress(law, lam + dl) - uniaxial_nominal_stress(law, lam - dl)) / (2 * dl)


def test_strain_stiffening_grows_with_C20():
    E, nu = 6.0, 0.45
    for lam in (0.75, 1.3):
        moduli = [uniaxial_tangent(NeoHookeStiffening(E, nu, c), lam) for c in (0.0, 1.0, 12.0)]
        assert moduli[0] < moduli[1] < moduli[2]
    # neo-Hooke softens in tension, the stiffened law stiffens beyond its small-strain E
    assert uniaxial_tangent(NeoHookeStiffening(E, nu, 0.0), 1.3) < E
    assert uniaxial_tangent(NeoHookeStiffening(E, nu, 12.0), 1.3) > 3 * E
    assert abs(uniaxial_tangent(NeoHookeStiffening(E, nu, 12.0), 1.0) / E - 1.0) < 1e-6


# -- metadata and inputs -----------------------------------------------------------

def test_metadata_names_match_the_parameters():
    law = LAWS[0]
    names = [f.name for f in dataclasses.fields(law)]
    assert names == ["E_kPa", "nu", "C20_kPa"]
    assert [p.name for p in law.parameter_info] == names
    assert law.parameters() == {"E_kPa": 6.0, "nu": 0.45, "C20_kPa": 12.0}
    assert all(p.unit for p in law.parameter_info)
    assert law.name == "neo-hooke-stiffening" and law.reference_modulus == 6.0
    assert law == NeoHookeStiffening(6.0, 0.45, 12.0) and hash(law) == hash(NeoHookeStiffening(6.0, 0.45, 12.0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        law.C20_kPa = 1.0


@pytest.mark.parametrize("E, nu, C20, match", [
    (0.0, 0.3, 1.0, "E must be > 0"), (float("nan"), 0.3, 1.0, "finite"), (10.0, 0.5, 1.0, "nu must lie"),
    (10.0, 0.3, -1.0, "C20 must be >= 0"), (10.0, 0.3, float("nan"), "C20 must be a finite"),
    (10.0, 0.3, float("inf"), "C20 must be a finite"), (10.0, 0.3, "1", "C20 must be a finite"),
    (10.0, 0.3, None, "C20 must be a finite"),
])
def test_bad_parameters_are_rejected(E, nu, C20, match):
    with pytest.raises(ValueError, match=match):
        NeoHookeStiffening(E, nu, C20)


# -- finite elements ---------------------------------------------------------------

def test_fe_force_is_homogeneous_in_E_and_C20():
    """F(2E, 2C20) = 2 F(E, C20): the contact penalty scales with reference_modulus = E."""
    R, d = 6.22, np.linspace(0.06, 0.6, 10)
    f1 = simulate(NeoHookeStiffening(3.7, 0.42, 5.0), SphericalIndenter(R), d, mesh="coarse").force_mN
    f2 = simulate(NeoHookeStiffening(7.4, 0.42, 10.0), SphericalIndenter(R), d, mesh="coarse").force_mN
    assert np.abs(f2 - 2 * f1).max() <= 1e-8 * np.abs(f2).max()


def test_fe_reproduces_the_independent_v04_curve():
    """Hidden-effect case v04 (FElupe, same law) on the default (medium) mesh: within 2% for h >= 0.05 mm."""
    data = load_curve("hidden-effects/v04_stiffening_exact.csv")
    data = data[data[:, 1] > 0]
    depth, force = data[:, 1], data[:, 2]
    curve = simulate(NeoHookeStiffening(6.0, 0.45, 12.0), SphericalIndenter(6.22), depth)
    rel = curve.force_mN / force - 1.0
    deep = depth >= 0.05
    print(f"v04: max |rel. error| for h >= 0.05 mm = {np.abs(rel[deep]).max():.2e}, at 0.6 mm = {rel[-1]:+.2e}")
    assert np.abs(rel[deep]).max() < 0.02
    # the stiffening is visible: the neo-Hookean curve is ~12% lower at 0.6 mm
    nh = simulate(NeoHooke(6.0, 0.45), SphericalIndenter(6.22), [0.3, 0.6], mesh="coarse").force_mN
    assert nh[-1] < 0.95 * force[-1]
