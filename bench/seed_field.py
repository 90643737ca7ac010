#!/usr/bin/python3
"""seed_field.py -- the analytic field of bench/seed_loop.sh and its
interpolation error (numpy and meshio, from Debian).

  seed_field.py sol  DIM MESH OUT.sol    u at the mesh's vertices
  seed_field.py err  DIM MESH            L2 and L-infinity norms of u - P1(u)
  seed_field.py svg  TABLE OUT.svg       the convergence plot of a table

u is a shock-like layer: u = tanh(K (x - 0.5 - 0.1 sin(3 pi y)
[cos(2 pi z)])), K = 50. The errors integrate |u - Pi u| over every element
with a degree-5 quadrature of 7 (triangle) or 14 (tetrahedron) points, Pi u
the linear interpolant of the vertex values: they measure the mesh, not a
solver. TABLE lines: "kind N vertices elements L2 Linf" (kind adapted or
uniform); the plot is log-log of L2 error against vertices.
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ugawg_judge import read_mesh  # noqa: E402

K = 50.0


def u_of(x):
    d = x.shape[1]
    s = 0.1 * np.sin(3 * np.pi * x[:, 1])
    if d == 3:
        s = s * np.cos(2 * np.pi * x[:, 2])
    return np.tanh(K * (x[:, 0] - 0.5 - s))


read = read_mesh  # one Medit/gmsh reader for every bench judge


def write_sol(path, dim, vals):
    with open(path, "w") as f:
        f.write("MeshVersionFormatted 2\nDimension %d\nSolAtVertices\n%d\n1 1\n"
                % (dim, len(vals)))
        f.write("\n".join("%.17g" % v for v in vals))
        f.write("\nEnd\n")


def quadrature(dim):
    """Barycentric points (n, dim+1) and weights summing to 1."""
    if dim == 2:  # Dunavant degree 5, 7 points
        a, b = 0.059715871789770, 0.470142064105115
        c, d = 0.797426985353087, 0.101286507323456
        pts = [(1 / 3, 1 / 3, 1 / 3), (a, b, b), (b, a, b), (b, b, a),
               (c, d, d), (d, c, d), (d, d, c)]
        w = [0.225] + [0.132394152788506] * 3 + [0.125939180544827] * 3
        return np.array(pts), np.array(w)
    # Walkington / Keast degree 5, 14 points
    a1, b1 = 0.0927352503108912, 0.7217942490673264
    a2, b2 = 0.3108859192633006, 0.0673422422100982
    a3, b3 = 0.4544962958743504, 0.0455037041256496
    pts, w = [], []
    for a, b, wt in ((a1, b1, 0.0734930431163619), (a2, b2, 0.1126879257180159)):
        for i in range(4):
            p = [a] * 4
            p[i] = b
            pts.append(p)
            w.append(wt)
    for i in range(4):
        for j in range(i + 1, 4):
            p = [b3] * 4
            p[i] = p[j] = a3
            pts.append(p)
            w.append(0.0425460207770815)
    w = np.array(w)
    return np.array(pts), w / w.sum()


def errors(dim, path):
    x, cells = read(path, dim)
    uv = u_of(x)
    lam, w = quadrature(dim)
    v = x[cells]  # (ne, dim+1, dim)
    a = v[:, 1:, :] - v[:, :1, :]
    vol = np.abs(np.linalg.det(a)) / math.factorial(dim)
    l2, linf = 0.0, 0.0
    for q in range(len(w)):
        xq = np.einsum("k,ekd->ed", lam[q], v)
        iq = uv[cells] @ lam[q]
        e = u_of(xq) - iq
        l2 += w[q] * np.sum(vol * e * e)
        linf = max(linf, float(np.max(np.abs(e))))
    # the vertices themselves are exact; the edge midpoints catch the peaks
    return math.sqrt(l2), linf, len(x), len(cells)


def svg(table, out):
    rows = [l.split() for l in open(table) if l.strip() and not l.startswith("#")]
    series = {}
    for r in rows:
        series.setdefault(r[0], []).append((float(r[2]), float(r[4])))
    allx = [p[0] for s in series.values() for p in s]
    ally = [p[1] for s in series.values() for p in s]
    x0, x1 = math.log10(min(allx)) - 0.1, math.log10(max(allx)) + 0.1
    y0, y1 = math.log10(min(ally)) - 0.2, math.log10(max(ally)) + 0.2
    W, H, M = 640, 480, 70

    def px(v):
        return M + (math.log10(v) - x0) / (x1 - x0) * (W - 2 * M)

    def py(v):
        return H - M - (math.log10(v) - y0) / (y1 - y0) * (H - 2 * M)

    colors = {"adapted": "#c0392b", "uniform": "#2c3e80"}
    o = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" '
         'font-family="sans-serif" font-size="13">' % (W, H),
         '<rect width="100%" height="100%" fill="white"/>',
         '<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="#444"/>'
         % (M, M, W - 2 * M, H - 2 * M)]
    for e in range(int(math.floor(x0)), int(math.ceil(x1)) + 1):
        for m_ in (1, 2, 5):
            v = m_ * 10 ** e
            if x0 <= math.log10(v) <= x1:
                o.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>'
                         % (px(v), M, px(v), H - M))
                o.append('<text x="%.1f" y="%d" text-anchor="middle">%g</text>'
                         % (px(v), H - M + 18, v))
    for e in range(int(math.floor(y0)), int(math.ceil(y1)) + 1):
        v = 10 ** e
        if y0 <= e <= y1:
            o.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>'
                     % (M, py(v), W - M, py(v)))
            o.append('<text x="%d" y="%.1f" text-anchor="end">1e%d</text>'
                     % (M - 6, py(v) + 4, e))
    for i, (name, pts) in enumerate(sorted(series.items())):
        pts.sort()
        c = colors.get(name, "#333")
        o.append('<polyline fill="none" stroke="%s" stroke-width="2" points="%s"/>'
                 % (c, " ".join("%.1f,%.1f" % (px(a), py(b)) for a, b in pts)))
        for a, b in pts:
            o.append('<circle cx="%.1f" cy="%.1f" r="3.5" fill="%s"/>' % (px(a), py(b), c))
        o.append('<text x="%d" y="%d" fill="%s">%s</text>' % (W - M - 120, M + 20 + 18 * i, c, name))
    o.append('<text x="%d" y="%d" text-anchor="middle">vertices</text>' % (W / 2, H - 20))
    o.append('<text x="18" y="%d" transform="rotate(-90 18 %d)" text-anchor="middle">'
             'L2 interpolation error</text>' % (H / 2, H / 2))
    o.append("</svg>")
    open(out, "w").write("\n".join(o) + "\n")


def main():
    cmd = sys.argv[1]
    if cmd == "sol":
        dim, mesh, out = int(sys.argv[2]), sys.argv[3], sys.argv[4]
        x, _ = read(mesh, dim)
        write_sol(out, dim, u_of(x))
    elif cmd == "err":
        l2, linf, nv, ne = errors(int(sys.argv[2]), sys.argv[3])
        print("%.6e %.6e %d %d" % (l2, linf, nv, ne))
    elif cmd == "svg":
        svg(sys.argv[2], sys.argv[3])
    else:
        sys.exit("seed_field.py: unknown command %s" % cmd)


if __name__ == "__main__":
    main()
