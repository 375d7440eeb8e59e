"""Warm starts (issue 29): a run of the finite-element model in the loop starts Newton's method from
the converged fields of the nearest run made before on a mesh of the same topology.

The solution is the cold run's to the Newton tolerance (the iterations it saves are measured in
benchmarks/, not here: no test counts solver iterations); a warm start that
fails is cut and predicted as usual; history-dependent problems refuse one.
"""

from __future__ import annotations

import numpy as np
import pytest

from skin_indent.mechanics.contact_law import SphericalIndenter
from skin_indent.models.fe_core import FECore
from skin_indent.simulate import simulate

R = 6.22
LAYER = np.array([8.0, 0.45, 0.9, 0.5])  # E, nu, thickness (mm), compliance of the half-space below


def _layer_sample():
    core = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1)
    sample = core.spec(LAYER[1:]).sample(merge=False)
    return sample, core.scheduler.mesh(sample), np.geomspace(0.007, 0.7, 10)


def test_a_warm_start_gives_the_cold_solution():
    sample, imesh, depths = _layer_sample()
    cold = simulate(sample, SphericalIndenter(R), depths, mesh=imesh, solve_at_outputs=True, rtol=1e-8,
                    keep_fields=True)
    assert len(cold.solved_fields) == depths.size
    again = simulate(sample, SphericalIndenter(R), depths, mesh=imesh, solve_at_outputs=True, rtol=1e-8,
                     initial_fields=cold.solved_fields)
    assert np.allclose(again.force_mN, cold.force_mN, rtol=1e-7, atol=0)
    # a far-off start fails, is cut and predicted as usual: the same solution
    bad = simulate(sample, SphericalIndenter(R), depths, mesh=imesh, solve_at_outputs=True, rtol=1e-8,
                   initial_fields=[5.0 * u for u in cold.solved_fields])
    assert np.allclose(bad.force_mN, cold.force_mN, rtol=1e-7, atol=0)
    with pytest.raises(ValueError, match="one field"):
        simulate(sample, SphericalIndenter(R), depths, mesh=imesh, solve_at_outputs=True,
                 initial_fields=cold.solved_fields[:-1])


def test_a_history_dependent_problem_refuses_a_warm_start():
    from skin_indent.mechanics.contact_law import ContactLaw
    from skin_indent.mechanics.materials import NeoHooke
    from skin_indent.mechanics.protocol import Protocol

    with pytest.raises(ValueError, match="path-independent"):
        simulate(NeoHooke(8.0, 0.45), SphericalIndenter(R), protocol=Protocol.ramp(0.3, 5), mesh="coarse",
                 contact=ContactLaw(friction=0.5), initial_fields=[None] * 5)


@pytest.mark.fe_loop  # finite elements in the loop: .ci/run runs it, not the default run
def test_fe_core_warm_starts_from_the_nearest_run(monkeypatch):
    """Two evaluations 1% apart in the thickness and the compliance: the second is warm-started from the
    first, and equals what a core that never warm-starts gives (same mesh reference) to 1e-7."""
    import skin_indent.models.fe_scheduler as fe_scheduler

    h = np.linspace(0.05, 0.6, 9)
    step = LAYER * np.array([1.0, 1.0, 1.01, 0.99])

    def two(core):
        with core.iterating():
            return core.force(h, LAYER, sensitivities=False), core.force(h, step, sensitivities=False)

    warm = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1)
    a, b = two(warm)
    assert warm.warm_starts == 1 and warm.runs == 2
    monkeypatch.setattr(fe_scheduler, "WARM_DISTANCE", -1.0)  # never warm
    cold = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1)
    c, d = two(cold)
    assert cold.warm_starts == 0
    assert np.array_equal(a, c) and np.allclose(b, d, rtol=1e-7, atol=0)
    # nothing within reach: a start 50% away runs cold
    monkeypatch.setattr(fe_scheduler, "WARM_DISTANCE", 0.2)
    with warm.iterating():
        warm.force(h, LAYER * np.array([1.0, 1.0, 1.5, 1.0]), sensitivities=False)
    assert warm.warm_starts == 1


def test_runs_finished_in_any_order_are_kept_for_warm_starts_in_the_order_asked(monkeypatch):
    """Worker processes finish in any order; the fields kept for the next warm starts (the nearest kept,
    the oldest dropped first) are kept in the order the runs were asked, so a fit in the loop starts
    every run from the same fields from one run of the program to the next."""
    import skin_indent.models.fe_scheduler as fe_scheduler

    class Reversed:  # a pool whose workers finish in the reverse order
        def imap_unordered(self, fn, tasks):
            done = [(key, fn(*args), None) for key, args in tasks]
            return iter(done[::-1])

    thetas = [LAYER * np.array([1.0, 1.0, 1.0 + 0.3 * k, 1.0]) for k in range(3)]  # beyond warm reach

    def kept(pool):
        core = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1)
        if pool is not None:
            monkeypatch.setattr(core.scheduler, "pool", lambda: pool)
        asked = []
        original = core.scheduler._compute

        def spy(todo, where, keys):
            asked.extend(keys)
            return original(todo, where, keys)

        monkeypatch.setattr(core.scheduler, "_compute", spy)
        core.prefetch(thetas)
        return asked, list(core.scheduler._fields)

    asked, fields = kept(Reversed())
    assert len(asked) == 3 and fields == asked
