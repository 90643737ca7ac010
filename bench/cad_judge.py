"""cad_judge.py -- the models of `padapt adapt -geo` and their judge, from
the shapes' closed forms alone (never from padapt): tests/cli/test_geo.py
and bench/cad.sh.

Models, written as OpenCASCADE .geo files, exported as STEP and meshed by
the gmsh command line (Debian's):
  cylhole  3D: the cylinder x^2 + y^2 <= 0.5^2, 0 <= z <= 1, with a hole of
           radius 0.2 along x at z = 0.5 (curved surfaces, curves where
           they meet, seams);
  plate    2D: the rectangle [0,2] x [0,1] minus a disk of radius 0.25 at
           (0.6, 0.5) and an ellipse of semi-axes 0.2, 0.15 at (1.4, 0.5).
judge(mesh, model, reference) reads a Gmsh file (Msh) and measures:
the largest distance of a boundary vertex to the shapes of its own entity
(which shapes an entity is made of is learned from the reference mesh,
gmsh's, whose nodes lie on the model), the model points kept (every
vertex of the reference on a point entity is in the mesh, bit for bit),
the area or volume against the exact one, and the polyhedral bound: what
facets whose vertices lie on the shapes may miss at most (3D: per
triangle, its area times kappa Rc^2 / 2, Rc its circumradius; 2D: per
edge, kappa L^3 / 12).
"""
import math
import os
import subprocess

import numpy as np

# ---- the shapes: distance functions and curvatures ----


def _ellipse_dist(p, c, a, b):
    """Distance from the points p (n, 2) to the ellipse of centre c and
    semi-axes a (x), b (y), by Newton on the angle of the closest point."""
    x = np.abs(p[:, 0] - c[0])
    y = np.abs(p[:, 1] - c[1])
    t = np.arctan2(a * y, b * x)
    for _ in range(50):
        ex, ey = a * np.cos(t), b * np.sin(t)
        dx, dy = -a * np.sin(t), b * np.cos(t)
        f = (ex - x) * dx + (ey - y) * dy
        df = dx * dx + dy * dy + (ex - x) * (-ex) + (ey - y) * (-ey)
        t = np.clip(t - f / df, 0, math.pi / 2)
    return np.hypot(a * np.cos(t) - x, b * np.sin(t) - y)


R, RH = 0.5, 0.2  # cylhole: cylinder and hole radii

MODELS = {
    "cylhole": {
        "dim": 3,
        "geo": ('SetFactory("OpenCASCADE");\n'
                'Cylinder(1) = {0, 0, 0, 0, 0, 1, %g};\n'
                'Cylinder(2) = {-1, 0, 0.5, 2, 0, 0, %g};\n'
                'BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; }\n'
                % (R, RH)),
        # physical groups on some entities: the file then lists no curve,
        # no point and only these surfaces (padapt completes the rest)
        "physical": ('Physical Surface("wall") = {1};\n'
                     'Physical Surface("hole") = {2};\n'
                     'Physical Volume("solid") = {1};\n'),
        "shapes": {
            "cylinder": (lambda p: np.abs(np.hypot(p[:, 0], p[:, 1]) - R), 1 / R),
            "hole": (lambda p: np.abs(np.hypot(p[:, 1], p[:, 2] - 0.5) - RH), 1 / RH),
            "bottom": (lambda p: np.abs(p[:, 2]), 0.0),
            "top": (lambda p: np.abs(p[:, 2] - 1), 0.0),
        },
        "size": math.sqrt(3.0),
    },
    "plate": {
        "dim": 2,
        "geo": ('SetFactory("OpenCASCADE");\n'
                'Rectangle(1) = {0, 0, 0, 2, 1};\n'
                'Disk(2) = {0.6, 0.5, 0, 0.25};\n'
                'Disk(3) = {1.4, 0.5, 0, 0.2, 0.15};\n'
                'BooleanDifference{ Surface{1}; Delete; }{ Surface{2, 3}; Delete; }\n'),
        "physical": None,
        "shapes": {
            "bottom": (lambda p: np.abs(p[:, 1]), 0.0),
            "top": (lambda p: np.abs(p[:, 1] - 1), 0.0),
            "left": (lambda p: np.abs(p[:, 0]), 0.0),
            "right": (lambda p: np.abs(p[:, 0] - 2), 0.0),
            "disk": (lambda p: np.abs(np.hypot(p[:, 0] - 0.6, p[:, 1] - 0.5) - 0.25), 4.0),
            "ellipse": (lambda p: _ellipse_dist(p, (1.4, 0.5), 0.2, 0.15),
                        0.2 / 0.15 ** 2),
        },
        "size": math.sqrt(5.0),
    },
}


def exact_volume(name):
    """The area or volume of the model, in closed form (the cylinder's hole
    by a quadrature of its section, exact to 1e-12)."""
    if name == "plate":
        return 2.0 - math.pi * 0.25 ** 2 - math.pi * 0.2 * 0.15
    # the hole inside the cylinder: the section y in [-RH, RH] has width
    # 2 sqrt(R^2 - y^2) and height 2 sqrt(RH^2 - y^2)
    n = 200000
    t = (np.arange(n) + 0.5) / n * math.pi  # y = RH cos t, substituted
    y = RH * np.cos(t)
    f = 4 * np.sqrt(R * R - y * y) * (RH * np.sin(t)) * RH * np.sin(t)
    return math.pi * R * R - f.sum() * math.pi / n


# ---- making the models with the gmsh command line ----


def gmsh(*args):
    subprocess.run(["gmsh"] + [str(a) for a in args], check=True,
                   capture_output=True, timeout=600)


def make(name, workdir, clmax, physical=False):
    """The model name as .geo and STEP in workdir, and gmsh's mesh of the
    STEP (elements of size about clmax; with physical, the model's physical
    groups, so the file lists those entities' elements only). Returns
    (step path, msh path)."""
    m = MODELS[name]
    geo = os.path.join(workdir, name + ".geo")
    step = os.path.join(workdir, name + ".step")
    msh = os.path.join(workdir, "%s-%g%s.msh" % (name, clmax, "-phys" if physical else ""))
    with open(geo, "w") as f:
        f.write(m["geo"])
    if not os.path.exists(step):
        gmsh("-0", geo, "-o", step)
    src = step
    if physical and m["physical"]:
        src = os.path.join(workdir, name + "-phys.geo")
        with open(src, "w") as f:
            f.write('Merge "%s";\n%s' % (os.path.basename(step), m["physical"]))
    gmsh("-%d" % m["dim"], src, "-clmax", clmax, "-o", msh)
    return step, msh


# ---- the judge ----


class Msh(object):
    """What the judge reads of a MSH 4.1 ASCII file: points (n, 3), the
    entity of each node's block (point_data["gmsh:dim_tags"], (n, 2)),
    cells by kind ("vertex", "line", "triangle", "tetra": 0-based node
    indices) with their entity tags, and the physical names (field_data).
    (meshio 5.0 refuses a file where some entities have physical tags and
    others none, which Gmsh writes and so does padapt.)"""

    KINDS = {15: "vertex", 1: "line", 2: "triangle", 4: "tetra"}

    def __init__(self, path):
        with open(path) as f:
            tok = f.read().split("\n")
        self.field_data = {}
        self.cells, self.cell_tags = {}, {}
        i = 0
        index = {}
        pts, dts = [], []
        while i < len(tok):
            line = tok[i].strip()
            i += 1
            if line == "$MeshFormat":
                if not tok[i].startswith("4.1 0"):
                    raise ValueError("%s: not a MSH 4.1 ASCII file" % path)
            elif line == "$PhysicalNames":
                for k in range(int(tok[i])):
                    d, t, n = tok[i + 1 + k].split(None, 2)
                    self.field_data[n.strip('"')] = np.array([int(t), int(d)])
            elif line == "$Nodes":
                nblock = int(tok[i].split()[0])
                i += 1
                for _ in range(nblock):
                    d, t, par, n = (int(x) for x in tok[i].split())
                    i += 1
                    tags = [int(x) for x in tok[i:i + n]]
                    i += n
                    for k in range(n):
                        index[tags[k]] = len(pts)
                        pts.append([float(x) for x in tok[i + k].split()[:3]])
                        dts.append((d, t))
                    i += n
            elif line == "$Elements":
                nblock = int(tok[i].split()[0])
                i += 1
                for _ in range(nblock):
                    d, t, typ, n = (int(x) for x in tok[i].split())
                    i += 1
                    kind = self.KINDS[typ]
                    rows = [[index[int(x)] for x in tok[i + k].split()[1:]]
                            for k in range(n)]
                    i += n
                    self.cells.setdefault(kind, []).extend(rows)
                    self.cell_tags.setdefault(kind, []).extend([t] * n)
        self.points = np.array(pts)
        self.point_data = {"gmsh:dim_tags": np.array(dts, dtype=int).reshape(-1, 2)}
        self.cells = {k: np.array(v, dtype=int) for k, v in self.cells.items()}


def read(path):
    return Msh(path)


def _cells(m, kind):
    return m.cells.get(kind, np.zeros((0, 3), int))


def entity_shapes(ref, name):
    """{(dim, tag): [shape names]} of the reference mesh: the shapes every
    node of the entity lies on (to 1e-7 of the model's size: OpenCASCADE
    approximates the curve where two surfaces meet by a spline that close)."""
    model = MODELS[name]
    d = model["dim"]
    x = ref.points[:, :d]
    dt = ref.point_data["gmsh:dim_tags"]
    out = {}
    for key in set(map(tuple, dt.tolist())):
        if key[0] >= d:
            continue
        sel = np.all(dt == key, axis=1)
        out[key] = [s for s, (f, _) in model["shapes"].items()
                    if f(x[sel]).max() <= 1e-7 * model["size"]]
    return out


def judge(path, name, ref):
    """Figures of the mesh at path on model name, with ref the reference
    mesh (Msh) of the model: {"dist_max" (relative to the model size),
    "points_kept", "npoints", "volume", "volume_error", "bound",
    "unclassified" (boundary vertices whose entity the reference lacks)}.
    A mesh without classification (one node block: padapt without -geo)
    is measured to the nearest shape, its points by its corners."""
    model = MODELS[name]
    d, size = model["dim"], model["size"]
    m = read(path)
    x = m.points[:, :d]
    dt = m.point_data["gmsh:dim_tags"]
    shapes = entity_shapes(ref, name)
    dist = np.zeros(len(x))
    unclassified = 0
    if (dt[:, 0] < d).any():
        for key in set(map(tuple, dt.tolist())):
            if key[0] >= d:
                continue
            sel = np.all(dt == key, axis=1)
            names = shapes.get(key)
            if not names:
                unclassified += int(sel.sum())
                continue
            dist[sel] = np.max([model["shapes"][s][0](x[sel]) for s in names],
                               axis=0)
        points = x[dt[:, 0] == 0]
    else:  # no classification: the boundary's vertices, the corners
        onb = np.unique(_cells(m, "triangle" if d == 3 else "line"))
        dist[onb] = np.min([f(x[onb]) for f, _ in model["shapes"].values()],
                           axis=0)
        points = x[_cells(m, "vertex").ravel()]
    # the model's points: the reference's point vertices, all in the mesh
    rdt = ref.point_data["gmsh:dim_tags"]
    rp = {tuple(p) for p in ref.points[rdt[:, 0] == 0, :d].tolist()}
    mp = {tuple(p) for p in points.tolist()}
    # volume, and the polyhedral bound of the boundary facets
    if d == 3:
        t = _cells(m, "tetra")
        a, b, c, e = (x[t[:, i]] for i in range(4))
        vol = np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), e - a)).sum() / 6
        facets = _cells(m, "triangle")
    else:
        t = _cells(m, "triangle")
        a, b, c = (x[t[:, i]] for i in range(3))
        vol = np.abs(np.cross(b - a, c - a)).sum() / 2
        facets = _cells(m, "line")
    bound = 0.0
    for f in facets:
        # the facet's entity: the shapes all its vertices lie on
        common = None
        for v in f:
            s = set(shapes.get(tuple(dt[v]), []))
            common = s if common is None else common & s
        kappa = max([model["shapes"][s][1] for s in (common or [])], default=0.0)
        if kappa == 0:
            continue
        p = x[f]
        if d == 3:
            # a triangle with its vertices on a surface of curvature kappa
            # stands at most kappa Rc^2 / 2 off it (Rc: its circumradius)
            a, b, c = (np.linalg.norm(p[i] - p[(i + 1) % 3]) for i in range(3))
            area = np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0])) / 2
            rc = a * b * c / (4 * area) if area > 0 else max(a, b, c)
            bound += area * kappa * rc * rc / 2
        else:  # the segment between a chord L and its arc
            bound += kappa * np.linalg.norm(p[1] - p[0]) ** 3 / 12
    exact = exact_volume(name)
    return {"dist_max": float(dist.max()) / size, "points_kept": rp <= mp,
            "npoints": len(rp), "volume": float(vol),
            "volume_error": abs(vol - exact) / exact, "bound": bound / exact,
            "unclassified": unclassified, "nvert": len(x),
            "nelem": len(t)}


# ---- the benchmark (bench/cad.sh) ----


def loglog_svg(panels, out, title):
    """Log-log plots side by side: panels is a list of (ylabel, {series
    name: [(h, value)]}); the x axis is h."""
    W, H, M, G = 460, 380, 64, 20
    colors = {"-geo": "#c0392b", "without -geo": "#2c3e80"}
    o = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" '
         'font-family="sans-serif" font-size="13">' % (len(panels) * W, H + 60),
         '<rect width="100%" height="100%" fill="white"/>',
         '<text x="%d" y="20" text-anchor="middle">%s</text>' % (len(panels) * W / 2, title)]
    for k, (ylabel, series) in enumerate(panels):
        ox, oy = k * W, 30
        xs = [p[0] for s in series.values() for p in s]
        ys = [p[1] for s in series.values() for p in s if p[1] > 0]
        x0, x1 = math.log10(min(xs)) - 0.1, math.log10(max(xs)) + 0.1
        y0, y1 = math.log10(min(ys)) - 0.3, math.log10(max(ys)) + 0.3

        def px(v, x0=x0, x1=x1, ox=ox):
            return ox + M + (math.log10(v) - x0) / (x1 - x0) * (W - M - G)

        def py(v, y0=y0, y1=y1, oy=oy):
            return oy + H - M - (math.log10(max(v, 10 ** y0)) - y0) / (y1 - y0) * (H - M - G)

        o.append('<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="#444"/>'
                 % (ox + M, oy + G, W - M - G, H - M - G))
        for e in range(int(math.floor(x0)), int(math.ceil(x1)) + 1):
            for m_ in (1, 2, 5):
                v = m_ * 10 ** e
                if x0 <= math.log10(v) <= x1:
                    o.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>'
                             % (px(v), oy + G, px(v), oy + H - M))
                    o.append('<text x="%.1f" y="%d" text-anchor="middle">%g</text>'
                             % (px(v), oy + H - M + 18, v))
        step = max(1, int(math.ceil((y1 - y0) / 8)))
        for e in range(int(math.floor(y0)), int(math.ceil(y1)) + 1, step):
            if y0 <= e <= y1:
                v = 10 ** e
                o.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>'
                         % (ox + M, py(v), ox + W - G, py(v)))
                o.append('<text x="%d" y="%.1f" text-anchor="end">1e%d</text>'
                         % (ox + M - 6, py(v) + 4, e))
        for i, (name, pts) in enumerate(sorted(series.items())):
            pts = sorted(pts)
            c = colors.get(name.split(", ")[-1], "#333")
            dash = ' stroke-dasharray="6 4"' if name.startswith("2D") else ""
            o.append('<polyline fill="none" stroke="%s" stroke-width="2"%s points="%s"/>'
                     % (c, dash, " ".join("%.1f,%.1f" % (px(a), py(b)) for a, b in pts)))
            for a, b in pts:
                o.append('<circle cx="%.1f" cy="%.1f" r="3" fill="%s"/>' % (px(a), py(b), c))
            if k == 0:  # the legend, once, under the panels
                lx = 60 + 200 * i
                o.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="%s" '
                         'stroke-width="2"%s/>' % (lx, H + 44, lx + 30, H + 44, c, dash))
                o.append('<text x="%d" y="%d" fill="%s">%s</text>'
                         % (lx + 36, H + 48, c, name))
        o.append('<text x="%d" y="%d" text-anchor="middle">h (-hsiz)</text>'
                 % (ox + W / 2, oy + H - 22))
        o.append('<text x="%d" y="%d" transform="rotate(-90 %d %d)" text-anchor="middle">'
                 '%s</text>' % (ox + 16, oy + H / 2, ox + 16, oy + H / 2, ylabel))
    o.append("</svg>")
    with open(out, "w") as f:
        f.write("\n".join(o) + "\n")


def bench(padapt, work, hs, np_=1):
    """padapt adapt with and without -geo on both models for each h of
    hs[name]: prints the table rows and returns {model: {geo: [rows]}}."""
    import json
    import resource
    import time
    os.makedirs(work, exist_ok=True)
    rows = {}
    for name in ("cylhole", "plate"):
        step, msh = make(name, work, 0.3)
        ref = read(msh)
        for h in hs[name]:
            for geo in (True, False):
                out = os.path.join(work, "%s-%g-%s.msh" % (name, h, "geo" if geo else "plain"))
                js = out[:-4] + ".json"
                cmd = ([] if np_ <= 1 else ["mpiexec", "-n", str(np_)]) + \
                    [padapt, "adapt", msh, "-hsiz", str(h), "-out", out, "-nosol",
                     "-json", js, "-v", "-1"] + (["-geo", step] if geo else [])
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.time()
                subprocess.run(cmd, check=True, capture_output=True)
                wall = time.time() - t0
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
                rep = json.load(open(js))
                f = judge(out, name, ref)
                row = {"model": name, "h": h, "geo": geo, "elements": f["nelem"],
                       "dist": f["dist_max"], "verr": f["volume_error"],
                       "bound": f["bound"], "wall": wall, "cpu": cpu,
                       "remesh_cpu": rep.get("remesh_cpu_s", 0),
                       "proj": rep.get("projections", 0),
                       "proj_s": rep.get("projection_s", 0.0)}
                rows.setdefault(name, {}).setdefault(geo, []).append(row)
                print("%-7s h %-6g %-12s %8d elements  off the model %8.2e  "
                      "volume error %8.2e (bound %8.2e)  process CPU %6.2f s  "
                      "remesher CPU %6.2f s  projections %7d in %6.3f s"
                      % (name, h, "-geo" if geo else "without -geo", f["nelem"],
                         f["dist_max"], f["volume_error"], f["bound"], cpu,
                         row["remesh_cpu"], row["proj"], row["proj_s"]), flush=True)
    return rows


def main():
    import sys
    if len(sys.argv) < 4 or sys.argv[1] != "bench":
        sys.exit("usage: cad_judge.py bench PADAPT WORKDIR")
    padapt, work = sys.argv[2], sys.argv[3]
    hs = {"cylhole": [float(x) for x in os.environ.get(
              "HS3", "0.1 0.07 0.05 0.035 0.025").split()],
          "plate": [float(x) for x in os.environ.get(
              "HS2", "0.04 0.02 0.01 0.005 0.0025").split()]}
    rows = bench(padapt, work, hs, int(os.environ.get("NP", "1")))
    dist, verr = {}, {}
    for name, dim in (("cylhole", "3D"), ("plate", "2D")):
        for geo in (True, False):
            key = "%s, %s" % (dim, "-geo" if geo else "without -geo")
            dist[key] = [(r["h"], r["dist"]) for r in rows[name][geo]]
            verr[key] = [(r["h"], r["verr"]) for r in rows[name][geo]]
    # observed orders of the volume error with -geo
    for name in rows:
        g = rows[name][True]
        orders = ["%.2f" % (math.log(g[i + 1]["verr"] / g[i]["verr"]) /
                            math.log(g[i + 1]["h"] / g[i]["h"]))
                  for i in range(len(g) - 1)]
        print("%s: order of the volume error in h with -geo: %s" % (name, ", ".join(orders)))
    out = os.path.join(work, "cad.svg")
    loglog_svg([("largest distance to the model / model size", dist),
                ("relative volume (area) error", verr)], out,
               "padapt adapt -geo: boundary vertices on the CAD model")
    print("plot: " + out)


if __name__ == "__main__":
    main()
