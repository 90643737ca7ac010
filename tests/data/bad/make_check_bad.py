#!/usr/bin/env python3
"""Write the folded and duplicated meshes of tests/data/bad (check_dup*,
check_fold*, check_overlap*): meshes every element of which is positive,
which pa_mesh_check must refuse, naming the entities (check.expected lists
the fragment of each message). Run from anywhere: python3 make_check_bad.py
(writes next to this script).
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, dim, verts, elems, here=HERE):
    """Write the Medit mesh name (in the folder here): verts coordinates,
    elems 0-based vertex tuples (reference 1). Also used by
    tests/cli/test_overlap_adapted.py."""
    kw = "Triangles" if dim == 2 else "Tetrahedra"
    with open(os.path.join(here, name), "w") as f:
        f.write("MeshVersionFormatted 2\nDimension %d\nVertices\n%d\n" % (dim, len(verts)))
        for x in verts:
            f.write(" ".join("%.17g" % c for c in x) + " 0\n")
        f.write("%s\n%d\n" % (kw, len(elems)))
        for e in elems:
            f.write(" ".join(str(v + 1) for v in e) + " 1\n")
        f.write("End\n")


def ring(n, turns, r=1.0, z=None):
    """n points at angles 2 pi turns k / n, radius r (z: a 3D height)."""
    pts = []
    for k in range(n):
        a = 2 * math.pi * turns * k / n
        p = [r * math.cos(a), r * math.sin(a)]
        pts.append(p if z is None else p + [z])
    return pts


def main():
    # One triangle, one tetrahedron, listed twice (the remesher crashed on the
    # tetrahedron, segfault in the 3D collapse pass).
    write("check_dup2d.mesh", 2, [[0, 0], [1, 0], [0, 1]], [(0, 1, 2), (0, 1, 2)])
    write("check_dup3d.mesh", 3, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
          [(0, 1, 2, 3), (1, 0, 3, 2)])

    # Two triangles on the same side of their common edge; two tetrahedra on the
    # same side of their common face.
    write("check_fold_edge2d.mesh", 2, [[0, 0], [1, 0], [0, 1], [0.6, 0.3]],
          [(0, 1, 2), (0, 1, 3)])
    write("check_fold_face3d.mesh", 3,
          [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.2, 0.2, 0.3]],
          [(0, 1, 2, 3), (0, 1, 2, 4)])

    # Seven triangles around an interior vertex turning twice around it.
    n = 7
    write("check_fold_vertex2d.mesh", 2, [[0, 0]] + ring(n, 2),
          [(0, 1 + k, 1 + (k + 1) % n) for k in range(n)])

    # Five triangles around a boundary vertex covering 400 degrees: the first and
    # the last overlap over 40 degrees.
    fan = [[0, 0]] + [[math.cos(math.radians(a)) * r, math.sin(math.radians(a)) * r]
                      for a, r in ((0, 1), (100, 1), (200, 1), (300, 1), (400, 0.5))]
    write("check_fold_boundary2d.mesh", 2, fan, [(0, k, k + 1) for k in range(1, 5)])

    # Seven tetrahedra around an interior edge turning twice around it.
    write("check_fold_edge3d.mesh", 3, [[0, 0, 0], [0, 0, 1]] + ring(n, 2, z=0.5),
          [(0, 1, 2 + k, 2 + (k + 1) % n) for k in range(n)])

    # Five tetrahedra around a boundary edge covering 400 degrees.
    pts = [[0, 0, 0], [0, 0, 1]] + [
        [math.cos(math.radians(a)) * r, math.sin(math.radians(a)) * r, 0.5]
        for a, r in ((0, 1), (100, 1), (200, 1), (300, 1), (400, 0.5))]
    write("check_fold_boundary3d.mesh", 3, pts, [(0, 1, k, k + 1) for k in range(2, 6)])


if __name__ == "__main__":
    main()
