"""Graded axisymmetric meshes of a half-space under a spherical indenter.

The half-space ``r >= 0, z <= 0`` (mm; z points up, the free surface is ``z = 0``)
is truncated to the square ``[0, L] x [-L, 0]`` with ``L`` two thousand contact
radii (~3900 mm for the paper's test), so the far boundary is almost free. The
element size is small on the surface under the contact and grows linearly with
the distance from it, which makes the mesh geometric: few elements reach the far
boundary. The mesh is built with scikit-fem alone: start from two triangles and
refine adaptively (red-green-blue, longest-edge bisection) until every element is
below the target size. The quadratic (P2) elements then live on this mesh.

Every length is scaled by the largest contact radius ``a = sqrt(R h_max)``, so the
same mesh design serves any sphere radius and depth range.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import sparse
from skfem import MeshTri


@dataclass(frozen=True)
class MeshDesign:
    """Dimensionless design of a graded indentation mesh.

    Parameters
    ----------
    name : str
        Name of the design (e.g. ``"medium"``).
    contact_elements : float
        Number of surface elements across the largest contact radius ``a``.
    growth : float
        Element size grows as ``s0 + growth * d`` with the distance ``d`` from the
        fine surface patch (a geometric growth ratio of about ``1 + growth``).
    patch : float
        Radius of the fine surface patch, in units of ``a``.
    extent : float
        Size ``L`` of the truncated domain, in units of ``a``.
    depth_growth : float
        Depth is weighted by this factor in the distance ``d``, so elements grow
        faster downwards than along the surface: the contact edge needs fine
        surface elements, the smooth field below it does not.
    """

    name: str
    contact_elements: float
    growth: float = 1.0
    patch: float = 1.3
    extent: float = 2000.0
    depth_growth: float = 1.0


#: The default family, from coarse to fine (see ``meshes/README.md``).
MESH_FAMILY = {
    "coarse": MeshDesign("coarse", contact_elements=6.0),
    "medium": MeshDesign("medium", contact_elements=12.0),
    "fine": MeshDesign("fine", contact_elements=24.0),
}
DEFAULT_MESH = "medium"
#: Element size along material interfaces under the contact, in surface sizes s0 (the
#: interfaces are conforming, see :func:`conform_to_interfaces`; measured on the
#: independent code's layered curves: 1 -> 3 halves the vertices of a layered mesh at an
#: unchanged error, while a non-conforming mesh needed 1 to stay within 5e-3).
INTERFACE_SIZE = 3.0
#: A vertex is moved onto an interface only if every triangle around it keeps at least this
#: fraction of its area.
CONFORM_MIN_AREA = 0.25


@dataclass(frozen=True)
class IndentationMesh:
    """A P1 triangle mesh (vertices) of the truncated half-space, with its design.

    Attributes
    ----------
    mesh : skfem.MeshTri
        Vertices and triangles, lengths in mm, with named boundaries
        ``axis``, ``top``, ``bottom``, ``outer``.
    name : str
        Human-readable name saying how the mesh was obtained.
    contact_radius_mm : float
        The design contact radius ``a = sqrt(R h_max)`` in mm.
    surface_size_mm : float
        Element size on the fine surface patch, mm.
    extent_mm : float
        Size L of the domain, mm.
    """

    mesh: MeshTri
    name: str
    contact_radius_mm: float
    surface_size_mm: float
    extent_mm: float

    @property
    def n_vertices(self) -> int:
        return self.mesh.p.shape[1]

    @property
    def n_elements(self) -> int:
        return self.mesh.t.shape[1]


def _distance_to_patch(x: np.ndarray, patch_mm: float, depth_weight: float = 1.0) -> np.ndarray:
    """Distance of points ``x`` (2, n) to the surface segment ``0 <= r <= patch, z = 0``.

    The depth coordinate is weighted by ``depth_weight``.
    """
    dr = np.maximum(x[0] - patch_mm, 0.0)
    return np.hypot(dr, depth_weight * x[1])


def _longest_edge(mesh: MeshTri) -> np.ndarray:
    p, t = mesh.p, mesh.t
    edges = [np.linalg.norm(p[:, t[i]] - p[:, t[(i + 1) % 3]], axis=0) for i in range(3)]
    return np.max(edges, axis=0)


def graded_mesh(radius_mm: float, depth_mm: float, design: MeshDesign | str = DEFAULT_MESH, *,
                interfaces_mm=(), rigid_base_mm: float | None = None) -> IndentationMesh:
    """Build the graded mesh for a sphere of radius R pressed to depth h_max.

    Parameters
    ----------
    radius_mm : float
        Sphere radius R, mm.
    depth_mm : float
        Largest indentation depth h_max the mesh is designed for, mm.
    design : MeshDesign or str
        A design or the name of a member of :data:`MESH_FAMILY`.
    interfaces_mm : sequence of float
        Depths of material interfaces (layers), mm: under the contact (r up to
        the patch radius plus the interface depth) the elements along them are
        :data:`INTERFACE_SIZE` times the surface size, and the mesh is made
        conforming to them (:func:`conform_to_interfaces`).
    rigid_base_mm : float, optional
        Depth of a rigid base: the domain is then ``[0, Lr] x [-T, 0]`` with
        ``Lr = min(L, 10 a + 40 T)`` (the field of a layer on a rigid base decays
        within a few thicknesses of the contact).

    Returns
    -------
    IndentationMesh
    """
    if isinstance(design, str):
        if design not in MESH_FAMILY:
            raise ValueError(f"unknown mesh {design!r}: choose one of {sorted(MESH_FAMILY)} or a file path")
        design = MESH_FAMILY[design]
    if not (radius_mm > 0 and depth_mm > 0):
        raise ValueError(f"radius and depth must be > 0 mm, got R={radius_mm}, h={depth_mm}")
    a = math.sqrt(radius_mm * depth_mm)
    s0 = a / design.contact_elements
    patch = design.patch * a
    L = design.extent * a
    interfaces = np.asarray(interfaces_mm, dtype=float)
    if rigid_base_mm is None:
        Lr = Lz = L
        mesh = MeshTri.init_tensor(np.array([0.0, L]), np.array([-L, 0.0]))
    else:
        if not (math.isfinite(rigid_base_mm) and rigid_base_mm > 0):
            raise ValueError(f"rigid base depth must be > 0 mm, got {rigid_base_mm}")
        Lz, Lr = rigid_base_mm, min(L, 10 * a + 40 * rigid_base_mm)
        columns = max(1, int(math.ceil(Lr / Lz)))
        rows = max(1, int(math.ceil(Lz / Lr)))
        mesh = MeshTri.init_tensor(np.linspace(0.0, Lr, columns + 1), np.linspace(-Lz, 0.0, rows + 1))
    for _ in range(200):
        centroid = mesh.p[:, mesh.t].mean(axis=1)
        size = _longest_edge(mesh)
        d = np.maximum(_distance_to_patch(centroid, patch, design.depth_growth) - design.depth_growth * size, 0.0)
        target = s0 + design.growth * d
        for t in interfaces[interfaces < Lz]:  # interfaces under the contact: elements of ~INTERFACE_SIZE s0
            shifted = centroid + np.array([[0.0], [t]])
            d_t = np.maximum(_distance_to_patch(shifted, patch) - size, 0.0)
            target = np.minimum(target, INTERFACE_SIZE * s0 + design.growth * d_t)
        marked = np.nonzero(size > target)[0]
        if marked.size == 0:
            break
        mesh = mesh.refined(marked)
    mesh = conform_to_interfaces(mesh, interfaces[interfaces < Lz])
    mesh = with_named_boundaries(mesh, Lr, Lz)
    base = f", rigid base at {Lz:.4g} mm" if rigid_base_mm is not None else ""
    layers = f", {interfaces.size} interface(s)" if interfaces.size else ""
    name = (f"{design.name} (generated: P2 on {mesh.t.shape[1]} triangles, a={a:.4g} mm, s0={s0:.3g} mm, "
            f"L={Lr:.4g} mm{base}{layers})")
    return IndentationMesh(mesh, name, a, s0, Lr)


def conform_to_interfaces(mesh: MeshTri, interfaces_mm) -> MeshTri:
    """``mesh`` with vertices moved vertically onto the interfaces ``z = -t`` it crosses.

    For every edge that crosses an interface, one end moves onto the interface: the
    nearer one (relative to the edge length; the nearest ends of all edges first), else
    the other, unless a triangle around it would keep less than
    :data:`CONFORM_MIN_AREA` of its area or the vertex lies on the free surface, the
    bottom or another interface. Each triangle then lies in one
    material, so the kink of the displacement across a bonded interface falls on
    element edges (a triangle cut by an interface smears it: measured on the independent
    code's layered curves, coarse mesh, 2x the error at equal size). Triangles that
    still cross an interface (far from the contact, where a move would distort large
    triangles) keep the per-quadrature-point material of :class:`~.layers.LayeredSample`.

    Parameters
    ----------
    mesh : skfem.MeshTri
        Triangle mesh of the domain, mm (z <= 0).
    interfaces_mm : sequence of float
        Interface depths below the free surface, mm (> 0).

    Returns
    -------
    skfem.MeshTri
        A mesh of the same topology (boundaries to be named again).
    """
    interfaces = np.asarray(interfaces_mm, dtype=float)
    if interfaces.size == 0:
        return mesh
    p, t = mesh.p.copy(), mesh.t
    z_top, z_bottom = p[1].max(), p[1].min()
    pinned = np.isclose(p[1], z_top) | np.isclose(p[1], z_bottom)
    for depth in interfaces:  # vertices already on an interface stay there
        pinned |= np.isclose(p[1], -depth)

    def signed_areas(tri):
        x = p[:, t[:, tri]]
        return 0.5 * ((x[0, 1] - x[0, 0]) * (x[1, 2] - x[1, 0]) - (x[0, 2] - x[0, 0]) * (x[1, 1] - x[1, 0]))

    area0 = signed_areas(np.arange(t.shape[1]))
    # the triangles around each vertex (CSR rows of the vertex-triangle incidence)
    incidence = sparse.csr_matrix((np.ones(t.size), (t.ravel(), np.tile(np.arange(t.shape[1]), 3))),
                                  shape=(p.shape[1], t.shape[1]))
    edges = mesh.facets
    for depth in interfaces:
        z = -depth
        crossing = edges[:, (p[1, edges[0]] - z) * (p[1, edges[1]] - z) < 0]
        if crossing.size == 0:
            continue
        # both ends of every crossing edge, nearer to the interface (relative to the edge) first
        gap = (np.abs(p[1, crossing] - z) / np.linalg.norm(p[:, crossing[0]] - p[:, crossing[1]], axis=0)).ravel()
        ends, edge = crossing.ravel(), np.tile(np.arange(crossing.shape[1]), 2)
        for k in np.argsort(gap, kind="stable"):
            v, (a, b) = ends[k], crossing[:, edge[k]]
            if pinned[v] or (p[1, a] - z) * (p[1, b] - z) >= 0:  # fixed, or the edge no longer crosses
                continue
            old = p[1, v]
            p[1, v] = z
            around = incidence.indices[incidence.indptr[v]:incidence.indptr[v + 1]]
            if np.all(signed_areas(around) / area0[around] >= CONFORM_MIN_AREA):
                pinned[v] = True
            else:
                p[1, v] = old
    return MeshTri(p, t)


def with_named_boundaries(mesh: MeshTri, L: float, Lz: float | None = None) -> MeshTri:
    Lz = L if Lz is None else Lz
    tol = 1e-9 * max(L, Lz)
    return mesh.with_boundaries(
        {
            "axis": lambda x: x[0] < tol,
            "top": lambda x: x[1] > -tol,
            "bottom": lambda x: x[1] < -Lz + tol,
            "outer": lambda x: x[0] > L - tol,
        }
    )


def save_mesh(imesh: IndentationMesh, path: str | Path) -> None:
    """Write the mesh with meshio (format from the suffix, e.g. ``.vtu``) and a JSON sidecar."""
    import meshio

    path = Path(path)
    m = imesh.mesh
    points = np.column_stack([m.p.T, np.zeros(m.p.shape[1])])  # VTU wants 3-D points
    meshio.Mesh(points, [("triangle", m.t.T)]).write(path)
    meta = {
        "name": imesh.name,
        "contact_radius_mm": imesh.contact_radius_mm,
        "surface_size_mm": imesh.surface_size_mm,
        "extent_mm": imesh.extent_mm,
    }
    path.with_suffix(".json").write_text(json.dumps(meta, indent=2) + "\n")


def load_mesh(path: str | Path) -> IndentationMesh:
    """Read a mesh written by :func:`save_mesh` (or any meshio triangle mesh of the domain).

    The domain must be ``[0, L] x [-L, 0]`` in mm, with the free surface at z = 0.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"mesh file not found: {path}")
    mio = meshio.read(path)
    tri = [c.data for c in mio.cells if c.type == "triangle"]
    if not tri:
        raise ValueError(f"mesh file {path} holds no triangle cells")
    p = np.asarray(mio.points[:, :2], dtype=float).T
    mesh = MeshTri(np.ascontiguousarray(p), np.ascontiguousarray(np.vstack(tri).T))
    L, Lz = float(p[0].max()), float(-p[1].min())
    if abs(p[1].max()) > 1e-9 * L or p[0].min() < -1e-9 * L:
        raise ValueError(f"mesh {path} must span r >= 0, z <= 0 with its free surface at z = 0")
    sidecar = path.with_suffix(".json")
    meta = json.loads(sidecar.read_text()) if sidecar.is_file() else {}
    top = np.abs(p[1]) <= 1e-9 * L
    r_top = np.sort(p[0, top])
    s0 = meta.get("surface_size_mm", float(np.diff(r_top[:2])[0]) if r_top.size > 1 else L)
    return IndentationMesh(
        with_named_boundaries(mesh, L, Lz),
        f"{path.name} (read from file)",
        meta.get("contact_radius_mm", float("nan")),
        s0,
        L,
    )


def refined_uniformly(imesh: IndentationMesh, levels: int = 1) -> IndentationMesh:
    """``imesh`` with every triangle split in four ``levels`` times (scikit-fem's ``refined``).

    The refined mesh keeps the named boundaries (axis, top, bottom, outer); the far
    field is refined too, so it is a mesh-convergence check, not a design.
    """
    mesh = imesh.mesh.refined(int(levels))
    lz = -float(mesh.p[1].min())
    return IndentationMesh(with_named_boundaries(mesh, imesh.extent_mm, lz),
                           f"{imesh.name.split(' (')[0]}, refined uniformly {int(levels)}x",
                           imesh.contact_radius_mm, imesh.surface_size_mm / 2**int(levels), imesh.extent_mm)
