#!/usr/bin/python3
"""test_mesh.py -- padapt.Mesh: numpy arrays in and out (views, no copy),
meshio round trips and files written by the C writers read back by meshio,
physical names,
and the bad inputs that must raise ValueError (before any library call) or
padapt.Error (the library's message).

Runs in CTest's scratch directory with PYTHONPATH=python and PADAPT_LIB set.
"""
import os
import unittest

import meshio
import numpy as np

import padapt

DATA = os.environ.get("PADAPT_TESTDATA", os.path.join(os.path.dirname(__file__), "..", "data"))


def square(n=4):
    """The unit square as numpy arrays: (points, cells, boundary edges)."""
    m = padapt.Mesh.generate_box(2, n)
    return m.points.copy(), m.cells.copy(), m.boundary.copy(), m.boundary_refs.copy()


def cube(n=2):
    m = padapt.Mesh.generate_box(3, n)
    return m.points.copy(), m.cells.copy(), m.boundary.copy(), m.boundary_refs.copy()


def multiset(cells):
    return sorted(tuple(sorted(c)) for c in np.asarray(cells).tolist())


class NumpyRoundTrip(unittest.TestCase):
    def check_round_trip(self, pts, cells, bdry, brefs):
        n, ne = len(pts), len(cells)
        vref = np.arange(n) % 5
        cref = np.arange(ne) % 3 + 1
        req = np.zeros(ne, bool)
        req[::7] = True
        m = padapt.Mesh(pts, cells, bdry, point_refs=vref, cell_refs=cref,
                        boundary_refs=brefs, required_cells=req,
                        fields={"u": pts[:, 0], "v": pts[:, :2]})
        m.check()
        self.assertEqual((m.nvert, m.nelem, m.nbdry), (n, ne, len(bdry)))
        np.testing.assert_array_equal(m.points, pts)
        np.testing.assert_array_equal(m.cells, cells)
        np.testing.assert_array_equal(m.boundary, bdry)
        np.testing.assert_array_equal(m.point_refs, vref)
        np.testing.assert_array_equal(m.cell_refs, cref)
        np.testing.assert_array_equal(m.boundary_refs, brefs)
        np.testing.assert_array_equal(m.cell_flags & padapt.FLAG_REQUIRED != 0, req)
        np.testing.assert_array_equal(m.fields["u"], pts[:, 0])
        np.testing.assert_array_equal(m.fields["v"], pts[:, :2])
        self.assertAlmostEqual(m.volume(), 1.0, places=12)
        # views: the same memory twice, writes reach the library
        a, b = m.points, m.points
        self.assertTrue(np.shares_memory(a, b))
        self.assertFalse(m.cells.flags.writeable)
        a[0, 0] += 0.0  # writable
        m.point_refs[0] = 42
        self.assertEqual(m.stats()["vertices"], n)
        self.assertEqual(m.point_refs[0], 42)
        # views outlive the Mesh object
        pts_view = m.points
        del m, a, b
        np.testing.assert_array_equal(pts_view, pts)

    def test_2d(self):
        self.check_round_trip(*square())

    def test_3d(self):
        self.check_round_trip(*cube())

    def test_boundary_built_when_absent(self):
        pts, cells, bdry, _ = square(3)
        m = padapt.Mesh(pts, cells)
        self.assertEqual(multiset(m.boundary), multiset(bdry))
        m.check()

    def test_inputs_converted(self):
        pts, cells, bdry, _ = square(3)
        m = padapt.Mesh(pts.astype(np.float32).astype(np.float64).tolist(),
                        cells.astype(np.int64), bdry.astype(np.uint16))
        m.check()
        self.assertEqual(m.cells.dtype, np.int32)


class Meshio(unittest.TestCase):
    def check_meshio(self, m, ctype, btype):
        mm = m.to_meshio()
        self.assertEqual(multiset(mm.cells_dict[ctype]), multiset(m.cells))
        back = padapt.Mesh.from_meshio(mm)
        back.check()
        np.testing.assert_array_equal(back.points, m.points)
        np.testing.assert_array_equal(back.cells, m.cells)
        np.testing.assert_array_equal(back.boundary_refs, m.boundary_refs)
        for ext in (".mesh", ".msh", ".vtu"):
            path = "rt_%dd%s" % (m.dim, ext)
            m.write(path)
            r = meshio.read(path)
            self.assertEqual(len(r.points), m.nvert, path)
            np.testing.assert_allclose(r.points[:, :m.dim], m.points, atol=1e-12, err_msg=path)
            self.assertEqual(multiset(r.cells_dict[ctype]), multiset(m.cells), path)
            if ext != ".vtu":  # the .vtu holds the elements only
                self.assertEqual(multiset(r.cells_dict[btype]), multiset(m.boundary), path)
            back = padapt.read(path) if ext != ".vtu" else None
            if back is not None:
                self.assertEqual((back.nvert, back.nelem, back.nbdry), (m.nvert, m.nelem, m.nbdry))

    def test_2d(self):
        self.check_meshio(padapt.read(os.path.join(DATA, "plate2d.mesh")), "triangle", "line")

    def test_3d(self):
        self.check_meshio(padapt.read(os.path.join(DATA, "rod3d.mesh")), "tetra", "triangle")

    def test_meshio_gmsh_file(self):
        # a file written by meshio itself, read by padapt.read and by from_meshio
        m = padapt.Mesh.generate_box(2, 4)
        mm = m.to_meshio()
        mm.points = np.c_[mm.points, np.zeros(len(mm.points))]
        mm.cell_data = {"gmsh:physical": mm.cell_data["medit:ref"],
                        "gmsh:geometrical": mm.cell_data["medit:ref"]}
        mm.point_data = {}
        meshio.write("by_meshio.msh", mm, file_format="gmsh22", binary=False)
        a = padapt.read("by_meshio.msh")
        b = padapt.Mesh.from_meshio(meshio.read("by_meshio.msh"))
        for x in (a, b):
            self.assertEqual((x.dim, x.nvert, x.nelem, x.nbdry), (2, m.nvert, m.nelem, m.nbdry))
            np.testing.assert_array_equal(np.sort(x.boundary_refs), np.sort(m.boundary_refs))


    def test_physical_names(self):
        # names and views survive Mesh -> .msh -> padapt.read, and meshio's
        # field_data both ways
        m = padapt.Mesh.generate_box(2, 3)
        m.names = [(1, 2, "right"), (2, 0, "fluid"), (1, 1, "left side")]
        m.add_field("u", m.points[:, 0] + 2 * m.points[:, 1])
        m.write("named.msh", binary=True)
        r = padapt.read("named.msh")
        self.assertEqual(r.names, [(1, 1, "left side"), (1, 2, "right"), (2, 0, "fluid")])
        np.testing.assert_array_equal(r.fields["u"], m.fields["u"])
        mm = r.to_meshio()
        self.assertEqual({k: v.tolist() for k, v in mm.field_data.items()},
                         {"left side": [1, 1], "right": [2, 1], "fluid": [0, 2]})
        self.assertEqual(padapt.Mesh.from_meshio(mm).names, r.names)
        r.names = []
        self.assertEqual(r.names, [])
        with self.assertRaises(padapt.Error):
            r.names = [(1, 1, 'a "quoted" name')]

    def test_partial_boundary_completed(self):
        m = padapt.Mesh.generate_box(2, 4)
        mm = m.to_meshio()
        keep = m.boundary_refs == 1  # only the side x = 0 listed, as one physical group
        mm = meshio.Mesh(mm.points, [("triangle", m.cells.copy()), ("line", m.boundary[keep].copy())],
                         cell_data={"gmsh:physical": [m.cell_refs.copy(), m.boundary_refs[keep].copy()]})
        b = padapt.Mesh.from_meshio(mm)
        b.check()
        self.assertEqual(b.nbdry, m.nbdry)
        self.assertEqual(sorted(b.boundary_refs.tolist()), sorted([0] * int((~keep).sum()) + [1] * int(keep.sum())))


class BadInput(unittest.TestCase):
    """One case per check: each must raise before the library sees it."""

    def setUp(self):
        self.pts, self.cells, self.bdry, _ = square(2)

    def bad(self, msg, **kw):
        args = {"points": self.pts, "cells": self.cells, "boundary": self.bdry}
        args.update(kw)
        with self.assertRaises(ValueError) as cm:
            padapt.Mesh(args.pop("points"), args.pop("cells"), args.pop("boundary"), **args)
        self.assertIn(msg, str(cm.exception))

    def test_shapes(self):
        self.bad("points: expected shape", points=self.pts.ravel())
        self.bad("points: expected shape", points=np.zeros((4, 4)))
        self.bad("cells: expected shape (n, 3)", cells=self.cells[:, :2])
        self.bad("a 2D mesh takes (n, 2) points", points=np.c_[self.pts, np.zeros(len(self.pts))])
        self.bad("boundary: expected shape (n, 2)", boundary=self.bdry.T)
        self.bad("cell_refs: expected shape", cell_refs=np.zeros(3, int))
        self.bad("required_points: expected shape", required_points=np.zeros(2, bool))
        self.bad("expected sizes", metric=np.ones((len(self.pts), 2)))
        self.bad("field 'u'", fields={"u": np.ones(len(self.pts) + 1)})

    def test_dtypes(self):
        self.bad("cells: expected an integer array", cells=self.cells.astype(float))
        self.bad("points: expected real numbers", points=self.pts.astype(complex))
        self.bad("point_refs: expected an integer array", point_refs=np.zeros(len(self.pts)))
        self.bad("points: not an array", points=[[0, 1], [2]])

    def test_not_finite(self):
        p = self.pts.copy()
        p[3, 1] = np.nan
        self.bad("points: value at (3, 1) is not finite", points=p)
        self.bad("metric: value at (2,) is not finite",
                 metric=np.r_[1, 1, np.inf, np.ones(len(self.pts) - 3)])

    def test_indices(self):
        c = self.cells.copy()
        c[2, 1] = len(self.pts)
        self.bad("cells: row 2 has vertex index", cells=c)
        c[2, 1] = -1
        self.bad("outside [0, 9)", cells=c)
        b = self.bdry.copy()
        b[0, 0] = 99
        self.bad("boundary: row 0", boundary=b)
        self.bad("references must fit in 32 bits", point_refs=np.full(len(self.pts), 2 ** 40))

    def test_metric_values(self):
        self.bad("vertex 0: size is not positive", metric=np.r_[0.0, np.ones(len(self.pts) - 1)])
        t = np.tile([1.0, 0.0, 1.0], (len(self.pts), 1))
        t[4] = [1.0, 2.0, 1.0]  # indefinite
        self.bad("vertex 4: tensor is not positive definite", metric=t)

    def test_library_errors(self):
        # a valid array but an invalid mesh: the library's checker names it
        c = self.cells.copy()
        c[0, [1, 2]] = c[0, [2, 1]]
        m = padapt.Mesh(self.pts, c, self.bdry)
        with self.assertRaises(padapt.Error) as cm:
            m.check()
        self.assertEqual(cm.exception.status, "invalid mesh")
        self.assertIn("element 1", str(cm.exception))
        with self.assertRaises(padapt.Error) as cm:
            padapt.read(os.path.join(DATA, "bad", "gmsh_nan.msh"))
        self.assertIn("gmsh_nan.msh:", str(cm.exception))
        with self.assertRaises(FileNotFoundError):
            padapt.read("no/such/file.mesh")
        with self.assertRaises(padapt.Error) as cm:
            padapt.Mesh.generate_box(2, 2).write("no/such/dir/out.mesh")
        self.assertIn("out.mesh", str(cm.exception))


if __name__ == "__main__":
    unittest.main(verbosity=2)
