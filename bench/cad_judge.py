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
