#!/usr/bin/python3
"""levelset_judge.py -- how far the discrete zero set of a mesh lies from an
exact sphere or ellipsoid (numpy and meshio, from Debian; nothing of padapt).

  levelset_judge.py MESH SHAPE EPS [DIM]

SHAPE: sphere:R[:cx,cy(,cz)] or ellipsoid:a,b(,c)[:cx,cy(,cz)] (a circle and
an ellipse in 2D). The exact signed distance is evaluated at the mesh's
vertices here (the ellipsoid's by Eberly's root of the closest-point
equation, solved by bisection), interpolated linearly on every element, and
its zero set is cut out element by element (marching simplices). The
samples are the cut's vertices (on the mesh edges), their pairwise
midpoints and the centroid of each cut polygon; each sample's exact
distance to the surface is measured. Prints one JSON object: cut elements,
samples, largest / mean / 99th-percentile distance, those over EPS, and the
share of samples within EPS and within 2 EPS.
"""
import json
import sys
import os

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ugawg_judge import read_mesh  # noqa: E402


read = read_mesh  # one Medit/gmsh reader for every bench judge


def parse(shape, dim):
    kind, _, rest = shape.partition(":")
    parts = rest.split(":")
    nums = [float(v) for v in parts[0].split(",")]
    centre = np.zeros(dim)
    if len(parts) > 1:
        centre = np.array([float(v) for v in parts[1].split(",")])[:dim]
    if kind == "sphere":
        axes = np.full(dim, nums[0])
    elif kind == "ellipsoid":
        axes = np.array(nums[:dim])
    else:
        raise SystemExit("levelset_judge: unknown shape %s" % kind)
    return axes, centre


def distance(p, axes, centre):
    """Signed distance of the points p (n, dim) to the ellipsoid (axes)."""
    y = np.abs(p - centre)
    a2 = axes * axes
    if np.ptp(axes) == 0:
        return np.linalg.norm(y, axis=1) - axes[0]
    inside = np.sum(y * y / a2, axis=1) < 1
    # the closest point x_i = a_i^2 y_i / (t + a_i^2), t the root of
    # F(t) = sum (a_i y_i / (t + a_i^2))^2 - 1, decreasing on t > -min a_i^2
    lo = np.full(len(y), -a2.min()) + 1e-300
    hi = np.maximum(np.linalg.norm(y, axis=1) * axes.max(), 1e-300)
    lo = np.where(inside, lo, 0.0)
    hi = np.where(inside, 0.0, hi)
    for _ in range(200):
        t = 0.5 * (lo + hi)
        f = np.sum((axes * y / (t[:, None] + a2)) ** 2, axis=1) - 1
        lo = np.where(f > 0, t, lo)
        hi = np.where(f > 0, hi, t)
    t = 0.5 * (lo + hi)
    x = a2 * y / (t[:, None] + a2)
    d = np.linalg.norm(y - x, axis=1)
    # points on the smallest axis's plane inside: the root may not exist in
    # the bracket; the distance to the surface along that axis bounds it
    return np.where(inside, -d, d)


def main():
    path, shape, eps = sys.argv[1], sys.argv[2], float(sys.argv[3])
    dim = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    axes, centre = parse(shape, dim)
    x, cells = read(path, dim)
    phi = distance(x, axes, centre)
    s = phi[cells] < 0
    cut = cells[(s.any(axis=1)) & (~s.all(axis=1))]
    samples = []
    nv = dim + 1
    for i in range(nv):
        for j in range(i + 1, nv):
            a, b = phi[cut[:, i]], phi[cut[:, j]]
            crosses = (a < 0) != (b < 0)
            w = np.where(crosses, a / np.where(crosses, a - b, 1.0), np.nan)
            p = x[cut[:, i]] + w[:, None] * (x[cut[:, j]] - x[cut[:, i]])
            samples.append(p)
    pts = np.stack(samples, 1)  # (ncut, nedges, dim), NaN where no crossing
    ok = ~np.isnan(pts[:, :, 0])
    cnt = ok.sum(axis=1)
    centroid = np.nansum(pts, axis=1) / cnt[:, None]
    allp = [pts[ok], centroid]
    ne = pts.shape[1]
    for i in range(ne):
        for j in range(i + 1, ne):
            both = ok[:, i] & ok[:, j]
            allp.append(0.5 * (pts[both, i] + pts[both, j]))
    q = np.concatenate(allp)
    d = np.abs(distance(q, axes, centre))
    out = {
        "mesh": path, "shape": shape, "eps": eps, "cut_elements": int(len(cut)),
        "samples": int(len(q)),
        "distance_max": float(d.max()) if len(d) else None,
        "distance_mean": float(d.mean()) if len(d) else None,
        "distance_p99": float(np.percentile(d, 99)) if len(d) else None,
        "samples_over_eps": int(np.sum(d > eps)),
        "within_eps": float(np.mean(d <= eps)) if len(d) else None,
        "within_2eps": float(np.mean(d <= 2 * eps)) if len(d) else None,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
