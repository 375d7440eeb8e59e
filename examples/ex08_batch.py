r"""
A folder of curves in, a table and a figure out
===============================================

.. topic:: What you will learn

   * how :func:`~skin_indent.batch.fit_many` fits every curve of every file in a folder
     (all curves of a force map too), in parallel, each with the sphere radius its file
     records;
   * that the response surfaces are built (or found in the cache) once, before the fits,
     and shared by all the curves: one unit-radius surface serves every radius;
   * how to write the table (:func:`~skin_indent.report.batch_table.write_tsv`, one row per curve with
     a provenance header: package version, command, each input's sha256, settings,
     surfaces), the summary figure (:func:`~skin_indent.report.batch_table.summary_figure`) and a plot
     of one fit (:func:`~skin_indent.report.fit_figure.plot_fit`);
   * how to read the quality columns: the misfit against a noise level independent of
     the model, and the verdict.

The folder holds three bundled curves: two real AFM curves (a JPK CellHesion curve with an
18.64 um bead and an Optics11 Chiaro curve with a 27.5 um sphere, both from the
afmformats test data, every 10th sample; the radius is a ``# radius_um:`` comment in each
file) and the forearm-like skin curve of the demo (R = 6.22 mm, the skin default: its file
records no radius). The command line does the same: ``skin-indent fit FOLDER --out
results.tsv --plot plots --fix nu=0.499``.
"""

# %%
# Fit the folder
# --------------
# The curves are read, their baselines and contact points prepared, the surfaces
# loaded or built (coarse mesh here, to run fast; cached in a temporary folder shared
# with the other examples), then the fits run on the local cores. nu is held at 0.499,
# the nearly incompressible value AFM users take (E* = E / (1 - nu^2) is what the data
# determine).
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from skin_indent import Context
from skin_indent.batch import fit_many
from skin_indent.report.batch_table import summary_figure, write_tsv
from skin_indent.data import bundled_path
from skin_indent.report.fit_figure import plot_fit
from skin_indent.runtime.provenance import read_provenance

CACHE = Context(cache_dir=Path(tempfile.gettempdir()) / "skin_indent_gallery")
folder = Path(tempfile.mkdtemp()) / "curves"
folder.mkdir()
for name in ("afm_jpk_force-save-example_R18.64um.csv", "afm_chiaro_AEBP1_R27.5um.csv", "forearm_like.csv"):
    shutil.copy(bundled_path(name), folder / name)

rows = fit_many([folder], fixed={"nu": 0.499}, mesh="coarse", context=CACHE, progress=False, keep_fits=True)

# %%
# The table
# ---------
# One row per curve. E* is the large-strain finite-element fit; Hertz's E* of the same
# points is next to it (at h/R up to 0.5 Hertz's small-strain law is off by 10-20%). The
# misfit is the RMS residual over the noise of the pre-contact baseline (or of the
# data's high-frequency part): far above 1 says the homogeneous half-space does not
# describe the curve, and the verdict points to ``skin-indent diagnose``.
print(f"{'curve':<44} {'R (um)':>7} {'E (kPa)':>9} {'E* (kPa)':>9} {'Hertz E*':>9} {'misfit':>7}  verdict")
for r in rows:
    if r.error:
        print(f"{r.label:<44} error: {r.error}")
        continue
    print(f"{r.label:<44} {r.radius_mm * 1e3:7.4g} {r.E_kPa:9.4g} {r.E_star_kPa:9.4g} {r.hertz_E_star_kPa:9.4g} "
          f"{r.misfit:7.2g}  {r.verdict.split(':')[0]}")
E_kPa = {r.label: r.E_kPa for r in rows}

# %%
# The table as a file, with its provenance
# ----------------------------------------
out = folder.parent / "results"
tsv = write_tsv(rows, out / "results.tsv")
prov = read_provenance(tsv)
for item in prov["inputs"]:
    print(f"{Path(item['path']).name:<44} sha256 {item['sha256'][:16]}...  {item['bytes']} bytes")
print("settings:", prov["settings"])
print("surfaces:", [s["hash"][:12] for s in prov["surface"]])
print("unit-radius surface of each curve:", {r.label: r.surface[:12] for r in rows})

# %%
# The summary figure and one fit
# ------------------------------
# :func:`~skin_indent.report.batch_table.summary_figure` and :func:`~skin_indent.report.fit_figure.plot_fit`
# write PNG files (matplotlib without pyplot, so they work on a server); here they are
# shown as images. The fit plot marks the contact point (dotted) and the fitted range
# (shaded); the residual is drawn against twice the noise.
summary = summary_figure(rows, out / "summary.png")
jpk = next(r for r in rows if r.label.startswith("afm_jpk"))
one = plot_fit(jpk.fit, out / "fit_jpk.png")
for path in (summary, one):
    image = plt.imread(path)
    fig, ax = plt.subplots(figsize=(9, 9 * image.shape[0] / image.shape[1]))
    ax.imshow(image)
    ax.set_axis_off()
plt.show()
