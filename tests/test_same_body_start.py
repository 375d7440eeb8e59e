"""An effect added outside the elastic body of a rung fitted in the loop starts from that rung's optimum.

With the finite-element model in the loop, a fit of the contact points on top of two layers already
fitted (the demo's pair: ``offset+layer+layer`` after ``layer+layer``) starts from the two layers'
optimum, not from one layer's with every start of the body screened again; the screen is made only
if the fit does not move from there. Checked on the analytic stand-in of ``analytic_model.py`` given
the finite-element core's in-loop methods (no finite-element run).
"""

from __future__ import annotations

import contextlib
import threading
from types import SimpleNamespace

import numpy as np
import pytest

from analytic_model import HertzLikeModel
from skin_indent.fitting import multistart
from skin_indent.fitting.multistart import Fitter
from skin_indent.fitting.starts import elastic_body, same_body
from skin_indent.measurement import measurement_from_arrays, prepare
from skin_indent.response_surface import SurfaceCore

NOISE = 0.01


class _LoopCore(HertzLikeModel, SurfaceCore):
    """The analytic stand-in with the in-loop methods a finite-element core has (runs made here)."""

    name = "analytic in the loop"
    in_loop = True  # as the finite-element core declares it (models.core.ElasticCore)

    def __init__(self, radius_mm, lower=(1.0, 0.2), upper=(100.0, 0.49)):
        super().__init__(radius_mm, lower, upper)
        self.depth_range = (0.0, 1.0)

    def prefetch(self, thetas):
        pass

    @contextlib.contextmanager
    def screening(self):
        yield self

    def jacobian(self, depth_mm, theta, columns=None):
        J = super().jacobian(depth_mm, theta)
        return J if columns is None else J[:, columns]


class _FlatLoopCore(_LoopCore):
    """No parameter (nor the contact point) moves its force: a fit cannot leave any start."""

    def force(self, depth_mm, theta):
        self._check(theta)
        return np.zeros(np.asarray(depth_mm).shape)

    def jacobian(self, depth_mm, theta, columns=None):
        return np.zeros((np.asarray(depth_mm).size, 2 if columns is None else len(columns)))


def test_the_elastic_body_of_a_set_of_effects():
    assert elastic_body(("layer", "offset", "layer")) == ("layer", "layer")
    assert elastic_body(("offset",)) == ()
    assert same_body(SimpleNamespace(effects=("layer", "layer")), ("offset", "layer", "layer"))
    assert not same_body(SimpleNamespace(effects=("layer", "offset")), ("offset", "layer", "layer"))
    assert not same_body(None, ("layer",))


def test_warm_prefers_the_rung_of_the_same_body_among_rungs_of_equal_size():
    class Stub(Fitter):
        def __init__(self, fits):
            self.fits = fits
            self._seen = threading.local()

    rung = {k: SimpleNamespace(effects=k) for k in [("layer",), ("layer", "offset"), ("layer", "layer"),
                                                     ("offset", "layer")]}
    fitter = Stub(dict(rung))
    assert fitter.warm(("offset", "layer", "layer")) is rung["layer", "layer"]  # not the first fitted of size 2
    assert fitter.warm(("layer", "stiffening", "offset")) is rung["layer", "offset"]  # none of its body: the first
    assert fitter.warm(("layer", "layer")) is rung["layer",]


def _curve(contact_mm):
    d = np.linspace(0.006, 0.6, 80)
    F = _LoopCore(6.22, upper=(1e3, 0.49)).force(np.maximum(d - contact_mm, 0.0), [10.0, 0.45])
    F = F + np.random.default_rng(3).normal(0.0, NOISE, d.size)
    return prepare(measurement_from_arrays(d, F, source="analytic.csv", radius_mm=6.22), segments=("approach",),
                   contact="origin")


@pytest.mark.parametrize("flat", [False, True])
def test_an_effect_outside_the_body_is_fitted_from_the_body_fitted_in_the_loop(monkeypatch, flat):
    screened = []

    def core(effects, *, radius_mm, **_):
        return (_FlatLoopCore if flat else _LoopCore)(radius_mm)

    def screen(fitter, model, starts, keep, nested=None):
        screened.append(model.name)
        return starts[:keep]

    monkeypatch.setattr(multistart, "elastic_core", core)
    monkeypatch.setattr(multistart, "screen", screen)
    fitter = Fitter(_curve(0.01), NOISE, noise_known=True, context=None, mesh="coarse")
    base = fitter.fit(())
    assert fitter.model(()).in_loop
    rung = fitter.fit(("offset",))
    if not flat:
        # from the half-space's optimum, the contact point moved: no start of the body screened again
        assert screened == ["neo-hooke"]
        assert rung.chi2_weighted < base.chi2_weighted
        assert rung.parameters["offset_mm"] == pytest.approx(0.01, abs=2e-3)
    else:
        # the fit could not leave that optimum: the screened starts are fitted
        assert screened == ["neo-hooke", "neo-hooke+offset"]


def test_a_model_known_from_another_curve_of_the_sample_starts_there(monkeypatch):
    """A model fitted before to another curve of the sample (the single curve's diagnosis, then the
    pair's): its fit in the loop starts from that optimum, without screening starts; a known start
    that does not let the fit move falls back on the screen."""
    screened = []

    def core(effects, *, radius_mm, **_):
        return _LoopCore(radius_mm)

    def screen(fitter, model, starts, keep, nested=None):
        screened.append(model.name)
        return starts[:keep]

    monkeypatch.setattr(multistart, "elastic_core", core)
    monkeypatch.setattr(multistart, "screen", screen)
    alone = Fitter(_curve(0.0), NOISE, noise_known=True, context=None, mesh="coarse").fit(())
    # another curve's optimum: near this one's, not at it
    known = {(): {k: v * (1.2 if k == "E_kPa" else 1.0) for k, v in alone.fit_parameters.items()}}
    assert "E_kPa" in known[()]
    fitter = Fitter(_curve(0.0), NOISE, noise_known=True, context=None, mesh="coarse", starts=known)
    rung = fitter.fit(())
    assert screened == ["neo-hooke"]  # only the first fitter's: the second started from the known optimum
    assert rung.moved
    assert rung.parameters["E_kPa"] == pytest.approx(alone.parameters["E_kPa"], rel=1e-3)
    assert rung.parameters["E_kPa"] == pytest.approx(10.0, rel=0.05)
    assert not Fitter(_curve(0.0), NOISE, noise_known=True, context=None, mesh="coarse")._known_start(
        fitter.model(()), (), [np.array([5.0, 0.3])])  # nothing known: no seed


def test_a_fit_in_a_thread_of_fit_all_starts_only_from_fits_it_was_shown():
    """fit_all's threads: a fit starts from the fits made before the call and its own group's, never
    from another thread's that happens to have finished first (the same start from run to run)."""
    class Stub(Fitter):
        def __init__(self, fits):
            self.fits = fits
            self._seen = threading.local()

    rung = {k: SimpleNamespace(effects=k) for k in [("layer",), ("layer", "layer")]}
    fitter = Stub(dict(rung))
    fitter._seen.keys = {("layer",)}  # ("layer", "layer") finished in another thread
    assert fitter.warm(("layer", "layer", "offset")) is rung["layer",]
    fitter._seen.keys = None
    assert fitter.warm(("layer", "layer", "offset")) is rung["layer", "layer"]
