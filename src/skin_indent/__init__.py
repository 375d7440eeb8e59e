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

# The main nouns, importable from the top level; loaded on first use so that
# ``import skin_indent`` (and the CLI's start) stays fast.
_EXPORTS = {
    "simulate": "skin_indent.simulate",
    "ForceDepthCurve": "skin_indent.simulate",
    "NeoHooke": "skin_indent.mechanics.materials",
    "LinearElastic": "skin_indent.mechanics.materials",
    "NeoHookeStiffening": "skin_indent.mechanics.materials",
    "Viscoelastic": "skin_indent.mechanics.materials",
    "PronyTerm": "skin_indent.mechanics.materials",
    "SphericalIndenter": "skin_indent.mechanics.contact",
    "ContactLaw": "skin_indent.mechanics.contact",
    "Layer": "skin_indent.mechanics.layers",
    "LayeredSample": "skin_indent.mechanics.layers",
    "RIGID": "skin_indent.mechanics.layers",
    "Protocol": "skin_indent.protocol",
    "Model": "skin_indent.effects",
    "load_csv": "skin_indent.measurement",
    "Measurement": "skin_indent.measurement",
    "ResponseSurface": "skin_indent.response_surface",
    "SurfaceGrid": "skin_indent.response_surface",
    "identify": "skin_indent.identify",
}
__all__ = ["__version__", *_EXPORTS]


def __getattr__(name):
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'skin_indent' has no attribute {name!r}")
