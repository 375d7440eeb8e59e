r"""
An in-vivo-like curve: estimates, uncertainty, and is nu identifiable?
======================================================================

.. topic:: What you will learn

   * how to read a measured curve with :func:`~skin_indent.measurement.load_csv`
     and keep the paper's fitting window with
     :func:`~skin_indent.measurement.prepare`;
   * how to identify (E, nu) with :func:`~skin_indent.fitting.identify` by the
     paper's filter, the better filter and least squares, and how to estimate the
     noise from the data alone (:func:`~skin_indent.inverse.estimate_noise`);
   * what the standard errors and the correlation of a fit say, and why E* is known
     much better than E;
   * how a profile of :math:`\chi^2` (:func:`~skin_indent.inverse.profile`) answers
     "is nu identifiable?", and how the residual against the noise band shows that
     the model is missing something (the paper's Figs. 10 and 11).

The curve ``forearm_like.csv`` ships with the package. It looks like the paper's
in-vivo forearm measurement (sphere R = 6.22 mm, 100 points to 0.6 mm, about
11 mN), but it is synthetic: computed by an independent finite-element code and
given sensor-like noise (see ``skin_indent/data/README.md``). The paper found
E = 5.67 kPa and nu = 0.48 for its subject.
"""

# %%
# The data
# --------
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from skin_indent.data import bundled_path
from skin_indent.fitting import identify
from skin_indent.inverse import estimate_noise, hertz_equivalence, profile
from skin_indent.measurement import load_csv, prepare
from skin_indent.report.paper import plot_fit, plot_residuals, plot_sweep_history
from skin_indent.response_surface import ResponseSurface, SurfaceGrid, default_settings

R = 6.22  # mm
measurement = load_csv(bundled_path("forearm_like.csv"), radius_mm=R)
data = prepare(measurement, window=(0.05, 0.6), contact="origin").data  # the paper's window, loading part
print(measurement)
print(f"fitting {data.n_points} points between {data.depth_mm[0]:.3f} and {data.depth_mm[-1]:.3f} mm")
noise = estimate_noise(data.depth_mm, data.force_mN)
print(f"noise estimated from the data: {noise:.3f} mN")

# %%
# :func:`~skin_indent.inverse.estimate_noise` predicts each point from its
# neighbours by a cubic and takes a robust spread of the prediction errors: the
# smooth curve cancels, the noise stays. The file was made with 0.05 mN.
#
# The response surface
# --------------------
# The same coarse surface as in :doc:`ex04_blind_test` (built there, or here on the
# first run).
CACHE = Path(tempfile.gettempdir()) / "skin_indent_gallery"
surface = ResponseSurface.load_or_build(SurfaceGrid.paper(), default_settings(R, mesh="coarse"),
                                        path=CACHE / "paper_grid_coarse.npz", cache_dir=CACHE, progress=False)

# %%
# Three identifications
# ---------------------
# The paper's filter starts from its starting point (10 kPa, 0.3) and stops at
# :math:`C = 10^{-5}`, as the paper did in vivo; the other two start from a Hertz
# estimate and use the noise level.
results = {
    "ekf-paper": identify(data, surface, "ekf-paper", x0=(10.0, 0.3), tol=1e-5),
    "ekf": identify(data, surface, "ekf", noise_mN=noise),
    "lsq": identify(data, surface, "lsq", noise_mN=noise),
}
for method, r in results.items():
    print(f"{method:>9}: E = {r.parameters['E_kPa']:.3f} +/- {r.std['E_kPa']:.3f} kPa, "
          f"nu = {r.parameters['nu']:.4f} +/- {r.std['nu']:.4f}, rms {r.rms_mN:.3f} mN, "
          f"{r.iterations} iterations ({r.message})")
lsq = results["lsq"]
invivo_E = lsq.parameters["E_kPa"]

# %%
# All three land near the paper's answer: E close to 5.7 kPa and nu at or near the
# top of the surface (0.49). The filters' sweeps (the paper's Fig. 10):
fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 4.6), layout="constrained")
plot_sweep_history(results["ekf-paper"], axes=axes)
E_forward, E_backward = results["ekf-paper"].history["sweeps"][-2:, 0][::-1]
print(f"paper's filter: E = {E_forward:.3f} kPa after the last forward sweep, "
      f"{E_backward:.3f} kPa after the backward one")

# %%
# After a few sweeps the filter alternates between two states: the forward sweeps
# end near 5.8 kPa, the backward ones near 5.6 kPa. A filter weighs the last points
# it sees most, and when the model cannot follow the data (see the residual below)
# the points at the two ends of the curve ask for different parameters. This is why
# the stop rule compares the states at the ends of two forward sweeps (see
# :doc:`/theory`). The paper needed 198-232 sweeps on its in-vivo curve.

# %%
# Uncertainty
# -----------
# The least-squares covariance is :math:`s^2 (J^T J)^{-1}` with :math:`J` the
# Jacobian of the model at the estimate (see :doc:`/theory`):
print(lsq.report())

# %%
# The correlation of E and nu is almost -1: the data fix a combination of them. It
# is Hertz's reduced modulus :math:`E^* = E/(1-\nu^2)`;
# :func:`~skin_indent.inverse.hertz_equivalence` measures how much of what the curve
# says about nu comes only through it:
equivalence = hertz_equivalence(surface, data.depth_mm, data.force_mN, noise_mN=noise)
print(equivalence.summary)

# %%
# Is nu identifiable?
# -------------------
# Standard errors assume a parabolic :math:`\chi^2` and an estimate away from the
# bounds, and nu sits on its upper bound. A profile is more honest: fix nu at a
# series of values, refit E each time, and see where :math:`\chi^2` rises by 3.84
# above its minimum (a 95 % interval for one parameter). Two noise levels bracket the
# answer: the noise of the data, and the RMS misfit of the model, which treats the
# misfit as if it were noise (the default of :func:`~skin_indent.inverse.profile`).
nu_values = np.linspace(0.3, 0.49, 39)
profiles = {
    f"sigma = noise ({noise:.3f} mN)": profile(surface, data.depth_mm, data.force_mN, "nu", nu_values,
                                               noise_mN=noise),
    f"sigma = misfit ({lsq.rms_mN:.3f} mN)": profile(surface, data.depth_mm, data.force_mN, "nu", nu_values),
}
fig, ax = plt.subplots(figsize=(7, 3.8), layout="constrained")
for label, prof in profiles.items():
    print(f"{label}: {prof.verdict}")
    ax.plot(prof.values, prof.delta_chi2, ".-", label=label)
ax.axhline(3.84, color="k", ls="--", lw=0.8, label="95 % (Delta chi2 = 3.84)")
ax.axhline(1.0, color="k", ls=":", lw=0.8, label="68 % (Delta chi2 = 1)")
ax.set(xlabel="nu (fixed)", ylabel="Delta chi2 (E refitted)", ylim=(0, 12), xlim=(0.3, 0.495),
       title="Profile of nu")
ax.legend(frameon=False, fontsize="small")

# %%
# Values of nu below about 0.46 (misfit counted as noise) or 0.48 (noise only) are
# excluded, but nothing excludes the largest values up to the surface's bound: nu is
# bounded from below only. A Poisson's ratio reported from such a curve with two
# digits (0.48 in the paper) says more than the data do. The paper's filter reports
# a larger standard error than the other two because, given no noise level, its
# covariance uses the residual spread as the noise.
#
# The residual against the noise
# ------------------------------
# The paper's Fig. 11 shows that its best fit does not follow the measurement well.
# The same happens here: the residual is far outside the noise band and has a shape
# (the same for the three methods), not scatter.
d, F = data.depth_mm, data.force_mN
models = {m: surface.force(d, (r.parameters["E_kPa"], r.parameters["nu"])) for m, r in results.items()}
fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 6), layout="constrained",
                               gridspec_kw={"height_ratios": [2, 1]})
plot_fit(d, F, {f"{m}: E = {r.parameters['E_kPa']:.2f} kPa, ν = {r.parameters['nu']:.3f}": models[m]
                for m, r in results.items()}, ax=ax1, title="forearm-like curve and homogeneous half-space fits")
plot_residuals(d, {m: F - models[m] for m in results}, noise, ax=ax2)
print(f"least-squares misfit {lsq.rms_mN:.3f} mN RMS, {lsq.rms_mN / noise:.1f} times the noise; "
      f"reduced chi2 {lsq.redchi:.1f}")

# %%
# The homogeneous neo-Hookean half-space explains the curve only to about three
# times the noise. The paper blamed its simple model (no layers, no viscosity, no
# anisotropy); the residual's shape is the evidence with which to decide which
# effect is missing. With such a misfit the standard errors above, computed with
# the noise level, are too small, and even the profile with the misfit as noise is
# only an indication: the uncertainty that matters here is that of the model.
plt.show()
