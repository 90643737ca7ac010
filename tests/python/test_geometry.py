#!/usr/bin/python3
"""test_geometry.py -- padapt.Geometry: a model as Python callables (a
quarter annulus in closed form) and Gmsh's (a STEP file made by the gmsh
command line, when both it and Gmsh's library are there), classified
meshes (read(model=True), set_vertex_entities, vertex_entities) and
adapt(..., geometry=): new boundary vertices on the model, the fallback
when a callable fails, and the bad inputs.

Runs in CTest's scratch directory with PYTHONPATH=python and PADAPT_LIB set.
"""
import math
import shutil
import subprocess
import unittest

import numpy as np

import padapt
from padapt import geometry as pgeo

R0, R1 = 0.5, 1.0


def to_box(x):
    r = math.hypot(x[0], x[1])
    return [(r - R0) / (R1 - R0), math.atan2(x[1], x[0]) / (math.pi / 2)]


def from_box(b):
    r, t = R0 + (R1 - R0) * b[0], b[1] * math.pi / 2
    return np.array([r * math.cos(t), r * math.sin(t), 0.0])


# the quarter annulus: curves 1 (u=0), 2 (u=1), 3 (v=0), 4 (v=1): the box's
# boundary references; points 1 (0,0) 2 (1,0) 3 (1,1) 4 (0,1)
CURVES = {1: (0, 0.0), 2: (0, 1.0), 3: (1, 0.0), 4: (1, 1.0)}
POINTS = {1: (0, 0), 2: (1, 0), 3: (1, 1), 4: (0, 1)}


def closest(dim, tag, x):
    if dim == 0:
        return from_box(POINTS[tag])
    axis, val = CURVES[tag]
    b = to_box(x)
    b[axis] = val
    return from_box(b)


def curvature(dim, tag, y):
    axis, val = CURVES[tag]
    return 1.0 / (R0 if val == 0 else R1) if axis == 0 else 0.0


def annulus(n=3):
    m = padapt.Mesh.generate_box(2, n)
    p = m.points
    dims = np.full(m.nvert, 2)
    tags = np.ones(m.nvert, dtype=np.int32)
    for v in range(m.nvert):
        u, w = p[v]
        on = [(0, u), (1, w)]
        fixed = [(a, c) for a, c in on if c in (0.0, 1.0)]
        if len(fixed) == 2:
            dims[v], tags[v] = 0, [k for k, c in POINTS.items() if c == (u, w)][0]
        elif len(fixed) == 1:
            dims[v], tags[v] = 1, [k for k, c in CURVES.items() if c == fixed[0]][0]
        p[v] = from_box((u, w))[:2]
    m.set_vertex_entities(dims, tags)
    return m


def off_model(m):
    dims, tags = m.vertex_entities
    worst = 0.0
    for v in np.nonzero(dims < 2)[0]:
        x = np.append(m.points[v], 0.0)
        worst = max(worst, np.linalg.norm(closest(dims[v], tags[v], x) - x))
    return worst


class PythonKernel(unittest.TestCase):
    def test_adapt_onto_model(self):
        m = annulus()
        self.assertTrue(m.classified)
        g = padapt.Geometry(closest, curvature, size=2.0)
        self.assertEqual(g.size, 2.0)
        np.testing.assert_allclose(g.closest(1, 2, [2.0, 0.1, 0]), closest(1, 2, [2.0, 0.1, 0]))
        new, _, rep = padapt.adapt(m, hsiz=0.04, geometry=g)
        self.assertTrue(new.classified)
        self.assertLess(off_model(new), 1e-12)
        self.assertGreater(rep["projections"], 0)
        self.assertEqual(rep["projections_failed"], 0)
        self.assertEqual(int((new.vertex_entities[0] == 0).sum()), 4)
        self.assertLess(g.check(new)["dist_max"], 1e-12)
        # without the model the new boundary vertices stay on the facets
        plain, _, _ = padapt.adapt(m, hsiz=0.04)
        self.assertGreater(off_model(plain), 1e-3)

    def test_failing_callable(self):
        def failing(dim, tag, x):
            if dim == 1 and tag == 2:
                raise RuntimeError("no projection on the outer arc")
            return closest(dim, tag, x)
        g = padapt.Geometry(failing, size=2.0)
        new, _, rep = padapt.adapt(annulus(), hsiz=0.05, geometry=g)
        self.assertGreater(rep["projections_failed"], 0)
        dims, tags = new.vertex_entities
        r = np.hypot(new.points[:, 0], new.points[:, 1])
        self.assertLess(np.abs(r[(dims == 1) & (tags == 1)] - R0).max(), 1e-12)
        self.assertGreater(np.abs(r[(dims == 1) & (tags == 2)] - R1).max(), 1e-6)

    def test_bad_inputs(self):
        with self.assertRaises(TypeError):
            padapt.Geometry(None)
        with self.assertRaises(padapt.Error):
            padapt.Geometry(closest, size=0)
        m = padapt.Mesh.generate_box(2, 2)
        self.assertFalse(m.classified)
        self.assertIsNone(m.vertex_entities)
        g = padapt.Geometry(closest, size=2.0)
        with self.assertRaises(padapt.Error):
            padapt.adapt(m, hsiz=0.3, geometry=g)  # not classified
        with self.assertRaises(TypeError):
            padapt.adapt(m, hsiz=0.3, geometry="model.step")
        with self.assertRaises(padapt.Error):
            m.set_vertex_entities(np.full(m.nvert, 5), np.ones(m.nvert))
        with self.assertRaises(FileNotFoundError):
            padapt.Geometry.read("no-such-model.step")
        with self.assertRaises(padapt.Error) as e:
            g.check(m)
        self.assertIn("classified", str(e.exception))


@unittest.skipUnless(pgeo.available()[0] and shutil.which("gmsh"),
                     "needs Gmsh's library and the gmsh command line")
class GmshModel(unittest.TestCase):
    def test_step(self):
        with open("disk.geo", "w") as f:
            f.write('SetFactory("OpenCASCADE");\nDisk(1) = {0, 0, 0, 1};\n')
        subprocess.run(["gmsh", "-0", "disk.geo", "-o", "disk.step"], check=True,
                       capture_output=True)
        subprocess.run(["gmsh", "-2", "disk.step", "-clmax", "0.5", "-o", "disk.msh"],
                       check=True, capture_output=True)
        subprocess.run(["gmsh", "-2", "disk.step", "-clmax", "0.5", "-format", "msh22",
                        "-o", "disk22.msh"], check=True, capture_output=True)
        m = padapt.read("disk.msh", model=True)
        self.assertTrue(m.classified)
        g = padapt.Geometry.read("disk.step")
        self.assertAlmostEqual(g.size, 2 * math.sqrt(2), places=5)
        self.assertLess(g.check(m)["dist_max"], 1e-9)
        new, _, rep = padapt.adapt(m, hsiz=0.05, geometry=g)
        r = np.hypot(new.points[:, 0], new.points[:, 1])
        dims = new.vertex_entities[0]
        self.assertLess(np.abs(r[dims < 2] - 1).max(), 1e-9)
        self.assertLess(abs(new.volume() - math.pi), 4 * math.pi * 0.05 ** 2 / 6)
        new.write("out.msh")
        back = padapt.read("out.msh", model=True)
        np.testing.assert_array_equal(back.vertex_entities[0], new.vertex_entities[0])
        with self.assertRaises(padapt.Error) as e:
            padapt.read("disk22.msh", model=True)
        self.assertIn("MSH 2.2", str(e.exception))
        with self.assertRaises(padapt.Error):  # one Gmsh model at a time
            padapt.Geometry.read("disk.step")
        g.close()
        padapt.Geometry.read("disk.step").close()


if __name__ == "__main__":
    unittest.main()
