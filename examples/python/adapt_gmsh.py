#!/usr/bin/python3
"""Adapt a Gmsh mesh, read by meshio, to the Hessian metric of a function.

    python3 adapt_gmsh.py [IN.msh [OUT.vtu]]     (default: plate.msh, adapted.vtu)

plate.msh is bench/plate.geo meshed by gmsh (tests/data/plate2d.mesh) in
Gmsh's MSH 4.1 format; any 2D triangle or 3D tetrahedron mesh meshio reads
will do.
"""
import os, sys
import meshio, numpy as np
import padapt

src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "plate.msh")
mesh = padapt.Mesh.from_meshio(meshio.read(src))
x, y = mesh.points[:, 0], mesh.points[:, 1]
u = np.tanh(40 * (y - 0.3 - 0.1 * np.sin(6 * x)))   # stands for your solver's solution
metric = padapt.metric.hessian(mesh, u, target=3000, hmin=1e-3, hmax=0.1)
new, fields, report = padapt.adapt(mesh, metric, fields={"u": u})
print(report.description, "--", new)
new.write(sys.argv[2] if len(sys.argv) > 2 else "adapted.vtu")   # or new.to_meshio()
