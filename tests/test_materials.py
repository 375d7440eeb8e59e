"""Constitutive laws: derivatives, limits, metadata, input checks."""

import dataclasses

import numpy as np
import pytest
from _laws import finite_differences, random_H

from skin_indent.mechanics.axisymmetric import F_COMPONENTS
from skin_indent.mechanics.materials import LinearElastic, Material, NeoHooke

LAWS = [NeoHooke(10.0, 0.45), NeoHooke(3.0, 0.2), LinearElastic(10.0, 0.3)]


@pytest.mark.parametrize("law", LAWS, ids=lambda m: f"{m.name}-{m.nu}")
def test_stress_is_energy_derivative_and_tangent_is_stress_derivative(law):
    H = random_H()
    P, A = law.stress_and_tangent(H)
    P_fd, A_fd = finite_differences(law, H)
    assert np.abs(P - P_fd).max() <= 1e-7 * np.abs(P).max()
    assert np.abs(A - A_fd).max() <= 1e-7 * np.abs(A).max()


@pytest.mark.parametrize("law", LAWS, ids=lambda m: f"{m.name}-{m.nu}")
def test_reduced_tangent_matches_full_tangent(law):
    H = random_H()
    P, A = law.stress_and_tangent(H)
    P5, A55 = law.tangent_components(H, F_COMPONENTS)
    generic = Material.tangent_components(law, H, F_COMPONENTS)
    assert np.allclose(P5, generic[0], rtol=1e-13, atol=0) and np.allclose(A55, generic[1], rtol=1e-13, atol=1e-14)
    for a, (i, j) in enumerate(F_COMPONENTS):
        assert np.allclose(P5[a], P[i, j])


@pytest.mark.parametrize("law", LAWS, ids=lambda m: f"{m.name}-{m.nu}")
def test_stress_free_reference_state(law):
    H = np.zeros((3, 3, 4))
    assert np.all(law.energy(H) == 0.0)
    assert np.abs(law.stress(H)).max() < 1e-14 * law.E_kPa


def test_neo_hooke_reduces_to_hooke_at_small_strain():
    H = random_H(scale=1e-6)
    nh, le = NeoHooke(7.0, 0.42), LinearElastic(7.0, 0.42)
    assert np.abs(nh.stress(H) - le.stress(H)).max() < 1e-5 * np.abs(le.stress(H)).max()
    _, A_nh = nh.stress_and_tangent(np.zeros((3, 3, 1)))
    _, A_le = le.stress_and_tangent(np.zeros((3, 3, 1)))
    assert np.allclose(A_nh, A_le, rtol=1e-12)


def test_far_field_stress_keeps_its_digits():
    """On a 1000 mm mesh strains are ~1e-9: the stress must not lose them to cancellation."""
    H = random_H(scale=1e-9, seed=3)
    nh = NeoHooke(10.0, 0.45)
    P_lin = LinearElastic(10.0, 0.45).stress(H)
    assert np.abs(nh.stress(H) - P_lin).max() < 1e-6 * np.abs(P_lin).max()


def test_neo_hooke_energy_is_the_documented_law():
    E, nu = 8.0, 0.45
    mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    H = random_H(n=3, seed=5)
    F = np.eye(3)[:, :, None] + H
    J = np.linalg.det(np.moveaxis(F, -1, 0))
    I1 = np.einsum("ij...,ij...->...", F, F)
    W = mu / 2 * (I1 - 3 - 2 * np.log(J)) + lam / 2 * np.log(J) ** 2
    assert np.allclose(NeoHooke(E, nu).energy(H), W, rtol=1e-12)


@pytest.mark.parametrize("cls", [NeoHooke, LinearElastic])
@pytest.mark.parametrize("E, nu, match", [
    (0.0, 0.3, "E must be > 0"), (-1.0, 0.3, "E must be > 0"), (float("nan"), 0.3, "finite"),
    (10.0, 0.5, "nu must lie"), (10.0, -1.0, "nu must lie"), (10.0, float("nan"), "finite"),
    (float("inf"), 0.3, "finite"),
])
def test_bad_elastic_constants_are_rejected(cls, E, nu, match):
    with pytest.raises(ValueError, match=match):
        cls(E, nu)


@pytest.mark.parametrize("law", LAWS[:1] + LAWS[2:], ids=lambda m: m.name)
def test_metadata_names_match_the_parameters(law):
    names = [f.name for f in dataclasses.fields(law)]
    assert [p.name for p in law.parameter_info] == names
    assert set(law.parameters()) == set(names)
    assert all(p.unit for p in law.parameter_info)
