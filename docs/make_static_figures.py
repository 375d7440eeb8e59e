"""Make the README's static figure, ``docs/_static/diagnose_ladder.png``, with the package's own figures.

From the root of a clone (a few seconds with the surfaces cached; on an empty cache the diagnosis
first builds its coarse response surfaces, several minutes on 2 cores)::

    python docs/make_static_figures.py [--cache-dir DIR] [--out docs/_static/diagnose_ladder.png]

It diagnoses the bundled curve ``v02_layer_soft_base.csv`` (a layer over a softer half-space,
computed with an independent finite-element code, noise 0.05 mN; see
``src/skin_indent/data/README.md``) as ``skin-indent diagnose --surfaces-only`` does (coarse
mesh), refuses to draw unless the verdict is the curve's answer key (``layer``), and draws the
diagnosis page's fit figure (left) and ladder figure (right) of
:mod:`skin_indent.report.diagnosis_page` side by side: the same functions, labels and numbers as
``skin-indent diagnose --report``. The PNG carries its provenance (this command line, the curve's
sha256, the settings and the surfaces used), as every figure of the package does.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from skin_indent.data import bundled_path
from skin_indent.diagnosis import diagnose
from skin_indent.measurement import load_csv
from skin_indent.report import save_figure
from skin_indent.report.diagnosis_page import fit_figure, ladder_figure
from skin_indent.report.labels import model_label
from skin_indent.runtime.context import Context
from skin_indent.runtime.provenance import provenance

#: the bundled curve, and what is hidden in it (src/skin_indent/data/README.md, tests/data/hidden-effects)
CURVE, ANSWER = "v02_layer_soft_base.csv", "layer"
OUT = Path(__file__).resolve().parent / "_static" / "diagnose_ladder.png"
#: how it is diagnosed (``skin-indent diagnose --surfaces-only``; coarse, diagnose's default mesh)
SETTINGS = {"mesh": "coarse", "in_loop": False}


def ladder_panels(diag):
    """The fit figure (left) and the ladder figure (right) of a diagnosis in one figure.

    Parameters
    ----------
    diag : Diagnosis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(14, 4.8), layout="constrained")
    left, right = fig.subfigures(1, 2, width_ratios=(1.0, 1.25))
    fit_figure(diag, left)
    ladder_figure(diag, right)
    base, best = diag.base, diag.current
    fig.suptitle(f"skin-indent diagnose: the {model_label(base.model)} half-space fails (RMS {base.rms_mN:.3g} mN); "
                 f"adding the named effect, {diag.verdict}, brings the error to the noise (RMS {best.rms_mN:.3g} mN, "
                 f"noise {diag.noise_mN:.3g} mN)", fontsize=11)
    return fig


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=OUT, help=f"the PNG (default {OUT})")
    parser.add_argument("--cache-dir", type=Path, default=None,
                        help="response-surface cache (default the per-user cache, SKIN_INDENT_CACHE)")
    args = parser.parse_args(argv)
    source = bundled_path(CURVE)
    diag = diagnose(load_csv(source), context=Context(cache_dir=args.cache_dir), **SETTINGS)
    if diag.verdict != ANSWER or not diag.explained:
        print(f"{CURVE}: verdict {diag.verdict!r} (explained: {diag.explained}), the answer key says "
              f"{ANSWER!r}: not drawing a figure that would say otherwise", file=sys.stderr)
        return 1
    command = ["python", "docs/make_static_figures.py", *(sys.argv[1:] if argv is None else argv)]
    prov = provenance(command, inputs=[source], settings=SETTINGS, surface=diag.surfaces)
    save_figure(ladder_panels(diag), args.out, prov)
    print(f"{CURVE}: verdict {diag.verdict}; " + ", ".join(f"{f.model} RMS {f.rms_mN:.3g} mN" for f in diag.ladder)
          + f"; noise {diag.noise_mN:.3g} mN; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
