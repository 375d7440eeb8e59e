"""Direct-differentiation sensitivities of the force curve against finite differences.

The reference is a fourth-order central difference of the forward model,
``(-F(p+2h) + 8F(p+h) - 8F(p-h) + F(p-2h)) / 12h``. The forces carry the Newton
tolerance as noise, which a difference amplifies by 1/h, while the truncation error
of a plain central difference needs h small (nu: 3e-5 at h = 2e-3). The residual's
round-off floor on the coarse mesh grows as the depth shrinks (~1e-10 relative at
0.006 mm, ~1e-11 at 0.3 mm; consistent with the cancellation in the gap |x - c| - R,
R = 6.22 mm, of penetrations of 1e-5 to 1e-4 mm), so the differences are taken on direct solves at 0.3-0.6 mm with
``rtol=3e-11``; the fourth-order stencil then allows steps of 0.2-0.5% of the
parameter (noise and truncation ~1e-8). Where 3e-11 is below the round-off floor (the
cut steps toward 0.3 mm pass 0.04 mm; a solve's state is at its floor half the time at
0.3-0.6 mm) Newton stops at that floor (``newton_converged``): residuals of at most
1.5e-10, on any floating-point path. The spline path (solved depths from h_max/100)
is checked with E, in which the force is linear.

The discrete model is only piecewise smooth in the parameters: each time a facet
quadrature point enters or leaves contact the slope dF/dp jumps (by ~2% on the
coarse mesh). Finite differences across such a switch are meaningless, so every
check records the contact sets of the stencil's runs (fixture ``contact_sets``) and
asserts that they are those of the differentiated run - a failure there means the
test point sits next to a switch, not that the sensitivities are wrong.
"""

from __future__ import annotations

import numpy as np
import pytest

from skin_indent import simulate
from skin_indent.mechanics.contact import SphereContact
from skin_indent.mechanics.contact_law import ContactLaw, SphericalIndenter
from skin_indent.mechanics.layers import RIGID, Layer, LayeredSample
from skin_indent.mechanics.materials import LinearElastic, NeoHooke, NeoHookeStiffening, PronyTerm, Viscoelastic
from skin_indent.mechanics.protocol import Protocol

SPHERE = SphericalIndenter(6.22)
NU = 0.45
#: the spline path (4 solved depths from 0.006 mm, where 2e-10 is about the residual's floor)
SPLINE = dict(depth_mm=0.6, points=12, increments=4, mesh="coarse", rtol=2e-10)
#: direct solves at the outputs, deep enough for a residual of 3e-11
DEPTHS = np.array([0.3, 0.45, 0.6])
DIRECT = dict(depth_mm=DEPTHS, solve_at_outputs=True, mesh="coarse", rtol=3e-11)


@pytest.fixture
def contact_sets(monkeypatch):
    """Record, per run, the contact set (gap < 0 at the facet quadrature points) of every converged depth."""
    runs = []
    commit = SphereContact.commit

    def recording(self, u, depth):
        runs[-1][round(float(depth), 12)] = self._kinematics(u, depth)[2] < 0
        return commit(self, u, depth)

    monkeypatch.setattr(SphereContact, "commit", recording)

    def run(*args, **kwargs):
        runs.append({})
        return simulate(*args, **kwargs), runs[-1]

    return run


def _check(run, make, p0, key, step, kwargs, tol=1e-6, order=4):
    """Sensitivity at p0 against a central difference (order 4, or 2) with the given step; returns the error."""
    curve, sets0 = run(make(p0), SPHERE, sensitivities=True, **kwargs)
    solved = set(np.round(curve.solved_depth_mm, 12))
    stencil = {}
    for m in (-2, -1, 1, 2) if order == 4 else (-1, 1):
        c, sets = run(make(p0 + m * step), SPHERE, **kwargs)
        switched = [z for z in solved if not np.array_equal(sets[z], sets0[z])]
        assert not switched, f"contact set changes within the stencil at depths {switched}: move the test point"
        stencil[m] = c.force_mN
    if order == 4:
        fd = (-stencil[2] + 8.0 * stencil[1] - 8.0 * stencil[-1] + stencil[-2]) / (12.0 * step)
    else:
        fd = (stencil[1] - stencil[-1]) / (2.0 * step)
    d = curve.sensitivities[key]
    assert d.shape == curve.depth_mm.shape
    err = np.max(np.abs(d - fd)) / np.max(np.abs(d))
    assert err < tol, f"{key}: max |dF/dp - FD| / max |dF/dp| = {err:.2e}"
    return err, curve


def test_young_modulus_and_homogeneity(contact_sets):
    law = NeoHooke(10.0, NU)
    curve, _ = contact_sets(law, SPHERE, sensitivities=True, **SPLINE)
    assert set(curve.sensitivities) == {(0, "E_kPa"), (0, "nu")}
    # the force is homogeneous of degree one in E (penalty scaled by E): E dF/dE = F
    dE = curve.sensitivities[0, "E_kPa"]
    # to the accuracy of its states: 1.3-5 times their largest relative residual (1e-10 to 2e-10 here, up to
    # the round-off floor of 1e-9 at 0.006 mm) on increment paths and OpenBLAS kernels
    res = max(curve.report.residuals)
    assert np.max(np.abs(dE * law.E_kPa - curve.force_mN)) < 15 * res * np.max(curve.force_mN)
    # direct solves converged to 3e-11 or to their round-off floor (relative residuals of 1e-11 to 8e-11):
    # homogeneous to 0.015-0.14 of their largest residual on three OpenBLAS kernels (SkylakeX, Haswell, Prescott)
    direct, _ = contact_sets(law, SPHERE, sensitivities=True, **DIRECT)
    dE = direct.sensitivities[0, "E_kPa"]
    res = max(direct.report.residuals)
    assert res <= 3e-10  # the floor at 0.3-0.6 mm
    assert np.max(np.abs(dE * law.E_kPa - direct.force_mN)) < res * np.max(direct.force_mN)
    # F is linear in E: a plain central difference with a large step has no truncation error
    _check(contact_sets, lambda p: NeoHooke(p, NU), 10.0, (0, "E_kPa"), 1.0, SPLINE, order=2)


def test_poisson_ratio(contact_sets):
    _check(contact_sets, lambda p: NeoHooke(10.0, p), NU, (0, "nu"), 2e-3, DIRECT)


def test_stiffening_constant(contact_sets):
    _, curve = _check(contact_sets, lambda p: NeoHookeStiffening(10.0, NU, p), 50.0, (0, "C20_kPa"), 0.5, DIRECT)
    assert set(curve.sensitivities) == {(0, "E_kPa"), (0, "nu"), (0, "C20_kPa")}
    # homogeneous of degree one in (E, C20) at fixed nu, penalty scaled by E
    s = curve.sensitivities
    assert np.allclose(10.0 * s[0, "E_kPa"] + 50.0 * s[0, "C20_kPa"], curve.force_mN, rtol=1e-9, atol=0.0)


def _two_layers(e1, e2):
    return LayeredSample((Layer(0.4, NeoHooke(e1, NU)),), NeoHooke(e2, NU))


def test_layer_modulus_over_half_space(contact_sets):
    # test points away from contact-set switches (moved with the conforming interface mesh)
    _check(contact_sets, lambda p: _two_layers(p, 15.0), 6.5, (0, "E_kPa"), 0.03, DIRECT)


def test_substrate_modulus(contact_sets):
    # the substrate is the stiffest material: it also scales the contact penalty
    _check(contact_sets, lambda p: _two_layers(6.0, p), 14.0, (1, "E_kPa"), 0.05, DIRECT)


def test_layer_on_rigid_base(contact_sets):
    # one layer on a rigid base is homogeneous in E: check nu
    make = lambda p: LayeredSample((Layer(1.5, NeoHooke(8.0, p)),), RIGID)  # noqa: E731
    _, curve = _check(contact_sets, make, 0.4, (0, "nu"), 1e-3, DIRECT)
    assert set(curve.sensitivities) == {(0, "E_kPa"), (0, "nu")}  # no key for the rigid base


def test_two_layers_on_rigid_base(contact_sets):
    make = lambda p: LayeredSample((Layer(0.3, NeoHooke(p, NU)), Layer(1.2, NeoHooke(4.0, NU))), RIGID)  # noqa: E731
    _check(contact_sets, make, 12.5, (0, "E_kPa"), 0.1, DIRECT)  # away from contact-set switches


def test_offset(contact_sets):
    # the offset path: zero before contact, F(depth - offset) after
    kwargs = dict(DIRECT, depth_mm=np.r_[0.02, DEPTHS + 0.04], offset_mm=0.04)
    _, curve = _check(contact_sets, lambda p: NeoHooke(10.0, p), 0.4, (0, "nu"), 2e-3, kwargs)
    d = curve.sensitivities[0, "nu"]
    assert d[0] == 0.0 and np.all(d[1:] != 0.0)


def test_elastic_protocol_matches_direct_solves():
    # an elastic sample may be driven by a protocol: every protocol point is differentiated
    protocol = Protocol(np.array([1.0, 2.0]), DEPTHS[:2])
    law = NeoHookeStiffening(10.0, NU, 30.0)
    curve = simulate(law, SPHERE, protocol=protocol, mesh="coarse", rtol=3e-11, sensitivities=True)
    direct = simulate(law, SPHERE, sensitivities=True, **dict(DIRECT, depth_mm=DEPTHS[:2]))
    for key, d in direct.sensitivities.items():
        p = curve.sensitivities[key]
        assert np.allclose(p, d, rtol=1e-7, atol=0.0), key


@pytest.mark.parametrize("sample, kwargs, message", [
    (LinearElastic(10.0, NU), {}, "neo-Hookean"),
    (Viscoelastic(NeoHooke(10.0, NU), (PronyTerm(0.3, 1.0),)), {}, "neo-Hookean"),
    (NeoHooke(10.0, NU), {"contact": ContactLaw(friction=0.2)}, "frictionless"),
    (NeoHooke(10.0, NU), {"contact": ContactLaw(adhesion_mJ_per_m2=10.0)}, "frictionless"),
    (LayeredSample((Layer(0.5, LinearElastic(5.0, NU)),), RIGID), {}, "neo-Hookean"),
])
def test_unsupported_samples_raise(sample, kwargs, message):
    with pytest.raises(ValueError, match=message):
        simulate(sample, SPHERE, 0.1, 4, mesh="coarse", sensitivities=True, **kwargs)


def test_default_has_no_sensitivities():
    assert simulate(NeoHooke(10.0, NU), SPHERE, 0.1, 4, mesh="coarse", increments=3).sensitivities is None
