"""Lee-Radok / Ting force histories over an elastic curve (effects.hereditary)."""

import numpy as np
import pytest

from skin_indent.analytic import hertz_force, ting_ramp_force
from skin_indent.effects.hereditary import hereditary_force, relaxation_weights

R, E, NU = 6.22, 10.0, 0.45


def _ramp(speed=0.02, depth=0.6, n=301, unload=False):
    t = np.linspace(0.0, depth / speed, n)
    h = speed * t
    if unload:
        t = np.r_[t, t[-1] + t[1:]]
        h = np.r_[h, h[-1] - h[1:]]
    return t, h


@pytest.mark.parametrize("g, tau", [(0.4, 5.0), (0.7, 0.5), (0.2, 100.0)])
def test_constant_speed_ramp_equals_the_closed_form(g, tau):
    t, h = _ramp()
    F = hereditary_force(t, h, hertz_force(h, E, NU, R), ((g, tau),))
    exact = ting_ramp_force(t, 0.02, E, NU, R, ((g, tau),))
    assert np.max(np.abs(F - exact)) < 2e-4 * exact.max()


def test_fast_and_slow_loading_give_the_instantaneous_and_relaxed_elastic_curves():
    g, tau = 0.4, 5.0
    for speed, modulus in ((1e3, E), (1e-5, E * (1 - g))):
        t, h = _ramp(speed=speed)
        F = hereditary_force(t, h, hertz_force(h, E, NU, R), ((g, tau),))
        assert F[-1] == pytest.approx(hertz_force(h[-1:], modulus, NU, R)[0], rel=2e-3)


def test_unloading_loses_contact_early_and_an_elastic_body_retraces():
    t, h = _ramp(unload=True)
    fe = hertz_force(np.maximum(h, 0), E, NU, R)
    elastic = hereditary_force(t, h, fe, ((0.0, 5.0),))
    assert np.allclose(elastic, fe, rtol=1e-12, atol=1e-12)
    F = hereditary_force(t, h, fe, ((0.4, 5.0),))
    peak = np.argmax(h)
    assert np.all(F >= 0) and F[peak + 1] < F[peak]  # the force drops at once on reversal
    lost = np.flatnonzero(F[peak:] == 0)
    assert lost.size and h[peak + lost[0]] > 0.05  # contact lost before the depth returns to zero
    # hysteresis: on the way out the force is below the way in at equal depth
    mid = peak + np.argmin(np.abs(h[peak:] - 0.3))
    assert F[mid] < F[np.argmin(np.abs(h[:peak] - 0.3))]


def test_a_hold_relaxes_towards_the_long_term_modulus():
    t = np.r_[np.linspace(0, 30, 151), 30 + np.linspace(0.2, 60, 300)]
    h = np.minimum(t * 0.02, 0.6)
    F = hereditary_force(t, h, hertz_force(h, E, NU, R), ((0.4, 5.0),))
    assert np.all(np.diff(F[151:]) < 0)
    assert F[-1] == pytest.approx(hertz_force(np.array([0.6]), E * 0.6, NU, R)[0], rel=1e-4)


def test_weights_integrate_the_kernel_exactly_and_check_their_input():
    t = np.array([0.0, 1.0, 3.0, 3.0, 7.0])
    W = relaxation_weights(t, ((0.5, 2.0),))
    # psi = 0.5 + 0.5 exp(-s/2): mean over step [t0, t1] seen from t_4 = 7
    assert W[4, 0] == pytest.approx(0.5 + 0.5 * 2.0 * (np.exp(-6 / 2) - np.exp(-7 / 2)))
    assert W[4, 2] == pytest.approx(0.5 + 0.5 * np.exp(-4 / 2))  # zero-length step: the kernel's value
    assert np.all(np.triu(W) == 0)
    with pytest.raises(ValueError, match="sum < 1"):
        relaxation_weights(t, ((0.7, 1.0), (0.4, 2.0)))
    with pytest.raises(ValueError, match="decrease"):
        relaxation_weights(t[::-1], ((0.5, 1.0),))
