"""A picture and a table of one model fitted to several curves of one sample.

- :func:`sample_fit_figure`: one column per curve, the data and the model at its points
  (top) and the residual against the curve's own noise (bottom), the shared parameters in
  the title;
- :func:`plot_sample_fit` writes it as a PNG with its provenance;
- :func:`write_sample_fit_csv`: every curve's points, model and residual in one CSV, after
  a provenance header;
- :func:`sample_diagnosis_figure`: a diagnosis of several curves: per curve, the data with
  the last rung's model (and the other explanations), and every rung's residual against the
  curve's noise.

The model force at each point is the measured force minus the fit's own residual, so
plot, table and fit agree to the last digit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..measurement.scale import display_units
from ..runtime.atomic import atomic_write
from ..runtime.provenance import provenance_comment_lines
from ._save import save_figure
from .labels import line_styles, model_label, parameter_label

__all__ = ["plot_sample_fit", "sample_diagnosis_figure", "sample_fit_arrays", "sample_fit_figure",
           "write_sample_fit_csv"]


def sample_fit_arrays(result) -> list[dict]:
    """Per curve of a :class:`~skin_indent.fitting.FitResult` of several curves: ``depth_mm``, ``force_mN``,
    ``model_mN``, ``residual_mN`` (= force - model) and ``indentation_mm`` (past its contact point)."""
    out = []
    residuals = result.per_curve(np.asarray(result.residuals_mN, dtype=float))
    for p, c, r in zip(result.prepared, result.curves, residuals):
        depth, force = np.asarray(p.depth_mm, float), np.asarray(p.force_mN, float)
        out.append({"depth_mm": depth, "force_mN": force, "model_mN": force - r, "residual_mN": r,
                    "indentation_mm": depth - c["contact_point_mm"]})
    return out


def sample_fit_figure(result):
    """The figure of a fit of several curves: per curve, data and model (top), residual with +-2 of its
    noise (bottom); in the units of the first curve's scale.

    Parameters
    ----------
    result : FitResult
        Of several curves of one sample.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    arrays = sample_fit_arrays(result)
    u = display_units(result.curves[0]["radius_mm"])
    n = len(arrays)
    fig = Figure(figsize=(4.2 * n, 5.6), layout="constrained")
    axes = fig.subplots(2, n, sharex="col", height_ratios=(3, 1.4), squeeze=False)
    for k, (a, c) in enumerate(zip(arrays, result.curves)):
        top, bottom = axes[0, k], axes[1, k]
        top.plot(a["depth_mm"] * u.per_mm, a["force_mN"] * u.per_mN, ".", ms=2.5, color="k", label="measured")
        top.plot(a["depth_mm"] * u.per_mm, a["model_mN"] * u.per_mN, "-", color="C0", lw=1.8, label="model")
        top.set_title(f"curve {k + 1}: {Path(c['data']).name}\nR = {c['radius_mm'] * u.per_mm:g} {u.length}, "
                      f"RMS {c['misfit']:.2g} x noise", fontsize=9)
        top.set_ylabel(f"force ({u.force})")
        top.legend(fontsize=8, loc="upper left")
        bottom.plot(a["depth_mm"] * u.per_mm, a["residual_mN"] * u.per_mN, ".", ms=2.5, color="k")
        bottom.axhline(0.0, color="C0", lw=1)
        for s in (-2, 2):
            bottom.axhline(s * c["noise_mN"] * u.per_mN, color="0.5", lw=0.8, ls="--")
        bottom.plot([], [], color="0.5", ls="--", label="noise of this curve: ±2 sd")
        bottom.legend(fontsize=8, loc="upper left")
        bottom.set_ylabel(f"residual ({u.force})")
        bottom.set_xlabel(f"recorded depth ({u.length})")
    shared = [f"{parameter_label(u.name(k))} = {v * u.factor(k):.4g}" for k, v in result.parameters.items() if "[" not in k]
    fig.suptitle(f"{model_label(result.model)} fitted to {n} curves of one sample: " + ", ".join(shared), fontsize=10)
    return fig


def plot_sample_fit(result, path, *, dpi: int = 110, provenance: dict | None = None) -> Path:
    """Write :func:`sample_fit_figure` as a PNG (atomically), its provenance in the metadata (default
    the fit's own)."""
    return save_figure(sample_fit_figure(result), path, provenance or getattr(result, "provenance", None), dpi=dpi)


def write_sample_fit_csv(result, path, provenance: dict | None = None) -> Path:
    """Write every curve's points, model and residual as CSV after a provenance header.

    Columns ``curve`` (1, 2, ... in input order), ``depth_mm`` (recorded), ``force_mN``
    (baseline removed), ``model_mN``, ``residual_mN``, ``indentation_mm``; ``#`` lines record
    the provenance, each curve's source and sphere radius, and the fitted parameters.
    """
    provenance = provenance or getattr(result, "provenance", None)
    lines = provenance_comment_lines(provenance) if provenance else []
    for k, c in enumerate(result.curves, 1):
        lines.append(f"# curve {k}: {c['data']}, radius_mm {c['radius_mm']:.10g}, noise_mN {c['noise_mN']:.6g}")
    lines.append("# fit: " + ", ".join(f"{k} {v:.10g}" for k, v in result.parameters.items()))
    lines.append("curve,depth_mm,force_mN,model_mN,residual_mN,indentation_mm")
    cols = ("depth_mm", "force_mN", "model_mN", "residual_mN", "indentation_mm")
    for k, a in enumerate(sample_fit_arrays(result), 1):
        lines += [f"{k}," + ",".join(f"{v:.12g}" for v in row) for row in zip(*(a[c] for c in cols))]
    text = "\n".join(lines) + "\n"
    return atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))


def sample_diagnosis_figure(diag):
    """A diagnosis of several curves of one sample: one column per curve.

    Top: the curve and the last rung's model (solid), the other explanations the diagnosis
    climbed (dashed). Bottom: the residual of every rung of the ladder, each its own line
    style, with the curve's own noise band (±2 sd); the ladder's models share one colour
    per rung across the columns. In the units of the diagnosis
    (:attr:`~skin_indent.diagnosis.result.Diagnosis.units`: the first curve's scale).

    Parameters
    ----------
    diag : Diagnosis
        Of several curves (``diag.curves``); one curve gives one column.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    curves = diag.curves or [diag.data]
    noises = diag.noises_mN or [diag.noise_mN]
    slices = diag.data.slices if len(curves) > 1 else [slice(0, diag.data.n)]
    u = diag.units  # the first curve's scale decides
    n = len(curves)
    fig = Figure(figsize=(4.6 * n, 6.4), layout="constrained")
    axes = fig.subplots(2, n, sharex="col", height_ratios=(2.2, 2.0), squeeze=False)
    final = diag.current
    styles = line_styles(len(diag.ladder), max(c.n for c in curves))
    for k, (c, noise, sl) in enumerate(zip(curves, noises, slices)):
        top, bottom = axes[0, k], axes[1, k]
        d = np.asarray(c.depth_mm) * u.per_mm
        top.plot(d, np.asarray(c.force_mN) * u.per_mN, ".", ms=2.5, color="k", label="measured")
        top.plot(d, np.asarray(final.prediction_mN)[sl] * u.per_mN, "-", color=f"C{len(diag.ladder) - 1}", lw=1.8,
                 label=model_label(final.model))
        for j, other in enumerate(diag.alternatives[:2]):
            top.plot(d, np.asarray(other.prediction_mN)[sl] * u.per_mN, "--", color="0.4", lw=1.2,
                     label=f"other explanation: {model_label(other.model)}")
        top.set_title(f"curve {k + 1}: {Path(c.source).name}, R = {c.radius_mm * u.per_mm:g} {u.length}", fontsize=9)
        top.set_ylabel(f"force ({u.force})")
        top.legend(fontsize=7, loc="upper left")
        for j, (rung, style) in enumerate(zip(diag.ladder, styles)):
            rms = rung.curve_rms_mN[k] if len(rung.curve_rms_mN) > k else rung.rms_mN
            bottom.plot(d, np.asarray(rung.residual_mN)[sl] * u.per_mN, color=f"C{j}", **style,
                        label=f"{model_label(rung.model)}: RMS {rms * u.per_mN:.3g} {u.force}")
        band = 2 * noise * u.per_mN
        bottom.axhspan(-band, band, color="0.9", zorder=0, label="noise of this curve: ±2 sd")
        bottom.axhline(0.0, color="0.3", lw=0.8)
        bottom.set_ylabel(f"residual ({u.force})")
        bottom.set_xlabel(f"recorded depth ({u.length})")
        bottom.legend(fontsize=7, loc="lower left")
    verdict = diag.verdict + (" (provisional)" if diag.provisional else "")
    fig.suptitle(f"{n} curve{'s' if n > 1 else ''} of one sample: what the {model_label(diag.base.model)} model "
                 f"misses: {verdict}", fontsize=10)
    return fig
