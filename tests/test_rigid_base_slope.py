"""The finite-element core's derivative in a layer's compliance at a rigid base (compliance 0).

A compliance below 1e-6 is a rigid base (no material below the layer), so the run's own
sensitivities have no base to differentiate: the column was 0 there, and a fit in the loop that
reached a rigid base could never leave it (measured on the demo's pair: two layers ended on a
rigid base 4.9 mm down where the curves' truth is 3 mm of fat over muscle, and with the truth's
base held the same curves fit with a lower chi-square). The slope is now that of the side the
fit can go to: checked against a central difference of two finite bases.
"""

from __future__ import annotations

import numpy as np
import pytest

from skin_indent.models.fe_core import FECore

pytestmark = [pytest.mark.xdist_group("fe-core"), pytest.mark.fe_loop]


def test_the_slope_in_the_compliance_at_a_rigid_base_is_that_of_a_finite_base():
    core = FECore(("layer",), radius_mm=3.11, max_depth_mm=0.6, e_star_kPa=8.0, mesh="coarse", workers=1)
    h = np.linspace(0.1, 0.6, 4)
    x = np.array([16.0, 0.45, 1.5, 0.0])  # a layer 1.5 mm thick on a rigid base
    slope = core.jacobian(h, x)[:, 3]
    a, b = x.copy(), x.copy()
    a[3], b[3] = 0.04, 0.12
    central = (core.force(h, b) - core.force(h, a)) / 0.08  # at a compliance of 0.08, where the slope is taken
    assert np.all(central < 0)  # a softer base: less force
    assert slope == pytest.approx(central, rel=0.03)
    # the fit's direction: away from the rigid base where the data are softer than it
    assert np.all(core.force(h, a) < core.force(h, x))
