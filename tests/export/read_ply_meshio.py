"""Reads abrad's PLY exports with meshio (Debian's python3-meshio) against abrad's counts.

    python3 read_ply_meshio.py VERTICES TRIANGLES BINARY_VERTEX_IDS.ply ASCII_CONTRACT.ply

BINARY_VERTEX_IDS.ply is `abrad export --surface-ids vertex` (binary, surface ids on the
vertices: meshio 5's binary reader takes a face element's properties one after the other for
all faces, so it cannot read the contract's `surface` face property), ASCII_CONTRACT.ply the
contract as ASCII (`--ascii`). Both must hold VERTICES points and TRIANGLES triangles, the
same positions, triangles and per-vertex values, and the face `surface` of the ASCII file
must be the vertex `surface` of the binary one at every corner.
Exit status: 0 every check passed, 1 a check failed, 2 usage.
"""

import sys
import warnings

import meshio
import numpy as np


def fail(message):
    print(f"read_ply_meshio: {message}", file=sys.stderr)
    sys.exit(1)


def triangles(mesh, path):
    blocks = [c for c in mesh.cells if len(c.data)]
    if [c.type for c in blocks] != ["triangle"]:
        fail(f"{path}: cells {[c.type for c in mesh.cells]}, expected one block of triangles")
    return np.asarray(blocks[0].data)


def main(argv):
    if len(argv) != 5:
        print(__doc__, file=sys.stderr)
        return 2
    n_vertices, n_triangles, binary_path, ascii_path = int(argv[1]), int(argv[2]), argv[3], argv[4]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy deprecations inside meshio
        binary = meshio.read(binary_path)
        text = meshio.read(ascii_path)
    for mesh, path in ((binary, binary_path), (text, ascii_path)):
        if mesh.points.shape != (n_vertices, 3):
            fail(f"{path}: {mesh.points.shape[0]} points, abrad wrote {n_vertices}")
        tris = triangles(mesh, path)
        if tris.shape != (n_triangles, 3):
            fail(f"{path}: {tris.shape[0]} triangles, abrad wrote {n_triangles}")
        if tris.min() < 0 or tris.max() >= n_vertices:
            fail(f"{path}: a vertex index out of range")
        for name in ("irradiance_r", "irradiance_g", "irradiance_b", "radiosity_r", "red"):
            if name not in mesh.point_data:
                fail(f"{path}: no vertex property {name}")
    if not np.array_equal(binary.points, text.points):
        fail("the binary and ASCII files' positions differ")
    if not np.array_equal(triangles(binary, binary_path), triangles(text, ascii_path)):
        fail("the binary and ASCII files' triangles differ")
    for name in ("irradiance_r", "irradiance_g", "irradiance_b", "radiosity_b"):
        if not np.array_equal(binary.point_data[name], text.point_data[name]):
            fail(f"the binary and ASCII files' {name} differ")
    # meshio 5's binary reader takes `uchar` for a signed byte (its table says "i1"): the
    # same bits, read back as unsigned
    for name in ("red", "green", "blue"):
        colour = np.asarray(binary.point_data[name]).astype(np.int64) % 256
        if not np.array_equal(colour, np.asarray(text.point_data[name]).astype(np.int64)):
            fail(f"the binary and ASCII files' {name} differ")
    vertex_surface = np.asarray(binary.point_data.get("surface"))
    face_surface = np.concatenate([np.asarray(s) for s in text.cell_data.get("surface", [])])
    if vertex_surface.shape != (n_vertices,) or face_surface.shape != (n_triangles,):
        fail("surface ids missing (vertex property of the binary file, face property of the ASCII)")
    corners = triangles(text, ascii_path)
    for k in range(3):
        if not np.array_equal(vertex_surface[corners[:, k]], face_surface):
            fail("a triangle's surface differs from its vertices'")
    print(f"meshio {meshio.__version__}: {n_vertices} vertices, {n_triangles} triangles, "
          f"{len(np.unique(face_surface))} surfaces, binary and ASCII agree")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
