"""The gallery scripts run, and each computes the number it is about (as scikit-fem tests its examples).

Design, to run every example once in CI:

- each test runs one script of ``examples/`` with :func:`runpy.run_path` (as
  ``__main__``, matplotlib's Agg backend, ``plt.show`` a no-op, from a scratch working
  directory) and asserts ONE number the script computes, read from its globals;
- ``test_docs_build`` builds the documentation with ``sphinx -W`` (warnings are errors)
  but ``-D plot_gallery=0``: the gallery pages are generated from the scripts without
  running them again, so API pages, theory and the gallery's reST are checked in about
  10 s;
- ``test_docs_build_with_gallery`` (marker ``slow``) is the documented full build, which
  also runs the scripts inside sphinx-gallery (about 1.5 minutes).
- the scripts' tests and the docs builds carry the marker ``gallery``: not in the default run
  (``python -m pytest``), ``.ci/run`` runs them in a second invocation.

ex04 and ex05 share a response surface cached in the temporary folder
(``skin_indent_gallery``), keyed by a hash of its grid and of the forward-model sources,
so it is built once (about 10 s) and reused, also by a later docs build: the two run in one
xdist group (one worker), one after the other. ex06 diagnoses on the coarse surfaces that
tests/test_diagnose.py uses, built once per run by the ``diagnosis_surfaces`` fixture.
"""

from __future__ import annotations

import importlib.util
import re
import runpy
import subprocess
import sys
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
DOCS = ROOT / "docs"
#: the scripts and the docs build: out of the default run, .ci/run runs them (pyproject.toml); the check
#: that every script has a test stays in it
GALLERY = pytest.mark.gallery


@pytest.fixture
def run_example(monkeypatch, tmp_path):
    """Run ``examples/<name>`` as a script; return its globals."""
    import matplotlib.pyplot as plt

    monkeypatch.setattr(plt, "show", lambda *args, **kwargs: None)
    monkeypatch.chdir(tmp_path)  # a script must not depend on, or write into, the working directory

    def run(name: str) -> dict:
        try:
            return runpy.run_path(str(EXAMPLES / name), run_name="__main__")
        finally:
            plt.close("all")

    return run


def test_every_example_is_tested():
    scripts = sorted(p.name for p in EXAMPLES.glob("ex[0-9][0-9]_*.py"))
    tested = sorted(name for name in scripts if f'"{name}"' in Path(__file__).read_text())
    assert scripts == tested


@GALLERY
def test_ex01_forward_simulation(run_example):
    g = run_example("ex01_forward_simulation.py")
    # F(0.6 mm) on the coarse mesh against the independent FElupe curve (E = 8 kPa, nu = 0.45)
    assert abs(g["error_at_0_6"]) < 0.01


@GALLERY
def test_ex02_hertz_limit(run_example):
    g = run_example("ex02_hertz_limit.py")
    # all six curves (linear and neo-Hooke, nu = 0.3, 0.45, 0.49) at h/R = 0.001
    assert g["worst_small_depth_error"] < 0.01


@GALLERY
def test_ex03_mesh_convergence(run_example):
    g = run_example("ex03_mesh_convergence.py")
    # the coarse mesh against its uniform refinement, F(0.6 mm)
    assert g["coarse_error"] < 2e-3


PAPER_GRID = pytest.mark.xdist_group("gallery-paper-grid")  # ex04 and ex05 share its surface file


@GALLERY
@PAPER_GRID
def test_ex04_blind_test(run_example):
    g = run_example("ex04_blind_test.py")
    # the paper's filter from (10 kPa, 0.3) on the coarse surface; truth 31 kPa
    assert abs(g["blind_E"] - 31.0) < 0.1


@GALLERY
@PAPER_GRID
def test_ex05_invivo_identifiability(run_example):
    g = run_example("ex05_invivo_identifiability.py")
    # least squares on the bundled forearm-like curve (the paper: 5.67 kPa)
    assert abs(g["invivo_E"] - 5.7) < 0.2


@GALLERY
def test_ex06_diagnose(run_example, diagnosis_surfaces):
    g = run_example("ex06_diagnose.py")
    # a layer on a soft half-space (independent FE): named, and adding it brings the error to the noise
    assert g["verdict"] == "layer"
    assert g["rms_ladder"][-1] < 1.3 * g["added"].noise_mN < g["rms_ladder"][0]
    # three materials: the best single effect helps but leaves structure
    assert g["best"].rms_mN < g["forearm"].base.rms_mN and not g["best"].white


@GALLERY
def test_ex07_dask_cluster(run_example):
    pytest.importorskip("distributed", reason="dask.distributed is not installed (pip install 'skin_indent[dask]')")
    g = run_example("ex07_dask_cluster.py")
    assert g["max_difference"] == 0.0  # where the runs happen does not change them


@GALLERY
def test_ex08_batch(run_example):
    g = run_example("ex08_batch.py")
    # a folder of real AFM curves in: one row per curve, each fitted, a table with its provenance
    rows = g["rows"]
    assert len(rows) >= 2 and not any(r.error for r in rows)
    afm = [r.E_kPa for r in rows if r.label.startswith("afm")]
    skin = [r.E_kPa for r in rows if r.label.startswith("forearm")]
    assert len(afm) == 2 and all(0.01 < E < 1.0 for E in afm)  # AFM gels and cells: ~100 Pa
    assert len(skin) == 1 and 4.0 < skin[0] < 8.0  # the forearm-like skin curve: ~5.7 kPa
    assert g["prov"]["inputs"] and g["tsv"].is_file()


def _sphinx_build(out: Path, *options: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", *options,
           str(DOCS), str(out / "html")]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)


@GALLERY
@pytest.mark.skipif(importlib.util.find_spec("sphinx") is None,
                    reason="sphinx is not installed (pip install -e '.[docs]')")
def test_docs_build(tmp_path):
    """The documented build with warnings as errors, without re-running the gallery scripts."""
    proc = _sphinx_build(tmp_path, "-D", "plot_gallery=0")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-5000:]
    html = tmp_path / "html"
    for page in ("index.html", "theory.html", "api.html", "cli.html", "instruments.html", "clusters.html",
                 "accuracy.html", "gallery/index.html", "gallery/ex05_invivo_identifiability.html"):
        assert (html / page).is_file(), page
    # the CLI reference is generated from the parser: every command and its options
    cli = (html / "cli.html").read_text()
    for text in ("demo", "simulate", "surface", "build", "diagnose", "--model", "--fix", "--prior", "--report"):
        assert text in cli, text
    # MathJax is served from the build, not a CDN: the formulas render offline
    theory = (html / "theory.html").read_text()
    scripts = re.findall(r'<script[^>]*src="([^"]*mathjax[^"]*)"', theory, flags=re.I)
    assert scripts and all("://" not in s for s in scripts), scripts
    assert all((html / s.split("?")[0]).is_file() for s in scripts), scripts


@GALLERY
@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("sphinx") is None,
                    reason="sphinx is not installed (pip install -e '.[docs]')")
def test_docs_build_with_gallery(tmp_path):
    """``python -m sphinx -W -b html docs docs/_build/html``: runs every gallery script.

    sphinx-gallery skips scripts unchanged since an earlier build in this clone
    (``docs/gallery/*.md5``); ``run_stale_examples`` makes it run them all.
    """
    proc = _sphinx_build(tmp_path, "-D", "sphinx_gallery_conf.run_stale_examples=1")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-5000:]
    images = list((tmp_path / "html" / "_images").glob("sphx_glr_ex0*.png"))
    assert len(images) >= 10
