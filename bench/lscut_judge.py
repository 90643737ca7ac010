#!/usr/bin/python3
"""lscut_judge.py -- the independent judge of bench/levelset_cut.sh: a mesh
that carries a level set's zero set as an interface (padapt adapt -ls, Mmg
-ls), measured against the exact surface with numpy and meshio only
(nothing of padapt).

  lscut_judge.py MESH SHAPE H DIM [REF_IN REF_IFACE]

SHAPE: sphere:R[:cx,cy(,cz)] (a circle in 2D), annulus:a,b[:cx,cy] (2D, the
ring a < r < b), torus:R,r[:cx,cy,cz] (3D, axis z). H: the uniform size
the mesh was adapted to. REF_IN, REF_IFACE: the inside's element reference
and the interface's (default 3 and 10, Mmg's).

Prints one JSON object:
  elements, vertices;
  volume_in, volume_exact, volume_error (|in - exact| / exact);
  interface (entities of REF_IFACE), and the distance of the interface to
  the exact surface: |signed distance| sampled at the entities' vertices,
  edge midpoints and centroids: dist_max, dist_mean (and both over H);
  quality in the metric (isotropic, size H: the Euclidean quality, Mmg's
  normalisation 4 sqrt 3 A / sum l^2, 72 sqrt 3 V / (sum l^2)^3/2):
  quality_worst, quality_mean, share above 0.5; edges with length / H in
  [0.7071, 1.4142): edges_in_range.
"""
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ugawg_judge import meshio_read  # noqa: E402

IN_LO, IN_HI = 0.7071, 1.4142


def read(path, dim):
    mesh = meshio_read(path)
    x = np.asarray(mesh.points, dtype=float)[:, :dim]
    cells, refs = {}, {}
    for block, ref in zip(mesh.cells, mesh.cell_data.get("medit:ref",
                                                         [None] * len(mesh.cells))):
        r = np.zeros(len(block.data), dtype=np.int64) if ref is None else ref
        cells.setdefault(block.type, []).append(block.data)
        refs.setdefault(block.type, []).append(np.asarray(r, dtype=np.int64))
    out = {}
    for k in cells:
        out[k] = (np.concatenate(cells[k]).astype(np.int64), np.concatenate(refs[k]))
    return x, out


def shape_fn(spec, dim):
    kind, _, rest = spec.partition(":")
    parts = rest.split(":")
    nums = [float(v) for v in parts[0].split(",")]
    c = np.full(dim, 0.5)
    if len(parts) > 1:
        c = np.array([float(v) for v in parts[1].split(",")])[:dim]
    if kind == "sphere":
        R = nums[0]
        vol = math.pi * R * R if dim == 2 else 4 * math.pi * R ** 3 / 3
        return (lambda p: np.linalg.norm(p - c, axis=1) - R), vol
    if kind == "annulus" and dim == 2:
        a, b = nums
        m, w = (a + b) / 2, (b - a) / 2
        return (lambda p: np.abs(np.linalg.norm(p - c, axis=1) - m) - w), math.pi * (b * b - a * a)
    if kind == "torus" and dim == 3:
        R, r = nums

        def sd(p):
            q = np.linalg.norm(p[:, :2] - c[:2], axis=1) - R
            return np.hypot(q, p[:, 2] - c[2]) - r
        return sd, 2 * math.pi ** 2 * R * r * r
    raise SystemExit("lscut_judge: unknown shape %s" % spec)


def quality(x, cells, dim):
    v = x[cells]
    a = v[:, 1:, :] - v[:, :1, :]
    vol = np.linalg.det(a) / math.factorial(dim)
    k = dim + 1
    l2 = sum(np.sum((v[:, i] - v[:, j]) ** 2, axis=1)
             for i in range(k) for j in range(i + 1, k))
    if dim == 2:
        return 4 * math.sqrt(3) * vol / l2, np.abs(vol)
    return 72 * math.sqrt(3) * vol / l2 ** 1.5, np.abs(vol)


def main():
    path, spec, h, dim = sys.argv[1], sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
    rin = int(sys.argv[5]) if len(sys.argv) > 5 else 3
    rif = int(sys.argv[6]) if len(sys.argv) > 6 else 10
    sd, exact = shape_fn(spec, dim)
    x, blocks = read(path, dim)
    ek, bk = ("tetra", "triangle") if dim == 3 else ("triangle", "line")
    cells, eref = blocks[ek]
    q, vol = quality(x, cells, dim)
    vin = float(np.sum(vol[eref == rin]))
    k = dim + 1
    pairs = np.array([(i, j) for i in range(k) for j in range(i + 1, k)])
    e = np.unique(np.sort(cells[:, pairs].reshape(-1, 2), axis=1), axis=0)
    le = np.linalg.norm(x[e[:, 1]] - x[e[:, 0]], axis=1) / h
    res = {"elements": int(len(cells)), "vertices": int(len(x)),
           "volume_in": vin, "volume_exact": exact,
           "volume_error": abs(vin - exact) / exact}
    if bk in blocks:
        b, bref = blocks[bk]
        f = b[bref == rif]
        samples = [x[f[:, i]] for i in range(dim)]
        samples += [0.5 * (x[f[:, i]] + x[f[:, (i + 1) % dim]]) for i in range(dim)]
        samples.append(x[f].mean(axis=1))
        d = np.abs(sd(np.concatenate(samples))) if len(f) else np.zeros(1)
        res.update({"interface": int(len(f)), "dist_max": float(d.max()),
                    "dist_mean": float(d.mean()), "dist_max_h": float(d.max() / h),
                    "dist_mean_h": float(d.mean() / h)})
    res.update({"quality_worst": float(q.min()), "quality_mean": float(q.mean()),
                "quality_above_05": float(np.mean(q > 0.5)),
                "edges_in_range": float(np.mean((le >= IN_LO) & (le < IN_HI)))})
    print(json.dumps(res))


if __name__ == "__main__":
    main()
