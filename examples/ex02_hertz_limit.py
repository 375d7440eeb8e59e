r"""
The Hertz limit, and where large strain leaves it
=================================================

.. topic:: What you will learn

   * that every curve tends to Hertz's solution as the depth goes to zero, for
     small-strain (:class:`~skin_indent.mechanics.LinearElastic`) and large-strain
     (:class:`~skin_indent.mechanics.NeoHooke`) laws alike, up to nu = 0.49 (the
     quadratic elements do not lock);
   * that the small-strain curves then follow Sneddon's exact sphere solution, which
     depends on E and nu only through :math:`E^* = E/(1-\nu^2)`;
   * that large strain moves the curve away from Sneddon's by an amount that depends
     on nu: the only reason why nu can be told apart from E at all.

Hertz's force :math:`F = \frac{4}{3} E^* \sqrt{R}\, h^{3/2}` assumes small strain, a
paraboloid instead of a sphere, and a half-space. We plot :math:`F / F_{Hertz}`
against :math:`h/R` for nu = 0.3, 0.45 and 0.49.

Meshes are designed for the largest depth of a run (:func:`~skin_indent.mechanics.graded_mesh`),
so the limit :math:`h \to 0` is checked with its own runs to h/R = 0.01 (on the coarse
mesh), and the departure with runs from h/R = 0.01 to 0.25 (1.6 mm). These use the
medium mesh: at their smallest depths the contact zone spans only a fifth of the
design contact radius, where the coarse mesh has about one element and would add
steps of a few 0.1 % to curves whose differences we want to see.
"""

# %%
# Two runs per law and Poisson's ratio
# ------------------------------------
import matplotlib.pyplot as plt
import numpy as np

from skin_indent.mechanics.analytic import hertz_force, sneddon_sphere_force
from skin_indent.mechanics import LinearElastic, NeoHooke, SphericalIndenter
from skin_indent.simulate import simulate

E = 10.0  # kPa; F / F_Hertz does not depend on E
sphere = SphericalIndenter(radius_mm=6.22)
R = sphere.radius_mm
small = 0.01 * R * np.arange(1, 11) / 10  # h/R = 0.001 ... 0.01
large = np.geomspace(0.01 * R, 0.25 * R, 30)  # h/R = 0.01 ... 0.25

ratios = {}
for law in (LinearElastic, NeoHooke):
    for nu in (0.3, 0.45, 0.49):
        material = law(E_kPa=E, nu=nu)
        runs = [simulate(material, sphere, small, mesh="coarse"), simulate(material, sphere, large, mesh="medium")]
        h = np.concatenate([r.depth_mm for r in runs])
        F = np.concatenate([r.force_mN for r in runs])
        ratios[law.name, nu] = h, F / hertz_force(h, E, nu, R)
        print(f"{law.name:>14}, nu = {nu:4}: F/F_Hertz = {ratios[law.name, nu][1][0]:.4f} at h/R = 0.001, "
              f"{ratios[law.name, nu][1][-1]:.4f} at h/R = 0.25")

# %%
# The limit
# ---------
# At h/R = 0.001 (6 micrometres) every curve is within a fraction of a per cent of
# Hertz, including the nearly incompressible nu = 0.49:
worst_small_depth_error = max(abs(r[0] - 1) for _, r in ratios.values())
print(f"largest |F/F_Hertz - 1| at h/R = 0.001: {100 * worst_small_depth_error:.2f} %")

# %%
# The departure
# -------------
fig, ax = plt.subplots(figsize=(7, 4.4), layout="constrained")
colors = {0.3: "C0", 0.45: "C1", 0.49: "C2"}
for (name, nu), (h, r) in ratios.items():
    style = "--" if name == "linear-elastic" else "-"
    ax.semilogx(h / R, r, style, color=colors[nu], label=f"{name}, nu = {nu}")
hh = np.geomspace(0.001 * R, 0.25 * R, 100)
ax.semilogx(hh / R, sneddon_sphere_force(hh, E, 0.3, R) / hertz_force(hh, E, 0.3, R), "k:", lw=2,
            label="Sneddon (any nu)")
ax.axhline(1.0, color="0.6", lw=0.8)
ax.axvline(0.6 / R, color="0.8", lw=6, zorder=0)
ax.text(0.6 / R, 0.945, " the paper's\n 0.6 mm", fontsize="small")
ax.set(xlabel="h / R", ylabel="F / F_Hertz", ylim=(0.94, 1.03),
       title="Finite elements against Hertz (R = 6.22 mm)")
ax.legend(frameon=False, fontsize="small", ncol=2, loc="lower left")

# %%
# The dashed small-strain curves fall on Sneddon's for every nu: with small strain
# the force depends on :math:`E^*` only, and the drop below Hertz is geometry (the
# sphere is flatter than a paraboloid). The solid large-strain curves fan out with
# nu: at h/R = 0.1 the neo-Hookean curve for nu = 0.3 is above Sneddon's and the one
# for nu = 0.49 below it. That nu-dependent correction of a few per cent is all the
# information that separates nu from :math:`E^*` in a force-depth curve, which is why
# :doc:`ex05_invivo_identifiability` asks whether nu is identifiable at all.
#
# The large-strain correction on its own is the ratio of the two laws:
fig, ax = plt.subplots(figsize=(7, 3.4), layout="constrained")
for nu in (0.3, 0.45, 0.49):
    h, r_nh = ratios["neo-hooke", nu]
    _, r_le = ratios["linear-elastic", nu]
    ax.semilogx(h / R, r_nh / r_le, color=colors[nu], label=f"nu = {nu}")
ax.axhline(1.0, color="0.6", lw=0.8)
ax.set(xlabel="h / R", ylabel="F_neo-Hooke / F_linear", title="Large strain against small strain")
ax.legend(frameon=False)
plt.show()
