"""Field output of a solved indentation state, written with meshio.

The quadratic (P2) triangles are written as VTK quadratic triangles
(``triangle6``) in the deformed configuration, with the displacement and the
contact pressure as point data and the element-averaged Cauchy stress and von
Mises stress as cell data (kPa). Open the ``.vtu`` file in ParaView.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from skfem import Basis, ElementTriP2


def nodal_fields(problem, u: np.ndarray, depth_mm: float) -> dict:
    """Fields of a solved state on the P2 nodes and the elements.

    Parameters
    ----------
    problem : IndentationProblem
    u : ndarray
        Displacement vector, mm.
    depth_mm : float
        Depth of the sphere, mm.

    Returns
    -------
    dict
        ``points`` (n, 2) reference coordinates, ``cells`` (nel, 6) P2 connectivity,
        ``displacement`` (n, 2) mm, ``contact_pressure`` (n,) kPa, and the cell
        fields ``cauchy_rr, cauchy_zz, cauchy_tt, cauchy_rz, von_mises`` (kPa).
    """
    mesh = problem.imesh.mesh
    vb = problem.solid.basis
    sb = Basis(mesh, ElementTriP2(), intorder=1)
    n_vertex = mesh.p.shape[1]
    # vector dofs of each component, in the scalar basis' node order (vertices, then edges)
    comp = [np.r_[vb.nodal_dofs[c], vb.facet_dofs[c]] for c in (0, 1)]
    disp = np.stack([u[comp[0]], u[comp[1]]], axis=1)
    points = sb.doflocs.T
    assert points.shape[0] == n_vertex + mesh.facets.shape[1]
    x = points + disp
    R = problem.indenter.radius_mm
    gap = np.hypot(x[:, 0], x[:, 1] - (R - depth_mm)) - R
    on_top = np.abs(points[:, 1]) <= 1e-12 * max(1.0, problem.imesh.extent_mm)
    pressure = np.where(on_top, problem.contact.penalty(depth_mm) * np.maximum(-gap, 0.0), 0.0)
    out = {
        "points": points,
        "cells": sb.element_dofs.T,
        "displacement": disp,
        "contact_pressure": pressure,
    }
    out.update(problem.solid.stress_fields(u))
    return out


def write_vtu(problem, u: np.ndarray, depth_mm: float, path: str | Path, deformed: bool = True) -> Path:
    """Write the mesh and fields of a solved state to ``path`` (``.vtu``) with meshio.

    Parameters
    ----------
    problem : IndentationProblem
    u : ndarray
        Displacement vector, mm.
    depth_mm : float
        Depth of the sphere, mm.
    path : str or Path
        Output file; the format follows the suffix (``.vtu`` recommended).
    deformed : bool
        Write the points in the deformed configuration (default) or the reference one.

    Returns
    -------
    Path
    """
    import meshio

    f = nodal_fields(problem, u, depth_mm)
    pts = f["points"] + (f["displacement"] if deformed else 0.0)
    pts3 = np.column_stack([pts, np.zeros(len(pts))])
    disp3 = np.column_stack([f["displacement"], np.zeros(len(pts))])
    cell_keys = ["cauchy_rr", "cauchy_zz", "cauchy_tt", "cauchy_rz", "von_mises"]
    mesh = meshio.Mesh(
        pts3,
        [("triangle6", f["cells"])],
        point_data={"displacement_mm": disp3, "contact_pressure_kPa": f["contact_pressure"]},
        cell_data={f"{k}_kPa": [f[k]] for k in cell_keys},
    )
    path = Path(path)
    mesh.write(path)
    return path
