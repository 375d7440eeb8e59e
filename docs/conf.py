"""Sphinx configuration of the skin_indent documentation.

Build (from the root of a clone, with the ``docs`` extra installed)::

    python -m sphinx -W -b html docs docs/_build/html

This runs the gallery scripts in ``examples/`` (about a minute on the coarse meshes
they use). ``-D plot_gallery=0`` builds the pages without running them.

The build needs no network: there is no intersphinx, and MathJax is served from the
build's own ``_static/mathjax`` (sphinx-mathjax-offline), so the formulas render in a
browser that is offline too.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# document the sources of this checkout, installed or not
sys.path.insert(0, str(ROOT / "src"))

import skin_indent  # noqa: E402

# -- project ---------------------------------------------------------------------------
project = "skin_indent"
author = "skin_indent developers"
copyright = "skin_indent developers"
version = release = skin_indent.__version__

# -- extensions ------------------------------------------------------------------------
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax copied into _static/mathjax: the formulas render offline
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "sphinxarg.ext",  # the command-line reference (cli.rst), generated from skin_indent.cli.build_parser
]

exclude_patterns = ["_build", "README.md", "gallery/*.ipynb", "gallery/*.py", "gallery/*.zip",
                    "gallery/*.json", "gallery/*.md5"]
templates_path: list[str] = []
# A docstring in src/ writes |H| (a norm) in plain text, which reStructuredText reads as a
# substitution: define it as itself. Remove once that docstring uses ``|H|``.
nitpicky = False  # numpy/scipy/skfem types are not linked (no intersphinx: the build is offline)

# -- autodoc / numpydoc ----------------------------------------------------------------
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # the numpydoc sections carry the types and units
autosummary_generate = False  # the API page lists its entries explicitly, no stub files
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# -- sphinx-gallery (FElupe style: numbered exNN_*.py, in file-name order) --------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"ex\d\d_.*\.py",
    "ignore_pattern": r"__init__\.py",
    "within_subsection_order": "sphinx_gallery.sorting.FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "show_memory": False,
    "min_reported_time": 1,
}

# -- HTML ------------------------------------------------------------------------------
try:
    import pydata_sphinx_theme  # noqa: F401
except ImportError:  # the build also works without the theme
    html_theme = "alabaster"
else:
    html_theme = "pydata_sphinx_theme"
    html_theme_options = {
        "navigation_with_keys": False,
        "show_toc_level": 2,
        "secondary_sidebar_items": ["page-toc"],
        "footer_start": ["copyright"],
        "footer_end": ["sphinx-version"],
    }
html_title = f"skin_indent {release}"
html_static_path: list[str] = []
html_show_sourcelink = False
