#!/usr/bin/python3
"""test_pictures.py -- the SVG pictures of `padapt stats -svg`, `padapt adapt
-svg` and `padapt plot`, judged by parsing them (xml.etree) and comparing
with what meshio and the JSON statistics say.

In a scratch directory (CTest's), with PADAPT = the CLI and PADAPT_SRC the
source tree:
  - stats -svg: well-formed, 9 edge-length and 5 quality bars whose heights
    are proportional to the JSON's edge_hist / quality_hist, the in-range band
    covering exactly the bars of [0.7071, 1.4142);
  - adapt -svg (1 and 2 processes): two series (before, after) of 9 + 5 bars;
  - plot 2D: one polygon per triangle and one boundary line per boundary
    edge; with -window, one polygon per triangle whose bounding box meets the
    window (counted here from the coordinates); -color ref gives one colour
    per reference, different between references;
  - plot 3D: the polygons of a cut of the unit cube cover the unit square
    (area 1) both through a grid plane (faces in the plane drawn once) and
    off it; the cut of rod3d draws (or merges) every tetrahedron that the
    plane crosses, counted here;
  - a mesh finer than the pixels is merged into at most one cell per
    2 x 2 pixels, and every triangle is accounted for;
  - the same command writes the same bytes;
  - errors (unknown option, .png output, bad or empty window, -cut on a 2D
    mesh) exit 1 with a message naming the problem and write nothing.
Exits 0 when every check passes, 1 naming each failure.
"""
import json
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

import meshio
import numpy as np

PADAPT = os.environ.get("PADAPT")
SRC = os.environ.get("PADAPT_SRC", os.path.join(os.path.dirname(__file__), "..", ".."))
MPIEXEC = os.environ.get("MPIEXEC", "mpiexec")
NS = "{http://www.w3.org/2000/svg}"
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        failures.append(what)


class Result:
    def __init__(self, returncode, stdout, stderr):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


# Independent commands run side by side: most of a small command's time is
# MPI start-up, spent waiting.
MAX_RUNNING = 8


def run_all(cmds):
    """Run every (args, nprocs) of cmds, MAX_RUNNING at a time; the results
    in the same order."""
    results, running, todo = [None] * len(cmds), [], list(enumerate(cmds))
    while todo or running:
        while todo and len(running) < MAX_RUNNING:
            k, (args, np_) = todo.pop(0)
            cmd = [PADAPT] + args
            if np_ > 1:
                cmd = [MPIEXEC, "-n", str(np_)] + cmd
            running.append((k, subprocess.Popen(cmd, stdout=subprocess.PIPE,
                                                stderr=subprocess.PIPE, text=True)))
        k, p = running.pop(0)
        out, err = p.communicate()
        results[k] = Result(p.returncode, out, err)
    return results


def run(args, np_=1):
    return run_all([(args, np_)])[0]


def parse(path):
    """The SVG's root, or None (reported) when missing or not well-formed."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as e:
        check(False, "%s parses as XML (%s)" % (path, e))
        return None
    check(root.tag == NS + "svg" and len(root) > 2, "%s: an <svg> with content" % path)
    return root


def with_class(root, tag, cls):
    return [e for e in root.iter(NS + tag) if cls in e.get("class", "").split()]


def group(root, cls):
    g = with_class(root, "g", cls)
    return g[0] if g else ET.Element("g")


def points(poly):
    return [tuple(map(float, p.split(","))) for p in poly.get("points").split()]


def area(pts):
    a = 0.0
    for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1]):
        a += x0 * y1 - x1 * y0
    return abs(a) / 2


def bars(root, kind, series):
    """The bars of one chart and series, left to right: (x, width, height)."""
    rs = [r for r in with_class(root, "rect", "bar")
          if kind in r.get("class").split() and series in r.get("class").split()]
    return sorted((float(r.get("x")), float(r.get("width")), float(r.get("height")))
                  for r in rs)


def check_heights(tag, bs, hist):
    """Bar heights proportional to the counts (two-decimal coordinates)."""
    top = max(hist)
    hmax = max(b[2] for b in bs)
    ok = len(bs) == len(hist) and top > 0 and all(
        abs(b[2] - hmax * h / top) < 0.02 for b, h in zip(bs, hist))
    check(ok, "%s: bar heights proportional to the counts %s (got %s)"
          % (tag, hist, [b[2] for b in bs]))


def mesh_tris(path):
    m = meshio.read(path)
    tris = np.concatenate([c.data for c in m.cells if c.type == "triangle"])
    lines = sum(len(c.data) for c in m.cells if c.type == "line")
    refs = np.concatenate([r for c, r in zip(m.cells, m.cell_data["medit:ref"])
                           if c.type == "triangle"])
    return m.points[:, :2], tris, lines, refs


PLATE = os.path.join(SRC, "tests", "data", "plate2d.mesh")
ROD = os.path.join(SRC, "tests", "data", "rod3d.mesh")
WINDOW = (0.1, 0.2, 0.45, 0.5)
CUTS = ("z=0.5", "x=0.6")  # through grid vertices, and between them
ERRORS = [  # (arguments, the message expected), each writing its own file
    (["plot", PLATE, "e0.svg", "-frobnicate"], "unknown option"),
    (["plot", PLATE, "e1.png"], "only SVG"),
    (["plot", PLATE, "e2.svg", "-window", "1", "0", "0", "1"], "-window needs"),
    (["plot", PLATE, "e4.svg", "-window", "5", "5", "6", "6"], "holds no element"),
    (["plot", PLATE, "e5.svg", "-cut", "z=0.5"], "need a 3D mesh"),
    (["plot", "cube.mesh", "e7.svg", "-cut", "z=7"], "does not cut"),
    (["stats", PLATE, "-svg", "e8.png"], "only SVG"),
    (["adapt", PLATE, "-hsiz", "0.07", "-out", "e9.mesh", "-svg", "e9.png"],
     "only SVG"),
]


def write_sizes():
    """sizes.sol: a size field on plate2d, fine near (0.5, 0.3), so that the
    edge lengths in it spread over several bins."""
    xy, _, _, _ = mesh_tris(PLATE)
    h = 0.02 + 0.1 * np.hypot(xy[:, 0] - 0.5, xy[:, 1] - 0.3)
    with open("sizes.sol", "w") as f:
        f.write("MeshVersionFormatted 2\nDimension 2\nSolAtVertices\n%d\n1 1\n"
                % len(h))
        f.writelines("%.6f\n" % v for v in h)
        f.write("End\n")


def write_refs_mesh():
    """plate2d with element reference 2 left of x = 0.5 (1 elsewhere)."""
    xy, tris, _, _ = mesh_tris(PLATE)
    cent = xy[tris].mean(axis=1)
    out, section, k = [], None, 0
    for line in open(PLATE).read().splitlines():
        w = line.split()
        if w and w[0][0].isalpha():
            section, k = w[0], 0
        elif section == "Triangles" and len(w) == 4:
            if cent[k, 0] < 0.5:
                w[3] = "2"
            line = " ".join(w)
            k += 1
        out.append(line)
    open("refs.mesh", "w").write("\n".join(out) + "\n")


def check_stats(r):
    check(r.returncode == 0, "stats -svg: exit 0 (%d: %s)" % (r.returncode, r.stderr))
    root = parse("s.svg")
    if root is None:
        return
    js = json.load(open("s.json"))
    eb, qb = bars(root, "edge", "s0"), bars(root, "quality", "s0")
    check(len(eb) == 9 and len(qb) == 5, "stats -svg: 9 edge and 5 quality bars "
          "(%d, %d)" % (len(eb), len(qb)))
    if len(eb) == 9 and len(qb) == 5:
        check_heights("stats -svg edges", eb, js["edge_hist"][:9])
        check_heights("stats -svg qualities", qb, js["quality_hist"])
        band = with_class(root, "rect", "inrange")
        check(len(band) == 1, "stats -svg: one in-range band (%d)" % len(band))
        if band:
            x0 = float(band[0].get("x"))
            x1 = x0 + float(band[0].get("width"))
            inside = [x0 <= b[0] and b[0] + b[1] <= x1 for b in eb]
            check(inside == [False] * 3 + [True] * 3 + [False] * 3,
                  "stats -svg: the band covers the bars of [0.7071, 1.4142) "
                  "exactly (%s)" % inside)


def check_adapt(np_, r):
    tag = "a%d" % np_
    check(r.returncode == 0, "adapt -svg at %d process(es): exit 0 (%d: %s)"
          % (np_, r.returncode, r.stderr[-300:]))
    root = parse(tag + ".svg")
    if root is None:
        return
    n = [len(bars(root, k, s)) for k in ("edge", "quality") for s in ("s0", "s1")]
    check(n == [9, 9, 5, 5], "adapt -svg at %d: before and after, 9 + 5 bars "
          "each (%s)" % (np_, n))
    text = " ".join(t.text or "" for t in root.iter(NS + "text"))
    check("before:" in text and "after:" in text,
          "adapt -svg at %d: the legend names before and after" % np_)
    check(len(with_class(root, "rect", "inrange")) == 1,
          "adapt -svg at %d: the in-range band" % np_)


def check_plot2d(r, r2, rw, rr):
    xy, tris, nline, _ = mesh_tris(PLATE)
    check(r.returncode == 0, "plot 2D: exit 0 (%s)" % r.stderr)
    root = parse("p.svg")
    if root is not None:
        polys = list(group(root, "elements").iter(NS + "polygon"))
        check(len(polys) == len(tris), "plot 2D: one polygon per triangle (%d, %d)"
              % (len(polys), len(tris)))
        lines = list(group(root, "boundary").iter(NS + "line"))
        check(len(lines) == nline, "plot 2D: one thick line per boundary edge "
              "(%d, %d)" % (len(lines), nline))
        check(len({p.get("fill") for p in polys}) > 5, "plot 2D: coloured by "
              "quality (several colours)")
        check(len(with_class(root, "rect", "legend")) >= 10, "plot 2D: a colour "
              "legend")
        check(r2.returncode == 0 and open("p.svg", "rb").read() ==
              open("p2.svg", "rb").read(), "plot 2D: the same bytes twice")

    # zoom: the triangles whose bounding box meets the window
    lo, hi = xy[tris].min(axis=1), xy[tris].max(axis=1)
    meet = int(((hi[:, 0] >= WINDOW[0]) & (lo[:, 0] <= WINDOW[2]) &
                (hi[:, 1] >= WINDOW[1]) & (lo[:, 1] <= WINDOW[3])).sum())
    root = parse("w.svg")
    if root is not None:
        polys = list(group(root, "elements").iter(NS + "polygon"))
        check(len(polys) == meet and 0 < meet < len(tris),
              "plot -window: one polygon per triangle meeting the window "
              "(%d, %d)" % (len(polys), meet))
        m = re.search(r"(\d+) elements outside", rw.stdout)
        check(m and int(m.group(1)) == len(tris) - meet,
              "plot -window: the culled count is printed (%s)" % rw.stdout.strip())

    # by reference: one colour per reference
    _, tris2, _, refs2 = mesh_tris("refs.mesh")
    check(set(refs2) == {1, 2}, "refs.mesh: element references 1 and 2 (%s)"
          % sorted(set(refs2)))
    root = parse("r.svg")
    if root is not None:
        fills = [p.get("fill") for p in group(root, "elements").iter(NS + "polygon")]
        by = {ref: {f for f, rr in zip(fills, refs2) if rr == ref} for ref in (1, 2)}
        check(rr.returncode == 0 and len(fills) == len(tris2) and
              len(by[1]) == 1 and len(by[2]) == 1 and by[1] != by[2],
              "plot -color ref: one colour per reference, different (%s)" % by)


def check_plot3d(rcuts, rrod):
    for cut, r in zip(CUTS, rcuts):
        check(r.returncode == 0, "plot 3D -cut %s: exit 0 (%s)" % (cut, r.stderr))
        root = parse("c-%s.svg" % cut)
        if root is None:
            continue
        frame = with_class(root, "rect", "frame")[0]
        px = float(frame.get("width")) / 1.04  # the unit square plus 2 % margins
        areas = [area(points(p)) for p in group(root, "elements").iter(NS + "polygon")]
        a = sum(areas)
        check(abs(a / px**2 - 1) < 1e-3, "plot 3D -cut %s: the polygons cover the "
              "unit square once (area %.5f)" % (cut, a / px**2))
        check(areas and min(areas) > 1 and " 0 sub-pixel" in r.stdout,
              "plot 3D -cut %s: no degenerate polygon nor merged cell (from a "
              "tetrahedron touching the plane; smallest %.3g px2; %s)"
              % (cut, min(areas) if areas else 0, r.stdout.strip()))
    m = meshio.read(ROD)
    tets = np.concatenate([c.data for c in m.cells if c.type == "tetra"])
    # crossed: a vertex on each side strictly, or a face in the plane with
    # the fourth vertex below (a vertex on the plane counts as above)
    s = m.points[tets][:, :, 2] - 0.1
    above, below, on = (s > 0).sum(axis=1), (s < 0).sum(axis=1), (s == 0).sum(axis=1)
    ncut = int((((above > 0) & (below > 0)) | ((on == 3) & (below == 1))).sum())
    mm = re.search(r"(\d+) polygons, (\d+) sub-pixel elements merged", rrod.stdout)
    check(rrod.returncode == 0 and mm and int(mm.group(1)) + int(mm.group(2)) == ncut,
          "plot rod3d -cut z=0.1: every crossed tetrahedron drawn or merged "
          "(%s; %d crossed)" % (rrod.stdout.strip(), ncut))
    root = parse("rod.svg")
    if root is not None and mm:
        n = len(list(group(root, "elements").iter(NS + "polygon")))
        check(n == int(mm.group(1)), "plot rod3d: as many polygons as printed")


def check_large(r):
    root = parse("big.svg")
    if root is None:
        return
    polys = len(list(group(root, "elements").iter(NS + "polygon")))
    cells = sum(p.get("d").count("M") for p in group(root, "cells").iter(NS + "path"))
    mm = re.search(r"(\d+) sub-pixel elements merged", r.stdout)
    merged = int(mm.group(1)) if mm else -1
    check(polys + merged == 20000 and cells <= 50 * 50 and merged > 0,
          "plot of 20 000 sub-pixel triangles at 100 px: merged into %d cells "
          "(<= 2500), %d polygons, %d merged" % (cells, polys, merged))
    check(os.path.getsize("big.svg") < 300000, "plot of a fine mesh stays small "
          "(%d bytes)" % os.path.getsize("big.svg"))


def check_errors(results):
    for (args, msg), r in zip(ERRORS, results):
        out = [a for a in args if a.startswith("e") and a[1].isdigit()]
        check(r.returncode == 1 and msg in r.stderr and
              not any(os.path.exists(f) for f in out),
              "%s %s: exit 1, '%s', nothing written (%d: %s)"
              % (args[0], " ".join(args[3:]) or args[2], msg, r.returncode,
                 r.stderr.strip()))


def main():
    if not PADAPT:
        print("test_pictures: PADAPT is not set", file=sys.stderr)
        return 1
    for f in os.listdir("."):
        if f.endswith((".svg", ".png", ".json", ".mesh", ".sol")):
            os.remove(f)
    write_refs_mesh()
    write_sizes()
    run_all([(["generate", "box3d", "4", "cube.mesh"], 1),
             (["generate", "box2d", "100", "big.mesh"], 1)])  # 20 000 triangles
    cmds = {
        "stats": ["stats", PLATE, "-met", "sizes.sol", "-json", "s.json",
                  "-svg", "s.svg"],
        "adapt1": ["adapt", PLATE, "-hsiz", "0.1", "-out", "a1-out.mesh",
                   "-nosol", "-svg", "a1.svg"],
        "plot": ["plot", PLATE, "p.svg"],
        "plot2": ["plot", PLATE, "p2.svg"],
        "window": ["plot", PLATE, "w.svg", "-window"] + [str(w) for w in WINDOW],
        "refs": ["plot", "refs.mesh", "r.svg", "-color", "ref"],
        "rod": ["plot", ROD, "rod.svg", "-cut", "z=0.1", "-color", "ref"],
        "big": ["plot", "big.mesh", "big.svg", "-width", "100"],
        "nodir": ["stats", PLATE, "-json", "n.json", "-svg", "nodir/n.svg"],
    }
    for cut in CUTS:
        cmds[cut] = ["plot", "cube.mesh", "c-%s.svg" % cut, "-cut", cut]
    keys = list(cmds)
    res = run_all([(cmds[k], 1) for k in keys] +
                  [(["adapt", PLATE, "-hsiz", "0.1", "-out", "a2-out.mesh",
                     "-nosol", "-svg", "a2.svg"], 2)] +
                  [(args, 1) for args, _ in ERRORS])
    r = dict(zip(keys, res))
    check_stats(r["stats"])
    check(r["nodir"].returncode != 0 and not os.path.exists("n.json"),
          "stats -svg into a missing directory: exit 1, no JSON either")
    check_adapt(1, r["adapt1"])
    check_adapt(2, res[len(keys)])
    check_plot2d(r["plot"], r["plot2"], r["window"], r["refs"])
    check_plot3d([r[c] for c in CUTS], r["rod"])
    check_large(r["big"])
    check_errors(res[len(keys) + 1:])
    check(not [f for f in os.listdir(".") if ".tmp." in f], "no temporary left")
    if failures:
        print("%d failure(s):" % len(failures))
        for f in failures:
            print("  " + f)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
