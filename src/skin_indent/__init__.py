"""skin_indent: sphere indentation of skin, from finite elements to diagnosis.

Units everywhere: mm, kPa, mN, s (consistent: kPa x mm^2 = mN).

Where things live
-----------------
- ``skin_indent.measurement``: where data enters (CSV, units, segments, contact point).
- ``skin_indent.mechanics``: the finite-element forward model (mesh, materials,
  axisymmetric large-strain assembly, sphere contact, incremental Newton).
- ``skin_indent.simulate``: the one seam between mechanics and everything else.
- ``skin_indent.response_surface``: F(h; E, nu, ...) on a grid, cached and interpolated.
- ``skin_indent.inverse``: identification (EKF as in Delalleau et al. 2006, least squares,
  uncertainty, identifiability).
"""

__version__ = "0.1.0"
