#!/usr/bin/python3
"""test_adapt.py -- padapt.adapt: numpy -> adapt -> numpy in 2D and 3D with
the result judged by meshio and numpy (edge lengths in the metric, areas,
volumes), sizes and tensor metrics, interpolated fields, required entities,
the report against the command line's -json, the GIL released during the
call, and one bad input per check.

Runs in CTest's scratch directory with PYTHONPATH=python, PADAPT_LIB and
PADAPT (the command-line tool) set.
"""
import json
import os
import subprocess
import threading
import time
import unittest

import meshio
import numpy as np

import padapt

DATA = os.environ.get("PADAPT_TESTDATA", os.path.join(os.path.dirname(__file__), "..", "data"))
PADAPT = os.environ.get("PADAPT")


def edges_of(cells):
    d = cells.shape[1]
    e = np.concatenate([cells[:, [i, j]] for i in range(d) for j in range(i + 1, d)])
    return np.unique(np.sort(e, axis=1), axis=0)


def tensor(m, dim):
    """(n, 3|6) Medit-ordered tensors as (n, dim, dim) matrices."""
    if dim == 2:
        a, b, c = m.T
        return np.stack([np.stack([a, b], -1), np.stack([b, c], -1)], -2)
    a, b, c, d, e, f = m.T
    return np.stack([np.stack([a, b, d], -1), np.stack([b, c, e], -1), np.stack([d, e, f], -1)], -2)


def simplex_measure(pts, cells):
    d = cells.shape[1] - 1
    x = pts[cells]
    v = x[:, 1:] - x[:, :1]
    return np.linalg.det(v) / (1 if d == 1 else (2 if d == 2 else 6))


class Adapt(unittest.TestCase):
    def judge(self, path, dim, metric_at, min_in_range=0.9):
        """Read path with meshio; check the measure is 1 (unit box), every
        element positive, and the share of edges of length in
        [0.7071, 1.4142) in metric_at(midpoints)."""
        r = meshio.read(path)
        ctype = "triangle" if dim == 2 else "tetra"
        pts, cells = r.points[:, :dim], r.cells_dict[ctype]
        vol = simplex_measure(pts, cells)
        self.assertTrue((vol > 0).all(), path)
        self.assertAlmostEqual(vol.sum(), 1.0, places=9)
        e = edges_of(cells)
        v = pts[e[:, 1]] - pts[e[:, 0]]
        M = metric_at(0.5 * (pts[e[:, 0]] + pts[e[:, 1]]))
        L = np.sqrt(np.einsum("ni,nij,nj->n", v, M, v))
        share = np.mean((L >= 0.7071) & (L < 1.4142))
        self.assertGreaterEqual(share, min_in_range, "%s: %.3f of the edges in range" % (path, share))
        return r

    def test_2d_tensor_metric(self):
        mesh = padapt.Mesh.generate_box(2, 8)
        n = mesh.nvert
        hx, hy = 0.03, 0.12
        met = np.tile([1 / hx ** 2, 0.0, 1 / hy ** 2], (n, 1))
        x0 = mesh.points.copy()
        new, fields, rep = padapt.adapt(mesh, met, hgrad=-1)
        np.testing.assert_array_equal(mesh.points, x0)  # the input is left as it was
        new.check()
        self.assertEqual(new.metric.shape, (new.nvert, 3))
        self.assertTrue(rep.target_met, rep.description)
        self.assertEqual(rep["elements"], new.nelem)
        new.write("aniso2d.mesh")
        const = np.diag([1 / hx ** 2, 1 / hy ** 2])
        r = self.judge("aniso2d.mesh", 2, lambda p: np.broadcast_to(const, (len(p), 2, 2)))
        # the arrays given back are those meshio reads
        np.testing.assert_allclose(r.points[:, :2], new.points, atol=1e-12)
        # and a round trip through meshio keeps the mesh valid
        padapt.Mesh.from_meshio(new.to_meshio()).check()

    def test_3d_size_metric(self):
        mesh = padapt.Mesh.generate_box(3, 3)
        size = lambda p: 0.2 + 0.25 * p[:, 0]
        new, _, rep = padapt.adapt(mesh, size(mesh.points))
        new.check()
        self.assertEqual(new.metric.shape, (new.nvert,))
        new.write("sizes3d.msh")
        self.judge("sizes3d.msh", 3,
                   lambda p: np.eye(3)[None] / size(p)[:, None, None] ** 2, 0.8)
        self.assertGreaterEqual(rep["edge_in_range"], 0.8, rep.description)
        self.assertAlmostEqual(new.volume(), 1.0, places=9)

    def test_fields_interpolated(self):
        for dim in (2, 3):
            mesh = padapt.Mesh.generate_box(dim, 4)
            p = mesh.points
            lin = 1 + p @ np.arange(1, dim + 1)  # linear: interpolated exactly
            vec = np.c_[p[:, 0], 2 * p[:, 1]]
            new, fields, _ = padapt.adapt(mesh, hsiz=0.12 if dim == 2 else 0.2,
                                          fields={"lin": lin, "vec": vec})
            self.assertEqual(sorted(fields), ["lin", "vec"])
            q = new.points
            np.testing.assert_allclose(fields["lin"], 1 + q @ np.arange(1, dim + 1), atol=1e-9)
            np.testing.assert_allclose(fields["vec"], np.c_[q[:, 0], 2 * q[:, 1]], atol=1e-9)
            self.assertNotEqual(new.nvert, mesh.nvert)

    def test_required_cells_kept(self):
        mesh = padapt.Mesh.generate_box(2, 6)
        c = mesh.points[mesh.cells].mean(axis=1)
        req = np.hypot(c[:, 0] - 0.5, c[:, 1] - 0.5) < 0.2
        m = padapt.Mesh(mesh.points, mesh.cells, mesh.boundary,
                        boundary_refs=mesh.boundary_refs, required_cells=req)
        new, _, _ = padapt.adapt(m, hsiz=0.04)
        key = lambda pts, cells: {tuple(sorted(map(tuple, np.round(pts[t], 12)))) for t in cells}
        before = key(m.points, m.cells[req])
        after = key(new.points, new.cells)
        self.assertTrue(before <= after, "required elements changed")
        self.assertGreater(new.nelem, 4 * mesh.nelem)

    @unittest.skipUnless(PADAPT, "PADAPT (the command-line tool) not set")
    def test_report_matches_cli(self):
        src = os.path.join(DATA, "plate2d.mesh")
        subprocess.run([PADAPT, "adapt", src, "-hsiz", "0.05", "-hmax", "0.04", "-out", "cli.mesh",
                        "-json", "cli.json"], check=True, stdout=subprocess.DEVNULL)
        with open("cli.json") as f:
            cli = json.load(f)
        rep = padapt.adapt(padapt.read(src), hsiz=0.05, hmax=0.04).report
        self.assertEqual(sorted(cli), sorted(rep))
        json.loads(rep.to_json())
        for k, v in cli.items():
            if k in ("time_s", "remesh_cpu_s", "peak_rss_bytes", "peak_memory_bytes"):
                continue
            w = rep[k]
            if isinstance(v, dict):
                for kk in v:
                    self.assertAlmostEqual(v[kk], w[kk], delta=1e-5 * max(1, abs(v[kk])), msg=kk)
            elif isinstance(v, float):
                self.assertAlmostEqual(v, w, delta=1e-9 * max(1, abs(v)), msg=k)
            else:
                self.assertEqual(v, w, k)
        self.assertEqual(rep["limited_by"], cli["limited_by"])
        self.assertEqual(padapt.read("cli.mesh").nelem, rep["elements"])

    def test_gil_released(self):
        mesh = padapt.Mesh.generate_box(2, 10)
        t = time.perf_counter()
        padapt.adapt(mesh, hsiz=0.01)
        # a size making each call last about 0.25 s on this machine and build
        h = 0.01 * min(1.0, np.sqrt((time.perf_counter() - t) / 0.25))
        calls = []

        def work():
            for _ in range(3):
                t = time.perf_counter()
                padapt.adapt(mesh, hsiz=h)
                calls.append(time.perf_counter() - t)

        th = threading.Thread(target=work)
        gap, last = 0.0, time.perf_counter()
        th.start()
        while th.is_alive():
            now = time.perf_counter()
            gap, last = max(gap, now - last), now
        th.join()
        self.assertEqual(len(calls), 3)
        self.assertGreater(min(calls), 0.08, "adaptation too short to judge")
        # were the GIL held through the C call, this loop would stall for all of it
        self.assertLess(gap, 0.5 * min(calls), "main thread stalled %.3f s in calls of %s s" % (gap, calls))


    def test_own_metric_and_no_leak(self):
        import gc
        gc.collect()
        base = padapt.memory_current()
        mesh = padapt.Mesh.generate_box(3, 2)
        mesh.metric = np.full(mesh.nvert, 0.3)
        new, _, rep = padapt.adapt(mesh)  # the mesh's own metric
        new.check()
        self.assertGreater(new.nelem, mesh.nelem)
        self.assertIsNotNone(mesh.metric)
        pts = new.points
        del mesh, new, rep
        gc.collect()
        self.assertGreater(padapt.memory_current(), base)  # pts keeps its mesh alive
        del pts
        gc.collect()
        self.assertEqual(padapt.memory_current(), base, "library memory not freed")


class AdaptBadInput(unittest.TestCase):
    def setUp(self):
        self.mesh = padapt.Mesh.generate_box(2, 3)
        self.n = self.mesh.nvert

    def bad(self, exc, msg, *args, **kw):
        with self.assertRaises(exc) as cm:
            padapt.adapt(*args, **kw)
        self.assertIn(msg, str(cm.exception))

    def test_each_check(self):
        m, n = self.mesh, self.n
        self.bad(TypeError, "padapt.Mesh", "mesh.mesh", hsiz=0.1)
        self.bad(ValueError, "no metric", m)
        self.bad(ValueError, "expected sizes", m, np.ones((n, 2)))
        self.bad(ValueError, "expected sizes", m, np.ones(n + 1))
        self.bad(ValueError, "expected real numbers", m, np.array(["a"] * n))
        self.bad(ValueError, "not finite", m, np.r_[np.nan, np.ones(n - 1)])
        self.bad(ValueError, "size is not positive", m, -np.ones(n))
        self.bad(ValueError, "tensor is not positive definite", m, np.tile([1.0, 0, -1.0], (n, 1)))
        self.bad(ValueError, "field 'u'", m, hsiz=0.1, fields={"u": np.ones(n - 1)})
        self.bad(ValueError, "not finite", m, hsiz=0.1, fields={"u": np.full(n, np.inf)})
        self.bad(TypeError, "unknown adaptation option 'hsize'", m, hsize=0.1)
        self.bad(ValueError, "hgrad: expected a number", m, hsiz=0.1, hgrad="steep")
        self.bad(ValueError, "hmax: expected a finite number", m, hsiz=0.1, hmax=np.inf)
        self.bad(ValueError, "hsiz: expected a positive size", m, hsiz=-1)

    def test_library_refuses(self):
        c = self.mesh.cells.copy()
        c[0, [1, 2]] = c[0, [2, 1]]
        bad = padapt.Mesh(self.mesh.points, c, self.mesh.boundary)
        with self.assertRaises(padapt.Error) as cm:
            padapt.adapt(bad, hsiz=0.1)
        self.assertEqual(cm.exception.status, "invalid mesh")
        self.assertIn("element 1", str(cm.exception))

    def test_duplicated_and_folded_refused(self):
        """A tetrahedron listed twice crashed the 3D remesher (and the
        interpreter with it); folded elements reached it too."""
        tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
        cases = [
            (tet, [[0, 1, 2, 3], [0, 1, 2, 3]], "elements 1 and 2 have the same vertices"),
            (np.vstack([tet, [[0.2, 0.2, 0.3]]]), [[0, 1, 2, 3], [0, 1, 2, 4]],
             "elements 1 and 2 overlap"),
        ]
        a = 2 * np.pi * 2 * np.arange(7) / 7  # seven triangles turning twice
        fan = np.vstack([[0, 0], np.c_[np.cos(a), np.sin(a)]])
        cases.append((fan, [[0, 1 + k, 1 + (k + 1) % 7] for k in range(7)],
                      "around vertex 1 turn 2 times"))
        for pts, cells, msg in cases:
            with self.subTest(msg=msg):
                with self.assertRaises(padapt.Error) as cm:
                    padapt.adapt(padapt.Mesh(pts, np.array(cells)), hsiz=0.3)
                self.assertEqual(cm.exception.status, "invalid mesh")
                self.assertIn(msg, str(cm.exception))


if __name__ == "__main__":
    unittest.main(verbosity=2)
