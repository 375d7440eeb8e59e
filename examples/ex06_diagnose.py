r"""
Diagnosing a curve: where the model fails, which effect is missing, and the error falling
=========================================================================================

.. topic:: What you will learn

   * how :func:`~skin_indent.diagnosis.diagnose` fits the neo-Hookean half-space to a
     curve, judges its residual against the noise, and says where it fails;
   * how each candidate effect (``layer``, ``stiffening``, ``viscoelastic``,
     ``friction``, ``adhesion``, ``offset``) is refitted and ranked by BIC, and why
     some are reported as "not detectable here";
   * how adding the named effect (``add=``) climbs the error ladder until the
     residual is noise, and what it means when no rung gets there;
   * how to write the HTML report (:func:`~skin_indent.diagnosis.write_report`).

The first curve, ``v02_layer_soft_base.csv`` from the project's test data, was
computed by an independent FE code (FElupe) for a 1 mm layer of 25 kPa bonded on a
4 kPa half-space, with 0.05 mN of noise; the diagnosis is not told so. The command
line does the same: ``skin-indent diagnose v02_layer_soft_base.csv --add layer
--report out``.
"""

# %%
# Diagnose
# --------
# The response surfaces behind the candidates (FE runs over nu and the effect's
# parameters; F is exactly proportional to E) are built on the first run and cached,
# here in a temporary folder shared with the other examples.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from skin_indent.data import bundled_path
from skin_indent import Context, diagnose, write_report
from skin_indent.measurement import load_csv

CACHE = Context(cache_dir=Path(tempfile.gettempdir()) / "skin_indent_gallery")
measurement = load_csv(bundled_path("v02_layer_soft_base.csv"))
diagnosis = diagnose(measurement, context=CACHE, in_loop=False)  # surfaces only: seconds
print(diagnosis.report())
verdict = diagnosis.verdict

# %%
# The base model's residual is not noise: the runs test and the autocorrelation
# reject it and its RMS is well above the noise (estimated from the data itself).
# Each candidate is refitted; the verdict names the one that lowers the BIC by more
# than 10 (very strong evidence) with no rival close to it. Viscoelasticity cannot be
# told from a single constant-speed ramp, adhesion needs tensile forces, and full-stick
# friction at this nu changes less than E absorbs: all three are said so, not claimed.
#
# Add the effect and watch the error fall
# ---------------------------------------
added = diagnose(measurement, context=CACHE, add=(verdict,), in_loop=False)
rms_ladder = [f.rms_mN for f in added.ladder]
for f in added.ladder:
    print(f"{f.model:<24} RMS {f.rms_mN:.4f} mN, BIC {f.bic:8.1f}, {'white' if f.white else 'structured'}")
print(added.current.parameters)
print("diagnosed again on top of it:", added.verdict)

fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
d = added.data
a1.plot(d.depth_mm, d.force_mN, ".", ms=3, color="0.5", label="measurement")
for f in added.ladder:
    a1.plot(d.depth_mm, f.prediction_mN, label=f"{f.model} (RMS {f.rms_mN:.3f} mN)")
a1.set_xlabel("depth (mm)")
a1.set_ylabel("force (mN)")
a1.legend(fontsize=8)
for f in added.ladder:
    a2.plot(d.depth_mm, f.residual_mN, ".-", ms=3, lw=0.5, label=f.model)
a2.axhspan(-2 * added.noise_mN, 2 * added.noise_mN, color="tab:green", alpha=0.15, label="2 sigma noise")
a2.set_xlabel("depth (mm)")
a2.set_ylabel("residual (mN)")
a2.legend(fontsize=8)
fig.tight_layout()
plt.show()

# %%
# When no single effect is enough
# -------------------------------
# The bundled forearm-like curve comes from three materials (1 mm of 17.5 kPa dermis,
# 3 mm of 2.9 kPa fat, 9.4 kPa muscle). The best single effect lowers the error a lot
# but leaves a structured residual above the noise: the ladder says that the model
# family is still missing something, rather than pretending that it is not. Here the
# climb stays on the response surfaces (``in_loop=False``, seconds); with the default
# ``in_loop=True`` it also fits two layers, or a layer with stiffening, with the
# finite-element model in the loop (minutes: ``skin-indent demo`` shows that ladder).
forearm = diagnose(load_csv(bundled_path("forearm_like.csv")), context=CACHE, in_loop=False)
print(forearm.report())
best = forearm.ranking[0]
print(f"best single effect: {best.model}, RMS {best.rms_mN:.3f} mN against noise {forearm.noise_mN:.3f} mN, "
      f"{'white' if best.white else 'still structured'}")

# %%
# The report
# ----------
# A self-contained HTML page (figures embedded) and the PNG figures.
page = write_report(added, Path(tempfile.mkdtemp()) / "report")
print(page)
