#!/usr/bin/python3
"""test_fields.py -- element and boundary fields in the Python package:
numpy in, padapt.adapt, numpy out, judged with numpy (the integral of a
conservative field kept to 1e-12 relative, a constant exactly constant,
bounded values within the source range, the material ids' set kept,
boundary values following the references, in 2D and 3D); meshio cell data
round trips (to_meshio/from_meshio, .msh and .vtu written by padapt and
read by meshio); and one bad input per check.

Runs in CTest's scratch directory with PYTHONPATH=python and PADAPT_LIB set.
"""
import unittest

import meshio
import numpy as np

import padapt


def measures(points, cells):
    x = points[cells]
    if cells.shape[1] == 3:
        a, b = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
        return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    return np.linalg.det(x[:, 1:] - x[:, :1]) / 6


def with_fields(dim, n):
    """The box and its test fields (rho, const, noise, mat, bc)."""
    m = padapt.Mesh.generate_box(dim, n)
    c = m.points[m.cells].mean(axis=1)
    rng = np.random.default_rng(5)
    rho = 2 + np.sin(4 * c[:, 0]) * np.cos(3 * c[:, 1])
    mat = 1.0 + (c[:, 0] > 0.5) + 2 * (c[:, 1] > 0.3)
    return m, {"rho": rho, "const": np.full(m.nelem, 3.7),
               "noise": (rng.uniform(-1, 2, m.nelem), "bounded"),
               "mat": (mat, "nearest")}, {"bc": 10.0 * m.boundary_refs}


class TestFields(unittest.TestCase):
    def judge(self, m0, cf, r):
        new = r.mesh
        out = r.cell_fields
        self.assertEqual(set(out), {"rho", "const", "noise", "mat"})
        self.assertEqual(new.transfers["noise"], "bounded")
        self.assertEqual(new.transfers["mat"], "nearest")
        self.assertEqual(new.transfers["rho"], "conservative")
        w0, w1 = measures(m0.points, m0.cells), measures(new.points, new.cells)
        for k in ("rho", "const", "noise"):
            v0 = cf[k][0] if isinstance(cf[k], tuple) else cf[k]
            i0, i1 = np.dot(w0, v0), np.dot(w1, out[k])
            self.assertLessEqual(abs(i1 - i0), 1e-12 * abs(i0), k)
        self.assertTrue(np.all(out["const"] == 3.7))
        lo, hi = cf["noise"][0].min(), cf["noise"][0].max()
        self.assertTrue(np.all((out["noise"] >= lo) & (out["noise"] <= hi)))
        self.assertEqual(set(np.unique(out["mat"])), {1.0, 2.0, 3.0, 4.0})
        self.assertTrue(np.all(r.boundary_fields["bc"] == 10.0 * new.boundary_refs))
        t = r.report["transfer"]
        self.assertEqual(t["nfield"], 5)
        self.assertLess(t["defect"], 1e-13)

    def test_adapt(self):
        for dim, n, h in ((2, 4, 0.06), (3, 2, 0.2)):
            m0, cf, bf = with_fields(dim, n)
            r = padapt.adapt(m0, hsiz=h, cell_fields=cf, boundary_fields=bf)
            self.assertGreater(r.mesh.nelem, m0.nelem)
            self.judge(m0, cf, r)
            self.assertEqual(m0.cell_fields, {})  # the input is not modified

    def test_fields_on_the_mesh(self):
        m0, cf, bf = with_fields(2, 4)
        m = padapt.Mesh(m0.points, m0.cells, m0.boundary, boundary_refs=m0.boundary_refs,
                        cell_fields=cf, boundary_fields=bf)
        r = padapt.adapt(m, hsiz=0.06, transfer={"rho": "bounded"})
        self.assertEqual(r.mesh.transfers["rho"], "bounded")
        r = padapt.adapt(m, hsiz=0.06, transfer="nearest")
        self.assertEqual(set(r.mesh.transfers.values()), {"nearest"})
        self.assertTrue(set(np.unique(r.cell_fields["mat"])) <= {1.0, 2.0, 3.0, 4.0})

    def test_meshio(self):
        m0, cf, bf = with_fields(3, 2)
        m = padapt.Mesh(m0.points, m0.cells, m0.boundary, boundary_refs=m0.boundary_refs,
                        cell_fields={"rho": cf["rho"], "sig": np.ones((m0.nelem, 6))},
                        boundary_fields=bf)
        mio = m.to_meshio()
        self.assertTrue(np.all(mio.cell_data["rho"][0] == cf["rho"]))
        self.assertTrue(np.all(np.isnan(mio.cell_data["rho"][1])))
        self.assertTrue(np.all(mio.cell_data["bc"][1] == bf["bc"]))
        back = padapt.Mesh.from_meshio(mio)
        self.assertTrue(np.all(back.cell_fields["rho"] == cf["rho"]))
        self.assertEqual(back.cell_fields["sig"].shape, (m0.nelem, 6))
        self.assertTrue(np.all(back.boundary_fields["bc"] == bf["bc"]))
        self.assertNotIn("bc", back.cell_fields)
        for path in ("f.msh", "f.vtu"):
            m.write(path)
            r = meshio.read(path)
            tets = [k for k, c in enumerate(r.cells) if c.type == "tetra"]
            got = np.concatenate([np.asarray(r.cell_data["rho"][k]).reshape(-1) for k in tets])
            cells = np.vstack([r.cells[k].data for k in tets])
            i0 = np.dot(measures(m0.points, m0.cells), cf["rho"])
            self.assertLessEqual(abs(np.dot(measures(r.points, cells), got) - i0), 1e-14 * i0)
        again = padapt.read("f.msh")
        self.assertEqual(set(again.cell_fields), {"rho", "sig"})
        self.assertEqual(set(again.boundary_fields), {"bc"})

    def test_bad_input(self):
        m0, cf, bf = with_fields(2, 2)
        with self.assertRaisesRegex(ValueError, "expected shape"):
            padapt.adapt(m0, hsiz=0.1, cell_fields={"rho": np.ones(3)})
        with self.assertRaisesRegex(ValueError, "not finite|finite"):
            padapt.adapt(m0, hsiz=0.1, cell_fields={"rho": np.full(m0.nelem, np.nan)})
        with self.assertRaisesRegex(ValueError, "unknown transfer mode 'cubic'.*conservative"):
            padapt.adapt(m0, hsiz=0.1, cell_fields={"rho": (cf["rho"], "cubic")})
        with self.assertRaisesRegex(ValueError, "no element field 'x'"):
            padapt.adapt(m0, hsiz=0.1, cell_fields={"rho": cf["rho"]}, transfer={"x": "bounded"})
        m = padapt.Mesh.generate_box(2, 2)
        with self.assertRaisesRegex(ValueError, "does not apply"):
            m.add_boundary_field("bc", bf["bc"]) or m._add_at(2, m.nbdry, "b2", bf["bc"], "bounded")
        self.assertEqual(list(m.boundary_fields), ["bc"])


if __name__ == "__main__":
    unittest.main()
