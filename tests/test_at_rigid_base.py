"""A fit that ends just above a rigid base (a layer's compliance near 0) is taken to the rigid base
when leaving it is not worth more than ``FACE_CHI2`` (:func:`skin_indent.fitting.resume.at_rigid_base`).

Checked on an analytic stand-in whose compliance softens the deep part of the curve (no
finite-element run): a fit left at a compliance of 0.015 on a rigid-base curve ends on the rigid
base, reported there as at a face of its range; on a curve whose base is that soft it stays.
"""

from __future__ import annotations

import numpy as np
import pytest

from skin_indent.fitting.resume import FACE_CHI2, at_rigid_base, cost
from skin_indent.inverse import fit_least_squares

NOISE = 0.01
H = np.linspace(0.02, 0.6, 60)


class _Based:
    """F = E h^1.5 (1 - c h / 0.6): a compliance c of the base softens the deep points."""

    parameter_names = ("E_kPa", "compliance")
    bounds = (np.array([1.0, 0.0]), np.array([100.0, 8.0]))

    def force(self, depth_mm, theta):
        h = np.asarray(depth_mm, dtype=float)
        return theta[0] * h**1.5 * (1 - theta[1] * h / 0.6)

    def jacobian(self, depth_mm, theta):
        h = np.asarray(depth_mm, dtype=float)
        return np.stack([h**1.5 * (1 - theta[1] * h / 0.6), -theta[0] * h**2.5 / 0.6], axis=1)


def _ended_at(model, force, c):
    """A fit stopped at E = 10 kPa, compliance ``c`` (its budget of one evaluation)."""
    return fit_least_squares(model, H, force, [10.0, c], noise_mN=NOISE, max_nfev=1)


@pytest.mark.parametrize("truth, rigid", [(0.0, True), (0.015, False)])
def test_a_fit_near_a_rigid_base_ends_on_it_unless_the_data_leave_it(truth, rigid):
    model = _Based()
    force = model.force(H, [10.0, truth]) + np.random.default_rng(1).normal(0.0, NOISE, H.size)
    stopped = _ended_at(model, force, 0.015)
    out = at_rigid_base(model, H, force, stopped, noise_mN=NOISE, known={"fixed": None, "priors": None},
                        options={})
    assert cost(out) <= cost(stopped)
    if rigid:
        assert out.parameters["compliance"] == 0.0 and "compliance" in out.info["active_bounds"]
        assert out.free_names == stopped.free_names and out.fixed_names == ()  # counted free, on its face
        free = fit_least_squares(model, H, force, [10.0, 0.015], noise_mN=NOISE)
        assert cost(out) - cost(free) <= FACE_CHI2  # leaving it was not worth it
    else:
        assert out.parameters["compliance"] == pytest.approx(truth, abs=3 * out.std["compliance"])
        assert "compliance" not in out.info["active_bounds"]
