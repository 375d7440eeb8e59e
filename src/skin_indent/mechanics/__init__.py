"""The finite-element forward model: mesh, materials, axisymmetric large-strain
solid, sphere contact, incremental Newton solver and field output.

Reading order: :mod:`.mesh` -> :mod:`.materials` -> :mod:`.weakform` (the maths in
scikit-fem forms) -> :mod:`.axisymmetric` (the same, fast) -> :mod:`.contact_law` (the sphere
and its interface law) -> :mod:`.contact` -> :mod:`.predictor` / :mod:`.linear` ->
:mod:`.solver` -> :mod:`.fields`.

Beside them: :mod:`.protocol`, the depth history of a test against time, and
:mod:`.analytic`, the closed-form solutions the forward model is checked against (Hertz,
Sneddon, Ting, Dimitriadis).
"""

# Exports are loaded on first use: the materials and the sphere need no scikit-fem, so a
# command that only describes them starts fast.
_EXPORTS = {
    "ContactLaw": ".contact_law", "SphereContact": ".contact", "SphericalIndenter": ".contact_law",
    "LinearElastic": ".materials", "Material": ".materials", "NeoHooke": ".materials",
    "NeoHookeStiffening": ".materials", "PronyTerm": ".materials", "Viscoelastic": ".materials",
    "DEFAULT_MESH": ".mesh", "MESH_FAMILY": ".mesh", "IndentationMesh": ".mesh", "MeshDesign": ".mesh",
    "graded_mesh": ".mesh", "load_mesh": ".mesh", "save_mesh": ".mesh",
    "ConvergenceError": ".convergence", "IndentationProblem": ".solver", "NewtonReport": ".convergence",
}
__all__ = list(_EXPORTS)


def __dir__():
    """The exports (loaded on first use) and what is loaded: what completion offers after ``mechanics.``."""
    return sorted({*globals(), *__all__})


def __getattr__(name):
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
