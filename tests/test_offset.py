"""The contact-point offset: a shift of the depth origin (a nuisance parameter of fits)."""

import numpy as np
import pytest
from _data import load_curve

from skin_indent.mechanics import NeoHooke, SphericalIndenter
from skin_indent.mechanics.protocol import Protocol
from skin_indent.simulate import simulate

R = 6.22


def test_shifted_curve_is_the_unshifted_curve_moved_along_depth():
    law, ind = NeoHooke(6.0, 0.45), SphericalIndenter(R)
    recorded = np.linspace(0.03, 0.33, 11)
    shifted = simulate(law, ind, recorded, offset_mm=0.03, mesh="coarse", solve_at_outputs=True)
    plain = simulate(law, ind, recorded[1:] - 0.03, mesh="coarse", solve_at_outputs=True)
    assert shifted.force_mN[0] == 0.0
    assert np.array_equal(shifted.depth_mm, recorded)
    assert np.allclose(shifted.force_mN[1:], plain.force_mN, rtol=1e-12)


def test_negative_offset_means_contact_before_the_recorded_zero():
    law, ind = NeoHooke(6.0, 0.45), SphericalIndenter(R)
    a = simulate(law, ind, np.array([0.1, 0.2]), offset_mm=-0.05, mesh="coarse", solve_at_outputs=True)
    b = simulate(law, ind, np.array([0.15, 0.25]), mesh="coarse", solve_at_outputs=True)
    # 0.1 + 0.05 = 0.15000000000000002: the depths differ by an ulp, so the two solves may take
    # different Newton paths; they agree to well within Newton's tolerance (relative residual 1e-6)
    assert np.allclose(a.solved_depth_mm, b.depth_mm, rtol=1e-15, atol=0)
    assert np.allclose(a.force_mN, b.force_mN, rtol=1e-7)


def test_offset_with_a_protocol_keeps_the_recorded_depths():
    prot = Protocol.ramp(0.3, 6, 0.02)
    curve = simulate(NeoHooke(6.0, 0.45), SphericalIndenter(R), protocol=prot, offset_mm=0.1, mesh="coarse")
    assert np.array_equal(curve.depth_mm, prot.depth_mm)
    assert np.all(curve.force_mN[prot.depth_mm <= 0.1] < 1e-9) and np.all(curve.force_mN[prot.depth_mm > 0.1] > 0)


def test_independent_offset_curve_v05():
    """NH half-space E = 6 kPa, nu = 0.45, contact at recorded depth +0.020 mm: within 2% (h >= 0.05)."""
    _, d, F_ref = load_curve("hidden-effects/v05_offset_exact.csv").T
    curve = simulate(NeoHooke(6.0, 0.45), SphericalIndenter(R), d[d > 0], offset_mm=0.02)
    F = np.r_[0.0, curve.force_mN] if d[0] == 0 else curve.force_mN
    sel = d >= 0.05
    assert np.abs(F[sel] / F_ref[sel] - 1).max() < 0.02
    assert np.all(F[d <= 0.02] == 0.0)


def test_clean_curve_v01_is_the_base_model():
    _, d, F_ref = load_curve("hidden-effects/v01_clean_exact.csv").T
    curve = simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), d[1:])
    assert np.abs(curve.force_mN / F_ref[1:] - 1)[d[1:] >= 0.05].max() < 0.005


@pytest.mark.parametrize("offset", [float("nan"), float("inf"), "0.1"])
def test_bad_offset(offset):
    with pytest.raises(ValueError, match="offset must be a finite number"):
        simulate(NeoHooke(6.0, 0.45), SphericalIndenter(R), 0.3, 5, offset_mm=offset, mesh="coarse")


def test_offset_beyond_every_depth():
    with pytest.raises(ValueError, match="fewer than 2 depths reach the surface"):
        simulate(NeoHooke(6.0, 0.45), SphericalIndenter(R), 0.3, 5, offset_mm=0.5, mesh="coarse")
