"""Figures and a self-contained HTML page of a :class:`~skin_indent.diagnosis.result.Diagnosis`.

:func:`write_report` writes ``fit.png`` (measurement and every fitted model),
``residuals.png`` (residual of each model against depth, and against time when the
curve has one, with the +-2 sd noise band), ``ladder.png`` (RMS and BIC of each
rung and candidate) and ``index.html``, which embeds the three figures as base64 PNG
so that the page reads offline in any browser, with the verdict, the parameter table,
the ladder and the provenance (a table, and the record as JSON).

The page is rendered by jinja2 from the template ``templates/diagnosis.html`` shipped with
the package (autoescaped: a file name or a message cannot inject markup). The template loops
over curves: :func:`page_context` makes the entry of one diagnosis, :func:`render_page` a
page of any number of them with one provenance.

Every number comes from the :class:`~skin_indent.diagnosis.result.Diagnosis` as it is:
one rung per model (parameters, standard deviations, RMS, BIC), the same as its text
report and its JSON; :func:`page_context` formats them, the template only places them.
The page and the figures show them in the units of the curve's scale, as the text report
does (:attr:`~skin_indent.diagnosis.result.Diagnosis.units`: um, nN and Pa for an AFM-scale
curve, mm, mN and kPa for skin).
"""

from __future__ import annotations

import base64
import functools
import math
from pathlib import Path

import numpy as np

from ..runtime.atomic import atomic_write
from ..diagnosis.criteria import FROM_FE
from ..fitting.bodies import body_lines
from ..measurement.scale import shown_in
from ..runtime.json_io import dumps
from .. import __version__
from ._save import save_figure
from .labels import line_styles, model_label, same_curve_as
from .sample_figure import sample_diagnosis_figure

FIGURES = ("fit.png", "residuals.png", "ladder.png")
#: the page's template, in ``skin_indent/report/templates`` (package data)
TEMPLATE = "diagnosis.html"


def _models(diag):
    """Ladder rungs, the other explanations, then the first ranked candidates (at most three), without
    duplicates (a model is one rung of the diagnosis wherever it appears)."""
    out, seen = [], set()
    for f in (*diag.ladder, *diag.alternatives, *diag.ranking[:3]):
        if f.model not in seen:
            seen.add(f.model)
            out.append(f)
    return out


def _canvas(fig, figsize):
    """``fig`` (a Figure or a SubFigure to draw into), else a new Figure of ``figsize`` (inches)."""
    if fig is not None:
        return fig
    from matplotlib.figure import Figure  # no pyplot: no GUI backend, no global state

    return Figure(figsize=figsize, layout="constrained")


def _verdicts(diag) -> str:
    """``"sample: viscoelastic; instrument: drag"`` (a diagnosis made before the instrument had effects:
    ``"verdict ..."``)."""
    return diag.verdicts() if hasattr(diag, "verdicts") else f"verdict {diag.verdict}"


def fit_figure(diag, fig=None):
    """The measurement and every fitted model against depth (``fit.png``).

    Models are drawn in the order of :func:`_models` with their own line styles and
    markers (the later ones dashed, dotted and thinner, on top), and a model whose curve
    is the same as an earlier one's says so in the legend ("same curve as ..."). Depth and
    force in the units of the diagnosis (:attr:`~skin_indent.diagnosis.result.Diagnosis.units`).

    Parameters
    ----------
    diag : Diagnosis
    fig : matplotlib.figure.Figure or SubFigure, optional
        Draw into this (e.g. a panel of a composite figure); default a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig`` when given.
    """
    d, u = diag.data, diag.units
    models = _models(diag)
    fig = _canvas(fig, (7, 4.5))
    ax = fig.subplots()
    depth = np.asarray(d.depth_mm) * u.per_mm
    ax.plot(depth, np.asarray(d.force_mN) * u.per_mN, ".", ms=3, color="0.4", label="measurement")
    names = [model_label(f.model) for f in models]
    same = same_curve_as([f.prediction_mN for f in models], names)
    for f, name, style in zip(models, names, line_styles(len(models), np.size(d.depth_mm))):
        ax.plot(depth, np.asarray(f.prediction_mN) * u.per_mN, **style,
                label=f"{name} (RMS {f.rms_mN * u.per_mN:.3g} {u.force})"
                + (f": same curve as {same[name]}" if name in same else ""))
    ax.set_xlabel(f"depth ({u.length})")
    ax.set_ylabel(f"force ({u.force})")
    ax.set_title(f"{Path(d.source).name}: {_verdicts(diag)}" + (" (provisional)" if diag.provisional else ""),
                 fontsize=9)
    ax.legend(fontsize=8)
    return fig


def residual_figure(diag, fig=None):
    """The residual of each model against depth (and time), with the +-2 sd noise band (``residuals.png``),
    in the units of the diagnosis (:attr:`~skin_indent.diagnosis.result.Diagnosis.units`).

    Parameters
    ----------
    diag : Diagnosis
    fig : matplotlib.figure.Figure or SubFigure, optional
        Draw into this; default a new figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    d, u = diag.data, diag.units
    models = _models(diag)
    timed = d.time_s is not None
    fig = _canvas(fig, (9 if timed else 7, 2.2 * len(models) + 0.4))
    axes = fig.subplots(len(models), 2 if timed else 1, squeeze=False, sharex="col")
    band = 2.0 * diag.noise_mN * u.per_mN
    xs = [(np.asarray(d.depth_mm) * u.per_mm, f"depth ({u.length})")] + ([(d.time_s, "time (s)")] if timed else [])
    for row, f in zip(axes, models):
        for ax, (x, label) in zip(row, xs):
            ax.axhspan(-band, band, color="tab:green", alpha=0.15, lw=0, label="noise: ±2 sd")
            for kind, color in (("approach", "tab:blue"), ("hold", "tab:orange"), ("retract", "tab:red")):
                sel = d.kind == kind
                if np.any(sel):
                    ax.plot(x[sel], np.asarray(f.residual_mN)[sel] * u.per_mN, ".", ms=3, color=color, label=kind)
            ax.axhline(0.0, color="k", lw=0.6)
            ax.set_ylabel(f"residual ({u.force})", fontsize=8)
            ax.set_title(f"{model_label(f.model)}: {'white' if f.white else 'structured'}", fontsize=9)

    for ax, (_, label) in zip(axes[-1], xs):
        ax.set_xlabel(label)
    axes[0][0].legend(fontsize=7, loc="best")
    return fig


def ladder_figure(diag, fig=None):
    """RMS and BIC of each model (``ladder.png``): the models by their names, BIC lower is better; the
    RMS in the force unit of the diagnosis (:attr:`~skin_indent.diagnosis.result.Diagnosis.units`).

    Parameters
    ----------
    diag : Diagnosis
    fig : matplotlib.figure.Figure or SubFigure, optional
        Draw into this; default a new figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    models = _models(diag)
    u = diag.units
    fig = _canvas(fig, (9, 4.2))
    a1, a2 = fig.subplots(1, 2)
    names = [model_label(f.model).replace(" + ", "\n+ ") for f in models]  # one effect per line
    if getattr(diag, "joint", False):  # several curves: each curve's RMS over its own noise, side by side
        k, width = len(diag.curves), 0.8 / len(diag.curves)
        x = np.arange(len(models))
        for j, (c, noise) in enumerate(zip(diag.curves, diag.noises_mN)):
            a1.bar(x + (j - (k - 1) / 2) * width, [f.curve_rms_mN[j] / noise for f in models], width,
                   color=f"C{j}", label=f"curve {j + 1} (R = {c.radius_mm * u.per_mm:g} {u.length})")
        a1.set_xticks(x, names)
        a1.axhline(1.0, color="tab:green", ls="--", label="noise")
        a1.axhline(1.3, color="tab:green", ls=":", label="1.3 x noise")
        a1.set_ylabel("RMS residual / the curve's noise")
    else:
        a1.bar(names, [f.rms_mN * u.per_mN for f in models], color="tab:blue")
        a1.axhline(diag.noise_mN * u.per_mN, color="tab:green", ls="--", label="noise")
        a1.axhline(1.3 * diag.noise_mN * u.per_mN, color="tab:green", ls=":", label="1.3 x noise")
        a1.set_ylabel(f"RMS residual ({u.force})")
    a1.set_title("misfit: down to the noise is enough", fontsize=9)
    a1.legend(fontsize=8)
    a2.bar(names, [f.bic for f in models], color="tab:purple")
    a2.set_ylabel("BIC (lower is better)")
    a2.set_title("evidence (BIC): lower is better", fontsize=9)
    for a in (a1, a2):
        a.tick_params(axis="x", labelsize=7)
    return fig


def figures(diag, out_dir, provenance: dict | None = None) -> list[Path]:
    """Write the three PNG figures into ``out_dir``, each with ``provenance`` (default the
    diagnosis's own) in its metadata (:func:`skin_indent.report.save_figure`); returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    prov = provenance or getattr(diag, "provenance", None)
    paths = []
    draws = (fit_figure, residual_figure, ladder_figure)
    names = FIGURES
    if getattr(diag, "joint", False):  # several curves: each with the last rung and every rung's residual
        draws, names = (sample_diagnosis_figure, ladder_figure), ("fit.png", "ladder.png")
    for name, draw in zip(names, draws):
        paths.append(out / name)
        save_figure(draw(diag), paths[-1], prov)
    return paths


def _fmt(v) -> str:
    """A parameter or standard deviation as the page shows it (4 significant digits)."""
    if isinstance(v, float):
        if math.isinf(v):
            return "inf (rigid)" if v > 0 else "-inf"
        if math.isnan(v):
            return "-"
        return f"{v:.4g}"
    return str(v)


def _surface_line(s) -> str:
    """One surface of a provenance record, as the page names it."""
    if not isinstance(s, dict):
        return str(s)
    settings = s.get("settings") or {}
    where = ", ".join(f"{k} {settings[k]}" for k in ("mesh",) if k in settings)
    if "radius_mm" in settings:
        where += f"{', ' if where else ''}R = {settings['radius_mm']:g} mm"
    what = " ".join(str(x) for x in (s.get("type"), settings.get("model")) if x)
    ident = f"hash {str(s['hash'])[:12]}" if s.get("hash") else "its runs made during the fit"
    return f"{what}{f' ({where})' if where else ''}: {ident}"


def provenance_rows(prov) -> list[tuple[str, object]]:
    """The provenance record as the rows of the page's table: ``(name, text or list of lines)``."""
    if not prov:
        return []
    libs = ", ".join(f"{k} {v}" for k, v in (prov.get("libraries") or {}).items())
    made = prov.get("api") or " ".join(map(str, prov.get("command") or ()))
    inputs = [f"{i.get('path', i.get('source', ''))}: sha256 {i.get('sha256', i.get('data_sha256', '-'))}"
              + (f" ({i['bytes']} bytes)" if "bytes" in i else "") + (f" ({i['error']})" if "error" in i else "")
              for i in prov.get("inputs") or ()]
    settings = ", ".join(f"{k} = {dumps(v)}" for k, v in (prov.get("settings") or {}).items())
    surface = prov.get("surface")
    surfaces = surface if isinstance(surface, list) else [surface] if surface else []
    return [("skin_indent", f"{prov.get('skin_indent')} (Python {prov.get('python')}; {libs})"),
            ("made by", made), ("at (UTC)", prov.get("time_utc", "")), ("inputs", inputs or "-"),
            ("settings", settings), ("surfaces", [_surface_line(s) for s in surfaces] or "-")]


def _script_json(prov) -> str:
    """The record as JSON that is safe inside ``<script>`` (no ``<``, ``>`` or ``&``: a value cannot
    close the element); ``json.loads`` of the element's text gives the record back."""
    text = dumps(prov, sort_keys=True)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def page_context(diag, figure_paths=()) -> dict:
    """The entry of one diagnosis in the page's template: its numbers, formatted as its text report
    formats them (RMS 4 significant digits, BIC 1 decimal, parameters and sd 4 significant digits), in
    the units of the diagnosis (:attr:`~skin_indent.diagnosis.result.Diagnosis.units`: the radius,
    noise and RMS in ``length`` and ``force``, the parameters renamed as
    :meth:`~skin_indent.measurement.scale.DisplayUnits.name` renames them and converted).

    Parameters
    ----------
    diag : Diagnosis
    figure_paths : sequence of path
        PNG figures to embed (base64).

    Returns
    -------
    dict
    """
    rows = []
    joint = getattr(diag, "joint", False)
    u = diag.units
    kL, kF = u.per_mm, u.per_mN
    for f in _models(diag):
        fe = diag.std_source if f is diag.current else {}
        params = [{"name": u.name(k), "value": _fmt(v * u.factor(k)), "std": _fmt(f.std.get(k, math.nan) * u.factor(k)),
                   "fe": fe.get(k) == FROM_FE} for k, v in f.parameters.items()]
        rms = ", ".join(f"{v * kF:.4g}" for v in f.curve_rms_mN) if joint else f"{f.rms_mN * kF:.4g}"
        rows.append({"model": f.model, "rms": rms, "bic": f"{f.bic:.1f}", "white": bool(f.white),
                     "parameters": params, "structure": shown_in(f.structure, u),
                     "flags": [shown_in(t, u) for t in f.flags]})
    sample = [{"number": k + 1, "source": str(c.source), "points": c.n, "radius": f"{c.radius_mm * kL:g}",
               "noise": f"{s * kF:.4g}", "noise_source": w}
              for k, (c, s, w) in enumerate(zip(diag.curves, diag.noises_mN, diag.noise_sources))] if joint else []
    return {
        "source": str(diag.data.source), "name": " + ".join(Path(c.source).name for c in diag.curves) if joint
        else Path(diag.data.source).name, "verdict": diag.verdict, "sample": sample,
        "instrument": getattr(diag, "instrument_verdict", "none"),
        "segments": [{"curve": m.curve + 1, "kind": m.kind, "points": m.n, "rms": f"{m.rms_mN * kF:.4g}",
                      "ratio": f"{m.ratio:.3g}", "white": bool(m.white), "explained": bool(m.explained),
                      "sentence": shown_in(m.sentence(), u)} for m in getattr(diag, "segments", [])],
        "provisional": bool(diag.provisional), "sentence": diag.sentence(u), "untried": list(diag.untried.items()),
        "noise": ", ".join(f"{v * kF:.4g}" for v in diag.noises_mN) if joint else f"{diag.noise_mN * kF:.4g}",
        "noise_source": diag.noise_source, "points": diag.data.n,
        "binned": 1 if joint else diag.data.binned, "n_effective": f"{diag.n_effective:.1f}",
        "radius": ", ".join(f"{c.radius_mm * kL:g}" for c in diag.curves) if joint else f"{diag.radius_mm * kL:g}",
        "length": u.length, "force": u.force,
        "models": rows, "not_detectable": [(k, shown_in(v, u)) for k, v in diag.not_detectable.items()],
        "fe_note": FROM_FE if FROM_FE in diag.std_source.values() else "",
        "notes": [shown_in(n, u) for n in diag.notes],
        "final": body_lines(diag.current, u),
        "figures": [{"name": p.name, "alt": p.stem, "base64": base64.b64encode(p.read_bytes()).decode()}
                    for p in map(Path, figure_paths)],
    }


@functools.lru_cache(maxsize=1)
def _template():
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader("skin_indent.report", "templates"), autoescape=True,
                             undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
    return env.get_template(TEMPLATE)


def render_page(curves, provenance: dict | None = None, title: str | None = None) -> str:
    """The HTML page (:data:`TEMPLATE`) of one or several diagnosed curves.

    Parameters
    ----------
    curves : sequence of dict
        From :func:`page_context`, one per curve (a section each, in this order).
    provenance : dict, optional
        The record of how the page was made (:func:`skin_indent.runtime.provenance.provenance`):
        a table, and the record as JSON in ``<script type="application/json" id="provenance">``.
    title : str, optional
        Default ``skin-indent diagnose: <file name>`` (of each curve).

    Returns
    -------
    str
    """
    curves = list(curves)
    if title is None:
        title = "skin-indent diagnose: " + ", ".join(c["name"] for c in curves)
    from markupsafe import Markup  # installed with jinja2

    return _template().render(title=title, curves=curves, generator=f"skin_indent {__version__}",
                              provenance=provenance_rows(provenance),
                              provenance_json=Markup(_script_json(provenance)) if provenance else "")


def write_report(diag, out_dir, provenance: dict | None = None) -> Path:
    """Write the PNG figures and ``index.html`` (figures embedded) into ``out_dir``; returns the page.

    Parameters
    ----------
    diag : Diagnosis
    out_dir : path
    provenance : dict, optional
        How the diagnosis was made (:func:`skin_indent.runtime.provenance.provenance`);
        default the diagnosis's own (``diag.provenance``, the API call). The page shows it
        in a table and holds it as JSON (``<script type="application/json"
        id="provenance">``); each PNG holds it in its metadata.

    Returns
    -------
    Path
        ``out_dir/index.html``, rendered by :func:`render_page` (written atomically).
    """
    out = Path(out_dir)
    prov = provenance or getattr(diag, "provenance", None)
    paths = figures(diag, out, prov)
    page = render_page([page_context(diag, paths)], prov)
    index = out / "index.html"
    atomic_write(index, lambda fh: fh.write(page.encode()))
    return index
