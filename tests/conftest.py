"""Test fixtures: data paths inside the project (tests/data), the only data a user's clone has.

The suite runs on two pytest-xdist workers (``-n auto --maxprocesses=2 --dist loadgroup`` in
pyproject.toml; ``-n 0`` runs it in one process). Here:

- every test process uses one BLAS thread (this one, each xdist worker, which inherits the
  environment set here before numpy loads, and the subprocesses tests start): the package's
  own policy (:func:`skin_indent.runtime.threads.configure_threads`); two workers with a full BLAS
  pool each would fight over the two cores;
- :func:`build_once` runs an expensive build (response surfaces into a shared cache) once per
  test run: the first worker that needs it builds under a lock, a second one waits and then
  finds everything cached instead of computing the same finite-element runs again;
- the gallery's cache folder, with two sets of surfaces built there once per run: the
  diagnosis surfaces of the 0.6 mm hidden-effect curves (tests/test_diagnose.py and the ex06
  example) and the coarse unit-radius surfaces that every coarse fit at AFM or skin scale
  scales (tests/test_api.py, test_batch.py, test_real_data.py, which built them each in a
  cache of their own before);
- one :class:`~skin_indent.runtime.context.Context` (fixture ``context``) on that folder, which
  the fits and diagnoses of every module use (they each made their own before).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import pytest

from skin_indent.runtime.threads import configure_threads

configure_threads()  # before numpy loads (``_data`` imports it): inherited by xdist workers

from _data import DATA, load_curve  # noqa: E402
from skin_indent.response_surface._store import file_lock  # noqa: E402 - the run cache's flock


def build_once(folder: Path, name: str, build):
    """``build()`` once per test run across xdist workers; returns its value, or None where skipped.

    The first worker to get here runs ``build`` holding an exclusive lock of
    ``folder/.<name>.lock``; a worker that arrives meanwhile waits for the lock, sees the
    marker the first one left (same ``PYTEST_XDIST_TESTRUNUID``) and returns None: what
    was built is in the cache. Without xdist, ``build`` just runs.
    """
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID")
    if run is None:
        return build()
    folder.mkdir(parents=True, exist_ok=True)
    marker = folder / f".{name}.built"
    with file_lock(folder / f".{name}.lock"):
        with contextlib.suppress(OSError):
            if marker.read_text() == run:
                return None
        out = build()
        marker.write_text(run)
        return out


@pytest.fixture(scope="session")
def context(coarse_unit_surfaces):
    """The suite's one :class:`~skin_indent.runtime.context.Context`: the gallery cache, two local
    workers, no progress bar.

    The cache holds the coarse unit-radius surfaces (:func:`coarse_unit_surfaces`), which every
    coarse fit scales; a test that needs the diagnosis surfaces of the 0.6 mm curves as well also
    requests :func:`diagnosis_surfaces` (built once per run into the same folder).
    """
    from skin_indent.runtime.context import Context

    return Context(cache_dir=coarse_unit_surfaces, workers=2, progress=False)


@pytest.fixture(scope="session")
def reference_curves():
    """The independent FE reference curves: {(E, nu): (depth_mm, force_mN)} without the h = 0 row."""
    out = {}
    for (E, nu), name in {(8.0, 0.45): "neo-hooke_halfspace_E8kPa_nu0.45.csv",
                          (5.0, 0.48): "neo-hooke_halfspace_E5kPa_nu0.48.csv"}.items():
        data = load_curve(f"reference/{name}")
        data = data[data[:, 0] > 0]
        out[(E, nu)] = (data[:, 0], data[:, 1])
    return out


@pytest.fixture(scope="session")
def gallery_cache():
    """The gallery's cache folder (``<tmp>/skin_indent_gallery``): the examples build their surfaces there."""
    return Path(tempfile.gettempdir()) / "skin_indent_gallery"


#: the hidden-effect curves of tests/data/hidden-effects (README: the answer key)
HIDDEN_EFFECT_CURVES = ("v01_clean", "v02_layer_soft_base", "v03_layer_rigid_base", "v04_stiffening", "v05_offset",
                        "v06_viscoelastic")


@pytest.fixture(scope="session")
def hidden():
    """The hidden-effect curves, loaded once per test process: ``{name: Measurement}``."""
    from skin_indent.measurement import load_csv

    return {name: load_csv(DATA / "hidden-effects" / f"{name}.csv") for name in HIDDEN_EFFECT_CURVES}


@pytest.fixture(scope="session")
def diagnosis_surfaces(gallery_cache, hidden):
    """Every coarse surface that diagnosing a 0.6 mm curve at R = 6.22 mm needs, built once per run.

    The diagnosis of the clean curve (all candidates) builds them: a few hundred
    finite-element runs, most of the suite's cost on an empty cache. Returns that
    :class:`~skin_indent.diagnosis.Diagnosis` (``diagnose(hidden["v01_clean"],
    cache_dir=gallery_cache, mesh="coarse", workers=2)``), or None where another xdist
    worker built them.
    """
    from skin_indent.diagnosis import diagnose

    return build_once(gallery_cache, "diagnosis-surfaces",
                      lambda: diagnose(hidden["v01_clean"], cache_dir=gallery_cache, mesh="coarse", workers=2,
                                       in_loop=False))


@pytest.fixture(scope="session")
def coarse_unit_surfaces(gallery_cache):
    """The gallery cache, holding the coarse unit-radius surfaces (R = 1 mm, h/R <= 0.1 and 0.5).

    :func:`skin_indent.fitting.surface_for` scales one of them to any radius, so the
    coarse fits of several modules share them; built once per run (12 finite-element runs).
    """
    from skin_indent.fitting import unit_surface_grid
    from skin_indent.response_surface import ResponseSurface, default_settings

    def build():
        for ratio in (0.1, 0.5):
            ResponseSurface.load_or_build(unit_surface_grid(ratio), default_settings(1.0, mesh="coarse"),
                                          cache_dir=gallery_cache, workers=2, progress=False)

    build_once(gallery_cache, "coarse-unit-surfaces", build)
    return gallery_cache
