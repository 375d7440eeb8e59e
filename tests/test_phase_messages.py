"""stderr as promised (issue 39): one line per long phase, the segments a curve has, no estimate on a rerun."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from skin_indent.fitting.surfaces import EFFECT_NU
from skin_indent.models.effect_surface import EffectSurface, default_axes
from skin_indent.response_surface import SurfaceGrid
from _executors import FakeExecutor




def _info_lines(caplog):
    return [r.getMessage() for r in caplog.records if r.name.startswith("skin_indent") and r.levelno >= logging.INFO]


def test_an_effect_surface_build_is_one_line_and_a_cached_one_none(caplog, tmp_path):
    grid = SurfaceGrid(np.linspace(0.002, 0.2, 6), [1.0, 10.0], EFFECT_NU)
    axes = default_axes("layer", 0.2)
    fake = FakeExecutor()
    with caplog.at_level(logging.INFO, logger="skin_indent"):
        EffectSurface.build(("layer",), axes, grid, radius_mm=6.22, mesh="coarse", cache_dir=tmp_path,
                            executor=fake, progress=False)
    n_sub = int(np.prod([len(a.nodes) for a in axes]))
    assert n_sub > 1 and fake.runs == n_sub * len(EFFECT_NU)
    lines = _info_lines(caplog)
    assert len(lines) == 1, lines
    assert f"{fake.runs} finite-element runs to make ({n_sub} sub-surfaces" in lines[0]
    assert str(tmp_path) not in lines[0]  # cache folders are DEBUG details
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="skin_indent"):
        EffectSurface.build(("layer",), axes, grid, radius_mm=6.22, mesh="coarse", cache_dir=tmp_path,
                            executor=fake, progress=False)
    assert _info_lines(caplog) == [] and fake.runs == n_sub * len(EFFECT_NU)


def test_a_response_surface_build_names_no_cache_folder(caplog, tmp_path):
    from skin_indent.response_surface import ResponseSurface

    grid = SurfaceGrid(np.linspace(0.01, 0.1, 5), [1.0, 10.0], [0.3, 0.4])
    with caplog.at_level(logging.INFO, logger="skin_indent"):
        ResponseSurface.build(grid, None, {"radius_mm": 6.22, "mesh": "coarse"}, cache_dir=tmp_path,
                              executor=FakeExecutor())
    lines = _info_lines(caplog)
    assert len(lines) == 1 and "2 finite-element runs to make, 0 of 2 cached" in lines[0], lines
    assert str(tmp_path) not in lines[0]


class _Stop(Exception):
    pass


@pytest.mark.parametrize("curve, announced", [("forearm_like.csv", "(approach)")])
def test_a_ramp_only_curve_is_announced_with_its_own_segments(caplog, monkeypatch, curve, announced):
    from skin_indent.data import bundled_path
    from skin_indent.diagnosis import diagnose
    from skin_indent.diagnosis import workflow
    from skin_indent.measurement import load_csv

    def stop(self, key):
        raise _Stop

    monkeypatch.setattr(workflow.Fitter, "fit", stop)
    with caplog.at_level(logging.INFO, logger="skin_indent"), pytest.raises(_Stop):
        diagnose(load_csv(bundled_path(curve), radius_mm=6.22))
    lines = [m for m in _info_lines(caplog) if m.startswith("diagnosing")]
    assert len(lines) == 1 and announced in lines[0] and "hold" not in lines[0], lines

