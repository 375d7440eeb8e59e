"""The outputs of a batch of diagnoses: a line per curve, the verdicts per curve and over each force map.

- :func:`verdict_line`: the line ``skin-indent diagnose`` prints per curve of a batch;
- :func:`verdict_figure`: per curve, which effect is missing (the verdict, in colour), the misfit
  (RMS / noise) and the main modulus E of the final model;
- :func:`map_figure`: the same three over the positions of one force map, a pixel per curve, the
  verdicts in categorical colours with a legend;
- :func:`write_batch_figures`: ``verdicts.png`` and, per force map, ``NAME_map.png``, each with the
  batch's provenance (:func:`~skin_indent.report.save_figure`);
- :func:`write_curve_report`: the HTML report of one curve's diagnosis in a folder of its own.

Every number is the row's (:class:`skin_indent.diagnosis.DiagnosisRow`), which is the diagnosis'
own: one set of numbers per curve in the text, the table, the figures and the reports. An effect
keeps its colour in every figure (:func:`verdict_colours`).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ..diagnosis.batch import FAILED
from ..effects import EFFECTS
from ..measurement.scale import display_units
from ..runtime.batch import one_line, row_provenance
from ._save import save_figure
from .diagnosis_page import write_report
from .labels import model_label

__all__ = ["force_maps", "map_figure", "verdict_colours", "verdict_figure", "verdict_line",
           "write_batch_figures", "write_curve_report"]

#: fixed colours of the verdicts that are not an effect
_SPECIAL = {"none": "#d9d9d9", "ambiguous": "#c994c7", "unexplained": "#252525", FAILED: "#ffffff"}
#: tab10 without its grey (kept for "none"): the colours of single effects, in the vocabulary's order
_EFFECT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#d62728", "#e377c2", "#bcbd22",
                   "#17becf")
#: combinations of effects (``offset+layer``): light and dark shades of tab20b, in order of appearance
_COMBO_COLOURS = ("#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#6b6ecf", "#b5cf6b", "#e7ba52",
                  "#d6616b", "#ce6dbd")


def _order(verdicts) -> list[str]:
    """Verdicts in the order of a legend: none, the single effects in the vocabulary's order, the
    combinations, ambiguous, unexplained, failed."""
    present = set(verdicts)
    singles = [e for e in EFFECTS if e in present]
    singles += sorted(v for v in present if v not in _SPECIAL and "+" not in v and v not in singles)
    combos = sorted(v for v in present if "+" in v)
    return [v for v in ("none",) if v in present] + singles + combos + [v for v in ("ambiguous", "unexplained",
                                                                                   FAILED) if v in present]


def verdict_colours(verdicts) -> dict[str, str]:
    """A colour per verdict: fixed ones for ``none``, ``ambiguous``, ``unexplained`` and ``failed``,
    each registered effect its own (the same in every figure), combinations in order of appearance."""
    out, combos = {}, 0
    for v in _order(verdicts):
        if v in _SPECIAL:
            out[v] = _SPECIAL[v]
        elif "+" in v:
            out[v] = _COMBO_COLOURS[combos % len(_COMBO_COLOURS)]
            combos += 1
        else:
            names = list(EFFECTS) + sorted(x for x in verdicts if x not in EFFECTS and x not in _SPECIAL)
            out[v] = _EFFECT_COLOURS[names.index(v) % len(_EFFECT_COLOURS)]
    return out


def verdict_line(row) -> str:
    """One line of text of a batch row, in the units of its scale.

    Returns
    -------
    str
        ``label: sample: verdict [(provisional)]; instrument: drag, baselines; final model M: E = ... kPa +- ..., misfit ... x noise,
        white|structured[; other explanations: ...]`` (``Pa`` for an AFM-scale sphere), or
        ``label: error: ...``.
    """
    if row.error:
        return f"{row.label}: error: {row.error}"
    u = display_units(row.radius_mm)
    sd = "" if not math.isfinite(row.E_std_kPa) else f" +- {row.E_std_kPa * u.per_kPa:.2g}"
    instrument = getattr(row, "instrument", "")
    verdict = row.verdict + (" (provisional)" if row.provisional else "")
    if instrument:
        verdict = f"sample: {verdict}; instrument: {instrument}"
    text = (f"{row.label}: {verdict}; final model "
            f"{row.model}: E = {row.E_kPa * u.per_kPa:.4g}{sd} {u.modulus}, misfit {row.misfit:.3g} x noise, "
            f"{'white' if row.white else 'structured'}")
    if len(row.confounded_with) > 1:
        text += f"; nearly as good: {', '.join(row.confounded_with[1:])}"
    return text + (f" [{'; '.join(row.flags)}]" if row.flags else "")


def force_maps(rows) -> dict[str, list]:
    """``{file: rows}`` of the files whose curves have map positions or grid indices (force maps)."""
    out: dict = {}
    for r in rows:
        if r.index is not None and ((r.grid_x is not None and r.grid_y is not None)
                                    or (r.x_mm is not None and r.y_mm is not None)):
            out.setdefault(r.file, []).append(r)
    return out


def _legend(where, colours, counts, provisional: bool, **kw) -> None:
    """The legend of the verdicts (an axes' or a figure's): a patch per verdict with its number of curves."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Patch(facecolor=c, edgecolor="0.3", label=f"{v} ({counts.get(v, 0)})") for v, c in colours.items()]
    if FAILED in colours:
        handles[list(colours).index(FAILED)] = (handles[list(colours).index(FAILED)],
                                                Line2D([], [], marker="x", color="0.35", linestyle="none"))
    labels = [f"{v} ({counts.get(v, 0)})" for v in colours]
    if provisional:
        handles.append(Line2D([], [], marker="o", markersize=4, color="k", linestyle="none"))
        labels.append("provisional (combinations untried)")
    where.legend(handles, labels, title="missing effect", fontsize=8, title_fontsize=8, **kw)


def _plain_ticks(axis) -> None:
    """Tick labels of a log axis as plain numbers (0.5, 1, 2, 5...), not powers of ten."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def _modulus_values(rows, u) -> np.ndarray:
    return np.array([r.E_kPa * u.per_kPa if not r.error else np.nan for r in rows], dtype=float)


def verdict_figure(rows, *, title: str | None = None):
    """Per curve of a batch: the verdict, the misfit and E of the final model.

    Parameters
    ----------
    rows : sequence of DiagnosisRow
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        Three panels over the curves, in row order: the verdict as a coloured bar (hatched when
        provisional; failed curves white), the misfit RMS / noise of the final model (log scale;
        1 is the noise), and its main modulus E with one standard deviation (log scale), in the
        units of the first row's scale.
    """
    from matplotlib.figure import Figure  # no pyplot: no GUI backend, no global state

    rows = list(rows)
    n = len(rows)
    cats = [r.outcome for r in rows]
    colours = verdict_colours(cats)
    counts = {v: cats.count(v) for v in colours}
    fig = Figure(figsize=(min(16.0, max(7.5, 0.28 * n + 4.5)), 7.0), layout="constrained")
    ax_v, ax_m, ax_e = fig.subplots(3, 1, sharex=True, height_ratios=(0.6, 1.0, 1.2))
    x = np.arange(n)
    ok = np.array([not r.error for r in rows], dtype=bool)
    ax_v.bar(x, np.ones(n), width=0.9, color=[colours[c] for c in cats], edgecolor="0.3", linewidth=0.5,
             hatch=None)
    prov = np.array([bool(r.provisional) and not r.error for r in rows], dtype=bool)
    if np.any(prov):
        ax_v.plot(x[prov], np.full(prov.sum(), 0.5), "o", color="k", markersize=4)
    failed = ~ok
    if np.any(failed):
        ax_v.plot(x[failed], np.full(failed.sum(), 0.5), "x", color="0.4", markersize=6)
    ax_v.set_yticks([])
    ax_v.set_ylim(0, 1)
    ax_v.set_ylabel("verdict")
    _legend(ax_v, colours, counts, bool(np.any(prov)), loc="upper left", bbox_to_anchor=(1.01, 1.0))
    misfit = np.array([r.misfit for r in rows], dtype=float)
    u = display_units(next((r.radius_mm for r in rows if not r.error), math.nan))
    E = _modulus_values(rows, u)
    sd = np.array([r.E_std_kPa * u.per_kPa if not r.error else np.nan for r in rows], dtype=float)
    for k, c in enumerate(cats):
        if not ok[k]:
            continue
        ax_m.plot(x[k], misfit[k], "o", color=colours[c], markeredgecolor="0.2")
        if np.isfinite(E[k]) and E[k] > 0:
            err = sd[k] if np.isfinite(sd[k]) else 0.0
            ax_e.errorbar(x[k], E[k], yerr=[[min(err, 0.999 * E[k])], [err]], fmt="o", color=colours[c],
                          markeredgecolor="0.2", capsize=2)
    ax_m.axhline(1.0, color="0.4", linestyle="--", linewidth=1, label="RMS = noise")
    ax_m.set_ylabel("misfit\nRMS / noise")
    for ax, values, log_above in ((ax_m, misfit, 10.0), (ax_e, E, 1.0)):
        good = values[ok & np.isfinite(values) & (values > 0)]
        if not good.size:
            continue
        lo, hi = float(good.min()), float(good.max())
        if ax is ax_m:
            lo = min(lo, 1.0)
        if hi / lo <= log_above:  # a narrow range (misfits near the noise): a linear axis from 0
            ax.set_ylim(0.0, 1.15 * hi)
            continue
        ax.set_yscale("log")
        ax.set_ylim(lo / 2.0, hi * 2.0)  # by the values: a standard deviation larger than E runs off the axis
        _plain_ticks(ax.yaxis)
    ax_m.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax_e.set_ylabel(f"E of the final\nmodel ({u.modulus})")
    labels = [r.short_label() for r in rows]
    if n <= 60:
        ax_e.set_xticks(x, labels, rotation=60 if n > 3 else 0, ha="right" if n > 3 else "center",
                        fontsize=8 if n < 30 else 6)
    else:
        ax_e.set_xlabel("curve (row of the table)")
    ax_v.set_title(title or (f"What the model misses, curve by curve\n{n} curve{'s' if n != 1 else ''}: "
                             + ", ".join(f"{v} {counts[v]}" for v in colours)), fontsize=10)
    return fig


def _axis(index, position, per_mm):
    """Cell centres of one axis of a map: positions (display units) as a line through the grid
    indices when every curve has one, else the indices; and whether they are positions."""
    index = np.asarray(index, dtype=int)
    n = int(index.max()) + 1
    if position is not None and np.unique(index).size >= 2:
        slope, start = np.polyfit(index, np.asarray(position, dtype=float) * per_mm, 1)
        return start + slope * np.arange(n), True
    if position is not None:
        return float(np.mean(position)) * per_mm + np.arange(n), True
    return np.arange(n, dtype=float), False


def _edges(centres) -> np.ndarray:
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.r_[c[0] - (mid[0] - c[0]), mid, c[-1] + (c[-1] - mid[-1])]


def _grid_of(rows, per_mm):
    """``(ix, iy, x centres, y centres, physical)`` of the rows of one map: the instrument's grid
    indices, else the ranks of the distinct positions."""
    if all(r.grid_x is not None and r.grid_y is not None for r in rows):
        ix = np.array([int(r.grid_x) for r in rows])
        iy = np.array([int(r.grid_y) for r in rows])
    else:
        xs = np.round(np.array([r.x_mm for r in rows], dtype=float), 9)
        ys = np.round(np.array([r.y_mm for r in rows], dtype=float), 9)
        ix = np.searchsorted(np.unique(xs), xs)
        iy = np.searchsorted(np.unique(ys), ys)
    have = all(r.x_mm is not None and r.y_mm is not None for r in rows)
    xc, physical = _axis(ix, [r.x_mm for r in rows] if have else None, per_mm)
    yc, _ = _axis(iy, [r.y_mm for r in rows] if have else None, per_mm)
    return ix, iy, xc, yc, physical


def map_figure(rows, *, title: str | None = None):
    """The diagnosis over one force map: a pixel per curve.

    Parameters
    ----------
    rows : sequence of DiagnosisRow
        The curves of one force map (grid indices or positions: :func:`force_maps`).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        Three panels over the map positions (um at AFM scale, mm at skin scale; grid indices when
        the file records no position): which effect is missing (the verdict; categorical colours
        and a legend with the number of curves of each; a dot marks a provisional verdict, white
        with a cross a curve that could not be diagnosed, and with 64 pixels or fewer each
        pixel's curve index), the misfit RMS / noise of the final model (log colour scale), and
        its main modulus E (log colour scale).
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm, Normalize
    from matplotlib.figure import Figure

    rows = list(rows)
    radius = next((r.radius_mm for r in rows if math.isfinite(r.radius_mm)), math.nan)
    u = display_units(radius)
    ix, iy, xc, yc, physical = _grid_of(rows, u.per_mm)
    shape = (yc.size, xc.size)
    cats = [r.outcome for r in rows]
    colours = verdict_colours(cats)
    order = list(colours)
    counts = {v: cats.count(v) for v in order}
    code = np.full(shape, np.nan)
    misfit = np.full(shape, np.nan)
    modulus = np.full(shape, np.nan)
    for r, c, i, j in zip(rows, cats, ix, iy):
        code[j, i] = order.index(c)
        if not r.error:
            misfit[j, i] = r.misfit
            modulus[j, i] = r.E_kPa * u.per_kPa
    xe, ye = _edges(xc), _edges(yc)
    aspect = (ye[-1] - ye[0]) / max(xe[-1] - xe[0], 1e-300)
    width = 4.6
    fig = Figure(figsize=(3 * width + 2.2, min(9.0, max(3.8, width * aspect * 0.9 + 1.6))), layout="constrained")
    ax_v, ax_m, ax_e = fig.subplots(1, 3)
    cmap = ListedColormap([colours[v] for v in order])
    ax_v.pcolormesh(xe, ye, np.ma.masked_invalid(code), cmap=cmap,
                    norm=BoundaryNorm(np.arange(len(order) + 1) - 0.5, len(order)), edgecolors="0.3", linewidth=0.4)
    X, Y = np.meshgrid(xc, yc)
    prov = np.zeros(shape, dtype=bool)
    failed = np.zeros(shape, dtype=bool)
    for r, i, j in zip(rows, ix, iy):
        prov[j, i] = bool(r.provisional) and not r.error
        failed[j, i] = bool(r.error)
    if np.any(prov):
        ax_v.plot(X[prov], Y[prov], "o", color="k", markersize=3.5)
    if np.any(failed):
        ax_v.plot(X[failed], Y[failed], "x", color="0.35", markersize=7)
    if len(rows) <= 64:
        for r, i, j in zip(rows, ix, iy):
            dark = r.outcome in ("unexplained",) or colours[r.outcome] in _COMBO_COLOURS[:5]
            ax_v.annotate(str(r.index), (xc[i], yc[j]), xytext=(0, 6), textcoords="offset points", ha="center",
                          fontsize=7, color="w" if dark else "k")
    entries = len(colours) + bool(np.any(prov))
    _legend(fig, colours, counts, bool(np.any(prov)), loc="outside lower center", ncol=min(entries, 6))

    def scale(ax, values, label, cmap_name):
        good = values[np.isfinite(values) & (values > 0)]
        if not good.size:
            ax.text(0.5, 0.5, "no curve diagnosed", ha="center", va="center", transform=ax.transAxes)
            return
        lo, hi = float(good.min()), float(good.max())
        if hi <= lo * 1.0001:
            lo, hi = lo / 1.5, hi * 1.5
        log = hi / lo > 10.0  # a log colour scale only over a decade or more
        mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(values), cmap=cmap_name,
                             norm=LogNorm(lo, hi) if log else Normalize(lo, hi), edgecolors="0.3", linewidth=0.4)
        bar = fig.colorbar(mesh, ax=ax, label=label, shrink=0.85)
        if log:
            _plain_ticks(bar.ax.yaxis)
        if np.any(failed):
            ax.plot(X[failed], Y[failed], "x", color="0.35", markersize=7)

    scale(ax_m, misfit, "misfit: RMS / noise of the final model", "viridis")
    scale(ax_e, modulus, f"E of the final model ({u.modulus})", "cividis")
    length = u.length if physical else None
    for ax, what in ((ax_v, "which effect is missing"), (ax_m, "misfit of the final model"),
                     (ax_e, "main modulus of the final model")):
        ax.set_xlim(xe[0], xe[-1])
        ax.set_ylim(ye[0], ye[-1])
        ax.set_aspect("equal" if physical else "auto")
        ax.set_xlabel(f"x ({length})" if length else "grid x")
        ax.set_ylabel(f"y ({length})" if length else "grid y")
        ax.set_title(what, fontsize=10)
    name = Path(rows[0].file).name if rows else ""
    diagnosed = sum(1 for r in rows if not r.error)
    fig.suptitle(title or (f"Diagnosis over the force map {name}: {len(rows)} curves, {diagnosed} diagnosed\n"
                           + ", ".join(f"{model_label(v) if '+' in v else v} {counts[v]}" for v in order)),
                 fontsize=10)
    return fig


def write_batch_figures(rows, plot_dir, provenance: dict | None = None) -> list[Path]:
    """Write ``verdicts.png`` (:func:`verdict_figure`) and ``NAME_map.png`` per force map (:func:`map_figure`).

    Parameters
    ----------
    rows : DiagnosisBatch or sequence of DiagnosisRow
    plot_dir : path
        The folder (made if needed).
    provenance : dict, optional
        Default the rows' own (``rows.provenance``).

    Returns
    -------
    list of Path
        The PNGs written, each with the provenance in its metadata.
    """
    prov = provenance if provenance is not None else getattr(rows, "provenance", None)
    folder = Path(plot_dir)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    if len(rows):
        out.append(save_figure(verdict_figure(rows), folder / "verdicts.png", prov))
    for name, members in force_maps(rows).items():
        out.append(save_figure(map_figure(members), folder / f"{Path(name).name}_map.png", prov))
    return out


def write_curve_report(row, plot_dir, provenance: dict | None = None):
    """Write the HTML report of a row's diagnosis into ``plot_dir/NAME_INDEX/`` (when the row holds one).

    Parameters
    ----------
    row : DiagnosisRow
        With ``diagnosis`` (``diagnose_many(..., keep_diagnoses=True)`` or in ``on_row``).
    plot_dir : path
    provenance : dict, optional
        The batch's; the report's keeps only the curve's file and names the curve.

    Returns
    -------
    DiagnosisRow
        The row, with a flag ``report not written: ...`` when writing failed (never raised).
    """
    if row.diagnosis is None or row.error:
        return row
    try:
        write_report(row.diagnosis, Path(plot_dir) / row.plot_name,
                     provenance=row_provenance(provenance, row) if provenance else None)
    except Exception as err:  # noqa: BLE001 - a report that cannot be written is a flag of its row
        return dataclasses.replace(row, flags=row.flags + (f"report not written: {one_line(err)}",))
    return row
