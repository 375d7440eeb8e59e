"""The outputs of a batch of fits: a table with its provenance, a line of text per curve, and a summary figure.

:func:`write_tsv` writes one line per curve of :func:`skin_indent.batch.fit_many` (and of
:func:`skin_indent.diagnosis.diagnose_many`, whose figures are :mod:`.verdict_map`'s) after
``#`` provenance lines, in the package units whatever the curve's scale (the units are in the
column names: ``E_kPa``, ``contact_point_mm``, ``noise_mN``); :func:`row_line` is the line
``skin-indent fit`` prints per curve, in the units of the curve's scale (Pa, um and nN for
AFM-scale curves, :func:`skin_indent.measurement.scale.display_units`); :func:`summary_figure`
draws E per curve and, for force maps, E over the map positions.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
from ..fitting import MISFIT_LIMIT
from ..measurement.scale import display_units
from ..runtime.atomic import atomic_write
from ..runtime.provenance import provenance_comment_lines
from ._save import save_figure

__all__ = ["UNITS_LINE", "row_line", "summary_figure", "write_tsv"]

#: the comment line before a table's header: its units, the same for every row
UNITS_LINE = ("# units: as in the column names (mm, mN, kPa, s) for every row whatever its scale; for AFM-scale "
              "curves E_kPa x 1000 = Pa, *_mm x 1000 = um, *_mN x 1e6 = nN")


def row_line(row) -> str:
    """One line of text of a batch row, in the units of its scale.

    Parameters
    ----------
    row : BatchRow

    Returns
    -------
    str
        ``label: E = ... kPa, E* = ..., nu = ..., contact ... mm, misfit ... x noise: verdict [flags]``
        (``Pa`` and ``um`` for an AFM-scale sphere), or ``label: error: ...``.
    """
    if row.error:
        return f"{row.label}: error: {row.error}"
    u = display_units(row.radius_mm)
    extra = "".join(f", {u.name(k)} = {v * u.factor(k):.4g}" for k, v in row.parameters.items()
                    if k not in ("E_kPa", "nu", "offset_mm"))
    return (f"{row.label}: E = {row.E_kPa * u.per_kPa:.5g} {u.modulus}, E* = {row.E_star_kPa * u.per_kPa:.5g} "
            f"{u.modulus}, nu = {row.nu:.3g}{extra}, contact {row.contact_point_mm * u.per_mm:.6g} {u.length}, "
            f"misfit {row.misfit:.2g} x noise: {row.verdict}" + (f" [{'; '.join(row.flags)}]" if row.flags else ""))


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return "nan" if math.isnan(value) else f"{float(value):.10g}"
    if isinstance(value, (tuple, list)):
        return " | ".join(_cell(v) for v in value)
    return " ".join(str(value).replace("\t", " ").split())


def _middle_ellipsis(text: str, width: int) -> str:
    """``text`` cut in its middle to at most ``width`` characters (file names have no spaces to wrap at)."""
    if len(text) <= width:
        return text
    head = (width - 3) // 2
    return text[:head] + "..." + text[len(text) - (width - 3 - head):]


def _columns(rows) -> tuple:
    """The table columns of rows of one dataclass (:class:`skin_indent.batch.BatchRow`,
    :class:`skin_indent.diagnosis.DiagnosisRow`)."""
    return tuple(f.name for f in dataclasses.fields(rows[0])
                 if f.name not in ("fit", "diagnosis", "parameters", "std")) if rows else ()


def _own(row) -> tuple:
    """The parameters with a column of their own in ``row``'s table (``own_parameters`` of its class)."""
    return getattr(type(row), "own_parameters", ("E_kPa", "nu", "offset_mm"))


def write_tsv(rows, path, provenance: dict | None = None) -> Path:
    """Write the rows as a tab-separated table, one line per curve, after a provenance header.

    Parameters
    ----------
    rows : sequence of BatchRow or DiagnosisRow
        From :func:`~skin_indent.batch.fit_many` or :func:`~skin_indent.diagnosis.diagnose_many`.
    path : path
        The TSV file (written atomically, mode 0644 under the usual umask).
    provenance : dict, optional
        :func:`skin_indent.runtime.provenance.provenance`; default the rows' own
        (``rows.provenance`` of a :class:`BatchResult`).

    Returns
    -------
    Path

    Notes
    -----
    Columns ``rows.columns`` (:data:`skin_indent.batch.TSV_COLUMNS` for fits,
    :data:`skin_indent.diagnosis.batch.DIAGNOSIS_COLUMNS` for diagnoses), then ``NAME`` and ``NAME_sd`` for
    each parameter of the models beyond those with a column of their own (``own_parameters`` of the row
    class: E_kPa, nu and the contact point of a fit; E_kPa of a diagnosis' final model): ``thickness_mm``,
    ``ratio``...; units in
    the names (mm, mN, kPa), the same for every row whatever its scale, as in JSON (an AFM-scale curve's
    E_kPa x 1000 is in Pa, its lengths x 1000 in um; the ``# units:`` line before the header says so,
    and the text of ``skin-indent fit`` shows them in Pa, um and nN: :func:`row_line`); empty cells for
    missing values, ``nan`` for numbers not computed; ``flags`` joined by ``" | "``.
    ``#`` lines come first (:func:`skin_indent.runtime.provenance.provenance_comment_lines`;
    read them back with :func:`skin_indent.runtime.provenance.read_provenance`), so
    ``pandas.read_csv(path, sep="\\t", comment="#")`` reads the table.
    """
    prov = provenance if provenance is not None else getattr(rows, "provenance", None)
    lines = (provenance_comment_lines(prov) if prov else []) + [UNITS_LINE]
    extra = list(dict.fromkeys(k for r in rows for k in getattr(r, "parameters", {}) if k not in _own(r)))
    columns = rows.columns if hasattr(rows, "columns") else _columns(rows)
    lines.append("\t".join([*columns, *(c for k in extra for c in (k, f"{k}_sd"))]))
    for r in rows:
        cells = [_cell(getattr(r, c)) for c in columns]
        for k in extra:
            cells += [_cell(r.parameters.get(k, math.nan)), _cell(r.std.get(k, math.nan) if k in r.parameters else
                                                                   math.nan)]
        lines.append("\t".join(cells))
    text = "\n".join(lines) + "\n"
    return atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))


def summary_figure(rows, path, *, title: str | None = None) -> Path:
    """A PNG of E per curve and, for each force map, E over the map's positions.

    Parameters
    ----------
    rows : sequence of BatchRow
    path : path
        The PNG (written atomically, mode 0644).
    title : str, optional

    Returns
    -------
    Path

    Notes
    -----
    Left: E (kPa, log scale) with its standard error per curve, in row order; curves
    whose misfit exceeds :data:`skin_indent.fitting.MISFIT_LIMIT` times the noise in
    orange, flagged curves in red, curves that failed as a grey cross at the bottom. Right (one panel
    per force-map file with map positions): the map points coloured by log10 E.
    """
    from matplotlib.figure import Figure  # no pyplot: no GUI backend, no global state

    rows = list(rows)
    maps: dict = {}
    for r in rows:
        if not r.error and r.x_mm is not None and r.y_mm is not None:
            maps.setdefault(r.file, []).append(r)
    n_maps = min(len(maps), 3)
    fig = Figure(figsize=(6.5 + 4.0 * n_maps, 4.2), layout="constrained")
    axes = fig.subplots(1, 1 + n_maps, squeeze=False)[0]
    ax = axes[0]
    x = np.arange(len(rows))
    E = np.array([r.E_kPa if not r.error else np.nan for r in rows], dtype=float)
    sd = np.array([r.E_std_kPa if not r.error else np.nan for r in rows], dtype=float)
    misfit = np.array([r.misfit if not r.error else np.nan for r in rows], dtype=float)
    flagged = np.array([not r.error and bool(r.flags) for r in rows], dtype=bool)
    poor = ~flagged & (misfit > MISFIT_LIMIT)
    good = np.array([not r.error for r in rows], dtype=bool) & ~flagged & ~poor
    failed = np.array([bool(r.error) for r in rows], dtype=bool)
    finite = np.isfinite(E) & (E > 0)
    sd = np.where(np.isfinite(sd), sd, 0.0)
    for sel, color, label in ((good & finite, "C0", "fitted"),
                              (poor & finite, "C1", f"misfit > {MISFIT_LIMIT:g} x noise"),
                              (flagged & finite, "C3", "flagged")):
        if np.any(sel):
            ax.errorbar(x[sel], E[sel], yerr=np.minimum(sd[sel], 0.999 * E[sel]), fmt="o", color=color,
                        capsize=2, label=label)
    if np.any(finite):
        from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

        ax.set_yscale("log")
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_formatter(NullFormatter())
        low = np.nanmin(E[finite]) / 2
    else:
        low = 1.0
    if np.any(failed):
        ax.plot(x[failed], np.full(failed.sum(), low), "x", color="0.5", label="failed")
    ax.set_xticks(x, [r.short_label() for r in rows], rotation=60 if len(rows) > 3 else 0, ha="right" if len(rows) > 3
                  else "center", fontsize=8 if len(rows) < 30 else 5)
    ax.set_ylabel("E (kPa)")
    ax.set_title(title or f"E per curve\n{len(rows)} curves: {int(failed.sum())} failed, {int(flagged.sum())} "
                          f"flagged, {int(poor.sum())} misfit > {MISFIT_LIMIT:g} x noise", fontsize=10)
    if len(rows):
        ax.legend(fontsize=8)
    for ax, (name, rs) in zip(axes[1:], list(maps.items())[:n_maps]):
        xy = np.array([(r.x_mm, r.y_mm) for r in rs], dtype=float) * 1e3  # um
        e = np.array([r.E_kPa for r in rs], dtype=float)
        ok = np.isfinite(e) & (e > 0)
        sc = ax.scatter(xy[ok, 0], xy[ok, 1], c=np.log10(e[ok]), marker="s", s=80, cmap="viridis")
        bad = np.array([bool(r.flags) for r in rs])
        if np.any(bad):
            ax.scatter(xy[bad, 0], xy[bad, 1], facecolors="none", edgecolors="C3", marker="s", s=140,
                       label="flagged")
            ax.legend(fontsize=8)
        for (px, py), r in zip(xy, rs):
            ax.annotate(str(r.index), (px, py), fontsize=7, xytext=(4, 4), textcoords="offset points")
        if np.any(ok):
            fig.colorbar(sc, ax=ax, label="log10 E (kPa)")
        ax.set_xlabel("x (um)")
        ax.set_ylabel("y (um)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"E over the map\n{_middle_ellipsis(Path(name).name, 44)}", fontsize=9)
    return save_figure(fig, path, getattr(rows, "provenance", None))
