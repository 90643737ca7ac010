#!/usr/bin/python3
"""test_lattice3d.py -- the 3D remesher on cube lattices (issues #36, #39).

A box3d lattice refined by whole bisection levels can end with every edge
in range and nothing left to do: twice the ideal count of tets, or Kuhn
tets of mean quality 0.66. For two such sizes,

    $PADAPT generate box3d 8 in.mesh
    $PADAPT adapt in.mesh -hsiz H -out out.mesh -nosol

and the output judged here with numpy on the file itself (meshio reads it):
the tet count against the ideal one (volume over the volume of the regular
tet of edge H), the mean and worst quality in Mmg's normalisation
(72 sqrt 3 V / (sum l^2)^{3/2}, the metric is uniform) and the share of
tet-edges in [1/sqrt 2, sqrt 2) H. Bounds: count <= 1.45 x ideal, mean
quality >= 0.8 (0.85 for H = 0.12, where the lattice is made body-centred),
worst >= 0.3, in range >= 99 %. Before the shake and the body-centred
lattice (driver_3d.c, shake_lattice, break_lattice_crowd) H = 0.08 gave
1.48 x ideal at mean quality 0.663, H = 0.11 1.93 x ideal, H = 0.12 mean
quality 0.813.

Run by CTest with PADAPT = path of the CLI, in a scratch working directory.
"""
import math
import os
import subprocess
import sys

import meshio
import numpy as np

EDGES = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
MAX_IDEAL = 1.45
# -hsiz and the least mean quality
CASES = ((0.08, 0.8), (0.11, 0.8), (0.12, 0.85))
MIN_QWORST = 0.3
MIN_INRANGE = 0.99


def judge(path, h):
    m = meshio.read(path)
    x = m.points
    t = m.cells_dict["tetra"]
    p = [x[t[:, i]] for i in range(4)]
    vol = np.einsum("ij,ij->i", p[1] - p[0],
                    np.cross(p[2] - p[0], p[3] - p[0])) / 6.0
    l2 = np.stack([((p[a] - p[b]) ** 2).sum(1) for a, b in EDGES])
    q = 72.0 * math.sqrt(3.0) * vol / l2.sum(0) ** 1.5
    ln = np.sqrt(l2) / h
    inr = np.mean((ln >= 1.0 / math.sqrt(2.0)) & (ln < math.sqrt(2.0)))
    ideal = vol.sum() / (h ** 3 / (6.0 * math.sqrt(2.0)))
    return len(t), len(t) / ideal, q.min(), q.mean(), inr


def main():
    padapt = os.environ.get("PADAPT")
    if not padapt:
        print("PADAPT not set", file=sys.stderr)
        return 1
    subprocess.run([padapt, "generate", "box3d", "8", "in.mesh"], check=True,
                   stdout=subprocess.DEVNULL)
    bad = 0
    for h, min_qmean in CASES:
        subprocess.run([padapt, "-v", "-1", "adapt", "in.mesh", "-hsiz",
                        str(h), "-out", "out.mesh", "-nosol"], check=True)
        n, r, qw, qm, inr = judge("out.mesh", h)
        print("box3d 8 -> %g: %d tets (%.3f x ideal), worst Q %.3f, mean Q "
              "%.3f, %.2f %% in range" % (h, n, r, qw, qm, 100 * inr))
        for ok, what in ((r <= MAX_IDEAL, "count %.3f x ideal > %g" %
                          (r, MAX_IDEAL)),
                         (qm >= min_qmean, "mean Q %.3f < %g" % (qm, min_qmean)),
                         (qw >= MIN_QWORST, "worst Q %.3f < %g" %
                          (qw, MIN_QWORST)),
                         (inr >= MIN_INRANGE, "in range %.4f < %g" %
                          (inr, MIN_INRANGE))):
            if not ok:
                print("FAIL: -hsiz %g: %s" % (h, what), file=sys.stderr)
                bad = 1
    return bad


if __name__ == "__main__":
    sys.exit(main())
