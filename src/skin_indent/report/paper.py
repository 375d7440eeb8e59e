"""Figures (matplotlib): every function takes result objects and an optional ``ax``.

Import matplotlib lazily so that the rest of the package does not pay for it.
"""

from __future__ import annotations

import numpy as np

from .labels import line_styles, parameter_label, same_curve_as


def _axes(ax, **subplot_kw):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(**subplot_kw)
    return ax


def plot_fit(depth_mm, force_mN, fits: dict, ax=None, title: str | None = None):
    """Measured force and model curves against depth.

    Parameters
    ----------
    depth_mm, force_mN : array_like
        The measurement (mm, mN).
    fits : dict
        ``label -> model force (mN) at depth_mm``. Each curve has its own line style
        and markers (:func:`~skin_indent.report.labels.line_styles`), so curves that
        coincide stay visible; the legend says which ones are the same curve.
    """
    ax = _axes(ax)
    ax.plot(depth_mm, force_mN, "o", ms=3, mfc="none", color="0.35", label="measurement")
    same = same_curve_as(list(fits.values()), list(fits))
    for (label, model), style in zip(fits.items(), line_styles(len(fits), np.size(depth_mm))):
        ax.plot(depth_mm, model, **style, label=label + (f" (same curve as {same[label].split(':')[0]})"
                                                         if label in same else ""))
    ax.set_xlabel("depth h (mm)")
    ax.set_ylabel("force F (mN)")
    ax.legend(frameon=False)
    if title:
        ax.set_title(title)
    return ax


def plot_residuals(depth_mm, residuals: dict, noise_mN: float | None = None, ax=None):
    """Residuals (measured - model, mN) against depth, with the noise bands.

    The darker band is +/- 1 standard deviation of the noise, the lighter one +/- 2;
    each model has its own line style and markers, as in :func:`plot_fit`.
    """
    ax = _axes(ax)
    if noise_mN:
        ax.axhspan(-2 * noise_mN, 2 * noise_mN, color="0.92", label="noise: ±2 sd")
        ax.axhspan(-noise_mN, noise_mN, color="0.84", label="noise: ±1 sd")
    ax.axhline(0.0, color="0.5", lw=0.8)
    same = same_curve_as(list(residuals.values()), list(residuals))
    for (label, r), style in zip(residuals.items(), line_styles(len(residuals), np.size(depth_mm))):
        style = {**style, "linewidth": 0.6 * style["linewidth"], "markersize": 4}
        ax.plot(depth_mm, r, **style, label=label + (f" (same as {same[label]})" if label in same else ""))
    ax.set_xlabel("depth h (mm)")
    ax.set_ylabel("residual (mN)")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.45 * (hi - lo))  # room above the residuals for the legend
    ax.legend(fontsize="small", ncols=3, loc="upper center", framealpha=0.9)
    return ax


def _parameter_panels(x, columns, names, axes, xlabel, title):
    """One panel per parameter: ``columns[:, k]`` against ``x``."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(len(names), 1, sharex=True)
    axes = np.atleast_1d(axes)
    for ax, name, col in zip(axes, names, np.asarray(columns).T):
        ax.plot(np.asarray(x)[: col.size], col, "-", lw=1.2)
        ax.set_ylabel(parameter_label(name))
    axes[-1].set_xlabel(xlabel)
    axes[0].set_title(title)
    return axes


def plot_sweep_history(result, axes=None):
    """Parameters at the end of each sweep of a Kalman filter (the paper's Figs. 9 and 10)."""
    sweeps = np.asarray(result.history["sweeps"])
    return _parameter_panels(np.arange(len(sweeps)), sweeps, result.free_names, axes,
                             "sweep (global stabilisation)", f"{result.method}: {result.iterations} sweeps")


def plot_first_pass(result, depth_mm, axes=None):
    """Parameters after each update of the first forward pass (the paper's Figs. 6 and 7)."""
    return _parameter_panels(depth_mm, result.history["first_pass"], result.free_names, axes,
                             "depth of the measured point (mm)", f"{result.method}: first forward pass")
