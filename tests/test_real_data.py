"""Real instrument curves (tests/data/real-data, see its README): loading, segments,
baseline, contact point, and the fit path (`fit_curve`, `skin-indent fit`) at AFM scale.

Surfaces are built on the coarse mesh in the gallery cache, once per run (conftest.py
``coarse_unit_surfaces``); the unit-radius surface (R = 1 mm, h/R <= 0.5) serves every radius
by similarity.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from _data import DATA

from skin_indent.fitting import fit, unit_surface_grid
from skin_indent.measurement import (MeasurementError, find_contact_point, find_segments, load_csv, load_curve)
from skin_indent.response_surface import ResponseSurface, default_settings

REAL = DATA / "real-data"
CHIARO_R_MM = 0.0275
CHIARO_HERTZ_E_STAR_KPA = 0.156  # the instrument's own Hertz fit (header: E_eff 156 Pa)

# file: (rows, [(kind, first row)] as the README states, rough contact depth (mm))
CURVES = {
    "chiaro_AEBP1_R27.5um.csv": (13827, [("approach", 0), ("retract", 12664)], 0.0725),
    "jpk_force-save-example_R18.64um.csv": (8400, [("approach", 0), ("retract", 6000)], 0.0267),
    "jpk_creep_brain_Runknown.csv": (9000, [("approach", 0), ("hold", 3000), ("retract", 6000)], 0.0168),
    "jpk_creep_polymergel_Runknown.csv": (9000, [("approach", 0), ("hold", 3000), ("retract", 6000)], 0.0277),
    "jpk_fd_spot3-0192_Runknown.csv": (4000, [("approach", 0), ("retract", 2000)], 0.00477),
    "jpk_fd_map2x2-0_Runknown.csv": (24060, [("approach", 0), ("retract", 12030)], 0.0294),
}
# boundaries are refined onto the physical transition (force peak, speed step): a few samples
# (here up to 7, i.e. 0.1% of the rows) from the instrument's segment start
ROW_TOLERANCE = 10


@pytest.fixture(scope="session")
def unit_surface(coarse_unit_surfaces, tmp_path_factory):
    """The h/R <= 0.5 unit-radius surface on the coarse mesh (about 10 s to build on 2 cores), and a copy
    of it in a file of its own (for the CLI)."""
    surface = ResponseSurface.load_or_build(unit_surface_grid(0.5), default_settings(1.0, mesh="coarse"),
                                            cache_dir=coarse_unit_surfaces, workers=2, progress=False)
    path = tmp_path_factory.mktemp("real-data-cache") / "unit.npz"
    surface.save(path)
    return surface, path


@pytest.mark.parametrize("name", sorted(CURVES))
def test_each_file_loads_in_package_units(name):
    rows, _, contact = CURVES[name]
    m = load_csv(REAL / name)
    assert m.n_points == rows and m.has_time
    assert m.depth_mm[0] == 0.0 and m.depth_mm.max() > contact  # contact well past the first sample
    assert np.abs(m.force_mN).max() < 1e-3  # nN-scale forces in mN


@pytest.mark.parametrize("name", sorted(CURVES))
def test_segments_match_the_readme(name):
    _, expected, _ = CURVES[name]
    segments = find_segments(load_csv(REAL / name))
    assert [s.kind for s in segments] == [k for k, _ in expected]
    for seg, (_, first) in zip(segments, expected):
        assert abs(seg.start - first) <= ROW_TOLERANCE, (seg, first)


@pytest.mark.parametrize("name", sorted(CURVES))
def test_contact_point_within_2um_of_the_readme(name):
    _, _, rough = CURVES[name]
    cp = find_contact_point(load_csv(REAL / name))
    assert cp.has_baseline
    assert abs(cp.depth_mm - rough) < 0.002, (cp.depth_mm, rough)


def test_chiaro_fit_with_nu_fixed_matches_the_instrument_hertz(unit_surface):
    """nu = 0.499 (the FE law is compressible; 0.5 is refused): E* within 20% of Chiaro's 156 Pa.

    Our own Hertz fit of the same points lands within a few % of the instrument; the
    large-strain FE E* is higher, since at h/R ~ 0.45 the sphere force falls below Hertz.
    """
    surface, _ = unit_surface
    m = load_csv(REAL / "chiaro_AEBP1_R27.5um.csv", radius_mm=CHIARO_R_MM)
    result = fit(m, surface, fixed={"nu": 0.499}, radius_mm=CHIARO_R_MM)  # timed by benchmarks/threads.py
    print(f"\n{result.report()}")
    assert result.success
    assert result.data.contact_mode == "fit" and result.data.baseline is not None
    assert abs(result.e_star_kPa / CHIARO_HERTZ_E_STAR_KPA - 1) < 0.2
    assert abs(result.hertz["E_star_kPa"] / CHIARO_HERTZ_E_STAR_KPA - 1) < 0.1
    assert 0 < result.fe_vs_hertz_percent < 25  # large strain: FE needs a stiffer material than Hertz
    assert abs(result.contact_point_mm - 0.0725) < 0.002 and 0 < result.contact_point_std_mm < 1e-3
    assert 0.4 < result.max_depth_ratio < 0.5
    d = result.to_dict()
    for key in ("baseline_mN", "baseline_tilt_mN_per_mm", "contact_point_mm", "contact_point_std_mm",
                "E_star_kPa", "hertz", "fe_vs_hertz_percent"):
        assert d[key] is not None, key
    json.dumps(d)
    for words in ("baseline: subtracted", "contact point:", "fitted jointly", "FE differs from Hertz by"):
        assert words in result.report()


def test_similarity_surface_matches_across_radii(unit_surface):
    surface, _ = unit_surface
    a, b = surface.at_radius(0.0275), surface.at_radius(6.22)
    h = np.linspace(0.01, 0.45, 30)
    theta = np.array([3.0, 0.45])
    Fa, Fb = a.force(h * 0.0275, theta), b.force(h * 6.22, theta)
    assert np.allclose(Fa / 0.0275**2, Fb / 6.22**2, rtol=1e-12)
    assert a.settings["similarity"]["radius_mm"] == 1.0 and a.depth_range[1] == pytest.approx(0.5 * 0.0275)


def test_fix_parser_and_nu_half_is_refused_in_one_line():
    from skin_indent.cli import CLIError, parse_fix as _parse_fix

    assert _parse_fix(["nu=0.499", "E=2", "contact_point_mm=0.07"]) == {"nu": 0.499, "E_kPa": 2.0,
                                                                         "offset_mm": 0.07}
    with pytest.raises(CLIError, match="NAME=VALUE"):
        _parse_fix(["poisson=0.5"])


def run_cli(*args):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(DATA.parent.parent / "src"),
                                                                    os.environ.get("PYTHONPATH")]))}
    return subprocess.run([sys.executable, "-m", "skin_indent", *args], capture_output=True, text=True,
                          timeout=300, env=env)


def test_fit_cli_on_the_chiaro_curve(unit_surface):
    _, path = unit_surface
    csv = str(REAL / "chiaro_AEBP1_R27.5um.csv")
    p = run_cli("fit", csv, "--radius", "0.0275", "--surface", str(path), "--fix", "nu=0.499", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["parameters"]["nu"] == 0.499 and "nu" in out["fixed_names"]
    assert out["baseline_mN"] != 0 and "baseline_tilt_mN_per_mm" in out
    assert abs(out["contact_point_mm"] - 0.0725) < 0.002 and out["contact_point_std_mm"] > 0
    assert abs(out["E_star_kPa"] / CHIARO_HERTZ_E_STAR_KPA - 1) < 0.2
    # the field's convention: nu = 0.5 is the incompressible limit, E* within a fraction of a % of nu = 0.499
    half = run_cli("fit", csv, "--radius", "0.0275", "--surface", str(path), "--fix", "nu=0.5", "--json")
    assert half.returncode == 0, half.stderr
    limit = json.loads(half.stdout)
    assert limit["parameters"]["nu"] == 0.5 and abs(limit["E_star_kPa"] / out["E_star_kPa"] - 1) < 0.005
    assert limit["parameters"]["E_kPa"] == pytest.approx(0.75 * limit["E_star_kPa"])
    assert any("incompressible limit" in n for n in limit["notes"])
    bad = run_cli("fit", csv, "--radius", "0.0275", "--surface", str(path), "--fix", "nu=0.6")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "Traceback" not in bad.stderr
    assert "0.5" in bad.stderr


def test_instrument_file_without_afmformats_is_one_line(tmp_path, monkeypatch):
    fake = tmp_path / "curve.jpk-force"
    fake.write_bytes(b"PK\x03\x04 not really")
    monkeypatch.setitem(sys.modules, "afmformats", None)  # import afmformats -> ImportError
    with pytest.raises(MeasurementError, match="pip install afmformats"):
        load_curve(fake)
    assert load_curve(REAL / "jpk_creep_brain_Runknown.csv").n_points == 9000  # CSV needs nothing extra


def test_fit_cli_instrument_file_error_is_one_line(tmp_path):
    try:
        import afmformats  # noqa: F401
        pytest.skip("afmformats is installed: the missing-package path is not reachable")
    except ImportError:
        pass
    fake = tmp_path / "curve.jpk-force"
    fake.write_bytes(b"PK\x03\x04 not really")
    p = run_cli("fit", str(fake), "--radius", "0.01864")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "pip install afmformats" in lines[0]


# ------------------------------------------------------------------ diagnose on real curves
@pytest.fixture(scope="session")
def diagnose_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("real-data-diagnose")


def test_diagnose_names_viscoelasticity_on_a_creep_curve(diagnose_cache):
    """Brain tissue under constant force: the depth creeps during the hold; an elastic model
    cannot follow it. The probe radius was not recorded: 30 um is assumed (13 um deep, so
    h/R ~ 0.45; the verdict does not depend on it, the modulus does). The retract, dominated
    by tethers (stepwise unbinding) that no candidate models, is left out (``segments``)."""
    from skin_indent.diagnosis import diagnose

    d = diagnose(load_csv(REAL / "jpk_creep_brain_Runknown.csv"), radius_mm=0.03, segments=("approach", "hold"),
                 candidates=("viscoelastic", "adhesion", "offset"), cache_dir=diagnose_cache, workers=2)
    assert d.data.has("hold") and not d.data.has("retract")
    assert d.data.contact_guess_mm == pytest.approx(0.0168, abs=0.002)
    assert d.verdict == "viscoelastic", d.report()
    assert d.ranking[0].rms_mN < 0.2 * d.base.rms_mN  # measured: 9x lower


def test_diagnose_names_adhesion_on_the_retract_segment(diagnose_cache):
    """The force-save curve: hysteresis first (viscoelastic), then, on top of it, the tensile
    dip on retract (adhesion)."""
    from skin_indent.diagnosis import diagnose

    m = load_csv(REAL / "jpk_force-save-example_R18.64um.csv")
    first = diagnose(m, radius_mm=0.01864, candidates=("viscoelastic", "adhesion"), cache_dir=diagnose_cache,
                     workers=2)
    assert first.missing[0] == "viscoelastic", first.report()  # the climb may go on to adhesion
    second = diagnose(m, radius_mm=0.01864, candidates=("adhesion",), add=("viscoelastic",),
                      cache_dir=diagnose_cache, workers=2)
    assert second.verdict == "adhesion", second.report()
    assert second.ranking[0].parameters["w_mJ_per_m2"] > 0


#: the cantilevers' spring constants (N/m) the original files record (README of tests/data/real-data)
SPRING_CONSTANTS = {"chiaro_AEBP1_R27.5um.csv": 0.019, "jpk_force-save-example_R18.64um.csv": 0.02230,
                    "jpk_creep_brain_Runknown.csv": 0.061, "jpk_creep_polymergel_Runknown.csv": 0.061,
                    "jpk_fd_spot3-0192_Runknown.csv": 0.04349, "jpk_fd_map2x2-0_Runknown.csv": 0.01548}


@pytest.mark.parametrize("name", sorted(SPRING_CONSTANTS))
def test_the_spring_constant_is_estimated_from_the_ramps(name):
    """The CSVs do not carry k: the piezo's constant speed in each ramp gives it (depth = a + b t - F/k per
    approach and retract), within 3 % of what the original file records, on every curve (the creep curves'
    constant-force holds left out); a depth recorded at the actuator (no cantilever) gives none."""
    from skin_indent.measurement import measurement_from_arrays, prepare
    from skin_indent.measurement.cantilever import estimate_spring_constant

    data = prepare(load_csv(REAL / name), segments=("approach", "hold", "retract"), radius_mm=0.02)
    k, source = data.spring_constant
    assert source == "estimated from the ramps"
    assert k == pytest.approx(SPRING_CONSTANTS[name], rel=0.03)
    assert np.allclose(data.deflection_mm, data.force_mN / k)
    t = np.linspace(0.0, 2.0, 400)
    depth = np.where(t < 1.0, 0.01 * t, 0.02 - 0.01 * t)  # the actuator's own position: no deflection in it
    force = np.maximum(depth - 0.005, 0.0) ** 1.5 + np.random.default_rng(1).normal(0.0, 1e-6, t.size)
    kind = np.where(t < 1.0, "approach", "retract")
    assert estimate_spring_constant(t, depth, force, kind) is None
    loading = measurement_from_arrays(depth[:200], force[:200], None, source="no time")
    assert prepare(loading, radius_mm=1.0).spring_constant == (None, "none")
