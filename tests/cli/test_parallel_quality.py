#!/usr/bin/python3
"""test_parallel_quality.py -- the same quality at every process count.

Two gmsh-made inputs with curved boundaries are adapted to a constant size,
sequentially (`padapt adapt`) and with the parallel driver at 2, 3, 4 and 8
processes (`mpiexec -n P padapt adapt`):

- tests/data/plate2d.mesh: a plate with a circular and an elliptic hole
  (`gmsh -2 bench/plate.geo`), -hsiz 0.006 -hausd 0.0005;
- tests/data/rod3d.mesh: the connecting rod of the seed paper
  (`gmsh -3 bench/rod.geo -setnumber lc 0.2`), -hsiz 0.07.

Each output is judged here, in numpy, from the file padapt wrote (never
from padapt's own statistics): valid (every element positive, the faces
conforming: each shared by one element on the boundary or two inside, the
volume and boundary measure of the sequential output), and, against the sequential output, the
share of edges in [0.7071, 1.4142) in the size H at most 0.4 points lower,
the longest edge at most 0.15 longer, the worst quality (Mmg's
normalisation) at least 0.6 of it; the JSON report must say "converged".
Before issue #19's fix the parallel runs kept edges of 1.8-2.2 on the plate
(1.414 sequentially) and 1.95 on the rod at 8 processes (1.64).

The same run twice at 2, 3 and 4 processes, with Scotch's threads on, must
give the same bytes (before issue #19's fix, three np=4 runs of the rod
gave three different meshes).

A loop that stops before converging (here -max-iter 1) is an error, with
nothing written, unless -best-effort, which writes the valid mesh.

The sanitizer build (PADAPT_SANITIZE=1) runs the plate only, at 1 and 2.
"""
import json
import math
import os
import subprocess
import sys

import numpy as np

PADAPT = os.environ["PADAPT"]
MPIEXEC = os.environ.get("MPIEXEC") or "mpiexec"
DATA = os.environ.get("PADAPT_TESTDATA",
                      os.path.join(os.path.dirname(__file__), "..", "data"))
SANITIZE = os.environ.get("PADAPT_SANITIZE") == "1"

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def read_medit(path):
    """(coordinates (nv, dim), elements (ne, dim+1) 0-based) of an ASCII
    Medit mesh: triangles in 2D, tetrahedra in 3D."""
    tok = open(path).read().split()
    dim = int(tok[tok.index("Dimension") + 1])
    i = tok.index("Vertices")
    nv = int(tok[i + 1])
    x = np.array(tok[i + 2:i + 2 + (dim + 1) * nv], float).reshape(nv, dim + 1)
    kw = "Tetrahedra" if dim == 3 else "Triangles"
    i = tok.index(kw)
    ne = int(tok[i + 1])
    e = np.array(tok[i + 2:i + 2 + (dim + 2) * ne], np.int64).reshape(ne, dim + 2)
    return x[:, :dim], e[:, :dim + 1] - 1


def judge(path, h):
    x, el = read_medit(path)
    dim = x.shape[1]
    v = x[el]
    a = v[:, 1:, :] - v[:, :1, :]
    vol = np.linalg.det(a) / math.factorial(dim)
    # faces: each once on the boundary, twice inside
    faces = []
    for k in range(dim + 1):
        f = np.delete(el, k, axis=1)
        faces.append(np.sort(f, axis=1))
    faces = np.concatenate(faces)
    uf, cnt = np.unique(faces, axis=0, return_counts=True)
    bf = x[uf[cnt == 1]]  # boundary faces: their measure
    if dim == 2:
        barea = np.sum(np.linalg.norm(bf[:, 1] - bf[:, 0], axis=1))
    else:
        barea = 0.5 * np.sum(np.linalg.norm(
            np.cross(bf[:, 1] - bf[:, 0], bf[:, 2] - bf[:, 0]), axis=1))
    pairs = [(i, j) for i in range(dim + 1) for j in range(i + 1, dim + 1)]
    edges = np.unique(np.sort(np.concatenate([el[:, [i, j]] for i, j in pairs]),
                          axis=1), axis=0)
    ln = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1) / h
    # quality, Mmg's normalisation (1 for the regular simplex)
    s2 = sum(np.sum((v[:, i] - v[:, j]) ** 2, axis=1) for i, j in pairs)
    if dim == 2:
        q = 4 * math.sqrt(3) * np.abs(vol) / s2
    else:
        q = 72 * math.sqrt(3) * np.abs(vol) / s2 ** 1.5
    return {
        "dim": dim,
        "positive": bool(np.all(vol > 0)),
        "conforming": bool(np.all(cnt <= 2)),
        "volume": float(np.sum(vol)),
        "boundary": float(barea),
        "elements": len(el),
        "in_range": float(np.mean((ln >= 0.7071) & (ln < 1.4142))),
        "longest": float(ln.max()),
        "worst_q": float(q.min()),
    }


def adapt(mesh, h, np_, tag, extra, env=None):
    out = "%s-np%d.mesh" % (tag, np_)
    rep = "%s-np%d.json" % (tag, np_)
    cmd = [PADAPT, "adapt", mesh, "-hsiz", str(h), "-out", out, "-nosol",
           "-json", rep] + extra
    if np_ > 1:
        cmd = [MPIEXEC, "-n", str(np_)] + cmd
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError("%s: exit %d\n%s%s" % (" ".join(cmd), r.returncode,
                                                  r.stdout, r.stderr))
    return judge(out, h), json.load(open(rep))


def case(tag, mesh, h, procs, extra=()):
    ref, _ = adapt(mesh, h, 1, tag, list(extra))
    print("%s np=1: %d elements, %.2f %% in range, longest %.3f, worst Q %.3f"
          % (tag, ref["elements"], 100 * ref["in_range"], ref["longest"],
             ref["worst_q"]))
    check(ref["positive"] and ref["conforming"], "%s np=1: valid" % tag)
    for p in procs:
        j, rep = adapt(mesh, h, p, tag, list(extra))
        what = "%s np=%d: %d elements, %.2f %% in range, longest %.3f, worst Q %.3f" % (
            tag, p, j["elements"], 100 * j["in_range"], j["longest"], j["worst_q"])
        print(what)
        check(j["positive"] and j["conforming"], "%s np=%d: valid" % (tag, p))
        # the curved boundary is rebuilt from a coarse input: the volume
        # moves by 0.1 % at most at any np, a missing element or a hole
        # changes the boundary measure by far more than 1 %
        check(abs(j["volume"] - ref["volume"]) <= 2e-3 * abs(ref["volume"]),
              "%s np=%d: volume %.6f (np=1 %.6f)" % (tag, p, j["volume"], ref["volume"]))
        check(abs(j["boundary"] - ref["boundary"]) <= 1e-2 * ref["boundary"],
              "%s np=%d: boundary measure %.6f (np=1 %.6f)" % (
                  tag, p, j["boundary"], ref["boundary"]))
        check(j["in_range"] >= ref["in_range"] - 0.004,
              "%s np=%d: in range %.2f %% >= np=1 %.2f %% - 0.4" % (
                  tag, p, 100 * j["in_range"], 100 * ref["in_range"]))
        check(j["longest"] <= ref["longest"] + 0.15,
              "%s np=%d: longest %.3f <= np=1 %.3f + 0.15" % (
                  tag, p, j["longest"], ref["longest"]))
        check(j["worst_q"] >= 0.6 * ref["worst_q"],
              "%s np=%d: worst quality %.3f >= 0.6 x np=1 %.3f" % (
                  tag, p, j["worst_q"], ref["worst_q"]))
        check(rep.get("converged") is True, "%s np=%d: report says converged" % (tag, p))


def reproducible(tag, mesh, h, procs):
    """Twice the same run, Scotch free to use its threads (the test
    environment sets SCOTCH_PTHREAD_NUMBER=1; a user does not): the same
    bytes."""
    env = dict(os.environ)
    env.pop("SCOTCH_PTHREAD_NUMBER", None)
    for p in procs:
        outs = []
        for run in (1, 2):
            adapt(mesh, h, p, "%s-run%d" % (tag, run), [], env)
            outs.append(open("%s-run%d-np%d.mesh" % (tag, run, p), "rb").read())
        check(outs[0] == outs[1], "%s np=%d: two runs give the same output" % (tag, p))


def stall(mesh, h, extra):
    """A loop stopped by -max-iter 1 before converging is an error (exit 1,
    nothing written); -best-effort writes the valid mesh."""
    out = "stall.mesh"
    for f in (out, "stall.sol", "stall.json"):
        if os.path.exists(f):
            os.remove(f)
    base = [MPIEXEC, "-n", "2", PADAPT, "adapt", mesh, "-hsiz", str(h),
            "-max-iter", "1", "-out", out, "-json", "stall.json"] + extra
    r = subprocess.run(base, capture_output=True, text=True)
    check(r.returncode != 0 and "stalled" in r.stderr and
          not os.path.exists(out) and not os.path.exists("stall.json"),
          "stalled loop: exit %d, nothing written" % r.returncode)
    r = subprocess.run(base + ["-best-effort"], capture_output=True, text=True)
    ok = r.returncode == 0 and os.path.exists(out)
    if ok:
        j = judge(out, h)
        ok = j["positive"] and j["conforming"]
    check(ok and "stalled" in r.stderr,
          "stalled loop with -best-effort: exit %d, a valid mesh written" % r.returncode)


def main():
    plate = os.path.join(DATA, "plate2d.mesh")
    rod = os.path.join(DATA, "rod3d.mesh")
    # without insertions: one iteration at 2 ranks meets the metric
    stall(plate, 0.006, ["-hausd", "0.0005", "-noinsert"])
    if SANITIZE:
        case("plate", plate, 0.006, [2], ["-hausd", "0.0005"])
    else:
        case("plate", plate, 0.006, [2, 3, 4, 8], ["-hausd", "0.0005"])
        case("rod", rod, 0.07, [2, 3, 4, 8])
        reproducible("rod", rod, 0.07, [2, 3, 4])
    if failures:
        print("%d check(s) failed" % len(failures))
        sys.exit(1)
    print("all checks passed")


if __name__ == "__main__":
    main()
