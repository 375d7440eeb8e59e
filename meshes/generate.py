"""Regenerate the default mesh family for the paper's test (R = 6.22 mm, h_max = 0.6 mm).

Usage::

    python meshes/generate.py            # writes meshes/{coarse,medium,fine}.vtu (+ .json)

The files are exactly what :func:`skin_indent.mechanics.graded_mesh` builds (a test
checks it), so ``simulate(..., mesh="meshes/medium.vtu")`` and
``simulate(..., mesh="medium")`` give the same curve. Other radii and depths get
their own meshes built on the fly from the same dimensionless design.
"""

from pathlib import Path

from skin_indent.mechanics.mesh import MESH_FAMILY, graded_mesh, save_mesh

RADIUS_MM = 6.22
DEPTH_MM = 0.6


def main(folder: Path = Path(__file__).parent) -> None:
    for name in MESH_FAMILY:
        imesh = graded_mesh(RADIUS_MM, DEPTH_MM, name)
        path = folder / f"{name}.vtu"
        save_mesh(imesh, path)
        p2_nodes = imesh.n_vertices + imesh.mesh.facets.shape[1]
        print(f"{path}: {imesh.n_elements} triangles, {imesh.n_vertices} vertices, {p2_nodes} P2 nodes")


if __name__ == "__main__":
    main()
