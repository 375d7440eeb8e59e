"""The public face: names importable from ``skin_indent``, one preparation for fit and
diagnose, the measurement's radius, and a new effect added by one file (here: this one)."""

import math

import numpy as np
import pytest

import skin_indent as si
from skin_indent.effects import FORCE, Effect, EffectParameter, register, unregister


def test_top_level_names_are_the_functions_not_modules():
    import skin_indent.simulate  # noqa: F401 - importing the seam module must not shadow si.simulate

    for name in ("load_csv", "load_curve", "prepare", "simulate", "fit", "diagnose", "identify", "surface_for",
                 "write_report", "register_effect"):
        assert callable(getattr(si, name)), name
        assert not isinstance(getattr(si, name), type(math)), name
    from skin_indent import diagnose, fit, simulate

    assert simulate is si.simulate and fit is si.fit and diagnose is si.diagnose
    with pytest.raises(AttributeError):
        si.no_such_name  # noqa: B018


def test_completion_lists_the_main_names_and_the_effects_keep_their_names():
    names = dir(si)
    for name in ("fit", "diagnose", "simulate", "load_csv", "Context", "fitting", "diagnosis"):
        assert name in names, name
    # ``layer`` and ``viscoelastic`` are effects; the mechanics' layer and law have names of their own
    assert not hasattr(si, "Layer") and not hasattr(si, "Viscoelastic")
    from skin_indent.mechanics.layers import Layer
    from skin_indent.mechanics.materials import Viscoelastic

    assert si.MaterialLayer is Layer and si.ViscoelasticMaterial is Viscoelastic


@pytest.mark.parametrize("sub", ["measurement", "mechanics", "effects", "response_surface", "models", "inverse",
                                 "fitting", "diagnosis", "report", "runtime", "data"])
def test_completion_of_each_subpackage_lists_its_public_names(sub):
    """``dir()`` of a subpackage lists all of ``__all__``, the names loaded on first use too."""
    import importlib

    module = importlib.import_module(f"skin_indent.{sub}")
    assert module.__all__ and not [n for n in module.__all__ if n not in dir(module)]


def _afm_curve(radius_mm=0.02, E=2.0, nu=0.45, noise=2e-7, seed=1):
    """A curve recorded from before contact at AFM scale (R = 20 um): flat baseline, then contact."""
    h_max = 0.25 * radius_mm
    d = np.linspace(0.0, 1.6 * h_max, 160)
    contact = 0.6 * h_max
    h = np.clip(d - contact, 0.0, None)
    touching = h > 0
    F = np.zeros_like(d)
    F[touching] = si.simulate(si.NeoHooke(E, nu), si.SphericalIndenter(radius_mm), h[touching],
                              mesh="coarse").force_mN
    F += 1e-6 + np.random.default_rng(seed).normal(0.0, noise, d.size)
    return si.Measurement(d, F, None, "afm-like", radius_mm=radius_mm), contact


def test_load_fit_and_diagnose_a_bundled_curve_from_the_top_level(context):
    m = si.load_csv(si.bundled_path("forearm_like.csv"), radius_mm=6.22)
    result = si.fit(m, window=(0.05, 0.6), context=context, mesh="coarse")
    assert result.success and 4.5 < result.parameters["E_kPa"] < 7.5
    assert result.quality["misfit"] > 1.0 and result.quality["verdict"]  # a layered curve: structured misfit
    d = si.diagnose(m, candidates=("offset",), context=context)
    assert d.radius_mm == 6.22 and d.base.rms_mN > 0 and d.to_dict()["bic_formula"]


def test_diagnose_and_fit_take_the_radius_the_measurement_carries(context):
    m, contact = _afm_curve()
    assert m.radius_mm == 0.02
    prepared = si.prepare(m)
    assert prepared.radius_mm == 0.02 and prepared.radius_source == "measurement"
    assert prepared.contact_mode == "fit"
    d = si.diagnose(m, candidates=(), context=context)
    assert d.radius_mm == 0.02 and d.data.radius_mm == 0.02
    assert abs(d.base.parameters["offset_mm"] - contact) < 0.02 * contact
    assert abs(d.base.parameters["E_kPa"] / 2.0 - 1) < 0.05


def test_the_skin_default_radius_on_nN_forces_is_refused_in_one_line():
    m, _ = _afm_curve()
    bare = si.Measurement(m.depth_mm, m.force_mN, None, "no-radius")
    with pytest.raises(si.measurement.MeasurementError, match="give the sphere radius"):
        si.prepare(bare)


class ForceOffset(Effect):
    """A constant force added to the whole curve (an untared instrument): a test-only effect."""

    name = "force_offset"
    description = "a constant force offset of the instrument"
    parameters = (EffectParameter("F0_mN", "mN", -math.inf, math.inf, 0.0, False, "constant force added"),)
    stage = FORCE
    linear_in_E = False

    def fit_bounds(self, data, reach_mm=math.inf):
        peak = float(np.max(np.abs(data.force_mN)))
        return {"F0_mN": (-0.5 * peak, 0.5 * peak)}

    def apply(self, ev, fit):
        ev.force_mN = ev.force_mN + float(fit["F0_mN"])


@pytest.fixture
def force_offset():
    effect = register(ForceOffset())
    yield effect
    unregister(effect.name)


def test_a_new_effect_is_one_class_registered_and_diagnose_considers_fits_and_reports_it(force_offset, context):
    d = np.linspace(0.006, 0.6, 100)
    F = si.simulate(si.NeoHooke(6.0, 0.45), si.SphericalIndenter(6.22), d, mesh="coarse").force_mN
    F = F + 0.4 + np.random.default_rng(3).normal(0.0, 0.02, d.size)
    m = si.Measurement(d, F, None, "untared", radius_mm=6.22)
    diag = si.diagnose(m, candidates=("force_offset", "offset"), noise_mN=0.02, context=context)
    assert diag.verdict == "force_offset", diag.report()
    top = diag.ranking[0]
    assert abs(top.parameters["F0_mN"] - 0.4) < 3 * top.std["F0_mN"] + 0.01
    assert "force_offset" in diag.report() and diag.to_dict()["verdict"] == "force_offset"
    added = si.diagnose(m, candidates=("offset",), add=("force_offset",), noise_mN=0.02, context=context)
    assert added.current.rms_mN < 1.3 * 0.02 and added.verdict == "none"


def test_written_files_are_readable_by_others(tmp_path):
    import os
    import stat

    from skin_indent.runtime.atomic import atomic_write

    old = os.umask(0o022)
    try:
        path = atomic_write(tmp_path / "report.html", lambda fh: fh.write(b"<html></html>"))
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o644


def test_nu_one_half_is_the_incompressible_limit_checked_against_hertz_and_0499(context):
    """At small depth the limit is Hertz's incompressible sphere; deeper it stays within a
    fraction of a percent of the compressible law at nu = 0.499 (same E*)."""
    from skin_indent.mechanics.analytic import hertz_force

    R = 1.0
    d = np.linspace(0.0005, 0.01, 40)  # h/R <= 0.01: Hertz holds
    hertz = si.Measurement(d, hertz_force(d, 3.0, 0.5, R), None, "hertz", radius_mm=R)
    small = si.fit(hertz, fixed={"nu": 0.5}, contact="origin", context=context, mesh="coarse")
    assert small.parameters["nu"] == 0.5 and abs(small.parameters["E_kPa"] / 3.0 - 1) < 0.01
    deep = np.linspace(0.005, 0.3, 60)
    F = si.simulate(si.NeoHooke(3.0, 0.499), si.SphericalIndenter(R), deep, mesh="coarse").force_mN
    fe = si.Measurement(deep, F, None, "fe-0.499", radius_mm=R)
    limit = si.fit(fe, fixed={"nu": 0.5}, contact="origin", context=context, mesh="coarse")
    near = si.fit(fe, fixed={"nu": 0.499}, contact="origin", context=context, mesh="coarse")
    assert abs(limit.e_star_kPa / near.e_star_kPa - 1) < 0.003
    with pytest.raises(ValueError, match="above 0.5"):
        si.fit(fe, fixed={"nu": 0.6}, contact="origin", context=context, mesh="coarse")
