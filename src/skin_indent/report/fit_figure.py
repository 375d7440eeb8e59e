"""A picture and a table of one fit: data, model and residuals against depth.

- :func:`fit_arrays`: the fitted points (recorded depth, force with the baseline
  removed), the model force at them and the residual, from a
  :class:`~skin_indent.fitting.FitResult` of one curve;
- :func:`fit_figure`: the figure of the data, the model (and Hertz's fit of the same
  points), the contact point and the fitted range, and the residuals against the noise;
  :func:`plot_fit` writes it as a PNG;
- :func:`write_fit_csv`: a CSV of depth, force, model and residual with a provenance
  header.

A fit of several curves of one sample gets the figure and table of
:mod:`.sample_figure` (one column per curve) from the same three functions.

The model force is the fitted model at the fitted parameters (for a fitted contact
point, the neo-Hookean surface with the ``offset`` effect, as
:func:`skin_indent.fitting.fit` builds it): the force minus the fit's own residuals,
so plot, table and fit agree to the last digit. matplotlib is used without pyplot
(no GUI backend, no global state).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
from ..measurement.scale import display_units
from ..runtime.atomic import atomic_write
from ..runtime.provenance import provenance_comment_lines
from ._save import save_figure
from .labels import model_label
from .sample_figure import sample_fit_figure, write_sample_fit_csv

__all__ = ["fit_arrays", "fit_figure", "plot_fit", "write_fit_csv"]


def fit_arrays(curve_fit) -> dict:
    """The fitted points of a fit, the model force at them and the residual.

    Parameters
    ----------
    curve_fit : FitResult
        From :func:`skin_indent.fitting.fit`.

    Returns
    -------
    dict
        ``depth_mm`` (recorded depth, mm), ``force_mN`` (baseline removed, mN),
        ``model_mN`` (mN) and ``residual_mN`` = force - model (mN), arrays of the
        fitted points; ``indentation_mm`` = depth - contact point (mm).

    Raises
    ------
    ValueError
        If the fit's residuals do not belong to its prepared points.
    """
    p = curve_fit.data
    if p.contact_mode == "fit" or np.size(curve_fit.residuals_mN) == p.n:  # every prepared point (fit(model=...))
        depth, force = np.asarray(p.depth_mm, float), np.asarray(p.force_mN, float)
    else:  # the loading points in contact, as fit() takes them
        sel = (p.kind == "approach") & (p.depth_mm > p.contact_guess_mm)
        depth, force = np.asarray(p.depth_mm[sel], float), np.asarray(p.force_mN[sel], float)
    residual = np.asarray(curve_fit.residuals_mN, dtype=float)
    if residual.shape != depth.shape:
        raise ValueError(f"the fit has {residual.size} residuals for {depth.size} prepared points")
    return {"depth_mm": depth, "force_mN": force, "model_mN": force - residual, "residual_mN": residual,
            "indentation_mm": depth - curve_fit.contact_point_mm}


def _hertz_mN(curve_fit, depth_mm) -> np.ndarray | None:
    h = curve_fit.hertz or {}
    e_star, c = h.get("E_star_kPa"), h.get("contact_point_mm", curve_fit.contact_point_mm)
    if e_star is None or not np.isfinite(e_star):
        return None
    d = np.clip(np.asarray(depth_mm, float) - c, 0.0, None)
    return 4.0 / 3.0 * e_star * np.sqrt(curve_fit.radius_mm) * d**1.5  # kPa mm^2 = mN


def fit_figure(curve_fit, *, title: str | None = None):
    """The figure of a fit: data, model and residuals against depth.

    Top: the approach as recorded (light; "baseline removed" when a pre-contact
    baseline was subtracted, "as recorded" otherwise), the fitted points, the model at
    them, Hertz's fit of the same points (dashed), the contact point (vertical line)
    and the fitted depth range (shaded). Bottom: the residual with +-2 noise levels
    (the noise independent of the model, ``curve_fit.quality``). Depth, force and
    moduli are shown in the units of the curve's scale, as the text of the fit
    (:func:`skin_indent.measurement.scale.display_units`: um, nN and Pa for an AFM-scale
    sphere, mm, mN and kPa for skin).

    Parameters
    ----------
    curve_fit : FitResult
        From :func:`skin_indent.fitting.fit`.
    title : str, optional
        Default: the source, the sphere radius and the quality verdict.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    if len(curve_fit.prepared) > 1:  # several curves of one sample: a column each
        return sample_fit_figure(curve_fit)
    a = fit_arrays(curve_fit)
    p = curve_fit.data
    m = p.measurement
    approach = m.loading() if m.has_time else m
    raw_d = np.asarray(approach.depth_mm, float)
    raw_f = np.asarray(approach.force_mN, float)
    if p.baseline is not None:
        raw_f = raw_f - p.baseline.force_at(raw_d)
    u = display_units(curve_fit.radius_mm)
    dname, dk, fname, fk = u.length, u.per_mm, u.force, u.per_mN

    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1.4))
    lo, hi = float(a["depth_mm"].min()), float(a["depth_mm"].max())
    for ax in (top, bottom):
        ax.axvspan(lo * dk, hi * dk, color="0.93", zorder=0)
        ax.axvline(curve_fit.contact_point_mm * dk, color="C3", lw=1, ls=":")
    raw = "approach (baseline removed)" if p.baseline is not None else "approach as recorded"
    top.plot(raw_d * dk, raw_f * fk, ".", ms=1.5, color="0.75", label=raw)
    top.plot(a["depth_mm"] * dk, a["force_mN"] * fk, ".", ms=2.5, color="k", label="fitted points")
    name = model_label(curve_fit.model)
    top.plot(a["depth_mm"] * dk, a["model_mN"] * fk, "-", color="C0", lw=1.8,
             label=f"{name}: E = {curve_fit.parameters['E_kPa'] * u.per_kPa:.4g} {u.modulus}, "
                   f"ν = {curve_fit.parameters['nu']:.3g}")
    hertz = _hertz_mN(curve_fit, a["depth_mm"])
    if hertz is not None:
        top.plot(a["depth_mm"] * dk, hertz * fk, "--", color="C2", lw=1,
                 label=f"Hertz: E* = {curve_fit.hertz['E_star_kPa'] * u.per_kPa:.4g} {u.modulus}")
    top.plot([], [], color="C3", ls=":", label=f"contact point {curve_fit.contact_point_mm * dk:.5g} {dname}")
    top.set_ylabel(f"force ({fname})")
    top.legend(fontsize=8, loc="upper left")
    q = curve_fit.quality or {}
    if title is None:
        title = "\n".join(textwrap.wrap(f"{p.source} (R = {curve_fit.radius_mm * dk:g} {dname}): "
                                        f"{q.get('verdict', '')}", 90))
    top.set_title(title, fontsize=9)
    bottom.plot(a["depth_mm"] * dk, a["residual_mN"] * fk, ".", ms=2.5, color="k")
    bottom.axhline(0.0, color="C0", lw=1)
    noise = q.get("noise_mN")
    if noise:
        for s in (-2, 2):
            bottom.axhline(s * noise * fk, color="0.5", lw=0.8, ls="--")
        bottom.plot([], [], color="0.5", ls="--",
                    label=f"noise: ±2 sd (misfit RMS {q.get('misfit', float('nan')):.2g} x noise)")
        bottom.legend(fontsize=8, loc="upper left")
    bottom.set_ylabel(f"residual ({fname})")
    bottom.set_xlabel(f"recorded depth ({dname})")
    return fig


def plot_fit(curve_fit, path, *, title: str | None = None, dpi: int = 110, provenance: dict | None = None) -> Path:
    """Write a PNG of a fit: data, model and residuals against depth (:func:`fit_figure`).

    Parameters
    ----------
    curve_fit : FitResult
        From :func:`skin_indent.fitting.fit`.
    path : path
        The PNG (written atomically, mode 0644 under the usual umask).
    title : str, optional
        Default: the source, the sphere radius and the quality verdict.
    dpi : int
    provenance : dict, optional
        Recorded in the PNG's metadata (:func:`skin_indent.report.save_figure`); default
        the fit's own (``curve_fit.provenance``: the API call that made it).

    Returns
    -------
    Path
    """
    fig = fit_figure(curve_fit, title=title)
    return save_figure(fig, path, provenance or getattr(curve_fit, "provenance", None), dpi=dpi)


def write_fit_csv(curve_fit, path, provenance: dict | None = None) -> Path:
    """Write the fitted points, the model and the residual as CSV, after a provenance header.

    Parameters
    ----------
    curve_fit : FitResult
        From :func:`skin_indent.fitting.fit`.
    path : path
        The CSV (written atomically, mode 0644 under the usual umask).
    provenance : dict, optional
        :func:`skin_indent.runtime.provenance.provenance`, written as ``#`` comment lines;
        default the fit's own (``curve_fit.provenance``: the API call that made it).

    Returns
    -------
    Path

    Notes
    -----
    Columns ``depth_mm`` (recorded depth), ``force_mN`` (baseline removed),
    ``model_mN``, ``residual_mN`` (= force - model), ``indentation_mm`` (depth past the
    contact point). ``#`` lines before the header record the provenance, the sphere
    radius (``# radius_mm: R``), the contact point, E and nu, so that
    :func:`skin_indent.measurement.load_csv` reads the file back as a curve with its radius.
    """
    provenance = provenance or getattr(curve_fit, "provenance", None)
    if len(curve_fit.prepared) > 1:  # several curves of one sample: a column ``curve`` numbers them
        return write_sample_fit_csv(curve_fit, path, provenance)
    a = fit_arrays(curve_fit)
    lines = provenance_comment_lines(provenance) if provenance else []
    lines += [f"# radius_mm: {curve_fit.radius_mm:.10g}",
              f"# fit: E_kPa {curve_fit.parameters['E_kPa']:.10g}, nu {curve_fit.parameters['nu']:.10g}, "
              f"contact_point_mm {curve_fit.contact_point_mm:.10g}, method {curve_fit.method}",
              "depth_mm,force_mN,model_mN,residual_mN,indentation_mm"]
    cols = ("depth_mm", "force_mN", "model_mN", "residual_mN", "indentation_mm")
    lines += [",".join(f"{v:.12g}" for v in row) for row in zip(*(a[c] for c in cols))]
    text = "\n".join(lines) + "\n"
    return atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))
