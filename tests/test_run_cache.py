"""The run cache of single finite-element runs (issue 29): a rerun solves nothing, a damaged entry is
recomputed, keys differ when anything that determines a run differs, processes share it.

The finite-element model in the loop (:class:`~skin_indent.models.fe_core.FECore`), the
identifiability checks and the forward runs of a suggested measurement keep their runs in
``cache_dir/fe-runs`` (:class:`~skin_indent.response_surface.RunCache`). Solves are counted
by wrapping :func:`skin_indent.simulate.simulate`, which every run goes through (one worker:
every run is made in this process).
"""

from __future__ import annotations

import dataclasses
import importlib
import multiprocessing
import os
import time
from pathlib import Path

import numpy as np
import pytest

from skin_indent.mechanics.convergence import ConvergenceError
from skin_indent.models.fe_core import FECore
from skin_indent.response_surface import RunCache, RunFailed

R = 6.22
#: two layers over a half-space, moduli relative to the dermis (as test_fe_fit's)
TWO_LAYERS = np.array([17.5, 0.48, 1.0, 17.5 / 2.9, 3.0, 2.9 / 9.4])


@pytest.fixture
def solves(monkeypatch):
    """Counts the forward solves made in this process; ``solves.refuse()`` makes every further one fail."""

    class Counter:
        n = 0
        refused = False

        def refuse(self):
            self.refused = True

    counter = Counter()
    module = importlib.import_module("skin_indent.simulate")  # the module (the package exports the function)
    real = module.simulate

    def counting(*args, **kwargs):
        if counter.refused:
            raise AssertionError("a finite-element solve was made on a rerun")
        counter.n += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(module, "simulate", counting)
    return counter


# ------------------------------------------------------------------ the cache itself
def test_a_run_is_computed_once_and_read_back(tmp_path):
    cache = RunCache(tmp_path)
    calls = []

    def compute():
        calls.append(1)
        return {"force_mN": np.array([1.0, 2.5]), "depth_mm": np.array([0.1, 0.2])}

    first = cache.get_or_compute({"run": "test", "x": 1.0}, compute)
    again = RunCache(tmp_path).get_or_compute({"run": "test", "x": 1.0}, compute)  # another process's view
    assert len(calls) == 1 and first.keys() == again.keys()
    assert all(np.array_equal(first[k], again[k]) for k in first)
    assert cache.counts["computed"] == 1 and list((tmp_path / "fe-runs").rglob("*.npz"))


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty", "another key", "bytes changed"])
def test_a_damaged_entry_is_recomputed_never_trusted(tmp_path, damage):
    cache = RunCache(tmp_path)
    parts = {"run": "test", "x": 2.0}
    cache.get_or_compute(parts, lambda: {"y": np.arange(50.0)})
    path = cache.path(cache.key(parts))
    raw = path.read_bytes()
    if damage == "truncated":
        path.write_bytes(raw[: len(raw) // 2])
    elif damage == "garbage":
        path.write_bytes(b"not a zip file at all")
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "another key":  # an intact entry of another run under this name
        other = {"run": "test", "x": 3.0}
        cache.get_or_compute(other, lambda: {"y": np.arange(50.0)})
        path.write_bytes(cache.path(cache.key(other)).read_bytes())
    else:  # one value changed inside an otherwise readable file (the checksum catches it)
        i = raw.rindex(np.float64(49.0).tobytes())
        path.write_bytes(raw[:i] + np.float64(48.0).tobytes() + raw[i + 8:])
    fresh = RunCache(tmp_path)
    assert fresh.load(cache.key(parts)) is None and fresh.counts["damaged"] == 1
    got = fresh.get_or_compute(parts, lambda: {"y": np.arange(50.0) + 1})  # recomputed (and replaced)
    assert np.array_equal(got["y"], np.arange(50.0) + 1) and fresh.counts["computed"] == 1
    assert np.array_equal(RunCache(tmp_path).load(cache.key(parts))["y"], np.arange(50.0) + 1)


def test_a_failure_is_kept_only_when_the_same_inputs_fail_again(tmp_path):
    cache = RunCache(tmp_path)

    def diverges():
        raise ConvergenceError("Newton did not converge at depth 0.7 mm")

    with pytest.raises(ConvergenceError):
        cache.get_or_compute({"run": "fails"}, diverges)
    with pytest.raises(RunFailed, match="did not converge at depth 0.7 mm"):
        RunCache(tmp_path).get_or_compute({"run": "fails"}, lambda: {"y": np.zeros(1)})

    def out_of_memory():
        raise MemoryError("a worker ran out of memory")

    with pytest.raises(MemoryError):
        cache.get_or_compute({"run": "transient"}, out_of_memory)
    assert RunCache(tmp_path).get_or_compute({"run": "transient"}, lambda: {"y": np.ones(1)})["y"][0] == 1.0


def test_keys_name_the_parts_and_the_forward_model_sources(tmp_path, monkeypatch):
    import skin_indent.response_surface.run_cache as run_cache

    parts = {"run": "test", "x": 1.0, "mesh": "coarse"}
    key = RunCache(tmp_path).key(parts)
    assert RunCache(tmp_path / "elsewhere").key(dict(reversed(list(parts.items())))) == key  # content, not order
    assert RunCache(tmp_path).key({**parts, "x": 1.0 + 1e-15}) != key
    monkeypatch.setattr(run_cache, "source_digest", lambda: "edited")  # the mechanics changed
    assert RunCache(tmp_path).key(parts) != key


def _slow_run(folder, log):
    cache = RunCache(folder)

    def compute():
        with open(log, "a") as fh:
            fh.write(f"{os.getpid()}\n")
        time.sleep(0.5)
        return {"y": np.array([float(len(Path(log).read_text().split()))])}

    return float(cache.get_or_compute({"run": "shared"}, compute)["y"][0])


def test_two_processes_share_a_run(tmp_path):
    """Two processes asking for the same run at once: one computes it, the other waits and reads it."""
    log = tmp_path / "computed.txt"
    with multiprocessing.get_context("fork").Pool(2) as pool:
        out = pool.starmap(_slow_run, [(tmp_path, log), (tmp_path, log)])
    assert out == [1.0, 1.0] and len(log.read_text().split()) == 1


# ------------------------------------------------------------------ the finite-element model in the loop
def test_fe_core_keys_differ_with_everything_that_determines_a_run(tmp_path):
    """The key parts of a run: the sample as built, the radius, the depths solved, the mesh (its family
    member and the reference it was morphed from), the Newton tolerance, the sensitivities; no run is
    solved (nor any mesh built) here."""
    from skin_indent.models.fe_core import RTOL
    from skin_indent.models.fe_runs import FIRST, INCREMENTS
    from skin_indent.models.fe_scheduler import Run

    cache = RunCache(tmp_path)

    def core_of(mesh="coarse", radius_mm=R, max_depth_mm=0.6):
        return FECore(("layer", "layer"), radius_mm=radius_mm, max_depth_mm=max_depth_mm, e_star_kPa=8.0, workers=1,
                      mesh=mesh, run_cache=cache)

    core = core_of()
    sample = core.spec(TWO_LAYERS[1:]).sample(merge=False)
    ref = [float(v) for v in sample.interfaces_mm]
    base = Run(TWO_LAYERS[1:], sample, RTOL, True, INCREMENTS, FIRST)

    def key(run=base, reference=ref, on=core, **changes):
        return cache.key(on.run_parts(dataclasses.replace(run, **changes), reference))

    other = core.spec((TWO_LAYERS * [1, 1, 1.1, 1, 1, 1])[1:]).sample(merge=False)
    keys = {
        "as built": key(),
        "another sample, on its own mesh": key(sample=other, reference=[float(v) for v in other.interfaces_mm]),
        "another sample, morphed from the same mesh": key(sample=other),
        "another radius": key(on=core_of(radius_mm=2 * R)),
        "deeper": key(on=core_of(max_depth_mm=1.2)),
        "fewer depths": key(increments=14),
        "from deeper": key(first=0.05),
        "looser": key(rtol=1e-5),
        "no sensitivities": key(sensitivities=False),
        "medium mesh": key(on=core_of("medium")),
        "morphed from elsewhere": key(reference=[v * 1.1 for v in ref]),
        "a half-space mesh reference": key(reference=None),
    }
    assert len(set(keys.values())) == len(keys), keys
    assert key(on=core_of()) == keys["as built"]  # another core (another process) names the same run alike
    # the parameters (what warm starts compare) are not part of the key: the sample is
    assert key(rest=TWO_LAYERS[1:] * 1.0001) == keys["as built"]


@pytest.mark.fe_loop  # finite elements in the loop: .ci/run runs it, not the default run
def test_a_rerun_of_a_fit_in_the_loop_solves_nothing(tmp_path, solves):
    """A fit with the finite-element model in the loop (a layer: E, the compliance of the half-space
    below and a contact offset free), made again by another core on the same cache: no solve, the
    same numbers."""
    from skin_indent.inverse import fit_least_squares
    from skin_indent.measurement import measurement_from_arrays, prepare
    from skin_indent.models import ComposedModel

    layer = np.array([8.0, 0.45, 0.9, 0.5])
    depth = np.linspace(0.0, 0.6, 31)
    force = np.zeros_like(depth)
    truth = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1)
    touch = depth > 0.02
    force[touch] = truth.force(depth[touch] - 0.02, layer)
    data = prepare(measurement_from_arrays(depth, force, source="a layer"), segments=("approach",),
                   contact="origin")
    solves.n = 0

    def fit():
        core = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1,
                      run_cache=RunCache(tmp_path))
        model = ComposedModel(core, ("layer", "offset"), data)
        x0 = dict(zip(model.parameter_names, [*layer, 0.0]))
        x0.update(E_kPa=9.0, compliance=0.6, offset_mm=0.01)
        with model.iterating():
            res = fit_least_squares(model, data.depth_mm, data.force_mN, x0, fixed={"nu": 0.45, "thickness_mm": 0.9},
                                    ftol=1e-8, xtol=1e-8, max_nfev=4)
        J = model.jacobian(data.depth_mm, np.array([res.parameters[n] for n in model.parameter_names]))
        return res, J, core

    first, J1, core1 = fit()
    assert solves.n == core1.made > 1 and core1.cached == 0
    solves.refuse()
    again, J2, core2 = fit()
    assert core2.made == 0 and core2.cached == core1.runs == core2.runs
    assert again.parameters == first.parameters and np.array_equal(J1, J2)
    assert np.array_equal(again.residuals_mN, first.residuals_mN)


def test_a_failed_run_in_the_loop_is_not_tried_again_by_a_rerun(tmp_path, monkeypatch):
    import skin_indent.models.fe_scheduler as fe_scheduler

    calls = []

    def failing(*args):
        calls.append(args)
        raise ConvergenceError("Newton did not converge at depth 0.7 mm\nmore")

    monkeypatch.setattr(fe_scheduler, "solve_unit", failing)
    theta = np.array([8.0, 0.45, 0.9, 0.0])
    for _ in range(2):  # two cores, as two processes: the second reads the failure
        core = FECore(("layer",), radius_mm=R, max_depth_mm=0.6, e_star_kPa=8.0, workers=1,
                      run_cache=RunCache(tmp_path))
        with pytest.raises(ValueError, match="finite-element run failed at nu = 0.45.*did not converge at depth 0.7 mm"):
            core.force(np.array([0.1, 0.3]), theta)
    assert len(calls) == 1


# ------------------------------------------------------------------ a diagnosis, its checks and its suggestion
@pytest.fixture
def cache_with_surfaces(tmp_path, gallery_cache, diagnosis_surfaces, monkeypatch):
    """A cache folder whose surfaces are the gallery's (built once per run) and whose single runs start empty;
    the default cache (``$SKIN_INDENT_CACHE``) too, as on the command line."""
    cache = tmp_path / "cache"
    cache.mkdir()
    for name in ("surfaces", "runs"):
        (gallery_cache / name).mkdir(parents=True, exist_ok=True)
        (cache / name).symlink_to(gallery_cache / name, target_is_directory=True)
    monkeypatch.setenv("SKIN_INDENT_CACHE", str(cache))
    return cache


@pytest.mark.xdist_group("diagnose-answer-key")
def test_a_rerun_of_a_diagnosis_solves_nothing(cache_with_surfaces, solves):
    """The forearm-like curve on surfaces (two explanations climbed, the measurement that separates
    them predicted by forward runs, friction weighed by two runs), then its plan (the finite-element
    Jacobians of what it does not determine): made again, nothing is solved and every number is the same."""
    from skin_indent.data import bundled_path
    from skin_indent.diagnosis import diagnose, plan
    from skin_indent.measurement import load_csv
    from skin_indent.runtime.context import Context

    m = load_csv(bundled_path("forearm_like.csv"))

    def once():
        d = diagnose(m, cache_dir=cache_with_surfaces, mesh="coarse", workers=1, in_loop=False)
        checks = plan(d, context=Context(cache_dir=cache_with_surfaces, workers=1))
        return d, checks

    d1, checks1 = once()
    assert solves.n > 0 and d1.suggested_measurement and checks1.recorded_std, d1.report()
    solves.refuse()
    d2, checks2 = once()
    out1, out2 = d1.to_dict(), d2.to_dict()
    out1.pop("provenance"), out2.pop("provenance")
    assert out1 == out2
    plan1, plan2 = checks1.to_dict(), checks2.to_dict()
    plan1.pop("provenance"), plan2.pop("provenance")
    assert plan1 == plan2
    assert list((cache_with_surfaces / "fe-runs").rglob("*.npz"))
