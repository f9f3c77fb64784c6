"""Reads the exports of `scalpelsim replay --export` with two independent readers, meshio and gmsh,
and checks what a mesh tool would: the tetrahedra and triangles all there, the surface closed and
consistently oriented (OBJ, PLY: every directed edge once and its reverse once), and the volume it
encloses equal to the mesh's.

usage: check_exports.py OUT_DIR GMSH
"""
import json
import os
import subprocess
import sys
import tempfile

import meshio
import numpy as np


def fail(message):
    sys.exit("check_exports: " + message)


def triangles(mesh):
    return np.concatenate([c.data for c in mesh.cells if c.type == "triangle"])


def enclosed_volume(points, tri):
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def gmsh_elements(gmsh, path):
    """The element count gmsh writes back after reading `path`."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "back.msh")
        subprocess.run([gmsh, path, "-0", "-format", "msh22", "-o", out, "-v", "1"], check=True)
        lines = open(out).read().split("\n")
        return int(lines[lines.index("$Elements") + 1])


def main():
    out, gmsh = sys.argv[1], sys.argv[2]
    report = json.load(open(os.path.join(out, "report.json")))
    final = report["mesh"]["final"]
    volume = final["rest_volume"]

    tet = meshio.read(os.path.join(out, "mesh.msh"))
    tets = sum(len(c.data) for c in tet.cells if c.type == "tetra")
    if tets != final["tetrahedra"]:
        fail("mesh.msh: meshio read %d tetrahedra, the report says %d" % (tets, final["tetrahedra"]))
    if gmsh_elements(gmsh, os.path.join(out, "mesh.msh")) != tets:
        fail("mesh.msh: gmsh read another number of elements")

    for name in ("surface.obj", "surface.ply"):
        s = meshio.read(os.path.join(out, name))
        tri = triangles(s)
        if len(tri) != final["boundary_faces"]:
            fail("%s: %d triangles, the mesh has %d boundary faces" % (name, len(tri), final["boundary_faces"]))
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        directed = set(map(tuple, edges))
        if len(directed) != len(edges):
            fail("%s: a directed edge appears twice (inconsistent orientation)" % name)
        if any((b, a) not in directed for a, b in directed):
            fail("%s: not closed (an edge with one triangle)" % name)
        v = enclosed_volume(s.points, tri)
        if abs(v - volume) > 1e-9 * volume:
            fail("%s: encloses %.12g m^3, the mesh holds %.12g" % (name, v, volume))

    stl = meshio.read(os.path.join(out, "surface.stl"))
    tri = triangles(stl)
    if len(tri) != final["boundary_faces"]:
        fail("surface.stl: %d triangles, expected %d" % (len(tri), final["boundary_faces"]))
    v = enclosed_volume(stl.points.astype(float), tri)
    if abs(v - volume) > 1e-6 * volume:  # corners stored as floats
        fail("surface.stl: encloses %.12g m^3, the mesh holds %.12g" % (v, volume))
    if gmsh_elements(gmsh, os.path.join(out, "surface.stl")) != len(tri):
        fail("surface.stl: gmsh read another number of triangles")
    print("check_exports: %d tetrahedra, %d boundary triangles, closed, %.9g m^3" % (tets, len(tri), volume))


main()
