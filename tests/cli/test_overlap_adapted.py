#!/usr/bin/python3
"""test_overlap_adapted.py -- meshes that overlap themselves where no local
check can see it (parts lying on each other without sharing a vertex: a
strip wound onto itself, two squares, two cubes) pass pa_mesh_check; the
remeshers must then adapt them, never crash (docs/guide/limits.md), on one
process and on two. Each result is checked by padapt stats (valid mesh).
"""
import math
import os
import subprocess
import sys

PADAPT = os.environ["PADAPT"]
sys.dont_write_bytecode = True  # nothing written into the source tree
sys.path.insert(0, os.path.join(os.environ["PADAPT_TESTDATA"], "bad"))
from make_check_bad import write  # noqa: E402  (the Medit writer of the corpus)
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
fails = []


def orient(x, e):
    """e with a positive orientation."""
    if len(e) == 3:
        a, b, c = (x[i] for i in e)
        d = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return e if d > 0 else (e[0], e[2], e[1])
    a, b, c, d = (x[i] for i in e)
    u = [b[k] - a[k] for k in range(3)]
    v = [c[k] - a[k] for k in range(3)]
    w = [d[k] - a[k] for k in range(3)]
    det = (u[0] * (v[1] * w[2] - v[2] * w[1]) + u[1] * (v[2] * w[0] - v[0] * w[2])
           + u[2] * (v[0] * w[1] - v[1] * w[0]))
    return e if det > 0 else (e[0], e[2], e[1], e[3])


def grid(n, dim, shift):
    m = n + 1
    if dim == 2:
        x = [[i / n + shift[0], j / n + shift[1]] for j in range(m) for i in range(m)]
        e = []
        for j in range(n):
            for i in range(n):
                a = j * m + i
                e += [(a, a + 1, a + m + 1), (a, a + m + 1, a + m)]
        return x, e
    x = [[i / n + shift[0], j / n + shift[1], k / n + shift[2]]
         for k in range(m) for j in range(m) for i in range(m)]
    idx = lambda i, j, k: (k * m + j) * m + i
    e = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                c = [idx(i + a, j + b, k + d) for d in (0, 1) for b in (0, 1) for a in (0, 1)]
                for t in ((0, 1, 3, 7), (0, 3, 2, 7), (0, 2, 6, 7), (0, 6, 4, 7),
                          (0, 4, 5, 7), (0, 5, 1, 7)):
                    e.append(tuple(c[q] for q in t))
    return x, e


def two(n, dim, shift):
    x1, e1 = grid(n, dim, [0] * dim)
    x2, e2 = grid(n, dim, shift)
    x = x1 + x2
    return x, [orient(x, t) for t in e1 + [tuple(v + len(x1) for v in t) for t in e2]]


def spiral(nt=90, nr=3, turns=1.5):
    x, e = [], []
    for i in range(nt + 1):
        th = 2 * math.pi * turns * i / nt
        for j in range(nr + 1):
            r = 1 + 0.05 * th + 0.5 * j / nr
            x.append([r * math.cos(th), r * math.sin(th)])
    for i in range(nt):
        for j in range(nr):
            a = i * (nr + 1) + j
            e += [orient(x, (a, a + nr + 1, a + nr + 2)), orient(x, (a, a + nr + 2, a + 1))]
    return x, e


def run(cmd, np_=0):
    full = ([MPIEXEC, "-n", str(np_)] if np_ else []) + [PADAPT] + cmd
    return subprocess.run(full, capture_output=True, text=True, timeout=600)


cases = [("squares.mesh", 2, two(6, 2, (0.37, 0.41)), "0.1"),
         ("spiral.mesh", 2, spiral(), "0.15"),
         ("cubes.mesh", 3, two(3, 3, (0.37, 0.41, 0.29)), "0.15")]
for name, dim, (x, e), h in cases:
    write(name, dim, x, e, here=".")
    r = run(["stats", name])
    if r.returncode != 0:
        fails.append("%s: refused by the check: %s" % (name, r.stderr.strip()[:200]))
        continue
    for np_ in (0, 2):
        out = "out%d-%s" % (np_, name)
        r = run(["adapt", name, "-hsiz", h, "-out", out, "-nosol", "-v", "-1"], np_)
        if r.returncode != 0:
            fails.append("%s on %d process(es): exit %d: %s" %
                         (name, max(np_, 1), r.returncode, r.stderr.strip()[-300:]))
            continue
        s = run(["stats", out])
        ok = s.returncode == 0
        print("%s %s on %d process(es): adapted, %s" %
              ("ok  " if ok else "FAIL", name, max(np_, 1),
               "valid" if ok else s.stderr.strip()[:200]))
        if not ok:
            fails.append("%s: the result is not valid" % out)
for f in fails:
    print("FAIL " + f)
sys.exit(1 if fails else 0)
