#!/usr/bin/python3
"""test_local_params.py -- Mmg's parameter file (-f FILE, IN.padapt): local
sizes and Hausdorff distances per reference, judged by meshio.

On the gmsh plate (tests/data/plate2d.mesh; boundary edge references 5-10,
5 and 6 the curved holes) adapted to -hsiz 0.05:
  - "9 Edges ... hmax 0.005" and "10 Edges ...": the edges of references 9
    and 10 get at most 1.5 x 0.005 long, the other boundary edges stay near
    0.05 -- sequentially and on 2 processes, with the same counts;
  - a local hausd alone on reference 5 (sizes left to the global ones)
    refines the curved hole 5 only: more edges on 5 than without, the same
    on 6;
  - "1 Triangles ... hmax 0.02" (the elements' reference) bounds every
    edge by 1.6 x 0.02;
  - IN.padapt beside the mesh is read without -f;
  - 3D, the gmsh rod (tests/data/rod3d.mesh) at -hsiz 0.08: a local hausd
    on boundary triangles of reference 10 keeps 1.2 times more of them than
    the global hausd, and those of reference 28 within 5 %, sequentially
    and on 2 processes;
  - malformed files are refused naming file:line, nothing written.
"""
import os
import shutil
import subprocess
import sys

import meshio
import numpy as np

PADAPT = os.environ["PADAPT"]
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
SRC = os.environ["PADAPT_SRC"]
fails = []


def fail(msg):
    fails.append(msg)
    print("FAIL " + msg)


def ok(msg):
    print("ok   " + msg)


def run(args, np_=1, expect=0):
    cmd = ([MPIEXEC, "-n", str(np_)] if np_ > 1 else []) + [PADAPT] + args
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if p.returncode != expect:
        fail("'%s' exited with %d: %s" % (" ".join(args), p.returncode,
                                          (p.stdout + p.stderr)[-400:]))
    return p


def edges_by_ref(path):
    m = meshio.read(path)
    out = {}
    for c, r in zip(m.cells, m.cell_data["medit:ref"]):
        if c.type != "line":
            continue
        L = np.linalg.norm(m.points[c.data[:, 0]] - m.points[c.data[:, 1]], axis=1)
        for k in np.unique(r):
            out[int(k)] = (int((r == k).sum()), float(L[r == k].max()))
    tri = m.cells_dict["triangle"]
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    longest = float(np.linalg.norm(m.points[e[:, 0]] - m.points[e[:, 1]], axis=1).max())
    return out, longest


def params(path, lines):
    with open(path, "w") as f:
        f.write("Parameters\n%d\n\n" % len(lines) + "\n".join(lines) + "\n")


shutil.copy(os.path.join(SRC, "tests/data/plate2d.mesh"), "plate.mesh")
for f in ("plate.padapt",):
    if os.path.exists(f):
        os.remove(f)
run(["adapt", "plate.mesh", "-hsiz", "0.05", "-out", "g.mesh"])
glob, _ = edges_by_ref("g.mesh")

params("holes.txt", ["9 Edges 0.001 0.005 0.01", "10 Edges 0.001 0.005 0.01"])
res = {}
for np_ in (1, 2):
    out = "h%d.mesh" % np_
    run(["adapt", "plate.mesh", "-hsiz", "0.05", "-f", "holes.txt", "-out", out], np_)
    e, _ = edges_by_ref(out)
    res[np_] = e
    small = all(e[k][1] <= 1.5 * 0.005 for k in (9, 10))
    others = all(e[k][1] >= 0.03 for k in (5, 6, 7, 8))
    (ok if small and others else fail)(
        "np=%d: holes at most %.4f, other boundary edges up to %.4f" %
        (np_, max(e[9][1], e[10][1]), max(e[k][1] for k in (5, 6, 7, 8))))
if res[1][9][0] != res[2][9][0] or res[1][10][0] != res[2][10][0]:
    fail("np=1 and np=2 differ on the holes: %s %s" % (res[1], res[2]))

params("hausd.txt", ["5 Edges 0.0001 10 0.00002"])
run(["adapt", "plate.mesh", "-hsiz", "0.05", "-f", "hausd.txt", "-out", "d.mesh"])
e, _ = edges_by_ref("d.mesh")
(ok if e[5][0] > 1.5 * glob[5][0] and e[6][0] == glob[6][0] else fail)(
    "local hausd on 5: %d edges (global %d), 6: %d (global %d)" %
    (e[5][0], glob[5][0], e[6][0], glob[6][0]))

params("elem.txt", ["1 Triangles 0.001 0.02 0.01"])
run(["adapt", "plate.mesh", "-hsiz", "0.05", "-f", "elem.txt", "-out", "t.mesh"])
_, longest = edges_by_ref("t.mesh")
(ok if longest <= 1.6 * 0.02 else fail)("element reference 1: longest edge %.4f" % longest)

shutil.copy("holes.txt", "plate.padapt")
p = run(["adapt", "plate.mesh", "-hsiz", "0.05", "-out", "a.mesh"])
e, _ = edges_by_ref("a.mesh")
(ok if "plate.padapt" in p.stdout and e[9][1] <= 1.5 * 0.005 else fail)(
    "plate.padapt read without -f")
os.remove("plate.padapt")

def tri_counts(path):
    m = meshio.read(path)
    for c, r in zip(m.cells, m.cell_data["medit:ref"]):
        if c.type == "triangle":
            return {int(k): int((r == k).sum()) for k in np.unique(r)}


shutil.copy(os.path.join(SRC, "tests/data/rod3d.mesh"), "rod.mesh")
params("rod.txt", ["10 Triangles 0.0001 10 0.0005"])
run(["adapt", "rod.mesh", "-hsiz", "0.08", "-out", "r0.mesh"])
g = tri_counts("r0.mesh")
for np_ in (1, 2):
    run(["adapt", "rod.mesh", "-hsiz", "0.08", "-f", "rod.txt", "-out", "r.mesh"], np_)
    c = tri_counts("r.mesh")
    good = c[10] > 1.2 * g[10] and abs(c[28] - g[28]) <= 0.05 * g[28]
    (ok if good else fail)("3D np=%d: local hausd on 10: %d triangles (global %d), "
                           "28: %d (global %d)" % (np_, c[10], g[10], c[28], g[28]))

bad = {
    "nokw.txt": ("Params\n1\n9 Edges 0.1 0.2 0.01\n", ":1:"),
    "count.txt": ("Parameters\n2\n9 Edges 0.1 0.2 0.01\n", "2 parameters announced"),
    "type.txt": ("Parameters\n1\n# a comment\n9 Tetrahedra 0.1 0.2 0.01\n", ":4:"),
    "num.txt": ("Parameters\n1\n9 Edges 0.1 x 0.01\n", ":3:"),
    "order.txt": ("Parameters\n1\n9 Edges 0.3 0.2 0.01\n", "hmin <= hmax"),
    "extra.txt": ("Parameters\n1\n9 Edges 0.1 0.2 0.01\n10 Edges 0.1 0.2 0.01\n", ":4:"),
}
for name, (text, want) in bad.items():
    with open(name, "w") as f:
        f.write(text)
    for np_ in (1, 2):
        if os.path.exists("x.mesh"):
            os.remove("x.mesh")
        p = run(["adapt", "plate.mesh", "-hsiz", "0.05", "-f", name, "-out", "x.mesh"],
                np_, expect=1)
        good = name in p.stderr and want in p.stderr and not os.path.exists("x.mesh")
        (ok if good else fail)("np=%d %s refused: %s" %
                               (np_, name, p.stderr.strip().split("\n")[0]))
if fails:
    sys.exit("%d check(s) failed" % len(fails))
print("all checks passed")
