#!/usr/bin/python3
"""test_levelset.py -- padapt.levelset.cut and padapt.adapt(..., levelset=)
judged with numpy: the sides of the cut against the level set, the faces
between them the interface entities, the inside area against the exact
one within the interpolation error; references, materials, rmc; the
report; the same cut as the command line's (-json); bad input.

Runs in CTest's scratch directory with PYTHONPATH=python, PADAPT_LIB and
PADAPT (the command-line tool) set.
"""
import json
import os
import subprocess
import unittest

import numpy as np

import padapt

PADAPT = os.environ.get("PADAPT")


def circle(x):
    return np.hypot(x[:, 0] - 0.51, x[:, 1] - 0.47) - 0.3


def sphere(x):
    return np.linalg.norm(x - [0.51, 0.47, 0.5], axis=1) - 0.3


def faces_between(mesh, a, b):
    """Sorted faces held by an element of reference a and one of b."""
    c, r = mesh.cells, mesh.cell_refs
    k = c.shape[1]
    f = np.sort(np.concatenate([np.delete(c, i, axis=1) for i in range(k)]), axis=1)
    owner = np.tile(np.arange(len(c)), k)
    o = np.lexsort(f.T[::-1])
    f, owner = f[o], owner[o]
    same = np.all(f[1:] == f[:-1], axis=1)
    ra, rb = r[owner[:-1][same]], r[owner[1:][same]]
    sel = ((ra == a) & (rb == b)) | ((ra == b) & (rb == a))
    return {tuple(t) for t in f[:-1][same][sel]}


def volumes(mesh):
    p = mesh.points[mesh.cells]
    d = p[:, 1:, :] - p[:, :1, :]
    return np.abs(np.linalg.det(d)) / (2 if mesh.dim == 2 else 6)


class TestLevelset(unittest.TestCase):
    def check_cut(self, mesh, phi, new, rep, rin=3, rout=2, riface=10):
        new.check()
        iface = {tuple(t) for t in np.sort(new.boundary[new.boundary_refs == riface], axis=1)}
        self.assertEqual(iface, faces_between(new, rin, rout))
        self.assertEqual(len(iface), rep["interface"])
        vin = volumes(new)[new.cell_refs == rin].sum()
        self.assertAlmostEqual(vin, rep["volume_in"], places=12)

    def test_cut_2d_3d(self):
        for dim, n, f, exact in ((2, 16, circle, np.pi * 0.09),
                                 (3, 6, sphere, 4 * np.pi * 0.027 / 3)):
            mesh = padapt.Mesh.generate_box(dim, n)
            phi = f(mesh.points)
            new, rep = padapt.levelset.cut(mesh, phi)
            self.assertEqual(mesh.nvert, (n + 1) ** dim)  # the input is not modified
            self.assertGreater(new.nvert, mesh.nvert)
            self.check_cut(mesh, phi, new, rep)
            # the volume within the interpolation error of the level set
            h = np.sqrt(dim) / n
            area = 2 * np.pi * 0.3 if dim == 2 else 4 * np.pi * 0.09
            self.assertLess(abs(rep["volume_in"] - exact), area * h * h / (8 * (0.3 - h)) * 2)
            # every interface vertex on the zero set: the added ones lie on
            # the linear zero of their edge
            iv = np.unique(new.boundary[new.boundary_refs == 10])
            self.assertTrue(np.all(new.point_refs[iv] == 10))

    def test_adapt(self):
        mesh = padapt.Mesh.generate_box(2, 12)
        phi = circle(mesh.points)
        new, fields, rep = padapt.adapt(mesh, hsiz=0.04, levelset=phi)
        self.assertIn("levelset", rep)
        self.assertGreater(rep["levelset"]["interface"], 0)
        iface = {tuple(t) for t in np.sort(new.boundary[new.boundary_refs == 10], axis=1)}
        self.assertEqual(iface, faces_between(new, 3, 2))
        self.assertTrue(rep.target_met)

    def test_options(self):
        mesh = padapt.Mesh.generate_box(2, 16)
        x = mesh.points
        refs = np.where(mesh.points[mesh.cells].mean(axis=1)[:, 0] < 0.5, 1, 4)
        m = padapt.Mesh(mesh.points, mesh.cells, mesh.boundary, cell_refs=refs,
                        boundary_refs=mesh.boundary_refs)
        phi = circle(x)
        new, rep = padapt.levelset.cut(m, phi, materials=[(1, 5, 6), (4, None)],
                                       ref_iface=20)
        self.assertEqual(set(np.unique(new.cell_refs)), {4, 5, 6})
        iface = {tuple(t) for t in np.sort(new.boundary[new.boundary_refs == 20], axis=1)}
        self.assertEqual(iface, faces_between(new, 5, 6))
        new, rep = padapt.levelset.cut(mesh, phi - 0.05, value=-0.05, ref_in=7, ref_out=8)
        self.assertEqual(set(np.unique(new.cell_refs)), {7, 8})
        with self.assertRaises(padapt.Error) as e:
            padapt.levelset.cut(m, phi, materials=[(1, 5, 6)])
        self.assertIn("reference 4", str(e.exception))
        with self.assertRaises(TypeError):
            padapt.levelset.cut(mesh, phi, bogus=1)
        with self.assertRaises(ValueError):
            padapt.levelset.cut(mesh, phi, materials=[(1, 2)])

    def test_rmc(self):
        mesh = padapt.Mesh.generate_box(2, 40)
        x = mesh.points
        phi = np.minimum(np.hypot(x[:, 0] - 0.4, x[:, 1] - 0.45) - 0.25,
                         np.hypot(x[:, 0] - 0.83, x[:, 1] - 0.82) - 0.04)
        _, keep = padapt.levelset.cut(mesh, phi)
        _, rm = padapt.levelset.cut(mesh, phi, rmc=1e-2)
        self.assertEqual((keep["removed_in"], rm["removed_in"]), (0, 1))
        self.assertGreater(keep["volume_in"] - rm["volume_in"], 0.5 * np.pi * 0.04 ** 2)

    def test_bad_values(self):
        mesh = padapt.Mesh.generate_box(2, 4)
        phi = circle(mesh.points)
        phi[3] = np.nan
        with self.assertRaises(ValueError) as e:
            padapt.levelset.cut(mesh, phi)
        self.assertIn("(3,)", str(e.exception))
        with self.assertRaises(ValueError):
            padapt.levelset.cut(mesh, phi[:5])
        new, rep = padapt.levelset.cut(mesh, 1 + mesh.points[:, 0])
        self.assertEqual(rep["interface"], 0)
        self.assertEqual(set(np.unique(new.cell_refs)), {2})

    @unittest.skipUnless(PADAPT, "PADAPT (the command-line tool) not set")
    def test_same_as_cli(self):
        mesh = padapt.Mesh.generate_box(3, 5)
        phi = sphere(mesh.points)
        mesh.write("ls.mesh")
        with open("ls.sol", "w") as f:
            f.write("MeshVersionFormatted 2\nDimension 3\nSolAtVertices\n%d\n1 1\n" % len(phi))
            f.write("".join("%.17g\n" % v for v in phi) + "End\n")
        subprocess.run([PADAPT, "-v", "-1", "adapt", "ls.mesh", "-ls", "ls.sol", "-hsiz",
                        "0.1", "-out", "ls.o.mesh", "-json", "ls.json"], check=True)
        cli = json.load(open("ls.json"))["levelset"]
        _, _, rep = padapt.adapt(mesh, hsiz=0.1, levelset=phi)
        self.assertEqual(rep["levelset"], cli)


if __name__ == "__main__":
    unittest.main()
