"""Figures and a self-contained HTML page of a :class:`~skin_indent.diagnosis.workflow.Diagnosis`.

:func:`write_report` writes ``fit.png`` (measurement and every fitted model),
``residuals.png`` (residual of each model against depth, and against time when the
curve has one, with the +-2 sd noise band), ``ladder.png`` (RMS and BIC of each
rung and candidate) and ``index.html``, which embeds the three figures as base64 PNG
so that the page reads offline in any browser, with the verdict, the parameter table
and the ladder.

Every number comes from the :class:`~skin_indent.diagnosis.workflow.Diagnosis` as it is:
one rung per model (parameters, standard deviations, RMS, BIC), the same as its text
report and its JSON.
"""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import numpy as np

from ..runtime.atomic import atomic_write
from ..diagnosis.workflow import FROM_FE
from ..runtime.json_io import dumps
from ._save import save_figure
from .labels import line_styles, model_label, same_curve_as

FIGURES = ("fit.png", "residuals.png", "ladder.png")


def _models(diag):
    """Ladder rungs, the other explanations, then the first ranked candidates (at most three), without
    duplicates (a model is one rung of the diagnosis wherever it appears)."""
    out, seen = [], set()
    for f in (*diag.ladder, *diag.alternatives, *diag.ranking[:3]):
        if f.model not in seen:
            seen.add(f.model)
            out.append(f)
    return out


def fit_figure(diag):
    """The measurement and every fitted model against depth (``fit.png``).

    Models are drawn in the order of :func:`_models` with their own line styles and
    markers (the later ones dashed, dotted and thinner, on top), and a model whose curve
    is the same as an earlier one's says so in the legend ("same curve as ...").

    Parameters
    ----------
    diag : Diagnosis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure  # no pyplot: no GUI backend, no global state

    d = diag.data
    models = _models(diag)
    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.subplots()
    ax.plot(d.depth_mm, d.force_mN, ".", ms=3, color="0.4", label="measurement")
    names = [model_label(f.model) for f in models]
    same = same_curve_as([f.prediction_mN for f in models], names)
    for f, name, style in zip(models, names, line_styles(len(models), np.size(d.depth_mm))):
        ax.plot(d.depth_mm, f.prediction_mN, **style,
                label=f"{name} (RMS {f.rms_mN:.3g} mN)" + (f": same curve as {same[name]}" if name in same else ""))
    ax.set_xlabel("depth (mm)")
    ax.set_ylabel("force (mN)")
    ax.set_title(f"{Path(d.source).name}: verdict {diag.verdict}" + (" (provisional)" if diag.provisional else ""))
    ax.legend(fontsize=8)
    return fig


def residual_figure(diag):
    """The residual of each model against depth (and time), with the +-2 sd noise band (``residuals.png``).

    Parameters
    ----------
    diag : Diagnosis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    d = diag.data
    models = _models(diag)
    timed = d.time_s is not None
    fig = Figure(figsize=(9 if timed else 7, 2.2 * len(models) + 0.4), layout="constrained")
    axes = fig.subplots(len(models), 2 if timed else 1, squeeze=False, sharex="col")
    band = 2.0 * diag.noise_mN
    xs = [(d.depth_mm, "depth (mm)")] + ([(d.time_s, "time (s)")] if timed else [])
    for row, f in zip(axes, models):
        for ax, (x, label) in zip(row, xs):
            ax.axhspan(-band, band, color="tab:green", alpha=0.15, lw=0, label="noise: ±2 sd")
            for kind, color in (("approach", "tab:blue"), ("hold", "tab:orange"), ("retract", "tab:red")):
                sel = d.kind == kind
                if np.any(sel):
                    ax.plot(x[sel], f.residual_mN[sel], ".", ms=3, color=color, label=kind)
            ax.axhline(0.0, color="k", lw=0.6)
            ax.set_ylabel("residual (mN)", fontsize=8)
            ax.set_title(f"{model_label(f.model)}: {'white' if f.white else 'structured'}", fontsize=9)

    for ax, (_, label) in zip(axes[-1], xs):
        ax.set_xlabel(label)
    axes[0][0].legend(fontsize=7, loc="best")
    return fig


def ladder_figure(diag):
    """RMS and BIC of each model (``ladder.png``): the models by their names, BIC lower is better.

    Parameters
    ----------
    diag : Diagnosis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    models = _models(diag)
    fig = Figure(figsize=(9, 4.2), layout="constrained")
    a1, a2 = fig.subplots(1, 2)
    names = [model_label(f.model).replace(" + ", "\n+ ") for f in models]  # one effect per line
    a1.bar(names, [f.rms_mN for f in models], color="tab:blue")
    a1.axhline(diag.noise_mN, color="tab:green", ls="--", label="noise")
    a1.axhline(1.3 * diag.noise_mN, color="tab:green", ls=":", label="1.3 x noise")
    a1.set_ylabel("RMS residual (mN)")
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
    for name, draw in zip(FIGURES, (fit_figure, residual_figure, ladder_figure)):
        paths.append(out / name)
        save_figure(draw(diag), paths[-1], prov)
    return paths


def _fmt(v) -> str:
    if isinstance(v, float):
        if math.isinf(v):
            return "inf (rigid)" if v > 0 else "-inf"
        if math.isnan(v):
            return "-"
        return f"{v:.4g}"
    return html.escape(str(v))


def _provenance_block(prov) -> str:
    """The provenance as a readable table, and as JSON in ``<script id="provenance">``."""
    if not prov:
        return ""
    libs = ", ".join(f"{k} {v}" for k, v in (prov.get("libraries") or {}).items())
    made = prov.get("api") or " ".join(map(str, prov.get("command") or ()))
    inputs = "<br>".join(
        html.escape(f"{i.get('path', i.get('source', ''))}: sha256 {i.get('sha256', i.get('data_sha256', '-'))}"
                    + (f" ({i['bytes']} bytes)" if "bytes" in i else "") + (f" ({i['error']})" if "error" in i else ""))
        for i in prov.get("inputs") or ())
    settings = ", ".join(f"{k} = {dumps(v)}" for k, v in (prov.get("settings") or {}).items())
    surface = prov.get("surface")
    surfaces = surface if isinstance(surface, list) else [surface] if surface else []
    cells = [("skin_indent", f"{prov.get('skin_indent')} (Python {prov.get('python')}; {libs})"),
             ("made by", made), ("at (UTC)", prov.get("time_utc", "")), ("inputs", None), ("settings", settings),
             ("surfaces", ", ".join(str(s.get("hash", ""))[:12] for s in surfaces if isinstance(s, dict)) or "-")]
    rows = "".join(f"<tr><th>{k}</th><td>{inputs or '-' if v is None else html.escape(str(v))}</td></tr>"
                   for k, v in cells)
    record = dumps(prov, sort_keys=True).replace("</", "<\\/")
    return (f'<h2>Provenance</h2>\n<table id="provenance-table">{rows}</table>\n'
            f'<script type="application/json" id="provenance">{record}</script>\n')


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
    """
    out = Path(out_dir)
    prov = provenance or getattr(diag, "provenance", None)
    paths = figures(diag, out, prov)
    imgs = "\n".join(
        f'<figure><img alt="{p.stem}" src="data:image/png;base64,{base64.b64encode(p.read_bytes()).decode()}">'
        f"<figcaption>{p.name}</figcaption></figure>" for p in paths)
    rows = []
    for f in _models(diag):
        fe = diag.std_source if f is diag.current else {}
        params = ", ".join(f"{k} = {_fmt(v)} &plusmn; {_fmt(f.std.get(k, math.nan))}"
                           + ("<sup>FE</sup>" if fe.get(k) == FROM_FE else "") for k, v in f.parameters.items())
        rows.append(f"<tr><td>{html.escape(f.model)}</td><td>{f.rms_mN:.4g}</td><td>{f.bic:.1f}</td>"
                    f"<td>{'yes' if f.white else 'no'}</td><td>{params}</td><td>{html.escape(f.structure)}</td></tr>")
    nd = "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>" for k, v in diag.not_detectable.items())
    untried = "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>" for k, v in diag.untried.items())
    provisional = ("" if not diag.provisional else
                   f'<p class="provisional" id="provisional"><b>Provisional:</b> combinations not tried</p>'
                   f"<ul>{untried}</ul>")
    fe_note = ("" if FROM_FE not in diag.std_source.values() else
               f"<p><sup>FE</sup> standard deviation from {FROM_FE} at the fitted values (it decides whether the "
               "parameter is determined); the others from the fit's covariance.</p>")
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>skin-indent diagnose: {html.escape(Path(diag.data.source).name)}</title>
<style>body{{font-family:sans-serif;max-width:1000px;margin:2em auto;line-height:1.4}}
table{{border-collapse:collapse;font-size:0.85em}}td,th{{border:1px solid #ccc;padding:4px}}
img{{max-width:100%}}.verdict{{font-size:1.1em;background:#eef;padding:0.8em}}.provisional{{background:#fec;padding:0.5em}}</style></head>
<body>
<h1>Diagnosis of {html.escape(str(diag.data.source))}</h1>
<p class="verdict" id="verdict"><b>Verdict: {html.escape(diag.verdict)}{' (provisional)' if diag.provisional else ''}.</b> {html.escape(diag.sentence())}</p>
{provisional}
<p>Noise {diag.noise_mN:.4g} mN, {html.escape(diag.noise_source)}; {diag.data.n} points
(binned by {diag.data.binned}); effective sample size {diag.n_effective:.1f} (every BIC); sphere R = {diag.radius_mm:g} mm.</p>
<h2>Models</h2>
<table><tr><th>model</th><th>RMS (mN)</th><th>BIC</th><th>white</th><th>parameters</th><th>where it fails</th></tr>
{''.join(rows)}</table>
{fe_note}<h2>Not detectable here</h2><ul>{nd or '<li>-</li>'}</ul>
<h2>Figures</h2>
{imgs}
{_provenance_block(prov)}</body></html>
"""
    index = out / "index.html"
    atomic_write(index, lambda fh: fh.write(page.encode()))
    return index
