"""One finite-element run of the model in the loop (:class:`~skin_indent.models.fe_core.FECore`).

A run indents a sample of unit top modulus (E = 1 kPa) to a depth ceiling: the depths it
solves (:func:`solved_depths`), the run itself, a worker task (:func:`solve_unit`), its
arrays as the run cache keeps them (:func:`as_arrays`, :func:`from_arrays`), the
material parameters its sensitivities are taken in (:func:`material_parameters`), and
the mesh of a layered sample moved to new interface depths (:func:`morph`,
:func:`geometry`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["FIRST", "INCREMENTS", "as_arrays", "from_arrays", "geometry", "material_parameters", "morph",
           "solve_unit", "solved_depths"]

#: solved depths of a run (geometric, to the ceiling): on two layers over a half-space the
#: spline between them is within 1.4e-3 of direct solves at 0.05 mm and 5e-4 beyond 0.1 mm
#: (12, the default of simulate for a half-space, gives 2.8e-3 there; 30 gives 1.1e-3 at 1.3x the cost)
INCREMENTS = 20
#: the first solved depth of a run, as a fraction of its ceiling
FIRST = 0.01


def solved_depths(sample, ceiling_mm: float, increments: int = INCREMENTS, first: float = FIRST) -> np.ndarray:
    """The depths (mm) a unit run solves: ``increments`` geometric depths from ``first`` times the
    ceiling to the ceiling, and a layered sample's depths near a rigid base
    (:meth:`~skin_indent.mechanics.layers.LayeredSample.squeeze_depths_mm`)."""
    depths = np.geomspace(first * ceiling_mm, ceiling_mm, increments)
    squeeze = getattr(sample, "squeeze_depths_mm", None)  # a layer squeezed on a rigid base: depths near it
    if squeeze is not None:
        depths = np.union1d(depths, squeeze(ceiling_mm))
    return depths


def solve_unit(sample, radius_mm: float, ceiling_mm: float, imesh, rtol: float, sensitivities: bool,
               increments: int = INCREMENTS, first: float = FIRST, initial=None):
    """One unit-modulus run to the ceiling (a worker task) at the depths of :func:`solved_depths`,
    warm-started from the fields ``initial`` (one per depth, or None) where given.

    Returns the solved depths (mm), the forces there (mN), with ``sensitivities`` their
    derivatives with respect to every material parameter (direct differentiation,
    :mod:`skin_indent.mechanics.sensitivity`, else None), and the converged displacement
    field at every solved depth (the warm start of a run nearby).
    """
    from ..mechanics.contact_law import SphericalIndenter
    from ..simulate import simulate

    depths = solved_depths(sample, ceiling_mm, increments, first)
    curve = simulate(sample, SphericalIndenter(radius_mm), depths, mesh=imesh, rtol=rtol, solve_at_outputs=True,
                     sensitivities=sensitivities, initial_fields=initial, keep_fields=True)
    return curve.solved_depth_mm, curve.solved_force_mN, curve.sensitivities, curve.solved_fields


def as_arrays(run) -> dict:
    """A unit run ``(depths, forces, sensitivities or None)`` as the named arrays the run cache keeps."""
    h, F, S = run
    out = {"depth_mm": np.asarray(h, dtype=float), "force_mN": np.asarray(F, dtype=float)}
    for (k, name), values in (S or {}).items():
        out[f"sensitivity/{int(k)}/{name}"] = np.asarray(values, dtype=float)
    return out


def from_arrays(arrays: dict, sensitivities: bool) -> tuple:
    """The unit run of :func:`as_arrays`' arrays (the sensitivities None unless they were asked for)."""
    S = {}
    for name, values in arrays.items():
        if name.startswith("sensitivity/"):
            _, k, law_parameter = name.split("/", 2)
            S[(int(k), law_parameter)] = values
    return arrays["depth_mm"], arrays["force_mN"], S if sensitivities else None


def material_parameters(sample) -> dict:
    """``{(k, name): value}`` of every material parameter of a sample (k as in ``sample.materials``)."""
    from ..mechanics.layers import LayeredSample

    laws = sample.materials if isinstance(sample, LayeredSample) else [sample]
    return {(k, name): float(getattr(law, name)) for k, law in enumerate(laws) for name in law.sensitivity_parameters}


def morph(imesh, reference_mm, interfaces_mm, rigid_base: bool):
    """``imesh`` (built for interfaces at depths ``reference_mm``) with its interfaces moved to ``interfaces_mm``.

    Depths are mapped piecewise linearly between interfaces; below the last interface
    of a half-space the shift decays linearly to zero at the bottom of the domain; with a
    rigid base the last interface is the bottom of the mesh.

    Parameters
    ----------
    imesh : IndentationMesh
    reference_mm, interfaces_mm : sequence of float
        Interface depths (mm, increasing) the mesh was built for and the new ones.
    rigid_base : bool
    """
    from ..mechanics.mesh import IndentationMesh, with_named_boundaries

    ref = np.r_[0.0, np.asarray(reference_mm, dtype=float)]
    new = np.r_[0.0, np.asarray(interfaces_mm, dtype=float)]
    p = imesh.mesh.p.copy()
    d = -p[1]
    bottom = float(d.max())
    inside = d <= ref[-1]
    mapped = np.interp(d, ref, new)
    if not rigid_base:
        shift = (new[-1] - ref[-1]) * np.clip((bottom - d) / (bottom - ref[-1]), 0.0, 1.0)
        mapped = np.where(inside, mapped, d + shift)
    p[1] = -mapped
    mesh = type(imesh.mesh)(p, imesh.mesh.t)
    lz = float(new[-1]) if rigid_base else bottom
    return IndentationMesh(with_named_boundaries(mesh, imesh.extent_mm, lz), imesh.name + " (morphed)",
                           imesh.contact_radius_mm, imesh.surface_size_mm, imesh.extent_mm)


def geometry(sample) -> tuple:
    """What of a sample moves the mesh: the interface depths and whether the base is rigid."""
    from ..mechanics.layers import LayeredSample

    if not isinstance(sample, LayeredSample):
        return ()
    return (tuple(float(v) for v in sample.interfaces_mm), sample.rigid_base)
