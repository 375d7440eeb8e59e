"""The response surfaces shipped with the package: verified by their forces, read like the cache.

The check of the shipped data (:func:`skin_indent.response_surface.shipped.verify`) recomputes one
run of every shipped family with the installed forward model (11 runs: the unit-radius half-space
on the medium mesh, the dimensionless base, layer and stiffening surfaces at R = 1 mm and those of
the demo's two radii on the coarse one) and fails if any force differs by more than a tenth of the
model error. The dimensionless surfaces scale to any radius by exact similarity (tested here
against runs at 2 and 4 times the radius, and against a direct run at R = 4 mm).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import shutil

import numpy as np
import pytest

from skin_indent.fitting.rung import MODEL_ERROR
from skin_indent.models.effect_surface import recompute_shipped
from skin_indent.response_surface import ResponseSurface, RunStore, default_settings, run_key, shipped
from skin_indent.response_surface._cache import source_digest
from _executors import FakeExecutor, RefusingExecutor


@pytest.fixture(scope="module")
def recomputed():
    """The sampled shipped runs made again by the installed forward model: ``{(label, nu): forces}``."""
    return {(label, nu): recompute_shipped(settings, depth, nu)
            for label, settings, depth, nu, _ in shipped.sample_runs(1)}


def _forces_of(recomputed):
    """``forces_of`` of :func:`shipped.verify` that answers with the runs made once by the fixture."""
    def key(settings, depth, nu):
        return json.dumps(settings, sort_keys=True), float(depth[-1]), float(nu)

    made = {key(s, depth, nu): recomputed[label, nu] for label, s, depth, nu, _ in shipped.sample_runs(1)}
    return lambda settings, depth, nu: made[key(settings, depth, nu)]


def test_the_tolerance_is_a_tenth_of_the_model_error():
    assert shipped.TOLERANCE == pytest.approx(MODEL_ERROR / 10)


def test_every_shipped_family_is_sampled_and_matches_the_forward_model(recomputed):
    index = json.loads((shipped.SHIPPED_DIR / shipped.INDEX).read_text())
    assert len(recomputed) == len({s["file"] for s in index["surfaces"]}) >= 11
    report = shipped.verify(1, forces_of=_forces_of(recomputed))
    assert report.ok, "\n".join(report.lines())
    assert all(c.difference <= MODEL_ERROR / 10 for c in report.checks)


def test_the_check_fails_when_a_shipped_node_is_perturbed_by_a_tenth_of_a_percent(recomputed, tmp_path):
    copy = tmp_path / "surfaces"
    shutil.copytree(shipped.SHIPPED_DIR, copy)
    index = json.loads((copy / shipped.INDEX).read_text())
    # the first layer family: the dimensionless one (R = 1 mm)
    label, settings, depth, nu, f = next(s for s in shipped.sample_runs(1, copy) if "layer" in s[0])
    assert settings["radius_mm"] == 1.0 and settings["mesh"] == "coarse"
    entry = next(e for e in index["surfaces"] if e["settings"] == settings)
    with np.load(copy / entry["file"]) as z:
        arrays = {k: np.array(z[k]) for k in z.files}
    j = int(np.flatnonzero(arrays[f"{entry['array']}_nu"] == nu)[0])
    arrays[f"{entry['array']}_f"][j, 40] *= 1.001  # one node, one depth, 0.1 %
    np.savez(copy / entry["file"], **arrays)
    # listed with its new checksum, as an export of a wrong run would be: only the forces can tell
    index["files"][entry["file"]] = hashlib.sha256((copy / entry["file"]).read_bytes()).hexdigest()
    (copy / shipped.INDEX).write_text(json.dumps(index))
    report = shipped.verify(1, directory=copy, forces_of=_forces_of(recomputed))
    assert not report.ok
    failed = [c for c in report.checks if not c.ok]
    assert [(c.label, c.nu) for c in failed] == [(label, nu)]
    assert failed[0].difference == pytest.approx(1e-3, rel=0.05)


def test_the_installed_forward_model_is_stamped():
    """A change of the mechanics that does not move the forces: stamp it (verify --stamp), no rebuild."""
    index = json.loads((shipped.SHIPPED_DIR / shipped.INDEX).read_text())
    assert source_digest() in index["verified_code"], (
        f"the shipped surfaces are verified for src.{index['verified_code']}, not for the installed forward model "
        f"src.{source_digest()}: run `python benchmarks/build_shipped_surfaces.py verify --stamp` (it stamps them "
        "if their forces hold, else says to rebuild them)")


def test_the_shipped_data_is_small():
    size = sum(p.stat().st_size for p in shipped.SHIPPED_DIR.iterdir())
    assert size < 5 * 2**20  # a few MiB: the dimensionless surfaces of every depth ceiling and the demo's own
    assert all(p.stat().st_size < 3 * 2**20 for p in shipped.SHIPPED_DIR.iterdir())






def _unit_surface():
    from skin_indent.fitting.surfaces import unit_surface_grid

    return unit_surface_grid(0.1), default_settings(1.0, mesh="medium")


def test_a_fresh_cache_reads_the_shipped_surface_without_a_run(tmp_path):
    grid, settings = _unit_surface()
    surface = ResponseSurface.load_or_build(grid, settings, cache_dir=tmp_path, executor=RefusingExecutor())
    entry = next(e for e in json.loads((shipped.SHIPPED_DIR / shipped.INDEX).read_text())["surfaces"]
                 if e["key"] == shipped.physics_key(settings, grid.depth_mm))
    with np.load(shipped.SHIPPED_DIR / entry["file"]) as z:
        assert np.array_equal(surface.unit_forces, z[f"{entry['array']}_f"].T)
    # read like the cache: not written into the run cache's manifest
    key = run_key(json.loads(json.dumps(surface.settings)), grid.depth_mm)
    assert RunStore(tmp_path / "runs" / key[:24], key, surface.settings, grid.depth_mm).runs == {}


def test_other_forward_model_sources_ignore_the_shipped_surface_with_one_line(tmp_path, caplog):
    grid, settings = _unit_surface()
    settings = {**settings, "code_version": "0+src.000000000000"}
    shipped._shipped.cache_clear()
    fake = FakeExecutor()
    with caplog.at_level(logging.DEBUG, logger="skin_indent"):
        surface = ResponseSurface.build(grid, None, settings, cache_dir=tmp_path, executor=fake)
    shipped._shipped.cache_clear()
    lines = [r.getMessage() for r in caplog.records if "shipped" in r.getMessage()]
    assert len(lines) == 1 and "src.000000000000" in lines[0] and "not used" in lines[0], lines
    assert fake.runs == grid.nu.size  # built as without them
    assert np.allclose(surface.unit_forces, grid.depth_mm[:, None] ** 1.5 * (1 + grid.nu[None, :]))


def test_a_damaged_shipped_file_is_not_used(tmp_path, caplog):
    copy = tmp_path / "surfaces"
    shutil.copytree(shipped.SHIPPED_DIR, copy)
    grid, settings = _unit_surface()
    entry = next(e for e in json.loads((copy / shipped.INDEX).read_text())["surfaces"]
                 if e["key"] == shipped.physics_key(settings, grid.depth_mm))
    raw = bytearray((copy / entry["file"]).read_bytes())
    raw[-100] ^= 1
    (copy / entry["file"]).write_bytes(bytes(raw))
    with caplog.at_level(logging.WARNING, logger="skin_indent"):
        assert shipped.lookup(settings, grid.depth_mm, float(grid.nu[0]), directory=copy) is None
    assert any("damaged" in r.getMessage() for r in caplog.records)
    assert shipped.lookup(settings, grid.depth_mm, float(grid.nu[0])) is not None


def test_a_stamp_adds_the_installed_digest_and_keeps_the_others(tmp_path):
    copy = tmp_path / "surfaces"
    shutil.copytree(shipped.SHIPPED_DIR, copy)
    index = json.loads((copy / shipped.INDEX).read_text())
    index["verified_code"] = ["aaaaaaaaaaaa"]
    (copy / shipped.INDEX).write_text(json.dumps(index))
    grid, settings = _unit_surface()
    assert shipped.lookup(settings, grid.depth_mm, float(grid.nu[0]), directory=copy) is None  # not verified
    # what the package ships (and so the choice of a curve's surfaces: the demo's own, else the
    # dimensionless ones) does not depend on whether it is verified for the installed code
    assert shipped.ships(settings, grid.depth_mm, directory=copy)
    assert not shipped.ships(settings, grid.depth_mm[:-1], directory=copy)
    assert shipped.stamp(copy) == source_digest()
    assert json.loads((copy / shipped.INDEX).read_text())["verified_code"] == sorted(["aaaaaaaaaaaa", source_digest()])
    assert shipped.lookup(settings, grid.depth_mm, float(grid.nu[0]), directory=copy) is not None


@pytest.mark.parametrize("name, radius", [("forearm_like.csv", 6.22), ("forearm_like_R3.11mm.csv", None)])
def test_the_demo_curves_surfaces_are_all_shipped(name, radius, tmp_path, monkeypatch):
    """What the demo's diagnosis asks for is what is shipped (a change of the grids or axes would
    otherwise leave the shipped data unused, silently)."""
    from skin_indent.data import bundled_path
    from skin_indent.diagnosis.workflow import prepare_curve
    from skin_indent.fitting.surfaces import elastic_core, surface_for
    from skin_indent.measurement import load_csv
    from skin_indent.models import effect_surface
    from skin_indent.response_surface import _runs
    from skin_indent.runtime.context import Context

    def refuse(*args, **kwargs):
        raise AssertionError("a surface needed a finite-element run: not shipped")

    monkeypatch.setattr(_runs, "choose_executor", refuse)
    monkeypatch.setattr(effect_surface, "make_executor", refuse)
    curve = prepare_curve(load_csv(bundled_path(name), radius_mm=radius), radius_mm=None,
                          segments=("approach", "hold", "retract"))
    context = Context(cache_dir=tmp_path)
    surface_for(curve.radius_mm, curve.max_indentation_mm, context=context)
    for key in ((), ("layer",), ("stiffening",)):
        elastic_core(key, radius_mm=curve.radius_mm, max_depth_mm=curve.max_indentation_mm, e_star_kPa=7.0,
                     context=context)
    assert not list(tmp_path.glob("runs/*/nu_*.npz"))


# ------------------------------------------------------------------ dimensionless surfaces
#: a tenth of the shipped surfaces' tolerance: what "exact" similarity means for runs solved to the
#: forward model's Newton tolerance (simulate.RTOL = 1e-5 moves the forces by up to 2e-6)
SIMILARITY_TOLERANCE = shipped.TOLERANCE / 10


@pytest.mark.parametrize("effects, values", [(("layer",), {"thickness_mm": 0.24, "ratio": math.inf}),
                                             (("layer",), {"thickness_mm": 0.8, "ratio": 1 / 0.3}),
                                             (("stiffening",), {"C20_kPa": 1.6})])
def test_a_layered_or_stiffening_run_scales_exactly_with_the_radius(effects, values):
    """F(k h; E, nu, k T, ratio, C20; k R) = k^2 F(h; E, nu, T, ratio, C20; R) on the coarse mesh
    (no law has a length scale; the mesh, the interfaces and a rigid base scale with sqrt(R h_max)):
    what lets one unit-radius surface serve every radius (measured: k = 2 within 4e-9, k = 4 within 2.1e-6)."""
    from skin_indent.effects import Model

    depth = np.linspace(0.002, 0.2, 100)
    forces = {}
    for k in (1.0, 2.0, 4.0):
        theta = {"E_kPa": 1.0, "nu": 0.3, **{n: v * k if n.endswith("_mm") else v for n, v in values.items()}}
        forces[k] = Model(effects, k).simulate(theta, depth * k, mesh="coarse").force_mN / k**2
    for k in (2.0, 4.0):
        assert np.max(np.abs(forces[k] / forces[1.0] - 1)) < SIMILARITY_TOLERANCE


def _dimensionless(effects, radius_mm, max_depth_mm, tmp_path, monkeypatch):
    from skin_indent.fitting.surfaces import elastic_core
    from skin_indent.models import effect_surface
    from skin_indent.response_surface import _runs
    from skin_indent.runtime.context import Context

    def refuse(*args, **kwargs):
        raise AssertionError("a surface needed a finite-element run: not shipped")

    monkeypatch.setattr(_runs, "choose_executor", refuse)
    monkeypatch.setattr(effect_surface, "make_executor", refuse)
    core = elastic_core(effects, radius_mm=radius_mm, max_depth_mm=max_depth_mm, e_star_kPa=7.0,
                        context=Context(cache_dir=tmp_path))
    assert not list(tmp_path.glob("runs/*/nu_*.npz"))
    return core


def test_a_curve_at_4_mm_takes_the_shipped_dimensionless_surfaces(tmp_path, monkeypatch):
    """No finite-element run for the surfaces of a skin curve at a radius without surfaces of its own;
    the layer's thickness axis starts at 1.2 c R (c = 0.17, the smallest ceiling >= h/R = 0.15)."""
    from skin_indent.fitting.surfaces import ceiling_for

    assert ceiling_for(4.0, 0.6) == 0.17
    layer = _dimensionless(("layer",), 4.0, 0.6, tmp_path, monkeypatch)
    assert layer.similarity == {"radius_mm": 1.0, "factor": 4.0} and layer.radius_mm == 4.0
    assert layer.bounds[0][2] == pytest.approx(1.2 * 0.17 * 4.0) and layer.depth_range[1] == pytest.approx(0.68)
    assert layer.bounds[0][0] == pytest.approx(7.0 / 30, rel=1e-2)  # E bounds from the curve's E*
    stiff = _dimensionless(("stiffening",), 4.0, 0.6, tmp_path, monkeypatch)
    base = _dimensionless((), 4.0, 0.6, tmp_path, monkeypatch)
    assert stiff.similarity["factor"] == 4.0 and base.depth_range[1] == pytest.approx(1.25 * 0.68)


def test_the_demo_radii_keep_their_own_surfaces(tmp_path, monkeypatch):
    """The demo's curves (R = 6.22 mm, 3.11 mm, depths to 0.6 mm) are served by the surfaces made for
    them, shipped: their documented numbers stay."""
    layer = _dimensionless(("layer",), 6.22, 0.6, tmp_path, monkeypatch)
    assert layer.similarity is None and layer.bounds[0][2] == pytest.approx(0.72)


@pytest.mark.parametrize("nu, thickness, compliance, flagged", [(0.45, 1.5, 0.5, False), (0.4, 4.0, 2.0, False),
                                                                (0.48, 1.0, 0.1, True)])
def test_the_dimensionless_layer_surface_at_4_mm_matches_a_direct_run(nu, thickness, compliance, flagged, tmp_path,
                                                                      monkeypatch):
    """The shipped unit-radius layer surface scaled to R = 4 mm against the finite-element model run
    at R = 4 mm (coarse mesh) between nodes: within the fits' model error where its interpolation
    error estimate is below it (measured 0.10 % and 0.20 %), and within that estimate where it is
    flagged (a thin layer over a stiff base, near the thinnest node: 0.40 % for an estimate of 1.25 %)."""
    from skin_indent.effects import Model

    layer = _dimensionless(("layer",), 4.0, 0.6, tmp_path, monkeypatch)
    depth = np.linspace(0.068, 0.68, 10)  # to the surface's deepest depth: the mesh its runs were made on
    theta = np.array([10.0, nu, thickness, compliance])
    direct = Model(("layer",), 4.0).simulate({"E_kPa": 10.0, "nu": nu, "thickness_mm": thickness,
                                              "ratio": 1 / compliance}, depth, mesh="coarse").force_mN
    error = np.max(np.abs(layer.force(depth, theta) / direct - 1))
    estimate = layer.interpolation_error(depth, theta)
    assert (estimate > MODEL_ERROR) == flagged
    assert error < (estimate if flagged else MODEL_ERROR), (error, estimate)
