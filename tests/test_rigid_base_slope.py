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


def test_a_base_stiffer_than_the_model_solves_is_between_the_rigid_and_the_stiffest_one():
    """A compliance between a rigid base (below 1e-6) and ``STIFF_BASE`` is not solved (runs of a base
    1e4-1e6 times stiffer than the layer do not converge, and a fit leaving a rigid base steps there):
    the force is linear in it from the rigid base's to ``STIFF_BASE``'s, continuous at both ends, and
    the Jacobian is that line's (its slope in the compliance, the ends' weighed in the others)."""
    from skin_indent.models.fe_core import STIFF_BASE

    core = FECore(("layer",), radius_mm=3.11, max_depth_mm=0.6, e_star_kPa=8.0, mesh="coarse", workers=1)
    h = np.linspace(0.1, 0.6, 4)
    rigid = np.array([16.0, 0.45, 1.5, 0.0])
    stiff = rigid.copy()
    stiff[3] = STIFF_BASE
    F0, F1 = core.force(h, rigid), core.force(h, stiff)
    assert np.all(F1 < F0)  # a finite base: softer
    runs = core.runs
    x = rigid.copy()
    x[3] = 0.3 * STIFF_BASE
    assert core.force(h, x) == pytest.approx(0.7 * F0 + 0.3 * F1, rel=1e-12)
    x[3] = 1e-5  # where a run does not converge
    assert core.force(h, x) == pytest.approx(F0 + 1e-5 / STIFF_BASE * (F1 - F0), rel=1e-12)
    assert core.runs == runs  # nothing solved in between: the two ends' runs
    above = stiff.copy()
    above[3] = STIFF_BASE * (1 + 1e-6)
    assert core.force(h, above) == pytest.approx(F1, rel=1e-6)  # continuous at the stiff end
    x[3] = 0.3 * STIFF_BASE
    J = core.jacobian(h, x)
    assert J[:, 3] == pytest.approx((F1 - F0) / STIFF_BASE, rel=1e-9)
    assert J[:, 0] == pytest.approx(core.force(h, x) / 16.0, rel=1e-6)  # the force is proportional to E
    thicker = x.copy()
    thicker[2] += 1e-3
    difference = (core.force(h, thicker) - core.force(h, x)) / 1e-3
    assert J[:, 2] == pytest.approx(difference, rel=0.02)
