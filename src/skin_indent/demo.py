"""``skin-indent demo``: the paper's workflow end to end on a bundled curve.

The bundled curve (``skin_indent/data/forearm_like.csv``) looks like the paper's in
vivo forearm measurement (sphere R = 6.22 mm, 100 points to 0.6 mm, ~11 mN), computed
by an independent finite-element code for a layered skin model plus sensor noise
(see its README). The demo loads or builds the response surface, identifies
(E, nu) over the paper's 0.05-0.6 mm window with the paper's EKF and global
stabilisation (from the paper's start E = 10 kPa, nu = 0.3, C = 1e-5), with the
better-conditioned EKF and with least squares, measures whether nu is identifiable,
and writes a figure and a JSON summary. Then it goes past the paper: the
homogeneous half-space leaves a structured misfit, and the diagnosis climbs the
ladder of effects (:func:`skin_indent.diagnosis.diagnose`) until the model explains
the curve to the noise, writing the ladder's report (``diagnosis/index.html``) and
one sentence saying what was missing.

Then it closes the loop: one curve cannot tell two layers from a layer with
stiffening, and the diagnosis names the measurement that would separate them best (a
sphere of twice the radius; half the radius separates them too). The bundled curve of the
same skin indented with a sphere of half the radius (``forearm_like_R3.11mm.csv``, same
independent code) is added, both curves are
diagnosed together (:func:`~skin_indent.diagnosis.diagnose` with a list: the material
shared, each curve its own sphere, contact point and noise), and the joint verdict, its
report (``diagnosis-both/index.html``) and a figure of both curves with the final
model and every rung's residuals (``loop.png``) say what was missing.
"""

from __future__ import annotations

import math

import time
from pathlib import Path

import numpy as np

from .data import bundled_path
from .runtime.context import Context
from .diagnosis import diagnose
from .fitting.bodies import body_lines
from .report import write_report
from .fitting import PAPER_TOLERANCE, fit, surface_for
from .measurement import load_csv, prepare
from .report import save_figure
from .report.sample_figure import sample_diagnosis_figure
from .runtime.atomic import atomic_write
from .runtime.json_io import dumps
from .runtime.provenance import provenance, surface_identity, with_provenance

RADIUS_MM = 6.22
#: the demo's second measurement: the same skin, a sphere of half the radius (its file gives R = 3.11 mm)
SECOND_CURVE = "forearm_like_R3.11mm.csv"
WINDOW_MM = (0.05, 0.6)
PAPER_START = (10.0, 0.3)


def bundled_rank(diag, radius_mm: float) -> str:
    """Where the plan ranks the bundled second curve (a sphere of ``radius_mm``) among the measurements it weighed."""
    ranking = [] if diag.outlook is None else diag.outlook.best(len(diag.outlook.ranking))
    for i, a in enumerate(ranking):
        if a.candidate.kind == "sphere" and math.isclose(a.candidate.radius_mm, radius_mm, rel_tol=1e-3):
            sep = "" if math.isnan(a.separation) else f", S = {a.separation:.3g}"
            return (f"the bundled curve at hand is a sphere of R = {radius_mm:g} mm: the plan ranks it {i + 1} of "
                    f"{len(ranking)}{sep} (skin-indent plan lists them all)")
    return f"the bundled curve at hand is a sphere of R = {radius_mm:g} mm (not among the measurements weighed)"


def run_demo(out_dir: str | Path = "skin_indent_demo", *, cache_dir=None, workers=None, progress: bool | None = None,
             echo=print, diagnosis: bool = True, command=None) -> dict:
    """Run the demo, write ``demo.png`` and ``demo.json`` into ``out_dir``; return the summary.

    With ``diagnosis`` (default), go on with the diagnosis ladder of the same curve and
    write its report into ``out_dir/diagnosis``; then, where one curve leaves the verdict
    ambiguous or a parameter undetermined, add the bundled curve of the same skin at half the
    sphere's radius (the measurement the diagnosis proposes), diagnose both curves together,
    write that report into ``out_dir/diagnosis-both`` and the figure ``loop.png``. ``progress``: bars of the surface builds
    (None, the default: only when stderr is a terminal). Every output carries the provenance of
    the run (``command``: the command line to record, default ``sys.argv``; the bundled
    curve with its sha256; the settings; the surface): ``demo.json`` under
    ``"provenance"``, the figures in their PNG metadata, the report in its page.
    """
    from . import inverse

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    source = bundled_path("forearm_like.csv")
    measurement = load_csv(source, radius_mm=RADIUS_MM)
    data = prepare(measurement, window=WINDOW_MM, contact="origin").data
    echo(f"data: {measurement.source} ({measurement.n_points} points; fitting {data.n_points} in "
         f"{WINDOW_MM[0]}-{WINDOW_MM[1]} mm), sphere R = {RADIUS_MM} mm")
    t = time.perf_counter()
    surface = surface_for(RADIUS_MM, WINDOW_MM[1],
                          context=Context(cache_dir=cache_dir, workers=workers, progress=progress))
    echo(f"response surface: {surface.grid.shape[1]} E x {surface.grid.shape[2]} nu x {surface.grid.shape[0]} "
         f"depths, ready in {time.perf_counter() - t:.1f} s")
    results = {}
    timings = {}
    for method in ("ekf-paper", "ekf", "lsq"):
        t = time.perf_counter()
        x0 = PAPER_START if method == "ekf-paper" else None
        tol = PAPER_TOLERANCE if method == "ekf-paper" else None
        # the paper's identification, an option of the one fit (its window, the noise alone): `fit`'s numbers
        results[method] = fit(measurement, surface, method, window=WINDOW_MM, contact="origin", x0=x0, tol=tol)
        timings[method] = time.perf_counter() - t
    noise = results["lsq"].noise_mN  # the error model's noise rule (fitting.error_model.curve_noise)
    prof = inverse.profile(surface, data.depth_mm, data.force_mN, "nu", noise_mN=noise)
    lines = [f"{'method':<10} {'E (kPa)':>16} {'nu':>16} {'rms (mN)':>9} {'iterations':>11} {'time (s)':>9}"]
    for method, r in results.items():
        E, nu = r.parameters["E_kPa"], r.parameters["nu"]
        sE, snu = r.std.get("E_kPa", np.nan), r.std.get("nu", np.nan)
        lines.append(f"{method:<10} {E:8.3f} +/- {sE:5.2f} {nu:8.4f} +/- {snu:5.3f} {r.rms_mN:9.4f} "
                     f"{r.iterations:11d} {timings[method]:9.2f}")
    for line in lines:
        echo(line)
    # how each fit ended where that is not a result (nu at its surface's end): as `fit` flags it
    flags = {method: list(r.flags) for method, r in results.items()}
    for method, method_flags in flags.items():
        for flag in method_flags:
            echo(f"  flag ({method}): {flag}")
    lsq = results["lsq"]
    echo(f"noise level from the data: {noise:.3f} mN; least-squares misfit {lsq.rms_mN:.3f} mN "
         f"({lsq.rms_mN / noise:.1f} x noise)")
    echo(f"is nu identifiable? {prof.verdict}")
    if lsq.rms_mN > 1.5 * noise:
        echo("the homogeneous half-space does not explain this curve to the noise level (as in the paper's "
             "Fig. 11): the residual is structured, something is missing from the model")
    prov = provenance(command=command, inputs=[source], surface=surface,
                      settings={"radius_mm": RADIUS_MM, "window_mm": list(WINDOW_MM), "contact": "origin",
                                "methods": list(results), "x0_ekf_paper": list(PAPER_START),
                                "tol_ekf_paper": PAPER_TOLERANCE, "diagnosis": diagnosis})
    figure = out / "demo.png"
    _figure(data, surface, results, noise, figure, prov)
    diag = page = joint = joint_page = loop = None
    if diagnosis:
        context = Context(cache_dir=cache_dir, workers=workers, progress=progress)
        echo("what is missing? the diagnosis ladder (finite-element fits in the loop where no surface combines "
             "the effects):")
        t = time.perf_counter()
        diag = diagnose(measurement, context=context)
        for f in diag.ladder:
            echo(f"  {f.model:<32} RMS {f.rms_mN:.4f} mN  {'white' if f.white else 'structured'}")
            for flag in f.flags:  # how its fit ended, where that is not a result (fitting.ended)
                echo(f"    flag: {flag}")
        for line in body_lines(diag.current, diag.units):  # the final model: E of each body, thicknesses
            echo(line)
        echo(diag.sentence())
        # the report and demo.json record the diagnosis's surfaces too (demo.png: the paper's surface alone)
        prov = {**prov, "surface": surface_identity([surface, *diag.surfaces])}
        page = write_report(diag, out / "diagnosis", provenance=prov)
        timings["diagnose"] = time.perf_counter() - t
        if diag.verdict == "ambiguous" or diag.undetermined() or len(diag.confounded_with) > 1:
            t = time.perf_counter()
            second = load_csv(bundled_path(SECOND_CURVE))
            echo(f"one curve cannot settle it; the measurement proposed: {diag.suggested_measurement or 'another sphere'}")
            echo(bundled_rank(diag, float(second.radius_mm)))
            echo(f"adding the same skin indented with a sphere of R = {second.radius_mm:g} mm ({second.source}, "
                 f"{second.n_points} points), and diagnosing both curves together:")
            joint = diagnose([measurement, second], context=context)
            for f in joint.ladder:
                rms = ", ".join(f"{v:.4f}" for v in f.curve_rms_mN)
                echo(f"  {f.model:<32} RMS ({rms}) mN  {'white' if f.white else 'structured'}")
                for flag in f.flags:
                    echo(f"    flag: {flag}")
            for line in body_lines(joint.current, joint.units):
                echo(line)
            echo(joint.sentence())
            both = provenance(command=command, inputs=[source, bundled_path(SECOND_CURVE)],
                              settings={"radius_mm": [RADIUS_MM, float(second.radius_mm)], "diagnosis": "joint"})
            joint_page = write_report(joint, out / "diagnosis-both", provenance=both)
            loop = save_figure(sample_diagnosis_figure(joint), out / "loop.png", both)
            timings["diagnose_both"] = time.perf_counter() - t
    summary = {
        "data": str(measurement.source),
        "window_mm": list(WINDOW_MM),
        "noise_mN": noise,
        "results": {m: {**r.to_dict(), "flags": flags[m]} for m, r in results.items()},
        "time_s": timings,
        "nu_profile": {"verdict": prof.verdict, "values": list(map(float, prof.values)),
                       "rms_mN": list(map(float, prof.rms_mN))},
        "diagnosis": diag.to_dict() if diag is not None else None,
        "diagnosis_both": joint.to_dict() if joint is not None else None,
    }
    write_summary(out / "demo.json", summary, prov)
    echo(f"wrote {figure} (fit, residuals, parameter histories), "
         + (f"the diagnosis report {page} (the ladder) " if page else "")
         + (f"the joint report {joint_page}, {loop} (both curves, every rung's residuals) " if joint_page else "")
         + f"and {out / 'demo.json'}")
    return summary


def write_summary(path, summary: dict, prov: dict) -> Path:
    """Write the demo's summary as JSON with its provenance (``"provenance"``), atomically.

    Parameters
    ----------
    path : path
        ``demo.json``.
    summary : dict
        What :func:`run_demo` returns (made JSON-safe: NaN as null).
    prov : dict
        :func:`skin_indent.runtime.provenance.provenance` of the run.

    Returns
    -------
    Path
    """
    text = dumps(with_provenance(summary, prov), indent=1) + "\n"
    return atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))


def demo_figure(data, surface, results: dict, noise_mN: float):
    """The demo's figure: the fits of every method, their residuals and the paper's filter histories.

    Left: the measurement and each method's fitted curve (each its own line style and
    markers, so that methods which agree stay visible, the legend saying which are the
    same curve), and below the residuals with the noise bands (±1 and ±2 standard
    deviations). Right: E after each update of the paper's filter's first pass, and E
    and ν after each of its sweeps (its global stabilisation).

    Parameters
    ----------
    data : Measurement
        The fitted points (depth in mm, force in mN).
    surface : ResponseSurface
    results : dict
        ``method -> IdentificationResult``, with ``"ekf-paper"`` among them.
    noise_mN : float
        Noise standard deviation (mN).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    from .report.paper import plot_first_pass, plot_fit, plot_residuals, plot_sweep_history

    d, F = data.depth_mm, data.force_mN
    models = {m: surface.force(d, np.array([r.parameters["E_kPa"], r.parameters["nu"]])) for m, r in results.items()}
    fig = Figure(figsize=(12, 8), layout="constrained")
    grid = fig.add_gridspec(3, 2)
    plot_fit(d, F, {f"{m}: E = {r.parameters['E_kPa']:.2f} kPa, ν = {r.parameters['nu']:.3f}": models[m]
                    for m, r in results.items()}, ax=fig.add_subplot(grid[0:2, 0]),
             title="forearm-like curve vs homogeneous neo-Hookean half-space")
    plot_residuals(d, {m: F - models[m] for m in results}, noise_mN, ax=fig.add_subplot(grid[2, 0]))
    paper = results["ekf-paper"]
    plot_first_pass(paper, d, axes=[fig.add_subplot(grid[0, 1])])
    ax_e = fig.add_subplot(grid[1, 1])
    ax_nu = fig.add_subplot(grid[2, 1], sharex=ax_e)
    plot_sweep_history(paper, axes=[ax_e, ax_nu])
    return fig


def _figure(data, surface, results, noise, path, prov=None):
    save_figure(demo_figure(data, surface, results, noise), path, prov, dpi=110)
