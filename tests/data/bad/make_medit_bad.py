#!/usr/bin/env python3
"""Regenerate the Medit corpus of tests/data/bad: the valid base meshes
base2d.mesh and base3d.mesh, the malformed medit_* (.mesh, .meshb) and sol_*
(.sol, .solb) files, and medit.expected.

medit.expected has one line per malformed file: FILE<TAB>FRAGMENT, where
FRAGMENT is a substring the error message must contain. Mesh files are checked
with `padapt convert FILE out.mesh`; solution files with
`padapt stats base2d.mesh -met FILE` (base3d.mesh for sol_3d_*). Every check
expects a failure whose message names the file and contains FRAGMENT.

Run from anywhere: python3 make_medit_bad.py (writes next to this script).
Binary files are written little-endian, the layout of libMeshb: code word 1,
version, then per keyword: code (int32), next keyword position (int32 for
versions 1-2, int64 for 3-4), record count (int32, int64 in version 4), data.
"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
expected = []


def put(name, data, fragment=None):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(os.path.join(HERE, name), mode) as f:
        f.write(data)
    if fragment is not None:
        assert "\t" not in fragment and "\n" not in fragment
        expected.append((name, fragment))


# ---------------------------------------------------------------- base meshes

def orient(x, verts):
    """Reorder a simplex so that its signed volume is positive."""
    v = list(verts)
    if len(v) == 3:
        (ax, ay), (bx, by), (cx, cy) = (x[i][:2] for i in v)
        det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    else:
        a, b, c, d = (x[i] for i in v)
        u = [b[k] - a[k] for k in range(3)]
        w = [c[k] - a[k] for k in range(3)]
        z = [d[k] - a[k] for k in range(3)]
        det = (u[0] * (w[1] * z[2] - w[2] * z[1]) - u[1] * (w[0] * z[2] - w[2] * z[0])
               + u[2] * (w[0] * z[1] - w[1] * z[0]))
    assert det != 0
    if det < 0:
        v[-1], v[-2] = v[-2], v[-1]
    return v


def boundary(x, cells, ref_of):
    """Faces that belong to one cell only, oriented outwards, with refs."""
    count = {}
    for c in cells:
        for i in range(len(c)):
            f = [c[j] for j in range(len(c)) if j != i]
            count.setdefault(tuple(sorted(f)), []).append((c, i))
    out = []
    for key, owners in sorted(count.items()):
        if len(owners) != 1:
            continue
        c, i = owners[0]
        f = [c[j] for j in range(len(c)) if j != i]
        # Outward (as pa__elem_face): the face followed by the opposite
        # vertex is a positive triangle in 2D, a negative tetrahedron in 3D.
        positive = orient(x, f + [c[i]]) == f + [c[i]]
        if positive != (len(f) == 2):
            f[-1], f[-2] = f[-2], f[-1]
        out.append((f, ref_of([x[v] for v in f])))
    return out


def mesh_text(dim, x, cells, bdry, version=2):
    kw = "Triangles" if dim == 2 else "Tetrahedra"
    bkw = "Edges" if dim == 2 else "Triangles"
    lines = ["MeshVersionFormatted %d" % version, "", "Dimension %d" % dim, "",
             "Vertices", str(len(x))]
    lines += [" ".join("%g" % c for c in p[:dim]) + " 0" for p in x]
    lines += ["", kw, str(len(cells))]
    lines += [" ".join(str(v + 1) for v in c) + " 1" for c in cells]
    lines += ["", bkw, str(len(bdry))]
    lines += [" ".join(str(v + 1) for v in f) + " %d" % r for f, r in bdry]
    lines += ["", "End", ""]
    return "\n".join(lines)


def box_ref(pts):
    for k, (lo, hi) in enumerate(((1, 2), (3, 4), (5, 6))):
        if k < len(pts[0]) and all(p[k] == 0 for p in pts):
            return lo
        if k < len(pts[0]) and all(p[k] == 1 for p in pts):
            return hi
    raise AssertionError(pts)


# 2D: the unit square, 2 x 2 squares of two triangles (9 vertices).
X2 = [(i / 2, j / 2) for j in range(3) for i in range(3)]
T2 = []
for j in range(2):
    for i in range(2):
        a, b, c, d = j * 3 + i, j * 3 + i + 1, (j + 1) * 3 + i + 1, (j + 1) * 3 + i
        T2 += [orient(X2, [a, b, c]), orient(X2, [a, c, d])]
B2 = boundary(X2, T2, box_ref)
BASE2D = mesh_text(2, X2, T2, B2)
put("base2d.mesh", BASE2D)

# 3D: the unit cube in 6 tetrahedra around the diagonal (0,0,0)-(1,1,1).
X3 = [(i, j, k) for k in range(2) for j in range(2) for i in range(2)]
T3 = []
for perm in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
    p = [0, 0, 0]
    path = [0]
    for axis in perm:
        p[axis] = 1
        path.append(p[0] + 2 * p[1] + 4 * p[2])
    T3.append(orient(X3, path))
B3 = boundary(X3, T3, box_ref)
BASE3D = mesh_text(3, X3, T3, B3)
put("base3d.mesh", BASE3D)


def line_of(text, needle, nth=1):
    """1-based line number of the nth line equal to needle."""
    found = 0
    for i, line in enumerate(text.split("\n")):
        if line == needle:
            found += 1
            if found == nth:
                return i + 1
    raise AssertionError(needle)


L2 = BASE2D.split("\n")


def edit(lines, i, new):
    """Copy of lines with line i (1-based) replaced by new (a list)."""
    return lines[:i - 1] + new + lines[i:]


# ----------------------------------------------------------- ASCII .mesh files

nv = len(X2)
vline = line_of(BASE2D, "Vertices")          # keyword; count at +1
tline = line_of(BASE2D, "Triangles")
eline = line_of(BASE2D, "Edges")

# Truncated in the middle of the last triangle.
cut = "\n".join(L2[:tline + 1 + len(T2) - 1]) + "\n1 2"
put("medit_truncated.mesh", cut, ":%d: Triangles: count 8 does not fit" % (tline + 1))
# Cut inside the last vertex: the count fits, the data ends early.
cut = "\n".join(L2[:vline + nv]) + "\n1 1"
put("medit_truncated_vertex.mesh", cut, "end of file in Vertices")

# More vertices announced than given: the next keyword is read as a number.
t = edit(L2, vline + 1, [str(nv + 3)])
put("medit_count_large.mesh", "\n".join(t), ":%d:" % tline)

# Fewer vertices announced than given: a number where a keyword should be.
t = edit(L2, vline + 1, [str(nv - 1)])
put("medit_count_small.mesh", "\n".join(t), ":%d:" % (vline + 1 + nv))

t = edit(L2, tline + 1, ["-3"])
put("medit_negative_count.mesh", "\n".join(t), "negative count")

t = L2[:vline] + L2[vline + 1 + nv + 1:]   # "Vertices" directly followed by "Triangles"
put("medit_missing_count.mesh", "\n".join(t), "number of Vertices")

t = edit(L2, tline + 3, ["1 2 99 1"])
put("medit_index_range.mesh", "\n".join(t), ":%d:" % (tline + 3))

t = edit(L2, eline + 4, ["0 3 1"])
put("medit_index_zero.mesh", "\n".join(t), "indices start at 1")

t = edit(L2, vline + 4, ["nan 0.5 0"])
put("medit_nan.mesh", "\n".join(t), ":%d:" % (vline + 4))

t = edit(L2, vline + 5, ["0.5 -inf 0"])
put("medit_inf.mesh", "\n".join(t), "infinite")

t = edit(L2, vline + 3, ["0.5 abc 0"])
put("medit_nonnumeric.mesh", "\n".join(t), ":%d:" % (vline + 3))

t = edit(L2, tline + 2, ["1 2 3.5 1"])
put("medit_real_index.mesh", "\n".join(t), "expected an integer in Triangles")

# A keyword padapt does not know is skipped with its data; a misspelt
# Triangles leaves vertices and no element, refused naming the keyword.
t = edit(L2, tline, ["Triangle"])
put("medit_unknown_keyword.mesh", "\n".join(t),
    ":%d: vertices but no Triangles nor Tetrahedra, and keywords padapt does "
    "not know were skipped: Triangle" % tline)

t = [l for l in L2 if not l.startswith("Dimension")]
put("medit_no_dimension.mesh", "\n".join(t), "missing Dimension")

t = [("Dimension 4" if l.startswith("Dimension") else l) for l in L2]
put("medit_bad_dimension.mesh", "\n".join(t), "Dimension must be 2 or 3")

t = [("MeshVersionFormatted 9" if l.startswith("MeshVersion") else l) for l in L2]
put("medit_bad_version.mesh", "\n".join(t), "MeshVersionFormatted must be 1 to 4")

t = L2[:-2] + ["Tetrahedra", "1", "1 2 3 4 1", "", "End", ""]
put("medit_tet_in_2d.mesh", "\n".join(t), "Tetrahedra in a mesh of Dimension 2")

t = L2[:-2] + ["Quadrilaterals", "1", "1 2 5 4 1", "", "End", ""]
put("medit_quads.mesh", "\n".join(t), "Quadrilaterals are not supported")

# Triangles before Vertices, one index too large: checked once the file is read.
tri = L2[tline - 1:tline + 1 + len(T2)]
tri[4] = "1 2 10 1"
t = L2[:vline - 1] + tri + [""] + L2[vline - 1:tline - 1] + L2[tline + 1 + len(T2):]
put("medit_deferred_index.mesh", "\n".join(t), ":%d:" % vline)

t = L2[:-2] + ["Ridges", "2", "1", "20", "", "End", ""]
put("medit_ridge_range.mesh", "\n".join(t), "ridge 2: edge index 20")

put("medit_empty.mesh", "", "missing Dimension")
put("medit_binary_garbage.mesh", bytes(range(256)) * 4, "expected a keyword")

# ---------------------------------------------------------- binary .meshb files


class Meshb:
    """Build a binary Medit file keyword by keyword, recording offsets."""

    def __init__(self, ver, dim, endian="<", code=1, with_dim=True):
        self.ver, self.dim, self.e = ver, dim, endian
        self.buf = struct.pack(endian + "ii", code, ver)
        self.offsets = {}
        if with_dim:
            self.kwd(3, b"", info=struct.pack(endian + "i", dim))

    def pos(self, v):
        return struct.pack(self.e + ("q" if self.ver >= 3 else "i"), v)

    def cnt(self, v):
        return struct.pack(self.e + ("q" if self.ver >= 4 else "i"), v)

    def kwd(self, code, data, count=None, info=b"", nextpos=None):
        head = struct.pack(self.e + "i", code)
        body = info + (self.cnt(count) if count is not None else b"")
        start = len(self.buf)
        nxt = start + len(head) + len(self.pos(0)) + len(body) + len(data)
        self.offsets[code] = (start, start + len(head) + len(self.pos(0)) + len(body))
        self.buf += head + self.pos(nxt if nextpos is None else nextpos) + body + data

    def real(self, v):
        return struct.pack(self.e + ("f" if self.ver == 1 else "d"), v)

    def int(self, v):
        return struct.pack(self.e + ("q" if self.ver >= 4 else "i"), v)

    def end(self):
        self.buf += struct.pack(self.e + "i", 54) + self.pos(0)
        return self.buf


def base2d_meshb(ver=2, tri=None, xs=None):
    m = Meshb(ver, 2)
    xs = xs or X2
    m.kwd(4, b"".join(m.real(p[0]) + m.real(p[1]) + m.int(0) for p in xs), len(xs))
    tri = tri or [c + [1] for c in T2]
    m.kwd(6, b"".join(b"".join(m.int(v + 1 if i < 3 else v) for i, v in enumerate(c))
                      for c in tri), len(tri))
    m.kwd(5, b"".join(m.int(f[0] + 1) + m.int(f[1] + 1) + m.int(r) for f, r in B2), len(B2))
    return m


m = base2d_meshb()
full = m.end()
tri_start, tri_data = m.offsets[6]
cut = tri_data + 3 * 16 + 6                   # inside the 4th triangle
put("medit_truncated.meshb", full[:cut], "byte %d" % tri_start)
put("medit_truncated_end.meshb", full[:-8], "no End keyword")

m = Meshb(2, 2)
m.kwd(4, b"".join(m.real(p[0]) + m.real(p[1]) + m.int(0) for p in X2), len(X2))
m.kwd(5, b"", 2000000000)                     # a corrupt count, no data
put("medit_huge_count.meshb", m.end(), "count 2000000000")

m = Meshb(4, 2)
m.kwd(4, b"", 1 << 40)
put("medit_huge_count_v4.meshb", m.end(), "too large")

m = Meshb(2, 2)
m.kwd(4, b"", -1)
put("medit_negative_count.meshb", m.end(), "negative count")

put("medit_bad_code.meshb", struct.pack("<ii", 7, 2) + full[8:], "code word")
put("medit_bad_version.meshb", struct.pack("<ii", 1, 9) + full[8:], "version 9")
put("medit_short.meshb", full[:6], "byte 0")

m = Meshb(2, 2)
m.kwd(4, b"".join(m.real(p[0]) + m.real(p[1]) + m.int(0) for p in X2), len(X2),
      nextpos=1 << 30)
put("medit_bad_nextpos.meshb", m.end(), "next keyword position")

m = Meshb(2, 2)
m.kwd(4, b"".join(m.real(p[0]) + m.real(p[1]) + m.int(0) for p in X2), len(X2),
      nextpos=8)                              # points backwards: a loop
put("medit_backward_nextpos.meshb", m.end(), "next keyword position")

bad = [c + [1] for c in T2]
bad[2] = [0, 1, 49, 1]                        # stored + 1: index 50
m = base2d_meshb(tri=bad)
put("medit_index_range.meshb", m.end(), "byte %d" % (m.offsets[6][1] + 2 * 16))

xs = list(X2)
xs[5] = (float("nan"), 0.5)
m = base2d_meshb(xs=xs)
put("medit_nan.meshb", m.end(), "byte %d" % (m.offsets[4][1] + 5 * 20))

m = base2d_meshb(ver=1)
m.kwd(8, b"", 1)                              # Tetrahedra in 2D
put("medit_tet_in_2d.meshb", m.end(), "Tetrahedra in a mesh of Dimension 2")

m = Meshb(2, 2, with_dim=False)                # vertices, no Dimension
m.kwd(4, b"".join(m.real(p[0]) + m.real(p[1]) + m.int(0) for p in X2), len(X2))
put("medit_no_dimension.meshb", m.end(), "missing Dimension")

# ------------------------------------------------------------- .sol and .solb


def sol_text(dim, n, types, rows, header_extra=""):
    lines = ["MeshVersionFormatted 2", "", "Dimension %d" % dim, "",
             "SolAtVertices", str(n), " ".join([str(len(types))] + [str(t) for t in types])]
    lines += [" ".join("%.17g" % v for v in r) for r in rows]
    lines += ["", "End", ""]
    return header_extra + "\n".join(lines)


def sol_first_row_line(text):
    return line_of(text, "SolAtVertices") + 3


iso = [[0.2]] * nv
t = sol_text(2, nv, [1], iso[:-1])
put("sol_short.sol", t, ":%d:" % line_of(t, "End"))

put("sol_count.sol", sol_text(2, 5, [1], iso[:5]), "sol_count.sol:5: 5 vertices in the solution")

rows = [[1.0, 0.0, 1.0]] * nv
rows = rows[:2] + [[1.0, 2.0, 1.0]] + rows[3:]      # indefinite at vertex 3
put("sol_nonspd.sol", sol_text(2, nv, [3], rows), "vertex 3")

rows = iso[:2] + [[float("nan")]] + iso[3:]
put("sol_nan.sol", sol_text(2, nv, [1], rows).replace("nan", "NaN"), "vertex 3")

rows = iso[:3] + [[-0.1]] + iso[4:]
put("sol_negative_size.sol", sol_text(2, nv, [1], rows), "vertex 4")

rows = [[0.5, 0.5]] * nv
put("sol_vector.sol", sol_text(2, nv, [2], rows), "vector")

t = sol_text(2, nv, [7], iso)
put("sol_bad_type.sol", t, "solution type 7")

put("sol_no_solution.sol", "MeshVersionFormatted 2\nDimension 2\nEnd\n",
    "no SolAtVertices")

t = sol_text(2, nv, [1], iso).replace("Dimension 2\n", "")
put("sol_no_dimension.sol", t, "missing Dimension")

t = sol_text(2, nv, [1], [[0.2]] * nv).split("\n")
first = sol_first_row_line("\n".join(t))
t[first - 1 + 4] = "0.2x"
put("sol_nonnumeric.sol", "\n".join(t), ":%d:" % (first + 4))

nv3 = len(X3)
rows = [[1, 0, 1, 0, 0, 1]] * nv3
rows = rows[:4] + [[1, 0, 1, 0, 0, -1]] + rows[5:]
put("sol_3d_nonspd.sol", sol_text(3, nv3, [3], rows), "vertex 5")

rows = [[1, 0, 1]] * nv3
put("sol_3d_dim2.sol", sol_text(2, nv3, [3], rows), "a solution of Dimension 2 for a 3D mesh")

# sizes of another Dimension than the mesh's (Mmg: "BAD SOL DIMENSION")
put("sol_3d_dim2_size.sol", sol_text(2, nv3, [1], [[0.2]] * nv3),
    "a solution of Dimension 2 for a 3D mesh")
put("sol_dim3_size.sol", sol_text(3, nv, [1], iso),
    "a solution of Dimension 3 for a 2D mesh (its file has Dimension 2)")

# two solutions given as the metric (Mmg: "SEVERAL SOLUTIONS FOUND")
put("sol_two_fields.sol", sol_text(2, nv, [1, 1], [[0.2, 0.3]] * nv),
    "holds 2 solutions, not one")


def solb(ver, dim, n, types, rows, count=None, cut=None):
    m = Meshb(ver, dim)
    data = b"".join(b"".join(m.real(v) for v in r) for r in rows)
    typ = struct.pack("<i", len(types)) + b"".join(struct.pack("<i", t) for t in types)
    # SolAtVertices: count, then the types, then the data.
    head = struct.pack("<i", 62)
    start = len(m.buf)
    body = m.cnt(n if count is None else count) + typ
    nxt = start + 4 + len(m.pos(0)) + len(body) + len(data)
    m.buf += head + m.pos(nxt) + body + data
    m.offsets[62] = (start, start + 4 + len(m.pos(0)) + len(body))
    buf = m.end()
    return m, (buf if cut is None else buf[:cut])


m, buf = solb(2, 2, nv, [1], iso)
put("sol_truncated.solb", buf[:m.offsets[62][1] + 3 * 8 + 4],
    "next keyword position")
m, buf = solb(2, 2, nv, [1], [], count=2147483647)
put("sol_huge_count.solb", buf, "count 2147483647")
m, buf = solb(3, 3, 7, [1], [[0.1]] * 7)
put("sol_3d_count.solb", buf, "sol_3d_count.solb: byte 24: 7 vertices in the solution")
m, buf = solb(2, 2, nv, [4], [[1, 0, 0, 1]] * nv)
put("sol_full_matrix.solb", buf, "type 4")
rows = [[0.2]] * nv
rows[6] = [0.0]
m, buf = solb(1, 2, nv, [1], rows)
put("sol_zero_size_v1.solb", buf, "vertex 7")

with open(os.path.join(HERE, "medit.expected"), "w") as f:
    for name, frag in expected:
        f.write("%s\t%s\n" % (name, frag))
print("%d malformed files" % len(expected))
