#!/usr/bin/python3
"""test_fields.py -- vertex, element and boundary fields through `padapt
adapt`, judged by numpy and meshio (Debian's python3-meshio).

In a scratch directory (CTest's), with PADAPT = the CLI:
  - a .sol holding SolAtVertices (u = x + y + z, linear), SolAtTriangles or
    SolAtTetrahedra (three types in one keyword, "3 1 1 1": a smooth
    density, the constant 2.5, integer materials) and SolAtEdges or
    SolAtTriangles (10 x the boundary reference) goes with the unit square
    and cube through `padapt adapt -field u.sol -field-transfer cell3=nearest`
    (refined, then coarsened), in 2D and 3D; the output .fields.sol and the
    mesh (meshio) are judged: the integral of the density kept to 1e-12
    relative, the constant exactly 2.5, the materials in their set and all
    present, every boundary value 10 x its entity's reference, u = x + y + z
    at every vertex (1e-12);
  - the same fields come out of -out X.msh ($ElementData) and X.vtu (cell
    data) as meshio reads them, with the same integrals; a .solb input gives
    the .sol input's output; `padapt plot -color cell1` draws the field;
  - a .msh written by meshio with cell data goes through padapt adapt and
    meshio finds the density's integral kept in padapt's .msh;
  - bad input: a count that does not match names the file and line, a NaN
    names the entity, an unknown mode lists the valid ones, an unknown
    field lists the fields; nothing is written then;
  - at 2 processes (the unit cube at -hsiz 0.1, 3 iterations): the same judge,
    and a run killed in its second iteration (PADAPT_TEST_KILL_ITER) and
    restarted from its checkpoint writes the uninterrupted run's mesh and
    fields, byte for byte.
Exits 0 on success, 1 naming every mismatch otherwise.
"""
import os
import re
import subprocess
import sys

import numpy as np

try:
    import meshio
except ImportError as e:  # pragma: no cover
    print("test_fields: cannot import meshio (%s); install python3-meshio" % e,
          file=sys.stderr)
    sys.exit(1)

PADAPT = os.environ.get("PADAPT")
failures = []


def fail(msg):
    failures.append(msg)
    print("MISMATCH: " + msg, file=sys.stderr)


def run(*args, expect=0):
    cmd = [PADAPT] + [str(a) for a in args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if p.returncode != expect:
        fail("'%s' exited with %d (expected %d): %s" %
             (" ".join(cmd[1:]), p.returncode, expect, (p.stderr or p.stdout).strip()))
    return p


def read_sol(path):
    """The fields of an ASCII .sol: {keyword: [array (n, ncomp) per type]}."""
    tok = open(path).read().split()
    dim, out, i = None, {}, 0
    while i < len(tok):
        t = tok[i]
        if t == "Dimension":
            dim = int(tok[i + 1])
            i += 2
        elif t.startswith("SolAt"):
            n, nt = int(tok[i + 1]), int(tok[i + 2])
            types = [int(x) for x in tok[i + 3:i + 3 + nt]]
            sizes = [1 if k == 1 else dim if k == 2 else dim * (dim + 1) // 2
                     for k in types]
            i += 3 + nt
            vals = np.array(tok[i:i + n * sum(sizes)], float).reshape(n, sum(sizes))
            i += n * sum(sizes)
            cols = np.cumsum([0] + sizes)
            out.setdefault(t, []).extend(vals[:, cols[k]:cols[k + 1]]
                                         for k in range(nt))
        else:
            i += 1
    return out


def write_sol(path, dim, blocks):
    """blocks: [(keyword, [arrays (n, ncomp)], [types])]."""
    with open(path, "w") as f:
        f.write("MeshVersionFormatted 2\nDimension %d\n\n" % dim)
        for kw, arrays, types in blocks:
            n = len(arrays[0])
            f.write("%s\n%d\n%d %s\n" % (kw, n, len(types), " ".join(map(str, types))))
            rows = np.hstack([a.reshape(n, -1) for a in arrays])
            for r in rows:
                f.write(" ".join(repr(float(x)) for x in r) + "\n")
            f.write("\n")
        f.write("End\n")


def measures(points, cells):
    """Areas (triangles) or volumes (tetrahedra) of cells (n, 3 or 4)."""
    x = points[cells]
    if cells.shape[1] == 3:
        a, b = x[:, 1, :2] - x[:, 0, :2], x[:, 2, :2] - x[:, 0, :2]
        return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    return np.linalg.det(x[:, 1:] - x[:, :1]) / 6


def blocks(mesh, kind):
    """(cells, refs, index) of every block of a cell type of a meshio mesh."""
    return [(c.data, k) for k, c in enumerate(mesh.cells) if c.type == kind]


def mesh_parts(path, dim):
    """Points, elements and boundary entities (with references) of a .mesh."""
    m = meshio.read(path)
    ek, bk = ("triangle", "line") if dim == 2 else ("tetra", "triangle")
    el = np.vstack([c for c, _ in blocks(m, ek)])
    bd = np.vstack([c for c, _ in blocks(m, bk)])
    bref = np.concatenate([m.cell_data["medit:ref"][k] for _, k in blocks(m, bk)])
    return pad3(m.points), el, bd, bref


def pad3(points):
    """Points with three coordinates (z = 0 in 2D)."""
    return np.hstack([points, np.zeros((len(points), 3 - points.shape[1]))])


def make_input(dim, n):
    """The box mesh and its fields file u.sol; returns (points, elements)."""
    run("generate", "box%dd" % dim, n, "in%d.mesh" % dim)
    pts, el, bd, bref = mesh_parts("in%d.mesh" % dim, dim)
    c = pts[el].mean(axis=1)
    rho = np.sin(3 * c[:, 0]) * np.cos(2 * c[:, 1]) + 1.5 + c[:, 2] ** 2
    mat = 1 + (c[:, 0] > 0.5) + 2 * (c[:, 1] > 0.3)
    u = pts[:, 0] + pts[:, 1] + (pts[:, 2] if dim == 3 else 0)
    ekw, bkw = ("SolAtTriangles", "SolAtEdges") if dim == 2 else \
        ("SolAtTetrahedra", "SolAtTriangles")
    write_sol("u%d.sol" % dim, dim, [
        ("SolAtVertices", [u], [1]),
        (ekw, [rho, np.full(len(el), 2.5), mat.astype(float)], [1, 1, 1]),
        (bkw, [10.0 * bref], [1])])
    return pts, el, rho, mat


def judge(tag, dim, pts0, el0, rho0, out_mesh, fields):
    pts, el, bd, bref = mesh_parts(out_mesh, dim)
    f = read_sol(fields)
    ekw, bkw = ("SolAtTriangles", "SolAtEdges") if dim == 2 else \
        ("SolAtTetrahedra", "SolAtTriangles")
    rho, const, mat = (a[:, 0] for a in f[ekw][:3])
    i0 = np.dot(measures(pts0, el0), rho0)
    i1 = np.dot(measures(pts, el), rho)
    if not abs(i1 - i0) <= 1e-12 * abs(i0):
        fail("%s: integral %.17g -> %.17g" % (tag, i0, i1))
    if not np.all(const == 2.5):
        fail("%s: the constant moved (%s)" % (tag, np.unique(const)[:5]))
    if set(np.unique(mat)) != {1.0, 2.0, 3.0, 4.0}:
        fail("%s: materials %s" % (tag, np.unique(mat)))
    bc = f[bkw][0][:, 0]
    if len(bc) != len(bd) or not np.all(bc == 10.0 * bref):
        fail("%s: boundary values do not follow the references" % tag)
    u = f["SolAtVertices"][0][:, 0]
    ue = pts[:, 0] + pts[:, 1] + (pts[:, 2] if dim == 3 else 0)
    if not np.allclose(u, ue, rtol=0, atol=1e-12):
        fail("%s: the linear vertex field is not reproduced (%.3g)" %
             (tag, np.abs(u - ue).max()))
    return i0


def cell_integral(path, dim, name):
    """Integral of cell data `name` over the elements of a .msh/.vtu."""
    m = meshio.read(path)
    ek = "triangle" if dim == 2 else "tetra"
    tot = 0.0
    for c, k in blocks(m, ek):
        v = np.asarray(m.cell_data[name][k]).reshape(len(c), -1)[:, 0]
        tot += np.dot(measures(pad3(m.points), c), v)
    return tot


def main():
    for dim, n, fine, coarse in ((2, 6, 0.05, 0.4), (3, 3, 0.15, 0.6)):
        pts0, el0, rho0, _ = make_input(dim, n)
        i0 = None
        for h, what in ((fine, "refined"), (coarse, "coarsened")):
            tag = "%dD %s" % (dim, what)
            out = "o%d%s" % (dim, what[0])
            run("adapt", "in%d.mesh" % dim, "-hsiz", h, "-field", "u%d.sol" % dim,
                "-field-transfer", "cell3=nearest", "-out", out + ".mesh", "-v", -1)
            i0 = judge(tag, dim, pts0, el0, rho0, out + ".mesh", out + ".fields.sol")
        # the same fields in .msh and .vtu, as meshio reads them
        for ext in (".msh", ".vtu"):
            out = "o%dm%s" % (dim, ext)
            run("adapt", "in%d.mesh" % dim, "-hsiz", fine, "-field", "u%d.sol" % dim,
                "-out", out, "-nosol", "-v", -1)
            i1 = cell_integral(out, dim, "cell1")
            if not abs(i1 - i0) <= 1e-12 * abs(i0):
                fail("%dD %s: meshio's integral %.17g, input's %.17g" % (dim, ext, i1, i0))
        # .solb out and back in: the values of the .sol written by the same
        # run (a remesh that changes nothing carries them as they are)
        for ext in (".solb", ".sol"):
            run("adapt", "in%d.mesh" % dim, "-hsiz", fine, "-field", "u%d.sol" % dim,
                "-outfield", "b%d%s" % (dim, ext), "-out", "b%d%s.mesh" % (dim, ext[1:]),
                "-v", -1)
        run("adapt", "b%dsolb.mesh" % dim, "-hsiz", 1, "-field", "b%d.solb" % dim,
            "-out", "c%d.mesh" % dim, "-outfield", "c%df.sol" % dim, "-noinsert",
            "-noswap", "-nomove", "-nosurf", "-v", -1)
        a, b = read_sol("b%d.sol" % dim), read_sol("c%df.sol" % dim)
        same = sorted(a) == sorted(b) and all(
            len(a[k]) == len(b[k]) and all(np.array_equal(np.sort(x, axis=0), np.sort(y, axis=0))
                                           for x, y in zip(a[k], b[k])) for k in a)
        if not same:
            fail("%dD: the fields through .solb differ from the .sol's" % dim)

    # meshio writes the cell data, padapt carries it, meshio reads it back
    m = meshio.read("in3.mesh")
    cd = {}
    for c in m.cells:
        cen = m.points[c.data].mean(axis=1)
        cd.setdefault("rho", []).append(1 + cen[:, 0] * cen[:, 1])
    cells = [(c.type, c.data) for c in m.cells]
    meshio.write("mio.msh", meshio.Mesh(m.points, cells, cell_data=cd),
                 file_format="gmsh22", binary=False)
    i0 = sum(np.dot(measures(m.points, c.data), r)
             for c, r in zip(m.cells, cd["rho"]) if c.type == "tetra")
    run("adapt", "mio.msh", "-hsiz", 0.2, "-out", "mio_out.msh", "-nosol", "-v", -1)
    i1 = cell_integral("mio_out.msh", 3, "rho")
    if not abs(i1 - i0) <= 1e-12 * abs(i0):
        fail("meshio's cell data: integral %.17g -> %.17g" % (i0, i1))

    # in parallel: the same judge; a run killed in its second iteration
    # and restarted from its checkpoint writes the uninterrupted run's
    # mesh and fields
    mpiexec = os.environ.get("MPIEXEC")
    if mpiexec:
        pts0, el0, rho0, _ = make_input(3, 3)
        par = [mpiexec, "-n", "2", PADAPT, "adapt", "in3.mesh", "-hsiz", "0.1",
               "-field", "u3.sol", "-field-transfer", "cell3=nearest", "-v", "-1"]
        p = subprocess.run(par + ["-out", "par3.mesh"], capture_output=True,
                           text=True, timeout=600)
        if p.returncode:
            fail("np=2: %s" % p.stderr.strip())
        else:
            judge("3D np=2", 3, pts0, el0, rho0, "par3.mesh", "par3.fields.sol")
            env = dict(os.environ, PADAPT_TEST_KILL_ITER="2")
            subprocess.run(par + ["-out", "ck3.mesh", "-checkpoint", "ck"], env=env,
                           capture_output=True, timeout=600)
            p = subprocess.run([mpiexec, "-n", "2", PADAPT, "adapt", "-restart", "ck",
                                "-hsiz", "0.1", "-out", "ck3.mesh", "-v", "-1"],
                               capture_output=True, text=True, timeout=600)
            same = p.returncode == 0 and all(
                open(a, "rb").read() == open(b, "rb").read()
                for a, b in (("par3.mesh", "ck3.mesh"),
                             ("par3.fields.sol", "ck3.fields.sol")))
            if not same:
                fail("np=2: the restarted run differs from the uninterrupted one (%s)"
                     % p.stderr.strip())

    # padapt plot -color FIELD draws an element field, its range in the legend
    run("plot", "o2r.mesh", "o2r.svg", "-field", "o2r.fields.sol", "-color", "cell1")
    svg = open("o2r.svg").read() if os.path.exists("o2r.svg") else ""
    rho = read_sol("o2r.fields.sol")["SolAtTriangles"][0][:, 0]
    if "coloured by cell1" not in svg or ">%.4g<" % rho.max() not in svg:
        fail("plot -color cell1: no title or legend of the field")
    p = run("plot", "o2r.mesh", "o2x.svg", "-color", "rho", expect=1)
    if "element fields: none" not in p.stderr or os.path.exists("o2x.svg"):
        fail("plot -color of no field: %r" % p.stderr)

    # bad input: the message names the place; nothing written
    text = open("u2.sol").read()
    ne = int(re.search(r"SolAtTriangles\n(\d+)", text).group(1))
    bad = text.replace("SolAtTriangles\n%d\n" % ne, "SolAtTriangles\n%d\n" % (ne - 1), 1)
    lines = bad.split("\n")
    kw = lines.index("SolAtTriangles") + 1
    drop = kw + 3  # the first row of the keyword
    open("bad_count.sol", "w").write("\n".join(lines[:drop - 1] + lines[drop:]))
    p = run("adapt", "in2.mesh", "-hsiz", 0.1, "-field", "bad_count.sol",
            "-out", "bad.mesh", expect=1)
    if "bad_count.sol:%d:" % kw not in p.stderr or "triangles" not in p.stderr:
        fail("count mismatch: %r" % p.stderr)
    nan = text.split("\n")
    row = nan.index("SolAtTriangles") + 5  # the second triangle's row
    nan[row - 1] = "nan 2.5 1.0"
    open("bad_nan.sol", "w").write("\n".join(nan))
    p = run("adapt", "in2.mesh", "-hsiz", 0.1, "-field", "bad_nan.sol",
            "-out", "bad.mesh", expect=1)
    if "element 2 is not finite" not in p.stderr or "bad_nan.sol" not in p.stderr:
        fail("NaN: %r" % p.stderr)
    p = run("adapt", "in2.mesh", "-hsiz", 0.1, "-field", "u2.sol",
            "-field-transfer", "cell1=cubic", "-out", "bad.mesh", expect=1)
    if not all(w in p.stderr for w in ("cubic", "conservative", "bounded", "nearest")):
        fail("unknown mode: %r" % p.stderr)
    p = run("adapt", "in2.mesh", "-hsiz", 0.1, "-field", "u2.sol",
            "-field-transfer", "rho=bounded", "-out", "bad.mesh", expect=1)
    if "no field 'rho'" not in p.stderr or "cell1, cell2, cell3" not in p.stderr:
        fail("unknown field: %r" % p.stderr)
    for f in ("bad.mesh", "bad.sol", "bad.fields.sol"):
        if os.path.exists(f):
            fail("%s written after a failure" % f)

    if failures:
        print("test_fields: %d mismatch(es)" % len(failures), file=sys.stderr)
        return 1
    print("test_fields: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
