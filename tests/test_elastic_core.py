"""Every elastic core declares the protocol the fitter reads (models/core.py): no capability probes."""

import numpy as np
import pytest

from skin_indent.effects import EffectAxis
from skin_indent.models import ComposedModel, HertzModel
from skin_indent.models.core import ElasticCore
from skin_indent.models.effect_surface import EffectSurface
from skin_indent.models.fe_core import FECore
from skin_indent.response_surface import ResponseSurface, SurfaceGrid


def _surface():
    grid = SurfaceGrid(np.linspace(0.006, 0.6, 20), np.geomspace(0.1, 100.0, 4), np.array([0.3, 0.42, 0.49]))
    hertz = np.column_stack([4 / 3 / (1 - nu**2) * np.sqrt(6.22) * grid.depth_mm**1.5 for nu in grid.nu])
    return ResponseSurface(grid, hertz, settings={"model": "synthetic"})


def _effect_surface():
    axis = EffectAxis("C20_over_E", (0.0, 1.0, 2.0), "linear")
    surfaces = np.empty(len(axis.nodes), dtype=object)
    for i in range(len(axis.nodes)):
        surfaces[i] = _surface()
    return EffectSurface(("stiffening",), (axis,), surfaces, 6.22)


CORES = {
    "response surface": (_surface, False),
    "effect surface": (_effect_surface, False),
    "Hertz": (lambda: HertzModel(6.22, (0.1, 100.0)), False),
    "finite elements": (lambda: FECore(("layer",), radius_mm=6.22, max_depth_mm=0.6, e_star_kPa=10.0), True),
}


@pytest.mark.parametrize("kind", CORES)
def test_every_core_declares_the_protocol(kind):
    make, in_loop = CORES[kind]
    core = make()
    assert isinstance(core, ElasticCore)
    assert core.in_loop is in_loop


def test_a_surface_core_runs_nothing_during_a_fit():
    core = _surface()
    with core.iterating(), core.screening(), core.in_workers():
        core.prefetch([np.array([5.0, 0.45])])
        core.start_workers()


def test_a_core_without_the_protocol_is_refused_by_name():
    class Bare:  # a force model of the inverse protocol only: not an elastic core of a composed model
        parameter_names = ("E_kPa", "nu")
        bounds = (np.array([0.1, 0.2]), np.array([100.0, 0.49]))
        depth_range = (0.0, 0.6)

        def force(self, depth_mm, theta):
            return theta[0] * np.asarray(depth_mm) ** 1.5

    assert not isinstance(Bare(), ElasticCore)
