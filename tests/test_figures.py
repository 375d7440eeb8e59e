"""What a reader sees in the figures, checked through matplotlib's objects.

- the words (:mod:`skin_indent.report.labels`): parameter names as axis labels, model names;
- the demo's figure (:func:`skin_indent.demo.demo_figure`): every method's curve visible and
  told apart, "same curve as" where two coincide, the noise shades named (1 sd, 2 sd), no
  raw identifier (``E_kPa``, ``nu``) in an axis label or a legend;
- the diagnosis figures (:mod:`skin_indent.report.diagnosis_page`): models by their names
  (neo-Hooke, not NH), one line style per model, "same curve as" where two models give the
  same curve, the BIC panel saying lower is better;
- the per-curve fit figure (:func:`skin_indent.report.fit_figure.fit_figure`): "baseline
  removed" only where a baseline was removed.

The fits run on the coarse surfaces of the gallery cache (conftest.py), as in test_batch.py
and test_diagnose.py.
"""

import re
from pathlib import Path

import numpy as np
import pytest

from skin_indent.data import bundled_path
from skin_indent.measurement import load_csv, prepare
from skin_indent.report.labels import line_styles, model_label, parameter_label, same_curve_as
from skin_indent.runtime.context import Context

DOCS = Path(__file__).resolve().parents[1] / "docs"
#: identifiers of the code that must not reach a reader: parameter names with units, the
#: abbreviation NH, "sigma" for a standard deviation
RAW = re.compile(r"E_kPa|\bnu\b|_mm\b|_kPa\b|\bNH\b|sigma|neo-hooke")


def _texts(fig):
    """Every axis label, title, tick label of a categorical axis and legend entry of a figure."""
    out = []
    for ax in fig.axes:
        out += [ax.get_xlabel(), ax.get_ylabel(), ax.get_title()]
        legend = ax.get_legend()
        if legend is not None:
            out += [t.get_text() for t in legend.get_texts()]
    return [t for t in out if t]


def _legend(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def _line(ax, name):
    """The one line of ``ax`` whose legend entry is ``name``, or starts with ``name:`` or ``name (``."""
    lines = [ln for ln in ax.get_lines()
             if ln.get_label() == name or ln.get_label().startswith((name + ":", name + " ("))]
    assert len(lines) == 1, [ln.get_label() for ln in ax.get_lines()]
    return lines[0]


def _style(line):
    return (str(line.get_linestyle()), str(line.get_marker()))


# ------------------------------------------------------------------ words and styles
def test_parameter_labels_are_symbols_with_units():
    assert parameter_label("E_kPa") == "E (kPa)"
    assert parameter_label("nu") == "ν"
    assert parameter_label("mu") == "μ"
    assert parameter_label("tau1_s") == "τ₁ (s)"
    assert parameter_label("g1") == "g₁"
    assert parameter_label("C20_kPa") == "C₂₀ (kPa)"
    assert parameter_label("thickness_mm") == "thickness (mm)"
    assert parameter_label("thickness2_mm") == "thickness 2 (mm)"
    assert parameter_label("contact_point_mm") == "contact point (mm)"
    assert parameter_label("w_mJ_per_m2") == "w (mJ/m²)"
    assert parameter_label("ratio") == "ratio"


def test_model_labels_are_written_out():
    assert model_label("neo-hooke") == "neo-Hooke"
    assert model_label("neo-hooke+layer+layer") == "neo-Hooke + layer + layer"


def test_line_styles_tell_every_curve_apart():
    styles = line_styles(5, 100)
    assert len({(str(s["linestyle"]), s["marker"]) for s in styles}) == 5
    widths = [s["linewidth"] for s in styles]
    assert widths == sorted(widths, reverse=True) and widths[-1] > 0  # the later ones thinner, on top
    # markers of curves drawn on top of each other do not fall on the same points
    starts = [s["markevery"][0] for s in styles if s["marker"]]
    assert len(set(starts)) == len(starts)


def test_same_curve_as_names_the_first_identical_curve():
    x = np.linspace(0, 1, 50)
    curves = [x**1.5, x**1.5 * (1 + 1e-5), x**2, x**1.5]
    assert same_curve_as(curves, ["a", "b", "c", "d"]) == {"b": "a", "d": "a"}
    assert same_curve_as([x, 2 * x], ["a", "b"]) == {}


# ------------------------------------------------------------------ the demo's figure
@pytest.fixture(scope="module")
def demo_results(coarse_unit_surfaces):
    """The demo's three identifications of the bundled forearm-like curve, on the coarse surface."""
    from skin_indent import demo
    from skin_indent.fitting import PAPER_TOLERANCE, identify, surface_for
    from skin_indent.inverse import estimate_noise

    m = load_csv(bundled_path("forearm_like.csv"), radius_mm=demo.RADIUS_MM)
    data = prepare(m, window=demo.WINDOW_MM, contact="origin").data
    surface = surface_for(demo.RADIUS_MM, demo.WINDOW_MM[1], mesh="coarse",
                          context=Context(cache_dir=coarse_unit_surfaces, workers=1, progress=False))
    noise = estimate_noise(data.depth_mm, data.force_mN)
    results = {
        "ekf-paper": identify(data, surface, "ekf-paper", x0=demo.PAPER_START, tol=PAPER_TOLERANCE),
        "ekf": identify(data, surface, "ekf", noise_mN=noise),
        "lsq": identify(data, surface, "lsq", noise_mN=noise),
    }
    return data, surface, results, noise


def test_demo_figure_shows_every_method_and_names_what_it_draws(demo_results):
    from skin_indent.demo import demo_figure

    data, surface, results, noise = demo_results
    fig = demo_figure(data, surface, results, noise)
    fit_ax, residual_ax = fig.axes[0], fig.axes[1]
    texts = _texts(fig)
    assert not [t for t in texts if RAW.search(t)], texts
    # the parameter panels: symbols and units, not identifiers
    assert {ax.get_ylabel() for ax in fig.axes[2:]} == {"E (kPa)", "ν"}
    # every method: its own line, its own style, drawn where a reader sees it
    lines = {m: _line(fit_ax, m) for m in results}
    assert len({_style(ln) for ln in lines.values()}) == len(results)
    assert all(ln.get_visible() and ln.get_linewidth() > 0 for ln in lines.values())
    widths = [ln.get_linewidth() for ln in lines.values()]
    assert widths == sorted(widths, reverse=True)  # a later curve lies on top, thinner: both seen
    # a method whose curve is another's says so (computed here independently of the figure)
    curves = {m: surface.force(data.depth_mm, np.array([r.parameters["E_kPa"], r.parameters["nu"]]))
              for m, r in results.items()}
    methods = list(results)
    scale = max(np.abs(c).max() for c in curves.values())
    for j, later in enumerate(methods):
        gaps = [np.abs(curves[m] - curves[later]).max() / scale for m in methods[:j]]
        if any(g < 1e-4 for g in gaps):  # the same curve to a thousandth of a line width
            assert "same curve as" in lines[later].get_label()
        elif all(g > 5e-3 for g in gaps):  # apart by more than a line width
            assert "same curve" not in lines[later].get_label()
    # the two noise shades each say what they are
    legend = _legend(residual_ax)
    assert "noise: ±1 sd" in legend and "noise: ±2 sd" in legend
    assert len({_style(_line(residual_ax, m)) for m in results}) == len(results)
    for m, r in results.items():  # the legend gives E and ν of each method
        assert f"ν = {r.parameters['nu']:.3f}" in lines[m].get_label()


# ------------------------------------------------------------------ the diagnosis figures
@pytest.fixture(scope="module")
def diagnosis(gallery_cache, hidden, diagnosis_surfaces):
    """A layer curve examined against two candidates: stiffening gives the half-space's curve."""
    from skin_indent.diagnosis import diagnose

    return diagnose(hidden["v02_layer_soft_base"], candidates=("offset", "stiffening"), max_rungs=0,
                    in_loop=False, cache_dir=gallery_cache, mesh="coarse", workers=2)


def test_ladder_figure_names_the_models_and_says_lower_bic_is_better(diagnosis):
    from skin_indent.report.diagnosis_page import _models, ladder_figure

    fig = ladder_figure(diagnosis)
    rms_ax, bic_ax = fig.axes
    names = [t.get_text() for t in bic_ax.get_xticklabels()]
    assert names == [model_label(f.model).replace(" + ", "\n+ ") for f in _models(diagnosis)]
    assert names[0] == "neo-Hooke" and len(names) == 3
    assert not [t for t in _texts(fig) + names if RAW.search(t)]
    assert "lower is better" in bic_ax.get_ylabel()
    assert [p.get_height() for p in bic_ax.patches] == [f.bic for f in _models(diagnosis)]


def test_fit_figure_keeps_every_model_visible(diagnosis):
    from skin_indent.report.diagnosis_page import _models, fit_figure

    fig = fit_figure(diagnosis)
    (ax,) = fig.axes
    models = _models(diagnosis)
    lines = [_line(ax, model_label(f.model)) for f in models]
    assert len({_style(ln) for ln in lines}) == len(models)
    assert not [t for t in _texts(fig) if RAW.search(t)]
    scale = np.abs(diagnosis.data.force_mN).max()
    for j, (f, line) in enumerate(zip(models, lines)):
        twins = [g for g in models[:j] if np.abs(g.prediction_mN - f.prediction_mN).max() < 1e-3 * scale]
        if twins:  # the curve it is the same as is named
            assert f"same curve as {model_label(twins[0].model)}" in line.get_label()
        elif all(np.abs(g.prediction_mN - f.prediction_mN).max() > 5e-3 * scale for g in models[:j]):
            assert "same curve" not in line.get_label()


def test_residual_figure_titles_use_model_names(diagnosis):
    from skin_indent.report.diagnosis_page import _models, residual_figure

    fig = residual_figure(diagnosis)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles and all(t.split(":")[0] in {model_label(f.model) for f in _models(diagnosis)} for t in titles)
    assert "noise: ±2 sd" in _legend(fig.axes[0])


def test_the_readme_figure_is_made_by_the_docs_script_from_the_diagnosis_figures(diagnosis):
    """docs/make_static_figures.py draws the page's fit and ladder figures side by side, and the README's
    PNG (docs/_static/diagnose_ladder.png) says it was made by that script from the bundled curve."""
    import hashlib
    import importlib.util

    from skin_indent.report.diagnosis_page import _models
    from skin_indent.runtime.provenance import read_provenance

    spec = importlib.util.spec_from_file_location("make_static_figures", DOCS / "make_static_figures.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    fig = script.ladder_panels(diagnosis)
    fit_ax, rms_ax, bic_ax = fig.axes
    names = [t.get_text() for t in bic_ax.get_xticklabels()]
    assert names == [model_label(f.model).replace(" + ", "\n+ ") for f in _models(diagnosis)]
    assert "lower is better" in bic_ax.get_ylabel()
    assert [ln.get_label().split(" (RMS")[0] for ln in fit_ax.get_lines()][1:] == [model_label(f.model)
                                                                                for f in _models(diagnosis)]
    title = " ".join(t.get_text() for t in fig.texts)  # the suptitle
    assert f"RMS {diagnosis.base.rms_mN:.3g} mN" in title and diagnosis.verdict in title
    assert not [t for t in _texts(fig) + names + [title] if RAW.search(t)]
    prov = read_provenance(DOCS / "_static" / "diagnose_ladder.png")
    assert prov["command"][:2] == ["python", "docs/make_static_figures.py"] and prov["settings"]["mesh"] == "coarse"
    (curve,) = prov["inputs"]
    source = bundled_path(script.CURVE)
    assert curve["sha256"] == hashlib.sha256(source.read_bytes()).hexdigest()
    assert {s["type"] for s in prov["surface"]} == {"ResponseSurface", "EffectSurface"}


# ------------------------------------------------------------------ the per-curve fit figure
@pytest.mark.parametrize("name, removed", [("afm_jpk_force-save-example_R18.64um.csv", True),
                                           ("forearm_like.csv", False)])
def test_fit_figure_says_baseline_removed_only_when_it_was(coarse_unit_surfaces, name, removed):
    from skin_indent.fitting import fit
    from skin_indent.report.fit_figure import fit_figure

    result = fit(load_csv(bundled_path(name)), mesh="coarse",
                 context=Context(cache_dir=coarse_unit_surfaces, workers=1, progress=False))
    assert (result.data.baseline is not None) == removed  # the AFM curve has a pre-contact baseline
    top = fit_figure(result).axes[0]
    legend = _legend(top)
    assert ("approach (baseline removed)" in legend) == removed
    assert ("approach as recorded" in legend) == (not removed)
    assert not [t for t in legend if RAW.search(t)], legend
