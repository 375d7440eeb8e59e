"""The finite-element forward model: mesh, materials, axisymmetric large-strain
solid, sphere contact, incremental Newton solver and field output.

Reading order: :mod:`.mesh` -> :mod:`.materials` -> :mod:`.weakform` (the maths in
scikit-fem forms) -> :mod:`.axisymmetric` (the same, fast) -> :mod:`.contact` ->
:mod:`.predictor` / :mod:`.linear` -> :mod:`.solver` -> :mod:`.fields`.
"""

from .contact import ContactLaw, SphereContact, SphericalIndenter
from .materials import LinearElastic, Material, NeoHooke, NeoHookeStiffening, PronyTerm, Viscoelastic
from .mesh import DEFAULT_MESH, MESH_FAMILY, IndentationMesh, MeshDesign, graded_mesh, load_mesh, save_mesh
from .solver import ConvergenceError, IndentationProblem, NewtonReport

__all__ = [
    "ContactLaw", "SphereContact", "SphericalIndenter", "LinearElastic", "Material", "NeoHooke", "NeoHookeStiffening",
    "PronyTerm", "Viscoelastic", "DEFAULT_MESH",
    "MESH_FAMILY", "IndentationMesh", "MeshDesign", "graded_mesh", "load_mesh", "save_mesh",
    "ConvergenceError", "IndentationProblem", "NewtonReport",
]
