"""skin_indent: sphere indentation of skin, from finite elements to diagnosis.

Units everywhere: mm, kPa, mN, s (consistent: kPa x mm^2 = mN).

>>> import skin_indent as si
>>> m = si.load_csv(si.bundled_path("forearm_like.csv"), radius_mm=6.22)
>>> result = si.fit(m, window=(0.05, 0.6))     # doctest: +SKIP
>>> diagnosis = si.diagnose(m)                  # doctest: +SKIP

Where things live
-----------------
- ``skin_indent.measurement``: where data enters (CSV and instrument files, units,
  segments, contact point) and :func:`prepare`, the one preparation of a recorded curve.
- ``skin_indent.mechanics``: the finite-element forward model (mesh, materials,
  axisymmetric large-strain assembly, sphere contact, incremental Newton).
- ``skin_indent.simulate``: the one seam between mechanics and everything else.
- ``skin_indent.effects``: the physical effects, one module each, and :class:`Model`.
- ``skin_indent.response_surface``: F(h; E, nu, ...) on a grid, cached and interpolated.
- ``skin_indent.models``: force models for fits (elastic core plus effects, Hertz).
- ``skin_indent.inverse``: identification (EKF as in Delalleau et al. 2006, least squares,
  uncertainty, identifiability).
- ``skin_indent.fitting``: from a recorded curve to parameters (:func:`fit`), for the paper's
  half-space or any model, with values held and priors; the multistart fitter.
- ``skin_indent.diagnosis``: which effect is missing (:func:`diagnose`): it orders and compares fits;
  which measurement to make next (:func:`plan`);
  :func:`diagnose_many` diagnoses every curve of files, folders and force maps in parallel.
- ``skin_indent.report``: every figure, table and page the package writes.
- ``skin_indent.runtime``: context, executors, threads, atomic writes, JSON, provenance.
- ``skin_indent.cli``: the ``skin-indent`` command.
"""

__version__ = "0.1.0"

import logging as _logging

# a library logs, the program decides what is shown (skin_indent.runtime.log; the CLI's -v/-q)
_logging.getLogger(__name__).addHandler(_logging.NullHandler())
del _logging

# The main nouns, importable from the top level; loaded on first use so that
# ``import skin_indent`` (and the CLI's start) stays fast. No submodule shares a
# name with these (a submodule, once imported, would shadow a lazy name).
_EXPORTS = {
    "load_csv": "skin_indent.measurement",
    "load_curve": "skin_indent.measurement",
    "load_curves": "skin_indent.measurement",
    "prepare": "skin_indent.measurement",
    "Measurement": "skin_indent.measurement",
    "PreparedCurve": "skin_indent.measurement",
    "bundled_path": "skin_indent.data",
    "simulate": "skin_indent.simulate",
    "ForceDepthCurve": "skin_indent.simulate",
    "NeoHooke": "skin_indent.mechanics.materials",
    "LinearElastic": "skin_indent.mechanics.materials",
    "NeoHookeStiffening": "skin_indent.mechanics.materials",
    "ViscoelasticMaterial": "skin_indent.mechanics.materials",
    "PronyTerm": "skin_indent.mechanics.materials",
    "SphericalIndenter": "skin_indent.mechanics.contact_law",
    "ContactLaw": "skin_indent.mechanics.contact_law",
    "MaterialLayer": "skin_indent.mechanics.layers",
    "LayeredSample": "skin_indent.mechanics.layers",
    "RIGID": "skin_indent.mechanics.layers",
    "Protocol": "skin_indent.mechanics.protocol",
    "Model": "skin_indent.effects",
    "Effect": "skin_indent.effects",
    "EFFECTS": "skin_indent.effects",
    "register_effect": "skin_indent.effects",
    "ResponseSurface": "skin_indent.response_surface",
    "SurfaceGrid": "skin_indent.response_surface",
    "Context": "skin_indent.runtime.context",
    "fit": "skin_indent.fitting",
    "identify": "skin_indent.fitting",
    "surface_for": "skin_indent.fitting",
    "CurveFit": "skin_indent.fitting",
    "FitResult": "skin_indent.fitting",
    "diagnose": "skin_indent.diagnosis",
    "diagnose_many": "skin_indent.diagnosis",
    "Diagnosis": "skin_indent.diagnosis",
    "plan": "skin_indent.diagnosis",
    "Plan": "skin_indent.diagnosis",
    "write_report": "skin_indent.report",
    "write_plan": "skin_indent.report",
}
# top-level name -> the name in its module (the mechanics' ``Layer`` and ``Viscoelastic`` are a
# layer of a sample and a material law; at the top level ``layer`` and ``viscoelastic`` are effects)
_RENAMED = {"register_effect": "register", "MaterialLayer": "Layer", "ViscoelasticMaterial": "Viscoelastic"}
__all__ = ["__version__", *_EXPORTS]
#: the subpackages, listed by ``dir(skin_indent)`` with the names above
_SUBPACKAGES = ("measurement", "mechanics", "effects", "response_surface", "models", "inverse", "fitting",
                "diagnosis", "report", "runtime", "cli")


def __dir__():
    """The top-level names and the subpackages: what completion (IPython, Jupyter) offers after ``si.``."""
    return sorted({*globals(), *__all__, *_SUBPACKAGES})


def __getattr__(name):
    if name in _EXPORTS:
        import importlib

        value = getattr(importlib.import_module(_EXPORTS[name]), _RENAMED.get(name, name))
        globals()[name] = value
        return value
    raise AttributeError(f"module 'skin_indent' has no attribute {name!r}")


def _keep_functions_over_modules():
    """``si.simulate`` stays the function once the module ``skin_indent.simulate`` is imported.

    Importing a submodule sets it as an attribute of its package; the one submodule whose
    name is also a top-level function (``simulate``, the seam module) must not shadow it.
    ``import skin_indent.simulate`` and ``from skin_indent.simulate import ...`` work as usual.
    """
    import sys
    import types

    class _Package(types.ModuleType):
        def __setattr__(self, name, value):
            if name == "simulate" and isinstance(value, types.ModuleType):
                return  # reachable as sys.modules["skin_indent.simulate"]
            super().__setattr__(name, value)

    sys.modules[__name__].__class__ = _Package


_keep_functions_over_modules()
