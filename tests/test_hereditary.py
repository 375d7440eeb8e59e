"""Lee-Radok / Ting force histories over an elastic curve (effects.hereditary)."""

import numpy as np
import pytest

from skin_indent.mechanics.analytic import hertz_force, ting_ramp_force
from skin_indent.effects.hereditary import hereditary_force, relaxation_weights

R, E, NU = 6.22, 10.0, 0.45


def _ramp(speed=0.02, depth=0.6, n=301, unload=False):
    t = np.linspace(0.0, depth / speed, n)
    h = speed * t
    if unload:
        t = np.r_[t, t[-1] + t[1:]]
        h = np.r_[h, h[-1] - h[1:]]
    return t, h


@pytest.mark.parametrize("prony", [((0.4, 5.0),), ((0.7, 0.5),), ((0.2, 100.0),),
                                   ((0.3, 0.2), (0.25, 3.0), (0.2, 60.0))])  # a series of three terms
def test_constant_speed_ramp_equals_the_closed_form(prony):
    t, h = _ramp()
    F = hereditary_force(t, h, hertz_force(h, E, NU, R), prony)
    exact = ting_ramp_force(t, 0.02, E, NU, R, prony)
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


# ------------------------------------------------------------------ the power-law kernel
def _triangle(speed=0.02, peak_s=30.0, n=1201):
    t = np.linspace(0.0, 2 * peak_s, 2 * n - 1)
    return t, np.where(t <= peak_s, speed * t, speed * (2 * peak_s - t))


@pytest.mark.parametrize("beta, cut_s, tol", [(0.1, None, 1e-5), (0.3, None, 6e-5), (0.6, 1e-12, 5e-4)])
def test_power_law_load_and_unload_equal_tings_closed_form(beta, cut_s, tol):
    """Ting's solution with the Beta function (loading) and the incomplete Beta function (unloading,
    contact radius from Ting's rule), small strain: the hereditary integral within ``tol`` of the
    peak force, contact lost at the same sample. Measured (1201 + 1200 points): 3.0e-6, 4.0e-5 (the
    10 us cut: (t_c / t)^(1 - beta)), 3.1e-4 (beta = 0.6 with no cut: the steps at short lags)."""
    from skin_indent.mechanics.analytic import ting_power_law_force
    from skin_indent.effects.hereditary import CUT_S, PowerLawKernel

    t, h = _triangle()
    kernel = PowerLawKernel(beta, cut_s=CUT_S if cut_s is None else cut_s)
    F = hereditary_force(t, h, hertz_force(h, E, NU, R), kernel)
    exact = ting_power_law_force(t, 0.02, E, NU, R, beta, peak_s=30.0)
    assert np.abs(F - exact).max() < tol * exact.max()
    assert np.array_equal(F > 0, exact > 0)
    assert (exact == 0).sum() > 100  # the contact is lost well before the depth returns to zero


def test_power_law_weights_integrate_the_kernel_exactly_and_beta_zero_is_elastic():
    from scipy.integrate import quad

    from skin_indent.effects.hereditary import PowerLawKernel

    k = PowerLawKernel(0.3)
    t = np.array([0.0, 1e-3, 0.5, 0.5, 2.0])
    W = relaxation_weights(t, k)
    for n, j in ((4, 0), (4, 1), (2, 1), (4, 3)):
        a, b = t[n] - t[j + 1], t[n] - t[j]
        assert W[n, j] == pytest.approx(quad(lambda s: k.value(s), a, b, points=[a])[0] / (b - a), rel=1e-9)
    assert W[4, 2] == pytest.approx(k.value(1.5))  # a zero-length step: the kernel's value
    assert k.value(1.0 - k.cut_s) == pytest.approx(1.0)  # E is the modulus at t0 = 1 s
    th, h = _triangle(n=101)
    fe = hertz_force(h, E, NU, R)
    assert np.allclose(hereditary_force(th, h, fe, PowerLawKernel(0.0)), fe, rtol=1e-12, atol=1e-12)
