"""The outputs of a :class:`~skin_indent.diagnosis.planning.Plan`: the predicted curves (CSV) and a figure.

- :func:`write_plan_curves`: for each of the best candidates, the curve each explanation
  predicts, one CSV per candidate and explanation (``time_s,depth_mm,force_mN``, depth below
  the contact point), after ``#`` lines with the provenance, the sphere radius (so that
  :func:`skin_indent.load_csv` reads it back as a curve with its radius), the model and its
  parameters, and the noise;
- :func:`plan_figure`: per candidate, the predicted curves with the noise band, the
  difference of each rival from the diagnosis' choice against the noise, and the standard
  deviations of the undetermined parameters with and without the candidate;
- :func:`write_plan`: both, into a folder.

The numbers are the plan's own: the CSV holds the forces the separations were computed from.
"""

from __future__ import annotations

import math
import re
import textwrap
from pathlib import Path

import numpy as np

from ..diagnosis.outlook import DETERMINED
from ..diagnosis.separation import error_model
from ..diagnosis.planning import BEST
from ..runtime.atomic import atomic_write
from ..runtime.provenance import provenance_comment_lines
from ._save import save_figure
from .labels import line_styles, model_label, parameter_label

__all__ = ["plan_figure", "write_plan", "write_plan_curves"]

#: the file name of the figure :func:`write_plan` writes
FIGURE_NAME = "plan.png"


def _slug(model: str) -> str:
    return re.sub(r"[^A-Za-z0-9.+_-]", "_", model)


def curve_name(rank: int, assessment, model: str) -> str:
    """``"01-sphere-R3.11mm-neo-hooke+layer+layer.csv"``: the file of one predicted curve."""
    return f"{rank:02d}-{assessment.candidate.slug}-{_slug(model)}.csv"


def write_plan_curves(plan, out_dir, provenance: dict | None = None, best: int | None = None) -> list[Path]:
    """Write the predicted curve of every explanation for the best candidates.

    Parameters
    ----------
    plan : Plan
    out_dir : path
        Folder (made if missing).
    provenance : dict, optional
        :func:`skin_indent.runtime.provenance.provenance` of the command; default the plan's.
    best : int, optional
        How many candidates (default :data:`~skin_indent.diagnosis.planning.BEST`).

    Returns
    -------
    list of Path
        In rank order, the explanations of each candidate in the plan's order.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    prov = provenance or plan.provenance
    paths = []
    fitted = {f.model: f for f in plan.explanations}
    for rank, a in enumerate(plan.best(BEST if best is None else best), 1):
        c = a.candidate
        for model, force in a.forces.items():
            f = fitted[model]
            lines = provenance_comment_lines(prov) if prov else []
            params = ", ".join(f"{k} {v:.10g}" for k, v in f.parameters.items())
            lines += [f"# radius_mm: {c.radius_mm:.10g}",
                      f"# plan: candidate {rank}: {c.label}",
                      f"# model: {model} at its fitted values: {params}",
                      f"# depth_mm: below the contact point; noise_mN: {plan.noise_mN:.10g} (of the recorded curve)"]
            cols = ["depth_mm", "force_mN"]
            data = [c.curve.depth_mm, force]
            if c.curve.time_s is not None:
                cols.insert(0, "time_s")
                data.insert(0, c.curve.time_s)
            lines.append(",".join(cols))
            lines += [",".join(repr(float(v)) for v in row) for row in zip(*data)]
            text = "\n".join(lines) + "\n"
            paths.append(atomic_write(out_dir / curve_name(rank, a, model), lambda fh, t=text: fh.write(t.encode())))
    return paths


def plan_figure(plan, best: int | None = None):
    """The best candidates side by side: what each explanation predicts, and what it would determine.

    One column per candidate (best first). Top: the predicted curve of each explanation
    against depth (against time for a hold or another speed), the diagnosis' choice with
    its noise band (+-2 sd). Middle (with rivals): each rival minus the choice, with the
    noise shades (+-1 and +-2 sd of the error model). Bottom (with undetermined
    parameters): their standard deviation over their value, from the recorded curves alone
    and with the candidate, against the line below which a parameter is determined.

    Parameters
    ----------
    plan : Plan
    best : int, optional
        How many candidates (default :data:`~skin_indent.diagnosis.planning.BEST`).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure  # no pyplot: no GUI backend, no global state

    shown = plan.best(BEST if best is None else best)
    rows = ["curves"] + (["difference"] if plan.rivals else []) + (["std"] if plan.undetermined else [])
    ncol = max(len(shown), 1)
    fig = Figure(figsize=(3.8 * ncol + 0.6, 2.8 * len(rows) + 0.8), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(rows), ncol, squeeze=False))
    noise = plan.noise_mN
    models = [f.model for f in plan.explanations]
    for j, a in enumerate(shown):
        c = a.candidate
        x = c.curve.time_s if c.in_time else c.curve.depth_mm
        xlabel = "time (s)" if c.in_time else "depth below contact (mm)"
        order = np.argsort(x, kind="stable") if not c.in_time else np.arange(x.size)
        styles = line_styles(len(models), x.size)
        ax = axes[0, j]
        choice = a.forces[models[0]]
        band = 2 * error_model(choice, noise)
        ax.fill_between(x[order], (choice - band)[order], (choice + band)[order], color="0.85",
                        label="±2 sd of the noise")
        for k, m in enumerate(models):
            ax.plot(x[order], a.forces[m][order], label=model_label(m), color=f"C{k}", **styles[k])
        title = "\n".join(textwrap.wrap(f"{j + 1}. {c.label}", 44))
        if a.separations:
            title += f"\nS = {a.separation:.3g} noise units" + (" (too close to separate)" if a.too_close else "")
        ax.set_title(title, fontsize=8.5)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("predicted force (mN)")
        if j == 0:
            ax.legend(fontsize=7, loc="upper left")
        r = 1
        if plan.rivals:
            ax = axes[r, j]
            sigma = error_model(choice, noise)
            ax.fill_between(x[order], -2 * sigma[order], 2 * sigma[order], color="0.9", label="±2 sd of the noise")
            ax.fill_between(x[order], -sigma[order], sigma[order], color="0.75", label="±1 sd")
            for k, m in enumerate(models[1:], 1):
                ax.plot(x[order], (a.forces[m] - choice)[order], color=f"C{k}", **styles[k],
                        label=f"{model_label(m)}\nminus the choice")
            ax.axhline(0.0, color="0.3", linewidth=0.6)
            ax.set_xlabel(xlabel)
            ax.set_ylabel("difference (mN)")
            if j == 0:
                ax.legend(fontsize=7, loc="best")
            r += 1
        if plan.undetermined:
            ax = axes[r, j]
            names = list(plan.undetermined)
            y = np.arange(len(names))
            rel0 = np.array([plan.recorded_std.get(n, math.nan) / abs(plan.undetermined[n]) for n in names])
            rel1 = np.array([a.std.get(n, math.nan) / abs(plan.undetermined[n]) for n in names])
            for i in range(len(names)):
                if math.isfinite(rel0[i]) and math.isfinite(rel1[i]):
                    ax.annotate("", xy=(rel1[i], y[i]), xytext=(rel0[i], y[i]),
                                arrowprops={"arrowstyle": "->", "color": "0.5"})
            ax.plot(rel0, y, "o", color="0.55", label="recorded curve(s) alone (FE)")
            ax.plot(rel1, y, "D", color="C0", label="with this measurement")
            ax.axvline(DETERMINED, color="C3", linestyle="--", linewidth=1,
                       label=f"determined below {DETERMINED:g}")
            finite = [v for v in (*rel0, *rel1, DETERMINED) if math.isfinite(v) and v > 0]
            ax.set_xscale("log")
            ax.set_xlim(min(finite) / 2, max(finite) * 2)
            ax.set_ylim(-0.7, len(names) - 0.3)
            ax.set_yticks(y, [parameter_label(n) for n in names])
            ax.set_xlabel("standard deviation / value")
            if j == 0:
                ax.legend(fontsize=7, loc="best")
    for j in range(len(shown), ncol):
        for r in range(len(rows)):
            axes[r, j].set_visible(False)
    fig.suptitle("The next measurement: what each explanation predicts, model " + model_label(models[0])
                 + " is the diagnosis' choice", fontsize=10)
    return fig


def write_plan(plan, out_dir, provenance: dict | None = None, best: int | None = None) -> dict:
    """Write the predicted curves of the best candidates (:func:`write_plan_curves`) and the figure
    (:func:`plan_figure`, ``plan.png``, with its provenance) into ``out_dir``.

    Returns
    -------
    dict
        ``{"curves": [Path, ...], "figure": Path}`` (nothing written when there is nothing to plan:
        ``{"curves": [], "figure": None}``).
    """
    if plan.nothing_to_plan or not plan.best(1):
        return {"curves": [], "figure": None}
    prov = provenance or plan.provenance
    curves = write_plan_curves(plan, out_dir, prov, best)
    figure = save_figure(plan_figure(plan, best), Path(out_dir) / FIGURE_NAME, prov)
    return {"curves": curves, "figure": figure}
