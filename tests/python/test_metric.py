#!/usr/bin/python3
"""test_metric.py -- padapt.metric against closed forms: recovery exact for
quadratics, the Hessian metric of a quadratic proportional to its Hessian at
the complexity asked for, signed distances, the level-set metric, the
intersection (contained in both, the smaller size), gradation, clamping,
complexity and scaling; a bad input per check; the mesh left unchanged.
"""
import unittest

import numpy as np

import padapt
from padapt import metric

from test_adapt import tensor


class Toolbox(unittest.TestCase):
    def setUp(self):
        self.m2 = padapt.Mesh.generate_box(2, 12)
        self.m3 = padapt.Mesh.generate_box(3, 4)

    def test_recover_quadratic(self):
        m = self.m2
        x, y = m.points.T
        g, h = metric.recover(m, x * x + 3 * y * y + x * y)
        np.testing.assert_allclose(h, np.tile([2.0, 1.0, 6.0], (m.nvert, 1)), atol=1e-7)
        np.testing.assert_allclose(g, np.c_[2 * x + y, 6 * y + x], atol=1e-7)
        g3, h3 = metric.recover(self.m3, self.m3.points[:, 2] ** 2, method="lsq")
        np.testing.assert_allclose(h3, np.tile([0, 0, 0, 0, 0, 2.0], (self.m3.nvert, 1)), atol=1e-7)
        g, _ = metric.recover(m, 2 * x - y, method="l2")  # L2 projection: exact for linear
        np.testing.assert_allclose(g, np.tile([2.0, -1.0], (m.nvert, 1)), atol=1e-9)

    def test_hessian_metric(self):
        m = self.m2
        x, y = m.points.T
        M = metric.hessian(m, x * x + 4 * y * y, target=400, hgrad=None)
        self.assertEqual(M.shape, (m.nvert, 3))
        self.assertAlmostEqual(metric.complexity(m, M), 400, delta=0.4)
        np.testing.assert_allclose(M[:, 2] / M[:, 0], 4.0, rtol=1e-6)  # |H| = diag(2, 8)
        np.testing.assert_allclose(M[:, 1], 0.0, atol=1e-6 * M[:, 0].max())
        M3 = metric.hessian(self.m3, self.m3.points[:, 0] ** 2 + self.m3.points[:, 1] ** 2,
                            err=1e-3, hmax=0.3)
        self.assertEqual(M3.shape, (self.m3.nvert, 6))
        self.assertTrue((np.linalg.eigvalsh(tensor(M3, 3)) >= 1 / 0.3 ** 2 * (1 - 1e-9)).all())

    def test_levelset(self):
        m = self.m2
        phi = metric.signed_distance(m, "sphere:0.3:0.5,0.5")
        ref = np.hypot(m.points[:, 0] - 0.5, m.points[:, 1] - 0.5) - 0.3
        np.testing.assert_allclose(phi, ref, atol=1e-12)
        M = metric.levelset(m, phi, eps=1e-3, hmin=0.005, hmax=0.1)
        ev = np.linalg.eigvalsh(tensor(M, 2))
        self.assertTrue((ev > 0).all())
        hsmall = 1 / np.sqrt(ev[:, 1])  # the smallest size at each vertex
        near, far = np.abs(phi) < 0.02, np.abs(phi) > 0.45
        self.assertLess(hsmall[near].max(), 0.03)
        np.testing.assert_allclose(hsmall[far], 0.1, rtol=1e-6)

    def test_intersect(self):
        a, b = np.array([0.1, 0.5, 0.2]), np.array([0.3, 0.2, 0.2])
        np.testing.assert_allclose(metric.intersect(a, b), np.minimum(a, b))
        A = np.array([[1.0, 0, 4], [2, 0.5, 1]])
        B = np.array([[4.0, 0, 1], [1, -0.2, 3]])
        C = metric.intersect(A, B)
        np.testing.assert_allclose(C[0], [4, 0, 4], atol=1e-12)
        for X in (A, B):  # C contains neither ball: C - X >= 0
            self.assertTrue((np.linalg.eigvalsh(tensor(C, 2) - tensor(X, 2)) > -1e-9).all())
        rng = np.random.default_rng(1)
        R = rng.normal(size=(20, 3, 3))
        S = np.einsum("nij,nkj->nik", R, R) + 0.1 * np.eye(3)
        T = np.einsum("nij,nkj->nik", R[::-1], R[::-1]) + 0.1 * np.eye(3)
        flat = lambda X: X[:, [0, 0, 1, 0, 1, 2], [0, 1, 1, 2, 2, 2]]
        C3 = metric.intersect(flat(S), flat(T))
        for X in (S, T):
            self.assertTrue((np.linalg.eigvalsh(tensor(C3, 3) - X) > -1e-8 * np.abs(X).max()).all())

    def test_grade_clamp_scale(self):
        m = self.m2
        h = np.ones(m.nvert)
        centre = np.argmin(np.hypot(m.points[:, 0] - 0.5, m.points[:, 1] - 0.5))
        h[centre] = 0.01
        g = metric.grade(m, h, hgrad=1.3)
        self.assertTrue((g <= h + 1e-12).all())
        self.assertEqual(g[centre], 0.01)
        self.assertLess(np.sort(g)[1], 0.2)  # its neighbours shrank
        self.assertIsNone(m.metric)  # the mesh keeps its own (none)
        c = metric.clamp(m, np.linspace(0.001, 2, m.nvert), hmin=0.01, hmax=0.5)
        self.assertAlmostEqual(c.min(), 0.01)
        self.assertAlmostEqual(c.max(), 0.5)
        self.assertAlmostEqual(metric.complexity(m, np.full(m.nvert, 0.1)), 100.0, places=9)
        s = metric.scale_complexity(m, np.full(m.nvert, 0.1), 400)
        np.testing.assert_allclose(s, 0.05)

    def test_analytic(self):
        m = self.m3
        m.metric = np.full(m.nvert, 0.3)
        self.assertIn("shell", metric.analytic_names())
        u = metric.analytic(m, "uniform:0.2")
        np.testing.assert_allclose(u, 0.2)
        self.assertEqual(metric.analytic(m, "shell").shape, (m.nvert, 6))
        np.testing.assert_allclose(m.metric, 0.3)  # left as it was


class ToolboxBadInput(unittest.TestCase):
    def setUp(self):
        self.m = padapt.Mesh.generate_box(2, 3)
        self.u = self.m.points[:, 0] ** 2

    def test_each_check(self):
        m, u, n = self.m, self.u, self.m.nvert
        cases = [
            (ValueError, "exactly one of target= and err=", lambda: metric.hessian(m, u)),
            (ValueError, "exactly one of", lambda: metric.hessian(m, u, target=10, err=0.1)),
            (ValueError, "u: expected shape (16,), got (15,)", lambda: metric.hessian(m, u[:-1], target=10)),
            (ValueError, "not finite", lambda: metric.hessian(m, np.r_[u[:-1], np.nan], target=10)),
            (ValueError, "target: expected a positive number", lambda: metric.hessian(m, u, target=-5)),
            (ValueError, "recovery: 'lsq' or 'l2'", lambda: metric.hessian(m, u, target=10, recovery="spr")),
            (ValueError, "method: 'lsq' or 'l2'", lambda: metric.recover(m, u, method="x")),
            (ValueError, "eps: expected a positive number", lambda: metric.levelset(m, u, eps=0, hmin=0.1, hmax=1)),
            (ValueError, "intersect: metrics of shapes", lambda: metric.intersect(np.ones(3), np.ones(4))),
            (ValueError, "tensors have 3 (2D) or 6 (3D)", lambda: metric.intersect(np.ones((3, 4)), np.ones((3, 4)))),
            (ValueError, "tensor is not positive definite",
             lambda: metric.intersect(np.tile([1.0, 2, 1], (2, 1)), np.tile([1.0, 0, 1], (2, 1)))),
            (ValueError, "expected sizes", lambda: metric.grade(m, np.ones((n, 6)))),
            (ValueError, "size is not positive", lambda: metric.complexity(m, np.zeros(n))),
            (TypeError, "padapt.Mesh", lambda: metric.recover(None, u)),
        ]
        for exc, msg, f in cases:
            with self.subTest(msg=msg):
                with self.assertRaises(exc) as cm:
                    f()
                self.assertIn(msg, str(cm.exception))

    def test_library_refuses(self):
        with self.assertRaises(padapt.Error) as cm:
            metric.signed_distance(self.m, "torus:1")
        self.assertIn("torus", str(cm.exception))
        with self.assertRaises(padapt.Error):
            metric.analytic(self.m, "no-such-field")


if __name__ == "__main__":
    unittest.main(verbosity=2)
